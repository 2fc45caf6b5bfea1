"""Where a time step's arrays live: the contract between one explicit step, written once, and the
targets it runs on.

A solver's step is a sequence of loop laws (``peridyn.core.traversal``) and calls on a
:class:`Placement`. The placement owns the arrays (host memory for the CPU backends, device
memory for a GPU's) and the backend that runs laws over them; what differs between targets is
only where the arrays are and how a loop is launched. The model (points, blocks, bonds, node sets)
stays the simulation's; the placement holds the copies a step reads and writes, and brings them
back to the host (``to_host``) where the run's services need them: output frames, checkpoints,
an instability's diagnosis, the Python API.

Shapes: point vectors (num_local, 3), point scalars (num_local,); units as the fields'.
"""
from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

from .state import SolverState
from .traversal import Backend


@runtime_checkable
class StepContact(Protocol):
    """What an explicit step calls of the run's contact (``ContactManager`` on the host, its
    device twin on a GPU)."""

    def begin_step(self, step: int) -> None:
        """Start of step ``step`` (1, 2, ...): a search when one is due."""

    def add_force(self, f: Any, t: float, step: int) -> None:
        """Add the contact force density at time ``t`` to ``f`` (num_owned, 3)."""

    def summary(self) -> dict[str, Any]:
        """The contact's statistics for the run summary."""


@runtime_checkable
class Placement(Protocol):
    """The arrays of an explicit step and the backend that runs laws over them.

    ``fields`` has the access of a :class:`~peridyn.core.fields.FieldStore` (``[name]`` the
    current (NP1) array, ``n(name)`` the previous state, ``name in fields``) with arrays on
    ``backend``. ``acceleration`` (num_local, 3) and the increments ``delta_u`` (num_local, 3) /
    ``delta_p`` (num_local,) that implicit solvers ask conditions to fill (None: not asked) are
    on the backend too: those of ``state``, the solver state the placement was made from, whose
    host arrays ``to_host`` makes current.
    """

    backend: Backend
    fields: Any
    state: SolverState
    acceleration: Any
    #: a (0, 3) float array on the backend: "no such vector field" in a law's arguments
    no_vectors: Any

    @property
    def delta_u(self) -> Any | None:
        """Displacement increments a prescribed displacement writes (None: none asked for)."""

    @property
    def delta_p(self) -> Any | None:
        """Fluid pressure increments a prescribed pressure writes (None: none asked for)."""

    @property
    def contact(self) -> StepContact | None:
        """The run's contact where the step's arrays are, or None without contact."""

    def resident(self, array: Any) -> Any:
        """A constant host array (a node set's points) where the kernels read it, copied once."""

    def asarray(self, array: Any) -> Any:
        """A host array computed this step (a condition's values) where the kernels read it."""

    def zeros(self, shape: int | tuple[int, ...], dtype: Any = float) -> Any:
        """A zero-filled array on the backend."""

    def evaluate_forces(self) -> Any:
        """Damage, precompute and the internal force density (num_owned, 3) at the current
        positions (M L^-2 T^-2), into ``fields["Force_Density"]``, which it returns."""

    def load_data(self, t: float) -> None:
        """The data loader's field at time t, on these arrays (nothing without a loader)."""

    def upload(self, names: list[str]) -> None:
        """Host fields ``names`` written outside the step (the data loader, the Python API) copied
        to these arrays (nothing to do on the host)."""

    def to_host(self, names: list[str] | None = None) -> None:
        """The simulation's host arrays made current: the fields ``names``, or with None every
        field, the acceleration and the contact state (nothing to do on the host)."""

    def advance(self) -> None:
        """End of a completed step: N and NP1 of two-step fields swapped (host and here)."""

    def memory_per_point(self) -> float | None:
        """Bytes this placement holds per owned point beyond the host model (None on the host)."""
