"""Dict decks (``peridyn.Model({...})``) read as the same deck in YAML does: ints among floats,
numpy scalars and arrays are numbers wherever YAML numbers would be, and any value is either
accepted or one InputError (no raw traceback)."""
from __future__ import annotations

import copy

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from peridyn.api.decks import build_deck, plain
from peridyn.core.errors import InputError
from peridyn.deck.files import dump_yaml
from peridyn.deck.model import load_deck

DECK = {
    "Discretization": {"Type": "PdQuickGrid", "NeighborhoodType": "Spherical",
                       "TensorProduct3DMeshGenerator": {"Type": "PdQuickGrid", "X Origin": 0.0, "Y Origin": 0.0, "Z Origin": 0.0,
                                                        "X Length": 0.01, "Y Length": 0.004, "Z Length": 0.002,
                                                        "Number Points X": 10, "Number Points Y": 4, "Number Points Z": 2}},
    "Materials": {"Glass": {"Material Model": "Elastic", "Density": 2440.0, "Young's Modulus": 72.0e9, "Poisson's Ratio": 0.22}},
    "Blocks": {"Plate": {"Block Names": "block_1", "Material": "Glass", "Horizon": 0.003015}},
    "Boundary Conditions": {
        "Left Node Set": {"Half Space": {"Point": [0.002, 0, 0], "Normal": [-1, 0.0, 0]}},
        "Box Node Set": {"Box": {"Min": [0, 0, 0.0], "Max": [0.01, 0.004, 0.002]}},
        "Ring Node Set": {"Cylinder": {"Center": [0.005, 0.002, 0], "Axis": [0, 0, 1.0], "Radius": 0.003}},
        "Hold": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": "x", "Value": "0.0"},
    },
    "Solver": {"Initial Time": 0.0, "Final Time": 1.0e-6, "Verlet": {"Safety Factor": 0.8}},
}


def test_ints_among_floats_read_as_the_same_deck_in_yaml(tmp_path) -> None:
    from_dict = build_deck(copy.deepcopy(DECK))
    file = tmp_path / "deck.yaml"
    text = dump_yaml(plain(DECK))
    assert "[0.002, 0.0, 0.0]" in text and "[-1.0, 0.0, 0.0]" in text
    file.write_text(text.replace("[0.002, 0.0, 0.0]", "[0.002, 0, 0]").replace("[-1.0, 0.0, 0.0]", "[-1, 0.0, 0]"))  # as a user writes it
    from_file = load_deck(file)
    assert from_dict.source.tree == from_file.source.tree
    assert {k: v.value for k, v in from_dict.node_sets.items()} == {k: v.value for k, v in from_file.node_sets.items()}
    assert from_dict.node_sets["LEFT_NODE_SET"].value.half_space.point == [0.002, 0.0, 0.0]


@pytest.mark.parametrize("value", [
    np.array([0.002, 0.0, 0.0]), np.array([0, 0, 0]), [np.float64(0.002), np.int64(0), 0], (0.002, 0, np.float32(0.0)),
    [np.int32(1), 2, 3], np.array([[0.002, 0.0, 0.0]])[0],
])
def test_numpy_scalars_and_arrays_are_numbers(value) -> None:
    tree = copy.deepcopy(DECK)
    tree["Boundary Conditions"]["Left Node Set"]["Half Space"]["Point"] = value
    tree["Discretization"]["TensorProduct3DMeshGenerator"]["Number Points X"] = np.int64(10)
    tree["Blocks"]["Plate"]["Horizon"] = np.float32(0.003015)
    deck = build_deck(tree)
    point = deck.source.tree["Boundary Conditions"]["Left Node Set"]["Half Space"]["Point"]
    assert point == [float(v) for v in np.asarray(value).tolist()]


def test_numbers_among_strings_read_as_yaml_reads_them() -> None:
    assert plain(["a", 1, 2.5]) == ["a", "1", "2.5"]
    assert plain([1, 2]) == [1, 2] and plain([1, 2.0]) == [1.0, 2.0] and plain([True, 1]) == [True, 1]


@pytest.mark.parametrize("value, words", [
    ([True, 0, 0], "Point"), ([None, 0, 0], "Point"), ({1, 2}, "set"), (object(), "object"), (2**40, "Point"),
    ([0.002, 0, "z"], "Point"), ([float("nan"), 0, 0], "Point"),
])
def test_values_no_deck_holds_are_one_input_error(value, words) -> None:
    tree = copy.deepcopy(DECK)
    tree["Boundary Conditions"]["Left Node Set"]["Half Space"]["Point"] = value
    with pytest.raises(InputError) as info:
        build_deck(tree)
    assert words in info.value.one_line() and "<python deck>" in info.value.one_line()


def test_a_top_key_that_is_not_a_section_is_an_input_error() -> None:
    with pytest.raises(InputError, match="Peridigm"):
        build_deck({"Peridigm": [1, 2]})


PATHS = [("Boundary Conditions", "Left Node Set", "Half Space", "Point"), ("Boundary Conditions", "Box Node Set", "Box", "Max"),
         ("Boundary Conditions", "Ring Node Set", "Cylinder", "Radius"), ("Boundary Conditions", "Ring Node Set", "Cylinder", "Axis"),
         ("Blocks", "Plate", "Horizon"), ("Discretization", "TensorProduct3DMeshGenerator", "Number Points X"),
         ("Materials", "Glass", "Density"), ("Solver", "Final Time"), ("Boundary Conditions", "Hold", "Value"),
         ("Boundary Conditions", "Left Node Set"), ("Solver", "Verlet")]

scalars = st.one_of(st.none(), st.booleans(), st.integers(-2**40, 2**40), st.floats(allow_nan=True, allow_infinity=True),
                    st.text(max_size=6), st.sampled_from([np.float64(0.5), np.int64(3), np.float32(1e-3), np.bool_(True)]))
values = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.tuples(inner, inner, inner),
    st.builds(np.array, st.lists(st.floats(-1.0, 1.0), min_size=1, max_size=4)),
    st.builds(np.array, st.lists(st.integers(-3, 3), min_size=1, max_size=4)),
    st.dictionaries(st.one_of(st.text(max_size=5), st.integers(0, 3)), inner, max_size=3)), max_leaves=8)


@settings(max_examples=150, deadline=None)
@given(path=st.sampled_from(PATHS), value=values)
def test_any_value_anywhere_is_accepted_or_one_input_error(path, value) -> None:
    tree = copy.deepcopy(DECK)
    node = tree
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    try:
        deck = build_deck(tree)
    except InputError as exc:  # one line per problem, each naming the dict deck
        assert all("<python deck>" in line for line in exc.one_line().splitlines())
        return
    assert deck.source.tree  # accepted: validated as the same deck in a file


@settings(max_examples=50, deadline=None)
@given(tree=st.dictionaries(st.text(max_size=8), values, max_size=4))
def test_any_tree_is_accepted_or_one_input_error(tree) -> None:
    with pytest.raises(InputError):
        build_deck(tree)  # no Discretization / Materials: never a valid deck
