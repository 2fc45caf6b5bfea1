"""The only code that knows about ranks (DESIGN.md decision 5).

A serial run uses :class:`SerialComm` and never imports mpi4py. A run started by an MPI
launcher with more than one process gets an MPI communicator (``peridyn.parallel.mpi``).
"""
from __future__ import annotations

import os
from typing import Any

import numpy as np

#: environment variables MPI launchers set to the number of processes
_SIZE_VARIABLES = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "MPI_LOCALNRANKS", "SLURM_NTASKS_PER_JOB", "MV2_COMM_WORLD_SIZE")


def launched_with_mpi() -> bool:
    """True when an MPI launcher started more than one process (no mpi4py import needed)."""
    for name in _SIZE_VARIABLES[:3] + ("MV2_COMM_WORLD_SIZE",):
        value = os.environ.get(name)
        if value is not None:
            try:
                return int(value) > 1
            except ValueError:
                continue
    return False


#: prefixes of the environment variables MPI launchers (MPICH's Hydra, Open MPI, Intel MPI,
#: MVAPICH, PMIx) give their processes
_LAUNCHER_PREFIXES = ("PMI_", "PMIX_", "OMPI_", "HYDRA_", "MPIR_", "MPI_LOCAL", "I_MPI_", "MV2_", "PRTE_", "OPAL_")


def without_launcher(env: dict[str, str]) -> dict[str, str]:
    """``env`` without the variables an MPI launcher set for this process: a child process given
    it starts as a serial run (or under its own ``mpiexec``), not as a rank of this job."""
    return {k: v for k, v in env.items() if not k.startswith(_LAUNCHER_PREFIXES)}


def ranks_on_this_node() -> int:
    """Number of MPI ranks sharing this machine, from the launcher's environment (1 if unknown)."""
    for name in ("MPI_LOCALNRANKS", "OMPI_COMM_WORLD_LOCAL_SIZE", "SLURM_NTASKS_PER_NODE", "PMI_SIZE"):
        value = os.environ.get(name)
        if value:
            try:
                return max(1, int(value.split("(")[0]))
            except ValueError:
                continue
    return 1


class NullHalo:
    """The halo of a serial run: there are no ghosts."""

    num_ghosts = 0
    bytes_sent = 0
    exchanges = 0
    seconds = 0.0

    def exchange(self, array) -> None:
        pass

    def begin(self, array) -> None:
        return None

    def end(self, pending) -> None:
        pass

    def reverse_sum(self, array) -> None:
        pass


class SerialComm:
    """A one-process communicator with the collective operations the engine uses."""

    rank = 0
    size = 1
    is_root = True

    def allreduce_sum(self, value):
        return value

    def allreduce_min(self, value):
        return value

    def allreduce_max(self, value):
        return value

    def bcast(self, value: Any) -> Any:
        return value

    def allgather(self, value: Any) -> list:
        return [value]

    def gather(self, value: Any) -> list | None:
        """Every rank's ``value`` in rank order on the root rank (None elsewhere)."""
        return [value]

    def alltoall(self, values: list) -> list:
        """``values[r]`` goes to rank r; returns what every rank sent to this one, by rank."""
        return list(values)

    def make_halo(self, *args) -> NullHalo:
        return NullHalo()

    def gather_points(self, values: np.ndarray, owned_index: np.ndarray, total: int) -> np.ndarray | None:
        """Assemble a per-point array in global (mothership) order on the root rank.

        values: (n_owned, ...) this rank's owned values; owned_index: (n_owned,) their
        mothership indices; returns (total, ...) on root, None elsewhere."""
        out = np.empty((total,) + values.shape[1:], dtype=values.dtype)
        out[owned_index] = values
        return out

    def barrier(self) -> None:
        pass

    def abort(self, code: int = 1) -> None:
        raise SystemExit(code)


def get_comm():
    """The communicator of this process: MPI when launched with several ranks, else serial."""
    if launched_with_mpi():
        from .mpi import MPIComm

        return MPIComm()
    return SerialComm()
