"""QuasiStatic benchmark (run on demand, not a test): Peridigm's ``bar_qs_lps.yaml`` deck
(40 x 10 x 10 PdQuickGrid bar, Elastic LPS, 4 load steps; Peridigm: 61 s, 1.01 GiB, 17.1 M
tangent nonzeros on this machine type; see ../shared/benchmarks/README.md).

For each linear solver it prints, from a fresh process (so the peak memory is the run's own):
whole-run wall time (set-up, numba cache loading and output included), the solver's wall time,
tangent allocation and assembly time, linear-solve time (and set-up, for Direct/AMG), Newton and
Krylov iteration counts, tangent nonzeros and peak resident memory.

    python benchmarks/quasistatic.py                       # Peridigm's CG (the deck as is)
    python benchmarks/quasistatic.py --solvers Belos AMG Direct
    python benchmarks/quasistatic.py --deck path/to/deck.yaml
    python benchmarks/quasistatic.py --np 2                # on 2 MPI ranks (times: rank 0's;
                                                           # nonzeros: summed; memory: per rank)
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

DEFAULT_DECK = Path(__file__).resolve().parents[2] / "shared" / "benchmarks" / "bar_qs_lps.yaml"


def child(deck_path: str, linear_solver: str, out_dir: str) -> dict:
    wall0 = time.perf_counter()
    from peridyn.cli import _single_threaded_blas

    _single_threaded_blas()  # what `peridyn run` sets up (threads per rank under MPI)
    from peridyn.deck.model import load_deck
    from peridyn.engine.run_services import RunServices
    from peridyn.engine.session import run_section
    from peridyn.engine.simulation import Simulation
    from peridyn.parallel.comm import get_comm

    deck = load_deck(deck_path)
    comm = get_comm()
    sim = Simulation(deck, comm=comm, output_dir=out_dir)
    setup = time.perf_counter() - wall0
    state = None
    run = RunServices.of(sim)
    try:
        for entry in deck.solvers:
            params = entry.params
            sub = getattr(params, "quasi_static", None)
            if sub is not None and linear_solver != "Belos":
                params = params.model_copy(update={"quasi_static": sub.model_copy(update={"linear_solver": linear_solver})})
            state = run_section(sim, entry.cls(params, section=entry.section), state, run)
    finally:
        run.close()
    st = next(s for s in sim.stats["solvers"] if s["method"] == "QuasiStatic")
    return {
        "linear_solver": st["linear_solver"],
        "wall": time.perf_counter() - wall0,
        "setup": setup,
        "solver_wall": st["wall"],
        "tangent_allocation": st["tangent_allocation_time"],
        "tangent_assembly": st["tangent_assembly_time"],
        "tangent_assemblies": st["tangent_assemblies"],
        "linear_solve": st["linear_solve_time"],
        "linear_setup": st["linear_setup_time"],
        "linear_iterations": st["linear_iterations"],
        "newton_iterations": st["nonlinear_iterations"],
        "force_evaluations": st["force_evaluations"],
        "tangent_nonzeros": comm.allreduce_sum(int(st["tangent_nonzeros"])),
        "tangent_bytes": comm.allreduce_sum(int(st["tangent_bytes"])),
        "ranks": comm.size,
        "rank": comm.rank,
        "load_steps": st["steps"],
        "converged": st["converged"],
        "peak_rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--deck", default=str(DEFAULT_DECK))
    ap.add_argument("--solvers", nargs="+", default=["Belos"], choices=["Belos", "Direct", "AMG", "Auto"])
    ap.add_argument("--np", type=int, default=1, help="MPI ranks (mpiexec from mpi4py/mpich)")
    ap.add_argument("--child", nargs=2, metavar=("SOLVER", "OUTDIR"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        r = child(args.deck, *args.child)
        if r["rank"] == 0:
            print(json.dumps(r))
        return 0
    print(f"deck: {args.deck}, {args.np} rank(s)")
    launcher = []
    if args.np > 1:
        from peridyn.testing.mpi import MPIEXEC

        launcher = [MPIEXEC, "-n", str(args.np)]
    for solver in args.solvers:
        with tempfile.TemporaryDirectory() as out:
            p = subprocess.run(
                [*launcher, sys.executable, __file__, "--deck", args.deck, "--child", solver, out], capture_output=True, text=True
            )
        if p.returncode != 0:
            print(f"{solver}: failed\n{p.stderr}")
            continue
        r = json.loads(p.stdout.strip().splitlines()[-1])
        print(
            f"{r['linear_solver']:>6}: wall {r['wall']:6.1f} s (set-up {r['setup']:.1f} s, QuasiStatic {r['solver_wall']:.1f} s); "
            f"tangent: allocation {r['tangent_allocation']:.2f} s, assembly {r['tangent_assembly']:.2f} s "
            f"({r['tangent_assemblies']} builds, {r['tangent_nonzeros'] / 1e6:.1f} M nonzeros, "
            f"{r['tangent_bytes'] / max(r['tangent_nonzeros'], 1):.2f} bytes each); "
            f"linear solves {r['linear_solve']:.2f} s (+ set-up {r['linear_setup']:.2f} s, {r['linear_iterations']} iterations); "
            f"{r['newton_iterations']} Newton iterations, {r['force_evaluations']} force evaluations, "
            f"{r['load_steps']} load steps{'' if r['converged'] else ' (NOT converged)'}; peak memory {r['peak_rss'] / 2**30:.2f} GiB"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
