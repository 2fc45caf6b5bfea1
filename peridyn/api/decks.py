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
from ..core.discretization import DiscretizationReader
from ..core.params import ModelParams
from ..deck.model import Deck, load_deck, parse_deck
from .checks import plain

#: what ``Model`` and ``Study`` accept as a deck
DeckLike = Union[str, "os.PathLike[str]", Mapping, Deck]

#: the file name dict decks carry in messages (inside ``directory``)
DICT_DECK_NAME = "<python deck>"


def deck_tree(deck: str | os.PathLike | Mapping) -> dict:
    """The raw tree of a deck file or a dict deck (a deep copy for a dict, as :func:`plain`
    makes it; no top key)."""
    if isinstance(deck, Mapping):
        tree = deck["Peridigm"] if set(deck) == {"Peridigm"} else deck
        if not isinstance(tree, Mapping):
            raise InputError(f"the deck's 'Peridigm' entry is a {type(tree).__name__}, not a mapping of sections",
                             file=DICT_DECK_NAME, path=("Peridigm",), fix="give {'Peridigm': {'Discretization': {...}, ...}} or the sections alone")
        return plain(tree)
    from ..deck.files import load_deck_file

    return load_deck_file(deck).tree


def parse_tree(tree: Mapping, directory: str | os.PathLike | None = None) -> Deck:
    """Validate a dict deck. Relative file names in it (meshes, node-set files) are relative to
    ``directory`` (default: the current folder); messages name ``<directory>/<python deck>``.
    Any value a deck cannot hold is an :class:`InputError` naming its deck path."""
    from ..deck.files import dump_yaml
    from ..deck.yaml_reader import parse_yaml_text

    folder = Path(directory) if directory is not None else Path.cwd()
    name = str(folder / DICT_DECK_NAME)
    try:
        text = dump_yaml(deck_tree(tree))
    except InputError as exc:
        raise exc.in_file(name) from None
    except (ValueError, TypeError) as exc:
        where, why = _first_bad(deck_tree(tree), ()) or ((), str(exc))
        raise InputError(why, file=name, path=where, fix="give a bool, int, float, str, a list of one kind of them, or a mapping") from None
    except RecursionError:
        raise InputError("the deck is nested too deeply", file=name, fix="give a deck of sections and values") from None
    return parse_deck(parse_yaml_text(text, name))


