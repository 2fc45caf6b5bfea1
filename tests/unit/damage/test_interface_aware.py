"""Interface Aware damage: the smaller critical stretch of a bond's two ends, neighbors without
the model left alone, bond damage that is never reset, the rank-deficiency rule, and the
conformance kit."""
import logging
import math
from typing import ClassVar

import numpy as np
import pytest
from pydantic import ValidationError

from peridyn.damage.interface_aware import InterfaceAwareParams
from peridyn.testing import DamageConformance, build_simulation

PALS = {"Material Model": "Pals", "Density": 7800.0, "Young's Modulus": 200.0e9, "Poisson's Ratio": 0.3}


def bar(tmp_path, *, s_c1=0.1, s_c2=0.3, second_damaged=True):
    """A 6 x 2 x 2 lattice bar (spacing 1, horizon 1.5: axial, lateral and face-diagonal bonds),
    block_1 for x < 3 with critical stretch s_c1, block_2 for x >= 3 with s_c2 (or no damage
    model)."""
    lines = [f"{x} {y} {z} {1 if x < 3 else 2} 1.0" for x in range(6) for y in range(2) for z in range(2)]
    (tmp_path / "bar.txt").write_text("\n".join(lines) + "\n")
    tree = {
        "Discretization": {"Type": "Text File", "Input Mesh File": "bar.txt"},
        "Materials": {"M": dict(PALS)},
        "Damage Models": {"D1": {"Damage Model": "Interface Aware", "Critical Stretch": s_c1},
                          "D2": {"Damage Model": "Interface Aware", "Critical Stretch": s_c2}},
        "Blocks": {
            "B1": {"Block Names": "block_1", "Material": "M", "Horizon": 1.5, "Damage Model": "D1"},
            "B2": {"Block Names": "block_2", "Material": "M", "Horizon": 1.5, **({"Damage Model": "D2"} if second_damaged else {})},
        },
    }
    if not second_damaged:
        del tree["Damage Models"]["D2"]
    return build_simulation(tree, directory=tmp_path)


def expected_bond_damage(sim, y, critical):
    """Broken (1) or intact (0) for every bond, by the rule of PERIDIGM_MODELS.md §8.1 written
    out in Python; ``critical`` is each point's critical stretch (0: no model)."""
    x = sim.fields["Model_Coordinates"]
    nl = sim.bonds
    d = np.zeros(nl.num_bonds)
    for i in range(sim.num_owned):
        if critical[i] == 0.0:
            continue  # a point without the model: its bonds are not this model's
        for b in range(nl.offsets[i], nl.offsets[i + 1]):
            j = nl.neighbors[b]
            if critical[j] == 0.0:
                continue
            L0 = np.linalg.norm(x[j] - x[i])
            s = (np.linalg.norm(y[j] - y[i]) - L0) / L0
            d[b] = 1.0 if s > min(critical[i], critical[j]) else 0.0
    return d


def stretch(sim, strain):
    x = sim.fields["Model_Coordinates"]
    y = x.copy()
    y[:, 0] *= 1.0 + strain
    sim.fields["Coordinates"][:] = y
    return y


def test_params():
    assert InterfaceAwareParams.model_validate({"Critical Stretch": 0.1}).thermal_expansion_coefficient is None
    with pytest.raises(ValidationError):
        InterfaceAwareParams.model_validate({})
    with pytest.raises(ValidationError):
        InterfaceAwareParams.model_validate({"Critical Stretch": -0.1})


def test_a_bond_breaks_at_the_smaller_critical_stretch_of_its_ends(tmp_path):
    sim = bar(tmp_path)
    x = sim.fields["Model_Coordinates"]
    critical = np.where(x[:, 0] < 3, 0.1, 0.3)
    np.testing.assert_array_equal(sim.fields["Critical_Stretch"], critical)
    # axial bonds stretch by 0.2, face diagonals in the x-y and x-z planes by 0.1045
    y = stretch(sim, 0.2)
    sim.evaluate_forces()
    d = np.asarray(sim.fields["Bond_Damage"], dtype=float)
    want = expected_bond_damage(sim, y, critical)
    np.testing.assert_array_equal(d, want)
    nl = sim.bonds
    # by hand: an axial bond inside block_2 holds (0.2 < 0.3), one crossing the interface breaks
    # from both sides (0.2 > min(0.1, 0.3)), a diagonal inside block_1 breaks (0.1045 > 0.1)
    def bond(p, q):
        i = int(np.flatnonzero(np.all(x == p, axis=1))[0])
        j = int(np.flatnonzero(np.all(x == q, axis=1))[0])
        k = nl.offsets[i] + int(np.flatnonzero(nl.neighbors[nl.offsets[i] : nl.offsets[i + 1]] == j)[0])
        return d[k]
    assert bond((3, 0, 0), (4, 0, 0)) == 0.0
    assert bond((2, 0, 0), (3, 0, 0)) == 1.0 and bond((3, 0, 0), (2, 0, 0)) == 1.0
    assert bond((0, 0, 0), (1, 1, 0)) == 1.0 and bond((4, 0, 0), (5, 1, 0)) == 0.0
    assert bond((0, 0, 0), (0, 1, 1)) == 0.0  # no stretch across the bar
    n = np.diff(nl.offsets[: sim.num_owned + 1])
    broken = np.add.reduceat(d, nl.offsets[: sim.num_owned])
    np.testing.assert_array_equal(sim.fields["Damage"][: sim.num_owned], broken / n)
    assert math.isclose((math.sqrt(1.2**2 + 1) - math.sqrt(2)) / math.sqrt(2), 0.1045, abs_tol=1e-4)


