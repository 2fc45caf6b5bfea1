"""The CPU's contact pair search: a sorted cell list in the current configuration, and the
build of the pairs every target runs (``build_pairs``).

Points are binned into cubic cells of the build radius r_b and sorted by cell key; each owned
point scans the 27 cells around its own (9 contiguous key ranges, found by binary search), so
memory is O(points) however far apart the bodies fly. Each candidate is tested and placed in its
row by the function every target shares (``contact/pair_laws.py``: ``offer``); a row is a fixed-capacity slot of a buffer, and a row that does not fit raises
the overflow count: ``build_pairs`` grows the capacity to the largest row and gathers again (no
Python loop over points, no scatter), then copies the rows into CSR pairs (the ``COMPACT`` law).
A GPU bins differently (``gpu/pair_search.py``, hashed buckets) behind the same
:class:`Binning` methods.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import numpy as np
from numba import njit, prange

from ..core.interfaces import ContactPairs
from ..core.traversal import Backend
from .pair_laws import COMPACT, offer

#: largest number of cells along an axis (keys must fit in 63 bits); far-flung points share the
#: outermost cells, which only adds candidates, never loses one
MAX_CELLS = 1 << 20


def cell_grid(y: np.ndarray, h: float) -> tuple[np.ndarray, float, np.ndarray]:
    """(lower corner (3,), 1/cell size, cells per axis (3,) int64) of a grid of cells of size h
    (L) over the points y (n, 3)."""
    if y.shape[0] == 0:
        return np.zeros(3), 1.0 / h, np.ones(3, dtype=np.int64)
    lo = y.min(axis=0)
    hi = y.max(axis=0)
    return grid_for_box(lo, hi, h)


def grid_for_box(lo: np.ndarray, hi: np.ndarray, h: float) -> tuple[np.ndarray, float, np.ndarray]:
    """The grid of cells of size at least h over the box [lo, hi] with at most MAX_CELLS cells
    per axis: a model whose points flew apart (an exploding run) gets bigger cells, not
    points piled into the outermost ones."""
    lo = np.where(np.isfinite(lo), lo, 0.0).astype(np.float64)
    hi = np.where(np.isfinite(hi), hi, 0.0).astype(np.float64)
    extent = float(np.max(hi - lo)) if lo.size else 0.0
    h = max(h, extent / (MAX_CELLS - 1))
    dims = np.floor((hi - lo) / h) + 1.0
    dims = np.minimum(dims, MAX_CELLS).astype(np.int64)
    return lo, 1.0 / h, np.maximum(dims, 1)


@njit(cache=True, inline="always")
def _cell(value, lo, inv_h, dim):
    c = (value - lo) * inv_h
    if not c >= 0.0:
        return 0
    if c >= dim - 1:
        return dim - 1
    return int(c)


@njit(cache=True, parallel=True)
def cell_keys_kernel(n, y, lo, inv_h, dims, keys):
    """keys[i] = the cell of point i as (cx * ny + cy) * nz + cz."""
    for i in prange(n):
        cx = _cell(y[i, 0], lo[0], inv_h, dims[0])
        cy = _cell(y[i, 1], lo[1], inv_h, dims[1])
        cz = _cell(y[i, 2], lo[2], inv_h, dims[2])
        keys[i] = (cx * dims[1] + cy) * dims[2] + cz


@njit(cache=True, inline="always")
def column_keys(ix, iy, cz, dims):
    """The keys of cells (ix, iy, cz - 1 .. cz + 1) inside the grid: a contiguous key range."""
    row = (ix * dims[1] + iy) * dims[2]
    return row + max(cz - 1, 0), row + min(cz + 1, dims[2] - 1)


@njit(cache=True, parallel=True)
def pair_search_kernel(num_owned, y, order, ys, cells, cell_start, dims, s, gid, x, near2, block, cross_block, rb2, rs2,
                       bond_offsets, bond_neighbors, bond_gid, one_offsets, one_gid, cap, buf, buf_visits, counts):
    """Candidate pairs of every owned point p into buf[p * cap : p * cap + counts[p]] (rows
    sorted by gid); counts[p] > cap means the row did not fit.

    y: (n, 3) current positions; ``order`` sorts the points by cell, ys = y[order]; ``cells``
    are the occupied cell keys (sorted), the points of cell c are
    order[cell_start[c]:cell_start[c + 1]]; the arguments from ``s`` to ``one_gid`` are those of
    ``pair_visits``. Parallel over cells: the 9 key ranges around a cell are found once for all
    its points."""
    d12 = dims[1] * dims[2]
    for c in prange(cells.size):
        key = cells[c]
        cx = key // d12
        cy = (key // dims[2]) % dims[1]
        cz = key % dims[2]
        first = np.empty(9, dtype=np.int64)
        last = np.empty(9, dtype=np.int64)
        m = 0
        for ix in range(max(cx - 1, 0), min(cx + 2, dims[0])):
            for iy in range(max(cy - 1, 0), min(cy + 2, dims[1])):
                k0, k1 = column_keys(ix, iy, cz, dims)
                a = np.searchsorted(cells, k0, side="left")
                b = np.searchsorted(cells, k1, side="right")
                if a < b:
                    first[m] = cell_start[a]
                    last[m] = cell_start[b]
                    m += 1
        for t0 in range(cell_start[c], cell_start[c + 1]):
            p = order[t0]
            if p >= num_owned:
                continue
            base = p * cap
            cnt = 0
            y0 = ys[t0, 0]
            y1 = ys[t0, 1]
            y2 = ys[t0, 2]
            for r in range(m):
                for t in range(first[r], last[r]):
                    if t == t0:
                        continue
                    cnt = offer(p, order[t], ys, t, y0, y1, y2, s, gid, x, near2, block, cross_block, rb2, rs2, bond_offsets,
                                bond_neighbors, bond_gid, one_offsets, one_gid, buf, buf_visits, base, cnt, cap)
            counts[p] = cnt


class Binning(ABC):
    """A target's binning of points for the pair search, and the buffers of its rows.

    ``bin(y)`` sorts the current positions y (n, 3) into the target's bins; ``gather(cap, test)``
    fills the padded rows (``rows``, ``row_visits``: num_owned * cap entries) and ``counts``
    (num_owned,) and returns (the largest row, the number of pairs); ``test`` is the tuple of
    ``pair_visits``'s arguments from ``s`` to ``one_gid``. ``offsets()`` is the exclusive scan of
    ``counts`` (num_owned + 1,) int64 on the target."""

    def __init__(self, backend: Backend, num_owned: int, rb: float) -> None:
        self.backend = backend
        self.num_owned = num_owned
        self.rb = rb
        self.cap = 0
        self.rows: Any = None
        self.row_visits: Any = None
        self.counts = backend.zeros(max(num_owned, 1), np.int64)

    def reserve(self, cap: int) -> None:
        """Buffers for rows of ``cap`` pairs (kept while the capacity stays the same)."""
        if cap != self.cap:
            size = max(self.num_owned * cap, 1)
            self.rows = self.backend.zeros(size, np.int32)
            self.row_visits = self.backend.zeros(size, np.uint8)
            self.cap = cap

    @abstractmethod
    def bin(self, y: Any) -> None:
        ...

    @abstractmethod
    def gather(self, cap: int, test: tuple) -> tuple[int, int]:
        ...

    @abstractmethod
    def offsets(self) -> Any:
        ...


class CellSearch(Binning):
    """The CPU's binning: points sorted by the key of their cell (see the module docstring)."""

    def bin(self, y: np.ndarray) -> None:
        n = y.shape[0]
        lo, inv_h, self.dims = cell_grid(y, self.rb)
        keys = np.empty(n, dtype=np.int64)
        cell_keys_kernel(n, y, lo, inv_h, self.dims, keys)
        self.order = np.argsort(keys, kind="stable")
        self.cells, cell_start = np.unique(keys[self.order], return_index=True)
        self.cell_start = np.append(cell_start, n).astype(np.int64)
        self.y = y
        self.ys = np.ascontiguousarray(y[self.order])

    def gather(self, cap: int, test: tuple) -> tuple[int, int]:
        n = self.num_owned
        pair_search_kernel(n, self.y, self.order, self.ys, self.cells, self.cell_start, self.dims, *test, cap, self.rows,
                           self.row_visits, self.counts)
        counts = self.counts[:n]
        return (int(counts.max()) if n else 0), int(counts.sum())

    def offsets(self) -> np.ndarray:
        offsets = np.zeros(self.num_owned + 1, dtype=np.int64)
        np.cumsum(self.counts[: self.num_owned], out=offsets[1:])
        return offsets


