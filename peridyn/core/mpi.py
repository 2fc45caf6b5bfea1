"""MPI through mpi4py (imported only when a run is launched on several ranks).

The engine keeps model code serial (DESIGN.md decision 5): each rank owns a set of points plus
ghost copies of the points its bonds reach. :class:`Halo` refreshes ghosts from their owners
(``exchange``) and returns ghost contributions to their owners (``reverse_sum``); everything
else is a global reduction or a gather of output to rank 0.
"""
from __future__ import annotations

import numpy as np


_HALO_TAG = 7101  # halo messages; every exchange completes before the next one starts


def _mpi():
    from mpi4py import MPI

    return MPI


class Halo:
    """Communication plan between the owned points and ghost points of all ranks.

    send_index: local indices of owned points to send, grouped by destination rank
    (``send_counts``); recv_index: local indices of ghosts filled from each source rank, grouped
    by source (``recv_counts``). Bytes moved per exchange are recorded in ``bytes_sent``.
    """

    def __init__(self, comm, send_index, send_counts, recv_index, recv_counts) -> None:
        self.comm = comm
        self.send_index = send_index
        self.send_counts = np.asarray(send_counts, dtype=np.int64)
        self.recv_index = recv_index
        self.recv_counts = np.asarray(recv_counts, dtype=np.int64)
        self.send_displs = np.concatenate([[0], np.cumsum(self.send_counts)[:-1]])
        self.recv_displs = np.concatenate([[0], np.cumsum(self.recv_counts)[:-1]])
        self.bytes_sent = 0
        self.exchanges = 0
        self.seconds = 0.0

    @property
    def num_ghosts(self) -> int:
        return int(self.recv_index.size)

    def _alltoallv(self, send: np.ndarray, send_counts, send_displs, recv_counts, recv_displs, width: int) -> np.ndarray:
        """Rows ``send[send_displs[r]:][:send_counts[r]]`` go to rank r; returns the rows
        received from each rank r at ``recv_displs[r]``. Point-to-point messages to and from
        the ranks with something to exchange only (a rank has a few neighbors whatever the
        number of ranks; an MPI_Alltoallv would cost O(ranks) per call)."""
        import time

        MPI = _mpi()
        t0 = time.perf_counter()
        recv = np.empty((int(np.sum(recv_counts)), width), dtype=np.float64)
        s = np.ascontiguousarray(send.reshape(-1, width), dtype=np.float64)
        requests = []
        for r in np.flatnonzero(recv_counts):
            lo = int(recv_displs[r])
            requests.append(self.comm.Irecv([recv[lo : lo + int(recv_counts[r])], MPI.DOUBLE], source=int(r), tag=_HALO_TAG))
        for r in np.flatnonzero(send_counts):
            lo = int(send_displs[r])
            requests.append(self.comm.Isend([s[lo : lo + int(send_counts[r])], MPI.DOUBLE], dest=int(r), tag=_HALO_TAG))
        MPI.Request.Waitall(requests)
        self.bytes_sent += s.nbytes
        self.exchanges += 1
        self.seconds += time.perf_counter() - t0
        return recv

    def exchange(self, array: np.ndarray) -> None:
        """Copy owners' values into the ghost rows of ``array`` (shape (n_local,) or (n_local, k))."""
        width = 1 if array.ndim == 1 else int(np.prod(array.shape[1:]))
        recv = self._alltoallv(array[self.send_index], self.send_counts, self.send_displs, self.recv_counts, self.recv_displs, width)
        if array.ndim == 1:
            array[self.recv_index] = recv[:, 0].astype(array.dtype, copy=False)
        else:
            array[self.recv_index] = recv.reshape((-1,) + array.shape[1:]).astype(array.dtype, copy=False)

    def reverse_sum(self, array: np.ndarray) -> None:
        """Add the ghost rows of ``array`` into their owners' rows (and leave the ghosts as they
        are): how contributions computed on a ghost reach the point's owner."""
        width = 1 if array.ndim == 1 else int(np.prod(array.shape[1:]))
        recv = self._alltoallv(array[self.recv_index], self.recv_counts, self.recv_displs, self.send_counts, self.send_displs, width)
        values = recv[:, 0] if array.ndim == 1 else recv.reshape((-1,) + array.shape[1:])
        np.add.at(array, self.send_index, values)


