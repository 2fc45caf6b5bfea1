"""Error against run time for the verification problems (run on demand, not a test).

1. Space: a bond-based bar under u = A sin(k x); force density against the exact peridynamic
   integral (tests/verification/test_convergence.py), for delta/h = 3.5 ... 63.5.
2. Time: velocity Verlet on a small LPS cube with a smooth shear; displacement against a run
   with a 64x smaller step, for 16 ... 256 steps.
3. Elastic wave speed in a bar against the analytic bar and P-wave speeds, by resolution.
4. Time, implicit: Newmark (trapezoidal rule and the damped beta = 0.3025, gamma = 0.6) on the
   free vibration of a small LPS cube; displacement against a 32x smaller step, with the Newton
   iterations' wall time.

The tensile test (Young's modulus against horizon/spacing ratio and section, with run time) is
benchmarks/tensile.py.

Prints, per problem and resolution, the error and the wall time, and the fitted rate.
"""
from __future__ import annotations

import time

import numpy as np
from scipy.special import sici

from peridyn.engine.run_services import RunServices
from peridyn.solvers.explicit.verlet import Verlet, VerletSection
from peridyn.testing import build_simulation, cube_deck
from peridyn.engine.session import run_section, run_sections

K = 1.0e9


def space() -> None:
    delta, length = 1.0, 12.0
    k = 2 * np.pi / length
    A = 1e-4
    c = 18 * K / (np.pi * delta**4)
    cin = 0.5772156649015329 + np.log(k * delta) - sici(k * delta)[1]
    print("space: bond-based bar, force density vs exact nonlocal integral")
    print(f"{'delta/h':>8s} {'points':>8s} {'rel. error':>11s} {'set-up s':>9s} {'force s':>9s}")
    rows = []
    for m in (3, 7, 15, 31, 63):
        h = delta / (m + 0.5)
        n = int(round(length / h))
        tree = cube_deck({"Material Model": "Elastic Bond Based", "Density": 1000.0, "Bulk Modulus": K}, n=1)
        tree["Discretization"]["TensorProduct3DMeshGenerator"].update({"X Length": n * h, "Number Points X": n, "Y Length": 1.0, "Z Length": 1.0})
        tree["Blocks"]["B"]["Horizon"] = delta
        t0 = time.perf_counter()
        sim = build_simulation(tree)
        t1 = time.perf_counter()
        x = sim.fields["Model_Coordinates"][:, 0]
        sim.fields["Coordinates"][:, 0] = x + A * np.sin(k * x)
        sim.evaluate_forces()
        t2 = time.perf_counter()
        f = sim.evaluate_forces()[:, 0]
        t3 = time.perf_counter()
        inside = (x > delta) & (x < length - delta)
        exact = -2 * c * A * np.sin(k * x) * cin
        err = np.abs(f[inside] - exact[inside]).max() / np.abs(exact).max()
        rows.append((h, err))
        print(f"{m + 0.5:8.1f} {n:8d} {err:11.3e} {t1 - t0:9.3f} {t3 - t2:9.5f}")
    hs, es = np.array(rows).T
    print(f"  fitted rate {np.polyfit(np.log(hs), np.log(es), 1)[0]:.2f} (expected 2)")


def timing() -> None:
    def run(dt: float) -> tuple[np.ndarray, float]:
        sim = build_simulation(cube_deck({"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": K, "Shear Modulus": 0.6 * K}, n=6))
        x = sim.fields["Model_Coordinates"]
        sim.fields["Velocity"][:, 0] = np.sin(np.pi * x[:, 1] / 6.0)
        section = VerletSection.model_validate({"Initial Time": 0.0, "Final Time": 2e-4 * (1 + 1e-12), "Verlet": {"Fixed dt": dt}})
        t0 = time.perf_counter()
        run_section(sim, Verlet(section))
        return sim.fields["Displacement"].copy(), time.perf_counter() - t0

    ref, _ = run(2e-4 / 16384)
    print("time: velocity Verlet, LPS cube, displacement vs a 64x finer step")
    print(f"{'steps':>8s} {'abs. error':>11s} {'wall s':>9s}")
    rows = []
    for steps in (16, 32, 64, 128, 256):
        u, wall = run(2e-4 / steps)
        err = np.abs(u - ref).max()
        rows.append((2e-4 / steps, err))
        print(f"{steps:8d} {err:11.3e} {wall:9.3f}")
    dts, es = np.array(rows).T
    print(f"  fitted rate {np.polyfit(np.log(dts), np.log(es), 1)[0]:.2f} (expected 2)")


