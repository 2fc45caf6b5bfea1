"""Peridigm's pre-split Exodus meshes: the pieces ``NAME.g.N.r`` (r = 0..N-1) that SEACAS
``decomp`` makes of a mesh ``NAME.g`` for N ranks.

On N > 1 ranks Peridigm's ``ExodusDiscretization::loadData`` opens the deck's mesh name with
``.N.r`` appended, on rank r, relative to the folder it runs in: its parallel tests run as
``cd npN; mpiexec -np N Peridigm ../DECK`` with only the pieces in ``npN``. Here the pieces are
looked for there first, then beside the deck; a rank reads only its own piece. Each piece holds
its elements with their global ids (``elem_num_map``, or the auxiliary
``original_global_id_map``) and its copies of the nodes with theirs (``node_num_map`` /
``original_global_id_map``); a node set lists the piece's own copies of its nodes, so the
elements of a set are found piece by piece and keyed by the global node id (see
:class:`~peridyn.core.discretization.DiscretizationPart`). SEACAS pads the rank number to the
width of N for N >= 10 (``NAME.g.16.03``); both spellings are accepted.
"""
from __future__ import annotations

import glob
import os
from pathlib import Path

import numpy as np

from ..core.discretization import DiscretizationPart
from ..core.errors import InputError, is_file

__all__ = ["find_pieces", "numbered_files", "piece_counts", "piece_path", "read_exodus_piece"]


def piece_path(base: Path, size: int, rank: int) -> Path:
    """The piece of rank ``rank`` of ``base`` split for ``size`` ranks, as Peridigm names it
    (``base.N.r``), or SEACAS's zero-padded name where only that exists."""
    plain = base.with_name(f"{base.name}.{size}.{rank}")
    if is_file(plain):
        return plain
    padded = base.with_name(f"{base.name}.{size}.{rank:0{len(str(size))}d}")
    return padded if is_file(padded) else plain


def _places(name: str, deck_dir: Path) -> list[Path]:
    path = Path(name)
    if path.is_absolute():
        return [path]
    return list(dict.fromkeys([Path(os.getcwd()) / path, Path(deck_dir) / path]))


def find_pieces(name: str, deck_dir: Path, size: int) -> Path | None:
    """The mesh path (without ``.N.r``) of which all ``size`` pieces exist: relative to the
    working folder (where Peridigm looks), then to the deck's folder; None when neither has
    them all (or ``size`` is 1)."""
    if size < 2:
        return None
    for base in _places(name, deck_dir):
        if all(is_file(piece_path(base, size, r)) for r in range(size)):
            return base
    return None


def piece_counts(name: str, deck_dir: Path) -> list[int]:
    """The rank counts for which some piece of ``name`` exists (for a message saying that the
    pieces there are for another number of ranks)."""
    counts: set[int] = set()
    for base in _places(name, deck_dir):
        counts.update(n for n in numbered_files(base) if n > 1)
    return sorted(counts)


def numbered_files(base: Path) -> dict[int, dict[int, Path]]:
    """N -> r -> the file ``base.N.r`` beside ``base`` (r as written, SEACAS's zero-padded too),
    for every such name there."""
    found: dict[int, dict[int, Path]] = {}
    folder = base.parent
    if not folder.is_dir():
        return found
    for f in folder.glob(glob.escape(base.name) + ".*.*"):
        parts = f.name[len(base.name) + 1:].split(".")
        if len(parts) == 2 and parts[0].isdigit() and parts[1].isdigit():
            found.setdefault(int(parts[0]), {})[int(parts[1])] = f
    return found


def _node_gids(ds, num_nodes: int, file: str) -> np.ndarray:
    """0-based global node ids: original_global_id_map, else node_num_map, else 0..n-1."""
    from .exodus_elements import auxiliary_map

    ids = auxiliary_map(ds, "node", num_nodes, file)
    if ids is None:
        if "node_num_map" not in ds.variables:
            return np.arange(num_nodes, dtype=np.int64)
        ids = np.asarray(ds.variables["node_num_map"][:], dtype=np.int64)
    if ids.shape != (num_nodes,):
        raise InputError(f"node id map has {ids.size} entries for {num_nodes} nodes", file=file)
    if num_nodes and ids.min() < 1:
        raise InputError("node id map holds an id below 1", file=file)
    return ids - 1


def read_exodus_piece(path: Path) -> DiscretizationPart:
    """One piece of a pre-split Exodus mesh: its points (element centroids and volumes, global
    ids) and its node sets as (global node id, point gid) pairs. Raises InputError for an
    unreadable or inconsistent piece."""
    import netCDF4

    from .exodus_elements import node_set_pairs, read_elements

    file = str(path)
    try:
        ds = netCDF4.Dataset(file, "r")
    except (OSError, RuntimeError, ValueError, UnicodeError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc).split(": '")[0]
        raise InputError(f"mesh piece {path.name!r} is not a readable Exodus II (netCDF) file ({reason})", file=file,
                         fix="regenerate the pieces (SEACAS decomp), or give the whole mesh") from None
    try:
        ds.set_auto_mask(False)
        points, conn_parts, num_nodes = read_elements(ds, file, piece=True)
        node_gid = _node_gids(ds, num_nodes, file)
        pairs = {name: (node_gid[nodes], points.gid[elements])
                 for name, (nodes, elements) in node_set_pairs(ds, file, num_nodes, conn_parts).items()}
    except (ValueError, IndexError, KeyError, UnicodeError, OverflowError, RuntimeError, OSError) as exc:
        raise InputError(f"mesh piece {path.name!r} is damaged or not laid out as Exodus II ({type(exc).__name__}: {str(exc)[:80]})",
                         file=file, fix="regenerate the pieces (SEACAS decomp), or give the whole mesh") from None
    finally:
        ds.close()
    return DiscretizationPart(points, pairs)

