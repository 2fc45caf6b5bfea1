"""``kalthoff-winkler``: the quick point passes its bands against the experiment, and a wrong
fracture model (a steel 100 times tougher) fails them; the crack fit on synthetic damage."""
import json
import math

import numpy as np
import pytest

from peridyn.verify.problems.experiments import (
    KW_RAYLEIGH, KalthoffWinkler, crack_angle, crack_points, kalthoff_deck, rayleigh_speed,
)
from peridyn.verify.runner import Run


def _run(tmp_path, problem, *, quick=True):
    rc = Run([problem], tmp_path, quick=quick).run()
    return rc, json.loads((tmp_path / "results.json").read_text())["problems"][0]


def test_rayleigh_speed():
    """c_R / c_s = 0.9194 at nu = 0.25; plane stress at nu = 1/3
    is plane strain at nu = 1/4."""
    E, rho = 200e9, 8000.0
    cs = math.sqrt(E / (2 * 1.25 * rho))
    assert rayleigh_speed(E, 0.25, rho, plane_stress=False) / cs == pytest.approx(0.9194, abs=5e-4)
    cs3 = math.sqrt(190e9 / (2 * (4 / 3) * 8000.0))
    assert KW_RAYLEIGH / cs3 == pytest.approx(0.9194, abs=5e-4)


def test_crack_fit_on_synthetic_damage():
    """A straight crack at 70 degrees from the tip is read as 70; a damaged cluster not connected
    to the tip (a crack from a free edge) and damage below the notch line are left out."""
    h, tip = 1e-3, (0.05, 0.025)
    g = np.arange(0.0, 0.1, h) + h / 2
    X, Y = np.meshgrid(g, g - 0.05 + h / 2)
    x = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    d = x[:, :2] - tip
    u = np.array([math.cos(math.radians(70)), math.sin(math.radians(70))])
    along, across = d @ u, d @ np.array([-u[1], u[0]])
    damage = np.where((along > 0) & (np.abs(across) < 0.75 * h), 0.5, 0.0)
    damage[(x[:, 0] > 0.09) & (np.abs(x[:, 1] - 0.03) < 0.6 * h)] = 0.5  # an edge crack, apart from the tip's
    damage[(d[:, 1] < 0) & (np.abs(d[:, 0] - 0.01) < 0.6 * h)] = 0.5  # below the notch line
    pts = crack_points(x, damage, tip, h, 0.0045, 0.03)
    assert len(pts) > 15
    assert crack_angle(pts, tip) == pytest.approx(70.0, abs=1.5)
    assert np.all(pts[:, 0] < 0.09) and np.all(pts[:, 1] > tip[1])
    assert math.isnan(crack_angle(pts[:2], tip))
    assert len(crack_points(x, np.zeros(len(x)), tip, h, 0.0045, 0.03)) == 0


def test_deck_needs_a_spacing_that_divides_the_notch_offset():
    kalthoff_deck(1e-3)
    with pytest.raises(ValueError):
        kalthoff_deck(0.7e-3)


def test_quick_point_passes_its_bands(tmp_path):
    """dx = 1 mm: a crack grows from the notch tip at about 61 degrees (rising towards the
    experiment's 70 with resolution), well below the Rayleigh speed."""
    rc, entry = _run(tmp_path, KalthoffWinkler())
    assert rc == 0, entry["checks"]
    assert entry["checks"] and all(c["passed"] for c in entry["checks"])
    v = entry["points"][0]["values"]
    assert 55.0 < v["crack angle (deg)"] < 67.0
    assert v["crack length (mm)"] > 40.0
    assert 0.3 < v["crack speed / c_R"] < 0.9


def test_a_hundred_times_tougher_steel_fails(tmp_path, monkeypatch):
    """G_c 100 times larger (s0 ten times): no crack grows, so there is no angle, length or speed
    and every band fails (run at the coarse 20-across point to keep it short)."""
    from peridyn.damage.critical_energy import CriticalEnergy

    bind = CriticalEnergy.bind_material

    def tougher(self, material):
        bind(self, material)
        self.s_c *= 10.0

    monkeypatch.setattr(CriticalEnergy, "bind_material", tougher)
    monkeypatch.setattr(KalthoffWinkler, "ladder", lambda self, method, quick: [20.0])
    rc, entry = _run(tmp_path, KalthoffWinkler())
    assert rc != 0
    failed = [c["what"] for c in entry["checks"] if not c["passed"]]
    assert len(failed) == 3 and len(entry["checks"]) == 3, entry["checks"]
    assert entry["points"][0]["values"]["crack length (mm)"] == 0.0


def test_the_angle_band_tightens_with_resolution():
    p = KalthoffWinkler()
    assert p.angle_band(20.0) == (40.0, 80.0)
    assert p.angle_band(50.0) == (55.0, 80.0)
    assert p.angle_band(100.0) == (62.0, 78.0)
    assert p.ladder(p.methods[0], True) == [50.0]
    assert "Kalthoff" in p.reference and "70" in p.reference