def build_pairs(binning: Binning, y: Any, test: tuple, cap: int) -> tuple[ContactPairs, int, int, int]:
    """The pairs of every owned point on ``binning``'s target (see ``pair_visits`` for which):
    y (n, 3) current positions, ``test`` as in :class:`Binning`, rows of ``cap`` pairs to start
    with. Returns (the pairs, the capacity used, the gathers run: more than 1 when a row
    overflowed, the largest row)."""
    backend = binning.backend
    binning.bin(y)
    passes = 0
    while True:
        passes += 1
        binning.reserve(cap)
        largest, total = binning.gather(cap, test)
        if largest <= cap:
            break
        cap = max(largest + largest // 4, 2 * cap)  # overflow: grow and gather again
    offsets = binning.offsets()
    partners = backend.zeros(total, np.int32)
    visits = backend.zeros(total, np.uint8)
    n = binning.num_owned
    if n:
        backend.kernel(COMPACT)(0, n, (cap, binning.rows, binning.row_visits, offsets, partners, visits))
    return ContactPairs(offsets, partners, visits), cap, passes, largest


def search_pairs(num_owned: int, y: np.ndarray, s: np.ndarray, gid: np.ndarray, rb: float, rs: float, bonds, bond_gid: np.ndarray,
                 one_offsets: np.ndarray, one_gid: np.ndarray, cap: int, shortcut: tuple | None = None,
                 backend: Backend | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
    """The pairs of every owned point on the CPU.

    y, s: (n, 3) current and last-search positions of owned points then ghosts; gid (n,);
    shortcut: (x (n, 3) reference positions, near2 (n,), block (n,), cross_block) for the bond
    test (see ``pair_visits``), or None; ``backend``: the CPU backend of the copy into CSR (the
    default one when None).
    Returns (offsets (num_owned + 1,) int64, partners int32, visits uint8, the capacity used,
    the number of searches run: more than 1 when a row overflowed the capacity)."""
    if backend is None:
        from ..kernels import default_backend

        backend = default_backend()
    n = y.shape[0]
    if shortcut is None:
        shortcut = (y, np.full(n, -1.0), np.zeros(n, np.int64), True)
    x, near2, block, cross_block = shortcut
    test = (s, gid, x, near2, block, bool(cross_block), rb * rb, rs * rs, bonds.offsets, bonds.neighbors, bond_gid, one_offsets, one_gid)
    pairs, cap, passes, _ = build_pairs(CellSearch(backend, num_owned, rb), y, test, cap)
    return pairs.offsets, pairs.partners, pairs.visits, cap, passes
