"""Node sets by geometry: the deck's region descriptions (docs/regions.md).

A ``Boundary Conditions`` entry whose name contains ``Node Set`` may be a mapping with exactly
one key naming a region instead of a list of point numbers::

    Right End Node Set:
      Intersection:                      # named parts (a Teuchos deck has no lists of lists)
        Layer: {Surface Layer: {Thickness: 0.002}}
        End: {Half Space: {Point: [0.1, 0, 0], Normal: [1, 0, 0]}}

This module holds the pydantic models that validate such a mapping (so bad input is one
deck-path-named error at load time); :mod:`peridyn.geometry.regions` evaluates them on the
points' reference coordinates. Lengths are in the deck's length unit L.
"""
from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field, field_validator, model_validator

from ..core.params import ModelParams

__all__ = ["REGION_KEYS", "BoxSpec", "CylinderSpec", "HalfSpaceSpec", "RegionSpec", "SphereSpec", "SurfaceLayerSpec",
           "axis_vector", "layer_thicknesses"]

#: [x, y, z]: a list of exactly three numbers
Vector = Annotated[list[float], Field(min_length=3, max_length=3)]
AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def _nonzero(v: Vector, what: str) -> Vector:
    if math.hypot(*v) == 0.0:
        raise ValueError(f"{what} must not be the zero vector")
    return v


def axis_vector(axis: str | list[float]) -> tuple[float, float, float]:
    """An axis given as 'x', 'y', 'z' or a vector, as a vector (not normalized)."""
    return AXES[axis] if isinstance(axis, str) else (axis[0], axis[1], axis[2])


class BoxSpec(ModelParams):
    """Axis-aligned box, faces included."""

    min: Vector = Field(alias="Min", description="lowest corner [x, y, z] (L)")
    max: Vector = Field(alias="Max", description="highest corner [x, y, z] (L); not below Min on any axis")

    @model_validator(mode="after")
    def _ordered(self):
        bad = [c for c, lo, hi in zip("xyz", self.min, self.max) if lo > hi]
        if bad:
            raise ValueError(f"Min is above Max along {', '.join(bad)}: give Min <= Max on every axis")
        return self


class SphereSpec(ModelParams):
    """Ball, its surface included."""

    center: Vector = Field(alias="Center", description="centre [x, y, z] (L)")
    radius: float = Field(alias="Radius", gt=0.0, description="radius (L)")


class CylinderSpec(ModelParams):
    """Circular cylinder (or tube) about an axis through ``Center``; unbounded along the axis
    unless ``Length`` or ``Min``/``Max`` bound it."""

    center: Vector = Field(alias="Center", description="a point on the axis [x, y, z] (L); the middle when Length is given")
    axis: Literal["x", "y", "z"] | Vector = Field("z", alias="Axis", description="axis direction: x, y, z or a vector [ax, ay, az]")
    radius: float = Field(alias="Radius", gt=0.0, description="outer radius (L)")
    inner_radius: float = Field(0.0, alias="Inner Radius", ge=0.0, description="inner radius of a tube (L); 0 for a full cylinder")
    length: float | None = Field(None, alias="Length", gt=0.0, description="length along the axis, centred on Center (L)")
    min: float | None = Field(None, alias="Min", description="lowest signed distance from Center along the axis (L)")
    max: float | None = Field(None, alias="Max", description="highest signed distance from Center along the axis (L)")

    @field_validator("axis")
    @classmethod
    def _axis(cls, v):
        return v if isinstance(v, str) else _nonzero(v, "Axis")

    @model_validator(mode="after")
    def _consistent(self):
        if self.inner_radius >= self.radius:
            raise ValueError(f"Inner Radius ({self.inner_radius!r}) must be below Radius ({self.radius!r})")
        if self.length is not None and (self.min is not None or self.max is not None):
            raise ValueError("give either Length or Min/Max along the axis, not both")
        if self.min is not None and self.max is not None and self.min > self.max:
            raise ValueError(f"Min ({self.min!r}) is above Max ({self.max!r}) along the axis")
        return self


