"""JSON Schema of the deck format: the core sections plus every installed plugin's parameters
(``peridyn schema``). Editors use it for completion and validation of YAML decks."""
from __future__ import annotations

import copy
from typing import Any

from ..plugins.manager import get_registry
from .model import BlockParams, DataLoaderParams, OutputParams


def _model(cls, defs: dict) -> dict:
    js = cls.model_json_schema(by_alias=True, ref_template="#/$defs/{model}")
    defs.update(js.pop("$defs", {}))
    return js


def _selected(cls, key: str, name: str, defs: dict, strip: tuple[str, ...] = ()) -> dict:
    """The Params schema of one model with ``key: name`` added (the key that selects it)."""
    js = copy.deepcopy(_model(cls, defs))
    props = js.setdefault("properties", {})
    for s in strip:
        props.pop(s, None)
    props[key] = {"const": name, "description": f"selects {name}"}
    js["required"] = sorted(set(js.get("required", [])) | {key})
    js["title"] = name
    return js


def _named_section(kind: str, key: str, defs: dict, reg) -> dict:
    variants = []
    for name, cls in reg.all_classes(kind).items():
        if isinstance(cls, Exception) or getattr(cls, "Params", None) is None:
            continue
        variants.append(_selected(cls.Params, key, name, defs))
    return {"type": "object", "additionalProperties": {"oneOf": variants} if variants else {"type": "object"}}


def deck_json_schema() -> dict[str, Any]:
    reg = get_registry()
    defs: dict[str, Any] = {}
    disc_variants = []
    for name, cls in reg.all_classes("discretization").items():
        if isinstance(cls, Exception):
            continue
        js = _selected(cls.Params, "Type", name, defs)
        props = js["properties"]
        props["Influence Function"] = {"type": "string", "description": "One, Parabolic Decay, Gaussian, or an expression of zeta and horizon"}
        if cls.supports_bond_filters:
            props["Bond Filters"] = {"type": "object", "description": "named filters: Rectangular_Plane, Disk, Exodus Mesh"}
            props["Omit Bonds Between Blocks"] = {"enum": ["None", "All"]}
        disc_variants.append(js)
    bc_variants = []
    for name, cls in reg.all_classes("boundary_condition").items():
        if isinstance(cls, Exception):
            continue
        js = copy.deepcopy(_model(cls.Params, defs))
        js["title"] = name
        bc_variants.append(js)
    solver_variants = []
    for name, cls in reg.all_classes("solver").items():
        if isinstance(cls, Exception):
            continue
        js = copy.deepcopy(_model(cls.Params, defs))
        js["title"] = name
        solver_variants.append(js)
    computes = {"type": "object", "additionalProperties": {"oneOf": [
        _selected(cls.Params, "Compute Class", name, defs)
        for name, cls in reg.all_classes("compute").items()
        if not isinstance(cls, Exception) and getattr(cls, "Params", None) is not None
    ]}}
    deck = {
        "type": "object",
        "description": "A peridyn / Peridigm input deck (the top key 'Peridigm' is optional)",
        "properties": {
            "Discretization": {"oneOf": disc_variants},
            "Materials": _named_section("material", "Material Model", defs, reg),
            "Damage Models": _named_section("damage", "Damage Model", defs, reg),
            "Blocks": {"type": "object", "additionalProperties": _model(BlockParams, defs)},
            "Boundary Conditions": {
                "type": "object",
                "description": "entries whose name contains 'Node Set' define node sets (a string of 1-based ids or a file name)",
                "additionalProperties": {"oneOf": [{"type": "string"}, *bc_variants]},
            },
            "Compute Class Parameters": computes,
            "Data Loader": _model(DataLoaderParams, defs),
            "Contact": {"type": "object"},
            "Random Seed": {
                "type": "integer", "minimum": 0, "maximum": 2**64 - 1, "default": 0,
                "description": "seed of rnd() in expressions: each value is a hash of the seed, the expression's place in the deck, "
                               "the call's position in it and the point's global id (the same on any number of ranks)",
            },
        },
        "patternProperties": {
            "Solver": {"oneOf": solver_variants},
            "Output": _model(OutputParams, defs),
        },
        "required": ["Discretization", "Materials", "Blocks"],
        "additionalProperties": False,
    }
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "peridyn deck",
        "oneOf": [deck, {"type": "object", "properties": {"Peridigm": deck}, "required": ["Peridigm"], "additionalProperties": False}],
        "$defs": defs,
    }
