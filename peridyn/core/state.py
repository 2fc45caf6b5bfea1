"""The solver state: what a solver section writes as it runs and hands on to the section after
it, apart from the model (points, blocks, bonds, fields) it acts on.

The engine makes one :class:`SolverState` for a run (or fills it from a checkpoint) and hands it
to each section in deck order: ``state = solver.run(sim, state, run)`` (``run``: the run's services,
:class:`peridyn.core.services.RunServices`). A section starts from the
state the one before it left (the time, and the acceleration of the last dynamic step, which an
implicit section's predictor reads) and returns its own. Nothing else holds it: the outputs,
computes, messages and the Python API read the time and the iteration count of the running
section through ``sim.clock`` (a :class:`Clock`, read-only); conditions fill the increments
through the step's placement, made from the state.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np


class Clock(Protocol):
    """The time the fields are at, as the running solver section left it (read-only)."""

    @property
    def time(self) -> float:
        """The time of the current (NP1) fields (T)."""

    @property
    def time_prev(self) -> float:
        """The time of the step before (T)."""

    @property
    def nonlinear_iterations(self) -> int:
        """Iterations of the implicit steps so far (an output variable)."""


@dataclass
class SolverState:
    """What solvers write and hand on between sections (the engine's checkpoints too)."""

    time: float = 0.0  #: the time the fields are at (T)
    time_prev: float = 0.0  #: the time of the step before (T)
    #: (num_local, 3) acceleration of the last dynamic step (L T^-2), kept across sections; None before one
    acceleration: np.ndarray | None = None
    delta_u: np.ndarray | None = None  #: (num_local, 3) displacement increment of the implicit solvers (L)
    delta_p: np.ndarray | None = None  #: (num_local,) fluid pressure increment of the coupled solver
    nonlinear_iterations: int = 0  #: iterations of the implicit steps so far (an output variable)
    #: what solver sections share by kind (the implicit tangents' sparsity and storage)
    solver_cache: dict[str, Any] = field(default_factory=dict)
