"""Neighbor search and bond-list operations: a numba cell-list radius search, row sorts,
renumbering, compaction and the space-filling-curve order. The CSR structure itself is
:class:`peridyn.core.bonds.NeighborList`.

Bonds are stored in CSR form (DESIGN.md decision 6): the bonds of point ``i`` are
``neighbors[offsets[i]:offsets[i+1]]``, and any per-bond array (bond damage, partial volumes) is
aligned with ``neighbors``. Lists are *full*: a bond i->j is stored in i's row and, when j's family
contains i, also as j->i in j's row. With horizons that differ between points the relation can be
one-sided (j in i's family, i not in j's); :meth:`NeighborList.reverse` is then -1 for that bond
and the incoming bonds of a point are found through :meth:`NeighborList.transpose`.

The search reproduces Peridigm's Exodus/Text search (PERIDIGM_SEMANTICS.md section 2.5): point i
searches with its *own* horizon delta_i and keeps every j != i with
``(dx*dx + dy*dy) + dz*dz <= delta_i*delta_i`` (``d = x_j - x_i``), inclusive, with no
tolerance; each list is in ascending point index. It is exact: the cell list only chooses the
candidates, the kept set is decided by that one comparison.

All kernels are ``@njit(cache=True)`` functions at module level. The search, the reverse index
and the packed row sort loop over rows with ``prange`` and every iteration writes only its own
row (gather, never scatter), so results do not depend on the number of threads; memory-bound
copies (compact, renumber) are serial (a parallel kernel costs about a second more to compile).

Memory: a :class:`NeighborList` costs 4 bytes per bond (int32 ``neighbors``) plus 8 bytes per
point (int64 ``offsets``); :meth:`~NeighborList.reverse` adds 4 bytes per bond, and
:meth:`~NeighborList.transpose` and :meth:`~NeighborList.sources` another 4 each, only when asked.
The search needs about 100 bytes per point for its cell list (cell coordinates, a sorted copy of
the positions, the cell order and cell starts) and one int64 count per query point, plus the
result: no temporary proportional to the number of bonds.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..core.bonds import INT32_MAX, NeighborList, shell_argsort, shellsort

__all__ = [
    "NeighborList",
    "radius_search",
    "sort_rows",
    "space_filling_order",
    "renumber",
    "omit_bonds_between_blocks",
    "compact",
    "hilbert_keys",
]


#: the cell edge is max horizon / this factor, so a point with the largest horizon scans
#: ceil(2.99) = 3 cells each way (7^3 cells of about one point each on a lattice with horizon 3
#: spacings: measured fastest among 1, 2, 3 and 4 cells per horizon); kept below an integer so
#: the rounding of cell coordinates never needs one more cell.
_CELL_FACTOR = 2.99


# ------------------------------------------------------------------------------------------------
# Radius search
# ------------------------------------------------------------------------------------------------
@njit(parallel=True, cache=True)
def _search_count(x, xs, order, cell_start, qpoints, qcell, qrange, h2, dims, counts):
    """Count pass of the cell-list search.

    x (n,3) float64 positions; xs (n,3) the same sorted by cell id; order (n,) int64 original
    index of each sorted point; cell_start (ncells+1,) int64 first sorted point of each cell;
    qpoints (k,) int64 query points; qcell (k,3) int64 their cell coordinates; qrange (k,) int64
    cells to scan each way; h2 (k,) float64 squared horizons (a point j is kept when
    ``(dx*dx + dy*dy) + dz*dz <= h2``); dims (3,) int64 grid size. Writes counts (k,) int64.
    The cells of one (y, z) row are contiguous in ``xs``, so each row is one linear scan.
    """
    k = qpoints.size
    nx = dims[0]
    ny = dims[1]
    nz = dims[2]
    for q in prange(k):
        i = qpoints[q]
        xi0 = x[i, 0]
        xi1 = x[i, 1]
        xi2 = x[i, 2]
        r2 = h2[q]
        rr = qrange[q]
        cx0 = max(qcell[q, 0] - rr, 0)
        cx1 = min(qcell[q, 0] + rr, nx - 1)
        cy0 = max(qcell[q, 1] - rr, 0)
        cy1 = min(qcell[q, 1] + rr, ny - 1)
        cz0 = max(qcell[q, 2] - rr, 0)
        cz1 = min(qcell[q, 2] + rr, nz - 1)
        c = 0
        for cz in range(cz0, cz1 + 1):
            for cy in range(cy0, cy1 + 1):
                row = (cz * ny + cy) * nx
                for p in range(cell_start[row + cx0], cell_start[row + cx1 + 1]):
                    dx = xs[p, 0] - xi0
                    dy = xs[p, 1] - xi1
                    dz = xs[p, 2] - xi2
                    d2 = (dx * dx + dy * dy) + dz * dz
                    if d2 <= r2 and order[p] != i:
                        c += 1
        counts[q] = c


@njit(parallel=True, cache=True)
def _search_fill(x, xs, order, cell_start, qpoints, qcell, qrange, h2, dims, offsets, out):
    """Fill pass: the same scan as :func:`_search_count`, writing row q of ``out`` at
    ``offsets[q]`` (offsets (k+1,) int64 from the counts) and sorting it ascending."""
    k = qpoints.size
    nx = dims[0]
    ny = dims[1]
    nz = dims[2]
    for q in prange(k):
        i = qpoints[q]
        xi0 = x[i, 0]
        xi1 = x[i, 1]
        xi2 = x[i, 2]
        r2 = h2[q]
        rr = qrange[q]
        cx0 = max(qcell[q, 0] - rr, 0)
        cx1 = min(qcell[q, 0] + rr, nx - 1)
        cy0 = max(qcell[q, 1] - rr, 0)
        cy1 = min(qcell[q, 1] + rr, ny - 1)
        cz0 = max(qcell[q, 2] - rr, 0)
        cz1 = min(qcell[q, 2] + rr, nz - 1)
        base = offsets[q]
        c = base
        for cz in range(cz0, cz1 + 1):
            for cy in range(cy0, cy1 + 1):
                row = (cz * ny + cy) * nx
                for p in range(cell_start[row + cx0], cell_start[row + cx1 + 1]):
                    dx = xs[p, 0] - xi0
                    dy = xs[p, 1] - xi1
                    dz = xs[p, 2] - xi2
                    d2 = (dx * dx + dy * dy) + dz * dz
                    if d2 <= r2:
                        j = order[p]
                        if j != i:
                            out[c] = j
                            c += 1
        if c - base > 1:
            shellsort(out, base, c)


def radius_search(
    x: np.ndarray,
    horizon: np.ndarray | float,
    points: np.ndarray | None = None,
    *,
    inclusive: bool = True,
    dtype: type = np.int64,
) -> tuple[np.ndarray, np.ndarray]:
    """Neighbors of ``points`` within each one's own horizon, among all points of ``x``.

    Parameters
    ----------
    x: float64, shape (n, 3); reference positions (length units).
    horizon: float64, shape (n,) (or a scalar); horizon of every point (length units), > 0.
    points: int64, shape (k,); the points whose lists are wanted, in the order of the result
        rows (default: all n points, in order).
    inclusive: keep ``|x_j - x_i|^2 <= delta_i^2`` (Peridigm's Exodus/Text search) when true,
        ``< delta_i^2`` when false.
    dtype: integer dtype of the returned ``neighbors`` (np.int32 halves the memory).

    Returns
    -------
    offsets: int64, shape (k+1,); neighbors: ``dtype``, shape (num_bonds,). Row q holds every
    j != points[q] with ``(dx*dx + dy*dy) + dz*dz <= horizon[points[q]]**2`` (d = x_j - x_i), in
    ascending index order. Families can be one-sided when horizons differ.
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"x must have shape (n, 3), got {x.shape}")
    n = x.shape[0]
    h = np.broadcast_to(np.asarray(horizon, dtype=np.float64), (n,))
    if points is None:
        qpoints = np.arange(n, dtype=np.int64)
    else:
        qpoints = np.ascontiguousarray(points, dtype=np.int64).reshape(-1)
        if qpoints.size and (qpoints.min() < 0 or qpoints.max() >= n):
            raise ValueError("points holds an index outside 0..n-1")
    k = qpoints.size
    offsets = np.zeros(k + 1, dtype=np.int64)
    if k == 0 or n == 0:
        return offsets, np.empty(0, dtype=dtype)
    if not np.all(np.isfinite(x)):
        raise ValueError("x holds non-finite coordinates")
    hq = np.ascontiguousarray(h[qpoints])
    if not np.all(np.isfinite(hq)) or hq.min() <= 0.0:
        raise ValueError("every horizon must be finite and > 0")

    # Cell grid: edge = max horizon / 2.99, enlarged until the grid has at most ~2n cells.
    xmin = x.min(axis=0)
    ext = x.max(axis=0) - xmin
    hmax = float(hq.max())
    max_cells = 2 * n + 64
    # a horizon far below the extent would ask for more cells than points: start at the size
    # that fits the budget (a horizon that underflows to a zero cell edge included)
    cell = max(hmax / _CELL_FACTOR, float(ext.max()) / max_cells ** (1.0 / 3.0))
    if not cell > 0.0:
        cell = 1.0  # every point at one place
    while True:
        dims_f = np.floor(ext / cell) + 1.0
        if float(dims_f[0]) * float(dims_f[1]) * float(dims_f[2]) <= max_cells:
            break
        cell *= 1.25
    dims = dims_f.astype(np.int64)
    ncells = int(dims[0]) * int(dims[1]) * int(dims[2])
    cc = np.floor((x - xmin) / cell).astype(np.int64)
    np.clip(cc, 0, dims - 1, out=cc)
    cell_id = (cc[:, 2] * dims[1] + cc[:, 1]) * dims[0] + cc[:, 0]
    order = np.argsort(cell_id, kind="stable").astype(np.int64)
    cell_start = np.zeros(ncells + 1, dtype=np.int64)
    np.cumsum(np.bincount(cell_id, minlength=ncells), out=cell_start[1:])
    xs = np.ascontiguousarray(x[order])
    del cell_id

    # Cells to scan each way: ceil(delta_i / cell + eps), eps bounding the rounding of the cell
    # coordinates (in cell units), so no candidate within delta_i is ever missed.
    eps = 32.0 * np.finfo(np.float64).eps * (float(np.abs(x).max()) / cell + float(dims.max())) + 1e-12
    qrange = np.ceil(hq / cell + eps).astype(np.int64)
    qcell = np.ascontiguousarray(cc[qpoints])
    del cc
    h2 = hq * hq
    if not inclusive:  # d2 < h2  <=>  d2 <= the largest double below h2
        h2 = np.nextafter(h2, 0.0)

    args = (x, xs, order, cell_start, qpoints, qcell, qrange, h2, dims)
    counts = np.empty(k, dtype=np.int64)
    _search_count(*args, counts)
    np.cumsum(counts, out=offsets[1:])
    del counts
    if np.dtype(dtype) == np.int32 and n - 1 > INT32_MAX:
        raise ValueError("too many points for int32 neighbor indices")
    neighbors = np.empty(int(offsets[-1]), dtype=dtype)
    if neighbors.size:
        _search_fill(*args, offsets, neighbors)
    return offsets, neighbors


