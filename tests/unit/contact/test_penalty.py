"""``Penalty Contact`` (PeriLab's penalty law): the conformance suite, the pair law against
PeriLab's formula, the stiffness from the bulk modulus, friction, bad input, and the GPU refusal."""
import math

import numpy as np
import pytest

from peridyn.contact.penalty import PenaltyContact, PenaltyContactParams
from peridyn.core.errors import ExitCode, InputError
from peridyn.core.interfaces import VISIT_FROM_PARTNER, VISIT_FROM_POINT, ContactPairs, ContactState, ElasticModuli
from peridyn.testing import ContactConformance
from tests.unit.contact.test_contact_runs import read, run, two_boxes


class TestPenaltyContactStiffness(ContactConformance):
    contact_model = "Penalty Contact"
    params = {"Contact Radius": 0.8, "Contact Stiffness": 3.0e9}


class TestPenaltyContactFriction(ContactConformance):
    contact_model = "Penalty Contact"
    params = {"Contact Radius": 0.8, "Contact Stiffness": 3.0e9, "Friction Coefficient": 0.4}


def all_pairs(n):
    offsets = np.arange(0, n * (n - 1) + 1, n - 1, dtype=np.int64)
    partners = np.array([j for i in range(n) for j in range(n) if j != i], dtype=np.int32)
    return ContactPairs(offsets, partners, np.full(partners.size, VISIT_FROM_POINT | VISIT_FROM_PARTNER, dtype=np.uint8))


def state(y, v=None, volume=None, horizon=None, block=None):
    n = len(y)
    return ContactState(
        np.asarray(y, float), np.zeros((n, 3)) if v is None else np.asarray(v, float),
        np.ones(n) if volume is None else np.asarray(volume, float),
        np.ones(n) if horizon is None else np.asarray(horizon, float),
        np.zeros(n, np.int64) if block is None else np.asarray(block, np.int64), np.arange(n, dtype=np.int64), n,
    )


def model(options=None, **deck):
    deck.setdefault("Contact Radius", 1.0)
    if "Penalty Factor" not in deck:
        deck.setdefault("Contact Stiffness", 2.0)
    return PenaltyContact(PenaltyContactParams.model_validate(deck), options=options)


class Stub:
    """A material that states its elastic constants (what Penalty Factor reads)."""

    def __init__(self, moduli):
        self.moduli = moduli

    def elastic_moduli(self):
        return self.moduli


def test_two_points_follow_perilabs_3d_law():
    """PeriLab: f = c_contact (9 / (pi delta^5)) (R_c - d) V_partner along the line, one visit per pair."""
    rc, c, delta, d = 1.0, 3.0, 2.0, 0.6
    st = state([[0, 0, 0], [d, 0, 0]], volume=[2.0, 5.0], horizon=[delta, delta])
    out = np.zeros((2, 3))
    model(**{"Contact Radius": rc, "Contact Stiffness": c}).force(all_pairs(2), st, out)
    law = c * 9.0 / (math.pi * delta**5) * (rc - d)
    assert out[0, 0] == pytest.approx(-law * 5.0, rel=1e-14)
    assert out[1, 0] == pytest.approx(law * 2.0, rel=1e-14)
    assert np.all(out[:, 1:] == 0.0)


def test_a_pair_of_two_blocks_averages_the_visits_and_one_sided_pairs_get_one():
    delta = np.array([1.0, 1.5])
    st = state([[0, 0, 0], [0, 0, 0.5]], horizon=delta, block=[0, 1])
    out = np.zeros((2, 3))
    m = model(**{"Contact Stiffness": 2.0})
    m.force(all_pairs(2), st, out)
    half = 4.5 * 2.0 / math.pi * 0.5  # 4.5 c / pi times R_c - d
    assert out[1, 2] == pytest.approx(half * (delta[0] ** -5 + delta[1] ** -5), rel=1e-14)
    assert out[0, 2] == -out[1, 2]
    # 0 holds 1 in its bond list: only 1 visits 0, with 1's horizon
    pairs = all_pairs(2)
    pairs.visits = np.array([VISIT_FROM_PARTNER, VISIT_FROM_POINT], np.uint8)
    one = np.zeros((2, 3))
    m.force(pairs, st, one)
    assert one[1, 2] == pytest.approx(half * delta[1] ** -5, rel=1e-14)
    assert one[0, 2] == -one[1, 2]