class HalfSpaceSpec(ModelParams):
    """The points on the side of a plane that its normal points to, the plane included."""

    point: Vector = Field(alias="Point", description="a point of the plane [x, y, z] (L)")
    normal: Vector = Field(alias="Normal", description="normal [nx, ny, nz], pointing into the region (any length but zero)")

    @field_validator("normal")
    @classmethod
    def _normal(cls, v):
        return _nonzero(v, "Normal")


class SurfaceLayerSpec(ModelParams):
    """The points within ``Thickness`` of the body's free surface (docs/regions.md)."""

    thickness: float = Field(alias="Thickness", gt=0.0, description="layer thickness, measured inward from the free surface (L)")


class RegionSpec(ModelParams):
    """One region: exactly one of its keys."""

    box: BoxSpec | None = Field(None, alias="Box", description="axis-aligned box: Min, Max")
    sphere: SphereSpec | None = Field(None, alias="Sphere", description="ball: Center, Radius")
    cylinder: CylinderSpec | None = Field(None, alias="Cylinder", description="cylinder or tube: Center, Axis, Radius, Inner Radius, Length or Min/Max")
    half_space: HalfSpaceSpec | None = Field(None, alias="Half Space", description="the side of a plane its normal points to: Point, Normal")
    expression: str | None = Field(None, alias="Expression", description="expression in x, y, z (L); a point is inside where it is nonzero, e.g. 'x > 0.01 && y < 0.02'")
    union: dict[str, "RegionSpec"] | None = Field(None, alias="Union", min_length=1, description="named regions: points in any of them")
    intersection: dict[str, "RegionSpec"] | None = Field(None, alias="Intersection", min_length=1,
                                                         description="named regions: points in all of them")
    difference: dict[str, "RegionSpec"] | None = Field(None, alias="Difference", min_length=2,
                                                       description="named regions: points of the first (in deck order) in none of the others")
    surface_layer: SurfaceLayerSpec | None = Field(None, alias="Surface Layer", description="points within Thickness of the free surface")
    all: Literal[True] | None = Field(None, alias="All", description="true: every point")

    @field_validator("all", mode="before")
    @classmethod
    def _all_is_true(cls, v):
        # Literal[True] compares with ==, so 1 and 1.0 passed as true; the deck must say true
        if v is not None and v is not True:
            raise ValueError(f"All must be true (every point), got {v!r}; write All: true, or leave the region out")
        return v

    @field_validator("expression")
    @classmethod
    def _expression(cls, v):
        if v is None:
            return v
        from .expressions import ExpressionError, compile_expression

        try:
            compile_expression(v, ("x", "y", "z"))
        except ExpressionError as exc:
            raise ValueError(f"Expression: {exc}") from None
        return v

    @model_validator(mode="after")
    def _one_key(self):
        given = [name for name in REGION_KEYS if getattr(self, REGION_KEYS[name]) is not None]
        if len(given) != 1:
            what = "no region" if not given else f"{len(given)} regions ({', '.join(given)})"
            raise ValueError(f"a region has exactly one of the keys {', '.join(REGION_KEYS)}; got {what} "
                             "(combine regions with Union, Intersection or Difference)")
        return self

    @property
    def kind(self) -> str:
        """The deck key of this region (``Box``, ``Half Space``, ...)."""
        return next(name for name, attr in REGION_KEYS.items() if getattr(self, attr) is not None)


#: deck key -> field name of RegionSpec
REGION_KEYS = {"Box": "box", "Sphere": "sphere", "Cylinder": "cylinder", "Half Space": "half_space", "Expression": "expression",
               "Union": "union", "Intersection": "intersection", "Difference": "difference", "Surface Layer": "surface_layer",
               "All": "all"}

RegionSpec.model_rebuild()


def layer_thicknesses(region: RegionSpec) -> set[float]:
    """The thicknesses of the ``Surface Layer`` regions in ``region`` (L)."""
    if region.surface_layer is not None:
        return {region.surface_layer.thickness}
    out: set[float] = set()
    parts = list((region.union or {}).values()) + list((region.intersection or {}).values()) + list((region.difference or {}).values())[:1]
    for part in parts:
        out |= layer_thicknesses(part)
    return out
