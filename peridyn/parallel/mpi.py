"""MPI through mpi4py (imported only when a run is launched on several ranks).

The engine keeps model code serial (DESIGN.md decision 5): each rank owns a set of points plus
ghost copies of the points its bonds reach. :class:`Halo` refreshes ghosts from their owners
(``exchange``) and returns ghost contributions to their owners (``reverse_sum``); everything
else is a global reduction or a gather of output to rank 0.
"""
from __future__ import annotations

import atexit
import time
import weakref

import numpy as np


_HALO_TAG = 7101  # halo messages; messages between two ranks with one tag arrive in order

#: halo messages are split into pieces of at most this many bytes. A message below the MPI
#: library's eager limit travels as soon as it is sent; a larger one waits for the sender to
#: enter MPI again, so it could not overlap with the sender's computation (MPICH on shared
#: memory: 8000-byte pieces arrive while the sender computes, 12000-byte ones do not).
#: ``PERIDYN_HALO_MESSAGE_BYTES`` overrides it (0: one message per rank pair).
HALO_MESSAGE_BYTES = 8000


def _mpi():
    from mpi4py import MPI

    return MPI


#: every Halo alive: their persistent requests are freed before MPI is finalized (MPICH prints
#: "freeing inactive persistent request" for each one left at MPI_Finalize)
_HALOS: "weakref.WeakSet[Halo]" = weakref.WeakSet()
_registered = False


def free_persistent_requests() -> None:
    """Free the persistent requests of every halo (at exit, before MPI_Finalize; a halo used
    afterwards plans its messages again)."""
    for halo in list(_HALOS):
        halo.free()


def _register_at_exit() -> None:
    """After mpi4py is imported: Python runs exit handlers last-registered first, and mpi4py
    finalizes MPI after them, so the requests are freed while MPI still works."""
    global _registered
    if not _registered:
        _mpi()
        atexit.register(free_persistent_requests)
        _registered = True


def _message_bytes() -> int:
    import os

    value = os.environ.get("PERIDYN_HALO_MESSAGE_BYTES")
    try:
        return int(value) if value is not None else HALO_MESSAGE_BYTES
    except ValueError:
        return HALO_MESSAGE_BYTES


class _Plan:
    """Persistent requests of one exchange direction and width: buffers and messages set up
    once, started and completed each time (two calls instead of one per message)."""

    def __init__(self, halo: "Halo", forward: bool, width: int) -> None:
        MPI = _mpi()
        h = halo
        counts_s, displs_s, counts_r, displs_r = (
            (h.send_counts, h.send_displs, h.recv_counts, h.recv_displs) if forward else (h.recv_counts, h.recv_displs, h.send_counts, h.send_displs)
        )
        self.send = np.empty((int(np.sum(counts_s)), width), dtype=np.float64)
        self.recv = np.empty((int(np.sum(counts_r)), width), dtype=np.float64)
        self.requests = [h.comm.Recv_init([self.recv[lo : lo + n], MPI.DOUBLE], source=r, tag=h.tag) for r, lo, n in h._pieces(counts_r, displs_r, width)]
        self.requests += [h.comm.Send_init([self.send[lo : lo + n], MPI.DOUBLE], dest=r, tag=h.tag) for r, lo, n in h._pieces(counts_s, displs_s, width)]
        self.busy = False


class PendingExchange:
    """A halo exchange in flight (``Halo.begin``): messages started, ghosts not yet written."""

    def __init__(self, array: np.ndarray, plan: _Plan) -> None:
        self.array = array
        self.plan = plan