class MPIComm:
    """The communicator of an MPI run, with the collectives the engine uses."""

    def __init__(self, comm=None) -> None:
        MPI = _mpi()
        self.MPI = MPI
        self.comm = comm if comm is not None else MPI.COMM_WORLD
        self.rank = self.comm.Get_rank()
        self.size = self.comm.Get_size()
        self.is_root = self.rank == 0

    # reductions -------------------------------------------------------------------------------
    def _reduce(self, value, op):
        if isinstance(value, np.ndarray):
            out = np.empty_like(value)
            self.comm.Allreduce(np.ascontiguousarray(value), out, op=op)
            return out
        return self.comm.allreduce(value, op=op)

    def allreduce_sum(self, value):
        return self._reduce(value, self.MPI.SUM)

    def allreduce_min(self, value):
        return self._reduce(value, self.MPI.MIN)

    def allreduce_max(self, value):
        return self._reduce(value, self.MPI.MAX)

    def allgather(self, value):
        return self.comm.allgather(value)

    def gather(self, value):
        """Every rank's ``value`` (any picklable object) in rank order on rank 0, None elsewhere."""
        return self.comm.gather(value, root=0)

    def alltoall(self, values: list) -> list:
        """``values[r]`` (picklable) goes to rank r; returns what each rank sent here, by rank."""
        return self.comm.alltoall(values)

    def bcast(self, value):
        return self.comm.bcast(value, root=0)

    def barrier(self) -> None:
        self.comm.Barrier()

    def abort(self, code: int = 1) -> None:
        self.comm.Abort(int(code))

    # output -----------------------------------------------------------------------------------
    def gather_points(self, values: np.ndarray, owned_index: np.ndarray, total: int) -> np.ndarray | None:
        """Per-point values of all ranks in global (mothership) order on rank 0 (None elsewhere).
        values (n_owned, ...) this rank's owned values; owned_index (n_owned,) their indices."""
        MPI = self.MPI
        width = 1 if values.ndim == 1 else int(np.prod(values.shape[1:]))
        counts = np.array(self.comm.allgather(int(values.shape[0])), dtype=np.int64)
        displs = np.concatenate([[0], np.cumsum(counts)[:-1]])
        send = np.ascontiguousarray(values, dtype=np.float64).reshape(-1)
        idx_send = np.ascontiguousarray(owned_index, dtype=np.int64)
        if self.is_root:
            vals = np.empty(int(counts.sum()) * width, dtype=np.float64)
            idx = np.empty(int(counts.sum()), dtype=np.int64)
        else:
            vals = idx = None
        self.comm.Gatherv(send, [vals, (counts * width, displs * width), MPI.DOUBLE] if self.is_root else None, root=0)
        self.comm.Gatherv(idx_send, [idx, (counts, displs), MPI.INT64_T] if self.is_root else None, root=0)
        if not self.is_root:
            return None
        out = np.empty((total,) + values.shape[1:], dtype=np.float64)
        out[idx] = vals.reshape((-1,) + values.shape[1:])
        return out.astype(values.dtype, copy=False)

    # halos ------------------------------------------------------------------------------------
    def make_halo(self, ghost_mothership: np.ndarray, ghost_owner: np.ndarray, ghost_local: np.ndarray, local_of_mothership: np.ndarray) -> Halo:
        """Plan the exchanges: this rank needs the ghosts ``ghost_mothership`` (owned by
        ``ghost_owner``, stored at local rows ``ghost_local``); every rank tells every owner
        which of its points it needs."""
        MPI = self.MPI
        order = np.lexsort((ghost_mothership, ghost_owner))
        ghost_mothership = ghost_mothership[order]
        ghost_owner = ghost_owner[order]
        recv_index = ghost_local[order]
        recv_counts = np.bincount(ghost_owner, minlength=self.size).astype(np.int64)
        send_counts = np.empty(self.size, dtype=np.int64)
        self.comm.Alltoall(recv_counts, send_counts)
        requested = np.empty(int(send_counts.sum()), dtype=np.int64)
        rdispls = np.concatenate([[0], np.cumsum(recv_counts)[:-1]])
        sdispls = np.concatenate([[0], np.cumsum(send_counts)[:-1]])
        self.comm.Alltoallv(
            [np.ascontiguousarray(ghost_mothership), (recv_counts, rdispls), MPI.INT64_T],
            [requested, (send_counts, sdispls), MPI.INT64_T],
        )
        send_index = local_of_mothership[requested]
        return Halo(self.comm, send_index, send_counts, recv_index, recv_counts)