def _first_bad(tree: Mapping, path: tuple[str, ...]) -> tuple[tuple[str, ...], str] | None:
    """(deck path, why) of the first value of ``tree`` no deck can hold, or None."""
    from ..deck.files import dump_yaml

    for key, value in tree.items():
        if isinstance(value, Mapping):
            found = _first_bad(value, path + (key,))
            if found:
                return found
            continue
        try:
            dump_yaml({"v": value}, top_key=None)
        except (ValueError, TypeError) as exc:
            return path + (key,), str(exc).removeprefix("v: ")
    return None


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
    from .checks import ArgumentError, ArgumentTypeError, as_array, real_array, region_mapping

    call = "Model.from_points"
    if not isinstance(tree, Mapping):
        raise ArgumentTypeError(f"deck must be a dict deck, not {type(tree).__name__}", path=(call, "deck"),
                                fix="give the deck's sections as a dict, without Discretization")
    x, volume, block_id = (as_array(call, arg, v) for arg, v in (("x", x), ("volume", volume), ("block_id", block_id)))
    if x.ndim != 2 or x.shape[1] not in (2, 3) or x.shape[0] == 0:
        raise ArgumentError(f"x has shape {x.shape}, expected (n, 3) (or (n, 2)) with n >= 1", path=(call, "x"),
                            fix="give one row of 3 coordinates per point")
    n = x.shape[0]
    x = np.ascontiguousarray(real_array(call, "x", x, x.shape, np.float64))
    if x.shape[1] == 2:
        x = np.hstack([x, np.zeros((n, 1))])
    if volume.ndim and volume.shape != (n,):
        raise ArgumentError(f"volume has shape {volume.shape}, expected ({n},): one cell volume per row of x", path=(call, "volume"),
                            fix=f"give {n} volumes, or one number for all")
    volume = np.array(real_array(call, "volume", volume, (n,), np.float64))
    if not np.all(volume > 0):
        raise ArgumentError(f"volume holds {int(np.count_nonzero(volume <= 0))} value(s) that are not positive", path=(call, "volume"),
                            fix="give positive cell volumes (L^3)")
    if block_id.ndim and block_id.shape != (n,):
        raise ArgumentError(f"block_id has shape {block_id.shape}, expected ({n},)", path=(call, "block_id"),
                            fix=f"give {n} block ids, or one int for all")
    ids = np.array(real_array(call, "block_id", block_id, (n,), np.int64))
    if not np.all(ids >= 1):
        raise ArgumentError("block_id holds a value below 1", path=(call, "block_id"), fix="number blocks from 1 (block k is block_k)")
    sets = {}
    if node_sets is not None and not isinstance(node_sets, Mapping):
        raise ArgumentTypeError(f"node_sets must be a mapping name -> points, not {type(node_sets).__name__}", path=(call, "node_sets"),
                                fix="give {'Left Node Set': indices, mask or region mapping, ...}")
    for name, members in (node_sets or {}).items():
        arg = f"node_sets[{name!r}]"
        if isinstance(members, Mapping):  # a region, evaluated on x with the regions' tolerance
            from ..geometry.regions import region_mask

            idx = np.nonzero(region_mask(region_mapping(call, arg, members), x, volume))[0]
        else:
            idx = point_indices(call, arg, members, n)
        sets[str(name)] = idx
    from ..io.textfile import min_element_radius

    disc = Discretization(x=x, volume=volume, block_id=ids, gid=np.arange(n, dtype=np.int64),
                          block_names={int(b): f"block_{int(b)}" for b in np.unique(ids)}, node_sets=sets,
                          min_element_radius=min_element_radius(volume), source="points given in Python")
    tree = deck_tree(tree)
    shared = dict(tree.get("Discretization") or {})
    extra = set(shared) - {"Influence Function", "Bond Filters", "Omit Bonds Between Blocks"}
    if extra:  # a Type or mesh keys would be silently replaced by the points
        raise ArgumentError(f"deck's Discretization section may hold only the shared keys, not {sorted(extra)}", path=(call, "deck"),
                            fix="the points are the arrays given: leave out Type and the mesh keys")
    # a stand-in type passes the deck's validation of the shared keys; the reader is swapped below
    shared.update({"Type": "Text File", "Input Mesh File": "<points given in Python>"})
    deck = parse_tree({**tree, "Discretization": shared}, directory)
    reader = type("PythonPoints", (_ArrayReader,), {"points": disc})
    deck.discretization = replace(deck.discretization, type=_ArrayReader.name, cls=reader, params=_ArrayParams())
    return deck


def point_indices(call: str, arg: str, members: Any, n: int) -> np.ndarray:
    """Sorted unique 0-based indices of ``members``: 0-based indices (whole numbers in 0..n-1)
    or a (n,) bool mask."""
    from .checks import ArgumentError, ArgumentTypeError, as_array

    arr = as_array(call, arg, members)
    if arr.dtype == bool:
        if arr.shape != (n,):
            raise ArgumentError(f"{arg}: a mask has shape {arr.shape}, expected ({n},)", path=(call, arg), fix="one bool per point, mesh order")
        return np.nonzero(arr)[0]
    if arr.size == 0:
        return np.zeros(0, dtype=np.int64)
    if arr.ndim > 1:
        raise ArgumentError(f"{arg}: indices have shape {arr.shape}, expected a flat list", path=(call, arg),
                            fix=f"give a flat list of 0-based point indices or a ({n},) bool mask")
    if arr.dtype.kind not in "iuf" or (arr.dtype.kind == "f" and not np.all(np.isfinite(arr) & (arr == np.round(arr)))):
        raise ArgumentTypeError(f"{arg} holds {arr.dtype} values that are not whole numbers", path=(call, arg),
                                fix=f"give 0-based point indices (ints) or a ({n},) bool mask")
    idx = arr.astype(np.int64).reshape(-1)
    if idx.min() < 0 or idx.max() >= n:
        bad = int(idx[(idx < 0) | (idx >= n)][0])
        raise ArgumentError(f"{arg} holds the index {bad}, outside 0..{n - 1}", path=(call, arg), fix="give 0-based point indices")
    return np.unique(idx)
