"""The boundary-condition contract: what the engine and every solver's step call on a condition.

A condition type is a plugin class (hook ``peridyn_boundary_conditions``). The engine binds it to
a node set (``points``: local indices of the owned points, (k,) int64) and calls the hook of its
``stage``: ``apply_initial`` once at set-up; ``apply_kinematic`` before each step or load step
(prescribed values for the step t_prev -> t); ``apply_force`` after External_Force_Density is
zeroed at each step. The step hooks receive the step's :class:`~peridyn.core.placement.Placement`
(``where``): the arrays the step is running on, on the host or on a GPU. A condition whose hooks
write only through point laws run by ``where.backend`` (``peridyn.kernels.scatter``) works on
every target and declares ``devices = {"cpu", "gpu"}``; one that writes host arrays directly
declares ``{"cpu"}`` (the default), and a GPU run refuses it before it starts.

The engine's implementation with deck expressions is :class:`peridyn.engine.conditions.BoundaryCondition`.
"""
from __future__ import annotations

from abc import ABC
from typing import Any, Callable, ClassVar

import numpy as np
from pydantic import Field

from .params import ModelParams
from .placement import Placement


class ConditionParams(ModelParams):
    """The keys of every ``Boundary Conditions`` entry: its type and the node set it is bound to."""

    type: str = Field(alias="Type", description="condition type (case and spaces do not matter)")
    node_set: str = Field(alias="Node Set", description="a node set defined in Boundary Conditions or by the mesh")


class Condition(ABC):
    """One ``Boundary Conditions`` entry bound to this rank's points."""

    #: the tidied ``Type`` name (``PRESCRIBED_DISPLACEMENT``)
    name: ClassVar[str]
    #: "initial", "kinematic" or "force": which hook the engine calls
    stage: ClassVar[str]
    #: what the condition acts on: "displacement", "velocity", "temperature", "body_force", ...
    target: ClassVar[str]
    #: whether it acts on a scalar field (no Coordinate)
    scalar: ClassVar[bool] = False
    #: where the step hooks run (see the module docstring)
    devices: ClassVar[frozenset[str]] = frozenset({"cpu"})
    #: the entry's keys
    Params: ClassVar[type[ConditionParams]]

    entry_name: str  #: the deck entry's name, for messages and deck paths
    points: np.ndarray  #: (k,) int64 local indices of the node set's owned points (a point may repeat)
    component: int  #: 0, 1 or 2: the component of a vector target

    def apply_initial(self, sim: Any) -> None:  # pragma: no cover - interface
        """Stage "initial": set the condition's values at t = 0 in the simulation's host fields."""
        raise NotImplementedError

    def apply_kinematic(self, where: Placement, t: float, t_prev: float) -> None:  # pragma: no cover - interface
        """Stage "kinematic": the condition for the step t_prev -> t on the step's arrays ``where``
        (nothing to do for an increment when t == t_prev)."""
        raise NotImplementedError

    def apply_force(self, where: Placement, t: float) -> None:  # pragma: no cover - interface
        """Stage "force": add or set the condition's share of External_Force_Density
        (M L^-2 T^-2) at time t on ``where``."""
        raise NotImplementedError

    def prepare(self, sim: Any, members: np.ndarray, region: Any, surface: Callable[[], Any]) -> None:
        """Called once after binding with the node set's points on *all* ranks (mothership
        indices), its region (None for a list of ids or a mesh node set) and a function
        returning the discretization's free surface. Conditions that need the whole node set
        (a total force) override it."""
