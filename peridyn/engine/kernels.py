"""The engine's own numba kernels: bond lengths, ghost and
block-crossing flags, the critical time step (shapes and units in each docstring)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange


@njit(cache=True, parallel=True, error_model="numpy")
def bond_length_kernel(n, offsets, neighbors, x, zeta):
    """zeta[b] = |x_j - x_i| for every bond b = i->j, as ((dx dx + dy dy) + dz dz)^(1/2)."""
    for i in prange(n):
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            dx = x[j, 0] - x[i, 0]
            dy = x[j, 1] - x[i, 1]
            dz = x[j, 2] - x[i, 2]
            zeta[b] = math.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True)
def shortest_bond_kernel(n, offsets, neighbors, x):
    """(min |xi|, its bond) over the bonds of rows [0, n), |xi| computed as in ``bond_length_kernel``;
    (inf, -1) without bonds."""
    best = np.inf
    where = -1
    for i in range(n):
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            dx = x[j, 0] - x[i, 0]
            dy = x[j, 1] - x[i, 1]
            dz = x[j, 2] - x[i, 2]
            z = math.sqrt(dx * dx + dy * dy + dz * dz)
            if where < 0 or z < best or (z != z and best == best):  # the first NaN counts as the shortest
                best = z
                where = b
    return best, where


@njit(cache=True)
def foreign_neighbor_kernel(n, offsets, neighbors, owner, rank, out):
    """out[i] = some neighbor of row i is owned by another rank."""
    for i in range(n):
        for b in range(offsets[i], offsets[i + 1]):
            if owner[neighbors[b]] != rank:
                out[i] = True
                break


@njit(cache=True)
def crossing_blocks_kernel(n, offsets, neighbors, block_index, open_mask):
    """open_mask[k] = True for every block with a bond leaving or entering it."""
    for i in range(n):
        bi = block_index[i]
        for b in range(offsets[i], offsets[i + 1]):
            bj = block_index[neighbors[b]]
            if bj != bi:
                open_mask[bi] = True
                open_mask[bj] = True


@njit(cache=True, parallel=True, error_model="numpy")
def critical_time_step_kernel(start, stop, offsets, neighbors, x, volume, density, c_const, c_point, dt):
    """dt_i = sqrt(2 rho / sum_j V_j c / |xi|) (Silling-Askari), inf for isolated points.
    c_point (n,) overrides c_const when non-empty (variable horizons)."""
    per_point = c_point.shape[0] > 0
    for i in prange(start, stop):
        c = c_point[i] if per_point else c_const
        acc = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            dx = x[i, 0] - x[j, 0]
            dy = x[i, 1] - x[j, 1]
            dz = x[i, 2] - x[j, 2]
            acc += (volume[j] * c) / math.sqrt(dx * dx + dy * dy + dz * dz)
        dt[i] = math.sqrt((2.0 * density) / acc) if acc > 0.0 else np.inf


# ------------------------------------------------------------------------------------------------
