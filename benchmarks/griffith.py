"""Crack initiation against Griffith, and J against K_I^2/E, by resolution (run on demand, not a
test): the centre-cracked plane-stress plate of tests/verification/test_griffith.py (height
2 x width, a/b = 0.4) with ``Critical Energy`` damage, for m = delta/dx and delta/a.

Per row: points; sigma_init / sigma_Griffith (first bond breaking at a tip, from the static
solution at a quarter of the load: the model is linear until then); J_init / G0 (the
``J_Integral`` ring a/3 < r < 5a/6 around the right tip, scaled to the initiation load);
J / (K_I^2/E) (Tada's K_I with the measured mean end stress); wall time of set-up plus solve.

Second study (``--kfield``): the boundary-layer problem of tests/verification/test_j_integral.py
(Williams' K field prescribed on a one-horizon layer of a square of side 20 delta, crack to its
centre), first-bond failure K_init against K_c = sqrt(E G0), by m = delta/dx; no finite-size
correction enters.

    python benchmarks/griffith.py            # m = 3, 4 and delta/a = 1/4, 1/6 (about 5 minutes)
    python benchmarks/griffith.py --quick    # m = 3, delta/a = 1/4 only
    python benchmarks/griffith.py --kfield   # the K-field study, m = 2 ... 6

Third study (``--growth M``): the plate of the first row (60 dx wide, a = 12 dx) with horizon
M dx loaded by QuasiStatic with the damage model on, in steps of 0.05 (then 0.025 from 0.9 for
m = 3, 0.7 for m = 4) of the end strain that gives about the Griffith stress: per step the mean
stress over sigma_Griffith, the broken bonds and the tip position. The run stops when a load step
finds no equilibrium (the crack runs). About 10 minutes.
"""
from __future__ import annotations

import argparse
import importlib.util
import math
import time
from pathlib import Path

import numpy as np

from peridyn.engine.run_services import RunServices
from peridyn.damage.critical_energy import bond_based_critical_stretch
from peridyn.testing.harness import build_simulation
from peridyn.engine.session import run_sections

HERE = Path(__file__).resolve().parent
_spec = importlib.util.spec_from_file_location("griffith_plate", HERE.parent / "tests" / "verification" / "test_griffith.py")
plate = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(plate)
_spec = importlib.util.spec_from_file_location("k_field", HERE.parent / "tests" / "verification" / "test_j_integral.py")
kfield = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(kfield)


def case(m: int, a_per_delta: int) -> dict:
    a_cells = m * a_per_delta
    n = 5 * a_cells  # width 2b = 5a: a/b = 0.4
    tree, g = plate.plate_deck(n=n, m=float(m), a_cells=a_cells, damage={"Damage Model": "Critical Energy", "Critical Energy": plate.G0})
    a, h, dx = g["a"], g["h"], plate.DX
    tree["Compute Class Parameters"] = {
        "J": {"Compute Class": "J_Integral", "Crack Tip X": a, "Crack Tip Y": 0.0, "Inner Radius": a / 3 + 0.5 * dx, "Outer Radius": 5 * a / 6 + 0.5 * dx, "Thickness": h}
    }
    t0 = time.perf_counter()
    sim = build_simulation(tree)
    run_sections(sim)
    seconds = time.perf_counter() - t0
    sigma = plate.mean_stress(sim, g)
    _, _, s = plate.bond_stretches(sim, g)
    factor = sim.blocks[0].damage.s_c / s.max()
    J = sim.outputs.computes["J"].value(sim)
    K = sigma * math.sqrt(math.pi * a) * plate.tada(a, g["W"] / 2)
    return {
        "m": m, "delta/a": f"1/{a_per_delta}", "points": sim.num_global,
        "sigma_init/griffith": factor * sigma / plate.griffith_stress(g),
        "J_init/G0": J * factor**2 / plate.G0,
        "J/(K^2/E)": J / (K**2 / plate.E),
        "seconds": seconds,
    }


def k_field_case(m: int) -> dict:
    n = 20 * m
    tree = kfield.k_field_deck(n=n, m=float(m))
    t0 = time.perf_counter()
    sim = build_simulation(tree)
    run_sections(sim)
    seconds = time.perf_counter() - t0
    g = {"H": n * plate.DX - 2 * math.ceil(m) * plate.DX}  # bonds between points off the prescribed layer
    x = sim.fields["Model_Coordinates"]
    nl, y = sim.bonds, sim.fields["Coordinates"]
    i = np.repeat(np.arange(sim.num_owned), np.diff(nl.offsets[: sim.num_owned + 1]))
    j = nl.neighbors[: i.size]
    L0 = sim.fields["Bond_Length"][: i.size]
    stretch = (np.linalg.norm(y[j] - y[i], axis=1) - L0) / L0
    free = np.max(np.abs(x[:, :2]), axis=1) < g["H"] / 2
    material = sim.blocks[0].material
    s0 = bond_based_critical_stretch(plate.G0, material.c, material.horizon, material.params.height)
    factor = s0 / stretch[free[i] & free[j]].max()  # no damage model: K_I may exceed K_c here
    Kc = math.sqrt(kfield.E * plate.G0)
    return {"m": m, "points": sim.num_global, "K_init/K_c": factor * kfield.K_I / Kc, "seconds": seconds}


