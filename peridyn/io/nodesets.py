"""Peridigm node-set values: inline lists of point numbers, or node-set files.

An entry of the ``Boundary Conditions`` list whose name contains ``Node Set`` defines a node set
(PERIDIGM_SEMANTICS.md §1.4). Its value is either

* an **inline list** of whitespace-separated 1-based point numbers (``"1 4 7 10"``), or
* the **name of a file** (relative to the deck's folder) holding such numbers.

A value is a file name when it has no space or tab, is not empty and does not read as a nonzero
integer; otherwise it is an inline list (``"0"`` is an inline list, and an error).

Node-set file format: each line is trimmed; lines that are empty or start with ``#``, ``/`` or
``*`` are skipped; every whitespace-separated token on the other lines is a 1-based point number.

Where peridyn deliberately differs from Peridigm (both are Peridigm defects, no deck relies on
them; listed in ``docs/peridigm-differences.md``):

* Peridigm appends the **last number twice** when an inline list has trailing whitespace (its
  extraction loop repeats the last value after the final, failed read: ``"1 "`` gives [1, 1]).
  peridyn parses the list correctly: ``"1 "`` gives [1].
* Peridigm stops reading a node-set file line at the first token that is not an integer and
  silently drops the rest of that line; peridyn reports it as an error with the line number.
* Peridigm classifies a value with ``strtol``, which reads a numeric *prefix*: a file named
  ``1_left.txt`` is taken for an inline list and fails. peridyn asks whether the whole value is
  an integer, so such file names work.
"""
from __future__ import annotations

import logging
import re
from pathlib import Path

import numpy as np

from ..core.errors import InputError, is_file, missing_file

__all__ = ["find_input_file", "is_node_set_file_name", "parse_node_set_value", "read_node_set_file"]

_log = logging.getLogger(__name__)

_INTEGER = re.compile(r"[+-]?[0-9]+\Z")
_COMMENT_STARTS = ("#", "/", "*")
_DIGITS_ONLY = re.compile(r"[0-9\s]*\Z")


def _exists(path: Path) -> bool:
    """Whether ``path`` exists; False for names the system refuses (too long, NUL bytes)."""
    try:
        return path.exists()
    except (OSError, ValueError):
        return False


def find_input_file(name: str, deck_dir: Path) -> Path:
    """The path of an input file named in a deck (mesh, node-set file).

    Relative names are relative to the deck's folder, then to the working folder (Peridigm's
    rule: its parallel tests run ``cd np2; Peridigm ../DECK``). When the file is in neither but a file of
    the same base name is in the deck's folder, that one is used, with a warning: Peridigm's test
    decks live in an ``np1/`` folder and name shared inputs ``../mesh.csv``, and the conformance
    runner copies a case's files flat into one folder. The returned path need not exist.
    """
    path = Path(name)
    if path.is_absolute():
        return path
    candidate = Path(deck_dir) / path
    if _exists(candidate):
        return candidate
    here = Path.cwd() / path  # where Peridigm looks: relative to the folder it runs in
    if here != candidate and _exists(here):
        return here
    fallback = Path(deck_dir) / path.name
    if path.name and is_file(fallback) and fallback != candidate:
        _log.warning("%s not found; using %s from the deck's folder", candidate, fallback)
        return fallback
    return candidate


def is_node_set_file_name(value: str) -> bool:
    """Whether a node-set value names a file (True) or is an inline list (False).

    A file name has no space or tab (after trimming), is not empty and is not an integer.
    """
    text = value.strip()
    if not text or " " in text or "\t" in text:
        return False
    return _INTEGER.match(text) is None


def _parse_ids(
    tokens: list[str], *, where: str, file: str | None, path: tuple[str, ...], line: int | None
) -> list[int]:
    ids: list[int] = []
    for token in tokens:
        if _INTEGER.match(token) is None:
            raise InputError(
                f"{where}: {token!r} is not a point number",
                file=file,
                path=path,
                line=line,
                fix="node sets list whole, 1-based point numbers separated by spaces",
            )
        value = int(token)
        if value >= 2**62:
            raise InputError(
                f"{where}: point number {token} is too large",
                file=file,
                path=path,
                line=line,
                fix="point numbers count the points of the mesh, from 1",
            )
        if value < 1:
            raise InputError(
                f"{where}: point number {value} is not allowed",
                file=file,
                path=path,
                line=line,
                fix="point numbers are 1-based: the first point is 1",
            )
        ids.append(value)
    return ids


def read_node_set_file(path: Path | str, *, deck_path: tuple[str, ...] = ()) -> np.ndarray:
    """Read a Peridigm node-set file.

    Parameters
    ----------
    path: the file to read.
    deck_path: the deck path of the node-set entry, for error messages.

    Returns
    -------
    (k,) int64 array of 1-based point numbers in file order (duplicates kept).

    Raises
    ------
    InputError: the file cannot be read, or holds a token that is not a positive integer
        (the message names the file and the line).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except FileNotFoundError:
        raise InputError(
            f"node-set file {str(path)!r} not found",
            path=deck_path,
            fix="check the file name; relative names are relative to the deck's folder",
        ) from None
    except OSError as exc:
        raise InputError(f"cannot read node-set file: {exc.strerror or exc}", file=str(path), path=deck_path) from None
    if _DIGITS_ONLY.match(text):  # the common case: nothing but point numbers (64k in 15 ms)
        try:
            ids_fast = np.array(text.split(), dtype=np.int64)
        except (ValueError, OverflowError):  # a number too large for int64: the slow path says so
            ids_fast = None
        if ids_fast is not None and (ids_fast.size == 0 or ids_fast.min() >= 1):
            return ids_fast
    ids: list[int] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith(_COMMENT_STARTS):
            continue
        ids.extend(_parse_ids(line.split(), where="node-set file", file=str(path), path=deck_path, line=number))
    return np.asarray(ids, dtype=np.int64)


def parse_node_set_value(value: str, *, deck_dir: Path, path: tuple[str, ...], deck_file: str) -> np.ndarray:
    """The point numbers of a node-set entry of the Boundary Conditions list.

    Parameters
    ----------
    value: the entry's value: an inline list (``"1 4 7"``) or a file name (``"nodeset_1.txt"``).
    deck_dir: the deck's folder; relative file names are looked up there.
    path: the entry's deck path, e.g. ``("Boundary Conditions", "Min X Node Set")``.
    deck_file: the deck file name, for error messages about inline lists.

    Returns
    -------
    (k,) int64 array of 1-based point numbers in the given order (duplicates kept; an empty or
    blank value gives an empty array).

    Raises
    ------
    InputError: a number is 0, negative or not an integer; the file is missing or malformed.
    """
    if not isinstance(value, str):
        raise InputError(
            f"node set value must be a string, got {type(value).__name__} {value!r}",
            file=deck_file,
            path=path,
            fix='quote it, e.g. "1 2 3" for points 1, 2 and 3, or give a node-set file name',
        )
    if is_node_set_file_name(value):
        name = value.strip()
        file_path = find_input_file(name, deck_dir)
        if not is_file(file_path):
            raise InputError(
                missing_file(name, "node-set file") if not _exists(file_path) else f"node-set file {name!r} is a folder, not a file",
                file=deck_file,
                path=path,
                fix=f"looked in {str(file_path.parent)!r}; an inline list of point numbers needs a space (\"1 2\")",
            )
        return read_node_set_file(file_path, deck_path=path)
    ids = _parse_ids(value.split(), where="inline node set", file=deck_file, path=path, line=None)
    return np.asarray(ids, dtype=np.int64)
