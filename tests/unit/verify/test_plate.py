"""``one-layer-plate``: a strip one point thick against plane stress and its own bond sums."""
import pytest

from peridyn.testing.tensile import tensile_bar
from peridyn.verify.problems import plate
from peridyn.verify.problems.lattice import lattice_stiffness
from peridyn.verify.problems.plate import OneLayerPlate
from peridyn.verify.problems.prism import prismatic_bar_modulus


def test_the_one_layer_bond_sums_tend_to_the_plates_lattice_modulus_as_the_strip_widens():
    import numpy as np

    K = 54.0e9
    S = lattice_stiffness("Elastic Bond Based", K, 0.0, 3.015, planar=True)
    C = S[np.ix_([0, 1, 5], [0, 1, 5])]
    plate_modulus = 1.0 / np.linalg.inv(C)[0, 0]
    e = [prismatic_bar_modulus(K, 0.0, 3.015, n, 1, model="Elastic Bond Based") / plate_modulus - 1.0 for n in (13, 25, 49)]
    assert e[0] < e[1] < e[2] < 0.0 and e[1] / e[2] == pytest.approx(2.0, rel=0.15)  # the free edges' share, as 1/n


def test_a_strip_one_point_thick_has_one_layer(tmp_path):
    bar = tensile_bar(plate.MATERIALS["Elastic, 3D on one layer"], tmp_path, ratio=3.015, horizon=1e-3, section=4.0, layers=1)
    assert bar.num_points % bar.points_across == 0 and bar.section_area == pytest.approx(bar.points_across * bar.spacing**2)
    with pytest.raises(ValueError, match="odd"):
        tensile_bar(plate.MATERIALS["Elastic, 3D on one layer"], tmp_path, ratio=3.015, horizon=1e-3, layers=2)


def test_both_plates_meet_their_bond_sums_and_the_lps_plates_stiffness_is_a_known_miss(monkeypatch):
    problem = OneLayerPlate()
    diagnosed = problem.measure(plate.DIAGNOSED, 3.015, True)
    check = problem.checks(plate.DIAGNOSED, [{"resolution": 3.015, "error": None, "values": diagnosed.values}], True)[0]
    assert check.passed and "shape tensor" in diagnosed.values["message"]
    for method in (m for m in problem.methods if m != plate.DIAGNOSED):
        m = problem.measure(method, 3.015, True)
        strip, continuum = problem.checks(method, [{"resolution": 3.015, "error": m.error, "values": m.values}], True)
        assert strip.passed, (method, strip.value)
        assert continuum.passed is (method != "Elastic, 3D on one layer") and (continuum.known is None) is continuum.passed
    stiffer = dict(plate.MATERIALS["Elastic Bond Based, plane stress"], **{"Young's Modulus": 1.05 * plate.E_BB})
    monkeypatch.setitem(plate.MATERIALS, "Elastic Bond Based, plane stress", stiffer)  # the model 5 % stiff, the reference not
    m = problem.measure("Elastic Bond Based, plane stress", 3.015, True)
    strip = problem.checks("Elastic Bond Based, plane stress", [{"resolution": 3.015, "error": m.error, "values": m.values}], True)[0]
    assert not strip.passed and strip.value == pytest.approx(0.05, abs=0.003)
