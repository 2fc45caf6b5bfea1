"""Peridigm's bond filters: remove (or, for Initial Damage, break) the bonds that cross a surface.

Three types, as in Peridigm (PERIDIGM_SEMANTICS.md sections 2.6 and 5.4; ``BondFilter.cxx``):

* ``Rectangular_Plane``: a finite rectangle (normal, lower-left corner, bottom unit vector,
  bottom and side lengths);
* ``Disk``: a disk (center, normal, radius);
* ``Exodus Mesh``: every triangle / quadrilateral of a surface mesh in an Exodus file.

A bond i->j is tested from i's side, as the segment p0 = x_i -> p1 = x_j, with Peridigm's
formulas in Peridigm's operation order and tolerances (no fused multiply-add, left-to-right dot
products), so the same bonds are cut. Deck vectors are used as given (Peridigm does not
normalize ``Normal_*`` or ``Bottom_Unit_Vector_*``).

The tests are numba kernels over CSR rows (the mesh test under ``prange``; each row writes only
its own flags). The Exodus Mesh filter bins its polygons in a uniform grid and tests a bond only
against the polygons of the cells its bounding box overlaps; the binning is conservative (padded
boxes; nearly degenerate polygons are tested against every bond), so it changes nothing but the
run time.
"""
from __future__ import annotations

import difflib
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, ClassVar, Literal

import numpy as np
from .neighbors import compact
from ..core.errors import InputError, is_file, missing_file, raise_collected
from pydantic import Field, ValidationError, model_validator

from ..core.params import DECK_CONTEXT, ModelParams
from ..deck.validation import explain
from .bond_filter_kernels import (
    POLYGON_ELEMENT_TYPES,
    _disk_kernel,
    _plane_kernel,
    _polygons_kernel,
)

__all__ = [
    "BondFilter",
    "RectangularPlaneFilter",
    "DiskFilter",
    "ExodusMeshFilter",
    "RectangularPlaneParams",
    "DiskParams",
    "ExodusMeshParams",
    "FILTER_TYPES",
    "make_filter",
    "make_filters",
    "apply_bond_filters",
    "flag_bonds",
    "read_exodus_polygons",
]

#: Peridigm's tolerances (BondFilter.h / BondFilter.cxx)
# ------------------------------------------------------------------------------------------------
# Parameters
# ------------------------------------------------------------------------------------------------
def _nonzero(v: Sequence[float], what: str) -> None:
    if all(c == 0.0 for c in v):
        raise ValueError(f"{what} is the zero vector")


class RectangularPlaneParams(ModelParams):
    """A finite rectangle: bonds crossing it are removed (cut)."""

    type: Literal["Rectangular_Plane"] = Field(alias="Type", description="Filter type")
    normal_x: float = Field(alias="Normal_X", description="Plane normal n, x component (used as given, not normalized)")
    normal_y: float = Field(alias="Normal_Y", description="Plane normal n, y component")
    normal_z: float = Field(alias="Normal_Z", description="Plane normal n, z component")
    lower_left_corner_x: float = Field(alias="Lower_Left_Corner_X", description="Corner r0, x (length)")
    lower_left_corner_y: float = Field(alias="Lower_Left_Corner_Y", description="Corner r0, y (length)")
    lower_left_corner_z: float = Field(alias="Lower_Left_Corner_Z", description="Corner r0, z (length)")
    bottom_unit_vector_x: float = Field(
        alias="Bottom_Unit_Vector_X", description="Unit vector u_b along the bottom edge from r0, x"
    )
    bottom_unit_vector_y: float = Field(alias="Bottom_Unit_Vector_Y", description="u_b, y")
    bottom_unit_vector_z: float = Field(alias="Bottom_Unit_Vector_Z", description="u_b, z")
    bottom_length: float = Field(
        alias="Bottom_Length", gt=0.0, description="Length of the bottom edge along u_b (length)"
    )
    side_length: float = Field(
        alias="Side_Length", gt=0.0, description="Length of the side edge along u_a = u_b x n (length)"
    )

    @model_validator(mode="after")
    def _check(self) -> "RectangularPlaneParams":
        _nonzero((self.normal_x, self.normal_y, self.normal_z), "the normal (Normal_X/Y/Z)")
        _nonzero(
            (self.bottom_unit_vector_x, self.bottom_unit_vector_y, self.bottom_unit_vector_z),
            "the bottom unit vector (Bottom_Unit_Vector_X/Y/Z)",
        )
        return self


