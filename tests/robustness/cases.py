"""A test case: one deck, one mutation, ``check`` or ``run``; and writing it to a folder.

:func:`cases` draws a :class:`Case` (for ``run``: a deck that passes ``check``, shrunk with
:func:`shrink_tree` so it runs in seconds, then mutated). :func:`prepare` writes the case: copies
of the deck's input files, the mutated deck (YAML through ``dump_yaml``, or Peridigm XML), the file
and deck-text corruptions, and a sentinel "earlier result" at every output file name.
"""
from __future__ import annotations

import copy
import hashlib
import random
import re
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np
from hypothesis import strategies as st
from mutations import (
    FAMILIES,
    DeckInfo,
    Mutation,
    Raw,
    _number,
    apply_tree_ops,
    iter_leaves,
    mutations,
    reaches,
)

from peridyn.deck.files import dump_yaml

# ------------------------------------------------------------------------------------------------
# Shrinking decks for ``run``
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Shrink:
    """How small to make a deck: points per direction, explicit steps, load steps."""

    points: int = 6
    steps: int = 20
    load_steps: int = 2
    spacing_factor: float = 4.0  #: generated shapes (Type: Shapes): lattice spacing and horizons times this

    def describe(self) -> str:
        return f"shrink(points<={self.points}, steps<={self.steps}, load steps<={self.load_steps})"


def shrinks() -> st.SearchStrategy[Shrink]:
    # at least 2 explicit steps: a span of one estimated step may round to 0 steps (an empty run)
    return st.builds(Shrink, st.sampled_from([1, 2, 3, 4, 6, 8]), st.sampled_from([2, 5, 10, 20, 40]),
                     st.sampled_from([1, 2, 3]))


def _has_node_sets(tree: dict) -> bool:
    """Whether the deck defines node sets (files or inline lists of point numbers), which fewer
    points would make invalid."""
    bcs = tree.get("Boundary Conditions")
    return isinstance(bcs, dict) and any("NODE_SET" in str(k).upper().replace(" ", "_") for k in bcs)


def shrink_tree(deck: DeckInfo, s: Shrink) -> dict:
    """A copy of the deck's tree with fewer points (if it has no node sets; spacing kept), fewer
    explicit steps (from ``deck.dt_hint`` when the step is not fixed) and fewer load steps."""
    tree = copy.deepcopy(deck.tree)
    disc = tree.get("Discretization")
    if isinstance(disc, dict) and not _has_node_sets(tree):
        for gen in disc.values():
            if not isinstance(gen, dict):
                continue
            for axis in "XYZ":
                n = gen.get(f"Number Points {axis}")
                length = _number(gen.get(f"{axis} Length"))
                if isinstance(n, int) and not isinstance(n, bool) and n > s.points:
                    gen[f"Number Points {axis}"] = s.points
                    if length is not None:
                        gen[f"{axis} Length"] = length * s.points / n
    if isinstance(disc, dict) and isinstance(disc.get("Shapes"), dict):
        # generated shapes: coarser lattices (node sets are the shapes themselves, so they stay)
        for shape in disc["Shapes"].values():
            h = _number(shape.get("Spacing")) if isinstance(shape, dict) else None
            if h is not None and h > 0:
                shape["Spacing"] = h * s.spacing_factor
        for blk in (tree.get("Blocks") or {}).values():
            hz = _number(blk.get("Horizon")) if isinstance(blk, dict) else None
            if hz is not None:
                blk["Horizon"] = hz * s.spacing_factor
    prev_end = None
    for name, sec in tree.items():
        if "Solver" not in name or not isinstance(sec, dict):
            continue
        t0, t1 = _number(sec.get("Initial Time", 0.0)), _number(sec.get("Final Time"))
        if t0 is None or t1 is None or t1 <= t0:
            continue
        if prev_end is not None and abs(t0 - prev_end[0]) <= 1e-12 * max(1.0, abs(t0)):
            t0_new = prev_end[1]
        else:
            t0_new = t0
        span = t1 - t0
        for method, body in sec.items():
            if not isinstance(body, dict):
                continue
            dt = _number(body.get("Fixed dt"))
            if method == "Verlet":
                if dt is None:  # check's estimate may be shorter than the run's step (contact, ...): 4x margin
                    dt = 4.0 * (deck.dt_hint or span / 50.0) * (_number(body.get("Safety Factor")) or 1.0)
                span = min(span, s.steps * dt)
            elif method == "Implicit" and dt is not None:
                span = min(span, min(s.steps, 3) * dt)
            if isinstance(body.get("Number of Load Steps"), int) and body["Number of Load Steps"] > s.load_steps:
                body["Number of Load Steps"] = s.load_steps
        if "Initial Time" in sec or t0_new != t0:
            sec["Initial Time"] = t0_new
        sec["Final Time"] = t0_new + span
        prev_end = (t1, t0_new + span)  # a solver that starts where this one ended follows it
    for name, sec in tree.items():
        if "Output" in name and isinstance(sec, dict):
            f = sec.get("Output Frequency")
            if isinstance(f, int) and not isinstance(f, bool) and f > 5:
                sec["Output Frequency"] = 5
    return tree


