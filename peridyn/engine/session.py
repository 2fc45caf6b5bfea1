"""One run of a deck: the run services around a :class:`~peridyn.engine.simulation.Simulation`.

A :class:`RunSession` owns what a run has besides its model: the output folder and its locks,
the output files, the checkpoints and signal handlers of a deck with a ``Restart`` section (or
``--restart``) and the progress setting (the :class:`~peridyn.engine.run_services.RunServices`
it hands every solver section), the deck's solver sections in order, and how the outputs close
on every way a run ends. ``peridyn
run`` (serially and under MPI) and the Python API (:class:`peridyn.api.Model`) both drive their
runs through it, so the lifecycle is written once:

1. open: the output folder made, the deck loaded and its output names checked, the outputs
   locked (rank 0: the only rank that writes), the simulation set up, its output files made and
   their paths checked, the set-up logged, checkpoints attached (a checkpoint loaded) and
   SIGTERM/SIGINT caught;
2. the solver sections in deck order (:func:`run_sections`; the API steps them itself);
3. close: outputs closed complete (under their final names) when the run ended or stopped as
   unstable on every rank, else incomplete; signals restored; locks released; on success the
   closing summary.

Under MPI every input check of step 1 is collective (:func:`agree_on_input`): when it fails on
any rank, rank 0 reports one message and every rank raises :class:`ReportedInputError`.
"""
from __future__ import annotations

import time as _time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from ..core.errors import InputError, InstabilityError
from ..core.interfaces import Solver
from ..core.logs import say
from ..core.state import SolverState
from ..deck.model import Deck, load_deck
from ..parallel.comm import SerialComm
from .output_paths import check_output_names, check_run_paths, lock_outputs, prepare_output_dir, release_locks
from .run_services import RunServices
from .simulation import Simulation
from .summary import log_setup, log_summary

T = TypeVar("T")


class ReportedInputError(Exception):
    """An input error found on some rank during a collective set-up, already reported by rank 0."""


def agree_on_input(comm, action: Callable[[], T]) -> T:
    """Run ``action`` on every rank; if it raised InputError on any rank, rank 0 reports one
    message and every rank raises :class:`ReportedInputError` (no rank is left waiting in a
    collective). Serially the InputError itself propagates."""
    if comm.size == 1:
        return action()
    result, message = None, None
    try:
        result = action()
    except InputError as exc:
        message = exc.one_line()
    messages = [m for m in comm.allgather(message) if m is not None]
    if messages:
        if comm.rank == 0:
            for line in messages[0].splitlines():
                say("error", line)
        raise ReportedInputError()
    return result  # type: ignore[return-value]


def run_sections(sim: Simulation, state: SolverState | None = None, run: RunServices | None = None) -> SolverState:
    """Run the deck's solver sections in deck order with the run's services ``run`` (None: as
    :func:`run_section`), each from the solver state the one before it left (the first from
    ``state``: a checkpoint's, or a fresh one), skipping those a loaded checkpoint has done
    (``run.checkpoints``) and writing the end-of-section checkpoints; returns the last
    section's state. The caller closes the output files."""
    state = state if state is not None else SolverState()
    run = run if run is not None else RunServices.of(sim)
    checkpoints = run.checkpoints
    for k, (solver, _, _) in enumerate(sim.plan_solvers()):
        if checkpoints is not None and not checkpoints.begin_section(k, solver):
            continue  # done before the checkpoint this run continues from
        state = run_section(sim, solver, state, run)
        if checkpoints is not None:
            checkpoints.end_section(k, solver, state)
    return state


def run_section(sim: Simulation, solver: Solver, state: SolverState | None = None, run: RunServices | None = None) -> SolverState:
    """Run one solver section from ``state`` (None: a fresh one), the simulation's clock reading
    it, with the run's services ``run`` (None: the deck's output files, written as the
    simulation's ``write_files`` says and left open; no checkpoint, no progress: a test or
    harness that closes its files passes its own, :meth:`RunServices.of`); returns the state it
    leaves."""
    state = state if state is not None else SolverState()
    run = run if run is not None else RunServices.of(sim)
    sim.show_clock(state)
    state = solver.run(sim, state, run)
    sim.show_clock(state)
    return state


def keeps_output(exc: BaseException | None, ranks: int) -> bool:
    """Whether a run that ended with ``exc`` (None: it ended) closes its outputs complete: a
    finished run, and an unstable one stopped on every rank at the same step (its frames are
    kept, readable, under their final names); any other error leaves them marked incomplete."""
    if exc is None:
        return True
    return isinstance(exc, InstabilityError) and (exc.collective or ranks == 1)


