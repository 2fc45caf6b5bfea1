"""The contact problems of ``peridyn verify`` (``hertz``, ``contact-stability``): their quick
ladders land in their bands, and the bands catch wrong physics (a block modulus 10 % off, a
spring constant the kernel does not apply, a monitor that lets an unstable run finish, a
diagnosis that does not name the contact springs)."""
import math

import pytest

from peridyn.verify.problems.contact import (
    ContactStability, Hertz, hertz_axis_displacement, hertz_surface_displacement, isotropic, lattice_moduli,
)

METHOD = "Elastic Bond Based"


def ladder(problem, method, resolutions=None):
    """Run ``method``'s quick ladder (or ``resolutions``) in-process: (points, checks), the points
    as the runner records them."""
    points = []
    for r in resolutions or problem.ladder(method, True):
        m = problem.measure(method, r, True)
        points.append({"resolution": r, "size": m.size, "error": m.error, "steps": m.steps, "values": dict(m.values)})
    return points, problem.checks(method, points, True)


def failed(checks):
    return [c for c in checks if not c.passed]


def test_the_problems_are_described():
    for cls in (Hertz, ContactStability):
        p = cls()
        assert p.computes and p.reference and p.methods
        for method in p.methods:
            quick, full = p.ladder(method, True), p.ladder(method, False)
            assert quick == sorted(quick) and full[: len(quick)] == quick
    # the reference point at depth R/4 is a lattice point
    assert all(r % 4 == 0 for r in Hertz().ladder(METHOD, False))


# -- the closed forms ---------------------------------------------------------------------------
def test_lattice_moduli_and_hertz_modulus():
    c11, c12, c44 = lattice_moduli(1.515, 1.0)
    assert (c11, c12, c44) == pytest.approx((2.6257, 0.7691, 0.7691), abs=1e-4)
    # the continuum bond-based solid: lambda = mu = 0.6 K, nu = 1/4, E* = E / (1 - nu^2) = 1.6 K
    e_star, nu, G = isotropic(1.8, 0.6, 0.6)
    assert (e_star, nu, G) == pytest.approx((1.6, 0.25, 0.6))


def test_hertz_displacements_are_the_approach_at_the_centre_and_boussinesq_far_away():
    G, nu, R, F = 0.75e9, 0.25, 0.02, 100.0
    e_star = 2.0 * G / (1.0 - nu)
    a = (3.0 * F * R / (4.0 * e_star)) ** (1.0 / 3.0)
    d = a * a / R
    assert hertz_axis_displacement(F, 0.0, e_star, nu, G, R) == pytest.approx(d, rel=1e-12)
    z = 200.0 * a  # a point load: u_z = F (3 - 2 nu) / (4 pi G z) on the axis
    assert hertz_axis_displacement(F, z, e_star, nu, G, R) == pytest.approx(F * (3.0 - 2.0 * nu) / (4.0 * math.pi * G * z), rel=1e-4)
    assert hertz_surface_displacement(F, 0.0, e_star, R) == pytest.approx(d, rel=1e-12)
    assert hertz_surface_displacement(F, 0.5 * a, e_star, R) == pytest.approx(d - 0.125 * a * a / R, rel=1e-12)
    assert hertz_surface_displacement(F, a * (1.0 + 1e-12), e_star, R) == pytest.approx(0.5 * d, rel=1e-6)  # half at the edge
    r = 200.0 * a  # and F / (pi E* r) on the surface
    assert hertz_surface_displacement(F, r, e_star, R) == pytest.approx(F / (math.pi * e_star * r), rel=1e-4)


# -- hertz --------------------------------------------------------------------------------------
def test_hertz_quick_ladder_passes():
    p = Hertz()
    points, checks = ladder(p, METHOD)
    assert not failed(checks), failed(checks)
    for q in points:
        v = q["values"]
        assert v["law error"] < 1e-12
        assert 0.9 < v["C/C_H"] < v["C_el/C_H"] < 1.0  # the springs' penetration is most of the difference
        assert v["raw C/C_H"] > 1.05  # the held block is stiffer than the half-space: hence the depth reference
    pen = [q["values"]["penetration/d_max"] for q in points]
    assert pen[1] < pen[0]


def test_a_block_ten_percent_too_stiff_fails(monkeypatch):
    """A micromodulus 10 % too large: C and C_el, measured from the point at depth R/4 whose
    descent scales with the modulus too, move 3 %; the descent against the surface at R/2 moves
    7.6 % and fails its band."""
    from peridyn.materials.elastic_bond_based import ElasticBondBased

    init = ElasticBondBased.__init__

    def stiffer(self, *args, **kwargs):
        init(self, *args, **kwargs)
        self.c *= 1.1

    monkeypatch.setattr(ElasticBondBased, "__init__", stiffer)
    points, checks = ladder(Hertz(), METHOD)
    bad = failed(checks)
    assert bad and all(c.what.startswith("|C_el (ring)/C_H - 1|") for c in bad), bad
    assert all(q["values"]["C_el (ring)/C_H"] > 1.06 for q in points)


