"""Hypothesis strategies that mutate a Peridigm deck (one mutation per example).

A :class:`DeckInfo` is an example or conformance deck loaded into its raw tree. ``mutations(deck,
tree)`` draws one :class:`Mutation` of that tree: a deleted or renamed key, a value of the wrong
type, a non-finite or extreme number, a broken expression, a missing, folder-valued or corrupted
neighbouring file, a duplicated output file name, a Final Time not after the Initial Time, or a
damaged deck text; for ``run``, also valid but extreme numbers (``scale_number``). :mod:`cases`
shrinks decks for ``run`` and writes a case; :mod:`runner` executes and classifies it.

Issue 19 added what an independent campaign found this one missing: whole sections removed
(``delete_section``: the Solver, Output, Contact sections, Adaptive Load-Stepping, Switch to
Verlet, Linear Solver, Shapes, ...), non-finite values on any key including ignored ones
(``nonfinite_anywhere``), very long names (``long_string``: 255-5000 characters on file names),
keys of every model family scaled by the factors that found bugs (x10, x0.3, x1660, unit slips
1e+-9, 1e-300, 1e308) or set to tiny/huge positives (``family_number``, family first so a deck's
few contact or plasticity keys are not drowned by its boundary conditions), time steps at any
depth, added where absent (``step_size``: QuasiStatic > Adaptive Load-Stepping > Switch to Verlet >
Fixed dt), other material models with valid parameters (``model_swap``: viscoelastic, Pals,
plasticity, correspondence, partial volumes from plain Elastic decks) and linear solver and
predictor choices (``solver_choice``: AMG, Direct, Belos GMRES, ...). :func:`family_of_case`
names the family a case reached (the campaign's coverage table).
"""
from __future__ import annotations

import copy
import glob
import logging
import math
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hypothesis import strategies as st

from peridyn.deck.files import load_deck_file

sys.path.insert(0, str(Path(__file__).resolve().parent))
from values import (  # noqa: E402
    EXPRESSION_KEYS,
    EXTREMES,
    NAME_KEYS,
    SCHEMA_KEYS,
    WRONG_TYPES,
    Path_,
    Raw,
    _number,
    iter_keys,
    iter_leaves,
)

REPO = Path(__file__).resolve().parents[2]
CONFORMANCE = REPO.parent / "shared" / "conformance" / "cases"
#: neighbour files that are results or metadata, never inputs of a deck
_NOT_INPUTS = re.compile(r"(_gold\.(e|h)|\.comp|\.ipynb|CASE\.json|README.*)$")
EXODUS_SUFFIXES = (".g", ".e", ".exo", ".h")



# ------------------------------------------------------------------------------------------------
# Decks
# ------------------------------------------------------------------------------------------------
@dataclass(repr=False)
class DeckInfo:
    """One source deck: where it is, its format and its raw tree."""

    name: str  #: ``examples/quickstart.yaml`` or ``conformance/<case>/<file>``
    path: Path
    fmt: str  #: "yaml" or "xml"
    tree: dict
    dt_hint: float | None = None  #: stable time step from ``peridyn check`` (for shrinking)
    baseline: int | None = None  #: exit code of ``check`` on the unmutated deck

    def __repr__(self) -> str:
        return f"DeckInfo({self.name!r})"

    def _repr_pretty_(self, printer: Any, cycle: bool) -> None:  # hypothesis' printer: stay short
        printer.text(repr(self))

    @property
    def folder(self) -> Path:
        return self.path.parent

    def neighbours(self) -> list[Path]:
        """Files beside the deck that may be inputs (gold results and metadata left out)."""
        return sorted(p for p in self.folder.iterdir() if p.is_file() and p != self.path and not _NOT_INPUTS.search(p.name))


def find_decks(include_conformance: bool = True) -> list[DeckInfo]:
    """Every example deck and (if present) every conformance deck that loads."""
    paths = [Path(p) for p in sorted(glob.glob(str(REPO / "examples" / "*.yaml")))]
    if include_conformance and CONFORMANCE.is_dir():
        for case in sorted(CONFORMANCE.iterdir()):
            paths += sorted(p for p in case.glob("*") if p.suffix in (".yaml", ".xml"))
    decks = []
    quiet = logging.getLogger("peridyn.deck")
    level = quiet.level
    quiet.setLevel(logging.ERROR)  # repeated keys etc. are the deck's business, not ours
    try:
        for p in paths:
            try:
                src = load_deck_file(p)
            except Exception:  # a deck that does not load is no mutation base
                continue
            rel = f"examples/{p.name}" if p.parent.name == "examples" else f"conformance/{p.parent.name}/{p.name}"
            decks.append(DeckInfo(rel, p, src.fmt, src.tree))
    finally:
        quiet.setLevel(level)
    return decks


# ------------------------------------------------------------------------------------------------
# Tree walking and editing
# ------------------------------------------------------------------------------------------------
def _parent(tree: dict, path: Path_) -> dict:
    node = tree
    for k in path[:-1]:
        node = node[k]
    return node


def apply_tree_ops(tree: dict, ops: tuple) -> dict:
    """A copy of ``tree`` with ``ops`` ((op, path, arg), ...) applied: delete, rename, set, copy."""
    out = copy.deepcopy(tree)
    for op, path, arg in ops:
        parent = _parent(out, path)
        key = path[-1]
        if op == "set":
            parent[key] = copy.deepcopy(arg)
        elif op == "delete":
            parent.pop(key, None)
        elif op in ("rename", "copy"):
            items = list(parent.items())
            parent.clear()
            for k, v in items:
                if k != key or op == "copy":
                    parent[k] = v
                if k == key:
                    parent[arg] = copy.deepcopy(v)
        else:  # pragma: no cover
            raise ValueError(op)
    return out