@dataclass
class Case:
    """A deck, one mutation, the command, and (for ``run``) how the deck was shrunk first."""

    deck: DeckInfo
    mutation: Mutation
    command: str = "check"
    shrink: Shrink | None = None

    def tree(self) -> dict:
        base = shrink_tree(self.deck, self.shrink) if self.shrink else self.deck.tree
        return apply_tree_ops(base, self.mutation.tree_ops)

    def __repr__(self) -> str:
        return f"<Case {self.describe()}>"

    def _repr_pretty_(self, printer: Any, cycle: bool) -> None:  # hypothesis' printer: stay short
        printer.text(repr(self))

    def describe(self) -> str:
        s = f" after {self.shrink.describe()}" if self.shrink else ""
        return f"{self.command} {self.deck.name}{s}: {self.mutation.describe()} (as {self.mutation.fmt})"


_REACHES: dict[tuple[int, str], bool] = {}


def _reaches(deck: DeckInfo, family: str) -> bool:
    key = (id(deck.tree), family)
    if key not in _REACHES:
        _REACHES[key] = reaches(deck.tree, family)
    return _REACHES[key]


@st.composite
def cases(draw, decks: list[DeckInfo], command: str) -> Case:
    """A case for ``command``: ``run`` uses decks whose ``check`` passes, shrunk, and leaves one
    case in eight unmutated (the shrunk deck itself must run cleanly); one case in three aims at a
    model family (FAMILIES), among the decks that reach it."""
    pool = [d for d in decks if d.baseline == 0] if command == "run" else decks + [d for d in decks if d.baseline == 0]
    # one case in three aims at a model family (contact, plasticity, ...: see FAMILIES), drawn first
    # so that the families of the few decks that have them are reached as often as the others
    family = draw(st.sampled_from(FAMILIES)) if draw(st.integers(0, 2)) == 0 else None
    if family is not None:
        pool = [d for d in pool if _reaches(d, family)] or pool
    deck = draw(st.sampled_from(pool or decks))
    if command != "run":
        return Case(deck, draw(mutations(deck, family=family)), command)
    s = draw(shrinks())
    tree = shrink_tree(deck, s)
    if family is None and draw(st.integers(0, 7)) == 0:
        return Case(deck, Mutation("none", detail="the shrunk deck unchanged"), command, s)
    return Case(deck, draw(mutations(deck, tree, focus="run", family=family)), command, s)


# ------------------------------------------------------------------------------------------------
# Writing the case
# ------------------------------------------------------------------------------------------------
def deck_bytes(tree: dict, fmt: str) -> bytes:
    """``tree`` as YAML (through ``dump_yaml``, Raw leaves spliced in) or as Peridigm XML."""
    if fmt == "xml":
        return "\n".join(['<ParameterList name="Peridigm">', *_xml_lines(tree, 1), "</ParameterList>", ""]).encode()
    raws: list[Raw] = []

    def sub(node: Any) -> Any:
        if isinstance(node, dict):
            return {k: sub(v) for k, v in node.items()}
        if isinstance(node, Raw):
            raws.append(node)
            return f"@@RAW{len(raws) - 1}@@"
        return node

    text = dump_yaml(sub(tree))
    for i, raw in enumerate(raws):
        text = text.replace(f'"@@RAW{i}@@"', raw.yaml)
    return text.encode("utf-8", "surrogatepass")