def test_a_spring_constant_not_applied_fails(monkeypatch):
    """The kernel applies a tenth of the deck's Spring Constant: the force on a point no longer
    follows the law, and the penetration (3.4 times larger: more of the sphere's points reach each
    block point) takes the stiffness error past its band."""
    from peridyn.contact.short_range import SHORT_RANGE_FORCE, ShortRangeForce
    from peridyn.kernels import default_backend

    def soft(self, pairs, state, out):
        p = self.params
        default_backend().kernel(SHORT_RANGE_FORCE)(0, state.num_owned, (
            pairs.offsets, pairs.partners, pairs.visits, state.gid, state.block, state.horizon, state.y, state.v, state.volume,
            float(p.contact_radius), 0.1 * float(p.spring_constant), self.mu, out))

    monkeypatch.setattr(ShortRangeForce, "force", soft)
    points, checks = ladder(Hertz(), METHOD, [12.0])
    whats = [c.what for c in failed(checks)]
    assert any(w.startswith("contact force on the top-centre point against the law") for w in whats), whats
    assert any(w.startswith("stiffness error at R/h = 12") for w in whats), whats
    assert points[0]["values"]["penetration/d_max"] > 0.2  # 0.08 with the deck's spring constant


# -- contact-stability --------------------------------------------------------------------------
def test_contact_stability_quick_passes():
    p = ContactStability()
    for method in p.methods:
        points, checks = ladder(p, method)
        assert not failed(checks), (method, failed(checks))
        v = points[0]["values"]
        assert v["silent"] == 0 and v["stopped"] == v["stopped naming the contact springs"] > 0
        if method == "k/K = 1":
            assert v["largest stable ratio"] > 1.5  # far from the limit: the estimate is cautious
            assert 0.85 < v["estimate / bond-only estimate"] < 0.95


def test_a_monitor_that_lets_unstable_runs_finish_fails(monkeypatch):
    """Without the energy monitor's checks (and the end-of-run judgement), the trials above the
    limit finish with non-finite values or a wildly wrong energy: counted as silent, a FAIL."""
    from peridyn.solvers.explicit import verlet
    from peridyn.solvers.monitors import energy

    monkeypatch.setattr(energy.EnergyMonitor, "check", lambda self, step, time: None)
    monkeypatch.setattr(verlet, "judge_energy", lambda *a, **k: None, raising=False)
    p = ContactStability()
    points, checks = ladder(p, "k/K = 10")
    assert points[0]["values"]["silent"] > 0
    assert any(c.what.startswith("trials ended silently") for c in failed(checks)), checks


def test_a_diagnosis_that_does_not_name_the_springs_fails(monkeypatch):
    """k/K = 1000 at 1.515 spacings stops above the estimate; when the message does not say that the
    contact springs are the cause, the check fails."""
    from peridyn.contact.manager import ContactManager

    monkeypatch.setattr(ContactManager, "diagnosis", lambda self, dt: "")
    p = ContactStability()
    points, checks = ladder(p, "k/K = 1000")
    assert points[0]["values"]["stopped"] > 0 and points[0]["values"]["stopped naming the contact springs"] == 0
    assert any(c.what.startswith("trials ended silently") for c in failed(checks)), checks


def test_contact_step_sees_the_estimates_contact_stiffness_ten_percent_off(monkeypatch):
    """The exact Verlet limit of the linearised contact model against the set-up estimate: the
    unchanged model is inside its band; the estimate's pair stiffness 10 % high moves the ratio
    out of it (contact-stability's bisection cannot see that)."""
    from peridyn.contact.short_range import ShortRangeForce
    from peridyn.verify.problems.contact_step import ContactStep

    problem = ContactStep()
    point = {"resolution": 1.515, "error": problem.measure("k/K = 1000", 1.515, True).error}
    point["values"] = {"asymmetry of K / rho": 0.0}
    assert all(c.passed for c in problem.checks("k/K = 1000", [point], True))
    stiffness = ShortRangeForce.pair_stiffness
    monkeypatch.setattr(ShortRangeForce, "pair_stiffness", lambda self, horizon: 1.1 * stiffness(self, horizon))
    point["error"] = problem.measure("k/K = 1000", 1.515, True).error
    failed = [c.what for c in problem.checks("k/K = 1000", [point], True) if not c.passed]
    assert failed and "against its measured" in failed[0]
