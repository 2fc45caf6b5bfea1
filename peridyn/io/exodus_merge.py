"""One Exodus file from the per-rank pieces ``NAME.e.N.r`` of a run on N ranks (what SEACAS
``epu`` does for Peridigm's pieces).

A piece holds its rank's own points as nodes, each block's nodes contiguous and in the order of
their place in the whole model, and ``node_num_map`` their 1-based global ids. peridyn's pieces
also carry ``peridyn_node_order`` (each node's place in the whole file, 0-based: the mothership
order a one-rank run writes) and ``peridyn_ns_order<k>`` (each entry's place in node set k, as
the deck lists it), so the merged file has the same bits as the file one process writes.
Peridigm's pieces have neither: their nodes are placed by global id (the ids must then be
1..N) and their node sets listed in ascending id.

The merge holds at most ``chunk`` nodes' values at a time (and, per piece and block, where each
chunk starts), never an array of the whole model: it reads every piece's slice of a chunk,
places it, and writes the chunk.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import netCDF4
import numpy as np

from .exodus_writer import ExodusBlock, ExodusWriter

__all__ = ["NODE_ORDER", "merge_pieces", "node_set_order_name"]

#: a piece's variable of each node's place in the merged file (0-based)
NODE_ORDER = "peridyn_node_order"
CHUNK = 1 << 20


def node_set_order_name(k: int) -> str:
    """The variable of node set ``k``'s (0-based) entries' places in the whole set."""
    return f"peridyn_ns_order{k + 1}"


def _names(ds: netCDF4.Dataset, var: str) -> list[str]:
    if var not in ds.variables:
        return []
    return [bytes(row).rstrip(b"\0").decode("ascii", "replace") for row in ds[var][:]]


def _dim(ds: netCDF4.Dataset, name: str) -> int:
    return int(ds.dimensions[name].size) if name in ds.dimensions else 0


class _Piece:
    """What the merge reads of one piece: its blocks' node ranges and the steps it holds."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.ds = netCDF4.Dataset(str(path))
        self.ds.set_auto_maskandscale(False)
        ds = self.ds
        self.num_nodes = _dim(ds, "num_nodes")
        nb = _dim(ds, "num_el_blk")
        self.block_ids = [int(v) for v in ds["eb_prop1"][:]]
        self.block_names = _names(ds, "eb_names")
        self.block_ranges = []  # (first node, number of nodes) of each block
        for b in range(1, nb + 1):
            size = _dim(ds, f"num_el_in_blk{b}")
            first = int(ds[f"connect{b}"][0, 0]) - 1 if size else 0
            self.block_ranges.append((first, size))
        self.set_names = _names(ds, "ns_names")
        self.set_sizes = [_dim(ds, f"num_nod_ns{k}") for k in range(1, len(self.set_names) + 1)]
        self.nodal = _names(ds, "name_nod_var")
        self.element = _names(ds, "name_elem_var")
        self.glob = _names(ds, "name_glo_var")
        self.truth = (np.asarray(ds["elem_var_tab"][:], dtype=bool) if self.element
                      else np.zeros((nb, 0), dtype=bool))
        self.steps = _dim(ds, "time_step")
        self.ordered = NODE_ORDER in ds.variables

    def keys(self, start: int, stop: int) -> np.ndarray:
        """Places in the merged file of nodes start..stop."""
        if self.ordered:
            return np.asarray(self.ds[NODE_ORDER][start:stop], dtype=np.int64)
        return np.asarray(self.ds["node_num_map"][start:stop], dtype=np.int64) - 1

    def close(self) -> None:
        self.ds.close()


def _check_alike(pieces: Sequence[_Piece], steps: int) -> None:
    first = pieces[0]
    for p in pieces[1:]:
        for what in ("block_ids", "set_names", "nodal", "element", "glob", "ordered"):
            if getattr(p, what) != getattr(first, what):
                raise ValueError(f"{p.path.name} and {first.path.name} differ in their {what.replace('_', ' ')} "
                                 f"({getattr(p, what)} against {getattr(first, what)}): not pieces of one run")
        if not np.array_equal(p.truth, first.truth):  # a block one piece lacks has a row of 0 there
            for b, (_, size) in enumerate(p.block_ranges):
                if size and first.block_ranges[b][1] and not np.array_equal(p.truth[b], first.truth[b]):
                    raise ValueError(f"{p.path.name} and {first.path.name} carry other element variables in block "
                                     f"{p.block_ids[b]}")
        if p.steps != steps:
            raise ValueError(f"{p.path.name} holds {p.steps} frames, {first.path.name} {steps}: not pieces of one run")
        times = np.asarray(p.ds["time_whole"][:steps])
        if not np.array_equal(times, np.asarray(first.ds["time_whole"][:steps])):
            raise ValueError(f"{p.path.name} and {first.path.name} hold other time values")