# ------------------------------------------------------------------------------------------------
# Row operations
# ------------------------------------------------------------------------------------------------
@njit(cache=True)
def _sort_rows_kernel(offsets, neighbors, key, out):
    """Each row of ``neighbors`` reordered by key[neighbor] ascending (stable) into ``out``."""
    n = offsets.size - 1
    for i in range(n):
        s = offsets[i]
        e = offsets[i + 1]
        if e - s == 0:
            continue
        vals = np.empty(e - s, dtype=key.dtype)
        for b in range(s, e):
            vals[b - s] = key[neighbors[b]]
        p = np.empty(e - s, dtype=np.int64)
        shell_argsort(vals, p)
        for t in range(e - s):
            out[s + t] = neighbors[s + p[t]]


@njit(parallel=True, cache=True)
def _sort_rows_packed(offsets, neighbors, key, out):
    """:func:`_sort_rows_kernel` for integer keys in [0, 2**31): sorts packed int64 values
    (key << 32 | position), which is stable and has no indirection in the comparisons."""
    n = offsets.size - 1
    for i in prange(n):
        s = offsets[i]
        e = offsets[i + 1]
        if e - s == 0:
            continue
        buf = np.empty(e - s, dtype=np.int64)
        for k in range(e - s):
            buf[k] = (np.int64(key[neighbors[s + k]]) << 32) | k
        shellsort(buf, 0, e - s)
        for k in range(e - s):
            out[s + k] = neighbors[s + (buf[k] & 0xFFFFFFFF)]


