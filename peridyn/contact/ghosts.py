"""Contact ghosts under MPI: copies of other ranks' points near this rank's points in the
current configuration, chosen again at every pair-list build.

Every rank bins its owned points into cells of the build radius r_b on one global grid and
shares the list of cells it occupies. A point is sent to every rank that occupies one of the 27
cells around the point's own: any point within r_b of a rank's point is found, however far the
bodies have moved from the ranks' reference regions (a fragment that flew across the model is
sent only to the ranks whose points it is near). Between builds the ghosts' positions and
velocities are refreshed every step; volumes, horizons, blocks, global ids and search positions
travel with the build.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, prange

from ..core.interfaces import ContactState
from .search import cell_keys_kernel, column_keys, grid_for_box

#: MPI tag of contact ghost messages (the engine's halo uses another)
CONTACT_TAG = 7102

#: columns of a ghost record: y (3), v (3), s (3), volume, horizon, block, gid, x (3)
_WIDTH = 16


@njit(cache=True, parallel=True)
def destinations_kernel(n, keys, dims, occ_keys, occ_first, occ_ranks, out):
    """out[i, r] = True when rank r occupies a cell next to point i's (keys[i]); occ_keys sorted
    unique cells, occ_ranks[occ_first[c]:occ_first[c + 1]] the ranks in cell occ_keys[c]."""
    d12 = dims[1] * dims[2]
    for i in prange(n):
        k = keys[i]
        cx = k // d12
        cy = (k // dims[2]) % dims[1]
        cz = k % dims[2]
        for ix in range(max(cx - 1, 0), min(cx + 2, dims[0])):
            for iy in range(max(cy - 1, 0), min(cy + 2, dims[1])):
                k0, k1 = column_keys(ix, iy, cz, dims)
                first = np.searchsorted(occ_keys, k0, side="left")
                last = np.searchsorted(occ_keys, k1, side="right")
                for c in range(first, last):
                    for t in range(occ_first[c], occ_first[c + 1]):
                        out[i, occ_ranks[t]] = True


class ContactGhosts:
    """The contact ghost layer of one rank and the plan that refreshes it."""

    def __init__(self, sim: Any) -> None:
        self.sim = sim
        self.comm = sim.comm
        self.halo = None
        self.n_owned = sim.num_owned

    def _grid(self, y: np.ndarray, h: float) -> tuple[np.ndarray, float, np.ndarray]:
        comm = self.comm
        lo = comm.allreduce_min(y.min(axis=0) if y.shape[0] else np.full(3, np.inf))
        hi = comm.allreduce_max(y.max(axis=0) if y.shape[0] else np.full(3, -np.inf))
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):  # no rank owns a point, or a blow-up
            lo, hi = np.where(np.isfinite(lo), lo, 0.0), np.where(np.isfinite(hi), hi, 0.0)
        return grid_for_box(lo, hi, h)

    def build(self, manager: Any, rb: float) -> tuple[ContactState, np.ndarray, np.ndarray]:
        """New ghosts for pair lists of radius rb; returns the contact state (owned points, then
        ghosts), and the search and reference positions of the same points. Collective."""
        sim, comm, n = self.sim, self.comm, self.n_owned
        fields = sim.fields
        y = np.ascontiguousarray(fields["Coordinates"][:n])
        v = fields["Velocity"][:n]
        lo, inv_h, dims = self._grid(y, rb)
        keys = np.empty(n, dtype=np.int64)
        cell_keys_kernel(n, y, lo, inv_h, dims, keys)
        mine = np.unique(keys)
        occupied = comm.allgather(mine)
        cells = np.concatenate(occupied)
        ranks = np.concatenate([np.full(a.size, r, dtype=np.int64) for r, a in enumerate(occupied)])
        order = np.lexsort((ranks, cells))
        cells, ranks = cells[order], ranks[order]
        occ_keys, first = np.unique(cells, return_index=True)
        occ_first = np.append(first, cells.size).astype(np.int64)
        dest = np.zeros((n, comm.size), dtype=np.bool_)
        destinations_kernel(n, keys, dims, occ_keys, occ_first, ranks, dest)
        dest[:, comm.rank] = False
        record = np.empty((n, _WIDTH))
        record[:, 0:3] = y
        record[:, 3:6] = v
        record[:, 6:9] = manager.s
        record[:, 9] = fields["Volume"][:n]
        record[:, 10] = manager.horizon
        record[:, 11] = manager.block
        record[:, 12] = manager.gid
        record[:, 13:16] = fields["Model_Coordinates"][:n]
        send_index = [np.flatnonzero(dest[:, r]) for r in range(comm.size)]
        received = comm.alltoall([record[idx] for idx in send_index])
        ghosts = np.concatenate(received) if received else np.zeros((0, _WIDTH))
        m = n + ghosts.shape[0]
        yy = np.empty((m, 3))
        vv = np.empty((m, 3))
        ss = np.empty((m, 3))
        yy[:n], vv[:n], ss[:n] = y, v, manager.s
        yy[n:], vv[n:], ss[n:] = ghosts[:, 0:3], ghosts[:, 3:6], ghosts[:, 6:9]
        volume = np.concatenate([fields["Volume"][:n], ghosts[:, 9]])
        horizon = np.concatenate([manager.horizon, ghosts[:, 10]])
        block = np.concatenate([manager.block, ghosts[:, 11].astype(np.int64)])
        gid = np.concatenate([manager.gid, ghosts[:, 12].astype(np.int64)])
        self._send_index = send_index
        self._recv_counts = np.array([a.shape[0] for a in received], dtype=np.int64)
        xx = np.concatenate([fields["Model_Coordinates"][:n], ghosts[:, 13:16]])
        return ContactState(yy, vv, volume, horizon, block, gid, n), ss, xx

    def keep(self, state: ContactState, used: np.ndarray) -> tuple[ContactState, np.ndarray]:
        """Keep only the ghosts some pair lists (``used``: (n_ghosts,) bool), and plan the
        per-step refresh of those: a ghost no pair lists now cannot come into contact before the
        next build (it was farther than the build radius, or bonded). Returns the reduced state
        and the new index of every old one (-1: dropped). Collective."""
        from ..parallel.mpi import Halo

        comm, n = self.comm, self.n_owned
        bounds = np.concatenate([[0], np.cumsum(self._recv_counts)])
        masks = [used[bounds[r]:bounds[r + 1]] for r in range(comm.size)]
        theirs = comm.alltoall(masks)  # which of the points this rank sent each rank keeps
        send_index = [idx[mask] for idx, mask in zip(self._send_index, theirs)]
        recv_counts = np.array([int(mk.sum()) for mk in masks], dtype=np.int64)
        rows = np.concatenate([np.arange(n), n + np.flatnonzero(used)]).astype(np.int64)
        new_index = np.full(state.y.shape[0], -1, dtype=np.int64)
        new_index[rows] = np.arange(rows.size)
        m = rows.size
        if self.halo is not None:
            self.halo.free()
        self.halo = Halo(comm.comm, np.concatenate(send_index).astype(np.int64), np.array([i.size for i in send_index], dtype=np.int64),
                         np.arange(n, m, dtype=np.int64), recv_counts, tag=CONTACT_TAG)
        st = ContactState(state.y[rows], state.v[rows], state.volume[rows], state.horizon[rows], state.block[rows], state.gid[rows], n, state.time)
        return st, new_index

    def update(self, state: ContactState) -> None:
        """Copy the owned points' current positions and velocities into the state and refresh
        the ghosts' (every force evaluation). Collective."""
        n = self.n_owned
        fields = self.sim.fields
        state.y[:n] = fields["Coordinates"][:n]
        state.v[:n] = fields["Velocity"][:n]
        self.halo.exchange(state.y)
        self.halo.exchange(state.v)
