"""``static-modulus``: the bands pass on the engine and fail when a material's shear modulus is
off (the moduli are the physics the tensile test measures)."""
import json

import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.verify.problems.static import E0, K, MU, lps_prediction


def test_lps_prediction_is_the_prism_of_the_bars_section_from_the_bond_sums():
    from peridyn.testing.tensile import lattice_youngs_modulus
    from peridyn.verify.problems.prism import surface_coefficient

    # Peridigm's example size (4.015 spacings, 9 points across): +19.0 % (the lattice's -2.5 % and the faces')
    assert lps_prediction(4.015, 9) / E0 - 1 == pytest.approx(0.190, abs=0.001)
    assert lps_prediction(4.015, 9) > lattice_youngs_modulus(K, MU, 4.015)
    # the surface term converges as the section grows (the edges' share falls as 1/n) to the flat faces' 0.48
    s11, s21 = surface_coefficient(K, MU, 2.515, 11, E0), surface_coefficient(K, MU, 2.515, 21, E0)
    assert 0.48 < s21 < s11 < 0.51 and s11 - s21 == pytest.approx(0.0116, abs=0.002)


def run(tmp_path):
    code = main(["verify", "--quick", "--problems", "static-modulus", "--out", str(tmp_path)])
    entry = json.loads((tmp_path / "results.json").read_text())["problems"][0]
    return code, entry


@pytest.mark.parametrize("scale", [1.1, 0.9])
def test_a_ten_percent_wrong_shear_modulus_fails_both_materials(tmp_path, monkeypatch, scale):
    """G 10 % off moves E by 8.6 %: past the correspondence's 2 % band around E0 and the LPS
    band of 1 % around the prism of its section from the bond sums, at every ratio."""
    from .test_elasticity import wrong_shear_modulus

    wrong_shear_modulus(monkeypatch, scale)
    code, entry = run(tmp_path)
    assert code == ExitCode.FAILURE
    assert all("failure" not in p for p in entry["points"])
    assert not any(c["passed"] for c in entry["checks"]), entry["checks"]
    assert {c["method"] for c in entry["checks"]} == {"Elastic Correspondence", "Elastic"}
