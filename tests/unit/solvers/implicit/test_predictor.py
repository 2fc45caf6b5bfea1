"""``Initialize Predictor From Previous Solver`` (PERIDIGM_MODELS.md section 9): what a second
QuasiStatic or NOXQuasiStatic solver takes over from the first one."""
import numpy as np
import pytest

from peridyn.engine.run_services import RunServices
from peridyn.engine.session import run_section
from tests.unit.solvers.implicit.test_implicit_solvers import bar_deck

PULL = 1.0e-7  # small: the peridynamic bar is geometrically nonlinear, the increments agree to O(strain)


def chained(h, method, flag, sub, sub2=None):
    """Two solvers on the linear elastic bar, each one load step of the same size (pull * t from
    t = 0 to 1, then 1 to 2): the increment of the second equals that of the first."""
    first = {"Initial Time": 0.0, "Final Time": 1.0, method: dict(sub)}
    tree = bar_deck(h, first, pull=PULL)
    tree["Solver2"] = {"Initial Time": 1.0, "Final Time": 2.0, "Initialize Predictor From Previous Solver": flag, method: dict(sub2 or sub)}
    return h.build(tree)


def run_pair(sim):
    """Run both solvers; returns (v after solver 1, v at solver 2's first write, iterations of
    solver 1, iterations of solver 2)."""
    entries = sim.deck.solvers
    state = run_section(sim, entries[0].cls(entries[0].params, section=entries[0].section))
    v1 = sim.fields["Velocity"].copy()
    it1 = sim.clock.nonlinear_iterations
    seen = []

    def spy(t):
        if not seen:
            seen.append(sim.fields["Velocity"].copy())

    run_section(sim, entries[1].cls(entries[1].params, section=entries[1].section), state, RunServices.reading(spy))
    return v1, seen[0], it1, sim.clock.nonlinear_iterations - it1


NOX = {"Number of Load Steps": 1, "Relative Tolerance": 1e-7, "Direction": {"Method": "Newton"}}
NOX2 = dict(NOX, **{"Relative Tolerance": 1e-5})
QS = {"Number of Load Steps": 1, "Relative Tolerance": 1e-8, "Maximum Solver Iterations": 20}
QS2 = dict(QS, **{"Relative Tolerance": 1e-5})  # the first solver's exact increment is well inside it


@pytest.mark.parametrize("solver", ["Line Search Based", "Inexact Trust Region Based"])
def test_nox_keeps_the_velocity_with_the_flag(h, solver):
    """NOX with the flag: v is not zeroed at the start (the first write shows it) and step 1 starts
    from v dt, here the exact increment: the first NOX step finds it converged."""
    sim = chained(h, "NOXQuasiStatic", True, dict(NOX, **{"Nonlinear Solver": solver}), dict(NOX2, **{"Nonlinear Solver": solver}))
    v1, v_start, _, it2 = run_pair(sim)
    assert np.abs(v1).max() > 0
    np.testing.assert_array_equal(v_start, v1)
    # the first NOX step only checks the initial guess: no Newton direction was computed
    assert it2 == 1
    assert sim.stats["solvers"][0]["linear_iterations"] > 0
    assert sim.stats["solvers"][1]["linear_iterations"] == 0


def test_nox_zeroes_the_velocity_without_the_flag(h):
    sim = chained(h, "NOXQuasiStatic", False, NOX, NOX2)
    v1, v_start, _, _ = run_pair(sim)
    assert np.abs(v1).max() > 0
    assert not v_start.any()
    assert sim.stats["solvers"][1]["linear_iterations"] > 0  # a Newton step from the zero initial guess


def test_quasistatic_predictor_from_the_previous_solver(h):
    """QS with the flag: v is zeroed at the start either way, but the predictor (the previous
    solver's v) runs at iteration 1 of step 1, without a linear solve: here it is exact, so the
    step needs that one pass only."""
    sim = chained(h, "QuasiStatic", True, QS, QS2)
    v1, v_start, _, it2 = run_pair(sim)
    assert np.abs(v1).max() > 0
    assert not v_start.any()
    assert it2 == 1
    assert sim.stats["solvers"][-1]["linear_solves"] == 0
    np.testing.assert_allclose(sim.fields["Velocity"], v1, rtol=0, atol=1e-6 * np.abs(v1).max())


def test_quasistatic_without_the_flag_starts_step_one_with_newton(h):
    sim = chained(h, "QuasiStatic", False, QS, QS2)
    _, v_start, _, it2 = run_pair(sim)
    assert not v_start.any()
    assert it2 >= 2  # Newton from the prescribed increments, CG to 1e-4 each time
    assert sim.stats["solvers"][-1]["linear_solves"] >= 1