def _truth(pieces: Sequence[_Piece]) -> np.ndarray:
    """The merged truth table: a block's row from a piece that holds some of the block."""
    nb, ne = len(pieces[0].block_ids), len(pieces[0].element)
    tab = np.zeros((nb, ne), dtype=bool)
    for b in range(nb):
        for p in pieces:
            if p.block_ranges[b][1]:
                tab[b] = p.truth[b]
                break
    return tab


def merge_pieces(pieces: Sequence[Path], out: Path, *, append_after: int | None = None, chunk: int = CHUNK,
                 common_steps: bool = False, title: str = "Peridigm", program: str = "peridyn") -> int:
    """Write the pieces ``pieces`` (rank order) of one run as the one file ``out``; with
    ``append_after``, append their steps to the first ``append_after`` steps of ``out`` (a
    restarted run's, whose mesh it holds already). ``common_steps``: the steps every piece holds
    (a killed run's pieces may differ by the frame being written), else each piece must hold
    them all. Returns the number of steps written. ValueError for pieces that are not of one run."""
    opened: list[_Piece] = []
    try:
        for p in pieces:
            try:
                opened.append(_Piece(Path(p)))
            except (OSError, RuntimeError, KeyError, IndexError) as exc:
                raise ValueError(f"{Path(p).name} is not a readable Exodus piece ({exc})") from None
        steps = min(p.steps for p in opened) if common_steps else opened[0].steps
        for p in opened:
            p.steps = min(p.steps, steps) if common_steps else p.steps
        return _merge(opened, Path(out), append_after, max(1, int(chunk)), title, program)
    finally:
        for p in opened:
            p.close()


def _merge(pieces: list[_Piece], out: Path, append_after: int | None, chunk: int, title: str, program: str) -> int:
    first = pieces[0]
    _check_alike(pieces, first.steps)
    n = sum(p.num_nodes for p in pieces)
    if not first.ordered:
        top = max((int(np.asarray(p.ds["node_num_map"][:]).max()) for p in pieces if p.num_nodes), default=0)
        if top != n:
            raise ValueError(f"the pieces' node ids run to {top} over {n} nodes: without peridyn's node order they "
                             "must be 1..N")
    nb = len(first.block_ids)
    # per piece and block: the node range of each key chunk [c * chunk, (c + 1) * chunk)
    num_chunks = (n + chunk - 1) // chunk
    bounds = np.zeros((len(pieces), nb, num_chunks + 1), dtype=np.int64)
    block_sizes = np.zeros(nb, dtype=np.int64)
    for i, p in enumerate(pieces):
        for b, (start, size) in enumerate(p.block_ranges):
            keys = p.keys(start, start + size)
            if size > 1 and np.any(np.diff(keys) <= 0):
                raise ValueError(f"{p.path.name}: block {p.block_ids[b]}'s nodes are not in ascending order")
            if size and (keys[0] < 0 or keys[-1] >= n):
                raise ValueError(f"{p.path.name} places a node at {int(keys[-1]) + 1}, beyond the {n} these pieces hold: "
                                 "they do not hold nodes of the run (a piece missing?)")
            bounds[i, b] = start + np.searchsorted(keys, np.arange(num_chunks + 1) * chunk)
            block_sizes[b] += size
    set_sizes = [sum(p.set_sizes[k] for p in pieces) for k in range(len(first.set_names))]
    truth = _truth(pieces)
    blocks = [ExodusBlock(first.block_ids[b], first.block_names[b] if b < len(first.block_names) else "", int(block_sizes[b]))
              for b in range(nb)]
    writer = ExodusWriter(out, coords=None, node_num_map=None, num_nodes=n, blocks=blocks,
                          node_sets=list(zip(first.set_names, set_sizes)), nodal_vars=first.nodal,
                          element_vars=first.element, global_vars=first.glob, truth_table=truth, title=title,
                          program=program, append_after=append_after)
    base = append_after or 0
    try:
        elem_at = np.zeros(nb, dtype=np.int64)  # each block's merged elements before this chunk
        for c in range(num_chunks):
            a = c * chunk
            m = min(chunk, n - a)
            parts = [(p, b, int(bounds[i, b, c]), int(bounds[i, b, c + 1]))
                     for i, p in enumerate(pieces) for b in range(nb) if bounds[i, b, c + 1] > bounds[i, b, c]]
            keys = [p.keys(s, e) - a for p, _, s, e in parts]
            placed = np.zeros(m, dtype=bool)
            for k in keys:
                placed[k] = True
            if not placed.all():
                raise ValueError(f"the pieces do not hold node {a + int(np.argmin(placed)) + 1} of the {n}")
            # each block's elements of this chunk: its parts and the order that sorts their rows by key
            per_block = []
            for b in range(nb):
                mine = [j for j, part in enumerate(parts) if part[1] == b]
                order = np.argsort(np.concatenate([keys[j] for j in mine]), kind="stable") if mine else np.zeros(0, np.int64)
                per_block.append((mine, order))
            if append_after is None:
                _write_mesh(writer, parts, keys, per_block, elem_at, a, m)
            for step in range(first.steps):
                _write_step(writer, first, parts, keys, per_block, elem_at, truth, step, base + step, a, m)
            elem_at += [order.size for _, order in per_block]
        times = np.asarray(first.ds["time_whole"][:first.steps], dtype=np.float64)
        glob = np.asarray(first.ds["vals_glo_var"][:first.steps], dtype=np.float64) if first.glob else np.zeros((first.steps, 0))
        for step in range(first.steps):
            writer.end_step(base + step, float(times[step]), glob[step])
        if append_after is None:
            for k in range(len(set_sizes)):
                _write_node_set(writer, pieces, k, set_sizes[k], chunk)
    finally:
        writer.close()
    return first.steps