class DiskParams(ModelParams):
    """A disk: bonds crossing it (strictly inside its radius) are removed."""

    type: Literal["Disk"] = Field(alias="Type", description="Filter type")
    center_x: float = Field(alias="Center_X", description="Disk center, x (length)")
    center_y: float = Field(alias="Center_Y", description="Disk center, y (length)")
    center_z: float = Field(alias="Center_Z", description="Disk center, z (length)")
    normal_x: float = Field(alias="Normal_X", description="Disk normal, x component (used as given)")
    normal_y: float = Field(alias="Normal_Y", description="Disk normal, y component")
    normal_z: float = Field(alias="Normal_Z", description="Disk normal, z component")
    radius: float = Field(alias="Radius", gt=0.0, description="Disk radius (length)")

    @model_validator(mode="after")
    def _check(self) -> "DiskParams":
        _nonzero((self.normal_x, self.normal_y, self.normal_z), "the normal (Normal_X/Y/Z)")
        return self


class ExodusMeshParams(ModelParams):
    """Every triangle and quadrilateral of an Exodus surface mesh cuts the bonds crossing it."""

    type: Literal["Exodus Mesh"] = Field(alias="Type", description="Filter type")
    file_name: str = Field(
        alias="File Name",
        min_length=1,
        description="Exodus file of TRI/TRI3/TRIANGLE/QUAD/QUAD4 element blocks, relative to the deck's folder",
    )


