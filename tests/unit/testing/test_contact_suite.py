"""Every built-in contact model passes the contact conformance suite, and the suite catches a
model that breaks momentum or writes to its partners."""
import numpy as np
import pytest

from peridyn.contact.short_range import ShortRangeForce
from peridyn.testing import ContactConformance


class TestShortRangeForce(ContactConformance):
    contact_model = "Short Range Force"
    params = {"Contact Radius": 0.2, "Spring Constant": 1e12}


class TestShortRangeForceWithFriction(ContactConformance):
    contact_model = "Short Range Force"
    params = {"Contact Radius": 0.2, "Spring Constant": 1e12, "Friction Coefficient": 0.4}


class TestTimeDependentShortRangeForce(ContactConformance):
    contact_model = "Time Dependent Short Range Force"
    params = {"Contact Radius": 0.2, "Spring Constant": 1e9, "Friction Coefficient": "0.3 + 0*t"}


class _OneSided(ShortRangeForce):
    """A bug: forces only on points with a lower index than their partner."""

    def force(self, pairs, state, out):
        super().force(pairs, state, out)
        out[state.num_owned // 2:] = 0.0


class _Scatter(ShortRangeForce):
    """A bug: each row also writes its reaction into the partner's row."""

    def force(self, pairs, state, out):
        mine = np.zeros_like(out)
        super().force(pairs, state, mine)
        out += mine
        for i in range(state.num_owned):
            for q in range(pairs.offsets[i], pairs.offsets[i + 1]):
                j = pairs.partners[q]
                if j < state.num_owned:
                    out[j] += 1e-3 * mine[i]


@pytest.mark.parametrize("bug, check", [(_OneSided, "test_linear_momentum_is_conserved"), (_Scatter, "test_rows_can_be_computed_apart")])
def test_the_suite_catches_a_broken_model(bug, check, monkeypatch):
    suite = TestShortRangeForce()
    monkeypatch.setattr(suite, "model", lambda params=None: bug(bug.Params.model_validate(suite.params)))
    with pytest.raises(AssertionError):
        getattr(suite, check)()
