"""Fatigue crack growth on a single-edge-notched plate against the Paris law (run on demand, not a
test; the tests are tests/verification/test_fatigue.py).

A plate of width W = 40 dx and height 2 W (bond-based, plane stress, one layer of points,
horizon 3 dx, E = 3 GPa) with an edge notch of a0 = 8 dx at mid-height, loaded in force control:
a body force on bands of 3 rows at the top and bottom edges gives the peak nominal stress sigma
(a uniform traction on the ends, free to rotate), R = 0.1; two corner points of the bottom edge
take the rigid-body modes (statically determinate: they carry no load). The Fatigue law:
phase I A1 = 1e4, m1 = 2 with a fatigue limit 2.5e-3 (the crack nucleates at the notch tip),
phase II A2 = 2e8, m2 = 4. QuasiStatic with the deck's ``Time Steps``: Delta N = 1 cycle a load
step to 450 cycles, 1/8 cycle from there (the crack accelerates), until the plate breaks in two.

The crack length a(N) is the notch tip's x plus the crack tip's advance: the largest x of the
points of the row above the crack line with Damage >= 0.3, plus dx/2 (the point's cell). Per
grid spacing the tip passes, da/dN = dx / (cycles between passes) at the mean a, and
Delta K = (1 - R) sigma sqrt(pi a) F(a/W) with Tada's single-edge-notch factor
F = 1.12 - 0.231 x + 10.55 x^2 - 21.72 x^3 + 30.39 x^4 (x = a/W <= 0.6; uniform end traction).
The least-squares slope of log da/dN against log Delta K is the Paris exponent M, to compare with
Silling & Askari's M = m2. Left out of the fit: the first two spacings after the notch
(nucleation, phase I), a/W > 0.6 (Tada's range), and rates resolved by fewer than 25 load steps
per spacing (a bond whose life runs out in a step is broken in the next one's solve, so a crack
can advance at most a few bonds a step: coarse steps cap the rate and flatten the curve).

    python benchmarks/fatigue.py             # several minutes; writes benchmarks/results/fatigue.md
"""
from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import numpy as np

from peridyn.engine.run_services import RunServices
from peridyn.io.exodus_reader import read_results
from peridyn.solvers.implicit.load_steps import LoadStepError
from peridyn.testing.harness import build_simulation, node_set_ids
from peridyn.engine.session import run_sections

DX = 1.0e-3
W_DX, A0_DX = 40, 8
E = 3.0e9
SIGMA = 2.5e6  # Pa: peak nominal stress
LAW = {"Load Ratio": 0.1, "Frequency": 1.0, "A1": 1.0e4, "m1": 2.0, "Fatigue Limit": 2.5e-3, "A2": 2.0e8, "m2": 4.0}
#: load steps, in cycles: 1 cycle each to 450, then 1/8 cycle (the crack accelerates) to 620
CYCLES = np.concatenate([np.arange(0.0, 450.0, 1.0), np.arange(450.0, 620.0 + 1e-9, 0.125)])
MIN_STEPS = 25  #: load steps per grid spacing of growth below which a rate is left out of the fit (too coarse)
RESULTS = Path(__file__).resolve().parent / "results" / "fatigue.md"


def tada_sent(x: float) -> float:
    """F(a/W) of the single-edge-notched plate in uniform tension (Tada, Paris & Irwin)."""
    return 1.12 - 0.231 * x + 10.55 * x**2 - 21.72 * x**3 + 30.39 * x**4


def plate_deck() -> dict:
    W, H, h = W_DX * DX, 2 * W_DX * DX, DX
    notch = {
        "Type": "Rectangular_Plane", "Normal_X": 0.0, "Normal_Y": 1.0, "Normal_Z": 0.0,
        "Lower_Left_Corner_X": -DX, "Lower_Left_Corner_Y": 0.0, "Lower_Left_Corner_Z": -h,
        "Bottom_Unit_Vector_X": 1.0, "Bottom_Unit_Vector_Y": 0.0, "Bottom_Unit_Vector_Z": 0.0,
        "Bottom_Length": (A0_DX + 1) * DX, "Side_Length": 3 * h,
    }
    tree = {
        "Discretization": {
            "Type": "Shapes",
            "Shapes": {"Plate": {"Shape": "Box", "Block": "block_1", "Min": [0.0, -H / 2, 0.0], "Max": [W, H / 2, h], "Spacing": DX}},
            "Bond Filters": {"Notch": notch},
        },
        "Materials": {"M": {"Material Model": "Elastic Bond Based", "Density": 1200.0, "Young's Modulus": E, "Plane Stress": True, "Height": h}},
        "Damage Models": {"F": {"Damage Model": "Fatigue", **LAW}},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Damage Model": "F", "Horizon": 3.0 * DX * (1 + 1e-9)}},
    }
    band = 3 * DX
    b = SIGMA / band  # body force density on a band of 3 rows: the end traction sigma
    tree["Boundary Conditions"] = {
        "Top Node Set": node_set_ids(tree, lambda x: x[:, 1] > H / 2 - band),
        "Bottom Node Set": node_set_ids(tree, lambda x: x[:, 1] < -H / 2 + band),
        "Corner Node Set": node_set_ids(tree, lambda x: (x[:, 1] < -H / 2 + DX) & (x[:, 0] < DX)),
        "Corners Node Set": node_set_ids(tree, lambda x: (x[:, 1] < -H / 2 + DX) & ((x[:, 0] < DX) | (x[:, 0] > W - DX))),
        "Pull Top": {"Type": "Body Force", "Node Set": "Top Node Set", "Coordinate": "y", "Value": repr(b)},
        "Pull Bottom": {"Type": "Body Force", "Node Set": "Bottom Node Set", "Coordinate": "y", "Value": repr(-b)},
        "Hold X": {"Type": "Prescribed Displacement", "Node Set": "Corner Node Set", "Coordinate": "x", "Value": "0.0"},
        "Hold Y": {"Type": "Prescribed Displacement", "Node Set": "Corners Node Set", "Coordinate": "y", "Value": "0.0"},
        "Plane": {"Type": "Prescribed Displacement", "Node Set": "Plate", "Coordinate": "z", "Value": "0.0"},
    }
    times = " ".join(repr(float(n) / LAW["Frequency"]) for n in CYCLES)
    tree["Solver"] = {"QuasiStatic": {"Time Steps": times, "Absolute Tolerance": 1e-7 * SIGMA * W * h,  # N: the supports carry no load
                                      "Linear Solver": "Direct", "Maximum Solver Iterations": 20}}
    tree["Output"] = {"Output Filename": "sent", "Output Frequency": 1, "Output Variables": {"Damage": True}}
    return tree


