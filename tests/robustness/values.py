"""The values mutations put into decks, and the values no valid deck has.

:class:`Raw` leaves are written verbatim (what ``dump_yaml`` cannot write: None, a huge int, mixed
or nested lists). :func:`obviously_invalid` says why a mutated tree cannot be a valid deck (a
non-positive density, a non-finite time, Final Time <= Initial Time, ...): accepting such a deck
with exit 0 is the ``exit0_bad`` outcome. Only unambiguous rules belong here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterator

Path_ = tuple[str, ...]


def iter_keys(tree: dict, prefix: Path_ = ()) -> Iterator[tuple[Path_, Any]]:
    """Every (key path, value) pair, sections included, outermost first."""
    for k, v in tree.items():
        yield prefix + (k,), v
        if isinstance(v, dict):
            yield from iter_keys(v, prefix + (k,))


def iter_leaves(tree: dict) -> Iterator[tuple[Path_, Any]]:
    return ((p, v) for p, v in iter_keys(tree) if not isinstance(v, dict))


# ------------------------------------------------------------------------------------------------
# Values the YAML writer cannot produce
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Raw:
    """A leaf written verbatim: ``yaml`` text, and ``xml`` (type, value; None = no value)."""

    yaml: str
    xml: tuple[str, str | None]
    label: str

    def __repr__(self) -> str:
        return self.label


NONE = Raw("null", ("string", None), "None")
HUGE_INT = Raw("123456789012345678901234567890", ("int", "123456789012345678901234567890"), "10**29 (huge int)")
INT_OVER = Raw("2147483648", ("int", "2147483648"), "2**31")
MIXED_LIST = Raw('[1, "a", 2.5]', ("Array(string)", "{1, a, 2.5}"), "[1, 'a', 2.5]")
BOOL_LIST = Raw("[true, false]", ("Array(int)", "{true, false}"), "[true, false]")
NESTED_LIST = Raw("[[1, 2], [3]]", ("Array(int)", "{{1, 2}, {3}}"), "[[1, 2], [3]]")
BAD_XML_NUMBER = Raw('"1,5"', ("double", "1,5"), "'1,5' (comma decimal)")

WRONG_TYPES: list[Any] = [True, False, [1, 2, 3], [1.5, 2.5], ["a", "b"], [], {}, {"x": 1.0}, {"Sub": {"y": "z"}},
                          "", "abc", "1 2 3", "true", "1e3", NONE, MIXED_LIST, BOOL_LIST, NESTED_LIST, BAD_XML_NUMBER]
EXTREMES: list[Any] = [math.nan, math.inf, -math.inf, 0, 0.0, -1, -1.0, 1e308, -1e308, 5e-324, -0.0, 2**31 - 1,
                       -(2**31), 10**9, 1e-300, 1e300, HUGE_INT, INT_OVER, Raw("1e999", ("double", "1e999"), "1e999"),
                       Raw("-nan", ("double", "-nan"), "-nan"), Raw("+inf", ("double", "+inf"), "+inf"),
                       Raw(".nan", ("double", "nan"), ".nan"), Raw("-.inf", ("double", "-inf"), "-.inf"),
                       2.2250738585072014e-308, 1e-30, 1e30, 1.7976931348623157e308]


# ------------------------------------------------------------------------------------------------
# Physics that no valid deck has (used to decide when exit 0 is wrong)
# ------------------------------------------------------------------------------------------------
#: keys whose value must be a finite number > 0 (per the deck section they live in)
POSITIVE = {
    "Materials": {"Density", "Bulk Modulus", "Shear Modulus", "Young's Modulus"},
    "Blocks": {"Horizon"},
    "Discretization": {"X Length", "Y Length", "Z Length", "Number Points X", "Number Points Y", "Number Points Z",
                       "Number Points Radius", "Outer Radius", "Cylinder Length"},
    "Solver": {"Fixed dt", "Safety Factor", "Number of Load Steps"},
}
#: keys whose value must be finite
FINITE = {
    "Materials": {"Poisson's Ratio"},
    "Discretization": {"X Origin", "Y Origin", "Z Origin", "Inner Radius"},
    "Solver": {"Initial Time", "Final Time"},
}
#: keys whose name is fixed by the schema: a typo in one must be refused
SCHEMA_KEYS = set().union(*POSITIVE.values(), *FINITE.values(), {"Material Model", "Block Names", "Material",
                                                                  "Input Mesh File", "Output Filename"})
#: keys whose values are names, models or choices, not expressions
NAME_KEYS = {"Type", "Material Model", "Damage Model", "Material", "Block Names", "Node Set", "Coordinate",
             "Output Filename", "Output File Type", "Output Format", "Compute Class", "Variable", "Output Label",
             "NeighborhoodType", "Nonlinear Solver", "Method", "Linear Solver", "Preconditioner",
             "Peridigm Preconditioner", "Input Mesh File", "File Name", "Field Name", "Contact Model"}
#: keys whose string value is evaluated as an expression
EXPRESSION_KEYS = {"Value", "Horizon", "Influence Function"}


def _section(path: Path_) -> str:
    return "Solver" if path and "Solver" in path[0] else (path[0] if path else "")


def _number(v: Any) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    return float(v)


_RAW_NUMBERS = {"1e999": math.inf, "-nan": math.nan, "+inf": math.inf, "10**29 (huge int)": 1.2e29, "2**31": 2.0**31,
                ".nan": math.nan, "-.nan": math.nan, ".inf": math.inf, "-.inf": -math.inf}
_NOT_NUMBERS = {"", "abc", "1 2 3", "true"}
#: strings that a number parser may read as non-finite numbers
_NONFINITE_TEXT = {"nan": math.nan, "-nan": math.nan, "inf": math.inf, "-inf": -math.inf, "+inf": math.inf}  # the strings WRONG_TYPES puts where a number belongs


def _as_float(value: Any) -> float | None:
    if isinstance(value, Raw):
        return _RAW_NUMBERS.get(value.label)
    if isinstance(value, str) and value.strip().lower() in _NONFINITE_TEXT:
        return _NONFINITE_TEXT[value.strip().lower()]
    return _number(value)


def _not_a_number(value: Any) -> bool:
    if isinstance(value, Raw):
        return value.label not in _RAW_NUMBERS
    return isinstance(value, (bool, list, dict)) or (isinstance(value, str) and value.strip() in _NOT_NUMBERS)


def obviously_invalid(tree: dict) -> str | None:
    """Why ``tree`` cannot be a valid deck (a non-positive density, ...), or None if not obvious."""
    for path, value in iter_leaves(tree):
        sec, key = _section(path), path[-1]
        positive, finite = key in POSITIVE.get(sec, ()), key in FINITE.get(sec, ())
        if not (positive or finite or (key == "Critical Stretch" and sec == "Damage Models")):
            continue
        where = " > ".join(path)
        if _not_a_number(value):
            return f"{where} is {value!r}, not a number"
        x = _as_float(value)
        if x is None:
            continue
        if math.isnan(x) or ((positive or finite) and math.isinf(x)):
            return f"{where} = {x} is not finite"
        if positive and x <= 0:
            return f"{where} = {x} must be positive"
        if key == "Poisson's Ratio" and not -1.0 < x < 0.5:
            return f"{where} = {x} is outside (-1, 0.5)"
    for name, sec in tree.items():
        if "Solver" in name and isinstance(sec, dict):
            t0, t1 = _as_float(sec.get("Initial Time", 0.0)), _as_float(sec.get("Final Time"))
            if t0 is not None and t1 is not None and t1 <= t0:
                return f"{name}: Final Time {t1} <= Initial Time {t0}"
    return None