# ------------------------------------------------------------------------------------------------
# The mutation
# ------------------------------------------------------------------------------------------------
@dataclass
class Mutation:
    """One change to a deck: tree edits, file edits and/or an edit of the written deck text."""

    kind: str
    path: Path_ = ()
    value: Any = None
    detail: str = ""
    tree_ops: tuple = ()
    file_ops: tuple = ()  #: ((op, file name relative to the deck folder, arg), ...)
    text_op: tuple | None = None  #: (op, position fraction, arg) on the written deck bytes
    expect_refusal: str | None = None  #: why exit 0 would be wrong (besides obviously_invalid)
    fmt: str = "yaml"  #: write the deck as "yaml" (with dump_yaml) or "xml"
    #: how much the mutation scaled the deck's loads (widens the blow-up bounds on |u| and |v|)
    load_factor: float = 1.0

    def __repr__(self) -> str:
        return f"<Mutation {self.describe()}>"

    def _repr_pretty_(self, printer: Any, cycle: bool) -> None:  # hypothesis' printer: stay short
        printer.text(repr(self))

    def describe(self) -> str:
        where = " > ".join(self.path) or "(deck)"
        val = repr(self.value)
        val = val if len(val) <= 90 else val[:60] + f"...<{len(val)} chars>"
        extra = f" [{self.detail}]" if self.detail else ""
        return f"{self.kind}: {where} -> {val}{extra}"

    def to_json(self) -> dict:
        return {"kind": self.kind, "path": list(self.path), "value": _jsonable(self.value), "detail": self.detail,
                "expect_refusal": self.expect_refusal, "fmt": self.fmt, "load_factor": _jsonable(self.load_factor),
                "description": self.describe()}


