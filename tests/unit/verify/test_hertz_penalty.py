"""``hertz-penalty``: PeriLab's ``Penalty Contact`` presses a rigid sphere into a bond-based block
as Hertz says, F = 4/3 E* sqrt(R + R_c) d^1.5 (E* = 2.22 K of the block's lattice solid, see
``peridyn.verify.problems.contact``), and the check catches a penalty stiffness that is wrong.

Tolerances (justified in ``HertzPenalty.reference``): the penalty springs let the sphere sink into
the block by an O(h) penetration (8 % of the largest approach at R/h = 12, 4.7 % at 20), which
makes the fitted stiffness C low by about as much; so |C / C_H - 1| <= 10 % at every R/h of the
quick ladder (12, 16, 20) and <= 7 % at 20 (measured 8.1 %, 5.6 %, 5.3 %), with the penetration
removed within 3 % (measured -1.8 %, -1.1 %, -1.6 %); the exponent of F against the approach,
fitted log-log, in 1.45 .. 1.55 (measured 1.508, 1.525, 1.506).
"""
import pytest

from peridyn.verify.problems.contact import Hertz
from peridyn.verify.problems.contact_penalty import METHOD, HertzPenalty
from tests.unit.verify.test_contact_verify import failed, ladder


def test_the_problem_is_described_and_listed():
    from peridyn.verify import PROBLEMS

    p = HertzPenalty()
    assert PROBLEMS["hertz-penalty"] is HertzPenalty
    assert p.computes and p.reference and p.methods == (METHOD,)
    assert all(r % 4 == 0 for r in p.ladder(METHOD, False))  # the reference point at depth R/4 is a lattice point


def test_hertz_quick_ladder_passes_with_the_penalty_model():
    points, checks = ladder(HertzPenalty(), METHOD)
    assert not failed(checks), failed(checks)
    assert [q["resolution"] for q in points] == [12.0, 16.0, 20.0]
    for q in points:
        v = q["values"]
        assert abs(v["C/C_H"] - 1.0) <= 0.10  # F against Hertz's 4/3 E* sqrt(R) d^1.5
        assert abs(v["C_el/C_H"] - 1.0) <= 0.03
        assert 1.45 <= v["exponent"] <= 1.55  # the fitted exponent of F against d
        assert v["law error"] < 1e-12  # the force on the top-centre point is PeriLab's law
    assert abs(points[-1]["values"]["C/C_H"] - 1.0) <= 0.07
    assert points[-1]["values"]["penetration/d_max"] < points[0]["values"]["penetration/d_max"]


def test_penalty_factor_two_hundred_is_hertzs_spring_constant_one_hundred_k():
    """PeriLab's law with c = 200 K is Peridigm's Short Range Force with k = 100 K: the two
    problems measure the same stiffness (to round-off in the order of the sums)."""
    penalty = HertzPenalty().measure(METHOD, 12.0, True).values
    springs = Hertz().measure("Elastic Bond Based", 12.0, True).values
    for key in ("C/C_H", "C_el/C_H", "exponent", "penetration/d_max"):
        assert penalty[key] == pytest.approx(springs[key], rel=1e-9), key


def test_a_penalty_stiffness_a_tenth_too_soft_fails(monkeypatch):
    """The model builds its stiffness with a tenth of PeriLab's 9 / pi: the force on a point no
    longer follows the law and the penetration takes the stiffness error past its band."""
    from peridyn.contact import penalty

    monkeypatch.setattr(penalty, "HALF_PENALTY", 0.1 * penalty.HALF_PENALTY)
    points, checks = ladder(HertzPenalty(), METHOD, [12.0])
    whats = [c.what for c in failed(checks)]
    assert any(w.startswith("contact force on the top-centre point against the law") for w in whats), whats
    assert any(w.startswith("stiffness error at R/h = 12") for w in whats), whats
    assert points[0]["values"]["penetration/d_max"] > 0.2


def test_a_penalty_factor_on_the_wrong_modulus_fails(monkeypatch):
    """Penalty Factor applied to the shear modulus (3/5 K for a bond-based material) instead of
    the bulk modulus: the force is no longer PeriLab's c = p K law."""
    from peridyn.core.interfaces import ElasticModuli
    from peridyn.materials.elastic_bond_based import ElasticBondBased

    moduli = ElasticBondBased.elastic_moduli

    def shear_as_bulk(self):
        m = moduli(self)
        return ElasticModuli(bulk=m.shear, shear=m.shear, planar=m.planar, hookean=m.hookean, thickness=m.thickness,
                             micromodulus=m.micromodulus)

    monkeypatch.setattr(ElasticBondBased, "elastic_moduli", shear_as_bulk)
    points, checks = ladder(HertzPenalty(), METHOD, [12.0])
    whats = [c.what for c in failed(checks)]
    assert any(w.startswith("contact force on the top-centre point against the law") for w in whats), whats
