"""``docs/reference.md``: every deck parameter with its type, unit, default and meaning, written
from the parameter models the loader and ``peridyn schema`` use (``peridyn schema --reference
FILE``; a test checks that the shipped page is up to date)."""
from __future__ import annotations

import re
from typing import Any

from ..core.params import IGNORED_KEY_TYPES, describe_params, reading_field, type_text
from ..plugins.manager import KINDS, get_registry
from .model import IGNORED_TOP_LEVEL, RANDOM_SEED_KEY, BlockParams, ContactSectionParams, DataLoaderParams, OutputParams
from .restart import RestartParams
from .schema import BOND_FILTER_KEYS, DISCRETIZATION_KEYS

#: deck sections of each kind of plugin, in the order of the page
SECTIONS = (
    ("discretization", "Discretization", "Type"),
    ("material", "Materials", "Material Model"),
    ("damage", "Damage Models", "Damage Model"),
    ("boundary_condition", "Boundary Conditions", "Type"),
    ("solver", "Solver", "method"),
    ("contact", "Contact > Models", "Contact Model"),
    ("compute", "Compute Class Parameters", "Compute Class"),
)
#: a parenthesized unit at the start of a description's group: L, M, T, Pa, 1/..., dimensionless
_UNIT = re.compile(r"\(((?:[LMT](?=[ /^),;])|Pa\b|J/|1/|dimensionless|length|time|force units|temperature)[^()]*)\)")


def unit_of(description: str) -> str:
    """The unit a description states in parentheses (``mass density (M/L^3, kg/m^3 in SI)`` ->
    ``M/L^3, kg/m^3 in SI``), or '' (L, M, T: the deck's units of length, mass, time)."""
    m = _UNIT.search(description)
    return m.group(1) if m else ""


def _cell(value: Any) -> str:
    return str(value).replace("|", "\\|").replace("\n", " ")


def _table(rows: list[dict[str, Any]]) -> list[str]:
    if not rows:
        return ["No parameters.", ""]
    out = ["| parameter | type | unit | default | meaning |", "|---|---|---|---|---|"]
    for r in rows:
        default = "required" if r["required"] else ("" if r["default"] is None else f"`{r['default']!r}`")
        out.append(f"| `{_cell(r['name'])}` | {_cell(r['type'])} | {_cell(unit_of(r['description']))} | {_cell(default)} | {_cell(r['description'])} |")
    return out + [""]


def _extra_rows(keys: dict[str, dict]) -> list[dict[str, Any]]:
    return [{"name": k, "type": "one of " + ", ".join(repr(v) for v in js["enum"]) if "enum" in js else js.get("type", "text").replace("object", "named entries")
             .replace("string", "text"), "required": False, "default": None, "description": js.get("description", "")} for k, js in keys.items()]


def reference_markdown() -> str:
    """The page, for the plugins installed now."""
    reg = get_registry()
    out = [
        "# Deck reference",
        "",
        "Every parameter of every section and model that this installation of peridyn reads, written by",
        "`peridyn schema --reference docs/reference.md` from the parameter models the deck loader and",
        "`peridyn schema` use (do not edit by hand; `tests/unit/deck/test_reference.py` checks it is up",
        "to date). L, M and T are the deck's units of length, mass and time (m, kg and s in an SI deck);",
        "a unit is shown where the parameter's description states one. Keys are case sensitive; a",
        "boundary condition's `Type` is read as Peridigm reads it (any case, `_` or space). Installed",
        "plugins add their models: `peridyn plugins` lists them, `peridyn schema` gives them to an",
        "editor ([schema.md](schema.md)).",
        "",
        "## Top level",
        "",
        "| key | meaning |",
        "|---|---|",
        "| `Discretization`, `Materials`, `Blocks` | required sections (below) |",
        "| `Damage Models`, `Boundary Conditions`, `Compute Class Parameters`, `Contact`, `Data Loader`, `Restart` | optional sections (below) |",
        "| any key containing `Solver` | a solver section (several run in turn) |",
        "| any key containing `Output` | an output file |",
        "| `Multiphysics` | 1: fluid pressure as a fourth degree of freedom (multiphysics materials) |",
        f"| `{RANDOM_SEED_KEY}` | seed of `rnd()` in expressions (default 0) |",
    ]
    out += [f"| `{k}` | accepted and ignored: {_cell(v)} |" for k, v in IGNORED_TOP_LEVEL.items()]
    out += ["", "## Blocks", "", "Each entry of `Blocks` is one block:", ""] + _table(describe_params(BlockParams))
    out += ["## Output", "", "Each section whose name contains `Output`:", ""] + _table(describe_params(OutputParams))
    out += ["## Data Loader", ""] + _table(describe_params(DataLoaderParams))
    out += ["## Restart", "", "Checkpoints and restarts ([restart.md](restart.md)):", ""] + _table(describe_params(RestartParams))
    out += ["## Contact", "", "The `Contact` section; its `Models` are listed below.", ""] + _table(describe_params(ContactSectionParams))
    for kind, section, key in SECTIONS:
        human = KINDS[kind][1]
        out += [f"## {section}", ""]
        if kind == "discretization":
            out += ["Every discretization type also takes these keys:", ""] + _table(_extra_rows(DISCRETIZATION_KEYS))
            out += ["Types that read a mesh of elements or points also take these:", ""] + _table(_extra_rows(BOND_FILTER_KEYS))
        if kind == "solver":
            out += ["A solver section names one method (a key holding its own parameters):", ""]
        for name, cls in reg.all_classes(kind).items():
            if isinstance(cls, Exception):
                continue
            out += [f"### {name}", "", f"{human.capitalize()}, `{key}: {name}`." if kind != "solver" else f"Solver method `{name}`.", ""]
            params = cls.Params
            rows = describe_params(params) if params is not None else []
            if kind != "solver":
                rows = [r for r in rows if r["name"] != key]
            rows += [{"name": k, "type": type_text(IGNORED_KEY_TYPES.get(k) or reading_field(k) or str), "required": False, "default": None,
                      "description": "accepted and ignored, as Peridigm does"} for k in sorted(params.ignored_keys if params is not None else ())]
            out += _table(rows) if params is not None else ["Takes no parameters (ask for it under `Output Variables`).", ""]
    return "\n".join(out).rstrip() + "\n"
