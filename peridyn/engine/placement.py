"""The step's arrays where the simulation holds them: host memory, run by the CPU backend
(:class:`~peridyn.core.placement.Placement` on the host)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ..core.placement import StepContact
from ..core.state import SolverState
from ..core.traversal import Backend


class HostPlacement:
    """A :class:`~peridyn.core.placement.Placement` over the simulation's own arrays: nothing is
    copied, forces are the simulation's (MPI halos and overlap included), conditions write
    its fields. The acceleration and increments are those of ``state`` (None: a placement for
    conditions that write fields only, as body forces do)."""

    def __init__(self, sim: Any, state: SolverState | None) -> None:
        self.sim = sim
        self.state = state if state is not None else SolverState()
        self.no_vectors = np.zeros((0, 3))

    @property
    def backend(self) -> Backend:
        return self.sim.backend

    @property
    def fields(self) -> Any:
        return self.sim.fields

    @property
    def acceleration(self) -> np.ndarray | None:
        return self.state.acceleration

    @property
    def delta_u(self) -> np.ndarray | None:
        return self.state.delta_u

    @property
    def delta_p(self) -> np.ndarray | None:
        return self.state.delta_p

    @property
    def contact(self) -> StepContact | None:
        return self.sim.contact

    def resident(self, array: Any) -> Any:
        return array

    def asarray(self, array: Any) -> Any:
        return array

    def zeros(self, shape: int | tuple[int, ...], dtype: Any = float) -> np.ndarray:
        return np.zeros(shape, dtype=dtype)

    def evaluate_forces(self) -> np.ndarray:
        return self.sim.evaluate_forces()

    def load_data(self, t: float) -> None:
        self.sim.load_data(t)

    def upload(self, names: list[str]) -> None:
        pass

    def to_host(self, names: list[str] | None = None) -> None:
        pass

    def advance(self) -> None:
        self.sim.advance()

    def memory_per_point(self) -> float | None:
        return None