class Halo:
    """Communication plan between the owned points and ghost points of all ranks.

    send_index: local indices of owned points to send, grouped by destination rank
    (``send_counts``); recv_index: local indices of ghosts filled from each source rank, grouped
    by source (``recv_counts``). Bytes moved per exchange are recorded in ``bytes_sent``;
    ``seconds`` is the time spent inside the exchanges (starting, waiting, copying), not the
    computation that ``begin``/``end`` overlap with them.
    """

    def __init__(self, comm, send_index, send_counts, recv_index, recv_counts, *, tag: int = _HALO_TAG) -> None:
        self.comm = comm
        self.tag = tag  #: a plan with its own tag never matches another plan's messages
        self.send_index = send_index
        self.send_counts = np.asarray(send_counts, dtype=np.int64)
        self.recv_index = recv_index
        self.recv_counts = np.asarray(recv_counts, dtype=np.int64)
        self.send_displs = np.concatenate([[0], np.cumsum(self.send_counts)[:-1]])
        self.recv_displs = np.concatenate([[0], np.cumsum(self.recv_counts)[:-1]])
        self.message_bytes = _message_bytes()
        self._plans: dict[tuple[bool, int], list[_Plan]] = {}  # by (direction, width); one per exchange in flight
        self.bytes_sent = 0
        self.exchanges = 0
        self.seconds = 0.0
        _register_at_exit()
        _HALOS.add(self)

    def __del__(self) -> None:
        try:
            if not _mpi().Is_finalized():
                self.free()
        except Exception:  # pragma: no cover - interpreter shutdown
            pass

    @property
    def num_ghosts(self) -> int:
        return int(self.recv_index.size)

    def _pieces(self, counts, displs, width: int):
        """(rank, first row, rows) of every message: each rank's rows in pieces of at most
        ``message_bytes`` bytes, in row order (the receiver posts the same pieces in the same
        order, and MPI keeps the order of messages with one tag between two ranks). Messages go
        to and come from the ranks with something to exchange only (a few neighbors whatever
        the number of ranks; an MPI_Alltoallv would cost O(ranks))."""
        per = max(1, self.message_bytes // (8 * width)) if self.message_bytes > 0 else None
        for r in np.flatnonzero(counts):
            lo, count = int(displs[r]), int(counts[r])
            step = per or count
            for k in range(0, count, step):
                yield int(r), lo + k, min(step, count - k)

    def _start(self, forward: bool, rows: np.ndarray, width: int) -> _Plan:
        plans = self._plans.setdefault((forward, width), [])
        plan = next((p for p in plans if not p.busy), None)
        if plan is None:  # first exchange of this shape, or all of its plans are in flight
            plan = _Plan(self, forward, width)
            plans.append(plan)
        plan.busy = True
        plan.send[...] = rows.reshape(plan.send.shape)
        _mpi().Prequest.Startall(plan.requests)
        self.bytes_sent += plan.send.nbytes
        self.exchanges += 1
        return plan

    def _finish(self, plan: _Plan) -> np.ndarray:
        _mpi().Request.Waitall(plan.requests)
        plan.busy = False
        return plan.recv

    def begin(self, array: np.ndarray) -> PendingExchange:
        """Start refreshing the ghost rows of ``array`` (shape (n_local,) or (n_local, k)) from
        their owners; compute what does not read ghosts, then call ``end``. The owned rows may
        change in between (they were copied), the ghost rows must not be read."""
        t0 = time.perf_counter()
        width = 1 if array.ndim == 1 else int(np.prod(array.shape[1:]))
        plan = self._start(True, array[self.send_index], width)
        self.seconds += time.perf_counter() - t0
        return PendingExchange(array, plan)

    def end(self, pending: PendingExchange) -> None:
        """Wait for the messages of ``begin`` and write the ghost rows."""
        t0 = time.perf_counter()
        recv = self._finish(pending.plan)
        array = pending.array
        array[self.recv_index] = recv.reshape((-1,) + array.shape[1:]).astype(array.dtype, copy=False)
        self.seconds += time.perf_counter() - t0

    def exchange(self, array: np.ndarray) -> None:
        """Copy owners' values into the ghost rows of ``array`` (shape (n_local,) or (n_local, k))."""
        self.end(self.begin(array))

    def free(self) -> None:
        """Release the persistent requests (a plan that is replaced, e.g. contact ghosts, and
        every plan at exit); an exchange in flight is completed first."""
        for plans in self._plans.values():
            for plan in plans:
                if plan.busy:
                    _mpi().Request.Waitall(plan.requests)
                    plan.busy = False
                for r in plan.requests:
                    if r:  # not MPI_REQUEST_NULL
                        r.Free()
        self._plans.clear()

    def reverse_sum(self, array: np.ndarray) -> None:
        """Add the ghost rows of ``array`` into their owners' rows (and leave the ghosts as they
        are): how contributions computed on a ghost reach the point's owner."""
        t0 = time.perf_counter()
        width = 1 if array.ndim == 1 else int(np.prod(array.shape[1:]))
        recv = self._finish(self._start(False, array[self.recv_index], width))
        np.add.at(array, self.send_index, recv.reshape((-1,) + array.shape[1:]))
        self.seconds += time.perf_counter() - t0


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
