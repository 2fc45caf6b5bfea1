"""``PdQuickGrid`` discretization: Peridigm's built-in tensor-product grid generators.

Follows ``Peridigm_PdQuickGridDiscretization.cpp`` and ``QuickGrid.cxx`` (PERIDIGM_SEMANTICS.md
§2.1, §2.2), bit for bit where the outputs depend on it.

``TensorProduct3DMeshGenerator`` (a box of nx x ny x nz cells)

* 1-D cell centers are **running sums**: h = L/n, p_0 = x0 + h/2.0, p_{k+1} = p_k + h;
* GID = i + j nx + k nx ny (i fastest); point (px_i, py_j, pz_k); volume (hx hy) hz;
* one block, ``block_1`` (Block_Id 1), no node sets;
* minElementRadius = pow(((0.238732414637843 hx) hy) hz, 0.33333333333333333).

``TensorProductCylinderMeshGenerator`` (a ring of nr x numRays x nz cells)

* dr = (ro - ri)/nr, R = (ri + ro)/2, numRays = int(2 pi/(dr/R)) + 1, nz = int(L/dr) + 1;
* radii, angles and z by the running-sum rule on [ri, ro], [0, 2 pi], [z0, z0 + L];
* GID = i_r + j_theta nr + k_z nr numRays; point (r cos theta, r sin theta, z) (the ring center
  is ignored, as in Peridigm); volume ((r dr) dtheta) dz with dtheta = 2 pi/numRays.

Neighborhoods (the discretization's ``neighbor_rule``)

* per axis n = round-half-up(delta/h), capped at the number of cells on that axis (for the
  angle, h = dtheta R);
* the candidates are the cells with |ii - i| <= n on every axis, clipped to the grid (the angle
  wraps around: a window of 2n + 1 rays, or every ray if that is more than the ring has);
* ``NeighborhoodType: Spherical`` keeps a candidate only if
  ((dx dx + dy dy) + dz dz) - delta delta < 0, strictly; any other value, or none, keeps the
  whole box (corners farther than delta included);
* lists are in ascending GID order, the point itself excluded.

Differences from Peridigm (``docs/peridigm-differences.md``): the cylinder lists are sorted by
GID (Peridigm lists rays in window order, so the first rays' lists wrap); a ray window wider than
the ring does not list rays twice; the cylinder's minElementRadius is computed from the cell
volumes (Peridigm leaves it at 1e50, which breaks the default finite-difference probe).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange
from pydantic import Field, model_validator

from ..core.discretization import Discretization
from ..core.discretization import DiscretizationReader
from ..core.params import ModelParams
from ..core.errors import InputError

__all__ = [
    "PdQuickGrid",
    "PdQuickGridParams",
    "TensorProduct3DParams",
    "TensorProductCylinderParams",
    "tensor_product_3d",
    "tensor_product_cylinder",
    "running_sum_centers",
    "cylinder_layout",
    "cell_neighborhood_size",
    "BoxNeighborRule",
    "CylinderNeighborRule",
]

_PATH = ("Discretization",)


# ------------------------------------------------------------------------------------------------
# Parameters
# ------------------------------------------------------------------------------------------------
class TensorProduct3DParams(ModelParams):
    """``TensorProduct3DMeshGenerator`` sublist: a box of cells (lengths in L)."""

    type: str | None = Field(None, alias="Type", description="Ignored (Peridigm decks write PdQuickGrid here).")
    x_origin: float = Field(alias="X Origin", description="Lower x corner of the box (L).")
    y_origin: float = Field(alias="Y Origin", description="Lower y corner of the box (L).")
    z_origin: float = Field(alias="Z Origin", description="Lower z corner of the box (L).")
    x_length: float = Field(alias="X Length", gt=0, description="Box length along x (L).")
    y_length: float = Field(alias="Y Length", gt=0, description="Box length along y (L).")
    z_length: float = Field(alias="Z Length", gt=0, description="Box length along z (L).")
    number_points_x: int = Field(alias="Number Points X", gt=0, description="Number of cells along x.")
    number_points_y: int = Field(alias="Number Points Y", gt=0, description="Number of cells along y.")
    number_points_z: int = Field(alias="Number Points Z", gt=0, description="Number of cells along z.")


class TensorProductCylinderParams(ModelParams):
    """``TensorProductCylinderMeshGenerator`` sublist: a ring around the z axis (lengths in L)."""

    type: str | None = Field(None, alias="Type", description="Ignored (Peridigm decks write PdQuickGrid here).")
    inner_radius: float = Field(alias="Inner Radius", ge=0, description="Inner radius of the ring (L).")
    outer_radius: float = Field(alias="Outer Radius", gt=0, description="Outer radius of the ring (L).")
    cylinder_length: float = Field(alias="Cylinder Length", gt=0, description="Length along z (L).")
    number_points_radius: int = Field(
        alias="Number Points Radius", gt=0, description="Number of cells through the wall; sets the cell size."
    )
    ring_center_x: float = Field(
        0.0, alias="Ring Center x", description="Ignored, as in Peridigm: the ring is centred on the z axis (L)."
    )
    ring_center_y: float = Field(
        0.0, alias="Ring Center y", description="Ignored, as in Peridigm: the ring is centred on the z axis (L)."
    )
    z_origin: float = Field(alias="Z Origin", description="z of the bottom of the cylinder (L).")

    @model_validator(mode="after")
    def _radii(self) -> "TensorProductCylinderParams":
        if not self.outer_radius > self.inner_radius:
            raise ValueError("Outer Radius must be larger than Inner Radius")
        return self


class PdQuickGridParams(ModelParams):
    """``Discretization`` section of ``Type: PdQuickGrid`` (besides the shared keys)."""

    neighborhood_type: str | None = Field(
        None,
        alias="NeighborhoodType",
        description="'Spherical': neighbors strictly closer than the horizon. Any other value, or "
        "none: every cell of the box of half-width round(horizon/cell size) (Peridigm's default).",
    )
    tensor_product_3d: TensorProduct3DParams | None = Field(
        None, alias="TensorProduct3DMeshGenerator", description="A box of cells."
    )
    tensor_product_cylinder: TensorProductCylinderParams | None = Field(
        None, alias="TensorProductCylinderMeshGenerator", description="A ring of cells around the z axis."
    )

    @model_validator(mode="after")
    def _one_generator(self) -> "PdQuickGridParams":
        given = (self.tensor_product_3d is not None) + (self.tensor_product_cylinder is not None)
        if given != 1:
            raise ValueError(
                "give exactly one of the sublists TensorProduct3DMeshGenerator and "
                "TensorProductCylinderMeshGenerator"
            )
        return self

    @property
    def spherical(self) -> bool:
        """Whether neighborhoods are spherical (exactly ``NeighborhoodType: Spherical``)."""
        return self.neighborhood_type == "Spherical"


# ------------------------------------------------------------------------------------------------
# 1-D helpers
# ------------------------------------------------------------------------------------------------
def running_sum_centers(n: int, x0: float, length: float) -> np.ndarray:
    """Peridigm's 1-D cell centers: h = length/n, p_0 = x0 + h/2.0, p_{k+1} = p_k + h.

    Returns (n,) float64. A sequential accumulation (``np.add.accumulate`` is sequential),
    which differs from x0 + (k + 1/2) h in the last bits.
    """
    h = length / n
    steps = np.full(n, h)
    steps[0] = x0 + h / 2.0
    return np.add.accumulate(steps)


def cell_neighborhood_size(horizon: float, cell_size: float, num_cells: int, ring_radius: float = 1.0) -> int:
    """One-sided neighborhood size in cells (``Spec1D::getCellNeighborhoodSize``).

    r = horizon/(cell_size ring_radius); n = trunc(r), plus 1 if r - n >= 0.5; capped at
    ``num_cells``.
    """
    dx = cell_size * ring_radius
    ratio = horizon / dx
    if not ratio < num_cells:  # also an overflow to inf
        return num_cells
    n = int(ratio)
    if abs(ratio - n) >= 0.5:
        n += 1
    return min(n, num_cells)


def _check_horizon(horizon: np.ndarray, num_points: int) -> float:
    horizon = np.asarray(horizon, dtype=np.float64)
    if horizon.shape != (num_points,):
        raise ValueError(f"horizon has shape {horizon.shape}, expected ({num_points},)")
    if num_points == 0:
        raise ValueError("no points")
    delta = float(horizon[0])
    if not np.all(horizon == delta):
        raise InputError(
            "PdQuickGrid needs one constant horizon, but the horizons differ between points",
            path=_PATH,
            fix="give the block a number as Horizon, or use a Text File or Exodus mesh for "
            "variable horizons",
        )
    if not (math.isfinite(delta) and delta > 0.0):
        raise InputError(f"the horizon must be positive, got {delta!r}", path=("Blocks",))
    return delta


# ------------------------------------------------------------------------------------------------
# Kernel: one tensor-product grid walk (the 3-D box, or the ring with a periodic angle axis).
# One kernel for both, to keep numba's compile time down. Two passes (count, then fill);
# prange over points; each point writes only its own list.
# ------------------------------------------------------------------------------------------------
@njit(cache=True, parallel=True)
def _grid_neighbors(points, x, n0, n1, n2, w0, w1, w2, periodic1, spherical, delta, offsets, neighbors, fill):
    """Neighbors of points of an n0 x n1 x n2 grid with GID = i + j n0 + k n0 n1.

    points: (k,) int64 GIDs; x: (n0 n1 n2, 3) float64 positions (L); w0, w1, w2: one-sided
    window half-widths in cells; periodic1: whether axis 1 wraps around (the cylinder's rays:
    cells within circular distance w1); spherical: keep only candidates with
    ((dx dx + dy dy) + dz dz) - delta delta < 0 (delta in L).
    Count pass (fill False): returns the (k,) int64 counts; ``offsets``/``neighbors`` unused.
    Fill pass (fill True): writes point q's neighbors in ascending GID order (k outer, j, i
    inner) to ``neighbors[offsets[q]:offsets[q+1]]`` and returns the counts again.
    """
    k = points.shape[0]
    counts = np.zeros(k, dtype=np.int64)
    dd = delta * delta
    for q in prange(k):
        p = points[q]
        i = p % n0
        j = (p // n0) % n1
        kz = p // (n0 * n1)
        # the window on axis 1 as up to two ascending ranges [a0, a1) and [b0, b1): on the
        # periodic axis the cells within circular distance w1, wrapped (not a pass over the ring)
        a0 = max(j - w1, 0)
        a1 = min(j + w1 + 1, n1)
        b0 = 0
        b1 = 0
        if periodic1:
            if 2 * w1 + 1 >= n1:
                a0, a1 = 0, n1
            elif j - w1 < 0:
                a0, a1, b0, b1 = 0, j + w1 + 1, j - w1 + n1, n1
            elif j + w1 >= n1:
                a0, a1, b0, b1 = 0, j + w1 + 1 - n1, j - w1, n1
        pos = offsets[q] if fill else 0
        c = 0
        for kk in range(max(kz - w2, 0), min(kz + w2 + 1, n2)):
            for t in range((a1 - a0) + (b1 - b0)):
                jj = a0 + t if t < a1 - a0 else b0 + (t - (a1 - a0))
                for ii in range(max(i - w0, 0), min(i + w0 + 1, n0)):
                    g = ii + jj * n0 + kk * n0 * n1
                    if g == p:
                        continue
                    if spherical:
                        dx = x[p, 0] - x[g, 0]
                        dy = x[p, 1] - x[g, 1]
                        dz = x[p, 2] - x[g, 2]
                        if not (((dx * dx + dy * dy) + dz * dz) - dd < 0.0):
                            continue
                    if fill:
                        neighbors[pos + c] = g
                    c += 1
        counts[q] = c
    return counts


def _grid_rule(points, x, shape, window, periodic1, spherical, delta) -> tuple[np.ndarray, np.ndarray]:
    points = np.ascontiguousarray(points, dtype=np.int64)
    n0, n1, n2 = shape
    w0, w1, w2 = window
    if points.size and (points.min() < 0 or points.max() >= n0 * n1 * n2):
        raise ValueError(f"points must be mothership indices in [0, {n0 * n1 * n2})")
    empty = np.zeros(1, dtype=np.int64)
    if not spherical and not periodic1:  # the box: counts in closed form
        i, j, k = points % n0, (points // n0) % n1, points // (n0 * n1)
        counts = (
            (np.minimum(i + w0 + 1, n0) - np.maximum(i - w0, 0))
            * (np.minimum(j + w1 + 1, n1) - np.maximum(j - w1, 0))
            * (np.minimum(k + w2 + 1, n2) - np.maximum(k - w2, 0))
            - 1
        )
    else:
        counts = _grid_neighbors(points, x, n0, n1, n2, w0, w1, w2, periodic1, spherical, delta, empty, empty, False)
    offsets = _csr(counts)
    index_type = np.int32 if n0 * n1 * n2 < 2**31 else np.int64  # 4 bytes per bond when possible
    neighbors = np.empty(max(int(offsets[-1]), 1), dtype=index_type)
    _grid_neighbors(points, x, n0, n1, n2, w0, w1, w2, periodic1, spherical, delta, offsets, neighbors, True)
    return offsets, neighbors[: int(offsets[-1])]


def _csr(counts: np.ndarray) -> np.ndarray:
    offsets = np.zeros(counts.shape[0] + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    return offsets


# ------------------------------------------------------------------------------------------------
# Neighbor rules (Discretization.neighbor_rule)
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class BoxNeighborRule:
    """Candidate neighbors of a ``TensorProduct3DMeshGenerator`` grid.

    Called as ``rule(points, horizon)``: ``points`` (k,) int64 mothership indices (= GIDs),
    ``horizon`` (n,) float64, all equal (L). Returns CSR ``(offsets (k+1,), neighbors)`` int64,
    each list in ascending GID order without the point itself.
    """

    x: np.ndarray  #: (n, 3) positions (L)
    shape: tuple[int, int, int]  #: (nx, ny, nz)
    cell_size: tuple[float, float, float]  #: (hx, hy, hz) (L)
    spherical: bool

    def sizes(self, delta: float) -> tuple[int, int, int]:
        """One-sided neighborhood sizes (n_x, n_y, n_z) in cells for horizon ``delta``."""
        hx, hy, hz = self.cell_size
        nx, ny, nz = self.shape
        return (
            cell_neighborhood_size(delta, hx, nx),
            cell_neighborhood_size(delta, hy, ny),
            cell_neighborhood_size(delta, hz, nz),
        )

    def __call__(self, points: np.ndarray, horizon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        nx, ny, nz = self.shape
        delta = _check_horizon(horizon, nx * ny * nz)
        return _grid_rule(points, self.x, self.shape, self.sizes(delta), False, self.spherical, delta)


@dataclass(frozen=True, eq=False)
class CylinderNeighborRule:
    """Candidate neighbors of a ``TensorProductCylinderMeshGenerator`` ring: a box in radius and
    z, a wrap-around window of rays in angle. Same call contract as :class:`BoxNeighborRule`."""

    x: np.ndarray  #: (n, 3) positions (L)
    shape: tuple[int, int, int]  #: (nr, numRays, nz)
    cell_size: tuple[float, float, float]  #: (dr (L), dtheta (rad), dz (L))
    mean_radius: float  #: R = (ri + ro)/2 (L), converts the ray angle to a length
    spherical: bool

    def sizes(self, delta: float) -> tuple[int, int, int]:
        """One-sided sizes (n_r, n_theta, n_z) in cells for horizon ``delta``."""
        nr, nrays, nz = self.shape
        dr, dtheta, dz = self.cell_size
        return (
            cell_neighborhood_size(delta, dr, nr),
            cell_neighborhood_size(delta, dtheta, nrays, self.mean_radius),
            cell_neighborhood_size(delta, dz, nz),
        )

    def __call__(self, points: np.ndarray, horizon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        nr, nrays, nz = self.shape
        delta = _check_horizon(horizon, nr * nrays * nz)
        return _grid_rule(points, self.x, self.shape, self.sizes(delta), True, self.spherical, delta)


# ------------------------------------------------------------------------------------------------
# Generators
# ------------------------------------------------------------------------------------------------
def tensor_product_3d(params: TensorProduct3DParams, *, spherical: bool = False) -> Discretization:
    """Points of a ``TensorProduct3DMeshGenerator`` box, in GID order.

    Returns a :class:`Discretization`: x (nx ny nz, 3) cell centers (L), volume (hx hy) hz (L^3),
    block 1 ``block_1``, gid 0..n-1, no node sets, and the box neighbor rule.
    """
    nx, ny, nz = params.number_points_x, params.number_points_y, params.number_points_z
    xs = running_sum_centers(nx, params.x_origin, params.x_length)
    ys = running_sum_centers(ny, params.y_origin, params.y_length)
    zs = running_sum_centers(nz, params.z_origin, params.z_length)
    n = nx * ny * nz
    x = np.empty((n, 3))
    x[:, 0] = np.tile(xs, ny * nz)
    x[:, 1] = np.tile(np.repeat(ys, nx), nz)
    x[:, 2] = np.repeat(zs, nx * ny)
    hx, hy, hz = params.x_length / nx, params.y_length / ny, params.z_length / nz
    volume = np.full(n, (hx * hy) * hz)
    radius = math.pow(((0.238732414637843 * hx) * hy) * hz, 0.33333333333333333)
    rule = BoxNeighborRule(x=x, shape=(nx, ny, nz), cell_size=(hx, hy, hz), spherical=spherical)
    return Discretization(
        x=x,
        volume=volume,
        block_id=np.ones(n, dtype=np.int64),
        gid=np.arange(n, dtype=np.int64),
        block_names={1: "block_1"},
        node_sets={},
        min_element_radius=radius,
        neighbor_rule=rule,
        source="PdQuickGrid TensorProduct3DMeshGenerator",
    )


def cylinder_layout(params: TensorProductCylinderParams) -> tuple[int, int, int, float, float, float, float]:
    """(nr, numRays, nz, dr, dtheta, dz, R) of a cylinder generator, as Peridigm computes them."""
    ri, ro, nr = params.inner_radius, params.outer_radius, params.number_points_radius
    ring_thickness = ro - ri
    dr = ring_thickness / nr
    mean_radius = (ri + ro) / 2
    num_rays = int(2 * math.pi / (dr / mean_radius)) + 1
    cell_size = abs(ro - ri) / nr
    nz = int(params.cylinder_length / cell_size) + 1
    dtheta = 2.0 * math.pi / num_rays
    dz = params.cylinder_length / nz
    return nr, num_rays, nz, cell_size, dtheta, dz, mean_radius


def tensor_product_cylinder(params: TensorProductCylinderParams, *, spherical: bool = False) -> Discretization:
    """Points of a ``TensorProductCylinderMeshGenerator`` ring, in GID order.

    Returns a :class:`Discretization`: x (nr numRays nz, 3) = (r cos theta, r sin theta, z) (L),
    volume ((r dr) dtheta) dz (L^3), block 1 ``block_1``, gid 0..n-1, no node sets, and the
    cylinder neighbor rule.
    """
    nr, num_rays, nz, dr, dtheta, dz, mean_radius = cylinder_layout(params)
    radii = running_sum_centers(nr, params.inner_radius, abs(params.outer_radius - params.inner_radius))
    thetas = running_sum_centers(num_rays, 0.0, 2.0 * math.pi)
    zs = running_sum_centers(nz, params.z_origin, params.cylinder_length)
    # math.cos/sin are the C library's, as in Peridigm (numpy's SIMD versions may differ by an ulp)
    cos_t = np.array([math.cos(t) for t in thetas])
    sin_t = np.array([math.sin(t) for t in thetas])
    ring_x = (radii[None, :] * cos_t[:, None]).ravel()  # (numRays, nr), radius fastest
    ring_y = (radii[None, :] * sin_t[:, None]).ravel()
    n_ring = nr * num_rays
    n = n_ring * nz
    x = np.empty((n, 3))
    x[:, 0] = np.tile(ring_x, nz)
    x[:, 1] = np.tile(ring_y, nz)
    x[:, 2] = np.repeat(zs, n_ring)
    ring_volume = np.tile(((radii * dr) * dtheta) * dz, num_rays)
    volume = np.tile(ring_volume, nz)
    radius = math.pow(0.238732414637843 * float(volume.min()), 0.33333333333333333)
    rule = CylinderNeighborRule(
        x=x, shape=(nr, num_rays, nz), cell_size=(dr, dtheta, dz), mean_radius=mean_radius, spherical=spherical
    )
    return Discretization(
        x=x,
        volume=volume,
        block_id=np.ones(n, dtype=np.int64),
        gid=np.arange(n, dtype=np.int64),
        block_names={1: "block_1"},
        node_sets={},
        min_element_radius=radius,
        neighbor_rule=rule,
        source="PdQuickGrid TensorProductCylinderMeshGenerator",
    )


class PdQuickGrid(DiscretizationReader):
    """Peridigm's grid generators (``Type: PdQuickGrid``)."""

    name = "PdQuickGrid"
    Params = PdQuickGridParams
    supports_bond_filters = False

    def estimate_points(self) -> int:
        params: PdQuickGridParams = self.params  # type: ignore[assignment]
        if params.tensor_product_3d is not None:
            g = params.tensor_product_3d
            return g.number_points_x * g.number_points_y * g.number_points_z
        assert params.tensor_product_cylinder is not None
        nr, num_rays, nz = cylinder_layout(params.tensor_product_cylinder)[:3]
        return nr * num_rays * nz

    def read(self) -> Discretization:
        params: PdQuickGridParams = self.params  # type: ignore[assignment]
        if params.tensor_product_3d is not None:
            return tensor_product_3d(params.tensor_product_3d, spherical=params.spherical)
        assert params.tensor_product_cylinder is not None  # the validator guarantees one
        return tensor_product_cylinder(params.tensor_product_cylinder, spherical=params.spherical)
