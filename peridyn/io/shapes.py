"""``Shapes`` discretization: points of solid primitives (boxes, cylinders, spheres), no mesh needed.

Each entry of ``Discretization > Shapes`` is one body: its points form a node set named after
the entry and belong to the block it names (``block_<id>``; shapes may share a block). Lengths
are in the deck's length unit (L), volumes in L^3.

Lattices (simple cubic, one per shape; h = ``Spacing``)

* ``Box`` (``Min``, ``Max``): along each axis n = max(1, round-half-up(L/h)) cells of size L/n;
  the points are the cell centres, so the cells tile the box and the total volume is exact;
  volume per point (Lx/nx)(Ly/ny)(Lz/nz).
* ``Cylinder`` (``Center``, ``Radius``, ``Length``, ``Axis``): in the cross-section, the
  cell-centred lattice ``Center + (k + 1/2) h`` (k integer) on both in-plane axes, keeping the
  points inside the circle (distance to the axis <= Radius); along the axis n = max(1,
  round-half-up(Length/h)) layers of thickness t = Length/n centred on ``Center``.
* ``Sphere`` (``Center``, ``Radius``): the cell-centred lattice ``Center + (k + 1/2) h`` on all
  three axes, keeping the points with distance to the centre <= Radius.

The cell-centred lattice (no point on the axis or at the centre) is symmetric under every
reflection and quarter turn about the axis (sphere: about the centre), like the alternative
``Center + k h``; it is chosen because its cells tile the body like the Box's, and because with
Radius an integer or half-integer multiple of h no point lies exactly on the surface (a sum of
two or three odd squares never equals (2 Radius/h)^2 then), so round-off never decides which
points are kept. The inside test is done on those odd integers, exactly, so the kept set is
exactly symmetric and the mean of the points is the centre to round-off.

Volumes of cylinders and spheres are **rescaled to the exact body volume**: every point of the
shape gets V/N, with V = pi Radius^2 Length (cylinder) or 4/3 pi Radius^3 (sphere) and N its
number of points, so mass and momentum of a body do not depend on how its surface cuts the
lattice. For fine lattices V/N is within a few percent of the cell volume h^2 t or h^3.

Points are in deck order of the shapes, inside a shape lexicographic (x fastest, then y, then
z); gid = 0..n-1. A point of a later shape closer than half the smaller spacing of the two
shapes to a point of an earlier shape is an input error (overlapping shapes). Neighborhoods
are the Euclidean search within the horizon (no grid rule).
"""
from __future__ import annotations

import difflib
import math
import re
from typing import Any, Literal

import numpy as np
from pydantic import Field, ValidationInfo, field_validator, model_validator

from ..core.discretization import Discretization
from ..core.errors import InputError
from ..core.discretization import DiscretizationReader
from ..core.params import ModelParams
from ..deck.model import tidy

__all__ = ["ShapeParams", "Shapes", "ShapesParams", "generate", "shape_points"]

_PATH = ("Discretization", "Shapes")
_AXES = "xyz"
_BLOCK = re.compile(r"block_([1-9][0-9]*)")
#: the smallest Spacing relative to the largest coordinate of a shape: below it, neighboring
#: points differ in fewer than ~1e6 units of the last place of their coordinates
_MIN_RELATIVE_SPACING = 1e-10
#: estimates above this are reported as this (the engine refuses them long before)
_HUGE = 1e30
#: 3/(4 pi), as PdQuickGrid writes it
_THREE_OVER_FOUR_PI = 0.238732414637843

_NEEDS = {"Box": ("min", "max"), "Cylinder": ("center", "radius", "length"), "Sphere": ("center", "radius")}
_ALLOWED = {"Box": {"min", "max"}, "Cylinder": {"center", "radius", "length", "axis"}, "Sphere": {"center", "radius"}}


def _layers(length: float, spacing: float) -> float:
    """max(1, round-half-up(length/spacing)) as a float (inf for absurd ratios, never raises)."""
    ratio = length / spacing
    return max(1.0, math.floor(ratio + 0.5)) if math.isfinite(ratio) else math.inf


def _radius_ratio_squared(radius: float, spacing: float) -> float:
    """(2 Radius/h)^2: a cell-centred point (k + 1/2) h per axis is inside when the sum of the
    squares of its odd integers 2k + 1 is at most this."""
    r = 2.0 * radius / spacing
    return r * r


