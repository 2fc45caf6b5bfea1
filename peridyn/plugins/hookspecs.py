"""Hook specifications: one hook per extension point. Each docstring is the contract.

Every hook returns a list of ``(deck name, "module:Class")`` pairs. A class is imported only
when a deck names it (or when ``peridyn plugins`` / ``peridyn schema`` lists everything), so a
scene imports only what it uses. A third-party package provides hooks through the entry-point
group ``peridyn``::

    [project.entry-points.peridyn]
    my_models = "my_models.plugin"      # a module with @hookimpl functions

Two plugins claiming one deck name (within one kind) is an error naming both.
"""
from __future__ import annotations

import pluggy

hookspec = pluggy.HookspecMarker("peridyn")
hookimpl = pluggy.HookimplMarker("peridyn")

ModelList = list[tuple[str, str]]


@hookspec
def peridyn_materials() -> ModelList:
    """Materials: deck name (``Material Model`` value, e.g. ``"Elastic"``) and a
    ``"module:Class"`` path to a :class:`peridyn.core.interfaces.Material` subclass."""


@hookspec
def peridyn_damage_models() -> ModelList:
    """Damage models: deck name (``Damage Model`` value, e.g. ``"Critical Stretch"``) and a
    path to a :class:`peridyn.core.interfaces.DamageModel` subclass."""


@hookspec
def peridyn_contact_models() -> ModelList:
    """Contact models: deck name (e.g. ``"Short Range Force"``) and a path to a
    :class:`peridyn.core.interfaces.ContactModel` subclass."""


@hookspec
def peridyn_computes() -> ModelList:
    """Computes: the output variable or ``Compute Class`` name (e.g. ``"Kinetic_Energy"``,
    ``"Block_Data"``) and a path to a :class:`peridyn.core.interfaces.Compute` subclass."""


@hookspec
def peridyn_solvers() -> ModelList:
    """Solvers: the method sublist name inside a solver section (e.g. ``"Verlet"``) and a path
    to a :class:`peridyn.core.interfaces.Solver` subclass."""


@hookspec
def peridyn_discretizations() -> ModelList:
    """Discretizations: the ``Discretization > Type`` value (e.g. ``"Exodus"``) and a path to a
    :class:`peridyn.core.discretization.DiscretizationReader` subclass."""


@hookspec
def peridyn_boundary_conditions() -> ModelList:
    """Boundary and initial condition types: the ``Type`` value in its tidied form (upper
    case, spaces as ``_``, e.g. ``"PRESCRIBED_DISPLACEMENT"``) and a path to a
    :class:`peridyn.engine.conditions.BoundaryCondition` subclass (the contract: :class:`peridyn.core.conditions.Condition`)."""


@hookspec
def peridyn_backends() -> ModelList:
    """Backends: the name given to ``peridyn run --backend`` (or ``PERIDYN_BACKEND``, e.g.
    ``"numba"``) and a path to a :class:`peridyn.core.traversal.Backend` subclass, which
    compiles the models' loop laws for its target and says where arrays live."""
