"""``dispersion`` and ``newmark-energy``: their quick ladders pass their bands, the references
are right where they are known in closed form, and the bands fail when the physics is wrong (a
model 4 % too stiff; Newmark with numerical damping)."""
import json
import math

import pytest

from peridyn.core.errors import ExitCode
from peridyn.verify import Run
from peridyn.verify.problems import dispersion
from peridyn.verify.problems.dispersion import Dispersion
from peridyn.verify.problems.newmark import NewmarkEnergy


def points(problem, method, ladder, quick=True):
    """The points of ``method`` at ``ladder`` as the runner records them."""
    out = []
    for r in ladder:
        m = problem.measure(method, r, quick)
        out.append({"method": method, "resolution": r, "size": m.size, "error": m.error, "steps": m.steps, "values": m.values})
    return out


def failed(problem, method, pts):
    return [c.what for c in problem.checks(method, pts, True) if not c.passed]


# -- dispersion --------------------------------------------------------------------------------
def test_dispersion_quick_run_passes(tmp_path):
    assert Run([Dispersion()], tmp_path, quick=True).run() == ExitCode.OK
    entry = json.loads((tmp_path / "results.json").read_text())["problems"][0]
    assert entry["kind"] == "table" and len(entry["checks"]) == 6
    assert all(c["passed"] for c in entry["checks"]), entry["checks"]
    by = {(p["method"], p["resolution"]): p["values"] for p in entry["points"]}
    # the departure from c0 at k delta = 3 is the peridynamic one (17 % and 22 % slow), not zero
    assert by[("Elastic Bond Based", 3.0)]["c/c0 - 1"] == pytest.approx(-0.168, abs=2e-3)
    assert by[("Elastic", 3.0)]["c/c0 - 1"] == pytest.approx(-0.219, abs=3e-3)
    assert "dispersion" in (tmp_path / "report.md").read_text()


def test_dispersion_references_tend_to_the_local_speeds():
    """At small k delta both relations tend to c0, the LPS one to the P-wave speed; the lattice
    sums tend to the continuum relations as h -> 0 (bar: midpoint rule, O(h^2))."""
    assert dispersion.bar_relation(1e-3) / dispersion.bar_speed() == pytest.approx(1.0, abs=1e-7)
    assert dispersion.lps_relation(1e-3) / dispersion.p_wave_speed() == pytest.approx(1.0, abs=1e-7)
    # the bar: 2 sqrt(Cin(z)) / z = 1 - z^2/48 + O(z^4)
    assert dispersion.bar_relation(0.1) / dispersion.bar_speed() == pytest.approx(1.0 - 0.01 / 48, abs=1e-7)
    for kd in (0.5, 2.0):
        errs = [abs(dispersion.bar_lattice(kd, m) / dispersion.bar_relation(kd) - 1.0) for m in (15.5, 31.5, 63.5)]
        assert 3.5 < errs[0] / errs[1] < 4.5 and 3.5 < errs[1] / errs[2] < 4.5
        assert dispersion.lps_lattice(kd, math.sqrt(17.5)) / dispersion.lps_relation(kd) == pytest.approx(1.0, abs=5e-3)


def test_dispersion_fails_for_a_model_four_percent_too_stiff(monkeypatch):
    """Forces 4 % too large (a modulus 4 % off) make every wave 2 % fast: every band fails."""
    force = dispersion.model_force
    monkeypatch.setattr(dispersion, "model_force", lambda sim, u: 1.04 * force(sim, u))
    problem = Dispersion()
    for method in problem.methods:
        pts = points(problem, method, (0.2, 0.4, 3.0))
        assert len(failed(problem, method, pts)) == 3, problem.checks(method, pts, True)


def test_dispersion_counts_only_points_far_from_every_face():
    """The LPS force uses the neighbours' dilatations: counting points only one horizon inside
    (``wave-speed``'s choice) would move c by up to 2 %; these match the lattice to 1e-6."""
    problem = Dispersion()
    sim, inside = problem.model("Elastic")
    x = sim.fields["Model_Coordinates"]
    assert inside.sum() >= 8
    assert (x[inside].min(axis=0) - x.min(axis=0) >= 2.0 * dispersion.DELTA - 1e-9).all()
    assert abs(problem.measure("Elastic", 0.4, True).values["c/c_lattice - 1"]) < 1e-6


# -- newmark-energy ----------------------------------------------------------------------------
def test_newmark_quick_run_passes(tmp_path):
    assert Run([NewmarkEnergy()], tmp_path, quick=True).run() == ExitCode.OK
    entry = json.loads((tmp_path / "results.json").read_text())["problems"][0]
    assert all(c["passed"] for c in entry["checks"]), entry["checks"]
    assert len(entry["checks"]) == 6
    for method, rate in entry["rates"].items():
        assert rate == pytest.approx(2.0, abs=0.05), method
    for p in entry["points"]:
        assert p["values"]["Newton iterations"] == p["steps"]  # the problem is nearly linear: one iteration a step
        assert p["values"]["Verlet error"] > p["error"]


def test_newmark_with_numerical_damping_fails(monkeypatch):
    """gamma = 0.6, beta = 0.3025 (Peridigm's dissipative choice): first order, energy lost,
    its error no longer -1/2 of Verlet's: every band fails."""
    monkeypatch.setattr(NewmarkEnergy, "GAMMA", 0.6)
    monkeypatch.setattr(NewmarkEnergy, "BETA", 0.3025)
    problem = NewmarkEnergy()
    method = "Elastic Bond Based"
    pts = points(problem, method, problem.ladder(method, True)[:3])
    assert problem.rate(pts) < 1.5
    assert len(failed(problem, method, pts)) == 3, problem.checks(method, pts, True)
