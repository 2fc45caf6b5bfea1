"""The gathers: force density and per-point sums from per-bond quantities, both bond ends, each
point summing its own bonds and the bonds into it (``NeighborList.transpose``), so no loop
scatters. Shapes: offsets (n+1,), neighbors (nb,) int32 CSR; in_offsets (n+1,), in_bonds (nb,)
the incoming bonds of each point; sources (nb,) the owner point of each bond; volume (n,) L^3."""
from __future__ import annotations

import math

from numba import njit, prange


@njit(cache=True, parallel=True, error_model="numpy")
def gather_scalar_force_kernel(start, stop, offsets, neighbors, in_offsets, in_bonds, sources, y, volume, t, f):
    """f_i = sum_{b out of i} t_b e_b V_j - sum_{b into i} t_b e_b V_src(b) for i in [start, stop):
    the force density from scalar (central) force states, both bond ends, gathered per point.
    Shapes: y (n, 3); volume (n,); t (nb,); f (n, 3)."""
    for i in prange(start, stop):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            ex = y[j, 0] - y[i, 0]
            ey = y[j, 1] - y[i, 1]
            ez = y[j, 2] - y[i, 2]
            L = math.sqrt(ex * ex + ey * ey + ez * ez)
            if L > 0.0:
                s = (t[b] * volume[j]) / L
                fx += s * ex
                fy += s * ey
                fz += s * ez
        for k in range(in_offsets[i], in_offsets[i + 1]):
            b = in_bonds[k]
            j = sources[b]
            ex = y[j, 0] - y[i, 0]
            ey = y[j, 1] - y[i, 1]
            ez = y[j, 2] - y[i, 2]
            L = math.sqrt(ex * ex + ey * ey + ez * ez)
            if L > 0.0:
                s = (t[b] * volume[j]) / L
                fx += s * ex
                fy += s * ey
                fz += s * ez
        f[i, 0] = fx
        f[i, 1] = fy
        f[i, 2] = fz


@njit(cache=True, parallel=True)
def gather_vector_force_kernel(start, stop, offsets, neighbors, in_offsets, in_bonds, sources, volume, T, f):
    """f_i += sum_{b out of i} T_b V_j - sum_{b into i} T_b V_src(b) for i in [start, stop): the
    force density from vector force states (non-ordinary materials), both bond ends, gathered
    per point. Shapes: volume (n,); T (nb, 3) force per volume squared; f (n, 3)."""
    for i in prange(start, stop):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            vj = volume[neighbors[b]]
            fx += T[b, 0] * vj
            fy += T[b, 1] * vj
            fz += T[b, 2] * vj
        for k in range(in_offsets[i], in_offsets[i + 1]):
            b = in_bonds[k]
            vj = volume[sources[b]]
            fx -= T[b, 0] * vj
            fy -= T[b, 1] * vj
            fz -= T[b, 2] * vj
        f[i, 0] += fx
        f[i, 1] += fy
        f[i, 2] += fz


@njit(cache=True, parallel=True)
def gather_bond_scalar_kernel(lo, hi, offsets, neighbors, in_offsets, in_bonds, sources, volume, q, flow):
    """flow_i = sum_{b = i->j} q_b V_j - sum_{b = j->i} q_b V_j for the rows [lo, hi) (owned
    rows, or under MPI the ghost rows, whose sums go back to their owners): a gather of a
    per-bond scalar q (nb,), added at the bond's owner and subtracted at its other end, e.g. the fluid flow of multiphysics
    materials (``Material.flow_bond_field``) into Flux_Density. Shapes: volume, flow (n,)."""
    for i in prange(lo, hi):
        acc = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            acc += q[b] * volume[neighbors[b]]
        for k in range(in_offsets[i], in_offsets[i + 1]):
            b = in_bonds[k]
            acc -= q[b] * volume[sources[b]]
        flow[i] = acc
