"""What a simulation holds besides its arrays, each named by the members read outside the
engine: the communicator and halo, the deck, the outputs, the data loader, the interface output
and the influence function. The ``Simulation`` protocol (:mod:`peridyn.core.interfaces`) types
its members with these. The run's services a solver is handed (output files, checkpoints,
progress) are :class:`RunServices`."""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from .params import ModelParams
from .placement import Placement
from .state import SolverState


class Communicator(Protocol):
    """Serial (:class:`peridyn.parallel.comm.SerialComm`) or MPI communicator: the collectives
    the engine uses. Reductions take a number or an array and return the same kind."""

    rank: int
    size: int
    is_root: bool

    def allreduce_sum(self, value: Any) -> Any: ...
    def allreduce_min(self, value: Any) -> Any: ...
    def allreduce_max(self, value: Any) -> Any: ...
    def bcast(self, value: Any) -> Any: ...
    def allgather(self, value: Any) -> list: ...
    def gather(self, value: Any) -> list | None: ...
    def alltoall(self, values: list) -> list: ...
    def gather_points(self, values: np.ndarray, owned_index: np.ndarray, total: int) -> np.ndarray | None: ...
    def barrier(self) -> None: ...
    def abort(self, code: int = 1) -> None: ...


class Halo(Protocol):
    """Ghost exchange of per-point arrays (num_local, ...): owners to ghosts (``exchange``,
    split as ``begin``/``end`` to overlap work), ghosts summed into owners (``reverse_sum``)."""

    def exchange(self, array: np.ndarray) -> None: ...
    def begin(self, array: np.ndarray) -> Any: ...
    def end(self, pending: Any) -> None: ...
    def reverse_sum(self, array: np.ndarray) -> None: ...


class DeckEntry(Protocol):
    """A validated deck section naming a model: its class, parameters and place in the deck."""

    cls: type
    params: ModelParams
    path: tuple[str, ...]


class SolverEntry(DeckEntry, Protocol):
    section: str  #: the section's name (``Solver``, ``Solver1``, ...)
    method: str  #: the solver's name (``Verlet``, ``QuasiStatic``, ...)


class DeckView(Protocol):
    """What outside the engine reads of the validated deck (:class:`peridyn.deck.model.Deck`)."""

    file: str | None  #: the deck file (None: a deck built in Python); every message names it
    directory: Path  #: the folder relative file names are read from
    solvers: Sequence[SolverEntry]
    discretization: DeckEntry
    multiphysics: bool
    contact: Any  #: the Contact section (peridyn.deck.model.ContactEntry), None without one
    blocks: Sequence[Any]  #: the Blocks entries (peridyn.deck.model.BlockEntry)


class OutputWriter(Protocol):
    path: Path  #: the output file (final name)
    frequency: int  #: steps between frames
    names: list[str]  #: the variables it writes
    entry: DeckEntry  #: its Output section


class Outputs(Protocol):
    """What the deck's outputs compute (:class:`peridyn.engine.output.OutputManager`): the
    variables they name and the computes behind them. Part of the model: it decides which
    fields exist; the files are the run's (:class:`OutputFiles`)."""

    computes: dict[str, Any]  #: compute name -> Compute, in Peridigm's creation order

    def run_computes(self, names: Sequence[str]) -> None: ...


class OutputFiles(Protocol):
    """The output files of a run (:class:`peridyn.engine.output.OutputFiles`), one writer per
    ``Output`` section, in deck order."""

    writers: list[OutputWriter]

    def write(self, t: float) -> None:
        """Write a frame at time ``t`` (T) in every file whose frequency is due."""

    def due_next(self) -> bool:
        """Whether the next ``write`` writes a frame in some file."""

    def close(self, complete: bool = True) -> None: ...


class RunCheckpoints(Protocol):
    """Checkpoints of a run (:class:`peridyn.engine.restart.Checkpoints`), called by solvers."""

    def begin_section(self, k: int, solver: object) -> bool: ...
    def resume(self, solver: object, dt: float) -> Any: ...
    def after_step(self, step: int, monitor: Any, where: Placement) -> None: ...
    def end_section(self, k: int, solver: object, state: SolverState) -> None: ...
    def install_signals(self) -> None: ...
    def remove_signals(self) -> None: ...


class RunServices(Protocol):
    """What a solver calls of its run besides the model (:class:`peridyn.engine.run_services.RunServices`,
    made by the run session, or by a test or harness for a bare simulation): the output files,
    the checkpoints, and whether to show progress. Handed to :meth:`Solver.run` with the state."""

    files: OutputFiles
    checkpoints: RunCheckpoints | None  #: None without a Restart section or ``--restart``
    progress: bool  #: whether solvers show progress bars

    def write_output(self, t: float) -> None:
        """Write every output whose frequency is due at time ``t`` (T)."""


class DataLoader(Protocol):
    def load(self, t: float) -> None:
        """Set the loaded fields to their values at time t (T)."""


class InterfaceOutput(Protocol):
    def write(self, step: int, time: float) -> None:
        """Write the interfaces' frame ``step`` at ``time``."""


class Influence(Protocol):
    """An influence function omega(zeta, delta): a named kind or a table of an expression."""

    kind: int

    def needs_table(self) -> bool: ...
    def evaluate(self, zeta: np.ndarray, delta: float | np.ndarray) -> np.ndarray: ...