# ------------------------------------------------------------------------------------------------
# Filters
# ------------------------------------------------------------------------------------------------
class BondFilter(ABC):
    """A surface that cuts bonds. ``name`` is the deck's ``Type``; ``Params`` validates the
    filter's sublist (deck keys as aliases)."""

    name: ClassVar[str]
    Params: ClassVar[type[ModelParams]]

    def __init__(self, params: ModelParams) -> None:
        self.params = params

    @abstractmethod
    def flag(self, x: np.ndarray, offsets: np.ndarray, neighbors: np.ndarray, rows: np.ndarray,
             flags: np.ndarray) -> None:
        """Set ``flags[b] = True`` for every bond b this filter cuts (never clears a flag).

        x (n,3) float64 reference positions; offsets (k+1,) int64; neighbors (B,) int32/int64
        point indices; rows (k,) int64 the point of each CSR row; flags (B,) bool, modified.
        Bond b of row r is the segment x[rows[r]] -> x[neighbors[b]].
        """

    def cuts(self, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
        """Whether each segment p0[m] -> p1[m] is cut: p0, p1 (m,3) float64; returns bool (m,)."""
        p0 = np.asarray(p0, dtype=np.float64).reshape(-1, 3)
        p1 = np.asarray(p1, dtype=np.float64).reshape(-1, 3)
        m = p0.shape[0]
        if p1.shape[0] != m:
            raise ValueError("p0 and p1 must have the same number of segments")
        x = np.ascontiguousarray(np.concatenate([p0, p1]))
        offsets = np.arange(m + 1, dtype=np.int64)
        neighbors = np.arange(m, 2 * m, dtype=np.int32)
        flags = np.zeros(m, dtype=np.bool_)
        if m:
            self.flag(x, offsets, neighbors, np.arange(m, dtype=np.int64), flags)
        return flags


class RectangularPlaneFilter(BondFilter):
    """Peridigm's ``Rectangular_Plane`` (FinitePlaneFilter)."""

    name = "Rectangular_Plane"
    Params = RectangularPlaneParams

    def __init__(self, params: RectangularPlaneParams) -> None:
        super().__init__(params)
        p = params
        self.n = np.array([p.normal_x, p.normal_y, p.normal_z], dtype=np.float64)
        self.r0 = np.array([p.lower_left_corner_x, p.lower_left_corner_y, p.lower_left_corner_z], dtype=np.float64)
        self.ub = np.array([p.bottom_unit_vector_x, p.bottom_unit_vector_y, p.bottom_unit_vector_z], dtype=np.float64)
        u, v = self.ub, self.n
        # u_a = u_b x n, in Vector3D's Cross order
        self.ua = np.array(
            [-u[2] * v[1] + u[1] * v[2], u[2] * v[0] - u[0] * v[2], -u[1] * v[0] + u[0] * v[1]], dtype=np.float64
        )
        self.a = float(p.side_length)
        self.b = float(p.bottom_length)

    def flag(self, x, offsets, neighbors, rows, flags) -> None:  # noqa: D102
        if neighbors.size:
            _plane_kernel(x, offsets, neighbors, rows, self.n, self.r0, self.ua, self.ub, self.a, self.b, flags)


class DiskFilter(BondFilter):
    """Peridigm's ``Disk`` filter."""

    name = "Disk"
    Params = DiskParams

    def __init__(self, params: DiskParams) -> None:
        super().__init__(params)
        p = params
        self.c = np.array([p.center_x, p.center_y, p.center_z], dtype=np.float64)
        self.n = np.array([p.normal_x, p.normal_y, p.normal_z], dtype=np.float64)
        self.radius = float(p.radius)

    def flag(self, x, offsets, neighbors, rows, flags) -> None:  # noqa: D102
        if neighbors.size:
            _disk_kernel(x, offsets, neighbors, rows, self.c, self.n, self.radius, flags)


def _polygon_normals(V: np.ndarray, nv: np.ndarray) -> np.ndarray:
    """Unit normals as Peridigm's Triangle/QuadFilter constructors compute them (m,3).

    Triangle: normalize((v2 - v1) x (v3 - v1)); quad: normalize((v2 - v1) x (v4 - v1)); the
    magnitude is sqrt((n0*n0 + n1*n1) + n2*n2) and each component is divided by it. Elementwise
    numpy operations round each step, like the C++ (no fused multiply-add).
    """
    a = V[:, 1, :] - V[:, 0, :]
    third = np.where((nv == 4)[:, None], V[:, 3, :], V[:, 2, :])
    b = third - V[:, 0, :]
    n = np.empty_like(a)
    n[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    n[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    n[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        mag = np.sqrt(n[:, 0] * n[:, 0] + n[:, 1] * n[:, 1] + n[:, 2] * n[:, 2])
        n /= mag[:, None]
    return n


class ExodusMeshFilter(BondFilter):
    """Peridigm's ``Exodus Mesh`` filter: a Triangle/QuadFilter per element of a surface mesh.

    Attributes: V (m,4,3) float64 polygon vertices, nv (m,) int64 vertex counts, normal (m,3).
    With ``as_triangles`` (the Initial Damage model) every polygon is the triangle of its first
    three vertices.
    """

    name = "Exodus Mesh"
    Params = ExodusMeshParams

    def __init__(self, params: ExodusMeshParams, *, deck_dir: Path | str = ".", as_triangles: bool = False,
                 path: Sequence[str] = ()) -> None:
        super().__init__(params)
        file = Path(params.file_name)
        if not file.is_absolute():
            file = Path(deck_dir) / file
        self.file = file
        blocks = read_exodus_polygons(file, path=tuple(path) + ("File Name",), any_vertex_count=as_triangles)
        polys = [v[:, :3, :] if as_triangles else v for v in blocks]
        m = sum(p.shape[0] for p in polys)
        V = np.zeros((m, 4, 3), dtype=np.float64)
        nv = np.zeros(m, dtype=np.int64)
        k = 0
        for p in polys:
            e, c = p.shape[0], p.shape[1]
            V[k:k + e, :c, :] = p
            nv[k:k + e] = c
            k += e
        self.V = V
        self.nv = nv
        self.normal = _polygon_normals(V, nv) if m else np.zeros((0, 3))
        self._grid_cache: tuple | None = None

    @property
    def num_polygons(self) -> int:
        return int(self.nv.size)

    def _grid(self, x: np.ndarray, offsets: np.ndarray, neighbors: np.ndarray, rows: np.ndarray) -> tuple:
        """Padded polygon boxes and a uniform grid binning them (cell edge about the larger of
        the largest polygon and the typical bond length, at most 64 cells per axis)."""
        V, nv = self.V, self.nv
        m = nv.size
        verts = np.where((nv == 4)[:, None, None], V, V[:, [0, 1, 2, 2], :])
        plo = verts.min(axis=1)
        phi = verts.max(axis=1)
        ext = phi - plo
        scale = float(np.abs(V).max()) + float(np.abs(x).max()) if x.size else float(np.abs(V).max())
        pad = 1e-6 * ext.max(axis=1, keepdims=True) + 1e-12 * scale + 1e-300
        plo = plo - pad
        phi = phi + pad
        # Ill-conditioned polygons (nearly collinear edges) can pass the barycentric test far
        # from their bounding box: test those against every bond.
        A = V[:, 2, :] - V[:, 0, :]
        bad = np.zeros(m, dtype=bool)
        for third in (1, 3):
            B = V[:, third, :] - V[:, 0, :]
            aa = np.einsum("ij,ij->i", A, A)
            bb = np.einsum("ij,ij->i", B, B)
            ab = np.einsum("ij,ij->i", A, B)
            with np.errstate(invalid="ignore"):
                ok = (aa * bb - ab * ab) > 1e-8 * aa * bb
            if third == 1:
                bad |= ~ok
            else:
                bad |= (nv == 4) & ~ok
        always = np.nonzero(bad)[0].astype(np.int64)
        good = np.nonzero(~bad)[0].astype(np.int64)
        if good.size:
            glo = plo[good].min(axis=0)
            ghi = phi[good].max(axis=0)
            s = float(ext[good].max())
        else:
            glo = np.zeros(3)
            ghi = np.ones(3)
            s = 1.0
        # typical bond length from a sample of bonds
        if neighbors.size:
            sample = np.linspace(0, neighbors.size - 1, num=min(neighbors.size, 4096)).astype(np.int64)
            src = np.searchsorted(offsets, sample, side="right") - 1
            L = np.linalg.norm(x[neighbors[sample]] - x[rows[src]], axis=1)
            s = max(s, float(np.median(L)))
        span = ghi - glo
        if s <= 0.0 or not np.isfinite(s):
            s = float(span.max()) or 1.0
        dims = np.minimum(np.floor(span / s).astype(np.int64) + 1, 64)
        dims = np.maximum(dims, 1)
        cs = np.where(span > 0.0, span / dims, 1.0)
        cs = np.where(cs > 0.0, cs, 1.0)
        ncells = int(np.prod(dims))
        lo_i = np.clip(np.floor((plo[good] - glo) / cs).astype(np.int64), 0, dims - 1)
        hi_i = np.clip(np.floor((phi[good] - glo) / cs).astype(np.int64), 0, dims - 1)
        # every (polygon, cell) pair of each polygon's box of cells, vectorized
        span_i = hi_i - lo_i + 1  # (g,3) cells per axis
        per_poly = span_i.prod(axis=1)
        rep = np.repeat(np.arange(good.size), per_poly)
        local = np.arange(rep.size) - np.repeat(np.cumsum(per_poly) - per_poly, per_poly)
        sx = span_i[rep, 0]
        sy = span_i[rep, 1]
        ix = lo_i[rep, 0] + local % sx
        iy = lo_i[rep, 1] + (local // sx) % sy
        iz = lo_i[rep, 2] + local // (sx * sy)
        cells = (iz * dims[1] + iy) * dims[0] + ix
        order = np.argsort(cells, kind="stable")
        cell_polys = good[rep[order]]
        counts = np.zeros(ncells + 1, dtype=np.int64)
        np.cumsum(np.bincount(cells, minlength=ncells), out=counts[1:])
        return (plo, phi, always, glo.astype(np.float64), cs.astype(np.float64), dims.astype(np.int64),
                counts, cell_polys)

    def flag(self, x, offsets, neighbors, rows, flags) -> None:  # noqa: D102
        if neighbors.size == 0 or self.num_polygons == 0:
            return
        plo, phi, always, glo, cs, dims, cell_start, cell_polys = self._grid(x, offsets, neighbors, rows)
        _polygons_kernel(x, offsets, neighbors, rows, self.V, self.nv, self.normal, plo, phi, always,
                         glo, cs, dims, cell_start, cell_polys, flags)


#: deck ``Type`` -> filter class
FILTER_TYPES: dict[str, type[BondFilter]] = {
    RectangularPlaneFilter.name: RectangularPlaneFilter,
    DiskFilter.name: DiskFilter,
    ExodusMeshFilter.name: ExodusMeshFilter,
}
_INITIAL_DAMAGE_TYPES = ("Rectangular_Plane", "Exodus Mesh")


# ------------------------------------------------------------------------------------------------
# Exodus reader (surface meshes)
# ------------------------------------------------------------------------------------------------
def read_exodus_polygons(
    file: Path | str, *, path: Sequence[str] = (), any_vertex_count: bool = False
) -> list[np.ndarray]:
    """Polygons of an Exodus surface mesh, as Peridigm's ``GenesisToPolygons`` reads them.

    Returns one float64 array per non-empty element block, in block order, of shape
    (elements, nodes per element, 3): the node coordinates of each element in connectivity
    order (z = 0 for a 2-D mesh). Every non-empty block must be TRI, TRI3, TRIANGLE, QUAD or
    QUAD4 (case-insensitive) with 3 nodes (triangles) or 4 (quads), else InputError naming the
    block; ``any_vertex_count`` accepts any count >= 3 (the Initial Damage model uses the first
    three nodes of every element).
    """
    import netCDF4

    file = Path(file)
    fname = str(file)
    if not is_file(file):
        raise InputError(
            missing_file(file, "Exodus mesh file"), path=path,
            fix="check the file name (relative to the deck's folder)",
        )
    try:
        ds = netCDF4.Dataset(fname, "r")
    except (OSError, RuntimeError, ValueError, UnicodeError) as exc:
        raise InputError(f"cannot read {fname} as an Exodus (netCDF) file: {exc}", path=path) from None
    try:
        ds.set_auto_mask(False)
        var = ds.variables
        if "coordx" in var:
            coords = [np.asarray(var[n][:], dtype=np.float64) for n in ("coordx", "coordy", "coordz") if n in var]
        elif "coord" in var:
            c = np.asarray(var["coord"][:], dtype=np.float64)
            coords = [c[d] for d in range(c.shape[0])]
        else:
            raise InputError(f"{fname} has no node coordinates (coordx/coordy/coordz)", path=path)
        num_nodes = coords[0].size if coords else 0
        while len(coords) < 3:
            coords.append(np.zeros(num_nodes))
        xyz = np.stack(coords[:3], axis=1)
        nblk = int(ds.dimensions["num_el_blk"].size) if "num_el_blk" in ds.dimensions else 0
        blocks: list[np.ndarray] = []
        ids = np.asarray(var["eb_prop1"][:]).ravel() if "eb_prop1" in var else np.arange(1, nblk + 1)
        for k in range(1, nblk + 1):
            name = f"connect{k}"
            if name not in var:
                continue
            conn_var = var[name]
            if conn_var.size == 0 or conn_var.shape[0] == 0:
                continue
            etype = str(getattr(conn_var, "elem_type", "")).upper()
            bid = int(ids[k - 1]) if k - 1 < len(ids) else k
            if etype not in POLYGON_ELEMENT_TYPES:
                raise InputError(
                    f"{fname}: element block {bid} has element type {etype or '(none)'}; a bond-filter "
                    f"mesh may hold only {', '.join(POLYGON_ELEMENT_TYPES)} elements",
                    path=path,
                )
            conn = np.asarray(conn_var[:], dtype=np.int64)
            npe = conn.shape[1]
            expected = 3 if etype.startswith("TRI") else 4
            if (npe < 3) if any_vertex_count else (npe != expected):
                raise InputError(
                    f"{fname}: element block {bid} ({etype}) has {npe} nodes per element; "
                    f"expected {expected}",
                    path=path,
                )
            if conn.min() < 1 or conn.max() > num_nodes:
                raise InputError(f"{fname}: element block {bid} refers to nodes outside 1..{num_nodes}", path=path)
            blocks.append(xyz[conn - 1])
        return blocks
    finally:
        ds.close()


# ------------------------------------------------------------------------------------------------
# Construction from the deck
# ------------------------------------------------------------------------------------------------
def _suggest(word: str, choices: Sequence[str]) -> str | None:
    """The closest of ``choices`` to ``word``: a case-insensitive match first, then difflib's."""
    for c in choices:
        if c.lower() == word.lower():
            return c
    close = difflib.get_close_matches(word, list(choices), n=1)
    return close[0] if close else None


def _validation_errors(exc: ValidationError, params_cls: type[ModelParams], path: tuple[str, ...]) -> list[InputError]:
    known = params_cls.deck_names()
    out = []
    for err in exc.errors():
        loc = tuple(str(p) for p in err.get("loc", ()))
        key = loc[0] if loc else None
        if err.get("type") == "extra_forbidden":
            close = _suggest(key or "", known)
            fix = f"did you mean {close!r}?" if close else f"valid keys: {', '.join(known)}"
            out.append(InputError(f"unknown key {key!r}", path=path + ((key,) if key else ()), fix=fix))
        elif err.get("type") == "missing":
            out.append(InputError("missing required key", path=path + ((key,) if key else ())))
        elif err.get("type") in ("value_error", "assertion_error"):
            msg = str(err.get("msg", "invalid value")).removeprefix("Value error, ")
            out.append(InputError(msg, path=path + ((key,) if key else ())))
        else:
            problem, fix = explain(err["type"], err.get("ctx") or {}, err.get("input"), str(err.get("msg", "invalid value")))
            out.append(InputError(problem, path=path + ((key,) if key else ()), fix=fix))
    return out


def make_filter(params: Mapping[str, Any], *, deck_dir: Path | str, path: Sequence[str] = (),
                for_initial_damage: bool = False) -> BondFilter:
    """Build one filter from a raw deck sublist (keys as in the deck, e.g. ``"Normal_X"``).

    ``path`` is the deck path of the sublist (for messages, e.g. ``("Discretization",
    "Bond Filters", "My Filter")``); ``deck_dir`` resolves an Exodus Mesh ``File Name``.
    ``for_initial_damage``: the Initial Damage model's filters (section 5.4): only
    Rectangular_Plane and Exodus Mesh, and every mesh polygon becomes the triangle of its first
    three vertices. Raises InputError (or InputErrors) naming the deck path.
    """
    path = tuple(path)
    if not isinstance(params, Mapping):
        raise InputError("a bond filter must be a sublist with a Type", path=path)
    allowed = _INITIAL_DAMAGE_TYPES if for_initial_damage else tuple(FILTER_TYPES)
    if "Type" not in params:
        raise InputError("missing required key", path=path + ("Type",), fix=f"one of {', '.join(allowed)}")
    ftype = params["Type"]
    if ftype not in allowed:
        close = _suggest(str(ftype), allowed)
        where = "an Initial Damage model's bond filter" if for_initial_damage else "a bond filter"
        fix = f"did you mean {close!r}?" if close else f"use one of {', '.join(allowed)}"
        raise InputError(f"invalid type {ftype!r} for {where}", path=path + ("Type",), fix=fix)
    cls = FILTER_TYPES[ftype]
    try:
        p = cls.Params.model_validate(dict(params), context={DECK_CONTEXT: True})
    except ValidationError as exc:
        raise_collected(_validation_errors(exc, cls.Params, path))
        raise  # pragma: no cover - raise_collected always raises here
    if cls is ExodusMeshFilter:
        return ExodusMeshFilter(p, deck_dir=deck_dir, as_triangles=for_initial_damage, path=path)
    return cls(p)


def make_filters(section: Mapping[str, Any], *, deck_dir: Path | str, path: Sequence[str] = (),
                 for_initial_damage: bool = False) -> list[BondFilter]:
    """All filters of a ``Bond Filters`` sublist, in deck order (each entry a named sublist).

    Errors of every entry are collected and raised together.
    """
    path = tuple(path)
    if not isinstance(section, Mapping):
        raise InputError("Bond Filters must be a list of named filter sublists", path=path)
    filters: list[BondFilter] = []
    errors: list[InputError] = []
    for name, sub in section.items():
        try:
            filters.append(make_filter(sub, deck_dir=deck_dir, path=path + (str(name),),
                                       for_initial_damage=for_initial_damage))
        except InputError as exc:
            errors.extend(getattr(exc, "errors", None) or [exc])
    raise_collected(errors)
    return filters


# ------------------------------------------------------------------------------------------------
# Applying filters to neighbor lists
# ------------------------------------------------------------------------------------------------
def _cut_flags(x: np.ndarray, offsets: np.ndarray, neighbors: np.ndarray, filters: Sequence[BondFilter],
               rows: np.ndarray | None) -> np.ndarray:
    x = np.ascontiguousarray(x, dtype=np.float64)
    offsets = np.ascontiguousarray(offsets, dtype=np.int64)
    neighbors = np.ascontiguousarray(neighbors)
    k = offsets.size - 1
    rows = np.arange(k, dtype=np.int64) if rows is None else np.ascontiguousarray(rows, dtype=np.int64)
    if rows.size != k:
        raise ValueError(f"rows has {rows.size} entries for {k} CSR rows")
    flags = np.zeros(neighbors.size, dtype=np.bool_)
    for f in filters:
        f.flag(x, offsets, neighbors, rows, flags)
    return flags


def apply_bond_filters(x: np.ndarray, offsets: np.ndarray, neighbors: np.ndarray, filters: Sequence[BondFilter],
                       rows: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Remove bond i->j when any filter cuts the segment x_i -> x_j (evaluated from i's side).

    x (n,3) float64 reference positions; offsets (k+1,) int64; neighbors (B,) int32/int64;
    rows (k,) int64 the point of each CSR row (default: row r is point r). Returns new
    ``(offsets, neighbors)`` keeping the order of the remaining bonds (the inputs themselves
    when ``filters`` is empty).
    """
    if not filters:
        return np.asarray(offsets, dtype=np.int64), np.asarray(neighbors)
    flags = _cut_flags(x, offsets, neighbors, filters, rows)
    np.logical_not(flags, out=flags)
    return compact(offsets, neighbors, flags)


def flag_bonds(x: np.ndarray, offsets: np.ndarray, neighbors: np.ndarray, filters: Sequence[BondFilter],
               rows: np.ndarray | None = None) -> np.ndarray:
    """1.0 for every bond a filter cuts, else 0.0: float64 (B,) aligned with ``neighbors``
    (the Initial Damage model's bond damage). Arguments as :func:`apply_bond_filters`."""
    return _cut_flags(x, offsets, neighbors, filters, rows).astype(np.float64)