def wave() -> None:
    import tempfile

    from peridyn.io.exodus_reader import read_results

    E, rho, nu = 200.0e9, 7800.0, 0.29
    bar, p_wave = np.sqrt(E / rho), np.sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho)
    print(f"wave: arrival of a struck-end pulse at mid-length of a 0.1 m bar, 5 x 5 points across")
    print(f"      (bar speed {bar:.0f} m/s, P-wave {p_wave:.0f} m/s; a thin bar lies between)")
    print(f"{'points x':>9s} {'speed m/s':>10s} {'wall s':>9s}")
    for nx in (50, 100, 200):
        h = 0.1 / nx
        tree = cube_deck({"Material Model": "Elastic", "Density": rho, "Young's Modulus": E, "Poisson's Ratio": nu}, n=1, spacing=h)
        tree["Discretization"]["TensorProduct3DMeshGenerator"].update(
            {"X Length": 0.1, "Number Points X": nx, "Y Length": 5 * h, "Z Length": 5 * h, "Number Points Y": 5, "Number Points Z": 5}
        )
        end = " ".join(str(i + j * nx + k * nx * 5 + 1) for k in range(5) for j in range(5) for i in range(3))
        tree["Boundary Conditions"] = {"End Node Set": end, "Strike": {"Type": "Initial Velocity", "Node Set": "End Node Set", "Coordinate": "x", "Value": "10.0"}}
        tree["Compute Class Parameters"] = {"Mid": {"Compute Class": "Nearest_Point_Data", "X": 0.05, "Y": 2.5 * h, "Z": 2.5 * h, "Variable": "Velocity", "Output Label": "Mid"}}
        tree["Output"] = {"Output Filename": "wave", "Output Frequency": 1, "Output Variables": {"Mid": True}}
        tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.5e-5, "Verlet": {"Safety Factor": 0.8}}
        with tempfile.TemporaryDirectory() as tmp:
            sim = build_simulation(tree, output_dir=tmp)
            t0 = time.perf_counter()
            run = RunServices.of(sim)
            run_section(sim, Verlet(sim.deck.solvers[0].params), run=run)
            wall = time.perf_counter() - t0
            run.close()
            r = read_results(f"{tmp}/wave.h")
        t, v = r["times"], r["global"]["MidX"]
        speed = (0.05 - 1.5 * h) / t[np.argmax(v > 2.5)]
        print(f"{nx:9d} {speed:10.0f} {wall:9.2f}")


def newmark() -> None:
    K, MU = 160.0e9, 80.0e9
    material = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": MU}

    def run(beta: float, gamma: float, steps: int, final_time: float = 1.0e-3) -> tuple[np.ndarray, float]:
        tree = cube_deck(material, n=4, horizon_factor=2.015)
        tree["Boundary Conditions"] = {
            "All Node Set": " ".join(str(i) for i in range(1, 65)),
            "VX": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "x", "Value": "0.01*(x-2.0)"},
            "VY": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "y", "Value": "0.005*(z-2.0)*(x-2.0)"},
        }
        tree["Solver"] = {
            "Initial Time": 0.0, "Final Time": final_time,
            "Implicit": {"Fixed dt": final_time / steps, "Beta": beta, "Gamma": gamma, "Absolute Tolerance": 1.0e-10, "Maximum Solver Iterations": 20},
        }
        sim = build_simulation(tree)
        t0 = time.perf_counter()
        run_sections(sim)
        return sim.fields["Displacement"].copy(), time.perf_counter() - t0

    for beta, gamma in ((0.25, 0.5), (0.3025, 0.6)):
        ref, _ = run(beta, gamma, 2560)
        print(f"time: Newmark beta = {beta}, gamma = {gamma}, LPS cube, displacement vs a 32x finer step")
        print(f"{'steps':>8s} {'abs. error':>11s} {'wall s':>9s}")
        rows = []
        for steps in (20, 40, 80):
            u, wall = run(beta, gamma, steps)
            err = np.abs(u - ref).max()
            rows.append((1.0e-3 / steps, err))
            print(f"{steps:8d} {err:11.3e} {wall:9.3f}")
        dts, es = np.array(rows).T
        print(f"  fitted rate {np.polyfit(np.log(dts), np.log(es), 1)[0]:.2f} (expected {2 if gamma == 0.5 else 1})")


if __name__ == "__main__":
    space()
    timing()
    wave()
    newmark()
