"""Convergence rates, fitted from errors against analytic or reference solutions.

Spatial: a bar of points (bond-based, fixed horizon delta, spacing h with delta/h = m + 1/2)
under the displacement u = A sin(k x). Where the family is complete, the peridynamic force
density of the continuum is, exactly (no bond changes direction),

    f(x) = c A_cs int_{-delta}^{delta} (u(x + xi) - u(x)) / |xi| dxi = -2 c A_cs A sin(k x) Cin(k delta)

with Cin(z) = gamma + ln z - Ci(z). The point sums are midpoint rules of this integral whose
cut-off falls half-way between points, so the error falls as h^2.

Temporal: velocity Verlet is second order; a wave in a small cube, run with dt, dt/2, dt/4, dt/8
and compared with dt/64, must show errors falling as dt^2.
"""
import numpy as np
from scipy.special import sici

from peridyn.testing import build_simulation, cube_deck
from peridyn.engine.session import run_section

K = 1.0e9
DELTA = 1.0


def bar(h: float, length: float):
    n = int(round(length / h))
    tree = cube_deck({"Material Model": "Elastic Bond Based", "Density": 1000.0, "Bulk Modulus": K}, n=1)
    tree["Discretization"]["TensorProduct3DMeshGenerator"].update(
        {"X Length": n * h, "Number Points X": n, "Y Length": 1.0, "Z Length": 1.0, "Number Points Y": 1, "Number Points Z": 1}
    )
    tree["Blocks"]["B"]["Horizon"] = DELTA
    return build_simulation(tree)


def fit_rate(sizes, errors) -> float:
    return float(np.polyfit(np.log(sizes), np.log(errors), 1)[0])


def test_bond_based_force_converges_at_second_order_in_space():
    length = 12.0
    k = 2 * np.pi / length
    A = 1e-4
    c = 18 * K / (np.pi * DELTA**4)
    gamma = 0.5772156649015329
    cin = gamma + np.log(k * DELTA) - sici(k * DELTA)[1]
    sizes, errors = [], []
    for m in (3, 7, 15, 31):
        h = DELTA / (m + 0.5)
        sim = bar(h, length)
        x = sim.fields["Model_Coordinates"][:, 0]
        sim.fields["Coordinates"][:, 0] = x + A * np.sin(k * x)
        f = sim.evaluate_forces()[:, 0]
        inside = (x > DELTA) & (x < length - DELTA)
        exact = -2 * c * A * np.sin(k * x) * cin  # cross-section area 1
        errors.append(np.abs(f[inside] - exact[inside]).max() / np.abs(exact).max())
        sizes.append(h)
    rate = fit_rate(sizes, errors)
    assert errors[-1] < 1e-3, errors
    assert 1.8 < rate < 2.3, (rate, errors)


def test_verlet_converges_at_second_order_in_time():
    def run(dt: float) -> np.ndarray:
        sim = build_simulation(cube_deck({"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": K, "Shear Modulus": 0.6 * K}, n=4))
        from peridyn.solvers.explicit.verlet import Verlet, VerletSection

        x = sim.fields["Model_Coordinates"]
        sim.fields["Velocity"][:, 0] = 1.0 * np.sin(np.pi * x[:, 1] / 4.0)  # smooth shear
        t_end = 2e-4
        section = VerletSection.model_validate({"Initial Time": 0.0, "Final Time": t_end * (1 + 1e-12), "Verlet": {"Fixed dt": dt}})
        run_section(sim, Verlet(section))
        assert abs(sim.clock.time - t_end) < 1e-9 * t_end
        return sim.fields["Displacement"].copy()

    reference = run(2e-4 / 1024)
    sizes, errors = [], []
    for steps in (16, 32, 64, 128):
        dt = 2e-4 / steps
        errors.append(np.abs(run(dt) - reference).max())
        sizes.append(dt)
    rate = fit_rate(sizes, errors)
    assert 1.9 < rate < 2.1, (rate, errors)