# ------------------------------------------------------------------------------------------------
# Parameters
# ------------------------------------------------------------------------------------------------
class ShapeParams(ModelParams):
    """One body of ``Discretization > Shapes`` (lengths in L)."""

    shape: Literal["Box", "Cylinder", "Sphere"] = Field(alias="Shape", description="'Box', 'Cylinder' or 'Sphere'.")
    block: str = Field(alias="Block", description="Block of the shape's points: block_<positive integer>.")
    spacing: float = Field(alias="Spacing", gt=0, description="Lattice spacing h of this shape (L).")
    center: list[float] | None = Field(
        None, alias="Center", min_length=3, max_length=3,
        description="Cylinder, Sphere: centre [x, y, z] (L); of a cylinder, the middle of its axis.",
    )
    radius: float | None = Field(None, alias="Radius", gt=0, description="Cylinder, Sphere: radius (L).")
    length: float | None = Field(None, alias="Length", gt=0, description="Cylinder: length along its axis (L).")
    axis: Literal["x", "y", "z"] | None = Field(None, alias="Axis", description="Cylinder: axis direction; default 'z'.")
    min: list[float] | None = Field(None, alias="Min", min_length=3, max_length=3, description="Box: lowest corner [x, y, z] (L).")
    max: list[float] | None = Field(None, alias="Max", min_length=3, max_length=3, description="Box: highest corner [x, y, z] (L).")

    @model_validator(mode="before")
    @classmethod
    def _unknown_keys(cls, data: Any) -> Any:
        """Unknown keys with a suggestion (the deck's error converter cannot look inside a
        mapping of shapes for the known keys)."""
        if isinstance(data, dict):
            known = cls.deck_names()
            for key in data:
                field = cls.model_fields.get(key)
                if key in known or (field is not None and field.alias not in data):  # 'spacing': _deck_values
                    continue
                close = difflib.get_close_matches(str(key), known, n=1, cutoff=0.6)
                hint = f"did you mean {close[0]!r}?" if close else f"known keys: {', '.join(known)}"
                raise ValueError(f"unknown key {key!r}; {hint}")
        return data

    @field_validator("block")
    @classmethod
    def _block_name(cls, value: str) -> str:
        match = _BLOCK.fullmatch(value)
        if match is None or int(match.group(1)) >= 2**31:
            raise ValueError(
                f"block name {value!r} is not of the form block_<positive integer>; write e.g. 'block_1' "
                "(no leading zeros, id below 2^31)"
            )
        return value

    @field_validator("max")
    @classmethod
    def _max_above_min(cls, value: list[float] | None, info: ValidationInfo) -> list[float] | None:
        low = info.data.get("min")
        if value is not None and low is not None:
            bad = [f"{a}: Max {hi!r} <= Min {lo!r}" for a, lo, hi in zip(_AXES, low, value) if not hi > lo]
            if bad:
                raise ValueError(f"'Max' must be larger than 'Min' on every axis ({'; '.join(bad)}); swap or correct the corners")
        return value

    @model_validator(mode="after")
    def _keys_of_shape(self) -> ShapeParams:
        kind = self.shape
        names = {n: f.alias or n for n, f in type(self).model_fields.items()}
        missing = [names[n] for n in _NEEDS[kind] if getattr(self, n) is None]
        if missing:
            raise ValueError(f"a {kind} needs {', '.join(repr(m) for m in missing)}; add the missing key(s)")
        extra = [names[n] for n in ("center", "radius", "length", "axis", "min", "max") if self.given(n) and n not in _ALLOWED[kind]]
        if extra:
            keys = ", ".join(sorted(names[n] for n in _ALLOWED[kind]))
            raise ValueError(f"{', '.join(repr(e) for e in extra)} does not apply to a {kind} (its keys: {keys}); remove it")
        h = self.spacing
        if kind != "Box" and _radius_ratio_squared(self.radius, h) < (2.0 if kind == "Cylinder" else 3.0):
            raise ValueError(
                f"the {kind} has no lattice point: Spacing {h!r} is too large for Radius {self.radius!r}; "
                f"reduce Spacing below {self.radius * (math.sqrt(2.0) if kind == 'Cylinder' else 2.0 / math.sqrt(3.0))!r}"
            )
        lo, hi = self.bounds()
        extent = max(max(abs(v) for v in lo), max(abs(v) for v in hi))
        if h < _MIN_RELATIVE_SPACING * extent:
            raise ValueError(
                f"Spacing {h!r} is too small for coordinates as large as {extent!r}: the points would not be "
                "distinguishable in double precision; increase Spacing or move the shape nearer the origin"
            )
        return self

    def bounds(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Lowest and highest corner of the body's bounding box (L)."""
        if self.shape == "Box":
            return tuple(self.min), tuple(self.max)  # type: ignore[arg-type]
        half = [self.radius] * 3
        if self.shape == "Cylinder":
            half[_AXES.index(self.axis or "z")] = self.length / 2.0  # type: ignore[operator]
        c = self.center
        return tuple(c[a] - half[a] for a in range(3)), tuple(c[a] + half[a] for a in range(3))  # type: ignore[index]

    @property
    def block_id(self) -> int:
        return int(self.block.rsplit("_", 1)[1])

    def exact_volume(self) -> float:
        """Volume of the body (L^3)."""
        if self.shape == "Box":
            return math.prod(hi - lo for lo, hi in zip(self.min, self.max))  # type: ignore[arg-type]
        if self.shape == "Cylinder":
            return math.pi * self.radius**2 * self.length  # type: ignore[operator]
        return 4.0 / 3.0 * math.pi * self.radius**3  # type: ignore[operator]

    def estimate_points(self) -> float:
        """About the number of points (from above for cylinders and spheres), without making
        them; a float, inf for absurd sizes (never raises)."""
        h = self.spacing
        if self.shape == "Box":
            return math.prod(_layers(hi - lo, h) for lo, hi in zip(self.min, self.max))  # type: ignore[arg-type]
        r = self.radius / h + 1.0  # type: ignore[operator]
        if self.shape == "Cylinder":
            return math.pi * r * r * _layers(self.length, h)  # type: ignore[arg-type]
        return 4.0 / 3.0 * math.pi * r * r * r


class ShapesParams(ModelParams):
    """``Discretization`` section of ``Type: Shapes`` (besides the shared keys)."""

    shapes: dict[str, ShapeParams] = Field(
        alias="Shapes", description="The bodies, by name; each name is also the node set of the body's points."
    )

    @field_validator("shapes")
    @classmethod
    def _names(cls, value: dict[str, ShapeParams]) -> dict[str, ShapeParams]:
        if not value:
            raise ValueError("give at least one shape (a name with Shape, Block, Spacing and the shape's sizes)")
        seen: dict[str, str] = {}
        for name in value:
            key = tidy(name)
            if not key:
                raise ValueError("a shape name must not be empty (it names the shape's node set)")
            if "NODE_SET" in key:
                raise ValueError(f"shape name {name!r} contains 'Node Set', which marks the deck's own node sets; rename the shape")
            if key in seen:
                raise ValueError(
                    f"shapes {seen[key]!r} and {name!r} name the same node set {key!r} (node set names ignore case "
                    "and turn spaces into '_'); rename one"
                )
            seen[key] = name
        return value


# ------------------------------------------------------------------------------------------------
# Generation
# ------------------------------------------------------------------------------------------------
def _count(n: float, name: str) -> int:
    """``n`` (a count along one axis) as an int; InputError when absurd (not below 2^40)."""
    if not n < 2.0**40:
        raise InputError(f"Spacing gives about {n:.3g} points along one axis", path=_PATH + (name,), fix="increase Spacing")
    return int(n)


def _centred(center: float, n: int, step: float) -> np.ndarray:
    """n points ``center + (k - (n - 1)/2) step``: symmetric about ``center`` to round-off."""
    return center + (np.arange(n, dtype=np.float64) * 2.0 - (n - 1)) * (0.5 * step)


def shape_points(p: ShapeParams, name: str = "shape") -> tuple[np.ndarray, np.ndarray]:
    """Points (N, 3) (L) and volumes (N,) (L^3) of one shape, lexicographic (x fastest).

    Raises InputError for a shape without points or with an absurd number of them.
    """
    h = p.spacing
    coords: list[np.ndarray] = []
    odd_sq: list[np.ndarray | None] = []  # per axis: squares of the odd integers 2k + 1, or None (not radial)
    if p.shape == "Box":
        for lo, hi in zip(p.min, p.max):  # type: ignore[arg-type]
            n = _count(_layers(hi - lo, h), name)
            coords.append(_centred((lo + hi) / 2.0, n, (hi - lo) / n))
            odd_sq.append(None)
    else:
        axis = _AXES.index(p.axis or "z") if p.shape == "Cylinder" else -1
        m = _count(p.radius / h + 1.0, name)  # type: ignore[operator]
        odd = np.arange(-(2 * m - 1), 2 * m, 2, dtype=np.float64)  # exact integers
        for a in range(3):
            if a == axis:
                n = _count(_layers(p.length, h), name)  # type: ignore[arg-type]
                coords.append(_centred(p.center[a], n, p.length / n))  # type: ignore[index, operator]
                odd_sq.append(None)
            else:
                coords.append(p.center[a] + odd * (0.5 * h))  # type: ignore[index]
                odd_sq.append(odd * odd)
    shape3 = (coords[2].size, coords[1].size, coords[0].size)  # (z, y, x): x fastest in C order
    if not math.prod(shape3) < 2**40:
        raise InputError(f"Spacing gives about {math.prod(shape3):.3g} lattice cells", path=_PATH + (name,), fix="increase Spacing")
    if p.shape == "Box":
        mask = np.ones(shape3, dtype=bool)
    else:
        total = np.zeros((1, 1, 1))  # broadcast over the radial axes only (a cylinder: 2-D)
        for a, sq in enumerate(odd_sq):
            if sq is not None:
                total = total + sq.reshape([-1 if b == 2 - a else 1 for b in range(3)])
        mask = np.broadcast_to(total <= _radius_ratio_squared(p.radius, h), shape3)  # type: ignore[arg-type]
    iz, iy, ix = np.nonzero(mask)
    if ix.size == 0:
        raise InputError(f"shape {name!r} has no points", path=_PATH + (name,), fix="reduce Spacing")
    x = np.empty((ix.size, 3))
    x[:, 0], x[:, 1], x[:, 2] = coords[0][ix], coords[1][iy], coords[2][iz]
    if p.shape == "Box":
        cell = math.prod((hi - lo) / c.size for lo, hi, c in zip(p.min, p.max, coords))  # type: ignore[arg-type]
    else:
        cell = p.exact_volume() / ix.size  # rescaled to the exact body volume
    return x, np.full(ix.size, cell)


def _check_overlap(names: list[str], points: list[np.ndarray], spacings: list[float]) -> None:
    """InputError when a point of a later shape lies closer than half the smaller spacing of
    the two shapes to a point of an earlier shape. Only points in the overlap of the two
    bounding boxes (widened by that distance) are compared."""
    boxes = [(x.min(axis=0), x.max(axis=0)) for x in points]
    for j in range(1, len(points)):
        for i in range(j):
            tol = 0.5 * min(spacings[i], spacings[j])
            lo = np.maximum(boxes[i][0], boxes[j][0]) - tol
            hi = np.minimum(boxes[i][1], boxes[j][1]) + tol
            if np.any(lo > hi):
                continue
            a = points[i][np.all((points[i] >= lo) & (points[i] <= hi), axis=1)]
            b = points[j][np.all((points[j] >= lo) & (points[j] <= hi), axis=1)]
            if not (a.size and b.size):
                continue
            from scipy.spatial import cKDTree

            dist, _ = cKDTree(a).query(b, distance_upper_bound=tol)
            close = dist < tol
            if np.any(close):
                k = int(np.argmax(close))
                at = ", ".join(f"{v:g}" for v in b[k])
                raise InputError(
                    f"shape {names[j]!r} overlaps shape {names[i]!r}: its point ({at}) is {dist[k]:g} from a point of "
                    f"{names[i]!r}, less than half the spacing ({tol:g})",
                    path=_PATH + (names[j],),
                    fix="move or resize the shapes so that they do not overlap",
                )


def generate(params: ShapesParams) -> Discretization:
    """The points of every shape, in deck order; see the module docstring.

    Returns a :class:`Discretization`: x (n, 3) (L), volume (n,) (L^3), block ids from the block
    names, gid 0..n-1, one node set per shape (int64 mothership indices), no neighbor rule.
    """
    names = list(params.shapes)
    xs, vols, ids, node_sets = [], [], [], {}
    start = 0
    for name in names:
        p = params.shapes[name]
        x, v = shape_points(p, name)
        xs.append(x)
        vols.append(v)
        ids.append(np.full(x.shape[0], p.block_id, dtype=np.int64))
        node_sets[name] = np.arange(start, start + x.shape[0], dtype=np.int64)
        start += x.shape[0]
    _check_overlap(names, xs, [params.shapes[n].spacing for n in names])
    volume = np.concatenate(vols)
    blocks = {p.block_id: p.block for p in params.shapes.values()}
    return Discretization(
        x=np.concatenate(xs),
        volume=volume,
        block_id=np.concatenate(ids),
        gid=np.arange(start, dtype=np.int64),
        block_names=dict(sorted(blocks.items())),
        node_sets=node_sets,
        min_element_radius=math.pow(_THREE_OVER_FOUR_PI * float(volume.min()), 1.0 / 3.0),
        neighbor_rule=None,
        source="Shapes generator",
    )


class Shapes(DiscretizationReader):
    """Boxes, cylinders and spheres given in the deck (``Type: Shapes``)."""

    name = "Shapes"
    Params = ShapesParams
    supports_bond_filters = True

    def estimate_points(self) -> int:
        """About the number of points, from the parameters alone (never raises; capped at 1e30)."""
        params: ShapesParams = self.params  # type: ignore[assignment]
        total = sum(p.estimate_points() for p in params.shapes.values())
        return int(total) if total < _HUGE else int(_HUGE)

    def read(self) -> Discretization:
        return generate(self.params)  # type: ignore[arg-type]
