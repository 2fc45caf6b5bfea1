"""Verification of the implicit solvers against exact results.

* QuasiStatic, a bar in uniaxial tension "in the bulk": the boundary layer (two horizons thick)
  is driven by the linear-elastic solution u = eps (x, -nu y, -nu z); a homogeneous deformation
  makes every force vanish where all neighbors have complete families, so the interior must
  come out exactly affine, with the dilatation tr(H) = (1 - 2 nu) eps and the mean Cauchy
  stress K theta = E eps / 3 of linear elasticity.
* Newton on the exact tangent converges quadratically.
* Newmark with beta = 1/4, gamma = 1/2 (trapezoidal rule) conserves the energy of a (here
  nearly) linear system; beta = 0.3025, gamma = 0.6 dissipates it.
* Newmark's order of accuracy: second order in the time step for gamma = 1/2, first order for
  gamma > 1/2 (the price of its numerical damping).
"""
import math

import numpy as np
import pytest

from peridyn.testing import build_simulation, cube_deck, node_set_ids
from peridyn.engine.run_services import RunServices
from peridyn.engine.session import run_sections

K, MU = 160.0e9, 80.0e9
E = 9.0 * K * MU / (3.0 * K + MU)
NU = (3.0 * K - 2.0 * MU) / (2.0 * (3.0 * K + MU))
LPS = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": MU}


def test_quasistatic_bar_in_the_bulk_is_the_linear_elastic_solution():
    eps = 1.0e-4
    shape, horizon, layer = (12, 8, 8), 1.515, 3.0  # layer >= 2 horizons
    L = np.array(shape, dtype=float)
    tree = cube_deck(LPS, shape=shape, horizon_factor=horizon)
    ids = node_set_ids(tree, lambda x: np.any((x < layer) | (x > L - layer), axis=1))
    tree["Boundary Conditions"] = {"Layer Node Set": ids}
    for c, f in zip("xyz", (1.0, -NU, -NU)):
        tree["Boundary Conditions"][f"U{c}"] = {"Type": "Prescribed Displacement", "Node Set": "Layer Node Set", "Coordinate": c, "Value": f"{f * eps!r}*{c}*t"}
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": 2, "Relative Tolerance": 1.0e-10}}
    sim = build_simulation(tree)
    run_sections(sim)
    assert sim.stats["solvers"][-1]["converged"]
    x = sim.fields["Model_Coordinates"]
    u = sim.fields["Displacement"]
    interior = np.all((x > layer) & (x < L - layer), axis=1)
    assert interior.sum() == 24
    exact = eps * x * np.array([1.0, -NU, -NU])
    # Newton stops at 1e-10 of the reactions: the displacement error is ~1e-10 of eps L
    np.testing.assert_allclose(u[interior], exact[interior], rtol=0, atol=1.0e-9 * eps * L.max())
    # strain: theta = tr(H) up to the geometric nonlinearity O(eps) ~ 1e-4 relative
    np.testing.assert_allclose(sim.fields["Dilatation"][interior], (1.0 - 2.0 * NU) * eps, rtol=1.0e-3)
    # stress: sigma = sum_j t_ij (M_ij x xi_ij) V_j; its trace is 3 K theta for any family,
    # i.e. the linear-elastic mean stress E eps / 3 of uniaxial tension (same O(eps) tolerance)
    blk = sim.blocks[0]
    t = np.zeros(sim.bonds.num_bonds)
    blk.material.force_state(blk.view, t)
    nl, y, V = sim.bonds, sim.fields["Coordinates"], sim.fields["Volume"]
    for i in np.flatnonzero(interior):
        b = slice(nl.offsets[i], nl.offsets[i + 1])
        j = nl.neighbors[b]
        eta, xi = y[j] - y[i], x[j] - x[i]
        M = eta / np.linalg.norm(eta, axis=1)[:, None]
        sigma = np.einsum("b,bi,bj->ij", t[b] * V[j], M, xi)
        np.testing.assert_allclose(np.trace(sigma) / 3.0, E * eps / 3.0, rtol=1.0e-3)


