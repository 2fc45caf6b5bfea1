"""A deck given as Python values (peridyn.testing.build_simulation's dicts) is typed as the same
deck in a YAML file: ints among floats ([0.002, 0, 0]), numpy scalars and arrays, tuples; and no
value whatever ends in anything but a valid deck or an InputError."""
from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from peridyn.core.errors import InputError
from peridyn.deck.model import parse_deck
from peridyn.deck.source import DeckSource, typed_tree
from peridyn.deck.yaml_reader import parse_yaml_text
from peridyn.testing import build_simulation, cube_deck

BASE = cube_deck({"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1.0e9, "Shear Modulus": 1.0e9}, n=3, spacing=1.0e-3)
BASE["Boundary Conditions"] = {"Left Node Set": {"Half Space": {"Point": [0.002, 0.0, 0.0], "Normal": [1.0, 0.0, 0.0]}},
                               "Fix": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": "x", "Value": "0"}}
BASE["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0e-8, "Verlet": {"Fixed dt": 1.0e-8}}


def yaml_text(value) -> str:
    """How a person writes ``value`` in a YAML deck (strings quoted)."""
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    return str(value)


leaf = st.one_of(st.integers(-(2**40), 2**40), st.floats(allow_nan=False, allow_infinity=True), st.text(alphabet="abc xyz", min_size=1, max_size=5))


@settings(max_examples=200, deadline=None)
@given(st.lists(leaf, min_size=1, max_size=5))
def test_a_list_is_typed_as_the_same_list_in_yaml(items):
    from_yaml = parse_yaml_text("Key: [" + ", ".join(yaml_text(v) for v in items) + "]\n", "x.yaml").tree["Key"]
    assert typed_tree({"Key": items})["Key"] == from_yaml
    assert [type(v) for v in typed_tree({"Key": items})["Key"]] == [type(v) for v in from_yaml]


@settings(max_examples=100, deadline=None)
@given(leaf)
def test_a_scalar_is_typed_as_the_same_scalar_in_yaml(value):
    from_yaml = parse_yaml_text(f"Key: {yaml_text(value)}\n", "x.yaml").tree["Key"]
    got = typed_tree({"Key": value})["Key"]
    assert got == from_yaml and type(got) is type(from_yaml)


def test_numpy_values_and_tuples_become_plain_values():
    tree = typed_tree({"a": np.int64(3), "b": np.float32(0.5), "c": np.bool_(True), "d": (1, 2.5), "e": np.array([0.002, 0, 0]),
                       "f": np.array([1, 2]), "g": np.array(7.0), 3: "x"})
    assert tree == {"a": 3, "b": 0.5, "c": True, "d": [1.0, 2.5], "e": [0.002, 0.0, 0.0], "f": [1, 2], "g": 7.0, "3": "x"}
    assert [type(tree[k]) for k in "abcg"] == [int, float, bool, float]


def test_ints_among_floats_in_a_region_and_numpy_numbers_build(tmp_path):
    tree = copy.deepcopy(BASE)
    tree["Boundary Conditions"]["Left Node Set"] = {"Half Space": {"Point": [0.002, 0, 0], "Normal": (1, 0, 0)}}
    tree["Discretization"]["TensorProduct3DMeshGenerator"]["Number Points X"] = np.int64(3)
    tree["Materials"]["M"]["Density"] = np.float32(1000.0)
    tree["Materials"]["M"]["Bulk Modulus"] = 1_000_000_000
    sim = build_simulation(tree, directory=tmp_path)
    assert sim.num_global == 27 and len(sim.node_sets["LEFT_NODE_SET"]) == 9


@pytest.mark.parametrize("key, value", [("Density", True), ("Density", [1.0, True]), ("Density", None), ("Bulk Modulus", "1e9 Pa"),
                                        ("Density", {"a": 1}), ("Shear Modulus", float("nan"))])
def test_values_no_yaml_deck_holds_are_input_errors_at_their_path(key, value, tmp_path):
    tree = copy.deepcopy(BASE)
    tree["Materials"]["M"][key] = value
    with pytest.raises(InputError) as info:
        build_simulation(tree, directory=tmp_path)
    assert any(e.path[:2] == ("Materials", "M") for e in getattr(info.value, "errors", [info.value]))


def leaves(tree, path=()):
    for key, value in tree.items():
        if isinstance(value, dict):
            yield from leaves(value, path + (key,))
        yield path + (key,)


scalars = st.one_of(st.integers(-(2**70), 2**70), st.floats(), st.booleans(), st.text(max_size=8), st.none(),
                    st.integers(-100, 100).map(np.int64), st.floats(-1e3, 1e3).map(np.float32), st.booleans().map(np.bool_))
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4), st.lists(inner, max_size=3).map(tuple),
                                                       st.dictionaries(st.text(max_size=6), inner, max_size=3),
                                                       st.lists(st.floats(-1, 1), max_size=4).map(np.array)), max_leaves=6)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(path=st.sampled_from(list(leaves(BASE))), value=values)
def test_any_value_anywhere_is_a_deck_or_an_input_error(path, value, tmp_path):
    tree = copy.deepcopy(BASE)
    holder = tree
    for key in path[:-1]:
        holder = holder[key]
    holder[path[-1]] = value
    try:
        parse_deck(DeckSource(typed_tree(tree), tmp_path / "deck.yaml", "yaml", {}))
    except InputError:
        pass
