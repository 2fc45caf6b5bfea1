"""Small bond formulas shared by kernels of different plugins (inlined by numba)."""
from __future__ import annotations

import math

from numba import njit, prange


@njit(cache=True, inline="always")
def stretch_exceeds(L2: float, L0: float, s_c: float) -> bool:
    """Whether (|eta| - |xi|)/|xi| > s_c, Peridigm's critical-stretch test, with |eta|^2 = L2 and
    |xi| = L0. Bonds far from the threshold are decided from squared lengths (a relative
    margin of 1e-10, far above round-off); the rest exactly as Peridigm computes it."""
    if s_c > -1.0:
        limit = L0 * (1.0 + s_c)
        limit2 = limit * limit
        if L2 < limit2 * (1.0 - 1e-10):
            return False
        if L2 > limit2 * (1.0 + 1e-10):
            return True
    L = math.sqrt(L2)
    return (L - L0) / L0 > s_c


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
