"""The solver state: what the solver sections write as they run and hand on to the sections
after them and to the output, apart from the model (points, blocks, bonds, fields) they act on.

A section starts from the state the section before it left (the time, and the acceleration of
the last dynamic step, which an implicit section's predictor reads), and leaves its own. The
output reads the time and the iteration count; rate-form models read the step.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class SolverState:
    """What solvers write (the engine's set-up and the checkpoints too; nothing else does)."""

    time: float = 0.0  #: the time the fields are at (T)
    time_prev: float = 0.0  #: the time of the step before (T)
    time_step: float = 0.0  #: the step of the solver running (T)
    #: (num_local, 3) acceleration of the last dynamic step (L T^-2), kept across sections; None before one
    acceleration: np.ndarray | None = None
    delta_u: np.ndarray | None = None  #: (num_local, 3) displacement increment of the implicit solvers (L)
    delta_p: np.ndarray | None = None  #: (num_local,) fluid pressure increment of the coupled solver
    nonlinear_iterations: int = 0  #: iterations of the last implicit step (an output variable)
    #: what solver sections share by kind (the implicit tangents' sparsity and storage)
    solver_cache: dict[str, Any] = field(default_factory=dict)
