"""``Surface Traction``: a traction or a pressure on a surface layer, applied as a body-force
density on the layer's points with the total force exact (docs/regions.md).

* ``Traction: [tx, ty, tz]`` (force per area): every point of the node set gets the same
  density ``b = T A / V_set`` (force per volume), V_set the node set's volume over all ranks and
  A the loaded area: ``Area`` when given, otherwise ``V_set / Thickness`` (exact for a flat face
  of a lattice when the thickness is a whole number of spacings: the layer is that many lattice
  planes). So ``sum_i b_i V_i = T A`` to round-off.
* ``Pressure: p``: the pressure pushes on the free faces of the body's cells
  (:mod:`peridyn.geometry.surface`): a surface point s carries ``F_s = -p sum_k h_s^2 e_k`` over
  its free faces, spread over the node set's points whose nearest surface point is s in
  proportion to their volume. The resultant is that of the pressure on the union of the cells:
  zero on a closed lattice surface (to round-off) and ``p`` times the projected area otherwise.

Both are multiplied by ``Scale``, an expression in t (the ramp). The condition adds its density
to ``External_Force_Density`` after that field is zeroed each step, so tractions on overlapping
node sets add up (a ``Body Force`` on the same points, later in the deck, sets its component).
"""
from __future__ import annotations

import logging
import math
from typing import Annotated, Any, Callable

import numpy as np
from pydantic import Field, model_validator

from ..core.errors import InputError, InstabilityError
from ..core.conditions import ConditionParams
from ..deck.regions import layer_thicknesses
from ..kernels import scatter as S
from .conditions import BoundaryCondition

__all__ = ["SurfaceTraction", "TractionParams"]

log = logging.getLogger(__name__)


class TractionParams(ConditionParams):
    node_set: str = Field(alias="Node Set", description="the loaded points: a surface layer (or a region intersected with one)")
    traction: Annotated[list[float], Field(min_length=3, max_length=3)] | None = Field(
        None, alias="Traction", description="traction vector [tx, ty, tz] on the loaded area, a force per area (M L^-1 T^-2)")
    pressure: float | None = Field(None, alias="Pressure", description="pressure on the free surface, pushing inward (M L^-1 T^-2)")
    scale: str | float = Field("1", alias="Scale", description="ramp: expression in t multiplying the load (dimensionless)")
    thickness: float | None = Field(
        None, alias="Thickness", gt=0.0,
        description="thickness of the loaded layer (L), for a Traction without Area; default: the Surface Layer of the node set's region")
    area: float | None = Field(None, alias="Area", gt=0.0, description="loaded area of a Traction (L^2); default: node-set volume / Thickness")

    @model_validator(mode="after")
    def _one_load(self):
        if (self.traction is None) == (self.pressure is None):
            raise ValueError("give either Traction: [tx, ty, tz] or Pressure: p")
        if self.pressure is not None and (self.area is not None or self.thickness is not None):
            raise ValueError("Area and Thickness apply to a Traction; a Pressure acts on the free faces of the layer's surface points")
        return self

    @property
    def scale_text(self) -> str:
        return repr(self.scale) if isinstance(self.scale, float) else self.scale