@njit(cache=True)
def _rows_in_order(offsets, neighbors, key):
    """Whether every row is already in ascending ``key[neighbor]`` order (ties allowed)."""
    for i in range(offsets.size - 1):
        for b in range(offsets[i] + 1, offsets[i + 1]):
            if key[neighbors[b]] < key[neighbors[b - 1]]:
                return False
    return True


def sort_rows(offsets: np.ndarray, neighbors: np.ndarray, key: np.ndarray) -> np.ndarray:
    """Reorder every row by ``key[neighbor]`` ascending, ties kept in their order (stable).

    offsets int64 (n+1,); neighbors integer (B,); key (m,) any sortable numeric dtype, indexed by
    neighbor (e.g. global ids). Returns a new neighbors array of the same dtype, or ``neighbors``
    itself when every row already is in that order (a serial lattice: 0.3 s of the Users' Guide
    cylinder's set-up); offsets unchanged.
    """
    offsets = np.ascontiguousarray(offsets, dtype=np.int64)
    neighbors = np.ascontiguousarray(neighbors)
    if neighbors.size and _rows_in_order(offsets, neighbors, np.ascontiguousarray(key)):
        return neighbors
    out = np.empty_like(neighbors)
    if neighbors.size:
        key = np.ascontiguousarray(key)
        row_max = int(np.diff(offsets).max())
        if (
            np.issubdtype(key.dtype, np.integer)
            and key.size
            and int(key.min()) >= 0
            and int(key.max()) <= INT32_MAX
            and row_max <= INT32_MAX
        ):
            _sort_rows_packed(offsets, neighbors, key.astype(np.int64, copy=False), out)
        else:
            _sort_rows_kernel(offsets, neighbors, key, out)
    return out


