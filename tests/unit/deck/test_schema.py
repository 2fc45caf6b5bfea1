"""``peridyn schema`` under a JSON Schema validator: it accepts every deck the loader accepts
(every example, every reference case, trees read by PyYAML, which leaves 72.0e9 a string) and
refuses, as the loader does, unknown sections, keys and models, missing required keys, and
values of the wrong type or outside a parameter's range."""
from __future__ import annotations

import copy
import math
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from peridyn.core.errors import InputError
from peridyn.deck.files import load_deck_file
from peridyn.deck.model import parse_deck
from peridyn.deck.schema import deck_json_schema
from peridyn.deck.source import DeckSource

jsonschema = pytest.importorskip("jsonschema")

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = sorted((ROOT / "examples").glob("*.yaml"))
CASES = ROOT.parent / "shared" / "conformance" / "cases"
REFERENCE = sorted(CASES.glob("*/*.yaml")) + sorted(CASES.glob("*/*.xml")) if CASES.is_dir() else []


@pytest.fixture(scope="module")
def validator():
    schema = deck_json_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def loader_accepts(tree: dict) -> bool:
    try:
        parse_deck(DeckSource(tree=tree, path=Path("deck.yaml"), fmt="yaml", lines={}))
    except InputError:
        return False
    return True


def deck(tree: dict) -> dict:
    return tree.get("Peridigm", tree)


@pytest.mark.parametrize("path", EXAMPLES + REFERENCE, ids=lambda p: p.name)
def test_every_deck_the_loader_reads_is_valid(validator, path):
    tree = load_deck_file(path).tree
    assert loader_accepts(tree)
    errors = [f"{list(e.path)}: {e.message[:200]}" for e in validator.iter_errors(tree)]
    assert not errors, errors


@pytest.mark.parametrize("path", [p for p in EXAMPLES + REFERENCE if p.suffix == ".yaml"], ids=lambda p: p.name)
def test_decks_as_pyyaml_reads_them_are_valid(validator, path):
    """YAML 1.1 (PyYAML) leaves 72.0e9 and 1.0e-3 without a sign strings; the loader converts them."""
    tree = yaml.safe_load(path.read_text())
    errors = [f"{list(e.path)}: {e.message[:200]}" for e in validator.iter_errors(tree)]
    assert not errors, errors


def _first(section: dict) -> str:
    return next(iter(section))


def _material(d: dict) -> dict:
    return d["Materials"][_first(d["Materials"])]


def _bc(d: dict) -> dict | None:
    return next((v for v in d.get("Boundary Conditions", {}).values() if isinstance(v, dict)), None)


def _solver(d: dict) -> dict:
    return d[next(k for k in d if "Solver" in k)]


MUTATIONS = {
    "unknown section": lambda d: d.__setitem__("Materialz", {}),
    "restart negative frequency": lambda d: d.__setitem__("Restart", {"Restart Frequency": -10}),
    "restart unknown key": lambda d: d.__setitem__("Restart", {"Restart Frequncy": 10}),
    "no Materials": lambda d: d.pop("Materials"),
    "unknown material key": lambda d: _material(d).__setitem__("Densty", 1.0),
    "unknown material model": lambda d: _material(d).__setitem__("Material Model", "Elastc"),
    "material without its model": lambda d: _material(d).pop("Material Model"),
    "negative density": lambda d: _material(d).__setitem__("Density", -1.0),
    "zero density": lambda d: _material(d).__setitem__("Density", 0.0),
    "density as a word": lambda d: _material(d).__setitem__("Density", "heavy"),
    "density as a boolean": lambda d: _material(d).__setitem__("Density", True),
    "density as a list": lambda d: _material(d).__setitem__("Density", [1.0, 2.0]),
    "density infinite": lambda d: _material(d).__setitem__("Density", math.inf),
    "density missing": lambda d: _material(d).pop("Density"),
    "block without material": lambda d: d["Blocks"][_first(d["Blocks"])].pop("Material"),
    "block unknown key": lambda d: d["Blocks"][_first(d["Blocks"])].__setitem__("Horizn", 1.0),
    "unknown discretization": lambda d: d["Discretization"].__setitem__("Type", "Voxels"),
    "discretization unknown key": lambda d: d["Discretization"].__setitem__("Spacng", 1.0),
    "omit bonds other word": lambda d: d["Discretization"].__setitem__("Omit Bonds Between Blocks", "Some"),
    "boundary condition unknown type": lambda d: _bc(d).__setitem__("Type", "Initial Velocityy"),
    "boundary condition unknown key": lambda d: _bc(d).__setitem__("Coordinat", "x"),
    "boundary condition as a number": lambda d: d["Boundary Conditions"].__setitem__("Push", 3.0),
    "solver without method": lambda d: d.__setitem__(next(k for k in d if "Solver" in k), {"Initial Time": 0.0, "Final Time": 1.0}),
    "solver unknown key": lambda d: _solver(d).__setitem__("Final Tme", 1.0),
    "output unknown key": lambda d: d[next(k for k in d if "Output" in k and "Solver" not in k)].__setitem__("Output Frequncy", 1),
    "random seed negative": lambda d: d.__setitem__("Random Seed", -1),
    "random seed text": lambda d: d.__setitem__("Random Seed", "one"),
}


