"""The free surface of a point cloud: which points' cells are open to the outside, how far each
point lies from the surface, and the outward faces a pressure acts on (docs/regions.md).

The body is the union of the points' cells: a cube of side h_i = V_i^(1/3) centred on each
point (exactly the body of a lattice). A point is a *surface point* when one of the six probes
``x_i +- h_i e_k`` (k = x, y, z) is farther than ``PROBE_GAP * h_i`` from every point: that face
of its cell is free. On a lattice a probe either lands on a point (distance 0) or is at least h
from every point, so the test is exact there; on irregular clouds (mesh element centroids) it is
an estimate. The distance of a point to the free surface is
``d_i = |x_i - x_s| + h_s / 2`` for its nearest surface point s: the distance to the free face of
s, exact for faces of a lattice that lie in a lattice plane (a box, the ends of a cylinder).

Everything is computed from the reference coordinates of all points, which every MPI rank
holds, so a rank count changes nothing.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PROBE_GAP", "Surface", "free_surface"]

#: a probe farther than this many spacings from every point is outside the body
PROBE_GAP = 0.75
#: the six probe directions, +x -x +y -y +z -z
DIRECTIONS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)


@dataclass
class Surface:
    """The free surface of a cloud of n points."""

    spacing: np.ndarray  #: (n,) h_i = V_i^(1/3) (L)
    free: np.ndarray  #: (n, 6) bool: the face of the cell in direction DIRECTIONS[k] is free
    nearest: np.ndarray  #: (n,) int64: the nearest surface point (itself for a surface point); -1 without any
    depth: np.ndarray  #: (n,) distance to the free surface, |x_i - x_s| + h_s / 2 (L); inf without any surface point

    @property
    def is_surface(self) -> np.ndarray:
        """(n,) bool: the point's cell has a free face."""
        return self.free.any(axis=1)

    def face_vectors(self) -> np.ndarray:
        """(n, 3) the sum of the outward free-face area vectors of each point's cell,
        ``h_i^2 sum_k free_ik e_k`` (L^2); zero off the surface. Over a closed lattice surface
        they sum to zero exactly, as the faces of any union of cubes do."""
        return (self.free.astype(float) @ DIRECTIONS) * (self.spacing**2)[:, None]


def free_surface(x: np.ndarray, volume: np.ndarray) -> Surface:
    """The free surface of the points ``x`` (n, 3) (L) with volumes ``volume`` (n,) (L^3)."""
    from scipy.spatial import cKDTree

    x = np.asarray(x, dtype=float)
    n = len(x)
    h = np.cbrt(np.asarray(volume, dtype=float))
    free = np.zeros((n, 6), dtype=bool)
    nearest = np.full(n, -1, dtype=np.int64)
    depth = np.full(n, np.inf)
    if n == 0:
        return Surface(h, free, nearest, depth)
    tree = cKDTree(x)
    for k, e in enumerate(DIRECTIONS):
        gap, _ = tree.query(x + h[:, None] * e, k=1)
        free[:, k] = gap > PROBE_GAP * h
    surface = np.flatnonzero(free.any(axis=1))
    if surface.size:
        dist, which = cKDTree(x[surface]).query(x, k=1)
        nearest = surface[which].astype(np.int64)
        depth = dist + 0.5 * h[nearest]
        nearest[surface] = surface  # a surface point is its own (a tie with a neighbour does not move it)
        depth[surface] = 0.5 * h[surface]
    return Surface(h, free, nearest, depth)
