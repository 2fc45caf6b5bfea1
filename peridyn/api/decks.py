"""Decks for the Python API: from a file, from a dict (no file), or from point arrays.

A dict deck is the tree a YAML deck holds (``{"Discretization": {...}, "Materials": {...}}``,
optionally under a top key ``"Peridigm"``); it is written as YAML text and read back by the
deck loader, so a dict is typed and validated exactly as the same deck in a file would be.
"""
from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any, Union

import numpy as np

from ..core.discretization import Discretization
from ..core.errors import InputError
from ..core.interfaces import DiscretizationReader
from ..core.params import ModelParams
from ..deck.model import Deck, load_deck, parse_deck

#: what ``Model`` and ``Study`` accept as a deck
DeckLike = Union[str, "os.PathLike[str]", Mapping, Deck]

#: the file name dict decks carry in messages (inside ``directory``)
DICT_DECK_NAME = "<python deck>"


def deck_tree(deck: str | os.PathLike | Mapping) -> dict:
    """The raw tree of a deck file or a dict deck (a deep copy for a dict; no top key)."""
    if isinstance(deck, Mapping):
        tree = deck["Peridigm"] if set(deck) == {"Peridigm"} else deck
        return _plain(tree)
    from ..deck.files import load_deck_file

    return load_deck_file(deck).tree


def _plain(value: Any) -> Any:
    """A copy of ``value`` with numpy scalars and arrays as plain Python values."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    return value


def parse_tree(tree: Mapping, directory: str | os.PathLike | None = None) -> Deck:
    """Validate a dict deck. Relative file names in it (meshes, node-set files) are relative to
    ``directory`` (default: the current folder); messages name ``<directory>/<python deck>``."""
    from ..deck.files import dump_yaml
    from ..deck.yaml_reader import parse_yaml_text

    folder = Path(directory) if directory is not None else Path.cwd()
    text = dump_yaml(deck_tree(tree))
    return parse_deck(parse_yaml_text(text, str(folder / DICT_DECK_NAME)))


def build_deck(deck: DeckLike, directory: str | os.PathLike | None = None) -> Deck:
    """A validated :class:`Deck` from a file name, a dict deck or a Deck (returned as it is)."""
    if isinstance(deck, Deck):
        return deck
    if isinstance(deck, Mapping):
        return parse_tree(deck, directory)
    if isinstance(deck, (str, os.PathLike)):
        return load_deck(deck)
    raise TypeError(f"a deck is a file name, a dict or a Deck, not {type(deck).__name__}")


# ------------------------------------------------------------------------------------------------
# points given as arrays
# ------------------------------------------------------------------------------------------------
class _ArrayParams(ModelParams):
    """No parameters: the points come from Python."""


class _ArrayReader(DiscretizationReader):
    """A discretization whose points were handed over as arrays (``Model.from_points``)."""

    name = "Python arrays"
    Params = _ArrayParams
    points: Discretization  # set on the subclass made for each model

    def estimate_points(self) -> int | None:
        return self.points.num_points

    def read(self) -> Discretization:
        return self.points


def points_deck(x: np.ndarray, volume: np.ndarray, tree: Mapping, *, block_id: np.ndarray | int = 1,
                node_sets: Mapping[str, np.ndarray] | None = None, directory: str | os.PathLike | None = None) -> Deck:
    """A deck whose points are ``x`` (n, 3) reference positions (L) with cell volumes ``volume``
    (n,) (L^3) and block ids ``block_id`` ((n,) or one int; block ``k`` is ``block_k``).
    ``tree`` is a dict deck without a ``Discretization`` section, or with one holding only the
    shared keys (``Influence Function``, ``Bond Filters``, ``Omit Bonds Between Blocks``).
    ``node_sets``: name -> 0-based point indices, usable as ``Node Set`` in the deck's
    boundary conditions. Neighbors: every point within the horizon (inclusive)."""
    x = np.ascontiguousarray(np.asarray(x, dtype=np.float64))
    n = x.shape[0] if x.ndim == 2 else -1
    if x.ndim != 2 or x.shape[1] not in (2, 3):
        raise InputError(f"points: x has shape {x.shape}, expected (n, 3)", fix="give one row of 3 coordinates per point")
    if x.shape[1] == 2:
        x = np.hstack([x, np.zeros((n, 1))])
    volume = np.asarray(volume, dtype=np.float64).reshape(-1) if np.ndim(volume) else np.full(n, float(volume))
    if volume.shape != (n,) or not np.all(np.isfinite(volume) & (volume > 0)):
        raise InputError(f"points: volume must be {n} positive finite numbers (got shape {volume.shape})", fix="give one cell volume per point")
    if not np.all(np.isfinite(x)):
        raise InputError("points: x holds a non-finite coordinate", fix="give finite coordinates")
    ids = np.broadcast_to(np.asarray(block_id, dtype=np.int64), (n,)).copy()
    sets = {}
    for name, members in (node_sets or {}).items():
        idx = np.asarray(members)
        idx = np.nonzero(idx)[0] if idx.dtype == bool else idx.astype(np.int64)
        if idx.size and (idx.min() < 0 or idx.max() >= n):
            raise InputError(f"points: node set {name!r} lists an index outside 0..{n - 1}", fix="give 0-based point indices")
        sets[str(name)] = np.unique(idx)
    from ..io.textfile import min_element_radius

    disc = Discretization(x=x, volume=volume, block_id=ids, gid=np.arange(n, dtype=np.int64),
                          block_names={int(b): f"block_{int(b)}" for b in np.unique(ids)}, node_sets=sets,
                          min_element_radius=min_element_radius(volume), source="points given in Python")
    tree = deck_tree(tree)
    shared = dict(tree.get("Discretization") or {})
    extra = set(shared) - {"Influence Function", "Bond Filters", "Omit Bonds Between Blocks", "Type"}
    if extra:
        raise InputError(f"points: the Discretization section may hold only the shared keys, not {sorted(extra)}",
                         fix="the points are the arrays given; leave out mesh keys")
    # a stand-in type passes the deck's validation of the shared keys; the reader is swapped below
    shared.update({"Type": "Text File", "Input Mesh File": "<points given in Python>"})
    deck = parse_tree({**tree, "Discretization": shared}, directory)
    reader = type("PythonPoints", (_ArrayReader,), {"points": disc})
    deck.discretization = replace(deck.discretization, type=_ArrayReader.name, cls=reader, params=_ArrayParams())
    return deck