@pytest.mark.parametrize("mutation", list(MUTATIONS))
@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_what_the_loader_refuses_the_schema_refuses(validator, path, mutation):
    tree = copy.deepcopy(load_deck_file(path).tree)
    d = deck(tree)
    if mutation.startswith("boundary condition") and _bc(d) is None or mutation.startswith("output") and not any(
            "Output" in k and "Solver" not in k for k in d):
        pytest.skip("the example has no such section")
    MUTATIONS[mutation](d)
    assert not loader_accepts(tree), f"the loader should refuse: {mutation}"
    assert not validator.is_valid(tree), f"the schema should refuse: {mutation}"


NUMBER_WORDS = st.sampled_from(["72.0e9", "1e3", " 7", "-2.5", "+.5", "1_000", "3.", "0"])
BOOLEAN_WORDS = st.sampled_from(["true", "False", "yes", "no", "on", "off", "1", "0", "t", "N"])
VALUES = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6),
    st.integers(-10, 10**6), st.booleans(), NUMBER_WORDS, BOOLEAN_WORDS, st.text(max_size=6),
    st.lists(st.floats(-10, 10), max_size=3),
)


def _leaves(d: dict, prefix=()):
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _leaves(v, prefix + (k,))
        else:
            yield prefix + (k,)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_the_schema_refuses_no_value_the_loader_accepts(validator, data):
    """Any value put in any parameter of an example: when the loader takes the deck, so does the
    schema (the schema is never stricter than the loader)."""
    path = data.draw(st.sampled_from(EXAMPLES))
    tree = copy.deepcopy(load_deck_file(path).tree)
    d = deck(tree)
    leaves = [p for p in _leaves(d) if p[0] in ("Materials", "Damage Models", "Blocks", "Boundary Conditions", "Discretization", "Contact")
              or "Solver" in p[0] or "Output" in p[0]]
    where = data.draw(st.sampled_from(leaves))
    node = d
    for k in where[:-1]:
        node = node[k]
    node[where[-1]] = data.draw(VALUES)
    if loader_accepts(tree):
        errors = [f"{list(e.path)}: {e.message[:200]}" for e in validator.iter_errors(tree)]
        assert not errors, (where, node[where[-1]], errors)


class _Plugin:
    """A plugin material with one parameter of its own."""

    @staticmethod
    def peridyn_materials():
        return [("Schema Test Material", f"{__name__}:SchemaTestMaterial")]


def test_a_plugin_material_is_checked_with_its_own_parameters(validator):
    from pydantic import Field

    from peridyn.core.interfaces import Material
    from peridyn.core.params import ModelParams
    from peridyn.plugins.hookspecs import hookimpl
    from peridyn.testing import isolated_registry

    class Params(ModelParams):
        density: float = Field(alias="Density", gt=0)
        stiffness: float = Field(alias="Stiffness", gt=0, description="the spring (Pa)")

    global SchemaTestMaterial

    class SchemaTestMaterial(Material):
        name = "Schema Test Material"

    SchemaTestMaterial.Params = Params
    plugin = type("P", (), {"peridyn_materials": staticmethod(hookimpl(_Plugin.peridyn_materials))})
    tree = copy.deepcopy(load_deck_file(EXAMPLES[0]).tree)
    d = deck(tree)
    d["Materials"][_first(d["Materials"])] = {"Material Model": "Schema Test Material", "Density": 1.0, "Stiffness": 2.0}
    assert not validator.is_valid(tree)  # the built-ins' schema does not know it
    with isolated_registry(plugin):
        own = jsonschema.Draft202012Validator(deck_json_schema())
    assert own.is_valid(tree)
    d["Materials"][_first(d["Materials"])]["Stiffness"] = -2.0
    assert not own.is_valid(tree)
    d["Materials"][_first(d["Materials"])]["Stiffness"] = 2.0
    d["Materials"][_first(d["Materials"])]["Bulk Modulus"] = 2.0
    assert not own.is_valid(tree)
