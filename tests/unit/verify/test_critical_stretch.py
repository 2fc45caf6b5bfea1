"""``critical-stretch``: the exact set of bonds broken under a homogeneous stretch; the check fails
when the model's critical stretch and the reference's differ by 10 %."""
import numpy as np
import pytest

from peridyn.verify.problems import critical_stretch as cs


def test_thresholds_are_where_the_bond_stretch_reaches_s_c():
    c2 = np.array([1.0, 0.5, 0.1])
    s = cs.threshold(c2)
    assert s[0] == pytest.approx(cs.S_C, rel=1e-12)
    stretch = np.sqrt(1.0 + (2.0 * s + s * s) * c2) - 1.0
    np.testing.assert_allclose(stretch, cs.S_C, rtol=1e-12)


@pytest.mark.parametrize("method", cs.CriticalStretch.methods)
def test_the_model_breaks_exactly_the_bonds_past_s_c(method):
    p = cs.CriticalStretch()
    m = p.measure(method, 3.015, True)
    assert m.error == 0.0 and m.values["direction classes"] >= 5
    pts = [{"resolution": 3.015, "error": m.error, "values": m.values}]
    assert all(c.passed for c in p.checks(method, pts, True))


@pytest.mark.parametrize("method", cs.CriticalStretch.methods)
def test_a_critical_stretch_ten_percent_off_is_seen(method, monkeypatch):
    exact = cs.threshold
    monkeypatch.setattr(cs, "threshold", lambda c2, s_c=cs.S_C: exact(c2, 1.1 * s_c))
    p = cs.CriticalStretch()
    m = p.measure(method, 3.015, True)
    assert m.error > 0
    assert not p.checks(method, [{"resolution": 3.015, "error": m.error, "values": m.values}], True)[0].passed
