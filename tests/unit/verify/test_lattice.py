"""``lattice-constants`` and the interior-constant checks of ``poisson-ratio`` and
``static-modulus``: the elastic constants read from the model's own forces of quadratic fields
match the closed-form bond sums, and a wrong modulus or micromodulus shows."""
import pytest

from peridyn.verify.problems.lattice import INTERIOR_BAND, LatticeConstants, interior_values, lattice_stiffness


def test_lattice_constants_from_the_forces_match_the_bond_sums_and_see_a_wrong_modulus():
    mat = {"Material Model": "Elastic Bond Based", "Density": 1000.0, "Bulk Modulus": 1.0e9}
    key = "interior constants: worst |C/C_lattice - 1|"
    good = interior_values("Elastic Bond Based", mat, 1.0e9, 0.0, 2.515, 1.0)
    assert good[key] < INTERIOR_BAND
    assert good["nu (interior forces)"] == pytest.approx(0.25, abs=0.05)
    wrong = interior_values("Elastic Bond Based", dict(mat, **{"Bulk Modulus": 1.01e9}), 1.0e9, 0.0, 2.515, 1.0)
    assert wrong[key] == pytest.approx(0.01, rel=1e-4)




def test_lattice_constants_quick_passes_and_a_2d_micromodulus_five_percent_off_fails(monkeypatch):
    p = LatticeConstants()
    for method in p.methods:
        m = p.measure(method, 3.015, True)
        assert p.checks(method, [{"resolution": 3.015, "error": m.error, "values": m.values}], True)[0].passed, (method, m.values)
    material = p.material

    def stiffer(method, ratio):  # a plate whose Height is 5 % too small: the 2D micromodulus 12 K / (pi t delta^3) 5 % too large
        mat = material(method, ratio)
        if method == p.PLANAR:
            mat["Height"] /= 1.05
        return mat

    monkeypatch.setattr(p, "material", stiffer)
    m = p.measure(p.PLANAR, 3.015, True)
    assert m.error == pytest.approx(0.05, rel=1e-3)
    assert not p.checks(p.PLANAR, [{"resolution": 3.015, "error": m.error, "values": m.values}], True)[0].passed


def test_the_planar_bond_sums_are_the_plates_and_refuse_lps():
    C = lattice_stiffness("Elastic Bond Based", 1.0, 0.0, 40.015, planar=True)
    # the continuum plate, c = 12 K / (pi t delta^3): C11 = c t pi delta^3 / 8 = 1.5 K, C12 = C66 = 0.5 K (nu = 1/3,
    # the plate's bulk modulus (C11 + C12) / 2 = K); the lattice tends to it as delta/h grows
    assert C[0, 0] == pytest.approx(1.5, rel=1e-2) and C[0, 1] == pytest.approx(0.5, rel=1e-2)
    assert C[5, 5] == pytest.approx(C[0, 1], rel=1e-12)
    with pytest.raises(ValueError, match="Bond Based only"):
        lattice_stiffness("Elastic", 1.0, 0.5, 3.015, planar=True)
