"""Static (Guyan) condensation on the tensile test (run on demand, not a test): QuasiStatic on the
straight tensile bar of ``peridyn.testing.tensile`` (the set-up of Peridigm's tensile example:
grips two horizons long pulled by ``y*0.005*t``, ``Elastic`` LPS, K = 160 GPa, G = 80 GPa, horizon
1 mm, one load step, relative tolerance 1e-8), solved four ways:

* ``direct``: the full system, ``Linear Solver: Direct`` (sparse LU: the exact solve the
  condensation reproduces);
* ``adaptive``: the full system, the default linear solver (Peridigm's CG, then AMG-CG);
* ``grips``: ``Model Reduction`` condensing the grips (``block_1 block_3``) onto the gauge section;
* ``gauge``: ``Model Reduction`` condensing the gauge section (``block_2``) onto the grips.

Each run is a fresh process on one thread (``NUMBA_NUM_THREADS=1``); the configurations take
turns (A B C D, A B C D, ...) so that a slow spell of a shared machine hits them alike, and
the ratios against ``direct`` are formed run by run. Figures: the process wall time (set-up,
numba cache loading and output included) and CPU time (user + system: less disturbed than the
wall time by other work on a shared machine), the solver's wall time, and the solve-only time
(factorizations, condensations and solves of the linear systems: ``linear_setup_time +
linear_solve_time``), medians over the runs with their min-max; and the largest difference of
the displacement field from ``direct``'s, relative to its largest displacement.

    python benchmarks/guyan.py                 # ratio 3.015 (1,274 points), 3 rounds (about 2 minutes)
    python benchmarks/guyan.py --ratio 3.015 --rounds 5 --configs direct grips
    NUMBA_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/guyan.py --pieces   # where the time goes
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from peridyn.engine.session import run_sections

K, MU = 160.0e9, 80.0e9
MATERIAL = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": MU}
REGIONS = {"grips": "block_1 block_3", "gauge": "block_2"}
CONFIGS = ("direct", "adaptive", "grips", "gauge")


def solver_section(config: str) -> dict:
    q = {"Number of Load Steps": 1, "Relative Tolerance": 1.0e-8, "Maximum Solver Iterations": 10}
    if config == "direct":
        q["Linear Solver"] = "Direct"
    elif config in REGIONS:
        q["Model Reduction"] = {"Type": "Static Condensation", "Reduction Blocks": REGIONS[config]}
    return {"Initial Time": 0.0, "Final Time": 1.0, "QuasiStatic": q}


def child(config: str, ratio: float, directory: str) -> dict:
    import numpy as np

    from peridyn.testing import build_simulation
    from peridyn.testing.tensile import tensile_bar

    bar = tensile_bar(MATERIAL, directory, ratio=ratio, horizon=1.0e-3, section=2.0, solver=solver_section(config))
    sim = build_simulation(bar.tree, directory=directory)
    run_sections(sim)
    st = sim.stats["solvers"][-1]
    np.save(Path(directory) / "u.npy", sim.fields["Displacement"][: sim.num_owned])
    return {
        "points": bar.num_points, "unknowns": 3 * bar.num_points, "solver_wall": st["wall"], "converged": st["converged"],
        "solve_only": st["linear_setup_time"] + st["linear_solve_time"], "newton": st["nonlinear_iterations"],
        "tangent_assembly": st["tangent_assembly_time"], "E": bar.youngs_modulus(sim), "reduction": st.get("model_reduction"),
    }


def pieces(ratio: float) -> None:
    """Times the pieces of one condensation against sparse LUs of the full system, on the
    tangent of the first Newton step (in this process, one thread; the least of 5 timings each)."""
    import numpy as np
    import scipy.sparse.linalg as spla

    from peridyn.solvers.linalg.guyan import StaticCondensation
    from peridyn.solvers.linalg.linear import LU_ORDERING
    from peridyn.solvers.implicit.problem import ImplicitProblem
    from peridyn.testing import build_simulation
    from peridyn.testing.tensile import tensile_bar

    def timed(f, repeat: int = 5):
        """f() and the least of ``repeat`` timings of it (the run least disturbed by other work)."""
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            out = f()
            times.append(time.perf_counter() - t0)
        return out, min(times)

    with tempfile.TemporaryDirectory() as d:
        sim = build_simulation(tensile_bar(MATERIAL, d, ratio=ratio, horizon=1.0e-3, section=2.0).tree, directory=d)
        sim.apply_kinematic(1.0, 0.0)
        prob = ImplicitProblem(sim)
        T = prob.assemble_tangent()
        T.apply_kinematic_bc(prob.fixed_rows)
        T.scale(-1.0)
        A = T.to_scipy().tocsr()
        free = ~prob.fixed_flat
        A_f = A[free][:, free]
        _, t_all = timed(lambda: spla.splu(A.tocsc(), permc_spec=LU_ORDERING))
        _, t_free = timed(lambda: spla.splu(A_f.tocsc(), permc_spec=LU_ORDERING))
        print(f"sparse LU: all {A.shape[0]} unknowns {t_all:.2f} s, the {A_f.shape[0]} free ones {t_free:.2f} s")
        n = sim.num_owned
        for config, names in REGIONS.items():
            region = np.zeros(n, dtype=bool)
            for blk in sim.blocks:
                if blk.name in names.split():
                    region[blk.start : blk.stop] = True
            masters = ~np.repeat(region[T.local_of_row[:n]], 3)[free]
            A_ss = A_f[~masters][:, ~masters].tocsc()
            _, t_ss = timed(lambda: spla.splu(A_ss, permc_spec=LU_ORDERING))
            cond, t_cond = timed(lambda: StaticCondensation(A_f, masters))
            z = cond.sizes
            print(f"{config}: {z.slaves} slaves, {z.masters} masters, {z.interface_columns} interface masters; "
                  f"sparse LU of A_ss {t_ss:.2f} s; the whole condensation {t_cond:.2f} s")


def run_one(config: str, ratio: float) -> dict:
    with tempfile.TemporaryDirectory() as d:
        env = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
        t0 = time.perf_counter()
        cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        out = subprocess.run([sys.executable, __file__, "--child", config, "--ratio", str(ratio), "--dir", d],
                             capture_output=True, text=True, env=env, check=True)
        wall = time.perf_counter() - t0
        cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        import numpy as np

        res = json.loads(out.stdout.strip().splitlines()[-1])
        res["process_wall"] = wall
        res["process_cpu"] = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
        res["u"] = np.load(Path(d) / "u.npy")
        return res


def spread(values: list[float]) -> str:
    return f"{statistics.median(values):.3g} ({min(values):.3g}-{max(values):.3g})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ratio", type=float, default=3.015, help="horizon / spacing of the bar")
    ap.add_argument("--rounds", type=int, default=3, help="runs of each configuration")
    ap.add_argument("--configs", nargs="+", default=list(CONFIGS), choices=CONFIGS)
    ap.add_argument("--pieces", action="store_true", help="time the pieces of one condensation in this process instead")
    ap.add_argument("--child", choices=CONFIGS, help=argparse.SUPPRESS)
    ap.add_argument("--dir", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.child, args.ratio, args.dir)))
        return
    if args.pieces:
        pieces(args.ratio)
        return
    import numpy as np

    configs = ["direct"] + [c for c in args.configs if c != "direct"]
    runs: dict[str, list[dict]] = {c: [] for c in configs}
    for k in range(args.rounds):
        for c in configs:
            r = run_one(c, args.ratio)
            runs[c].append(r)
            print(f"round {k + 1} {c}: process {r['process_wall']:.2f} s, solver {r['solver_wall']:.2f} s, solve-only {r['solve_only']:.2f} s",
                  file=sys.stderr)
    first = runs["direct"][0]
    print(f"tensile bar, ratio {args.ratio}: {first['points']} points, {first['unknowns']} unknowns, one thread, {args.rounds} rounds\n")
    print("| configuration | process wall (s) | process CPU (s) | solver wall (s) | solve-only (s) | CPU / direct | solver / direct | solve-only / direct "
          "| Newton its | max \\|u - u_direct\\| / max \\|u\\| | E (GPa) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    u_ref = first["u"]
    for c in configs:
        rs = runs[c]
        ratio_solver = [r["solver_wall"] / d["solver_wall"] for r, d in zip(rs, runs["direct"])]
        ratio_solve = [r["solve_only"] / d["solve_only"] for r, d in zip(rs, runs["direct"])]
        ratio_cpu = [r["process_cpu"] / d["process_cpu"] for r, d in zip(rs, runs["direct"])]
        diff = max(float(np.abs(r["u"] - u_ref).max() / np.abs(u_ref).max()) for r in rs)
        print(f"| {c} | {spread([r['process_wall'] for r in rs])} | {spread([r['process_cpu'] for r in rs])} | {spread([r['solver_wall'] for r in rs])} "
              f"| {spread([r['solve_only'] for r in rs])} | {spread(ratio_cpu)} | {spread(ratio_solver)} | {spread(ratio_solve)} | {rs[0]['newton']} | {diff:.1e} | {rs[0]['E'] / 1e9:.4f} |")
    for c in configs:
        if runs[c][0]["reduction"]:
            print(f"\n{c}: {runs[c][0]['reduction']}")


if __name__ == "__main__":
    main()
