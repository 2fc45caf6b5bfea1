"""Steady-state peridynamic diffusion (``Diffusion`` + ``ImplicitDiffusion``) against closed-form
answers, with convergence in the grid spacing at a fixed ratio m = horizon / spacing = 3.015.

Peridigm's diffusion model has no source term and no transient solver (its only temperature
solver is the steady-state ``ImplicitDiffusion``; explicit dynamics refuses the material), so
the checks are steady states:

* a bar whose two ends are held at fixed temperatures on volume constraints (layers at least a
  horizon thick, the nonlocal Dirichlet condition): the linear profile is the exact discrete
  solution, to round-off, at every grid spacing;
* the same bar held on single end layers (a local-style condition): nonlocal boundary layers of
  width delta shift the bulk profile by O(delta) = O(h), so the error converges at first order;
* a plate with the harmonic field T = exp(x) cos(y) prescribed on a collar of width delta: a
  harmonic function is a steady state of the continuum nonlocal operator too (on a ball every
  term of its Taylor expansion is a power of the Laplacian), so the discrete error is the
  lattice quadrature's O(h^2).
"""
import math

import numpy as np
import pytest

from peridyn.testing import build_simulation, cube_deck
from peridyn.testing.harness import node_set_ids
from peridyn.engine.session import run_sections

M = 3.015  # horizon / spacing


def solve(shape, spacing, fixed, value, *, improved=False, solver="Direct"):
    """Run one ImplicitDiffusion load step on a PdQuickGrid box with Prescribed Temperature
    ``value`` on the points where ``fixed(x)``; returns (x, T) of all points."""
    material = {"Material Model": "Diffusion", "Coefficient": 0.7, "Use Improved Quadrature": improved}
    tree = cube_deck(material, shape=shape, spacing=spacing, horizon_factor=M)
    tree["Boundary Conditions"] = {
        "Fixed Node Set": node_set_ids(tree, fixed),
        "T": {"Type": "Prescribed Temperature", "Node Set": "Fixed Node Set", "Value": value},
    }
    tree["Solver"] = {
        "Final Time": 1.0, "Solve For Displacement": False, "Solve For Temperature": True,
        "ImplicitDiffusion": {"Number of Load Steps": 1, "Relative Tolerance": 1e-12, "Linear Solver": solver},
    }
    sim = build_simulation(tree)
    run_sections(sim)
    n = sim.num_owned
    return sim.fields["Model_Coordinates"][:n].copy(), sim.fields["Temperature"][:n].copy()


def collar(x, h):
    """Points within 3 spacings of the edges of the unit square."""
    return (np.minimum(x[:, 0], x[:, 1]) < 3 * h) | (np.maximum(x[:, 0], x[:, 1]) > 1.0 - 3 * h)


def rates(h, err):
    return [math.log(err[k] / err[k + 1]) / math.log(h[k] / h[k + 1]) for k in range(len(h) - 1)]


def bar(n, layers):
    """A line of n points on [0, 1] (spacing 1/n), ``layers`` points held at each end at
    T = 100 + 50 x; returns (bulk error, error everywhere) of the linear profile, the bulk being
    the points more than (layers + 3) spacings from the ends."""
    h = 1.0 / n
    x, T = solve((n, 1, 1), h, lambda x: (x[:, 0] < layers * h) | (x[:, 0] > 1.0 - layers * h), "100.0 + 50.0*x")
    err = np.abs(T - (100.0 + 50.0 * x[:, 0]))
    bulk = (x[:, 0] > (layers + M) * h) & (x[:, 0] < 1.0 - (layers + M) * h)
    return float(err[bulk].max()), float(err.max())


def test_volume_constrained_bar_is_exactly_linear():
    for n in (24, 96, 384):
        _, everywhere = bar(n, 3)
        assert everywhere < 1e-9, (n, everywhere)


def test_bar_with_single_end_layers_converges_at_first_order():
    ns = (24, 48, 96, 192)
    bulk = [bar(n, 1)[0] for n in ns]
    r = rates([1.0 / n for n in ns], bulk)
    assert bulk[-1] < 0.5  # of a 50-degree span
    assert all(bulk[k + 1] < bulk[k] for k in range(len(bulk) - 1))
    assert 0.85 < r[-1] < 1.15, r


@pytest.mark.parametrize("improved", [False, True])
def test_harmonic_plate_converges_at_second_order(improved):
    """T = exp(x) cos(y) on the unit square (one layer of points), prescribed on the collar of
    width delta: max error over the free points, n = 24, 48, 96 points per side."""
    ns = (24, 48, 96)
    errors = []
    for n in ns:
        h = 1.0 / n
        x, T = solve((n, n, 1), h, lambda x, h=h: collar(x, h), "exp(x)*cos(y)", improved=improved)
        free = ~collar(x, h)
        errors.append(float(np.abs(T - np.exp(x[:, 0]) * np.cos(x[:, 1]))[free].max()))
    r = rates([1.0 / n for n in ns], errors)
    assert errors[-1] < 1e-6  # |T| ~ 1
    assert r[0] > 1.2 and r[-1] > 1.75, (errors, r)


def test_krylov_and_direct_solves_agree_on_the_plate():
    """Peridigm's ILU(0)-preconditioned CG stops at the Newton tolerance, the direct solve at
    round-off: the two steady states agree to that tolerance."""
    n = 24
    h = 1.0 / n
    _, T_direct = solve((n, n, 1), h, lambda x: collar(x, h), "exp(x)*cos(y)")
    _, T_cg = solve((n, n, 1), h, lambda x: collar(x, h), "exp(x)*cos(y)", solver="Belos")
    np.testing.assert_allclose(T_cg, T_direct, rtol=1e-9)
