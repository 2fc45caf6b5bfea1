"""What contact needs from the reference bonds: the pairs bonded one way only, and the volume
within the contact radius (for the stable time step estimate).

Peridigm excludes j from i's contact list when j is in i's reference bond list, broken or not
(PERIDIGM_CONTACT.md §2). With one horizon the lists are symmetric; with blocks of different
horizons a pair can be bonded one way only, and then only one of its two visits exists. Those
pairs are few, so they are kept as a small CSR of global ids per owned point (empty when every
block has the same horizon).
"""
from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, prange

from ..core.traversal import PointSum
from ..kernels import default_backend
from .pair_laws import in_sorted


# not a loop law: one binary search per (row, key) query, not a traversal of the row's bonds
@njit(cache=True, parallel=True)
def has_bond_kernel(rows, keys, offsets, neighbors, gid, out):
    """out[k] = whether row rows[k] holds a neighbor whose gid is keys[k] (rows sorted by gid)."""
    for k in prange(rows.size):
        out[k] = in_sorted(neighbors, offsets[rows[k]], offsets[rows[k] + 1], keys[k], gid)


# Loop law (peridyn.core.traversal). args (bond_length (nb,) L, volume (n,) L^3, rc L).
def short_bond_gate(i, b, p, args):
    """Only the bonds shorter than the contact radius count."""
    return args[0][b] < args[2]


def partner_volume_term(i, j, b, ex, ey, ez, L, z, p, args):
    """V_j (L^3)."""
    return args[1][j]


def partner_volume_finish(i, acc, p, args):
    """max(V_i, acc) (L^3)."""
    return max(args[1][i], acc)


PARTNER_VOLUME = PointSum(partner_volume_term, finish=partner_volume_finish, gate=short_bond_gate)


def partner_volume_kernel(n, offsets, neighbors, bond_length, volume, rc, out):
    """out[i] = max(V_i, sum of V_j over bonds of i shorter than rc) for the points [0, n) (the
    law PARTNER_VOLUME; reads no positions). Shapes: offsets (>= n+1,), neighbors, bond_length
    (nb,); volume (n_local,) L^3; out (>= n,) L^3."""
    y = np.zeros((volume.shape[0], 3))  # the law reads no geometry
    default_backend().kernel(PARTNER_VOLUME)(0, n, offsets, neighbors, bond_length, y, (bond_length, volume, float(rc)), out)


def _has_bond(rows: np.ndarray, keys: np.ndarray, bonds, gid: np.ndarray) -> np.ndarray:
    out = np.zeros(rows.size, dtype=np.bool_)
    if rows.size:
        has_bond_kernel(np.ascontiguousarray(rows, np.int64), np.ascontiguousarray(keys, np.int64), bonds.offsets, bonds.neighbors, gid, out)
    return out


def one_sided_partners(sim: Any, *, uniform: bool) -> tuple[np.ndarray, np.ndarray]:
    """(offsets (num_owned + 1,), sorted gids) of the partners each owned point is bonded to in
    one direction only. Collective under MPI."""
    n = sim.num_owned
    empty = (np.zeros(n + 1, dtype=np.int64), np.zeros(0, dtype=np.int64))
    if uniform:
        return empty
    nl = sim.bonds
    gid = np.asarray(sim.gid, dtype=np.int64)
    counts = np.diff(nl.offsets[: n + 1])
    src = np.repeat(np.arange(n, dtype=np.int64), counts)
    dst = nl.neighbors[: nl.offsets[n]].astype(np.int64)
    rows: list[np.ndarray] = []
    keys: list[np.ndarray] = []
    local = dst < n
    ls, ld = src[local], dst[local]
    lone = ~_has_bond(ld, gid[ls], nl, gid)  # p -> j without j -> p: both ends record it
    rows += [ls[lone], ld[lone]]
    keys += [gid[ld[lone]], gid[ls[lone]]]
    comm = sim.comm
    if comm.size > 1:
        rs, rd = src[~local], dst[~local]
        m_dst = sim.mothership_of_local[rd]
        owner = sim.owner[m_dst]
        dgid = np.asarray(sim.discretization.gid, dtype=np.int64)
        m_src = sim.mothership_of_local[rs]
        outgoing = [np.stack([m_src[owner == r], m_dst[owner == r]]) for r in range(comm.size)]
        replies = []
        for msg in comm.alltoall(outgoing):  # (mothership index of the far point p, of our point j)
            j = sim.local_of_mothership[msg[1]]
            miss = ~_has_bond(j, dgid[msg[0]], nl, gid)
            rows.append(j[miss])
            keys.append(dgid[msg[0][miss]])
            replies.append(np.stack([msg[0][miss], dgid[msg[1][miss]]]))
        for msg in comm.alltoall(replies):  # (mothership index of our p, gid of the far j)
            rows.append(sim.local_of_mothership[msg[0]])
            keys.append(msg[1])
    r = np.concatenate(rows) if rows else np.zeros(0, np.int64)
    k = np.concatenate(keys) if keys else np.zeros(0, np.int64)
    if r.size == 0:
        return empty
    order = np.lexsort((k, r))
    r, k = r[order], k[order]
    keep = np.ones(r.size, dtype=bool)
    keep[1:] = (r[1:] != r[:-1]) | (k[1:] != k[:-1])
    r, k = r[keep], k[keep]
    offsets = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(r, minlength=n), out=offsets[1:])
    return offsets, np.ascontiguousarray(k, dtype=np.int64)