def test_penalty_factor_scales_each_blocks_bulk_modulus():
    blocks = [("soft", Stub(ElasticModuli(bulk=1.0e9, shear=6.0e8))), ("stiff", Stub(ElasticModuli(bulk=4.0e9, shear=2.4e9)))]
    m = model(options={"blocks": blocks}, **{"Penalty Factor": 2.0})
    assert np.allclose(m.contact_stiffness(), [2.0e9, 8.0e9], rtol=1e-15)
    st = state([[0, 0, 0], [0.4, 0, 0]], block=[0, 1])
    out = np.zeros((2, 3))
    m.force(all_pairs(2), st, out)
    same = np.zeros((2, 3))  # the same pair through the Contact Stiffness of the mean
    model(**{"Contact Stiffness": 5.0e9}).force(all_pairs(2), st, same)
    assert np.allclose(out, same, rtol=1e-14)
    # the pair stiffness for the time step estimate: the stiffest block's 9 c / (pi delta^5)
    assert m.pair_stiffness(np.array([2.0]))[0] == pytest.approx(9.0 * 8.0e9 / (math.pi * 32.0), rel=1e-14)


def test_friction_is_mu_times_the_normal_force_against_the_sliding():
    mu = 0.3
    st = state([[0, 0, 0], [0, 0.5, 0]], v=[[2.0, 0, 7.0], [-2.0, 0, 7.0]])
    out = np.zeros((2, 3))
    model(**{"Friction Coefficient": mu}).force(all_pairs(2), st, out)
    assert out[0, 0] < 0 < out[1, 0]
    assert abs(out[0, 0]) == pytest.approx(mu * abs(out[0, 1]), rel=1e-13)
    assert out[0, 2] == 0.0  # the common sliding along z is no relative sliding


@pytest.mark.parametrize(
    "deck, key",
    [
        ({"Contact Radius": 1.0}, "Contact Stiffness"),  # no stiffness
        ({"Contact Radius": 1.0, "Contact Stiffness": 1.0, "Penalty Factor": 1.0}, "Penalty Factor"),  # both
        ({"Contact Radius": 0.0, "Contact Stiffness": 1.0}, "Contact Radius"),
        ({"Contact Radius": float("nan"), "Contact Stiffness": 1.0}, "Contact Radius"),
        ({"Contact Radius": 1.0, "Contact Stiffness": -1.0}, "Contact Stiffness"),
        ({"Contact Radius": 1.0, "Contact Stiffness": float("inf")}, "Contact Stiffness"),
        ({"Contact Radius": 1.0, "Penalty Factor": 0.0}, "Penalty Factor"),
        ({"Contact Radius": 1.0, "Contact Stiffness": 1.0, "Friction Coefficient": -0.2}, "Friction Coefficient"),
        ({"Contact Radius": 1.0, "Contact Stiffness": 1.0, "Horizon": 2.0}, "Horizon"),
        ({"Contact Radius": 1.0, "Contact Stiffness": 1e200}, "Contact Stiffness"),
        ({"Contact Radius": 1.0, "Spring Constant": 1.0}, "Spring Constant"),  # Short Range Force's key
    ],
)
def test_bad_parameters_are_refused_naming_the_key(deck, key):
    with pytest.raises(ValueError, match=key):
        PenaltyContactParams.model_validate(deck)


def test_penalty_factor_needs_moduli_and_planar_blocks_are_refused():
    with pytest.raises(InputError, match="states none"):
        model(options={"blocks": [("b", Stub(None))]}, **{"Penalty Factor": 1.0})
    with pytest.raises(InputError, match="without its blocks"):
        model(**{"Penalty Factor": 1.0})
    planar = ElasticModuli(bulk=1e9, shear=5e8, planar="plane stress", thickness=0.01)
    with pytest.raises(InputError, match="planar"):
        model(options={"blocks": [("plate", Stub(planar))]})