class RunSession:
    """The run services of one run of ``deck`` (a deck file or a validated ``Deck``).

    ``output_dir``: the folder of the output files (created when missing; default: the current
    folder). ``write_files=False``: nothing is written (no folder, lock, checkpoint or frame).
    ``restart``: a checkpoint to continue from (a path or "latest"; ``--restart``). ``option``:
    how messages name the output folder (``--output-dir``; the API's argument). ``comm``: the
    communicator (default: serial). ``progress``, ``backend``, ``device``: as ``peridyn run``.
    """

    def __init__(self, deck: Deck | str | Path, *, output_dir: str | Path | None = None, comm=None, progress: bool = True,
                 write_files: bool = True, backend: str | None = None, device: str | None = None, restart: str | None = None,
                 option: str = "--output-dir") -> None:
        self.source = deck
        self.comm = comm or SerialComm()
        self.output_dir = Path(output_dir) if output_dir is not None else Path.cwd()
        self.progress = progress
        self.write_files = write_files
        self.backend, self.device = backend, device
        self.restart_from = restart
        self.option = option
        self.deck: Deck | None = deck if isinstance(deck, Deck) else None
        self.sim: Simulation | None = None
        #: the output files, checkpoints and progress every section is handed (made by ``open``)
        self.services: RunServices | None = None
        #: the solver state handed to the first section (a checkpoint's when the run continues one)
        self.state = SolverState()
        self._locks: list = []
        self._closed = False
        self._wall0 = _time.perf_counter()

    # -- 1. open -----------------------------------------------------------------------------------
    def open(self) -> Simulation:
        """Steps 1 of the module docstring; returns the simulation. On any error what was opened
        is closed again (locks released, outputs closed incomplete) before it propagates."""
        comm, rank0 = self.comm, self.comm.rank == 0
        try:
            if self.write_files:
                agree_on_input(comm, lambda: prepare_output_dir(self.output_dir, self.option))
            if self.deck is None:
                self.deck = agree_on_input(comm, lambda: load_deck(self.source))
            deck = self.deck
            if self.write_files:
                agree_on_input(comm, lambda: check_output_names(deck, self.output_dir))
                # a second run of the deck in this folder is refused here
                self._locks = agree_on_input(comm, lambda: lock_outputs(deck, self.output_dir) if rank0 else [])
            self.sim = sim = agree_on_input(comm, lambda: Simulation(
                deck, comm=comm, output_dir=self.output_dir, write_files=self.write_files, backend=self.backend, device=self.device))
            sim.show_clock(self.state)
            # the engine's write_files keeps set-up from writing; the run writes nothing either
            self.services = services = RunServices.of(sim, write=self.write_files, progress=self.progress and rank0)
            if self.write_files:
                agree_on_input(comm, lambda: check_run_paths(sim, services.files) if rank0 else None)
            log_setup(sim)
            if self.write_files and (deck.restart is not None or self.restart_from is not None):
                from .restart import attach

                services.checkpoints = checkpoints = agree_on_input(comm, lambda: attach(sim, services.files, self.restart_from, self.state))
                checkpoints.install_signals()
        except BaseException:
            self.close(complete=False)
            raise
        return sim

    # -- 2. the sections ---------------------------------------------------------------------------
    def run(self) -> None:
        """Open (when not yet), run every solver section, and close: complete on success, as
        :func:`keeps_output` says on an error (which propagates)."""
        sim = self.sim if self.sim is not None else self.open()
        assert self.services is not None  # made by open
        try:
            self.state = run_sections(sim, self.state, self.services)
        except BaseException as exc:
            self.close(complete=keeps_output(exc, self.comm.size))
            raise
        self.close(complete=True, summary=True)

    # -- 3. close ----------------------------------------------------------------------------------
    def close(self, complete: bool = True, *, summary: bool = False) -> None:
        """Close the outputs (``complete``: under their final names), restore the signal handlers
        and release the locks; then, with ``summary``, log the closing summary. Idempotent."""
        if self._closed:
            return
        self._closed = True
        sim, services = self.sim, self.services
        try:
            if services is not None:
                try:
                    services.close(complete=complete)
                finally:
                    if services.checkpoints is not None:
                        services.checkpoints.remove_signals()
        finally:
            release_locks(self._locks)
            self._locks = []
        if summary and sim is not None and services is not None:
            log_summary(sim, services.files, _time.perf_counter() - self._wall0)

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has run."""
        return self._closed
