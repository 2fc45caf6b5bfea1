"""The contact contract: the pairs a search finds, the state a contact model reads, the model and
the run's contact (:class:`peridyn.contact.manager.ContactManager`) as the solvers see it.

Units as in :mod:`peridyn.core.interfaces`.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

import numpy as np

from .fields import FieldSpec
from .params import ModelParams
from .traversal import Backend

#: bits of ``ContactPairs.visits``: point i visits j (j is not in i's reference bond list) ...
VISIT_FROM_POINT = 1
#: ... and j visits i (i is not in j's reference bond list)
VISIT_FROM_PARTNER = 2


@dataclass
class ContactPairs:
    """The pairs that may touch now, as CSR rows over the owned points ``0:num_owned``.

    Row i lists the partners j (indices into the :class:`ContactState` arrays: owned points or
    contact ghosts) whose distance is at most the list's build radius, that lay within the
    search radius at the last search and are not bonded to i both ways. Each row is sorted by
    global id, so a sum over a row does not depend on the decomposition. Every pair appears in
    both points' rows when both are owned (and in each owner's row under MPI).

    ``visits[k]`` tells which of the two one-sided interactions of pair k exist (Peridigm visits
    a pair from each point whose reference bond list does not hold the other):
    ``VISIT_FROM_POINT`` (i -> j) and ``VISIT_FROM_PARTNER`` (j -> i); both are set unless the
    blocks' horizons differ.
    """

    offsets: np.ndarray  #: (num_owned + 1,) int64
    partners: np.ndarray  #: (num_pairs,) int32
    visits: np.ndarray  #: (num_pairs,) uint8

    @property
    def num_pairs(self) -> int:
        return int(self.partners.size)


@dataclass
class ContactState:
    """What a contact model reads: owned points ``0:num_owned``, then contact ghosts (MPI).

    y, v: (n, 3) current positions (L) and velocities (L/T; the mid-step velocity in Verlet);
    volume: (n,) (L^3); horizon: (n,) the constant horizon of each point's block (L);
    block: (n,) int64 block index (deck order); gid: (n,) int64 global ids.
    """

    y: np.ndarray
    v: np.ndarray
    volume: np.ndarray
    horizon: np.ndarray
    block: np.ndarray
    gid: np.ndarray
    num_owned: int
    time: float = 0.0


class ContactModel(ABC):
    """Short-range forces between points that are not bonded, found by a search in the deformed
    configuration (the engine does the search; the model turns pairs into forces).

    ``force`` adds the contact force density (M L^-2 T^-2) on every owned point to ``out``
    (num_owned, 3): a gather over the point's row of :class:`ContactPairs`, rows in parallel. The
    model must not act beyond ``contact_radius`` (pairs are listed up to it plus a margin).
    """

    name: ClassVar[str]
    Params: ClassVar[type[ModelParams]]
    #: where the contact force is computed: "cpu" (see Material.devices)
    devices: ClassVar[frozenset[str]] = frozenset({"cpu"})
    #: the deck key(s) that set the contact stiffness, named in advice on the time step
    stiffness_key: ClassVar[str] = "Spring Constant"

    def __init__(self, params: ModelParams, *, options: dict[str, Any] | None = None) -> None:
        self.params = params
        self.options = options or {}

    @property
    @abstractmethod
    def contact_radius(self) -> float:
        """Distance (L) below which two points interact."""

    def fields(self) -> list[FieldSpec]:
        return []

    def begin_step(self, time: float) -> None:
        """Before each force evaluation of an explicit step, at the step's time (T)."""

    def spring_constant(self) -> float | None:
        """The deck's one-number stiffness (M L^-1 T^-2, as a bulk modulus) if it has one."""
        return None

    def pair_stiffness(self, horizon: np.ndarray) -> np.ndarray | None:
        """Force density per unit partner volume per unit approach (M L^-5 T^-2) of one pair, per
        point of the given horizons, for the stable time step; None if unknown."""
        return None

    @abstractmethod
    def force(self, pairs: ContactPairs, state: ContactState, out: np.ndarray) -> None:
        """Add the contact force density of the owned points to ``out`` (num_owned, 3)."""

    def force_on(self, backend: Backend, pairs: ContactPairs, state: ContactState, out: Any) -> None:
        """``force`` with the pairs, the state and ``out`` where ``backend`` keeps them (a GPU's
        device arrays). A model that lists "gpu" in ``devices`` overrides it with its force as
        a law the backend compiles (a :class:`~peridyn.core.traversal.PointUpdate` over the
        owned points, each gathering its row); the default runs ``force`` (host arrays)."""
        self.force(pairs, state, out)

    def potential_energy(self, pairs: ContactPairs, state: ContactState) -> float | None:
        """Energy (M L^2 T^-2) held by the owned points' visits now, or None if unknown (the
        stability monitor then cannot tell created energy from released contact energy)."""
        return None


class ContactRun(Protocol):
    """The contact of a run (:class:`peridyn.contact.manager.ContactManager`): its schedule of
    pair searches and the forces added to a step."""

    model: ContactModel

    def begin_step(self, step: int) -> None: ...
    def add_force(self, f: np.ndarray, t: float, step: int) -> None: ...
    def potential_energy(self) -> float | None: ...
    def stable_time_step(self) -> float: ...
    def stiffness_ratio(self) -> float: ...
    def diagnosis(self, dt: float) -> str: ...
    def summary(self) -> dict[str, Any]: ...