class SurfaceTraction(BoundaryCondition):
    """A traction vector or a pressure on a surface layer (module docstring)."""

    name = "SURFACE_TRACTION"
    Params = TractionParams  # type: ignore[assignment]
    stage = "force"
    target = "body_force"
    devices = frozenset({"cpu", "gpu"})
    _once: tuple[np.ndarray, np.ndarray] | None = None  #: (distinct points, their force densities at Scale 1)

    def __init__(self, params: TractionParams, *, entry_name: str = "") -> None:
        # not BoundaryCondition.__init__: there is no Value or Coordinate, the Scale is a function of t alone
        from ..deck.expressions import compile_expression

        self.params = params
        self.entry_name = entry_name
        self.expr = compile_expression(params.scale_text, ("t",), stream=f"Boundary Conditions > {entry_name}")
        self.component = 0
        self.points = np.zeros(0, dtype=np.int64)
        self._x = np.zeros((0, 3))
        self._gid = None
        self.density = np.zeros((0, 3))  #: (k, 3) force density of each owned point of the node set at Scale 1 (M L^-2 T^-2)
        self.total = np.zeros(3)  #: total force at Scale 1, over all ranks (M L T^-2)

    @classmethod
    def check(cls, params: TractionParams) -> list[str]:  # type: ignore[override]
        from ..deck.expressions import ExpressionError, compile_expression, constant_not_finite

        try:
            problem = constant_not_finite(compile_expression(params.scale_text, ("t",)))
        except ExpressionError as exc:
            return [f"Scale: {exc} (an expression in t)"]
        return [f"Scale: {problem}; give a finite value"] if problem else []

    def prepare(self, sim: Any, members: np.ndarray, region: Any, surface: Callable[[], Any]) -> None:
        self._once = None
        members = np.unique(members)
        volume = np.asarray(sim.discretization.volume, dtype=float)
        where = ("Boundary Conditions", self.entry_name)
        mine = np.searchsorted(members, sim.mothership_of_local[self.points])  # each owned point's place in members
        p = self.params
        if p.traction is not None:
            t = p.thickness
            if t is None and p.area is None:
                found = layer_thicknesses(region) if region is not None else set()
                if len(found) != 1:
                    raise InputError(
                        f"the node set {p.node_set!r} " + ("has several Surface Layer thicknesses" if found else "is not a Surface Layer region")
                        + ": the loaded area (node-set volume / thickness) is unknown", path=where,
                        fix="give Thickness (L) or Area (L^2) in the condition, or define the node set with a Surface Layer")
                t = found.pop()
            v_set = float(volume[members].sum())
            area = p.area if p.area is not None else v_set / t
            self.total = np.asarray(p.traction, dtype=float) * area
            self.density = np.broadcast_to(self.total / v_set, (len(self.points), 3)).copy()
            log.info("%s: traction on %d points, loaded area %.6g, total force %s", self.entry_name, len(members), area, self.total)
            return
        surf = surface()
        owner = surf.nearest[members]
        if np.any(owner < 0):
            raise InputError(f"the node set {p.node_set!r} has no free surface to press on", path=where,
                             fix="a pressure needs a body with a free surface")
        unit_faces = surf.face_vectors()
        faces = -p.pressure * unit_faces
        owners, inverse = np.unique(owner, return_inverse=True)
        weight = np.bincount(inverse, weights=volume[members])  # volume of the node set's points each surface point loads
        force = faces[owners]
        if not np.any(unit_faces[owners]):  # judged on the faces, not the force: a pressure of 0 is a legal load
            raise InputError(f"the points of node set {p.node_set!r} are nearest to no free face a pressure could push on "
                             "(or their faces cancel)", path=where, fix="use a node set on the body's surface, e.g. a Surface Layer")
        self.total = force.sum(axis=0)
        per_member = force[inverse] / weight[inverse, None]
        self.density = per_member[mine]
        log.info("%s: pressure on %d points (%d surface points), resultant %s", self.entry_name, len(members), len(owners), self.total)

    def scale(self, t: float) -> float:
        """The ramp at time ``t``; a non-finite value stops the run naming the condition."""
        with np.errstate(all="ignore"):
            value = float(self.expr(t=t))
        if not math.isfinite(value):
            text = f"Boundary Conditions > {self.entry_name}: the Scale {self.params.scale_text!r} is {value!r} at t = {t:.6g}"
            raise InstabilityError(f"{text}; the run stops before using it (no output frame holds it)", collective=False)
        return value

    def apply_force(self, where: Any, t: float) -> None:
        if len(self.points):
            # each point once (a node set may list one twice; the force is the point's, not the entry's)
            if self._once is None:
                points, rows = np.unique(self.points, return_index=True)
                self._once = points, np.ascontiguousarray(self.density[rows])
            points, density = self._once
            S.scatter(where, S.ADD_SCALED, len(points), (where.resident(points), self.scale(t), where.resident(density),
                                                         where.fields["External_Force_Density"]))
