"""``j-integral``: the quick points pass their bands, and the bands fail when the J compute uses a
wrong modulus or the damage model a wrong critical stretch. Driven through the runner with the
problem given directly (it is registered in peridyn.verify.problems by the lead)."""
import json
import math

import pytest

from peridyn.core.errors import ExitCode
from peridyn.verify.problems.griffith import E, G0
from peridyn.verify.problems.j_integral import JIntegral, critical_energy_of_stretch, cracked_plate, rings
from peridyn.verify.runner import Run


def test_the_conversion_is_the_damage_models():
    from peridyn.damage.critical_energy import bond_based_critical_stretch

    delta, h = 3.0e-3, 1.0e-3
    c = 9.0 * E / (math.pi * h * delta**3)  # plane-stress bond-based micromodulus, nu = 1/3
    s0 = bond_based_critical_stretch(G0, c, delta, h)
    assert critical_energy_of_stretch(s0, delta) == pytest.approx(G0, rel=1e-12)


def test_the_plate_is_griffiths_with_rings_inside_it():
    tree, g = cracked_plate(3.0)  # a = 9 dx: 46 points across (even), a/b = 0.39
    assert g["a"] == pytest.approx(9e-3) and round(g["W"] / 1e-3) == 46
    for (ri, ro), ring in zip(rings(g["a"], g["delta"]).values(), tree["Compute Class Parameters"].values()):
        assert ring["Inner Radius"] == ri and ring["Outer Radius"] == ro and ring["Crack Tip X"] == g["a"]
        assert ri >= g["delta"] * (1 - 1e-6) and ro < min(2 * g["a"], g["W"] / 2 - g["a"])  # off the tip zone, the other tip, the edge
    with pytest.raises(ValueError, match="whole spacings"):
        cracked_plate(2.5)


def test_quick_points_pass_their_bands(tmp_path):
    assert Run([JIntegral()], tmp_path, quick=True).run() == ExitCode.OK
    entry = json.loads((tmp_path / "results.json").read_text())["problems"][0]
    assert [p["resolution"] for p in entry["points"]] == [2.0, 3.0]
    assert all(c["passed"] for c in entry["checks"]) and len(entry["checks"]) == 7
    for p in entry["points"]:
        v = p["values"]
        assert 0.95 < v["J/(K_I^2/E')"] < 1.0  # measured 0.972, 0.975
        assert 0.95 < v["J_init/G_c"] < 1.07  # measured 0.984, 1.047
    assert entry["rates"] == {"m = 3": None} and "lattice" in entry["unfitted"]["m = 3"]
    assert (tmp_path / "report.md").read_text().count("| pass |") == 7


def one_point(resolution: float = 2.0) -> dict:
    """The checks of one point (a/delta = 2, about a second), by what they say."""
    p = JIntegral()
    m = p.measure(p.methods[0], resolution, True)
    point = {"resolution": resolution, "size": m.size, "error": m.error, "values": m.values}
    return {c.what.split(",")[0].split(" at ")[0]: c for c in p.checks(p.methods[0], [point], True)}


@pytest.mark.parametrize("scale", [0.8, 1.25])
def test_a_modulus_twenty_percent_off_in_j_fails(monkeypatch, scale):
    """The compute's Hooke law with E off by a factor scales J by it: both J bands fail (J/(K^2/E)
    is 0.972 at a/delta = 2, J_init/G_c 0.984), the damage model's checks do not."""
    from peridyn.computes import j_integral

    right = j_integral.elastic_constants

    def wrong(material):
        E_, nu, mode = right(material)
        return scale * E_, nu, mode

    monkeypatch.setattr(j_integral, "elastic_constants", wrong)
    checks = one_point()
    failed = sorted(k for k, c in checks.items() if not c.passed)
    assert failed == ["|J / (K_I^2/E') - 1|", "|J_init / G_c - 1|"], checks


def test_a_critical_stretch_ten_percent_off_fails_the_g_c_check(monkeypatch):
    """s0 10 % high stands for G_c 21 % above the deck's G0; J at the first break follows s0, so
    J_init / G_c(s0) still holds: only the conversion check fails."""
    from peridyn.damage.critical_energy import CriticalEnergy

    bind = CriticalEnergy.bind_material

    def wrong(self, material):
        bind(self, material)
        self.s_c *= 1.1

    monkeypatch.setattr(CriticalEnergy, "bind_material", wrong)
    checks = one_point()
    failed = [k for k, c in checks.items() if not c.passed]
    assert len(failed) == 1 and failed[0].startswith("|G_c(s0) / G0 - 1|"), checks
    assert checks[failed[0]].value == pytest.approx(0.21, rel=1e-9)


def test_the_problem_states_its_reference():
    assert "Tada" in JIntegral.reference and "K_I^2 / E'" in JIntegral.reference and "9 E delta s0^2 / (4 pi)" in JIntegral.reference
    assert JIntegral.name == "j-integral"