def test_neighbors_without_the_model_are_left_alone(tmp_path):
    sim = bar(tmp_path, second_damaged=False)
    x = sim.fields["Model_Coordinates"]
    critical = np.where(x[:, 0] < 3, 0.1, 0.0)
    np.testing.assert_array_equal(sim.fields["Critical_Stretch"], critical)
    y = stretch(sim, 0.2)
    sim.evaluate_forces()
    d = np.asarray(sim.fields["Bond_Damage"], dtype=float)
    np.testing.assert_array_equal(d, expected_bond_damage(sim, y, critical))
    nl = sim.bonds
    i = int(np.flatnonzero(np.all(x == (2, 0, 0), axis=1))[0])
    for b in range(nl.offsets[i], nl.offsets[i + 1]):
        if x[nl.neighbors[b], 0] >= 3:
            assert d[b] == 0.0  # stretched by 0.2 > 0.1, but the neighbor has no critical stretch


def test_bond_damage_is_never_reset(tmp_path):
    """Bonds broken by one evaluation stay broken in the next ones of the same step (a trial
    configuration leaves them behind, as in Peridigm) and after the step is completed."""
    sim = bar(tmp_path)
    stretch(sim, 0.2)
    sim.evaluate_forces()
    d = np.asarray(sim.fields["Bond_Damage"], dtype=float).copy()
    damage = sim.fields["Damage"].copy()
    assert d.sum() > 0
    stretch(sim, 0.0)
    sim.evaluate_forces()
    np.testing.assert_array_equal(sim.fields["Bond_Damage"], d)
    sim.advance()
    sim.evaluate_forces()
    np.testing.assert_array_equal(sim.fields["Bond_Damage"], d)
    np.testing.assert_array_equal(sim.fields["Damage"], damage)


def test_rank_deficient_points_lose_all_their_bonds(tmp_path, caplog):
    """A point with at most two intact bonds has all of them broken and is reported once."""
    sim = bar(tmp_path)
    nl = sim.bonds
    model = sim.blocks[0].damage
    i = 0
    lo, hi = nl.offsets[i], nl.offsets[i + 1]
    assert hi - lo > 3
    for arr in (sim.fields["Bond_Damage"], sim.fields.n("Bond_Damage")):
        arr[lo : hi - 2] = 1  # two intact bonds left
    with caplog.at_level(logging.WARNING, logger="peridyn.damage"):
        sim.evaluate_forces()
    assert np.all(sim.fields["Bond_Damage"][lo:hi] == 1)
    assert sim.fields["Damage"][i] == 1.0
    assert model.rank_deficient[i] == 1 and model.rank_deficient.sum() == 1
    np.testing.assert_array_equal(model.take_new_rank_deficient(), [i])
    assert "RANK_DEFICIENT_NODES" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="peridyn.damage"):
        sim.evaluate_forces()
    assert model.take_new_rank_deficient().size == 0 and not caplog.text
    # three intact bonds: not rank deficient
    j = 1
    lo, hi = nl.offsets[j], nl.offsets[j + 1]
    for arr in (sim.fields["Bond_Damage"], sim.fields.n("Bond_Damage")):
        arr[lo : hi - 3] = 1
    sim.evaluate_forces()
    assert model.rank_deficient[j] == 0
    np.testing.assert_allclose(sim.fields["Damage"][j], (hi - lo - 3) / (hi - lo))


class TestInterfaceAwareWithElastic(DamageConformance):
    damage = "Interface Aware"
    params: ClassVar[dict] = {"Critical Stretch": 0.06}  # above the kit's first, uniform 5 % stretch: this model never resets within a step


class TestInterfaceAwareWithPals(DamageConformance):
    damage = "Interface Aware"
    params: ClassVar[dict] = {"Critical Stretch": 0.06}  # above the kit's first, uniform 5 % stretch: this model never resets within a step
    material = "Pals"
    material_params: ClassVar[dict] = {"Density": 1000.0, "Bulk Modulus": 1.0e9, "Shear Modulus": 0.4e9}


def test_thermal_strain_of_the_owner_point_by_hand():
    """s = (L - a_T dT_i L0 - L0)/L0 with the owner's temperature change: one bond, two ends."""
    from peridyn.damage.interface_aware import interface_aware_kernel

    offsets = np.array([0, 1, 2])
    neighbors = np.array([1, 0], dtype=np.int32)
    zeta = np.array([1.0, 1.0])
    y = np.array([[0.0, 0.0, 0.0], [1.2, 0.0, 0.0]])  # stretch 0.2
    critical = np.array([0.1, 0.1])
    d_n = np.zeros(2, np.uint8)
    d = np.zeros(2, np.uint8)
    flags = np.ones(2, np.uint8)  # registered already: the rank-deficiency rule is not applied again
    new = np.zeros(2, np.uint8)
    damage = np.zeros(2)
    dT = np.array([3.0, 0.0])  # point 0: 0.2 - 0.05 * 3 = 0.05 < 0.1; point 1: 0.2 > 0.1
    interface_aware_kernel(0, 2, offsets, neighbors, zeta, y, 0.1, critical, d_n, d, dT, 0.05, flags, new, damage)
    np.testing.assert_array_equal(d, [0, 1])
    np.testing.assert_array_equal(damage, [0.0, 1.0])
    # one neighbour each (n <= 2): both points are rank deficient and lose their bond
    interface_aware_kernel(0, 2, offsets, neighbors, zeta, y, 0.1, critical, d_n, d, dT, 0.05, np.zeros(2, np.uint8), new, damage)
    np.testing.assert_array_equal(damage, [1.0, 1.0])
