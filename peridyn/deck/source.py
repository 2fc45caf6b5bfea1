"""Peridigm deck files (Teuchos ParameterLists in YAML or XML): the raw tree and its typing rules.

Both formats load into one *raw tree*: nested ``dict`` objects in deck order whose leaves are
``bool``, ``int``, ``float``, ``str`` or ``list`` (a Teuchos array of ints, floats or strings).
The Python type of a leaf is the Teuchos type Peridigm would see, because Peridigm treats a
double-typed and a string-typed entry differently (PERIDIGM_SEMANTICS.md §1.1, §1.3, §1.4):

* YAML: a quoted scalar is a string; an unquoted one is a bool (``true``/``false``/``yes``/``no``,
  any case), else an int (``[+-]?[0-9]+`` within 32 bits), else a double if it parses entirely as
  a C double (``200e9``, ``.5``, ``5.``, ``inf``, ``nan``), else a string (``1 2 3``). An empty
  value (``Key:``) is an empty parameter list (``{}``). The top key ``Peridigm:`` is optional.
* XML: ``<ParameterList name=..>`` and ``<Parameter name=.. type=.. value=..>`` with the types
  ``double``, ``int``, ``bool``, ``string``, ``Array(double)``, ``Array(int)``, ``Array(string)``.

A name repeated in one list replaces the earlier value in place (Teuchos ``setEntry``): the entry
keeps the position of its first occurrence and the value of its last, with one warning on the
``peridyn.deck`` logger. :func:`dump_yaml` writes a tree back as Peridigm-style YAML that loads to
an identical tree, types included; :func:`convert` is the ``peridyn convert`` command.
"""
from __future__ import annotations

import logging
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Union

from ..core.errors import format_path

log = logging.getLogger("peridyn.deck")

#: A leaf of the raw tree.
Leaf = Union[bool, int, float, str, list]

YAML_SUFFIXES = (".yaml", ".yml")
XML_SUFFIXES = (".xml",)

#: Teuchos ``int`` is a C ``int``: an unquoted integer outside this range is read as a double.
INT_MIN = -(2**31)
INT_MAX = 2**31 - 1

#: Top-level section names of a Peridigm deck (besides any name containing Solver or Output).
SECTION_NAMES = frozenset(
    {
        "Discretization",
        "Materials",
        "Damage Models",
        "Blocks",
        "Boundary Conditions",
        "Compute Class Parameters",
        "Contact",
        "Data Loader",
        "Restart",
        "Multiphysics",
    }
)

_INT_RE = re.compile(r"[+-]?[0-9]+")
_DOUBLE_RE = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_SPECIAL_DOUBLE_RE = re.compile(r"[+-]?(?:inf|infinity|nan)", re.IGNORECASE)
_TRUE_WORDS = frozenset({"true", "yes"})
_FALSE_WORDS = frozenset({"false", "no"})

# Scalar type ranks, as in Teuchos: a list takes the lowest rank of its items.
_STRING, _DOUBLE, _INT, _BOOL = 0, 1, 2, 3
_KIND_NAMES = {_STRING: "string", _DOUBLE: "double", _INT: "int", _BOOL: "bool"}


# --------------------------------------------------------------------------------------------
# The loaded deck
# --------------------------------------------------------------------------------------------


@dataclass
class DeckSource:
    """A deck file loaded into a raw tree, with where each entry came from.

    Attributes
    ----------
    tree: nested dicts in deck order; leaves are ``bool | int | float | str | list``.
    path: the file (``Path("<string>")`` for text parsed from memory).
    fmt: ``"yaml"`` or ``"xml"``.
    lines: the 1-based line of each key path, e.g.
        ``("Materials", "My Elastic", "Bulk Modulus") -> 17``.
    """

    tree: dict
    path: Path
    fmt: str
    lines: dict[tuple[str, ...], int] = field(default_factory=dict)

    def line_of(self, path: Sequence[str | int]) -> int | None:
        """Line of ``path``, or of its longest prefix that has one; ``None`` if none does."""
        key = tuple(path)
        for n in range(len(key), 0, -1):
            line = self.lines.get(key[:n])  # type: ignore[arg-type]
            if line is not None:
                return line
        return None


def is_section_name(name: str) -> bool:
    """Whether ``name`` is a top-level section of a Peridigm deck (so never a wrapper key)."""
    return name in SECTION_NAMES or "Solver" in name or "Output" in name


# --------------------------------------------------------------------------------------------
# Scalar typing (Teuchos rules)
# --------------------------------------------------------------------------------------------


def _is_int_text(text: str) -> bool:
    return _INT_RE.fullmatch(text) is not None and INT_MIN <= int(text) <= INT_MAX


