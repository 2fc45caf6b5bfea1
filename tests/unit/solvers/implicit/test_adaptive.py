"""QuasiStatic ``Adaptive Load-Stepping`` (PERIDIGM_MODELS.md section 13): load step halving,
the reduction limits, ``Reduce all remaining load steps``, the output frequency rules and the
switch to Verlet."""
import types

import pytest

from peridyn.solvers.implicit.quasistatic import (
    LoadStepError,
    change_output_frequency,
    halve_load_step,
    multiply_output_frequency,
    reduce_remaining_load_steps,
)
from tests.unit.solvers.implicit.test_implicit_solvers import bar_deck
from peridyn.engine.run_services import RunServices
from peridyn.engine.session import run_sections


# -- the rules, one by one ----------------------------------------------------------------------
def test_a_failed_step_is_halved_from_the_previous_time():
    times = [0.0, 1.0, 2.0]
    halve_load_step(times, 1, 0.0, 1.0)
    assert times == [0.0, 0.5, 1.0, 2.0]
    halve_load_step(times, 1, 0.0, 0.5)
    assert times == [0.0, 0.25, 0.5, 1.0, 2.0]
    halve_load_step(times, 3, 0.5, 0.5)  # a later step: t_prev + dt/2
    assert times == [0.0, 0.25, 0.5, 0.75, 1.0, 2.0]


@pytest.mark.parametrize(
    "times, step, t_cur, dt, t_final, expected",
    [
        ([0.0, 0.25, 0.5, 1.0], 1, 0.25, 0.25, 1.0, [0.0, 0.25, 0.5, 0.75, 1.0]),
        ([0.0, 0.3, 0.6, 1.0], 1, 0.3, 0.3, 1.0, [0.0, 0.3, 0.6, 0.8999999999999999, 1.2]),  # passes the final time, as Peridigm
        ([0.0, 0.5, 1.0], 2, 1.0, 0.5, 1.0, [0.0, 0.5, 1.0]),  # the last step: nothing left
    ],
)
def test_reduce_all_remaining_load_steps(times, step, t_cur, dt, t_final, expected):
    reduce_remaining_load_steps(times, step, t_cur, dt, t_final)
    assert times == expected


def test_output_frequency_rules():
    writers = [types.SimpleNamespace(frequency=f) for f in (1, 3, 0, -1)]
    multiply_output_frequency(writers, 2.0)
    assert [w.frequency for w in writers] == [2, 6, 0, -2]
    multiply_output_frequency(writers, 1.5)  # an int times a double, truncated
    assert [w.frequency for w in writers] == [3, 9, 0, -3]
    change_output_frequency(writers, 10)
    assert [w.frequency for w in writers] == [10] * 4


# -- a run that needs halvings -------------------------------------------------------------------
def qs(h, tmp_path, **adaptive_and_more):
    """The bar pulled 0.05 in one load step, one exact Newton iteration per attempt (direct
    solves, no heuristics): the residual left is quadratic in the step size."""
    extra = adaptive_and_more.pop("qs", {})
    sub = {"Number of Load Steps": 1, "Maximum Solver Iterations": 1, "Linear Solver": "Direct", **extra}
    if adaptive_and_more:
        sub["Adaptive Load-Stepping"] = adaptive_and_more
    tree = bar_deck(h, {"Initial Time": 0.0, "Final Time": 1.0, "Disable Heuristics": True, "QuasiStatic": sub}, pull=0.05)
    tree["Output"] = {"Output Filename": "adaptive", "Output Frequency": 1, "Output Variables": {"Displacement": True}}
    return h.build(tree, output_dir=tmp_path)


def residual_after_one_iteration(h, tmp_path):
    sim = qs(h, tmp_path, qs={"Absolute Tolerance": 1e-30})
    with pytest.raises(LoadStepError):
        run_sections(sim)
    return sim.stats["solvers"][0]["load_steps"][0]["residual"]


@pytest.fixture
def tolerance(h, tmp_path):
    """An absolute tolerance the full step misses by more than 100x, the half step too, and the
    quarter step (residual / 16) meets within 100x: two halvings."""
    r1 = residual_after_one_iteration(h, tmp_path)
    return r1 / 800.0


def attempts(sim):
    return [(a["dt"], a["outcome"]) for a in sim.stats["solvers"][0]["load_steps"]]