def _xml_scalar(v: Any) -> tuple[str, str]:
    if isinstance(v, bool):
        return "bool", "true" if v else "false"
    if isinstance(v, int):
        return "int", str(v)
    if isinstance(v, float):
        return "double", repr(v)
    return "string", str(v)


def _xml_lines(tree: dict, level: int) -> list[str]:
    pad, out = "  " * level, []
    for k, v in tree.items():
        name = quoteattr(str(k))
        if isinstance(v, dict):
            out += [f"{pad}<ParameterList name={name}>", *_xml_lines(v, level + 1), f"{pad}</ParameterList>"]
            continue
        if isinstance(v, Raw):
            typ, val = v.xml
        elif isinstance(v, list):
            kinds = {_xml_scalar(x)[0] for x in v}
            typ = f"Array({kinds.pop()})" if len(kinds) == 1 else "Array(string)"
            val = "{" + ", ".join(_xml_scalar(x)[1] for x in v) + "}"
        else:
            typ, val = _xml_scalar(v)
        value = "" if val is None else f" value={quoteattr(val)}"
        out.append(f"{pad}<Parameter name={name} type={quoteattr(typ)}{value}/>")
    return out


def _text_op(data: bytes, op: tuple) -> bytes:
    kind, frac, arg = op
    lines = data.split(b"\n")
    i = min(int(len(lines) * frac), len(lines) - 1)
    if kind == "truncate":
        return data[: int(len(data) * frac)]
    if kind == "insert":
        pos = int(len(data) * frac)
        raw = arg.encode("latin-1") if arg == "\xff" else arg.encode("utf-8")
        return data[:pos] + raw + data[pos:]
    if kind == "drop_line":
        return b"\n".join(lines[:i] + lines[i + 1 :])
    if kind == "dup_line":
        return b"\n".join(lines[: i + 1] + lines[i:])
    if kind == "tabs":
        return re.sub(rb"(?m)^  ", b"\t", data)
    if kind == "crlf":
        return data.replace(b"\n", b"\r\n")
    return b""  # "empty"


def _file_op(folder: Path, op: tuple) -> None:
    kind, name, arg = op
    path = folder / name
    if kind == "mkdir":
        path.mkdir(parents=True, exist_ok=True)
        return
    if kind == "write":
        path.write_text(arg)
        return
    data = bytearray(path.read_bytes())
    if kind == "truncate":
        data = data[: int(len(data) * arg)]
    elif kind == "flip" and data:
        frac, k = arg
        start = int(len(data) * frac)
        for j in range(k):
            data[(start + 97 * j) % len(data)] ^= 0xFF
    elif kind == "garbage":
        data = bytearray(random.Random(arg * 7919 + len(data)).randbytes(max(len(data), 64)))
    elif kind == "text":
        data = bytearray(_text_edit(bytes(data), *arg))
    path.write_bytes(bytes(data))


def _text_edit(data: bytes, frac: float, edit: str) -> bytes:
    lines = data.decode("utf-8", "replace").splitlines()
    rows = [j for j, ln in enumerate(lines) if ln.strip() and not ln.lstrip().startswith("#")]
    if edit == "dup_all":
        return data + data
    if edit == "no_newlines":
        return " ".join(lines).encode()
    if edit == "crlf":
        return "\r\n".join(lines).encode() + b"\r\n"
    if edit == "tabs":
        return "\n".join(re.sub(r" +", "\t", ln) for ln in lines).encode() + b"\n"
    if edit == "":
        return b"\n\n\n"
    if edit == "1 2 3 4 5 6 7 8":
        return data.rstrip(b"\n") + b"\n1 2 3 4 5 6 7 8\n"
    if not rows:
        return data + edit.encode("latin-1") + b"\n"
    j = rows[min(int(len(rows) * frac), len(rows) - 1)]
    if edit == "\xff\xfe":
        return "\n".join(lines[:j]).encode() + b"\n\xff\xfe" + "\n".join(lines[j:]).encode() + b"\n"
    tokens = lines[j].split()
    tokens[int(frac * 997) % len(tokens)] = edit
    lines[j] = " ".join(tokens)
    return "\n".join(lines).encode() + b"\n"


