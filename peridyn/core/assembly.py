"""Dense-local to block-sparse assembly of tangents, shared by the materials' finite-difference
tangents and the implicit solvers' (numba, serial).

A point i's force state touches S_i = [N_i..., i] (its neighbors in bond order, then i): the
``local_*_force_kernel`` write the force density of i's bonds on S_i as a flat vector
(3 (|N_i| + 1),), and :func:`scatter_local_kernel` adds a dense local matrix on S_i into the
BSR arrays of K (3x3 blocks, rows and columns in row numbering, columns ascending within a row;
see :class:`TangentTarget`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit


@dataclass
class TangentTarget:
    """What ``Material.tangent`` writes into: the BSR arrays of K in row (global-id) numbering
    and the maps a gather kernel needs.

    indptr (nrows+1,) int64; indices (nnzb,) int32 block columns (row numbering); data
    (nnzb, 3, 3) float64, ``data[p, d, c] = dF_(row,d)/dy_(col,c)`` (force per length);
    row_of_local / local_of_row map local point indices and rows (under MPI the rows are the
    rank's local points, owned then ghosts; nrows = number of local points); eval_rank (n,) is Peridigm's
    evaluation order of points (block, then global id); in_offsets, in_bonds, sources: the
    transposed neighbor list (incoming bonds of every point and the owner of every bond);
    nchunks: number of independent row chunks for ``prange``; max_degree / max_in: the longest
    neighbor list and incoming list (scratch sizes)."""

    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray
    row_of_local: np.ndarray
    local_of_row: np.ndarray
    eval_rank: np.ndarray
    in_offsets: np.ndarray
    in_bonds: np.ndarray
    sources: np.ndarray
    nrows: int
    nchunks: int
    max_degree: int
    max_in: int
    probe_length: float | None = None  #: the finite-difference probe of the block being filled (L)


@njit(cache=True)
def local_vector_force_kernel(i, offsets, neighbors, volume, T, out):
    """``local_scalar_state_force_kernel`` for vector force states T (nb, 3) of i's bonds: f_i = sum T_b V_j,
    f_j = -T_b V_i on S_i = [N_i..., i]."""
    o = offsets[i]
    ns = offsets[i + 1] - o + 1
    fx = 0.0
    fy = 0.0
    fz = 0.0
    Vi = volume[i]
    for b in range(o, offsets[i + 1]):
        j = neighbors[b]
        k = 3 * (b - o)
        out[k] = -T[b, 0] * Vi
        out[k + 1] = -T[b, 1] * Vi
        out[k + 2] = -T[b, 2] * Vi
        fx += T[b, 0] * volume[j]
        fy += T[b, 1] * volume[j]
        fz += T[b, 2] * volume[j]
    k = 3 * (ns - 1)
    out[k] = fx
    out[k + 1] = fy
    out[k + 2] = fz


@njit(cache=True, error_model="numpy")
def local_scalar_state_force_kernel(i, offsets, neighbors, y, volume, t, out):
    """Force density of point i's bonds on S_i = [N_i..., i] (out (3 (|N_i| + 1),)) from the
    local scalar force states t[b - offsets[i]] (zero-length bonds carry none): the
    finite-difference probes of the deviatoric materials, of Pals and of the solvers' tangent."""
    o = offsets[i]
    ns = offsets[i + 1] - o + 1
    for k in range(3 * ns):
        out[k] = 0.0
    fx = 0.0
    fy = 0.0
    fz = 0.0
    Vi = volume[i]
    for b in range(o, offsets[i + 1]):
        j = neighbors[b]
        ex = y[j, 0] - y[i, 0]
        ey = y[j, 1] - y[i, 1]
        ez = y[j, 2] - y[i, 2]
        L = math.sqrt(ex * ex + ey * ey + ez * ez)
        if L > 0.0:
            s = t[b - o] / L
            k = 3 * (b - o)
            out[k] -= s * ex * Vi
            out[k + 1] -= s * ey * Vi
            out[k + 2] -= s * ez * Vi
            fx += s * ex * volume[j]
            fy += s * ey * volume[j]
            fz += s * ez * volume[j]
    k = 3 * (ns - 1)
    out[k] = fx
    out[k + 1] = fy
    out[k + 2] = fz


@njit(cache=True)
def scatter_local_kernel(rows, Kloc, indptr, indices, data):
    """data += a dense local matrix Kloc (3 ns, 3 ns) whose points are rows (ns,) (row numbers),
    entries outside the pattern dropped. Serial (finite-difference path)."""
    ns = rows.shape[0]
    for a in range(ns):
        r = rows[a]
        lo = indptr[r]
        hi = indptr[r + 1]
        for b in range(ns):
            col = rows[b]
            # binary search of col in indices[lo:hi] (ascending)
            left = lo
            right = hi
            while left < right:
                mid = (left + right) // 2
                if indices[mid] < col:
                    left = mid + 1
                else:
                    right = mid
            if left < hi and indices[left] == col:
                for d in range(3):
                    for c in range(3):
                        data[left, d, c] += Kloc[3 * a + d, 3 * b + c]