def growth(m: int) -> None:
    """Crack growth under QuasiStatic load steps (see the module docstring)."""
    a_cells = 12
    tree, g = plate.plate_deck(n=60, m=float(m), a_cells=a_cells, damage={"Damage Model": "Critical Energy", "Critical Energy": plate.G0})
    sigma_G = plate.griffith_stress(g)
    eps1 = sigma_G / (0.9 * plate.E)  # t = 1: about the Griffith stress
    bcs = tree["Boundary Conditions"]
    for k, sign in (("TY", 1.0), ("BY", -1.0)):
        bcs[k]["Value"] = f"{sign * eps1 * g['H'] / 2!r}*t"
    for k in ("TX", "BX"):
        bcs[k]["Value"] = f"{-plate.NU * eps1!r}*x*t"
    fine = 0.9 if m == 3 else 0.7
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": fine,
                      "QuasiStatic": {"Number of Load Steps": round(fine / 0.05), "Relative Tolerance": 1e-10, "Linear Solver": "Direct"}}
    tree["Solver 2"] = {"Initial Time": fine, "Final Time": 1.3,
                        "QuasiStatic": {"Number of Load Steps": round((1.3 - fine) / 0.025), "Relative Tolerance": 1e-8, "Linear Solver": "Direct",
                                        "Maximum Solver Iterations": 40}}
    sim = build_simulation(tree)
    x = sim.fields["Model_Coordinates"]
    run = RunServices.of(sim)
    print(f"m = {m}: {sim.num_global} points")

    def record(t: float) -> None:
        run.write_output(t)
        sigma = plate.mean_stress(sim, g)
        broken = int(np.sum(sim.fields["Bond_Damage"]))
        if broken == 0 and t > 0:
            _, _, s = plate.bond_stretches(sim, g)
            print(f"  t = {t:.3f}  sigma/sigma_G = {sigma / sigma_G:.4f}  first-break prediction {sim.blocks[0].damage.s_c / s.max() * sigma / sigma_G:.4f}", flush=True)
            return
        damaged = sim.fields["Damage"][: sim.num_owned] > 0
        tip = np.max(np.abs(x[: sim.num_owned][damaged, 0])) / plate.DX if damaged.any() else a_cells
        print(f"  t = {t:.3f}  sigma/sigma_G = {sigma / sigma_G:.4f}  broken bonds {broken}  tip at {tip:.1f} dx (a = {a_cells} dx)", flush=True)

    from peridyn.solvers.implicit.quasistatic import LoadStepError

    try:
        run_sections(sim, run=RunServices.reading(record))
    except LoadStepError as exc:  # the load step in which the crack runs finds no equilibrium
        print(f"  stopped: {type(exc).__name__}: {str(exc)[:160]}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--kfield", action="store_true")
    parser.add_argument("--growth", type=int, choices=(3, 4), default=None)
    args = parser.parse_args()
    if args.growth is not None:
        growth(args.growth)
        return
    if args.kfield:
        print(f"{'m':>3s} {'points':>8s} {'K_init/K_c':>11s} {'seconds':>8s}")
        for m in (2, 3, 4, 5, 6):
            r = k_field_case(m)
            print(f"{r['m']:>3d} {r['points']:>8d} {r['K_init/K_c']:>11.4f} {r['seconds']:>8.1f}", flush=True)
        return
    cases = [(3, 4)] if args.quick else [(3, 4), (4, 4), (3, 6), (4, 6)]
    print(f"{'m':>3s} {'delta/a':>8s} {'points':>8s} {'sig_init/sig_G':>15s} {'J_init/G0':>10s} {'J/(K^2/E)':>10s} {'seconds':>8s}")
    for m, k in cases:
        r = case(m, k)
        print(f"{r['m']:>3d} {r['delta/a']:>8s} {r['points']:>8d} {r['sigma_init/griffith']:>15.4f} {r['J_init/G0']:>10.4f} {r['J/(K^2/E)']:>10.4f} {r['seconds']:>8.1f}", flush=True)


if __name__ == "__main__":
    main()