@njit(cache=True)
def _renumber_kernel(offsets, neighbors, new_of_old, order, new_offsets, out):
    """New row r = old row order[r], entries mapped through new_of_old (gather per new row)."""
    k = order.size
    for r in range(k):
        o = order[r]
        s = offsets[o]
        base = new_offsets[r]
        for b in range(s, offsets[o + 1]):
            out[base + b - s] = new_of_old[neighbors[b]]


def renumber(
    offsets: np.ndarray, neighbors: np.ndarray, new_of_old: np.ndarray, order: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Permute rows and renumber entries.

    offsets int64 (n+1,); neighbors integer (B,); new_of_old integer (m,) new index of every old
    point an entry can name; order integer (k,) old row of every new row (``order[new] = old``,
    usually the inverse of ``new_of_old``). Returns ``(new_offsets int64 (k+1,), new_neighbors)``
    with ``new_neighbors`` of the dtype of ``neighbors``; each row keeps its entry order (run
    :func:`sort_rows` to re-sort by the new indices).
    """
    offsets = np.ascontiguousarray(offsets, dtype=np.int64)
    neighbors = np.ascontiguousarray(neighbors)
    order = np.ascontiguousarray(order, dtype=np.int64)
    new_of_old = np.ascontiguousarray(new_of_old).astype(neighbors.dtype, copy=False)
    counts = np.diff(offsets)[order]
    new_offsets = np.zeros(order.size + 1, dtype=np.int64)
    np.cumsum(counts, out=new_offsets[1:])
    out = np.empty(int(new_offsets[-1]), dtype=neighbors.dtype)
    if out.size:
        _renumber_kernel(offsets, neighbors, new_of_old, order, new_offsets, out)
    return new_offsets, out


@njit(cache=True)
def _compact_kernel(offsets, neighbors, keep, new_offsets, out):
    """Copy the kept bonds of every row, in order."""
    n = offsets.size - 1
    for i in range(n):
        c = new_offsets[i]
        for b in range(offsets[i], offsets[i + 1]):
            if keep[b]:
                out[c] = neighbors[b]
                c += 1


@njit(cache=True)
def _row_kept_counts(offsets, keep, counts):
    n = offsets.size - 1
    for i in range(n):
        c = 0
        for b in range(offsets[i], offsets[i + 1]):
            if keep[b]:
                c += 1
        counts[i] = c


def compact(offsets: np.ndarray, neighbors: np.ndarray, keep: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop the bonds where ``keep`` is false, keeping the order within each row.

    offsets int64 (n+1,); neighbors integer (B,); keep bool (B,). Returns new
    ``(offsets int64 (n+1,), neighbors)`` with the dtype of ``neighbors``.
    """
    offsets = np.ascontiguousarray(offsets, dtype=np.int64)
    neighbors = np.ascontiguousarray(neighbors)
    keep = np.ascontiguousarray(keep, dtype=np.bool_)
    n = offsets.size - 1
    counts = np.empty(n, dtype=np.int64)
    if n:
        _row_kept_counts(offsets, keep, counts)
    new_offsets = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=new_offsets[1:])
    out = np.empty(int(new_offsets[-1]), dtype=neighbors.dtype)
    if out.size:
        _compact_kernel(offsets, neighbors, keep, new_offsets, out)
    return new_offsets, out


