"""Contact pair search kernels: a hashed cell list in the current configuration.

Points are binned into cubic cells of the build radius r_b and sorted by cell key; each owned
point scans the 27 cells around its own (9 contiguous key ranges, found by binary search), so
memory is O(points) however far apart the bodies fly. Each row is written into a fixed-capacity
slot of a buffer; a row that does not fit raises the overflow count, the caller grows the
capacity to the largest row and searches again (no Python loop over points, no scatter).

A pair (p, j) is kept when |y_j - y_p| <= r_b now, |s_j - s_p| <= R_s at the positions s of the
last contact search (Peridigm's search list, PERIDIGM_CONTACT.md §3.3, inclusive), and the two
points are not bonded both ways in the reference configuration (broken bonds count as bonds).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

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
def in_sorted(values, lo, hi, key, table):
    """Whether table[values[k]] == key for some k in [lo, hi) (values sorted by table value)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        t = table[values[mid]]
        if t < key:
            lo = mid + 1
        elif t > key:
            hi = mid
        else:
            return True
    return False


@njit(cache=True, inline="always")
def _in_sorted_plain(values, lo, hi, key):
    """Whether values[k] == key for some k in [lo, hi) (values sorted)."""
    k = lo + np.searchsorted(values[lo:hi], key)
    return k < hi and values[k] == key


@njit(cache=True, inline="always")
def column_keys(ix, iy, cz, dims):
    """The keys of cells (ix, iy, cz - 1 .. cz + 1) inside the grid: a contiguous key range."""
    row = (ix * dims[1] + iy) * dims[2]
    return row + max(cz - 1, 0), row + min(cz + 1, dims[2] - 1)


@njit(cache=True, parallel=True)
def pair_search_kernel(num_owned, y, s, gid, order, ys, cells, cell_start, dims, rb2, rs2,
                       bond_offsets, bond_neighbors, bond_gid, one_offsets, one_gid, x, near2, block, cross_block,
                       cap, buf, buf_visits, counts):
    """Candidate pairs of every owned point p into buf[p * cap : p * cap + counts[p]] (rows
    sorted by gid); counts[p] > cap means the row did not fit.

    y, s: (n, 3) current and last-search positions; ``order`` sorts the points by cell, ys =
    y[order]; ``cells`` are the occupied cell keys (sorted), the points of cell c are
    order[cell_start[c]:cell_start[c + 1]]. Bond rows are sorted by bond_gid[neighbor]; one_gid
    rows (sorted) are the partners bonded one way only. Shortcut: j is in p's bond list, without
    a search of the list, when |x_j - x_p|^2 < near2[p] (reference positions x; near2 < 0
    disables it) and the blocks agree or ``cross_block`` (bonds between blocks are kept).
    Parallel over cells: the 9 key ranges around a cell are found once for all its points."""
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
                    dx = ys[t, 0] - y0
                    dy = ys[t, 1] - y1
                    dz = ys[t, 2] - y2
                    if not (dx * dx + dy * dy) + dz * dz <= rb2 or t == t0:
                        continue
                    j = order[t]
                    ex = s[j, 0] - s[p, 0]
                    ey = s[j, 1] - s[p, 1]
                    ez = s[j, 2] - s[p, 2]
                    if not (ex * ex + ey * ey) + ez * ez <= rs2:
                        continue
                    gj = gid[j]
                    fx = x[j, 0] - x[p, 0]
                    fy = x[j, 1] - x[p, 1]
                    fz = x[j, 2] - x[p, 2]
                    if (fx * fx + fy * fy) + fz * fz < near2[p] and (cross_block or block[j] == block[p]):
                        node = False
                    else:
                        node = not in_sorted(bond_neighbors, bond_offsets[p], bond_offsets[p + 1], gj, bond_gid)
                    partner = node
                    if one_offsets[p + 1] > one_offsets[p] and _in_sorted_plain(one_gid, one_offsets[p], one_offsets[p + 1], gj):
                        partner = not node
                    if not (node or partner):
                        continue
                    if cnt < cap:
                        # insertion by gid keeps the row sorted
                        k = cnt
                        while k > 0 and gid[buf[base + k - 1]] > gj:
                            buf[base + k] = buf[base + k - 1]
                            buf_visits[base + k] = buf_visits[base + k - 1]
                            k -= 1
                        buf[base + k] = j
                        buf_visits[base + k] = (1 if node else 0) | (2 if partner else 0)
                    cnt += 1
            counts[p] = cnt