def _is_double_text(text: str) -> bool:
    return _DOUBLE_RE.fullmatch(text) is not None or _SPECIAL_DOUBLE_RE.fullmatch(text) is not None


def _kind_of_plain(text: str) -> int:
    """Teuchos type rank of an unquoted, untagged scalar."""
    lower = text.lower()
    if lower in _TRUE_WORDS or lower in _FALSE_WORDS:
        return _BOOL
    if _is_int_text(text):
        return _INT
    if _is_double_text(text):
        return _DOUBLE
    return _STRING


def _convert(text: str, kind: int) -> Leaf:
    """``text`` as a value of type ``kind``; raises ``ValueError`` if it is not one."""
    if kind == _STRING:
        return text
    if kind == _BOOL:
        lower = text.lower()
        if lower in _TRUE_WORDS:
            return True
        if lower in _FALSE_WORDS:
            return False
        raise ValueError(f"{text!r} is not a bool (true or false)")
    if kind == _INT:
        if _INT_RE.fullmatch(text) is None:
            raise ValueError(f"{text!r} is not an int")
        value = int(text)
        if not INT_MIN <= value <= INT_MAX:
            raise ValueError(f"{text!r} is outside the range of a 32-bit int")
        return value
    if not _is_double_text(text):
        raise ValueError(f"{text!r} is not a number")
    return float(text)


def infer_scalar(text: str) -> Leaf:
    """The value of an unquoted YAML scalar under Teuchos typing rules.

    ``"1"`` -> ``1``, ``"1.0"`` -> ``1.0``, ``"200e9"`` -> ``2e11``, ``"TRUE"`` -> ``True``,
    ``"1 2 3"`` -> ``"1 2 3"``. Quoted scalars are always strings and never pass through here.
    """
    return _convert(text, _kind_of_plain(text))


def typed_tree(value: Any) -> Any:
    """A Python deck (a dict deck, from the API or a test) as the raw tree the same deck in a
    YAML file gives: numpy scalars and arrays as Python values, tuples as lists, keys as text,
    integers beyond 32 bits as doubles, and each list of one Teuchos type, the lowest of its
    items' (``[0.002, 0, 0]`` -> ``[0.002, 0.0, 0.0]``, ``["a", 1]`` -> ``["a", "1"]``). What no
    YAML deck holds (a list with bools, lists or mappings in it, None, other objects) is left as
    it is, for validation to report at its deck path."""
    value = _python(value)
    if isinstance(value, dict) or (hasattr(value, "items") and hasattr(value, "keys")):
        return {str(k): typed_tree(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        items = [_python(v) for v in value]
        if not all(isinstance(v, (int, float, str)) and not isinstance(v, bool) for v in items):
            return [typed_tree(v) for v in items]
        if any(isinstance(v, str) for v in items):
            return [v if isinstance(v, str) else repr(v) if isinstance(v, float) else str(v) for v in items]
        if any(isinstance(v, float) or not INT_MIN <= v <= INT_MAX for v in items):
            return [_double(v) for v in items]
        return items
    if isinstance(value, int) and not isinstance(value, bool) and not INT_MIN <= value <= INT_MAX:
        return _double(value)
    return value


def _python(value: Any) -> Any:
    """numpy scalars and arrays as Python values (arrays as lists)."""
    import numpy as np

    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _double(value: int | float) -> float:
    """``value`` as a double, as its digits in a file read: infinite when too large."""
    try:
        return float(value)
    except OverflowError:
        return float("inf") if value > 0 else float("-inf")


# --------------------------------------------------------------------------------------------
# Shared tree building
# --------------------------------------------------------------------------------------------


class _TreeBuilder:
    """Inserts entries into dicts, records their lines, handles repeated names."""

    def __init__(self, filename: str) -> None:
        self.filename = filename
        self.lines: dict[tuple[str, ...], int] = {}

    def prepare(self, mapping: dict, path: tuple[str, ...], line: int) -> None:
        """Call before building the value of ``path``: warn about and forget a repeated name."""
        key = path[-1]
        if key not in mapping:
            return
        old_line = self.lines.get(path)
        earlier = f" (line {old_line})" if old_line else ""
        log.warning(
            "%s:%d: %r is given twice in the same list; this entry replaces the earlier one%s",
            self.filename,
            line,
            format_path(path),
            earlier,
        )
        n = len(path)
        for p in [p for p in self.lines if p[:n] == path]:
            del self.lines[p]

    def put(self, mapping: dict, path: tuple[str, ...], value: Any, line: int) -> None:
        """Store ``value`` (in place of an earlier one of the same name) and its line."""
        mapping[path[-1]] = value
        self.lines[path] = line


def too_deep() -> str:
    return "the deck is nested too deeply to be read"
