"""ModelParams refuses what a deck means as nonsense: non-finite numbers, booleans given as
numbers, Python attribute names given as deck keys."""
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pydantic import Field, ValidationError

from peridyn.core.params import DECK_CONTEXT, ModelParams


class P(ModelParams):
    density: float = Field(1.0, alias="Density", gt=0)
    count: int = Field(1, alias="Count", ge=1)
    values: list[float] = Field(default_factory=list, alias="Values")
    horizon: float | str = Field(1.0, alias="Horizon")
    flag: bool = Field(False, alias="Flag")


def deck(data):
    return P.model_validate(data, context={DECK_CONTEXT: True})


@given(st.sampled_from([math.inf, -math.inf, math.nan]), st.sampled_from(["Density", "Horizon"]))
def test_non_finite_numbers_are_refused(value, key):
    with pytest.raises(ValidationError, match="finite"):
        deck({key: value})


def test_non_finite_in_a_list_is_refused():
    with pytest.raises(ValidationError, match="'Values' must be finite"):
        deck({"Values": [1.0, math.nan]})


@pytest.mark.parametrize("key", ["Density", "Count", "Horizon", "Values"])
@pytest.mark.parametrize("value", [True, False])
def test_booleans_are_not_numbers(key, value):
    with pytest.raises(ValidationError, match="must be a number, got the boolean"):
        deck({key: value})


def test_a_boolean_field_takes_booleans():
    assert deck({"Flag": True}).flag is True


def test_python_names_are_not_deck_keys():
    with pytest.raises(ValidationError, match="'density' is not a deck key: write 'Density'"):
        deck({"density": 2.0})
    # code that builds parameters by name (tests, solvers) still may
    assert P.model_validate({"density": 2.0}).density == 2.0


@given(st.floats(min_value=1e-150, max_value=1e150))
def test_finite_values_pass(x):
    assert deck({"Density": x}).density == x


@given(st.one_of(st.floats(min_value=5e-324, max_value=1e-155), st.floats(min_value=1e155, max_value=1e308)))
def test_values_whose_square_is_not_a_double_are_refused(x):
    with pytest.raises(ValidationError, match="'Density' = .* cannot be used: its square (under|over)flows"):
        deck({"Density": x})
