"""Hypothesis strategies that mutate a Peridigm deck (one mutation per example).

A :class:`DeckInfo` is an example or conformance deck loaded into its raw tree. ``mutations(deck,
tree)`` draws one :class:`Mutation` of that tree: a deleted or renamed key, a value of the wrong
type, a non-finite or extreme number, a broken expression, a missing, folder-valued or corrupted
neighbouring file, a duplicated output file name, a Final Time not after the Initial Time, or a
damaged deck text; for ``run``, also valid but extreme numbers (``scale_number``). :mod:`cases`
shrinks decks for ``run`` and writes a case; :mod:`runner` executes and classifies it.
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
                "expect_refusal": self.expect_refusal, "fmt": self.fmt, "description": self.describe()}


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
SCALES = [1e-300, 1e-12, 1e-3, 10.0, 1e3, 1e12, 1e300, -1.0]


def scale_number(numeric: list[tuple[Path_, Any]], fast: bool = False) -> st.SearchStrategy[Mutation]:
    """Multiply a number by a huge or tiny factor (a valid but extreme deck: instabilities, NaN)."""

    def make(args: tuple) -> Mutation:
        (p, v), f = args
        if fast and ((p[-1] in SLOWER_UP and f > 1) or (p[-1] in SLOWER_DOWN and 0 < f < 1)):
            f = 1.0 / f
        new = float(v) * f
        if isinstance(v, int) and not isinstance(v, bool) and abs(new) < 2**31 and new == int(new):
            new = int(new)
        return Mutation("scale_number", p, new, f"x{f:g}", tree_ops=(("set", p, new),))

    return st.tuples(st.sampled_from(numeric), st.sampled_from(SCALES)).map(make)


def unstable_step(solvers: list[str], tree: dict) -> st.SearchStrategy[Mutation]:
    """A Verlet/Implicit time step k times too large, the span k times longer (same step count):
    the run must stop with exit 3 (or finish), never write non-finite values."""
    targets = [(name, method, key) for name in solvers for method, body in tree[name].items()
               if isinstance(body, dict) for key in ("Fixed dt", "Safety Factor") if _number(body.get(key))]

    def make(args: tuple) -> Mutation:
        (name, method, key), k = args
        sec = tree[name]
        t0 = _number(sec.get("Initial Time", 0.0)) or 0.0
        t1 = _number(sec.get("Final Time", t0 + 1.0))
        t1 = t0 + 1.0 if t1 is None else t1
        ops = (("set", (name, method, key), _number(sec[method][key]) * k), ("set", (name, "Final Time"), t0 + (t1 - t0) * k))
        return Mutation("unstable_step", (name, method, key), k, f"{key} and the span x{k:g}", tree_ops=ops)

    return st.tuples(st.sampled_from(targets), st.sampled_from([2.0, 5.0, 20.0, 1e3, 1e6])).map(make)


def extreme_load(values: list[tuple[Path_, Any]]) -> st.SearchStrategy[Mutation]:
    """A boundary-condition expression scaled by a huge factor (a valid deck with absurd loads)."""

    def make(args: tuple) -> Mutation:
        (p, v), e = args
        new = f"1e{e}*({v})"
        return Mutation("extreme_load", p, new, tree_ops=(("set", p, new),))

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


def mutations(deck: DeckInfo, tree: dict | None = None, focus: str = "check") -> st.SearchStrategy[Mutation]:
    """One mutation of ``tree`` (default: the deck's own), drawn from every applicable class.

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
        if run and any(_number(b.get(k)) for n in solvers for b in tree[n].values() if isinstance(b, dict)
                       for k in ("Fixed dt", "Safety Factor")):
            options += [unstable_step(solvers, tree)] * 4
    loads = [(p, v) for p, v in leaves if p[0] == "Boundary Conditions" and p[-1] == "Value" and isinstance(v, str)]
    if run and loads:
        options += [extreme_load(loads)] * 2
    fmts = st.sampled_from(["xml", "yaml", "yaml"]) if deck.fmt == "xml" else st.just("yaml")
    chosen = st.sampled_from(options).flatmap(lambda s: s)  # repeats in options are weights
    return st.tuples(chosen, fmts).map(lambda mf: _with_fmt(*mf))


def _with_fmt(m: Mutation, fmt: str) -> Mutation:
    m.fmt = fmt
    return m
