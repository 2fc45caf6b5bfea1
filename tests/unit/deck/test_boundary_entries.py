"""Entries that are plainly the other kind than their name makes them: a node set (ids, a file
name, a region) under a name without "Node Set" is told to be renamed, and the rename it names
makes the deck valid; a condition (with a Type) under a "... Node Set" name is told the reverse;
a mistyped Type, Compute Class or Material Model key is named with its rename."""
from __future__ import annotations

import copy
import string

import pytest
from hypothesis import given, settings, strategies as st

from peridyn.core.errors import InputError
from peridyn.deck.boundary import looks_like_node_set, node_set_name
from peridyn.deck.model import parse_deck
from peridyn.deck.source import DeckSource
from peridyn.testing import cube_deck

BASE = cube_deck({"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1.0e9, "Shear Modulus": 1.0e9}, n=3, spacing=1.0e-3)
REGION = {"Half Space": {"Point": [0.002, 0.0, 0.0], "Normal": [1.0, 0.0, 0.0]}}


def parse(tree, tmp_path):
    (tmp_path / "ids.txt").write_text("1\n2\n")
    return parse_deck(DeckSource(copy.deepcopy(tree), tmp_path / "deck.yaml", "yaml", {}))


def problems(tree, tmp_path) -> list[InputError]:
    with pytest.raises(InputError) as info:
        parse(tree, tmp_path)
    return list(getattr(info.value, "errors", None) or [info.value])


def with_conditions(entries: dict) -> dict:
    tree = copy.deepcopy(BASE)
    tree["Boundary Conditions"] = entries
    return tree


NODE_SETS = {"ids as text": "1 2 3", "a list of ids": [1, 2, 3], "one id": 4, "a file": "ids.txt", "a region": REGION,
             "a union": {"Union": {"a": REGION, "b": {"All": True}}}}
names = st.text(alphabet=string.ascii_letters + " _", min_size=1, max_size=12).filter(
    lambda n: n.strip(" ") and "NODE_SET" not in n.upper().strip(" ").replace(" ", "_"))


@settings(max_examples=30, deadline=None)
@given(name=names, kind=st.sampled_from(sorted(NODE_SETS)))
def test_a_node_set_without_node_set_in_its_name_is_told_the_rename_that_works(name, kind, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("ns")
    value = NODE_SETS[kind]
    found = problems(with_conditions({name: value}), tmp)
    assert len(found) == 1, [e.one_line() for e in found]
    err = found[0]
    assert err.path == ("Boundary Conditions", name)
    assert "must end in 'Node Set'" in err.message and "missing required key" not in err.message
    renamed = node_set_name(name)
    assert repr(renamed) in err.fix
    if kind == "a list of ids":
        value = "1 2 3"  # a node set's ids are one string; the message for the list under the new name says so
    parse(with_conditions({renamed: value, "Fix": {"Type": "Prescribed Displacement", "Node Set": renamed, "Coordinate": "x", "Value": "0"}}), tmp)


@pytest.mark.parametrize("name, renamed", [("Left", "Left Node Set"), ("LeftNodeSet", "Left Node Set"), ("Left Nodeset", "Left Node Set"),
                                           ("left nodes", "left Node Set"), ("Left_Set", "Left Node Set"), ("Set", "Set Node Set")])
def test_the_suggested_name(name, renamed):
    assert node_set_name(name) == renamed


@pytest.mark.parametrize("value", [{"Type": "Prescribed Displacement", "Node Set": "x", "Coordinate": "x", "Value": "0"}, "Prescribed",
                                   "1 a", True, 2.5, [1.5, 2.0], {}, {"Box": 1, "Type": "x"}, None])
def test_what_does_not_look_like_a_node_set(value):
    assert looks_like_node_set(value) is None


def test_a_list_of_ids_under_a_node_set_name_is_told_to_be_one_string(tmp_path):
    (err,) = problems(with_conditions({"Left Node Set": [1, 2, 3]}), tmp_path)
    assert "'1 2 3'" in err.fix


def test_a_condition_named_as_a_node_set_is_told_to_drop_node_set(tmp_path):
    bc = {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": "x", "Value": "0"}
    (err,) = problems(with_conditions({"Left Node Set": "1 2", "Pull Node Set": bc}), tmp_path)
    assert err.path == ("Boundary Conditions", "Pull Node Set") and "has a 'Type'" in err.message and "'Pull'" in err.fix


@pytest.mark.parametrize("typo", ["type", "TYPE", "Typ", "Tpye", " Type"])
def test_a_mistyped_type_key_is_named(typo, tmp_path):
    bc = {typo: "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": "x", "Value": "0"}
    found = problems(with_conditions({"Left Node Set": "1 2", "Fix": bc}), tmp_path)
    assert any(f"rename {typo!r} to 'Type'" in (e.fix or "") for e in found), [e.one_line() for e in found]


def test_a_condition_without_type_lists_the_types(tmp_path):
    bc = {"Node Set": "Left Node Set", "Coordinate": "x", "Value": "0"}
    (err,) = problems(with_conditions({"Left Node Set": "1 2", "Fix": bc}), tmp_path)
    assert err.message == "missing required key 'Type'" and "Prescribed Displacement" in err.fix.replace("_", " ").title()


@pytest.mark.parametrize("entry, words", [({"compute class": "Block_Data", "Block": "block_1"}, "rename 'compute class' to 'Compute Class'"),
                                          ({"Block": "block_1"}, "add 'Compute Class: <name>'"),
                                          ("Block_Data", "write it as 'Compute Class: <name>'")])
def test_a_compute_without_compute_class(entry, words, tmp_path):
    tree = copy.deepcopy(BASE)
    tree["Compute Class Parameters"] = {"Sum": entry}
    (err,) = problems(tree, tmp_path)
    assert err.path == ("Compute Class Parameters", "Sum") and words in err.fix, err.one_line()


@pytest.mark.parametrize("typo", ["Material model", "MaterialModel", "material_model"])
def test_a_mistyped_material_model_key_is_named(typo, tmp_path):
    tree = copy.deepcopy(BASE)
    material = tree["Materials"]["M"]
    material[typo] = material.pop("Material Model")
    found = problems(tree, tmp_path)
    assert any(e.path == ("Materials", "M") and f"rename {typo!r} to 'Material Model'" in (e.fix or "") for e in found), [e.one_line() for e in found]


def test_valid_node_sets_and_conditions_still_pass(tmp_path):
    deck = parse(with_conditions({"Left Node Set": REGION, "Ids Node Set": "1 2", "File Node Set": "ids.txt",
                                  "Fix": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": "x", "Value": "0"}}), tmp_path)
    assert set(deck.node_sets) == {"LEFT_NODE_SET", "IDS_NODE_SET", "FILE_NODE_SET"} and len(deck.boundary_conditions) == 1