@njit(cache=True, parallel=True)
def compact_kernel(num_owned, cap, buf, buf_visits, offsets, partners, visits):
    """Copy the rows of the padded buffer into CSR arrays."""
    for p in prange(num_owned):
        base = p * cap
        o = offsets[p]
        for k in range(offsets[p + 1] - o):
            partners[o + k] = buf[base + k]
            visits[o + k] = buf_visits[base + k]


@njit(cache=True)
def max_displacement2_kernel(n, y, y0):
    """max_i |y_i - y0_i|^2 (serial: a reduction whose result must not depend on threads)."""
    m = 0.0
    for i in range(n):
        dx = y[i, 0] - y0[i, 0]
        dy = y[i, 1] - y0[i, 1]
        dz = y[i, 2] - y0[i, 2]
        d = (dx * dx + dy * dy) + dz * dz
        if not d <= m:  # NaN propagates
            m = d
    return m


@njit(cache=True)
def min_pair_distance2_kernel(num_owned, offsets, partners, y):
    """Smallest squared distance between listed pairs (inf when there is none)."""
    m = math.inf
    for p in range(num_owned):
        for q in range(offsets[p], offsets[p + 1]):
            j = partners[q]
            dx = y[j, 0] - y[p, 0]
            dy = y[j, 1] - y[p, 1]
            dz = y[j, 2] - y[p, 2]
            d = (dx * dx + dy * dy) + dz * dz
            if d < m:
                m = d
    return m


def search_pairs(num_owned: int, y: np.ndarray, s: np.ndarray, gid: np.ndarray, rb: float, rs: float, bonds, bond_gid: np.ndarray,
                 one_offsets: np.ndarray, one_gid: np.ndarray, cap: int, shortcut: tuple | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
    """The pairs of every owned point (see the module docstring).

    y, s: (n, 3) current and last-search positions of owned points then ghosts; gid (n,);
    shortcut: (x (n, 3) reference positions, near2 (n,), block (n,), cross_block) for the bond
    test (see ``pair_search_kernel``), or None.
    Returns (offsets (num_owned + 1,) int64, partners int32, visits uint8, the capacity used,
    the number of searches run: more than 1 when a row overflowed the capacity)."""
    n = y.shape[0]
    lo, inv_h, dims = cell_grid(y, rb)
    keys = np.empty(n, dtype=np.int64)
    cell_keys_kernel(n, y, lo, inv_h, dims, keys)
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    cells, cell_start = np.unique(sorted_keys, return_index=True)
    cell_start = np.append(cell_start, n).astype(np.int64)
    ys = np.ascontiguousarray(y[order])
    counts = np.zeros(num_owned, dtype=np.int64)
    if shortcut is None:
        shortcut = (y, np.full(n, -1.0), np.zeros(n, np.int64), True)
    x, near2, block, cross_block = shortcut
    passes = 0
    while True:
        passes += 1
        buf = np.empty(num_owned * cap, dtype=np.int32)
        buf_visits = np.empty(num_owned * cap, dtype=np.uint8)
        pair_search_kernel(num_owned, y, s, gid, order, ys, cells, cell_start, dims, rb * rb, rs * rs,
                           bonds.offsets, bonds.neighbors, bond_gid, one_offsets, one_gid, x, near2, block, bool(cross_block),
                           cap, buf, buf_visits, counts)
        largest = int(counts.max()) if num_owned else 0
        if largest <= cap:
            break
        cap = max(largest + largest // 4, 2 * cap)  # overflow: grow and search again
    offsets = np.zeros(num_owned + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    partners = np.empty(int(offsets[-1]), dtype=np.int32)
    visits = np.empty(int(offsets[-1]), dtype=np.uint8)
    compact_kernel(num_owned, cap, buf, buf_visits, offsets, partners, visits)
    return offsets, partners, visits, cap, passes
