"""JSON Schema (draft 2020-12) of the deck format: the core sections plus every installed plugin's
parameters (``peridyn schema``). Editors use it for completion and validation of YAML decks.

It accepts what the loader (:func:`peridyn.deck.model.parse_deck`) accepts and refuses, key by
key, what the loader refuses: unknown sections and keys, unknown model names, missing required
keys, values of the wrong type or outside a parameter's range. What it cannot see are the checks
that read the mesh, files or several keys at once (a node set's points, a file that does not
exist, 'Plane Strain' with 'Plane Stress', a bound that applies only under some settings), and
a NaN (.nan in YAML), which no JSON Schema keyword can refuse.

The loader selects a model by a key (``Material Model``, a boundary condition's ``Type``, the
solver method present in a solver section), so the schema does too, with ``if``/``then`` on that
key rather than a ``oneOf`` of the models (whose parameters overlap, so a ``oneOf`` matches
several and refuses every deck). Numbers may be written as text (``"72.0e9"``, which YAML 1.1
readers such as PyYAML leave a string) as the loader converts them; booleans as the words the
loader reads as booleans.
"""
from __future__ import annotations

import copy
from typing import Any

from pydantic import TypeAdapter

from ..core.params import IGNORED_KEY_TYPES, reading_field
from ..plugins.manager import get_registry
from .model import (
    IGNORED_TOP_LEVEL,
    RANDOM_SEED_KEY,
    SOLVER_METHOD_ORDER,
    UNSUPPORTED_SECTIONS,
    BlockParams,
    ContactSectionParams,
    DataLoaderParams,
    OutputParams,
)
from .regions import RegionSpec
from .restart import RestartParams

#: a number written as text, as Python's float() and the loader read it
NUMBER_TEXT = r"^\s*[-+]?(\d[\d_]*(\.[\d_]*)?|\.\d[\d_]*)([eE][-+]?\d+)?\s*$"
FLOAT_MAX = 1.7976931348623157e308
INTEGER_TEXT = r"^\s*[-+]?\d[\d_]*(\.0*)?\s*$"
#: the words pydantic reads as booleans (any case)
BOOLEAN_TEXT = r"^([Tt]([Rr][Uu][Ee])?|[Ff]([Aa][Ll][Ss][Ee])?|[Yy]([Ee][Ss])?|[Nn][Oo]?|[Oo][Nn]|[Oo][Ff][Ff]|[01])$"

DISCRETIZATION_KEYS = {
    "Influence Function": {"type": "string", "description": "One, Parabolic Decay, Gaussian, or an expression of zeta and horizon"},
}
BOND_FILTER_KEYS = {
    "Bond Filters": {"type": "object", "description": "named bond filters (Type: Rectangular_Plane, Disk, Exodus Mesh)",
                     "additionalProperties": {"type": "object", "required": ["Type"]}},
    "Omit Bonds Between Blocks": {"enum": ["None", "All"], "description": "All: no bonds between points of different blocks"},
}


def _either_case(name: str) -> str:
    """A regular expression (ECMAScript and Python) matching ``name`` as Peridigm's tidy_string
    does: any case, '_' or ' ' between words, spaces around."""
    out = []
    for ch in name:
        if ch.isalpha():
            out.append(f"[{ch.upper()}{ch.lower()}]")
        elif ch in "_ ":
            out.append("[ _]")
        else:
            out.append("\\" + ch if not ch.isalnum() else ch)
    return "^ *" + "".join(out) + " *$"


def _lenient(js: Any) -> Any:
    """Every number also as text, every boolean also as a word the loader reads (in place)."""
    if isinstance(js, list):
        return [_lenient(v) for v in js]
    if not isinstance(js, dict):
        return js
    out = {k: _lenient(v) for k, v in js.items()}
    kind = out.get("type")
    if kind == "number":  # finite (a JSON Schema cannot refuse NaN: no comparison holds for it)
        out.setdefault("maximum", FLOAT_MAX)
        out.setdefault("minimum", -FLOAT_MAX)
    if kind in ("number", "integer", "boolean"):
        text = {"number": NUMBER_TEXT, "integer": INTEGER_TEXT, "boolean": BOOLEAN_TEXT}[kind]
        keep = {k: out.pop(k) for k in ("title", "description", "default") if k in out}
        return {**keep, "anyOf": [out, {"type": "string", "pattern": text}]}
    return out