def test_halving_until_a_step_converges_then_the_remaining_steps(h, tmp_path, tolerance):
    sim = qs(h, tmp_path, qs={"Absolute Tolerance": tolerance}, **{"Maximum load step reductions in one step": 2, "Maximum total load step reductions": 5,
                                                                "Adaptive output frequency": True})
    run = RunServices.of(sim)
    run_sections(sim, run=run)
    got = attempts(sim)
    # 1 -> 0.5 -> 0.25 (accepted); then 0.25 to 0.5 at dt 0.25; then 0.5 to 1 fails once and is halved
    assert [dt for dt, _ in got] == [1.0, 0.5, 0.25, 0.25, 0.5, 0.25, 0.25]
    assert [o for _, o in got] == ["cut back", "cut back", "accepted", "accepted", "cut back", "accepted", "accepted"]
    assert sim.stats["solvers"][0]["load_step_reductions"] == 3
    assert sim.clock.time == pytest.approx(1.0)
    assert run.files.writers[0].frequency == 8  # doubled at each of the three halvings


def test_reduce_all_remaining_load_steps_keeps_the_small_step(h, tmp_path, tolerance):
    sim = qs(h, tmp_path, qs={"Absolute Tolerance": tolerance}, **{"Maximum load step reductions in one step": 2, "Maximum total load step reductions": 2,
                                                                "Reduce all remaining load steps": True})
    run = RunServices.of(sim)
    run_sections(sim, run=run)
    got = attempts(sim)
    assert [dt for dt, _ in got] == [1.0, 0.5, 0.25, 0.25, 0.25, 0.25]
    assert sim.stats["solvers"][0]["load_step_reductions"] == 2
    assert run.files.writers[0].frequency == 1  # no Adaptive output frequency
    assert run.files.writers[0].count == 5  # t = 0 and the four accepted steps; failed attempts write nothing


def test_too_many_reductions_in_one_step_stop_the_solver(h, tmp_path, tolerance):
    sim = qs(h, tmp_path, qs={"Absolute Tolerance": tolerance}, **{"Maximum load step reductions in one step": 1, "Maximum total load step reductions": 5})
    run = RunServices.of(sim)
    with pytest.raises(LoadStepError, match="no more load step reductions"):
        run_sections(sim, run=run)
    assert [o for _, o in attempts(sim)] == ["cut back", "failed"]
    assert run.files.writers[0].count == 1  # only the initial write


def test_the_total_limit_counts_every_halving(h, tmp_path, tolerance):
    sim = qs(h, tmp_path, qs={"Absolute Tolerance": tolerance}, **{"Maximum load step reductions in one step": 2, "Maximum total load step reductions": 2})
    with pytest.raises(LoadStepError):
        run_sections(sim)
    # two halvings reach the quarter step; 0.5 -> 1.0 fails again: the third reduction is over the total
    assert [o for _, o in attempts(sim)] == ["cut back", "cut back", "accepted", "accepted", "failed"]


def test_switch_to_verlet_restarts_from_the_last_accepted_step(h, tmp_path, tolerance):
    sim = qs(h, tmp_path, qs={"Absolute Tolerance": tolerance}, **{"Maximum load step reductions in one step": 2, "Maximum total load step reductions": 2,
                                                                "Switch to Verlet": {"Fixed dt": 1.0e-4, "Output Frequency": 400}})
    run = RunServices.of(sim)
    run_sections(sim, run=run)
    st = sim.stats["solvers"]
    assert [s["method"] for s in st] == ["QuasiStatic", "Verlet"]
    assert st[1]["steps"] == 5000  # from t_prev = 0.5 to 1.0 at dt 1e-4 (below the estimate, 1.18e-4)
    assert run.files.writers[0].frequency == 400


def test_a_switch_to_verlet_that_cannot_advance_stops_the_run(h, tmp_path, tolerance):
    """The fallback's step (0.6) is longer than what is left after the last accepted step
    (0.5 to 1.0): no step fits, the run cannot reach its final time, exit 3 (it ended 'done'
    with nothing written past the last load step)."""
    sim = qs(h, tmp_path, qs={"Absolute Tolerance": tolerance}, **{"Maximum load step reductions in one step": 2, "Maximum total load step reductions": 2,
                                                                "Switch to Verlet": {"Fixed dt": 0.6}})
    with pytest.raises(LoadStepError, match=r"Switch to Verlet cannot continue the run from t = 0.5: .*longer than the solver's interval 0.5"):
        run_sections(sim)


def test_a_switch_to_verlet_with_an_absurd_step_count_is_refused_at_set_up(h, tmp_path):
    """The estimate-and-limit rules of a Verlet section apply to the fallback before anything
    runs (a Fixed dt of 1e-300 announced a 300-digit step count and never ended)."""
    from peridyn.core.errors import InputError

    sim = qs(h, tmp_path, **{"Maximum load step reductions in one step": 2, "Maximum total load step reductions": 2,
                            "Switch to Verlet": {"Fixed dt": 1e-300}})
    with pytest.raises(InputError, match=r"Adaptive Load-Stepping > Switch to Verlet: .*steps"):
        sim.plan_solvers()