def penalty_boxes(**contact):
    tree = two_boxes(final=0.06)
    tree["Contact"]["Models"] = {"Springs": {"Contact Model": "Penalty Contact", "Contact Radius": 0.8, **contact}}
    return tree


@pytest.mark.parametrize(
    "contact, expected",
    [
        ({}, "Contact Stiffness"),
        ({"Penalty Factor": 1.0, "Contact Stiffness": 1e9}, "Penalty Factor"),
        ({"Penalty Factor": "two"}, "Penalty Factor"),
        ({"Penalty Factor": True}, "Penalty Factor"),
    ],
)
def test_bad_deck_is_one_line_exit_2(tmp_path, capsys, contact, expected):
    assert run(tmp_path, penalty_boxes(**contact), "-q") == ExitCode.INPUT_ERROR
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and expected in err[0] and "deck.yaml" in err[0], err


def test_a_run_bounces_and_the_penalty_factor_is_the_contact_stiffness_it_implies(tmp_path):
    """Two boxes of K = 1 GPa closing at 40 m/s: Penalty Factor 2 and Contact Stiffness 2 GPa are
    the same run; the boxes bounce, and linear momentum is conserved."""
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    assert run(a, penalty_boxes(**{"Penalty Factor": 2.0}), "-q") == ExitCode.OK
    assert run(b, penalty_boxes(**{"Contact Stiffness": 2.0e9}), "-q") == ExitCode.OK
    va, vb = read(a, "Velocity"), read(b, "Velocity")
    assert np.array_equal(va, vb)
    left = slice(0, 64)  # the Left box's points come first (4 x 4 x 4)
    assert va[0, left, 0].mean() == pytest.approx(20.0) and va[-1, left, 0].mean() < -5.0  # it bounced
    assert abs(va[-1, :, 0].sum()) <= 1e-9 * np.abs(va[-1, :, 0]).sum()  # equal masses: sum of velocities


def test_the_gpu_takes_the_deck(tmp_path):
    """Penalty Contact has its force as a point law every backend compiles (the simulated GPU's
    run against the CPU's: tests/unit/solvers/explicit/test_verlet_gpu.py)."""
    from peridyn.gpu.support import gpu_problems
    from peridyn.testing import build_simulation

    sim = build_simulation(penalty_boxes(**{"Contact Stiffness": 1e9}), directory=tmp_path)
    assert [what for path, what in gpu_problems(sim) if path == ("Contact",)] == []


def test_too_stiff_penalty_springs_are_named_at_set_up_and_when_the_run_goes_unstable(tmp_path, capsys):
    """Penalty Factor 2e4 (c = 2e4 K: Short Range Force springs of k = 1e4 K) with Safety Factor 0.9."""
    tree = penalty_boxes(**{"Penalty Factor": 2.0e4})
    tree["Solver"]["Verlet"]["Safety Factor"] = 0.9
    code = run(tmp_path, tree)
    lines = capsys.readouterr().err.splitlines()
    assert any("contact springs (Spring Constant 1e+04 times the smallest bulk modulus)" in w for w in lines), lines
    assert code == ExitCode.UNSTABLE
    error = [w for w in lines if "unstable" in w]
    assert error and "1e+04 times the bulk modulus" in error[-1] and "'Contact Stiffness' or 'Penalty Factor'" in error[-1], error


def test_a_planar_block_is_one_line_exit_2(tmp_path, capsys):
    tree = penalty_boxes(**{"Penalty Factor": 2.0})
    tree["Materials"]["M"] = {"Material Model": "Elastic Bond Based", "Density": 1000.0, "Bulk Modulus": 1e9, "Plane Stress": True, "Height": 1.0}
    assert run(tmp_path, tree, "-q") == ExitCode.INPUT_ERROR
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and "planar" in err[0] and "Contact Model" in err[0] and "deck.yaml" in err[0], err