def _jsonable(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return repr(v)
    if isinstance(v, (bool, int, float)) or v is None:
        return v if not (isinstance(v, int) and abs(v) > 2**53) else str(v)
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    text = repr(v) if not isinstance(v, str) else v
    return text if len(text) <= 300 else text[:200] + f"...<{len(text)} chars>"


# ------------------------------------------------------------------------------------------------
# Strategies, one per mutation class
# ------------------------------------------------------------------------------------------------
def _renamed(key: str, style: str, i: int) -> str:
    n = max(len(key), 1)
    j = i % n
    if style == "typo_swap" and n > 1:
        j = min(j, n - 2)
        new = key[:j] + key[j + 1] + key[j] + key[j + 2 :]
    elif style == "typo_drop":
        new = key[:j] + key[j + 1 :]
    elif style == "typo_double":
        new = key[: j + 1] + key[j:]
    elif style == "lower":
        new = key.lower()
    elif style == "upper":
        new = key.upper()
    elif style == "snake":
        new = re.sub(r"[^0-9a-zA-Z]+", "_", key).strip("_").lower()
    elif style == "trailing_space":
        new = key + " "
    else:
        new = key + "x"
    return new if new and new != key else key + "_x"


def delete_key(keys: list[Path_]) -> st.SearchStrategy[Mutation]:
    required = {"Discretization", "Materials", "Blocks", "Material Model", "Material", "Block Names"}

    def make(p: Path_) -> Mutation:
        why = f"deleted required {p[-1]!r}" if p[-1] in required and (len(p) == 1 or p[0] != "Boundary Conditions") else None
        return Mutation("delete_key", p, None, tree_ops=(("delete", p, None),), expect_refusal=why)

    return st.sampled_from(keys).map(make)


def rename_key(keys: list[Path_]) -> st.SearchStrategy[Mutation]:
    styles = ["typo_swap", "typo_drop", "typo_double", "lower", "upper", "snake", "trailing_space"]

    def make(args: tuple) -> Mutation:
        p, style, i = args
        new = _renamed(p[-1], style, i)
        why = None
        if style.startswith("typo") and p[-1] in SCHEMA_KEYS and new.lower() != p[-1].lower():
            why = f"typo {new!r} for the schema key {p[-1]!r}"
        return Mutation("rename_key", p, new, style, tree_ops=(("rename", p, new),), expect_refusal=why)

    return st.tuples(st.sampled_from(keys), st.sampled_from(styles), st.integers(0, 40)).map(make)


def wrong_type(items: list[tuple[Path_, Any]]) -> st.SearchStrategy[Mutation]:
    def make(args: tuple) -> Mutation:
        (p, old), v = args
        why = None
        if isinstance(old, dict) and old and not isinstance(v, dict):
            why = f"the list of parameters {p[-1]!r} replaced by {v!r}"
        return Mutation("wrong_type", p, v, type(v).__name__ if not isinstance(v, Raw) else "raw",
                        tree_ops=(("set", p, v),), expect_refusal=why)

    return st.tuples(st.sampled_from(items), st.sampled_from(WRONG_TYPES)).map(make)


def extreme_number(numeric: list[Path_]) -> st.SearchStrategy[Mutation]:
    def make(args: tuple) -> Mutation:
        p, v = args
        return Mutation("extreme_number", p, v, tree_ops=(("set", p, v),))

    return st.tuples(st.sampled_from(numeric), st.sampled_from(EXTREMES)).map(make)


#: keys a larger (SLOWER_UP) or smaller (SLOWER_DOWN) value makes a run slower; ``run`` avoids that
SLOWER_UP = {"Final Time", "Number of Load Steps", "Number Points X", "Number Points Y", "Number Points Z",
             "Number Points Radius", "Horizon", "Maximum Solver Iterations", "Max Solver Iterations",
             "X Length", "Y Length", "Z Length", "Outer Radius", "Cylinder Length"}
SLOWER_DOWN = {"Fixed dt", "Safety Factor", "Initial Time"}
SCALES = [1e-300, 1e-12, 1e-9, 1e-3, 0.3, 10.0, 1660.0, 1e3, 1e9, 1e12, 1e300, 1e308, -1.0]


def scale_number(numeric: list[tuple[Path_, Any]], fast: bool = False) -> st.SearchStrategy[Mutation]:
    """Multiply a number by a huge or tiny factor (a valid but extreme deck: instabilities, NaN)."""

    def make(args: tuple) -> Mutation:
        (p, v), f = args
        if fast and ((p[-1] in SLOWER_UP and f > 1) or (p[-1] in SLOWER_DOWN and 0 < f < 1)):
            f = 1.0 / f
        new = float(v) * f
        if isinstance(v, int) and not isinstance(v, bool) and abs(new) < 2**31 and new == int(new):
            new = int(new)
        load = abs(f) if p[0] == "Boundary Conditions" and math.isfinite(new) else 1.0
        return Mutation("scale_number", p, new, f"x{f:g}", tree_ops=(("set", p, new),), load_factor=max(load, 1.0))

    return st.tuples(st.sampled_from(numeric), st.sampled_from(SCALES)).map(make)


def unstable_step(solvers: list[str], tree: dict) -> st.SearchStrategy[Mutation]:
    """A Verlet/Implicit time step k times too large, the span k times longer (same step count):
    the run must stop with exit 3 (or finish), never write non-finite values."""
    targets = [p + (key,) for name in solvers for p, body in iter_keys(tree[name], (name,))
               if isinstance(body, dict) for key in ("Fixed dt", "Safety Factor") if _number(body.get(key))]

    def make(args: tuple) -> Mutation:
        p, k = args
        name = p[0]
        sec = tree[name]
        t0 = _number(sec.get("Initial Time", 0.0)) or 0.0
        t1 = _number(sec.get("Final Time", t0 + 1.0))
        t1 = t0 + 1.0 if t1 is None else t1
        ops = (("set", p, _number(_parent(tree, p)[p[-1]]) * k), ("set", (name, "Final Time"), t0 + (t1 - t0) * k))
        return Mutation("unstable_step", p, k, f"{p[-1]} and the span x{k:g}", tree_ops=ops)

    return st.tuples(st.sampled_from(targets), st.sampled_from([2.0, 5.0, 20.0, 1e3, 1e6])).map(make)


def extreme_load(values: list[tuple[Path_, Any]]) -> st.SearchStrategy[Mutation]:
    """A boundary-condition expression scaled by a huge factor (a valid deck with absurd loads)."""

    def make(args: tuple) -> Mutation:
        (p, v), e = args
        new = f"1e{e}*({v})"
        return Mutation("extreme_load", p, new, tree_ops=(("set", p, new),), load_factor=10.0**e)

    return st.tuples(st.sampled_from(values), st.sampled_from([3, 6, 12, 100, 300])).map(make)


_SYNTAX_BREAKS = {"open_paren", "close_paren", "unknown_function", "empty", "garbage", "python", "trailing_op",
                  "wrong_arity", "bad_chars"}


def _broken(text: str, how: str) -> str:
    """``text`` (an expression) broken in the way ``how`` names."""
    return {
        "open_paren": f"({text}",
        "close_paren": f"{text})",
        "unknown_function": f"frobnicate({text})",
        "zero_div": "0/0",
        "div_zero": f"({text})/0",
        "overflow_pow": "10^400",
        "overflow_pow2": "10**400",
        "overflow_exp": "exp(1000)",
        "overflow_literal": f"1e999*{text}",
        "tower": "t^t^t^t^t^t^t^t",
        "sqrt_neg": "sqrt(-1)",
        "log_zero": "log(0)",
        "long": "+".join(["t"] * 5000),
        "deep": "(" * 600 + "t" + ")" * 600,
        "unary_chain": "-" * 5000 + "1",
        "nul": f"{text}\x00",
        "bell": f"\x07{text}",
        "newline": f"{text}\n+1",
        "ansi": f"\x1b[31m{text}",
        "bidi": f"{text}\u202e",
        "empty": "",
        "garbage": f"{text} {text}",
        "trailing_op": f"{text} *",
        "python": "__import__('os').system('touch PWNED')",
        "dunder": "x.__class__",
        "wrong_arity": f"sin({text}, {text})",
        "bad_chars": f"{text} $ @",
        "nan_word": "nan*t",
        "huge_const": "1e308*1e308",
        # valid expressions that become non-finite only when evaluated (at t = 0, or anywhere)
        "runtime_sqrt": "sqrt(t-1e30)",
        "runtime_log": "log(t)",
        "runtime_inv": "1/t",
        "runtime_nan": "0*log(t)",
        "runtime_acos": "acos(2+t)",
        "runtime_space": "1/(x-x)",
    }[how]


def broken_expression(targets: list[tuple[Path_, Any]]) -> st.SearchStrategy[Mutation]:
    hows = ["open_paren", "close_paren", "unknown_function", "zero_div", "div_zero", "overflow_pow", "overflow_pow2",
            "overflow_exp", "overflow_literal", "tower", "sqrt_neg", "log_zero", "long", "deep", "unary_chain", "nul",
            "bell", "newline", "ansi", "bidi", "empty", "garbage", "trailing_op", "python", "dunder", "wrong_arity",
            "bad_chars", "nan_word", "huge_const", "runtime_sqrt", "runtime_log", "runtime_inv", "runtime_nan",
            "runtime_acos", "runtime_space"]

    def make(args: tuple) -> Mutation:
        (p, v), how = args
        new = _broken(str(v), how)
        why = None
        if how in _SYNTAX_BREAKS and p[-1] in EXPRESSION_KEYS and not (how == "garbage" and str(v).strip()[:1] in "+-"):
            why = f"syntax error ({how}) in the expression {p[-1]!r}"
        return Mutation("broken_expression", p, new, how, tree_ops=(("set", p, new),), expect_refusal=why)

    return st.tuples(st.sampled_from(targets), st.sampled_from(hows)).map(make)


# -- files ---------------------------------------------------------------------------------------
_TEXT_EDITS = ["nan", "inf", "-1", "0", "1.5", "1e30", "99999999999", "abc", "\xff\xfe", "1 2 3 4 5 6 7 8", "",
               "dup_all", "no_newlines", "crlf", "tabs"]


def file_mutation(refs: list[tuple[Path_, str, bool]]) -> st.SearchStrategy[Mutation]:
    """``refs``: (deck path, file name as written, is_node_set) of the deck's input files."""

    def make(args: tuple) -> Mutation:
        (p, name, node_set), op, frac, k, edit = args
        stem, suffix = Path(name).stem, Path(name).suffix
        exodus = suffix.lower() in EXODUS_SUFFIXES
        if op == "missing":
            new = f"missing_{stem}{suffix}"
            return Mutation("file_missing", p, new, tree_ops=(("set", p, new),), expect_refusal="the file does not exist")
        if op == "folder":
            new = f"{stem}_folder{suffix}"
            return Mutation("file_folder", p, new, tree_ops=(("set", p, new),), file_ops=(("mkdir", new, None),),
                            expect_refusal="the file is a folder")
        if op == "absolute":
            new = f"/nonexistent/{stem}{suffix}"
            return Mutation("file_missing", p, new, "absolute", tree_ops=(("set", p, new),), expect_refusal="no such file")
        if op == "truncate":
            why = "truncated to 0 bytes" if frac == 0.0 and (exodus or not node_set) else None
            why = why or ("truncated Exodus file" if exodus and frac < 0.5 else None)
            return Mutation("file_truncate", p, name, f"keep {frac:.0%}", file_ops=(("truncate", name, frac),), expect_refusal=why)
        if op == "flip":
            return Mutation("file_flip", p, name, f"flip {k} byte(s) from {frac:.0%}", file_ops=(("flip", name, (frac, k)),))
        if op == "garbage":
            return Mutation("file_garbage", p, name, "random bytes", file_ops=(("garbage", name, k),),
                            expect_refusal="the file holds random bytes")
        if exodus:  # text edits make no sense for a binary file: write text instead
            return Mutation("file_garbage", p, name, "text instead of Exodus", file_ops=(("write", name, "hello world\n"),),
                            expect_refusal="a text file given as an Exodus mesh")
        why = None
        if node_set and edit in ("nan", "-1", "99999999999", "abc", "\xff\xfe"):
            why = f"node-set file with an invalid id {edit!r}"
        if not node_set and edit in ("nan", "inf", "abc", "\xff\xfe"):
            why = f"mesh text file with an invalid number {edit!r}"
        return Mutation("file_text", p, name, f"line {frac:.0%}: {edit!r}", file_ops=(("text", name, (frac, edit)),),
                        expect_refusal=why)

    ops = ["missing", "folder", "absolute", "truncate", "flip", "garbage", "text", "text", "text"]
    fracs = st.sampled_from([0.0, 0.01, 0.1, 0.5, 0.9, 0.999])
    return st.tuples(st.sampled_from(refs), st.sampled_from(ops), fracs, st.sampled_from([1, 8, 64]),
                     st.sampled_from(_TEXT_EDITS)).map(make)


def duplicate_output(outputs: list[Path_], tree: dict) -> st.SearchStrategy[Mutation]:
    def make(args: tuple) -> Mutation:
        p, second = args
        if second is not None and second != p and "Output Filename" in tree[second[0]]:
            q = second + ("Output Filename",)
            name = tree[p[0]].get("Output Filename", "dump")
            return Mutation("duplicate_output", q, name, f"same file name as {p[0]!r}", tree_ops=(("set", q, name),))
        return Mutation("duplicate_output", p, f"{p[0]} Copy", "section copied", tree_ops=(("copy", p, f"{p[0]} Copy"),),
                        expect_refusal="two output sections write the same file")

    return st.tuples(st.sampled_from(outputs), st.sampled_from([None, *outputs])).map(make)


def time_order(solvers: list[str], tree: dict) -> st.SearchStrategy[Mutation]:
    def make(args: tuple) -> Mutation:
        name, how = args
        sec = tree[name]
        t0 = _number(sec.get("Initial Time", 0.0)) or 0.0
        t1 = _number(sec.get("Final Time", t0 + 1.0))
        t1 = t0 + 1.0 if t1 is None else t1
        span = abs(t1 - t0) or 1.0
        if how == "equal":
            ops = (("set", (name, "Final Time"), t0),)
        elif how == "before":
            ops = (("set", (name, "Final Time"), t0 - span),)
        elif how == "negative":
            ops = (("set", (name, "Initial Time"), 0.0), ("set", (name, "Final Time"), -1.0))
        else:  # start after the end
            ops = (("set", (name, "Initial Time"), t1 + span),)
        return Mutation("time_order", (name,), how, tree_ops=ops, expect_refusal="Final Time <= Initial Time")

    return st.tuples(st.sampled_from(solvers), st.sampled_from(["equal", "before", "negative", "start_after"])).map(make)


_TEXT_INSERTS = ["\t", "\x00", "\xff", ": :", "- item\n", "{", "<", "]]>", "&amp;", "\r", "\n\n", " " * 3, "\ufeff",
                 "Peridigm:\n", "<ParameterList>", "!!python/object:os.system", "*alias"]


def deck_text(fmt: str) -> st.SearchStrategy[Mutation]:
    def make(args: tuple) -> Mutation:
        op, frac, arg = args
        detail = f"{op} at {frac:.0%}" + (f": {arg!r}" if op == "insert" else "")
        return Mutation("deck_text", (), arg if op == "insert" else None, detail, text_op=(op, frac, arg))

    ops = st.sampled_from(["truncate", "insert", "insert", "drop_line", "dup_line", "tabs", "crlf", "empty"])
    return st.tuples(ops, st.floats(0.0, 1.0), st.sampled_from(_TEXT_INSERTS)).map(make)


# -- issue 19: what an independent campaign found and this one did not draw -----------------------
#: sub-sections deleted whole by ``delete_section`` (besides every top-level section)
SUBSECTIONS = {"Adaptive Load-Stepping", "Switch to Verlet", "Linear Solver", "Direction", "Line Search", "Newton",
               "Verlet", "QuasiStatic", "Implicit", "NOXQuasiStatic", "ImplicitDiffusion", "Shapes", "Bond Filters",
               "Models", "Interactions", "Output Variables", "Damage Models", "Printing", "Solver Options"}


def delete_section(tree: dict) -> st.SearchStrategy[Mutation] | None:
    """A whole section removed: a top-level one (Solver, Output, Contact, ...) or a named sub-section
    (a solver's method, Adaptive Load-Stepping, Switch to Verlet, Linear Solver, Shapes, ...)."""
    required = {"Discretization", "Materials", "Blocks"}
    paths = [(k,) for k, v in tree.items() if isinstance(v, dict)]
    paths += [p for p, v in iter_keys(tree) if len(p) > 1 and isinstance(v, dict) and p[-1] in SUBSECTIONS]
    if not paths:
        return None

    def make(p: Path_) -> Mutation:
        why = f"deleted the required section {p[0]!r}" if len(p) == 1 and p[0] in required else None
        if len(p) == 2 and "Solver" in p[0] and p[1] in ("Verlet", "QuasiStatic", "Implicit", "NOXQuasiStatic", "ImplicitDiffusion"):
            why = f"{p[0]!r} lost its only method {p[1]!r}" if sum(isinstance(v, dict) for v in _parent(tree, p).values()) == 1 else None
        return Mutation("delete_section", p, None, "whole section", tree_ops=(("delete", p, None),), expect_refusal=why)

    return st.sampled_from(paths).map(make)


#: non-finite values spelled the ways a deck can spell them (YAML .nan/.inf, text nan, XML doubles)
NONFINITE: list[Any] = [math.nan, math.inf, -math.inf, Raw(".nan", ("double", "nan"), ".nan"),
                        Raw("-.inf", ("double", "-inf"), "-.inf"), Raw(".inf", ("double", "inf"), ".inf"),
                        Raw("-.nan", ("double", "-nan"), "-.nan"), "nan", "-inf"]


def nonfinite_anywhere(leaves: list[tuple[Path_, Any]]) -> st.SearchStrategy[Mutation]:
    """nan / inf / -.inf on any leaf, whatever its type: booleans, names, keys peridyn ignores
    (Verbose, Output Precision, ...) - an ignored key must stay ignored, never crash or leak."""

    def make(args: tuple) -> Mutation:
        (p, old), v = args
        return Mutation("nonfinite_anywhere", p, v, f"was {type(old).__name__}", tree_ops=(("set", p, v),))

    return st.tuples(st.sampled_from(leaves), st.sampled_from(NONFINITE)).map(make)


#: keys whose value names a file (read or written)
FILE_KEYS = {"Input Mesh File", "Output Filename", "File Name", "Node Set", "Restart File", "Data File"}


def long_string(leaves: list[tuple[Path_, Any]]) -> st.SearchStrategy[Mutation]:
    """Very long names: 255, 256, 300 and 5000 characters, long folder chains; on file names (an
    output name too long for the file system must be an input error, not a crash) and on any string."""
    files = [(p, v) for p, v in leaves if isinstance(v, str) and (p[-1] in FILE_KEYS or "Node Set" in p[-1] or "File" in p[-1])]
    names = [(p, v) for p, v in leaves if isinstance(v, str)]

    def make(args: tuple) -> Mutation:
        (p, old), how = args
        stem = {"n255": "a" * 255, "n256": "b" * 256, "n300": "c" * 300, "n5000": "d" * 5000,
                "dirs": "/".join(["x" * 60] * 80), "dots": "../" * 200 + "f", "space300": "e " * 150}[how]
        suffix = Path(old).suffix if p[-1] != "Output Filename" else ""
        new = stem + suffix
        why = None
        if p[-1] in ("Input Mesh File",) or "Node Set" in p[-1]:
            why = "names a file that cannot exist"
        return Mutation("long_string", p, new, f"{how} ({len(new)} chars)", tree_ops=(("set", p, new),), expect_refusal=why)

    pool = files * 3 + names
    return st.tuples(st.sampled_from(pool), st.sampled_from(["n255", "n256", "n300", "n300", "n5000", "dirs", "dots", "space300"])).map(make)


#: scale factors that found bugs: unit slips (GPa <-> Pa, mm <-> m, g <-> kg), x10, x0.3, x1660, 1e+-300
FACTORS = [10.0, 0.3, 2.0, 0.5, 1660.0, 1e-9, 1e9, 1e-6, 1e6, 1e-3, 1e3, 1e-300, 1e300, 1e308, -1.0, 0.0]
#: tiny and huge positives
POSITIVES = [5e-324, 2.2250738585072014e-308, 1e-300, 1e-30, 1e-12, 1e12, 1e30, 1e300, 1.7976931348623157e308]


def _family_of(tree: dict, path: Path_) -> str | None:
    """The model family a key belongs to (see FAMILIES), or None."""
    joined = " > ".join(path)
    model = ""
    if path[0] in ("Materials", "Damage Models") and len(path) > 2 and isinstance(tree.get(path[0], {}).get(path[1]), dict):
        sec = tree[path[0]][path[1]]
        model = str(sec.get("Material Model", sec.get("Damage Model", sec.get("Type", ""))))
    if path[0] == "Contact":
        return "contact"
    if "Adaptive Load-Stepping" in path or "Switch to Verlet" in path:
        return "adaptive_load_stepping"
    if path[-1] == "Initialize Predictor From Previous Solver" or "Predictor" in path[-1]:
        return "predictors"
    if any(k in joined for k in ("Linear Solver", "Preconditioner", "Belos", "Aztec", "AMG", "Direction", "Line Search")):
        return "linear_solver"
    if "Shapes" in path:
        return "shapes"
    if "Multiphysics" in model or path[0] == "Multiphysics" or "Fluid" in path[-1]:
        return "multiphysics"
    if "Diffusion" in model or "ImplicitDiffusion" in path or "Temperature" in joined:
        return "diffusion"
    if "Partial Volume" in model or "Element-Horizon" in path[-1]:
        return "partial_volumes"
    if "Interface" in joined or "Interface" in model or path[-1] == "Construct Interfaces":
        return "interfaces"
    if model == "Pals" or "Influence Function" in path[-1]:
        return "pals"
    if "Viscoelastic" in model:
        return "viscoelastic"
    if "Correspondence" in model:
        return "correspondence"
    if "Plastic" in model or "Hardening" in model or "Yield" in path[-1]:
        return "plasticity"
    if path[0] == "Damage Models" or "Bond Filters" in path:
        return "damage"
    if "Solver" in path[0] and path[-1] in ("Fixed dt", "Safety Factor", "Number of Load Steps", "Time Steps"):
        return "time_stepping"
    return None


FAMILIES = ("contact", "correspondence", "plasticity", "viscoelastic", "pals", "partial_volumes", "diffusion",
            "multiphysics", "interfaces", "predictors", "adaptive_load_stepping", "shapes", "linear_solver", "damage",
            "time_stepping")


def family_of_case(tree: dict, mutation: Mutation) -> str | None:
    """The family a mutation reached (by the key it changed, or the model it swapped in)."""
    if mutation.kind in ("model_swap", "solver_choice", "step_size") and mutation.detail.split(":")[0] in FAMILIES:
        return mutation.detail.split(":")[0]
    return _family_of(tree, mutation.path) if mutation.path else None


def family_number(tree: dict, only: str | None = None) -> st.SearchStrategy[Mutation] | None:
    """A numeric (or boolean) key of one model family present in the deck (families first, then a
    key: a deck's few contact or plasticity keys are not drowned by its many boundary conditions),
    scaled by a factor that found bugs, or set to a tiny/huge positive or a non-finite value."""
    by_family: dict[str, list[tuple[Path_, Any]]] = {}
    for p, v in iter_leaves(tree):
        fam = _family_of(tree, p)
        if fam and (only is None or fam == only) and (_number(v) is not None or isinstance(v, bool)):
            by_family.setdefault(fam, []).append((p, v))
    if not by_family:
        return None

    def make(args: tuple) -> Mutation:
        fam, i, how, j = args
        p, v = by_family[fam][i % len(by_family[fam])]
        x = _number(v)
        if isinstance(v, bool) or x is None:
            new: Any = (not v) if how != "nonfinite" else NONFINITE[j % len(NONFINITE)]
            return Mutation("family_number", p, new, f"{fam}: flipped", tree_ops=(("set", p, new),))
        if how == "scale":
            f = FACTORS[j % len(FACTORS)]
            new = x * f
            if isinstance(v, int) and abs(new) < 2**31 and new == int(new):
                new = int(new)
            detail = f"{fam}: x{f:g}"
        elif how == "positive":
            new = POSITIVES[j % len(POSITIVES)]
            detail = f"{fam}: {new:g}"
        else:
            new = NONFINITE[j % len(NONFINITE)]
            detail = f"{fam}: non-finite"
        return Mutation("family_number", p, new, detail, tree_ops=(("set", p, new),))

    return st.tuples(st.sampled_from(sorted(by_family)), st.integers(0, 200), st.sampled_from(["scale", "scale", "positive", "nonfinite"]),
                     st.integers(0, 100)).map(make)


def step_size(tree: dict, only: str | None = None) -> st.SearchStrategy[Mutation] | None:
    """A time step or load-step count at any depth, added where absent: Fixed dt / Safety Factor in
    Verlet, Implicit and fallback sublists (QuasiStatic > Adaptive Load-Stepping > Switch to
    Verlet), Number of Load Steps, Time Steps. Tiny steps ask for absurd work: the run must refuse
    (exit 2 with an estimate) or stop, never hang."""
    targets: list[tuple[Path_, str]] = []
    for p, v in iter_keys(tree):
        if not ("Solver" in p[0] and isinstance(v, dict)):
            continue
        if p[-1] in ("Verlet", "Switch to Verlet", "Implicit"):
            targets += [(p, "Fixed dt"), (p, "Safety Factor")]
        if p[-1] in ("QuasiStatic", "NOXQuasiStatic", "ImplicitDiffusion"):
            targets += [(p, "Number of Load Steps")]
        if p[-1] == "Adaptive Load-Stepping":
            targets += [(p + ("Switch to Verlet",), "Fixed dt")] if "Switch to Verlet" not in v else []
    if only == "adaptive_load_stepping":
        targets = [t for t in targets if "Adaptive Load-Stepping" in t[0]]
    if not targets:
        return None
    values = [1e-300, 5e-324, 1e-20, 1e-12, 1e-9, 1e3, 1e300, 0.0, -1.0, math.nan, math.inf, 2**31 - 1, 10**7]

    def make(args: tuple) -> Mutation:
        (p, key), val = args
        if key == "Number of Load Steps":
            val = int(val) if isinstance(val, float) and math.isfinite(val) and abs(val) < 2**31 and val == int(val) else val
        ops: tuple = ()
        node = tree
        for k in p[:-1]:
            node = node[k]
        if p[-1] not in node:  # a fallback sublist the deck lacks: add it
            ops += (("set", p, {}),)
        ops += (("set", p + (key,), val),)
        fam = "adaptive_load_stepping" if "Adaptive Load-Stepping" in p else "time_stepping"
        return Mutation("step_size", p + (key,), val, f"{fam}: {key}", tree_ops=ops)

    return st.tuples(st.sampled_from(targets), st.sampled_from(values)).map(make)


#: models swapped in (a valid parameter set derived from the deck's moduli): families no deck has
_SWAPS = {
    "Viscoelastic": ("viscoelastic", {"lambda_i": 0.5, "tau b": "span"}),
    "Pals": ("pals", {"Dilatation Influence Function": "One", "Deviatoric Influence Function": "Parabolic Decay"}),
    "Elastic Plastic": ("plasticity", {"Yield Stress": "yield"}),
    "Elastic Plastic Hardening": ("plasticity", {"Yield Stress": "yield", "Hardening Modulus": "hardening"}),
    "Elastic Correspondence": ("correspondence", {"Hourglass Coefficient": 0.02}),
    "Elastic Plastic Correspondence": ("correspondence", {"Hourglass Coefficient": 0.02, "Yield Stress": "yield"}),
    "Elastic Hypoelastic Correspondence": ("correspondence", {"Hourglass Coefficient": 0.02}),
    "Elastic Bond Associated Correspondence": ("correspondence", {}),
    "Elastic Partial Volume": ("partial_volumes", {}),
    "Linear LPS Partial Volume": ("partial_volumes", {}),
    "Elastic Bond Based": ("bond_based", {}),
}


def model_swap(tree: dict, only: str | None = None) -> st.SearchStrategy[Mutation] | None:
    """A material given another model (its moduli kept, the new model's parameters added with valid
    values), and maybe one of the new parameters scaled: mutations reach viscoelastic, Pals,
    plasticity, correspondence and partial-volume code from decks that use plain Elastic."""
    mats = [(k, v) for k, v in (tree.get("Materials") or {}).items() if isinstance(v, dict) and "Density" in v
            and any(m in v for m in ("Bulk Modulus", "Young's Modulus"))]
    if not mats:
        return None
    t0 = _number(next((v.get("Initial Time") for k, v in tree.items() if "Solver" in k and isinstance(v, dict)), 0.0)) or 0.0
    t1 = _number(next((v.get("Final Time") for k, v in tree.items() if "Solver" in k and isinstance(v, dict)), 1.0)) or 1.0
    span = abs(t1 - t0) or 1.0

    def make(args: tuple) -> Mutation:
        (name, mat), model, scale_key, f = args
        fam, params = _SWAPS[model]
        modulus = _number(mat.get("Bulk Modulus")) or _number(mat.get("Young's Modulus")) or 1.0
        ops: list = [("set", ("Materials", name, "Material Model"), model)]
        added = {}
        for key, val in params.items():
            val = {"span": span / 5, "yield": abs(modulus) * 1e-3, "hardening": abs(modulus) * 1e-2}.get(val, val) if isinstance(val, str) else val
            added[key] = val
            ops.append(("set", ("Materials", name, key), val))
        detail = f"{fam}: {mat.get('Material Model')!r} -> {model!r}"
        numeric = [k for k, v in added.items() if _number(v) is not None]
        if numeric and f != 1.0:
            key = numeric[scale_key % len(numeric)]
            ops.append(("set", ("Materials", name, key), added[key] * f))
            detail += f", {key} x{f:g}"
        return Mutation("model_swap", ("Materials", name, "Material Model"), model, detail, tree_ops=tuple(ops))

    models = sorted(m for m, (fam, _) in _SWAPS.items() if only is None or fam == only)
    if not models:
        return None
    return st.tuples(st.sampled_from(mats), st.sampled_from(models), st.integers(0, 5),
                     st.sampled_from([1.0, 1.0, 1.0, *FACTORS])).map(make)


def solver_choice(tree: dict, only: str | None = None) -> st.SearchStrategy[Mutation] | None:
    """Linear solver / preconditioner choices in implicit solver sublists (AMG, Direct, Auto,
    Adaptive, Belos GMRES, unknown names), and the predictor switch."""
    subs = [p for p, v in iter_keys(tree) if "Solver" in p[0] and isinstance(v, dict)
            and p[-1] in ("QuasiStatic", "NOXQuasiStatic", "Implicit", "ImplicitDiffusion")]
    tops = [(k,) for k, v in tree.items() if "Solver" in k and isinstance(v, dict)]
    if not subs and not tops:
        return None
    choices = [("Linear Solver", "AMG"), ("Linear Solver", "Direct"), ("Linear Solver", "Auto"), ("Linear Solver", "Adaptive"),
               ("Linear Solver", "Belos"), ("Linear Solver", "amg"), ("Linear Solver", "Multigrid"),
               ("Belos Linear Solver", "BlockGMRES"), ("Belos Linear Solver", "BlockCG"), ("Belos Linear Solver", "Pseudo"),
               ("Linear Solver Tolerance", 1e-300), ("Linear Solver Tolerance", 0.5), ("Linear Solver Tolerance", math.nan),
               ("Belos Relative Tolerance", 1e-300), ("Belos Maximum Iterations", 1), ("Preconditioner", "None"),
               ("Preconditioner", "AMG"), ("Peridigm Preconditioner", "Full Tangent"), ("Peridigm Preconditioner", "Block 3x3")]

    def make(args: tuple) -> Mutation:
        i, (key, val), pred = args
        if pred and tops:
            p = tops[i % len(tops)] + ("Initialize Predictor From Previous Solver",)
            return Mutation("solver_choice", p, True, "predictors: on", tree_ops=(("set", p, True),))
        if not subs:
            p = tops[i % len(tops)] + ("Initialize Predictor From Previous Solver",)
            return Mutation("solver_choice", p, False, "predictors: off", tree_ops=(("set", p, False),))
        p = subs[i % len(subs)] + (key,)
        return Mutation("solver_choice", p, val, f"linear_solver: {key}", tree_ops=(("set", p, val),))

    preds = {"predictors": [True], "linear_solver": [False]}.get(only or "", [False, False, False, True])
    return st.tuples(st.integers(0, 50), st.sampled_from(choices), st.sampled_from(preds)).map(make)


def family_mutations(tree: dict, family: str) -> st.SearchStrategy[Mutation] | None:
    """A mutation aimed at one model family (see FAMILIES), or None if this tree cannot reach it."""
    options = [s for s in (family_number(tree, family), model_swap(tree, family)) if s is not None]
    if family in ("time_stepping", "adaptive_load_stepping"):
        options += [s for s in (step_size(tree, family),) if s is not None]
    if family in ("linear_solver", "predictors"):
        options += [s for s in (solver_choice(tree, family),) if s is not None]
    return st.sampled_from(options).flatmap(lambda s: s) if options else None


def reaches(tree: dict, family: str) -> bool:
    """Whether ``family_mutations(tree, family)`` can draw anything."""
    if family in ("linear_solver", "predictors"):
        return any("Solver" in k for k in tree) and (family == "predictors" or any(
            p[-1] in ("QuasiStatic", "NOXQuasiStatic", "Implicit", "ImplicitDiffusion") for p, _ in iter_keys(tree)))
    if family in _FAMILY_MODELS:
        return True if model_swap(tree, family) is not None else any(_family_of(tree, p) == family for p, _ in iter_leaves(tree))
    if family in ("time_stepping", "adaptive_load_stepping") and step_size(tree, family) is not None:
        return True
    return any(_family_of(tree, p) == family for p, v in iter_leaves(tree) if _number(v) is not None or isinstance(v, bool))


_FAMILY_MODELS = {fam for fam, _ in _SWAPS.values()}


# ------------------------------------------------------------------------------------------------
# Putting them together
# ------------------------------------------------------------------------------------------------
def _is_node_set_key(path: Path_) -> bool:
    return path[0] == "Boundary Conditions" and "NODE_SET" in path[-1].upper().replace(" ", "_")


def file_refs(deck: DeckInfo, tree: dict) -> list[tuple[Path_, str, bool]]:
    """String leaves of ``tree`` that name an existing file relative to the deck's folder."""
    out = []
    for p, v in iter_leaves(tree):
        if isinstance(v, str) and v and len(v) < 300 and "\x00" not in v:
            try:
                if (deck.folder / v).is_file():
                    out.append((p, v, _is_node_set_key(p)))
            except OSError:
                continue
    return out


def mutations(deck: DeckInfo, tree: dict | None = None, focus: str = "check", family: str | None = None) -> st.SearchStrategy[Mutation]:
    """One mutation of ``tree`` (default: the deck's own), drawn from every applicable class
    (or, with ``family``, one aimed at that model family when the tree can reach it).

    ``focus="run"`` favours valid-but-extreme numbers and expressions (what only a run exercises)
    and avoids scaling values that would make the run much slower."""
    tree = deck.tree if tree is None else tree
    keys = [p for p, _ in iter_keys(tree)]
    leaves = list(iter_leaves(tree))
    numeric = [p for p, v in leaves if _number(v) is not None]
    refs = file_refs(deck, tree)
    ref_paths = {p for p, _, _ in refs}
    exprs = [(p, v) for p, v in leaves if isinstance(v, str) and p not in ref_paths and p[-1] not in NAME_KEYS]
    exprs += [(p, v) for p, v in leaves if p[-1] in EXPRESSION_KEYS and _number(v) is not None]
    outputs = [(name,) for name, v in tree.items() if "Output" in name and isinstance(v, dict)]
    solvers = [name for name, v in tree.items() if "Solver" in name and isinstance(v, dict)]
    options = [delete_key(keys), rename_key(keys), wrong_type(list(iter_keys(tree))), wrong_type(leaves or list(iter_keys(tree))),
               deck_text(deck.fmt)]
    run = focus == "run"
    if numeric:
        options += [extreme_number(numeric)] * 3
        options += [scale_number([(p, v) for p, v in leaves if _number(v) is not None], run)] * (6 if run else 1)
    if exprs:
        options += [broken_expression(exprs)] * (3 if run else 2)
    if refs:
        options += [file_mutation(refs)] * 2
    if outputs:
        options.append(duplicate_output(outputs, tree))
    if solvers:
        options.append(time_order(solvers, tree))
        if run and any(_number(b.get(k)) for n in solvers for _, b in iter_keys(tree[n]) if isinstance(b, dict)
                       for k in ("Fixed dt", "Safety Factor")):
            options += [unstable_step(solvers, tree)] * 4
    loads = [(p, v) for p, v in leaves if p[0] == "Boundary Conditions" and p[-1] == "Value" and isinstance(v, str)]
    if run and loads:
        options += [extreme_load(loads)] * 2
    # issue 19: whole sections, non-finite values on any key, long names, model families, steps
    sections = delete_section(tree)
    options += [sections if sections is not None else delete_key(keys), nonfinite_anywhere(leaves or list(iter_keys(tree)))]
    if any(isinstance(v, str) for _, v in leaves):
        options.append(long_string(leaves))
    extra = [(family_number(tree), 4 if run else 3), (step_size(tree), 2 if run else 1), (model_swap(tree), 2 if run else 1),
             (solver_choice(tree), 1)]
    for strategy, weight in extra:
        if strategy is not None:
            options += [strategy] * weight
    if family is not None:
        aimed = family_mutations(tree, family)
        options = [aimed] if aimed is not None else options
    fmts = st.sampled_from(["xml", "yaml", "yaml"]) if deck.fmt == "xml" else st.just("yaml")
    chosen = st.sampled_from(options).flatmap(lambda s: s)  # repeats in options are weights
    return st.tuples(chosen, fmts).map(lambda mf: _with_fmt(*mf))


def _with_fmt(m: Mutation, fmt: str) -> Mutation:
    m.fmt = fmt
    return m
