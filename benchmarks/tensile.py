"""Tensile-test accuracy study (run on demand, not a test): Young's modulus error against the
horizon/spacing ratio and run time, on the straight bar of ``peridyn.testing.tensile``.

The set-up of Peridigm's tensile example (grips two horizons long pulled by ``y*0.005*t``,
``Block_Data`` reactions over ``Nearest_Point_Data`` gauge strain), with ``Elastic`` (LPS) at
K = 160 GPa, G = 80 GPa (E = 205.7 GPa), horizon 1 mm, one load step.

Two tables:

* the ratio sweep (3 to 8 spacings in the horizon; the 0.015 keeps lattice shells off the
  horizon) at a fixed section of about two horizons, the thickness of Peridigm's example;
* the section sweep at a ratio of 4.015, which separates the two errors of LPS on a lattice:
  the bulk lattice error (``lattice_youngs_modulus``, the infinitely wide bar) and the stiffer
  surface layer, proportional to horizon / width.

Each run is a fresh process (set-up and numba cache loading included in its wall time). The
solver is NOXQuasiStatic with matrix-free Newton-Krylov (the sparse tangent of LPS couples
points two horizons apart: beyond a few thousand points it does not fit in memory), or
``--solver QuasiStatic`` for Newton on the assembled tangent.

    python benchmarks/tensile.py                  # both tables (about 10 minutes on 2 cores)
    python benchmarks/tensile.py --ratios 3.015 4.015 --sections 2 4
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from peridyn.engine.run_services import RunServices
from peridyn.engine.session import run_sections

K, MU, HORIZON = 160.0e9, 80.0e9, 1.0e-3
E = 9.0 * K * MU / (3.0 * K + MU)
MATERIAL = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": MU}


def solver_section(name: str) -> dict:
    if name == "QuasiStatic":
        return {"Initial Time": 0.0, "Final Time": 1.0,
                "QuasiStatic": {"Number of Load Steps": 1, "Relative Tolerance": 1.0e-8, "Maximum Solver Iterations": 10}}
    return {
        "Initial Time": 0.0, "Final Time": 1.0, "Peridigm Preconditioner": "None",
        "NOXQuasiStatic": {
            "Nonlinear Solver": "Line Search Based", "Number of Load Steps": 1, "Max Solver Iterations": 10,
            "Relative Tolerance": 1.0e-8, "Line Search": {"Method": "Full Step"},
            "Direction": {"Method": "Newton", "Newton": {"Linear Solver": {"Jacobian Operator": "Matrix-Free", "Preconditioner": "None"}}},
        },
    }


def child(ratio: float, section: float, solver: str, directory: str) -> dict:
    wall0 = time.perf_counter()
    from peridyn.testing import build_simulation
    from peridyn.testing.tensile import lattice_youngs_modulus, tensile_bar

    bar = tensile_bar(MATERIAL, directory, ratio=ratio, horizon=HORIZON, section=section, solver=solver_section(solver))
    sim = build_simulation(bar.tree, directory=directory)
    run = RunServices.of(sim)
    run_sections(sim, run=run)
    run.close()
    st = sim.stats["solvers"][-1]
    modulus = bar.youngs_modulus(sim)
    return {
        "ratio": ratio, "section": bar.points_across * bar.spacing / HORIZON, "points": bar.num_points,
        "bonds": int(sim.bonds.num_bonds), "E": modulus, "lattice_E": lattice_youngs_modulus(K, MU, ratio),
        "wall": time.perf_counter() - wall0, "newton": st.get("nonlinear_iterations"), "krylov": st.get("linear_iterations"),
        "force_evaluations": st.get("force_evaluations"), "peak_rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
    }


def run(ratio: float, section: float, solver: str) -> dict | None:
    with tempfile.TemporaryDirectory() as out:
        p = subprocess.run([sys.executable, __file__, "--child", repr(ratio), repr(section), solver, out], capture_output=True, text=True)
    if p.returncode != 0:
        print(f"ratio {ratio} section {section}: failed\n{p.stderr[-2000:]}")
        return None
    return json.loads(p.stdout.strip().splitlines()[-1])


HEADER = (f"{'ratio':>6} {'width/horizon':>13} {'points':>7} {'bonds':>10} {'E (GPa)':>8} {'error':>8} "
          f"{'lattice':>8} {'surface':>8} {'Newton':>6} {'Krylov':>6} {'wall (s)':>8} {'memory':>9}")


def row(r: dict) -> str:
    return (f"{r['ratio']:>6.3f} {r['section']:>13.2f} {r['points']:>7d} {r['bonds']:>10d} {r['E'] / 1e9:>8.2f} "
            f"{100 * (r['E'] / E - 1):>+7.2f}% {100 * (r['lattice_E'] / E - 1):>+7.2f}% {100 * (r['E'] / r['lattice_E'] - 1):>+7.2f}% "
            f"{r['newton']!s:>6} {r['krylov']!s:>6} {r['wall']:>8.1f} {r['peak_rss'] / 2**20:>6.0f} MiB")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ratios", nargs="*", type=float, default=[3.015, 4.015, 5.015, 6.015, 7.015, 8.015])
    ap.add_argument("--sections", nargs="*", type=float, default=[2.0, 4.0, 8.0], help="widths in horizons at ratio 4.015")
    ap.add_argument("--solver", default="NOXQuasiStatic", choices=["NOXQuasiStatic", "QuasiStatic"])
    ap.add_argument("--child", nargs=4, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        ratio, section, solver, out = args.child
        print(json.dumps(child(float(ratio), float(section), solver, out)))
        return 0
    print(f"Elastic (LPS), E = {E / 1e9:.2f} GPa; error = bar vs E, lattice = infinite lattice vs E, surface = bar vs lattice")
    if args.ratios:
        print(f"\nratio sweep, section of two horizons, {args.solver}\n{HEADER}")
        for ratio in args.ratios:
            r = run(ratio, 2.0, args.solver)
            if r:
                print(row(r), flush=True)
    if args.sections:
        print(f"\nsection sweep at ratio 4.015, {args.solver}\n{HEADER}")
        results = [r for r in (run(4.015, s, args.solver) for s in args.sections) if r]
        for r in results:
            print(row(r), flush=True)
        if len(results) >= 2:
            # E(W) = E_inf + a / W through the two widest bars
            (w1, e1), (w2, e2) = sorted((r["section"], r["E"]) for r in results)[-2:]
            a = (e1 - e2) / (1.0 / w1 - 1.0 / w2)
            e_inf = e2 - a / w2
            lat = results[0]["lattice_E"]
            print(f"fit E(W) = E_inf + a/W: E_inf = {e_inf / 1e9:.2f} GPa ({100 * (e_inf / E - 1):+.2f}% of E, "
                  f"{100 * (e_inf / lat - 1):+.2f}% of the lattice's), surface term a/E_inf = {a / e_inf:.3f} horizons")
    return 0


if __name__ == "__main__":
    sys.exit(main())
