"""What a solver calls of its run besides the model: the output files, the checkpoints, and
whether it shows progress (the :class:`peridyn.core.services.RunServices` contract).

The run session (:mod:`peridyn.engine.session`) makes one per run and hands it to every
section. A test, benchmark or verify problem that drives a bare simulation makes its own
(:meth:`RunServices.of`), and may pass one whose ``write_output`` reads the fields at every
step as an output would."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ..core.interfaces import Simulation
from ..core.services import OutputFiles as OutputFilesContract
from ..core.services import RunCheckpoints
from .output import OutputFiles


@dataclass
class RunServices:
    files: OutputFilesContract
    checkpoints: RunCheckpoints | None = None
    progress: bool = False

    @classmethod
    def of(cls, sim: Simulation, *, write: bool | None = None, progress: bool = False) -> "RunServices":
        """The output files of ``sim``'s deck in its output folder (``write``: whether they are
        written; default: ``sim.write_files``), no checkpoints."""
        return cls(OutputFiles(sim, write=sim.write_files if write is None else write), None, progress)

    @classmethod
    def reading(cls, each: Callable[[float], None]) -> "RunServices":
        """No file: ``each(t)`` is called wherever a frame could be written (after step 0 and
        after every step, the fields current on the host), as a harness that reads them needs."""
        return cls(_Reader(each), None, False)

    def write_output(self, t: float) -> None:
        self.files.write(t)

    def close(self, complete: bool = True) -> None:
        """Close the output files (``complete``: under their final names)."""
        self.files.close(complete)


class _Reader:
    """Output "files" that call a function instead of writing (:meth:`RunServices.reading`)."""

    def __init__(self, each: Callable[[float], None]) -> None:
        self.writers: list = []
        self.each = each

    def write(self, t: float) -> None:
        self.each(t)

    def due_next(self) -> bool:
        return True

    def close(self, complete: bool = True) -> None:
        pass
