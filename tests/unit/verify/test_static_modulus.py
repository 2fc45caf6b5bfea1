"""``static-modulus``: the bands pass on the engine and fail when a material's shear modulus is
off (the moduli are the physics the tensile test measures)."""
import json

import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.verify.problems.static import E0, K, MU, SURFACE, lps_prediction


def test_lps_prediction_is_lattice_plus_surface():
    from peridyn.testing.tensile import lattice_youngs_modulus

    assert lps_prediction(4.015, 2.0) == pytest.approx(lattice_youngs_modulus(K, MU, 4.015) + SURFACE * E0 / 2.0)
    # Peridigm's example size (4.015 spacings, about two horizons across): about +19.6 %
    assert lps_prediction(4.015, 9 / 4.015) / E0 - 1 == pytest.approx(0.198, abs=0.005)


def run(tmp_path):
    code = main(["verify", "--quick", "--problems", "static-modulus", "--out", str(tmp_path)])
    entry = json.loads((tmp_path / "results.json").read_text())["problems"][0]
    return code, entry


@pytest.mark.parametrize("scale", [1.1, 0.9])
def test_a_ten_percent_wrong_shear_modulus_fails_both_materials(tmp_path, monkeypatch, scale):
    """G 10 % off moves E by 8.6 %: past the correspondence's 2 % band around E0 and the LPS
    band of 3 % around its lattice-plus-surface prediction, at every ratio."""
    from .test_elasticity import wrong_shear_modulus

    wrong_shear_modulus(monkeypatch, scale)
    code, entry = run(tmp_path)
    assert code == ExitCode.FAILURE
    assert all("failure" not in p for p in entry["points"])
    assert not any(c["passed"] for c in entry["checks"]), entry["checks"]
    assert {c["method"] for c in entry["checks"]} == {"Elastic Correspondence", "Elastic"}
