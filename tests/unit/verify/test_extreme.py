"""``extreme-cases``: the outcome classifier on made-up runs, a FAIL row failing the command, and
two real decks (a converged one and one with wrong physics: a unit conversion off by 1000)."""
import json
import math

import numpy as np
import pytest

from peridyn.core.errors import ExitCode
from peridyn.verify import Run
from peridyn.verify.problems.extreme import (
    CONVERGED,
    DIAGNOSED,
    FAIL,
    ExtremeCases,
    Outcome,
    RunResult,
    balance_judge,
    classify,
    mm_impact,
    run_deck,
    scale_judge,
)

ENERGY = "Solver (Verlet): 100 steps in 0.1 s\n  energy: kinetic 1 -> 0.5, stored +0.5, work by loads +0, by prescribed motion +0; balance error {e} ({p}% of the energy scale, worst {w}%)\ndone in 1 s; wrote out.e\n"


def result(rc=0, stderr="done in 1 s; wrote out.e\n", u=1e-3, nan=False):
    disp = np.full((2, 4), u)
    if nan:
        disp[1, 2] = np.nan
    outputs = {f"Displacement{c}": disp.copy() for c in "XYZ"} if rc is not None else {}
    return RunResult(rc, stderr, 0.1, outputs, np.array([0.0, 1.0]), np.zeros((4, 3)))


def right(runs):
    return True, 0.0, "fine"


def wrong(runs):
    return False, 1.0, "off by 100 %"


@pytest.mark.parametrize(("runs", "judge", "expected", "says"), [
    ([result()], right, CONVERGED, "fine"),
    ([result()], wrong, FAIL, "wrong answer: off by 100 %"),
    ([result(nan=True)], right, FAIL, "non-finite values in the output"),
    ([result(3, "error: the run went unstable at step 3\nthe output written so far is kept\n")], right, DIAGNOSED, "exit 3: the run went unstable"),
    ([result(2, "error: deck.yaml:3: Materials > M > Density: must be > 0\n")], right, DIAGNOSED, "exit 2: deck.yaml:3"),
    ([result(2, "error: one\nerror: two\n")], right, FAIL, "2 error lines instead of one"),
    ([result(3, "error: unstable\n", nan=True)], right, FAIL, "exit 3, but non-finite values"),
    ([result(3, "Traceback (most recent call last):\nValueError: x\n")], right, FAIL, "traceback"),
    ([result(1, "error: internal error (a bug)\n")], right, FAIL, "exit 1"),
    ([result(-11, "")], right, FAIL, "exit -11"),
    ([result(None, "")], right, FAIL, "hang"),
    ([RunResult(0, "done\n", 0.1)], right, FAIL, "no output was written"),
    ([result(), result(3, "error: unstable\n")], right, DIAGNOSED, "exit 3: unstable"),
    ([result(3, "error: unstable\n"), result(1, "boom\n")], right, FAIL, "exit 1"),
])
def test_outcomes(runs, judge, expected, says):
    out = classify(runs, judge)
    assert out.outcome == expected and says in out.why, out


def test_energy_balance_must_be_small_and_fall_with_the_step():
    def pair(p1, p2):
        return [result(stderr=ENERGY.format(e=1, p=p1, w=p1)), result(stderr=ENERGY.format(e=1, p=p2, w=p2))]

    ok, answer, why = balance_judge(pair(4.0, 1.0))
    assert ok and answer == 1.0 and "falling 4 times" in why
    assert not balance_judge(pair(1.2, 1.0))[0]  # not Verlet's O(dt^2) error: a force doing work
    assert not balance_judge(pair(40.0, 10.0))[0]  # falls, but far too large
    assert balance_judge(pair(1e-12, 1e-12))[0]  # exact to rounding: nothing to fall
    assert not balance_judge([result(), result()])[0]  # no energy account
    still = [result(stderr=ENERGY.format(e=1, p=4, w=4)), result(stderr=ENERGY.format(e=1, p=1, w=1), u=0.0)]
    assert "nothing moved" in balance_judge(still)[2]


class Fake(ExtremeCases):
    """The real problem with made-up outcomes instead of runs."""

    methods = ("good", "stopped", "bad")
    OUTCOMES = {"good": Outcome(CONVERGED, "exit 0; fine", 0.1), "stopped": Outcome(DIAGNOSED, "exit 3: unstable"),
                "bad": Outcome(FAIL, "exit 0 with a wrong answer: u off by 50 %", 0.5)}

    def run_case(self, method, n):
        return self.OUTCOMES[method], [result(rc=3 if method == "stopped" else 0)]


def test_a_fail_row_fails_the_command_and_the_report_says_why(tmp_path):
    assert Run([Fake()], tmp_path, quick=True).run() == ExitCode.FAILURE
    data = json.loads((tmp_path / "results.json").read_text())
    entry = data["problems"][0]
    assert [p["values"]["outcome"] for p in entry["points"]] == [CONVERGED, DIAGNOSED, FAIL]
    assert [c["passed"] for c in entry["checks"]] == [True, True, False] and data["failed checks"] == 1
    report = (tmp_path / "report.md").read_text()
    assert "| bad | 5 | FAIL |" in report and "u off by 50 %" in report
    assert "| converged or diagnosed | **FAIL** |" in report and "| stopped | diagnosed | converged or diagnosed | pass |" in report


def test_without_a_fail_row_the_command_passes(tmp_path):
    class Good(Fake):
        methods = ("good", "stopped")

    assert Run([Good()], tmp_path, quick=True).run() == ExitCode.OK
    assert "**FAIL**" not in (tmp_path / "report.md").read_text()


def test_a_real_rigid_translation_converges():
    problem = ExtremeCases()
    out, runs = problem.run_case("isolated point", 4)
    assert out.outcome == CONVERGED and out.answer < 1e-9 and runs[0].steps > 0, out


def test_a_wrong_unit_conversion_is_a_fail(tmp_path):
    """The mm-tonne-s deck with its density converted as if 1 kg/m^3 were 1e-9 t/mm^3: the
    waves run 31 times slower and the displacements no longer scale, so exit 0 is a wrong
    answer."""
    problem = ExtremeCases()
    reference = problem.reference_run(4)
    tree = mm_impact(4)
    tree["Materials"]["M"]["Density"] *= 1e3
    res = run_deck(tree, tmp_path / "wrong")
    out = classify([res], scale_judge(lambda: reference, 1.0e3, "1000"))
    assert res.rc == 0 and out.outcome == FAIL and "wrong answer" in out.why, out
    assert out.answer > 1e-2
    good = classify([run_deck(mm_impact(4), tmp_path / "right")], scale_judge(lambda: reference, 1.0e3, "1000"))
    assert good.outcome == CONVERGED and good.answer < 1e-9 and not math.isnan(good.answer), good


def test_the_quickstart_plate_above_its_measured_limit_is_refused():
    """Safety Factor 1.5 once finished 6.6 % off with more damage than at 1.0: the plate's stable
    limit is 1.49 times the estimate, so the run is refused before its first step (exit 3)."""
    from peridyn.verify.problems.extreme import DIAGNOSED, PLATE

    out, runs = ExtremeCases().run_case(PLATE, 5)
    assert out.outcome == DIAGNOSED and runs[0].rc == 3 and "stable limit measured on the model" in out.why, out
