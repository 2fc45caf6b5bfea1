"""Packed point records: row i of P (n_local, width) holds what a hot kernel reads of a neighbor
(positions in columns 0-2, then the model's per-point values) in one record, so a neighbor costs
one or two cache lines instead of one per array. Only the rows a view's bonds reach are packed:
two ranges, owned rows and ghost rows (``reach_kernel``)."""
from __future__ import annotations

from numba import njit, prange


@njit(cache=True)
def reach_kernel(start, stop, n_owned, offsets, neighbors):
    """(lo1, hi1, lo2, hi2): the owned rows [lo1, hi1) (including [start, stop)) and the ghost
    rows [lo2, hi2) (empty: 0, 0) the bonds of rows [start, stop) reach."""
    lo1, hi1 = start, stop
    lo2, hi2 = -1, -1
    for b in range(offsets[start], offsets[stop]):
        j = neighbors[b]
        if j < n_owned:
            lo1 = min(lo1, j)
            hi1 = max(hi1, j + 1)
        elif lo2 < 0:
            lo2, hi2 = j, j + 1
        else:
            lo2 = min(lo2, j)
            hi2 = max(hi2, j + 1)
    if lo2 < 0:
        lo2, hi2 = 0, 0
    return lo1, hi1, lo2, hi2


@njit(cache=True, parallel=True)
def pack_points_kernel(lo1, hi1, lo2, hi2, y, volume, vcol, P):
    """P[i, 0:3] = y_i (L) and P[i, vcol] = V_i (L^3) for the rows [lo1, hi1) and [lo2, hi2);
    the other columns are the model's."""
    n1 = hi1 - lo1
    for k in prange(n1 + (hi2 - lo2)):
        i = lo1 + k if k < n1 else lo2 + (k - n1)
        P[i, 0] = y[i, 0]
        P[i, 1] = y[i, 1]
        P[i, 2] = y[i, 2]
        P[i, vcol] = volume[i]