def _write_mesh(writer: ExodusWriter, parts: list, keys: list, per_block: list, elem_at: np.ndarray, a: int,
                m: int) -> None:
    """The coordinates, node ids and connectivity of the chunk's nodes a..a + m."""
    coords = np.empty((m, 3))
    ids = np.empty(m, dtype=np.int64)
    for (p, _, s, e), k in zip(parts, keys):
        for j, c in enumerate("xyz"):
            coords[k, j] = p.ds[f"coord{c}"][s:e]
        ids[k] = p.ds["node_num_map"][s:e]
    writer.write_nodes(a, coords, ids)
    for b, (mine, order) in enumerate(per_block):
        if mine:
            nodes = np.concatenate([keys[j] for j in mine])[order]
            writer.write_block(b, int(elem_at[b]), nodes + a, ids[nodes])


def _write_step(writer: ExodusWriter, first: _Piece, parts: list, keys: list, per_block: list, elem_at: np.ndarray,
                truth: np.ndarray, step: int, at: int, a: int, m: int) -> None:
    """The chunk's values of the pieces' step ``step`` as the merged file's step ``at``."""
    for v in range(len(first.nodal)):
        buf = np.empty(m)
        for (p, _, s, e), k in zip(parts, keys):
            buf[k] = p.ds[f"vals_nod_var{v + 1}"][step, s:e]
        writer.write_nodal_slice(at, v, a, buf)
    for b, (mine, order) in enumerate(per_block):
        for v in range(len(first.element)):
            if not mine or not truth[b, v]:
                continue
            rows = []
            for j in mine:
                p, _, s, e = parts[j]
                start = p.block_ranges[b][0]  # a piece's element k of a block is its node start + k
                rows.append(np.asarray(p.ds[f"vals_elem_var{v + 1}eb{b + 1}"][step, s - start:e - start]))
            writer.write_element_slice(at, v, b, int(elem_at[b]), np.concatenate(rows)[order])


def _write_node_set(writer: ExodusWriter, pieces: Sequence[_Piece], k: int, size: int, chunk: int) -> None:
    """Node set ``k``: each piece's entries placed by ``peridyn_ns_order<k>`` (Peridigm's pieces:
    all entries in ascending node)."""
    if not size:
        return
    name, dim = node_set_order_name(k), f"num_nod_ns{k + 1}"
    if not pieces[0].ordered:
        found = [_piece_keys_of(p, np.asarray(p.ds[f"node_ns{k + 1}"][:], dtype=np.int64) - 1)
                 for p in pieces if dim in p.ds.dimensions]
        writer.write_node_set(k, 0, np.sort(np.concatenate(found), kind="stable"))
        return
    for a in range(0, size, chunk):
        m = min(chunk, size - a)
        buf = np.empty(m, dtype=np.int64)
        for p in pieces:
            if dim not in p.ds.dimensions:
                continue
            places = np.asarray(p.ds[name][:], dtype=np.int64)
            lo, hi = np.searchsorted(places, [a, a + m])
            if hi > lo:
                buf[places[lo:hi] - a] = _piece_keys_of(p, np.asarray(p.ds[f"node_ns{k + 1}"][lo:hi], dtype=np.int64) - 1)
        writer.write_node_set(k, a, buf)


def _piece_keys_of(p: _Piece, nodes: np.ndarray) -> np.ndarray:
    """Places in the merged file of a piece's nodes ``nodes`` (0-based, any order)."""
    if not nodes.size:
        return nodes
    lo, hi = int(nodes.min()), int(nodes.max()) + 1
    return p.keys(lo, hi)[nodes - lo]