def test_newton_converges_quadratically():
    """Pure Newton (Disable Heuristics: no predictor, no line search) with the exact tangent and
    a direct solver on a bar stretched 4 % and sheared 6 % in one load step: each residual is
    about the square of the previous (convergence order >= 1.8 until round-off is reached)."""
    shape = (5, 5, 5)
    tree = cube_deck(LPS, shape=shape, horizon_factor=2.015)
    tree["Boundary Conditions"] = {
        "Left Node Set": node_set_ids(tree, lambda x: x[:, 0] < 1.0),
        "Right Node Set": node_set_ids(tree, lambda x: x[:, 0] > 4.0),
        **{f"L{c}": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": c, "Value": "0.0"} for c in "xyz"},
        "RX": {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "x", "Value": "0.2*t"},
        "RY": {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "y", "Value": "0.3*t"},
    }
    tree["Solver"] = {
        "Initial Time": 0.0, "Final Time": 1.0, "Disable Heuristics": True,
        "QuasiStatic": {"Number of Load Steps": 1, "Relative Tolerance": 1.0e-13, "Maximum Solver Iterations": 12, "Linear Solver": "Direct"},
    }
    sim = build_simulation(tree)
    run_sections(sim)
    r = np.array(sim.stats["solvers"][-1]["residuals"][0])
    floor = 1.0e-14 * r[0]  # round-off of the force evaluation (the last residual sits there)
    # the order of iteration k: log(r_k+1/r_k) / log(r_k/r_k-1); the first step starts far from
    # the solution (pre-asymptotic), so the orders are taken from the second step on
    orders = [math.log(r[k + 1] / r[k]) / math.log(r[k] / r[k - 1]) for k in range(2, len(r) - 1) if r[k + 1] > floor]
    assert len(orders) >= 2
    assert min(orders) > 1.8, (r, orders)


def vibration(beta, gamma, steps, final_time):
    """Free vibration of a 4^3 cube of unit spacing (V = 1, so Peridigm's Jacobian is exact) from
    a smooth initial velocity, integrated by Newmark in ``steps`` steps to ``final_time``."""
    tree = cube_deck(LPS, n=4, horizon_factor=2.015)
    everyone = " ".join(str(i) for i in range(1, 65))
    tree["Boundary Conditions"] = {
        "All Node Set": everyone,
        "VX": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "x", "Value": "0.01*(x-2.0)"},
        "VY": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "y", "Value": "0.005*(z-2.0)*(x-2.0)"},
    }
    tree["Solver"] = {
        "Initial Time": 0.0, "Final Time": final_time,
        "Implicit": {"Fixed dt": final_time / steps, "Beta": beta, "Gamma": gamma, "Absolute Tolerance": 1.0e-10, "Maximum Solver Iterations": 20},
    }
    return build_simulation(tree)


def newmark_energy(beta, gamma, steps=20, dt=2.0e-4):
    """Total energy (kinetic + stored) of the vibration after every step."""
    sim = vibration(beta, gamma, steps, dt * steps)
    energy = []

    def record(t):
        energy.append(sim.kinetic_energy() + (sim.stored_energy() if t > 0 else 0.0))

    run_sections(sim, run=RunServices.reading(record))
    return np.array(energy)


def test_newmark_trapezoidal_rule_conserves_energy():
    E0 = newmark_energy(0.25, 0.5)
    # exact for a linear system; what remains comes from the geometric nonlinearity of the bond
    # lengths (strains ~1e-5) and the Newton tolerance
    assert np.abs(E0 / E0[0] - 1.0).max() < 1.0e-5
    E1 = newmark_energy(0.3025, 0.6)
    assert E1[-1] < 0.9 * E1[0]  # numerical damping of the dissipative parameters
    assert np.all(np.diff(E1) < 1.0e-9 * E1[0])


def newmark_displacement(beta, gamma, steps, final_time=1.0e-3):
    """Displacement of the vibration at ``final_time``."""
    sim = vibration(beta, gamma, steps, final_time)
    run_sections(sim)
    np.testing.assert_allclose(sim.clock.time, final_time, rtol=1e-12)
    return sim.fields["Displacement"].copy()


@pytest.mark.parametrize(("beta", "gamma", "order"), [(0.25, 0.5, 2.0), (0.3025, 0.6, 1.0)])
def test_newmark_order_of_accuracy(beta, gamma, order):
    """Error against a run with a 32x smaller step, at 20, 40, 80 steps of 5e-5 to 1.25e-5 s;
    measured rates 1.99, 2.00 (gamma = 1/2) and 1.17, 1.11 (gamma = 0.6). The reference's own
    error is below 1e-3 (order 2) and 4 % (order 1) of the errors compared."""
    reference = newmark_displacement(beta, gamma, 2560)
    errors = [np.abs(newmark_displacement(beta, gamma, steps) - reference).max() for steps in (20, 40, 80)]
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    np.testing.assert_allclose(rates, order, atol=0.2)