def output_names(tree: dict) -> list[str]:
    """The Exodus file names (both .e and .h) the deck's output sections may write."""
    names = []
    for key, sec in tree.items():
        if "Output" in str(key) and isinstance(sec, dict):
            base = sec.get("Output Filename", "dump")
            if isinstance(base, str) and re.fullmatch(r"[\w][\w.\- ]{0,100}", base):
                names += [base + ".e", base + ".h"]
    return list(dict.fromkeys(names))


_SENTINEL: bytes | None = None


def sentinel_bytes() -> bytes:
    """A small valid Exodus file, made once, standing for an earlier run's result."""
    global _SENTINEL
    if _SENTINEL is None:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "earlier.e"
            try:
                from peridyn.io.exodus_writer import ExodusBlock, ExodusWriter

                w = ExodusWriter(path, coords=np.array([[0.0, 0, 0], [1.0, 0, 0]]), node_num_map=np.array([1, 2]),
                                 blocks=[ExodusBlock(1, "block_1", np.array([0, 1]))], nodal_vars=["DisplacementX"])
                w.write_step(0.0, nodal={"DisplacementX": np.zeros(2)})
                w.close()
            except Exception:  # the writer's API changed: a minimal netCDF file is enough
                import netCDF4

                with netCDF4.Dataset(str(path), "w", format="NETCDF3_64BIT_OFFSET") as ds:
                    ds.createDimension("time_step", None)
                    ds.createDimension("num_nodes", 2)
                    ds.createVariable("time_whole", "f8", ("time_step",))[0] = 0.0
                    ds.createVariable("coordx", "f8", ("num_nodes",))[:] = [0.0, 1.0]
            _SENTINEL = path.read_bytes()
    return _SENTINEL


@dataclass
class Prepared:
    root: Path
    deck: Path
    out: Path
    sentinels: dict[Path, str]
    names: set[str]


def prepare(case: Case, root: Path) -> Prepared:
    """Write the case under ``root``: the deck's input files, the mutated deck, sentinels."""
    folder = root / "case" / "deck"
    folder.mkdir(parents=True)
    names = {case.deck.path.name}
    for src in case.deck.neighbours():
        shutil.copyfile(src, folder / src.name)
        names.add(src.name)
    tree = case.tree()
    for ref in _up_refs(case.deck.tree):
        src, dst = (case.deck.folder / ref).resolve(), (folder / ref).resolve()
        if src.is_file() and root in dst.parents and not dst.exists():
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, dst)
            names.add(dst.name)
    for op in case.mutation.file_ops:
        _file_op(folder, op)
    data = deck_bytes(tree, case.mutation.fmt)
    if case.mutation.text_op is not None:
        data = _text_op(data, case.mutation.text_op)
    deck = folder / (case.deck.path.stem + (".xml" if case.mutation.fmt == "xml" else ".yaml"))
    deck.write_bytes(data)
    out = root / "out"
    out.mkdir()
    sentinels = {}
    for name in output_names(tree):
        p = out / name
        p.write_bytes(sentinel_bytes())
        sentinels[p] = sha(p)
    return Prepared(root, deck, out, sentinels, names)


def _up_refs(tree: dict) -> list[str]:
    return [v for _, v in iter_leaves(tree) if isinstance(v, str) and v.startswith("../") and len(v) < 300]


def sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def keep_reproducer(case: Case, folder: Path) -> Path:
    """Write the case's files (deck, inputs, sentinels) to ``folder`` for a bug report."""
    folder.mkdir(parents=True, exist_ok=True)
    prepare(case, folder)
    (folder / "MUTATION.txt").write_text(case.describe() + "\n")
    return folder