def main() -> None:
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        sim = build_simulation(plate_deck(), output_dir=tmp)
        n_points = sim.num_global
        run = RunServices.of(sim)
        try:
            run_sections(sim, run=run)
        except (LoadStepError, RuntimeError) as exc:  # the plate breaks in two (a singular tangent): the converged steps are kept
            print(f"stopped at t = {sim.clock.time:g}: {exc}")
        run.close(complete=True)
        r = read_results(Path(tmp) / "sent.e")
    wall = time.perf_counter() - t0
    x = r["coords"]
    row = np.abs(x[:, 1] - DX / 2) < 1e-9
    cycles = np.asarray(r["times"]) * LAW["Frequency"]
    tips = np.array([x[row & (d >= 0.3), 0].max() if np.any(row & (d >= 0.3)) else -1.0 for d in r["element"]["Damage"]])
    W, R = W_DX * DX, LAW["Load Ratio"]
    passes = []  # (a, cycles) when the crack length first reaches a
    for k in range(A0_DX + 1, W_DX):
        a = k * DX
        hit = np.nonzero(tips + DX / 2 >= a - 1e-12)[0]
        if len(hit):
            passes.append((a, float(cycles[hit[0]])))
    rows, fit_k, fit_r = [], [], []
    for (a1, n1), (a2, n2) in zip(passes, passes[1:]):
        if n2 <= n1:
            continue
        a = 0.5 * (a1 + a2)
        dK = (1 - R) * SIGMA * math.sqrt(math.pi * a) * tada_sent(a / W)
        rate = (a2 - a1) / (n2 - n1)
        steps = int(np.count_nonzero((cycles > n1) & (cycles <= n2)))
        used = a1 >= (A0_DX + 2) * DX and a2 / W <= 0.6 and steps >= MIN_STEPS
        rows.append((a / DX, a / W, n1, n2, steps, dK / 1e6, rate / DX, used))
        if used:
            fit_k.append(math.log(dK))
            fit_r.append(math.log(rate))
    M, logC = np.polyfit(fit_k, fit_r, 1) if len(fit_k) >= 2 else (float("nan"), float("nan"))
    lines = [
        "# Fatigue crack growth on a single-edge-notched plate (benchmarks/fatigue.py)",
        "",
        f"{n_points} points, W = {W_DX} dx, a0 = {A0_DX} dx, sigma = {SIGMA / 1e6:g} MPa, R = {R}, "
        f"{len(CYCLES) - 1} load steps to {CYCLES[-1]:g} cycles; m1 = {LAW['m1']}, fatigue limit {LAW['Fatigue Limit']}, m2 = {LAW['m2']}. Wall time {wall:.0f} s.",
        "",
        "| a (dx) | a/W | N at a - dx/2 | N at a + dx/2 | load steps | Delta K (MPa m^0.5) | da/dN (dx/cycle) | in fit |",
        "|---|---|---|---|---|---|---|---|",
    ]
    lines += [f"| {a:.1f} | {aw:.3f} | {n1:g} | {n2:g} | {k} | {dk:.3f} | {rate:.4g} | {'yes' if used else 'no'} |" for a, aw, n1, n2, k, dk, rate, used in rows]
    lines += ["", f"Fitted Paris exponent M = {M:.2f} against the model's m2 = {LAW['m2']:g} (Silling & Askari: M = m2).", ""]
    text = "\n".join(lines)
    print(text)
    RESULTS.write_text(text)


if __name__ == "__main__":
    main()