class _Builder:
    """Collects the ``$defs`` of the pydantic models it turns into schemas."""

    def __init__(self) -> None:
        self.defs: dict[str, Any] = {}
        self.registry = get_registry()

    def params(self, cls, *, extra: dict[str, Any] | None = None, drop: tuple[str, ...] = ()) -> dict[str, Any]:
        """The schema of a ``Params`` model: its keys by deck name, its ignored keys (any value of
        the type a model that reads them gives them), ``extra`` keys the core handles."""
        js = copy.deepcopy(cls.model_json_schema(by_alias=True, ref_template="#/$defs/{model}"))
        for name, d in js.pop("$defs", {}).items():
            self.defs.setdefault(name, _lenient(d))
        js = _lenient(js)
        props = js.setdefault("properties", {})
        for key in drop:
            props.pop(key, None)
        for key in sorted(cls.ignored_keys):
            annotation = IGNORED_KEY_TYPES.get(key) or reading_field(key)
            value = _lenient(TypeAdapter(annotation).json_schema()) if annotation is not None else {}
            props[key] = {**value, "description": "accepted and ignored, as Peridigm does"}
        props.update(extra or {})
        if "required" in js:
            js["required"] = [k for k in js["required"] if k not in drop]
        js["type"] = "object"
        js.setdefault("additionalProperties", False)
        return js

    def selected(self, kind: str, key: str, *, drop: tuple[str, ...] = (), tidy: bool = False, spaces: bool = False,
                 extra=None) -> dict[str, Any]:
        """An object whose ``key`` names a model of ``kind``, checked against that model's
        parameters. ``tidy``: the name matched as Peridigm's tidy_string (case, '_' or ' ');
        ``spaces``: ' ' may stand for '_' (Compute Class)."""
        branches, patterns, names = [], [], []
        for name, cls in self.registry.all_classes(kind).items():
            if isinstance(cls, Exception) or cls.Params is None:
                continue
            body = self.params(cls.Params, drop=drop, extra=extra(cls) if extra else None)
            body["properties"][key] = {"description": f"selects {name}"} | ({} if tidy or spaces else {"const": name})
            if tidy or spaces:
                pattern = _either_case(name) if tidy else "^" + name.replace("_", "[ _]") + "$"
                patterns.append(pattern)
                test = {"pattern": pattern}
            else:
                names.append(name)
                test = {"const": name}
            branches.append({"if": {"properties": {key: test}, "required": [key]}, "then": body})
        selector = {"type": "string", "anyOf": [{"pattern": p} for p in patterns]} if patterns else {"enum": names}
        selector["description"] = f"the {kind.replace('_', ' ')}: {', '.join(self.registry.names(kind))}"
        return {"type": "object", "required": [key], "properties": {key: selector}, "allOf": branches}

    def discretization(self) -> dict[str, Any]:
        def extra(cls):
            return DISCRETIZATION_KEYS | (BOND_FILTER_KEYS if cls.supports_bond_filters else {})

        return self.selected("discretization", "Type", extra=extra)

    def solver(self) -> dict[str, Any]:
        """The first method present (in Peridigm's order, then plugins') selects the parameters."""
        reg = self.registry
        order = [m for m in SOLVER_METHOD_ORDER if reg.has("solver", m)] + [m for m in reg.names("solver") if m not in SOLVER_METHOD_ORDER]
        chain: dict[str, Any] = {"not": {}, "description": f"a solver section names one method: {', '.join(order)}"}
        for method in reversed(order):
            cls = reg.all_classes("solver").get(method)
            if isinstance(cls, Exception) or cls is None:
                continue
            chain = {"if": {"required": [method], "properties": {method: {"type": "object"}}}, "then": self.params(cls.Params), "else": chain}
        return {"type": "object", **chain}

    def contact(self) -> dict[str, Any]:
        js = self.params(ContactSectionParams)
        js["properties"]["Models"] = {"type": "object", "minProperties": 1, "description": "contact models by name (the first acts)",
                                      "additionalProperties": self.selected("contact", "Contact Model")}
        return js

    def boundary_conditions(self) -> dict[str, Any]:
        node_set = "".join(f"[{c.upper()}{c.lower()}]" if c.isalpha() else "[ _]" for c in "node set")
        regions = RegionSpec.model_json_schema(by_alias=True, ref_template="#/$defs/{model}")
        for name, d in regions.pop("$defs", {}).items():
            self.defs.setdefault(name, _lenient(d))
        self.defs["RegionSpec"].update(minProperties=1, maxProperties=1)  # exactly one region key
        return {
            "type": "object",
            "description": "boundary conditions by name; an entry whose name contains 'Node Set' defines a node set "
                           "(a string of 1-based point numbers, a file name, or a region: docs/regions.md)",
            "patternProperties": {node_set: {"anyOf": [{"type": ["string", "integer"]}, {"$ref": "#/$defs/RegionSpec"}]}},
            "additionalProperties": self.selected("boundary_condition", "Type", tidy=True),
        }


