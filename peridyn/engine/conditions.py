"""Boundary and initial conditions, with Peridigm's semantics (PERIDIGM_SEMANTICS.md §1.4, §6.4, §7).

Each ``Type`` is a plugin class; the engine calls the class's hooks at the places Peridigm does:

* initial conditions once, at set-up, with t = 0, in deck order;
* kinematic conditions (prescribed displacement / temperature) at every step with
  ``(t_cur, t_prev)``; increments do nothing when ``t_cur == t_prev``;
* force contributions (body force): the external force density is zeroed, then every body
  force sets its components at ``t_cur``.

Expressions are evaluated at the points' *reference* coordinates.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from pydantic import Field, field_validator

from ..core.errors import InputError, InstabilityError, raise_collected
from ..core.fields import FieldSpec, Length, Relation
from ..core.conditions import Condition, ConditionParams
from ..core.interfaces import Simulation
from ..core.placement import Placement
from ..kernels import scatter as S
from ..deck.model import tidy

COMPONENT = {"x": 0, "y": 1, "z": 2}


class BCParams(ConditionParams):
    coordinate: str = Field("x", alias="Coordinate", description="component: x, y or z (scalar fields: x or omitted)")
    value: str | float = Field(alias="Value", description="expression in x, y, z, t (reference coordinates, time)")

    @field_validator("value", mode="before")
    @classmethod
    def _int_value(cls, v):
        # Peridigm rejects an int-typed Value; accepting it as the number it is costs nothing
        if isinstance(v, int) and not isinstance(v, bool):
            return float(v)
        return v

    @field_validator("coordinate")
    @classmethod
    def _coordinate(cls, v: str) -> str:
        c = v.strip().lower()
        if c not in COMPONENT:
            raise ValueError(f"Coordinate must be x, y or z (got {v!r})")
        return c

    @property
    def text(self) -> str:
        """The Value as expression text (a number keeps its full precision; see
        docs/peridigm-differences.md)."""
        return repr(self.value) if isinstance(self.value, float) else self.value


class BoundaryCondition(Condition):
    """A condition whose value is a deck expression of (x, y, z, t) at the node set's reference
    coordinates: the engine's implementation of :class:`~peridyn.core.conditions.Condition`.
    Subclasses set ``stage`` (and ``devices``) and override the hook of that stage."""

    Params: ClassVar[type[BCParams]] = BCParams

    def __init__(self, params: BCParams, *, entry_name: str = "") -> None:
        from ..deck.expressions import compile_expression

        self.params = params
        self.entry_name = entry_name
        # rnd() draws from this condition's own stream (two conditions' rnd() differ)
        self.expr = compile_expression(params.text, ("x", "y", "z", "t"), stream=f"Boundary Conditions > {entry_name}")
        self.component = COMPONENT[params.coordinate]
        self.points = np.zeros(0, dtype=np.int64)
        self._x = np.zeros((0, 3))
        self._gid: np.ndarray | None = None

    @classmethod
    def check(cls, params: BCParams) -> list[str]:
        """Problems beyond the schema (one message each)."""
        from ..deck.expressions import ExpressionError, compile_expression, constant_not_finite

        problems = []
        try:
            problem = constant_not_finite(compile_expression(params.text, ("x", "y", "z", "t")))
        except ExpressionError as exc:
            problems.append(f"Value: {exc}")
        else:
            if problem:
                problems.append(f"Value: {problem}; give a finite value")
        if cls.scalar and params.coordinate != "x":
            problems.append(f"{cls.name} acts on a scalar field; omit Coordinate or use 'x'")
        return problems

    def bind(self, points: np.ndarray, x: np.ndarray, gid: np.ndarray | None = None) -> None:
        """Attach the local point indices of the node set, their reference coordinates and
        their global ids (what ``rnd()`` hashes: the same values on any number of ranks)."""
        self.points = points
        self._x = x[points]
        self._gid = None if gid is None else np.asarray(gid)[points]

    def evaluate(self, t: float) -> np.ndarray:
        """The expression at the node set's reference coordinates, time ``t`` (shape (k,)).

        A non-finite value stops the run before it reaches a field: an input error for an
        initial condition, an instability (exit 3) naming the condition, point and time later."""
        x = self._x
        with np.errstate(all="ignore"):
            value = self.expr(self._gid, x=x[:, 0], y=x[:, 1], z=x[:, 2], t=t)
        value = np.broadcast_to(np.asarray(value, dtype=float), (len(self.points),))
        if not np.all(np.isfinite(value)):
            self._non_finite(value, t)
        return value

    def _non_finite(self, value: np.ndarray, t: float) -> None:
        k = int(np.argmax(~np.isfinite(value)))
        where = tuple(float(c) for c in self._x[k])
        text = (f"Boundary Conditions > {self.entry_name}: the value {self.params.text!r} is {float(value[k])!r} "
                f"at the point {where} at t = {t:.6g}")
        if self.stage == "initial":
            raise InputError(text.split(": ", 1)[1], path=("Boundary Conditions", self.entry_name),
                             fix="give a value that is finite at every point of the node set")
        raise InstabilityError(f"{text}; the run stops before using it (no output frame holds it)", collective=False)


class InitialVelocity(BoundaryCondition):
    name = "INITIAL_VELOCITY"
    stage = "initial"
    target = "velocity"

    def apply_initial(self, sim: "Simulation") -> None:
        sim.fields["Velocity"][self.points, self.component] = self.evaluate(0.0)


class InitialDisplacement(BoundaryCondition):
    name = "INITIAL_DISPLACEMENT"
    stage = "initial"
    target = "displacement"

    def apply_initial(self, sim: "Simulation") -> None:
        u = sim.fields["Displacement"]
        u[self.points, self.component] = self.evaluate(0.0)
        y = sim.fields["Coordinates"]
        x = sim.fields["Model_Coordinates"]
        y[self.points, self.component] = x[self.points, self.component] + u[self.points, self.component]


class InitialTemperature(BoundaryCondition):
    """Sets the temperature once; it does not change the temperature change that drives
    thermal expansion (Peridigm's semantics)."""

    name = "INITIAL_TEMPERATURE"
    stage = "initial"
    target = "temperature"
    scalar = True

    def apply_initial(self, sim: "Simulation") -> None:
        sim.fields["Temperature"][self.points] = self.evaluate(0.0)


class PrescribedDisplacement(BoundaryCondition):
    """Displacement prescribed through the velocity: on its components,
    ``v = (f(t) - f(t_prev)) / (t - t_prev)`` and the increment ``du = f(t) - f(t_prev)``; when
    the two values are exactly equal (a time-independent value) the previous value is replaced
    by the current displacement, so the value becomes an absolute target."""

    name = "PRESCRIBED_DISPLACEMENT"
    stage = "kinematic"
    target = "displacement"
    devices = frozenset({"cpu", "gpu"})

    def apply_kinematic(self, where: Placement, t: float, t_prev: float) -> None:
        if t == t_prev:
            return
        f = where.fields
        du = where.delta_u
        S.scatter(where, S.PRESCRIBED_DISPLACEMENT, len(self.points),
                  (where.resident(self.points), self.component, where.asarray(self.evaluate(t)), where.asarray(self.evaluate(t_prev)),
                   1.0 / (t - t_prev), f["Displacement"], f["Velocity"], du if du is not None else where.no_vectors))


class PrescribedTemperature(BoundaryCondition):
    """Sets T = f(x, t) at every application and, when time advanced, the temperature change
    dT = f(x, t) - f(x, 0) that drives thermal expansion."""

    name = "PRESCRIBED_TEMPERATURE"
    stage = "kinematic"
    target = "temperature"
    scalar = True
    devices = frozenset({"cpu", "gpu"})

    def apply_kinematic(self, where: Placement, t: float, t_prev: float) -> None:
        value = where.asarray(self.evaluate(t))
        points = where.resident(self.points)
        S.scatter(where, S.SET_SCALAR, len(self.points), (points, value, where.fields["Temperature"]))
        if t != t_prev:
            if self._initial is None:
                self._initial = self.evaluate(0.0)
            S.scatter(where, S.SET_DIFFERENCE, len(self.points),
                      (points, value, where.resident(self._initial), where.fields["Temperature_Change"]))

    _initial: np.ndarray | None = None  #: the value at t = 0 (k,), computed once


class BodyForce(BoundaryCondition):
    """External force density (force per unit volume) on a node set."""

    name = "BODY_FORCE"
    stage = "force"
    target = "body_force"
    devices = frozenset({"cpu", "gpu"})

    def apply_force(self, where: Placement, t: float) -> None:
        S.scatter(where, S.SET_COMPONENT, len(self.points),
                  (where.resident(self.points), self.component, where.asarray(self.evaluate(t)), where.fields["External_Force_Density"]))


class PrescribedFluidPressureU(BoundaryCondition):
    """Multiphysics (PERIDIGM_MODELS.md §7): the fluid pressure increment of a load step,
    dp = f(t) - f(t_prev), and its rate p_V = dp / (t - t_prev), on the node set (an increment
    condition without the constant-value rule of Prescribed Displacement: a constant value gives
    dp = 0). Its dofs are prescribed in the coupled QuasiStatic solve."""

    name = "PRESCRIBED_FLUID_PRESSURE_U"
    stage = "kinematic"
    target = "fluid_pressure"
    scalar = True

    def apply_kinematic(self, where: Placement, t: float, t_prev: float) -> None:
        if t == t_prev or "Fluid_Pressure_V" not in where.fields:
            return
        dp = self.evaluate(t) - self.evaluate(t_prev)
        where.fields["Fluid_Pressure_V"][self.points] = dp * (1.0 / (t - t_prev))
        if where.delta_p is not None:
            where.delta_p[self.points] = dp


class InitialFluidPressureU(BoundaryCondition):
    """Multiphysics: sets the accumulated fluid pressure p_U once, and p_Y = p_U."""

    name = "INITIAL_FLUID_PRESSURE_U"
    stage = "initial"
    target = "fluid_pressure"
    scalar = True

    def apply_initial(self, sim: "Simulation") -> None:
        if "Fluid_Pressure_U" not in sim.fields:
            raise InputError("'Initial Fluid Pressure U' needs a Multiphysics deck (Multiphysics: 1 and Multiphysics materials)",
                             path=("Boundary Conditions", self.entry_name), fix="remove the condition or enable Multiphysics")
        sim.fields["Fluid_Pressure_U"][self.points] = self.evaluate(0.0)
        sim.fields["Fluid_Pressure_Y"][self.points] = sim.fields["Fluid_Pressure_U"][self.points]


BUILTIN_CONDITIONS = (InitialVelocity, InitialDisplacement, InitialTemperature, PrescribedDisplacement, PrescribedTemperature, BodyForce,
                      PrescribedFluidPressureU, InitialFluidPressureU)


# ------------------------------------------------------------------------------------------------
# Binding the deck's node sets and conditions to a simulation
# ------------------------------------------------------------------------------------------------
@dataclass
class BoundConditions:
    """The deck's node sets and boundary conditions bound to this rank's points."""

    node_sets: dict[str, np.ndarray]  #: tidied name -> mothership indices (duplicates kept)
    conditions: list[Condition]  #: every condition, deck order
    kinematic: list[Condition]  #: conditions applied before a step (prescribed displacement, temperature, pressure)
    force_conditions: list[Condition]  #: body forces
    prescribed_points: np.ndarray  #: (k,) local points with a prescribed displacement component
    prescribed_dofs: np.ndarray  #: (num_local, 3) bool, True on displacement components a kinematic condition prescribes


def declare_condition_fields(fields: Any, cond: Any) -> None:
    """Declare the fields condition ``cond`` writes: Temperature (and, prescribed, its change),
    or External_Force_Density."""
    if cond.target == "temperature":
        fields.declare(FieldSpec("Temperature", Relation.NODE))
        if cond.stage == "kinematic":
            fields.declare(FieldSpec("Temperature_Change", Relation.NODE, halo=True))
    if cond.target == "body_force":
        fields.declare(FieldSpec("External_Force_Density", Relation.NODE, Length.VECTOR))


def create_conditions(sim: Any) -> BoundConditions:
    """Resolve the deck's node sets (mothership indices) and bind its boundary conditions to
    this rank's points; declares the fields the conditions need."""
    deck = sim.deck
    from ..io.nodesets import parse_node_set_value

    disc = sim.discretization
    gid_order = np.argsort(disc.gid, kind="stable")
    sorted_gid = disc.gid[gid_order]
    node_sets: dict[str, np.ndarray] = {}
    errors: list[InputError] = []
    cache: dict[str, Any] = {}
    failed: set[str] = set()  # node sets whose error is reported already

    def surface():
        if "surface" not in cache:
            from ..geometry.surface import free_surface

            cache["surface"] = free_surface(disc.x, disc.volume)
        return cache["surface"]

    for name, entry in deck.node_sets.items():
        if not isinstance(entry.value, str):  # a region: evaluated on every point's reference coordinates
            from ..geometry.regions import region_mask

            try:
                mask = region_mask(entry.value, disc.x, disc.volume, surface=surface, path=entry.path, file=deck.file)
            except InputError as exc:
                errors.append(exc)
                failed.add(name)
                continue
            node_sets[name] = np.flatnonzero(mask).astype(np.int64)
            continue
        try:
            ids = parse_node_set_value(entry.value, deck_dir=deck.directory, path=entry.path, deck_file=deck.file)
        except InputError as exc:
            errors.append(exc)
            continue
        wanted = np.asarray(ids, dtype=np.int64) - 1
        where = np.clip(np.searchsorted(sorted_gid, wanted), 0, max(len(sorted_gid) - 1, 0))
        found = (sorted_gid[where] == wanted) if len(sorted_gid) else np.zeros(len(wanted), bool)
        missing = [int(i) for i in np.asarray(ids)[~found]]
        if missing:
            errors.append(
                InputError(
                    f"node set lists point(s) {', '.join(map(str, missing[:5]))}{'...' if len(missing) > 5 else ''} that do not exist",
                    file=deck.file,
                    path=entry.path,
                    fix=f"point numbers are 1-based global ids ({sim.num_global} points)",
                )
            )
            continue
        node_sets[name] = gid_order[where].astype(np.int64)
    for raw_name, members in disc.node_sets.items():
        name = tidy(raw_name)
        if name in node_sets:
            errors.append(InputError(f"node set {raw_name!r} is defined both in the deck and in the mesh", file=deck.file, path=("Boundary Conditions",), fix="rename the deck's node set"))
            continue
        node_sets[name] = np.asarray(members, dtype=np.int64)
    if rank_deficient_node_set(sim):
        node_sets.setdefault("RANK_DEFICIENT_NODES", np.zeros(0, dtype=np.int64))
    conditions = []
    for bc in deck.boundary_conditions:
        ns = tidy(bc.params.node_set)
        if ns in failed:
            continue
        if ns not in node_sets:
            errors.append(
                InputError(
                    f"unknown node set {bc.params.node_set!r}",
                    file=deck.file,
                    path=bc.path + ("Node Set",),
                    fix=f"node sets: {', '.join(sorted(node_sets)) or 'none'}",
                )
            )
            continue
        if node_sets[ns].size == 0:
            errors.append(InputError(f"node set {bc.params.node_set!r} is empty: the condition would act on no point",
                                     file=deck.file, path=bc.path + ("Node Set",), fix="give the node set at least one point"))
            continue
        obj = bc.cls(bc.params, entry_name=bc.name)
        members = sim.local_of_mothership[node_sets[ns]]
        members = members[(members >= 0) & (members < sim.num_owned)]  # this rank's points
        obj.bind(np.unique(members) if obj.stage != "initial" else members, sim.discretization.x[sim.mothership_of_local], sim.gid)
        entry = deck.node_sets.get(ns)
        try:
            obj.prepare(sim, node_sets[ns], None if entry is None or isinstance(entry.value, str) else entry.value, surface)
        except InputError as exc:
            errors.append(exc)
            continue
        conditions.append(obj)
    raise_collected(errors)
    for obj in conditions:
        declare_condition_fields(sim.fields, obj)
    kinematic = [c for c in conditions if c.stage == "kinematic"]
    prescribed_dofs = np.zeros((sim.num_local, 3), dtype=bool)
    for c in kinematic:
        if c.target == "displacement":
            prescribed_dofs[c.points, c.component] = True
    return BoundConditions(
        node_sets=node_sets,
        conditions=conditions,
        kinematic=kinematic,
        force_conditions=[c for c in conditions if c.stage == "force"],
        prescribed_points=np.unique(np.concatenate([c.points for c in kinematic if c.target == "displacement"] or [np.zeros(0, np.int64)])),
        prescribed_dofs=prescribed_dofs,
    )

def rank_deficient_node_set(sim: Any) -> bool:
    """Peridigm creates an empty RANK_DEFICIENT_NODES node set (and writes it to Exodus) when
    the run allocates a full tangent and a block has a damage model (PERIDIGM_SEMANTICS.md
    §1.4). Solvers say what they need through ``tangent_request(params)``: "full" or
    "block diagonal" when the deck asks for one, "default" (full unless another solver asks
    for a block-diagonal one), None for no tangent."""
    if not any(entry.damage_model is not None for entry in sim.deck.blocks):
        return False
    requests = [e.cls.tangent_request(e.params) for e in sim.deck.solvers]
    return "full" in requests or ("default" in requests and "block diagonal" not in requests)