@njit(cache=True)
def _same_block_kernel(offsets, neighbors, rows, block_id, keep):
    n = offsets.size - 1
    for r in range(n):
        bi = block_id[rows[r]]
        for b in range(offsets[r], offsets[r + 1]):
            keep[b] = block_id[neighbors[b]] == bi


def omit_bonds_between_blocks(
    offsets: np.ndarray, neighbors: np.ndarray, block_id: np.ndarray, rows: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Peridigm's ``Omit Bonds Between Blocks: All`` (PERIDIGM_SEMANTICS.md section 2.7).

    Removes every bond whose two ends have different block ids, keeping the order of the rest.
    offsets int64 (k+1,); neighbors integer (B,); block_id integer (n,) per point; rows int64 (k,)
    the point of each CSR row (default: row r is point r). Returns ``(offsets, neighbors)``.
    """
    offsets = np.ascontiguousarray(offsets, dtype=np.int64)
    neighbors = np.ascontiguousarray(neighbors)
    k = offsets.size - 1
    rows = np.arange(k, dtype=np.int64) if rows is None else np.ascontiguousarray(rows, dtype=np.int64)
    keep = np.empty(neighbors.size, dtype=np.bool_)
    if neighbors.size:
        _same_block_kernel(offsets, neighbors, rows, np.ascontiguousarray(block_id, dtype=np.int64), keep)
    return compact(offsets, neighbors, keep)


# ------------------------------------------------------------------------------------------------
# Space-filling curve
# ------------------------------------------------------------------------------------------------
_HILBERT_BITS = 21  # 3 x 21 = 63 bits: the key fits in an int64


@njit(cache=True)
def _hilbert_keys(q, bits):
    """3-D Hilbert index of integer coordinates q (n,3) int64 in [0, 2**bits) (Skilling 2004)."""
    n = q.shape[0]
    keys = np.empty(n, dtype=np.int64)
    m = np.int64(1) << (bits - 1)
    for p in range(n):
        X0 = q[p, 0]
        X1 = q[p, 1]
        X2 = q[p, 2]
        # inverse undo
        Q = m
        while Q > 1:
            P = Q - 1
            # i = 0
            if X0 & Q:
                X0 ^= P
            # i = 1
            if X1 & Q:
                X0 ^= P
            else:
                t = (X0 ^ X1) & P
                X0 ^= t
                X1 ^= t
            # i = 2
            if X2 & Q:
                X0 ^= P
            else:
                t = (X0 ^ X2) & P
                X0 ^= t
                X2 ^= t
            Q >>= 1
        # Gray encode
        X1 ^= X0
        X2 ^= X1
        t = np.int64(0)
        Q = m
        while Q > 1:
            if X2 & Q:
                t ^= Q - 1
            Q >>= 1
        X0 ^= t
        X1 ^= t
        X2 ^= t
        # interleave the transposed bits, most significant first
        key = np.int64(0)
        for b in range(bits - 1, -1, -1):
            key = (key << 1) | ((X0 >> b) & 1)
            key = (key << 1) | ((X1 >> b) & 1)
            key = (key << 1) | ((X2 >> b) & 1)
        keys[p] = key
    return keys


def hilbert_keys(x: np.ndarray, bits: int = _HILBERT_BITS) -> np.ndarray:
    """Hilbert-curve index (int64, shape (n,)) of points x (n,3), quantized on a cube of 2**bits
    cells per axis spanning the bounding box (same scale on every axis)."""
    x = np.ascontiguousarray(x, dtype=np.float64)
    n = x.shape[0]
    if n == 0:
        return np.empty(0, dtype=np.int64)
    lo = x.min(axis=0)
    span = float((x.max(axis=0) - lo).max())
    top = (1 << bits) - 1
    if span > 0.0 and np.isfinite(span):
        q = np.floor((x - lo) * (top / span)).astype(np.int64)
        np.clip(q, 0, top, out=q)
    else:
        q = np.zeros((n, 3), dtype=np.int64)
    return _hilbert_keys(q, bits)


#: rows ``storage_rank`` counts runs over (evenly spaced): the layouts compare alike on a sample
ROW_SAMPLE = 20000


@njit(cache=True)
def row_runs(offsets, neighbors, position, stride=1):
    """Runs of consecutive storage positions along the rows: the number of bonds whose neighbor
    is not stored right after the previous neighbor of its row (plus one a non-empty row), over
    every ``stride``-th row. offsets (n+1,), neighbors (B,) indices into position (m,) int64.
    Fewer runs, fewer streams for a gather over the rows to follow (``storage_rank`` picks the
    layout with fewer)."""
    runs = 0
    for i in range(0, offsets.size - 1, stride):
        for b in range(offsets[i], offsets[i + 1]):
            if b == offsets[i] or position[neighbors[b]] != position[neighbors[b - 1]] + 1:
                runs += 1
    return runs


def space_filling_order(x: np.ndarray) -> np.ndarray:
    """Permutation (int64, shape (n,)) listing the points of x (n,3) along a 3-D Hilbert curve.

    ``x[order]`` puts points close in space close in memory; ties (points in the same curve cell,
    duplicates) keep their index order, so the result is deterministic.
    """
    keys = hilbert_keys(x)
    return np.argsort(keys, kind="stable").astype(np.int64)


def storage_rank(x: np.ndarray, gid: np.ndarray, block: np.ndarray, owned: np.ndarray, offsets: np.ndarray,
                 neighbors: np.ndarray, serial: bool) -> np.ndarray:
    """Where each owned point is stored within its block: (n_owned,) int64 ranks, along a
    Hilbert curve (``space_filling_order``) or, in a serial run whose rows follow the global ids
    in fewer runs of consecutive points (``row_runs``; a lattice numbered axis by axis), in
    global-id order. Rows are summed in global-id order either way; the id order also lets one
    thread compute each bond once (``peridyn.kernels.mirror``). A copy of the elastic force
    loop on cube40's bonds, one thread, gathered: 38 ms in Hilbert order, 29 ms in id order.

    x (m, 3), gid (m,), block (m,) of every point; owned (n_owned,) the owned points' indices in
    those; offsets, neighbors the owned points' rows (entries index x).
    """
    n_owned = owned.size
    sfc = space_filling_order(x[owned]) if n_owned else np.zeros(0, np.int64)
    rank = np.empty(n_owned, dtype=np.int64)
    rank[sfc] = np.arange(n_owned)
    if not serial or not neighbors.size:
        return rank
    by_id = np.empty(n_owned, dtype=np.int64)
    by_id[np.argsort(gid[owned], kind="stable")] = np.arange(n_owned)
    runs = []
    stride = max(1, n_owned // ROW_SAMPLE)
    for key in (by_id, rank):
        position = np.zeros(x.shape[0], dtype=np.int64)
        position[owned[np.lexsort((key, block[owned]))]] = np.arange(n_owned)
        runs.append(row_runs(offsets, neighbors, position, stride))
    return by_id if runs[0] <= runs[1] else rank