def deck_json_schema() -> dict[str, Any]:
    """The JSON Schema of a deck, with the parameters of every installed plugin."""
    b = _Builder()
    top: dict[str, Any] = {
        "Discretization": b.discretization(),
        "Materials": {"type": "object", "additionalProperties": b.selected("material", "Material Model", drop=("Horizon",))},
        "Damage Models": {"type": "object", "additionalProperties": b.selected("damage", "Damage Model")},
        "Blocks": {"type": "object", "additionalProperties": b.params(BlockParams)},
        "Boundary Conditions": b.boundary_conditions(),
        "Compute Class Parameters": {"type": "object", "additionalProperties": b.selected("compute", "Compute Class", spaces=True)},
        "Data Loader": b.params(DataLoaderParams),
        "Contact": b.contact(),
        "Restart": b.params(RestartParams),
        "Multiphysics": {"description": "Peridigm's number of extra degrees of freedom: 1 (fluid pressure)",
                         "anyOf": [{"const": 1}, {"type": "string", "pattern": INTEGER_TEXT}]},
        RANDOM_SEED_KEY: {
            "type": "integer", "minimum": 0, "maximum": 2**64 - 1, "default": 0,
            "description": "seed of rnd() in expressions: each value is a hash of the seed, the expression's place in the deck, "
                           "the call's position in it and the point's global id (the same on any number of ranks)",
        },
    }
    for key, reason in UNSUPPORTED_SECTIONS.items():
        top[key] = {"not": {}, "description": reason}
    for key, reason in IGNORED_TOP_LEVEL.items():
        annotation = IGNORED_KEY_TYPES.get(key) or reading_field(key)
        top[key] = {**(_lenient(TypeAdapter(annotation).json_schema()) if annotation is not None else {}), "description": f"ignored: {reason}"}
    deck = {
        "type": "object",
        "description": "A peridyn / Peridigm input deck (the top key 'Peridigm' is optional)",
        "properties": top,
        "patternProperties": {
            "Solver": b.solver(),
            "^(?!.*Solver).*Output": b.params(OutputParams),
        },
        "required": ["Discretization", "Materials", "Blocks"],
        "additionalProperties": False,
    }
    b.defs["deck"] = deck
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "peridyn deck",
        "if": {"type": "object", "required": ["Peridigm"]},
        "then": {"type": "object", "properties": {"Peridigm": {"$ref": "#/$defs/deck"}}, "required": ["Peridigm"],
                 "additionalProperties": False},
        "else": {"$ref": "#/$defs/deck"},
        "$defs": b.defs,
    }
