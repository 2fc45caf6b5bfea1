"""The ``Boundary Conditions`` section: node sets and conditions, validated (phase 1 and 2).

Peridigm's convention: an entry whose tidied name contains ``NODE_SET`` defines a node set
(point numbers, a file name or, here, a region); every other entry is a condition with a
``Type``. An entry that plainly is the other kind (a list of ids or a region under a name without
"Node Set", a ``Type`` under a name with it) is told so, with the rename that fixes it.
"""
from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Callable

from ..core.conditions import Condition, ConditionParams
from ..core.errors import InputError
from .regions import RegionSpec
from .validation import close_key, suggest, validate_params

#: the keys a boundary condition is written with (Peridigm's), besides Type
CONDITION_KEYS = ("Node Set", "Coordinate", "Value")
#: the keys a region node set starts with (docs/regions.md)
REGION_KEYS = tuple(f.alias or n for n, f in RegionSpec.model_fields.items())
NODE_SET_SUFFIX = re.compile(r"[\s_]*(node[\s_]*set|nodeset|nodes|set)\s*$", re.IGNORECASE)


def tidy(name: str) -> str:
    """Peridigm's ``tidy_string``: upper case, trim spaces, remaining spaces become ``_``."""
    return str(name).upper().strip(" ").replace(" ", "_")


@dataclass
class NodeSetEntry:
    name: str  #: tidied
    value: str | RegionSpec  #: point numbers or a file name; or a region (docs/regions.md)
    path: tuple[str, ...]


@dataclass
class BCEntry:
    name: str
    type: str  #: tidied
    cls: type[Condition]
    params: ConditionParams
    path: tuple[str, ...]


def node_set_name(name: str) -> str:
    """The name an entry meant as a node set should have: ``Left`` -> ``Left Node Set``,
    ``LeftNodeSet`` or ``Left Nodes`` -> ``Left Node Set``."""
    base = NODE_SET_SUFFIX.sub("", str(name)).strip() or str(name).strip()
    return f"{base} Node Set"


def _ids(value: Any) -> bool:
    """Whether ``value`` reads as point numbers: whole numbers, alone, in a list or a string."""
    if isinstance(value, bool):
        return False
    if isinstance(value, int):
        return True
    if isinstance(value, (list, tuple)):
        return bool(value) and all(_ids(v) for v in value)
    if isinstance(value, str):
        words = value.replace(",", " ").split()
        return bool(words) and all(w.isdigit() for w in words)
    return False


def _file_name(value: Any) -> bool:
    return isinstance(value, str) and " " not in value.strip() and bool(re.search(r"\.[A-Za-z][A-Za-z0-9]{0,4}$", value.strip()))


def looks_like_node_set(value: Any) -> str | None:
    """What a value given as a condition looks like, as a node set ("a list of point numbers",
    "a file name", "a region"), or None."""
    if _ids(value):
        return "a list of point numbers"
    if _file_name(value):
        return "a file name"
    if isinstance(value, Mapping) and value and "Type" not in value and any(k in REGION_KEYS for k in value):
        return "a region"
    return None


def parse_boundary_conditions(sec: Mapping[str, Any], registry, file: str, errors: list[InputError],
                              lines: Callable | None) -> tuple[dict[str, NodeSetEntry], list[BCEntry]]:
    """The node sets (by tidied name) and conditions of ``sec``; problems go to ``errors``."""

    def err(message: str, path: tuple[str, ...], fix: str | None = None) -> None:
        errors.append(InputError(message, file=file, path=path, fix=fix, line=lines(path) if lines else None))

    node_sets: dict[str, NodeSetEntry] = {}
    invalid_node_sets: set[str] = set()  # reported already: conditions using them are not "unknown"
    bcs: list[BCEntry] = []
    for name, raw in sec.items():
        path = ("Boundary Conditions", name)
        if "NODE_SET" in tidy(name):
            if isinstance(raw, Mapping) and "Type" in raw and not any(k in REGION_KEYS for k in raw):
                invalid_node_sets.add(tidy(name))
                plain = NODE_SET_SUFFIX.sub("", str(name)).strip() or "My Condition"
                err("this entry has a 'Type', as a boundary condition does, but its name contains 'Node Set', which makes it a node set", path,
                    f"rename it without 'Node Set' (e.g. {plain!r}) to make it a condition, or give a region (docs/regions.md)")
                continue
            if isinstance(raw, Mapping):  # a region (docs/regions.md)
                region = validate_params(RegionSpec, raw, path=path, file=file, errors=errors, lines=lines)
                if region is not None:
                    node_sets[tidy(name)] = NodeSetEntry(tidy(name), region, path)
                else:
                    invalid_node_sets.add(tidy(name))
                continue
            if isinstance(raw, bool) or not isinstance(raw, (str, int)):
                invalid_node_sets.add(tidy(name))
                fix = "e.g. \"1 2 3\", \"left.txt\" or {Box: {Min: [x, y, z], Max: [x, y, z]}} (docs/regions.md)"
                if _ids(raw):
                    fix = f"write the point numbers as one string: {' '.join(str(v) for v in raw)!r}"
                err(f"a node set must be a string of point numbers, a file name or a region (got {raw!r})", path, fix)
                continue
            node_sets[tidy(name)] = NodeSetEntry(tidy(name), str(raw), path)
            continue
        like = looks_like_node_set(raw)
        if like is not None:
            err(f"this entry looks like a node set ({like}), but node-set keys must end in 'Node Set'; without it the entry is read as a "
                "boundary condition", path, f"rename it {node_set_name(name)!r} (and name it so in the conditions' 'Node Set')")
            continue
        if not isinstance(raw, Mapping):
            err(f"expected a boundary condition (Type, Node Set, Coordinate, Value), got {raw!r}", path,
                "or name the entry '... Node Set' to define a node set")
            continue
        bc_type = raw.get("Type")
        if bc_type is None:
            typo = close_key("Type", raw)
            if typo is not None:
                err(f"missing required key 'Type' (the entry has {typo!r})", path, f"rename {typo!r} to 'Type'")
            else:
                err("missing required key 'Type'", path, f"add 'Type:' one of {', '.join(registry.names('boundary_condition'))}")
            continue
        if not isinstance(bc_type, str):
            errors.append(registry.unknown("boundary_condition", bc_type, path=path + ("Type",), file=file))
            continue
        key = tidy(bc_type)
        if not registry.has("boundary_condition", key):
            errors.append(registry.unknown("boundary_condition", str(bc_type), path=path + ("Type",), file=file))
            continue
        cls = registry.get("boundary_condition", key, path=path + ("Type",), file=file)
        params = validate_params(cls.Params, raw, path=path, file=file, errors=errors, lines=lines)
        if params is not None:
            for problem in cls.check(params):
                err(problem, path)
            bcs.append(BCEntry(name, key, cls, params, path))
    for bc in bcs:
        ns = bc.params.node_set
        if "NODE_SET" in tidy(ns) and tidy(ns) not in node_sets and tidy(ns) not in invalid_node_sets:
            # mesh node sets (nodelist_1) are checked once the mesh is read
            err(f"unknown node set {ns!r}", bc.path + ("Node Set",), suggest(ns, node_sets))
    return node_sets, bcs
