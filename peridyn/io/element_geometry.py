"""Exact volumes and volume centroids of linear 3-D elements (tet, hex, wedge, pyramid).

An element is the region bounded by its faces: triangles are flat, quadrilaterals are bilinear
patches (hyperbolic paraboloids, flat when the four corners are coplanar). That region is the
image of the element's linear map (tet), trilinear map (hex), linear-triangle x linear map
(wedge) and collapsed-hex map (pyramid), so the results are the exact volume and centroid of the
element as a finite-element code sees it, also for hexahedra with warped faces.

Both follow from the divergence theorem over the faces (n the outward normal):

    V = 1/3 sum_faces int x . n dA,        int x_i dV = 1/2 sum_faces int x_i^2 n_i dA.

On a bilinear patch x(u, v), n dA = (x_u x x_v) du dv has degree 1 in u and in v, so the
integrands have degree at most 3 in each of u and v, and the 2 x 2 Gauss rule integrates them
exactly. A triangle is the patch (a, b, c, c). Tetrahedra use the closed forms a.(b x c)/6 and
the mean of the corners.

Node order is meshio's (VTK's; the wedge as gmsh numbers it):

* tet 0-3: the right-hand normal of (0, 1, 2) points to node 3;
* hex 0-7: (0, 1, 2, 3) one face, (4, 5, 6, 7) the opposite, i + 4 above i, the right-hand normal
  of (0, 1, 2, 3) pointing to the other face;
* wedge 0-5: triangles (0, 1, 2) and (3, 4, 5), i + 3 above i, the normal of (0, 1, 2) pointing
  to the other triangle;
* pyramid 0-4: base (0, 1, 2, 3), apex 4, the base normal pointing to the apex.

An element is *inverted or degenerate* when its volume, or the volume of one of its corner
tetrahedra (a corner and its neighbours along the edges, in right-hand order), is not above
1e-12 l^3, l the element's longest edge: a negative value is an inverted element, a value near 0
a flat one (or a corner with a straight angle).
"""
from __future__ import annotations

import numpy as np

__all__ = ["CORNERS", "element_centroids_and_volumes", "bad_elements"]

#: number of corner nodes of each element family
CORNERS = {"tetra": 4, "hexahedron": 8, "wedge": 6, "pyramid": 5}

# faces with outward right-hand order; a triangle repeats its last node (a collapsed patch)
_FACES = {
    "hexahedron": ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)),
    "wedge": ((0, 2, 1, 1), (3, 4, 5, 5), (0, 1, 4, 3), (1, 2, 5, 4), (2, 0, 3, 5)),
    "pyramid": ((0, 3, 2, 1), (0, 1, 4, 4), (1, 2, 4, 4), (2, 3, 4, 4), (3, 0, 4, 4)),
}
# corner tetrahedra (corner, three edge neighbours in right-hand order)
_CORNER_TETS = {
    "tetra": ((0, 1, 2, 3),),
    "hexahedron": ((0, 1, 3, 4), (1, 2, 0, 5), (2, 3, 1, 6), (3, 0, 2, 7),
                   (4, 7, 5, 0), (5, 4, 6, 1), (6, 5, 7, 2), (7, 6, 4, 3)),
    "wedge": ((0, 1, 2, 3), (1, 2, 0, 4), (2, 0, 1, 5), (3, 5, 4, 0), (4, 3, 5, 1), (5, 4, 3, 2)),
    "pyramid": ((0, 1, 3, 4), (1, 2, 0, 4), (2, 3, 1, 4), (3, 0, 2, 4)),
}
_EDGES = {
    "tetra": ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)),
    "hexahedron": ((0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)),
    "wedge": ((0, 1), (1, 2), (2, 0), (3, 4), (4, 5), (5, 3), (0, 3), (1, 4), (2, 5)),
    "pyramid": ((0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 4), (2, 4), (3, 4)),
}
_GAUSS = (0.5 - 0.5 / np.sqrt(3.0), 0.5 + 0.5 / np.sqrt(3.0))  # on [0, 1], weights 1/2 each
#: volumes not above this times the cube of the longest edge are degenerate
DEGENERATE = 1e-12


def _tet_volumes(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Signed volumes (b - a).((c - a) x (d - a))/6; arguments (m, 3), result (m,)."""
    return np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) / 6.0


def element_centroids_and_volumes(family: str, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact volume centroids and signed volumes of linear elements.

    Parameters
    ----------
    family: ``"tetra"``, ``"hexahedron"``, ``"wedge"`` or ``"pyramid"``.
    nodes: (m, k, 3) corner coordinates (L), k = ``CORNERS[family]``, in the module's node order.

    Returns
    -------
    centroid (m, 3) (L; NaN where the volume is 0) and volume (m,) (L^3, negative for an
    element numbered inside out).
    """
    if family == "tetra":
        volume = _tet_volumes(nodes[:, 0], nodes[:, 1], nodes[:, 2], nodes[:, 3])
        return nodes.mean(axis=1), volume
    m = nodes.shape[0]
    volume = np.zeros(m)
    moment = np.zeros((m, 3))
    for ia, ib, ic, id_ in _FACES[family]:
        a, b, c, d = nodes[:, ia], nodes[:, ib], nodes[:, ic], nodes[:, id_]
        for u in _GAUSS:
            for v in _GAUSS:
                x = (1 - u) * (1 - v) * a + u * (1 - v) * b + u * v * c + (1 - u) * v * d
                xu = (1 - v) * (b - a) + v * (c - d)
                xv = (1 - u) * (d - a) + u * (c - b)
                n = np.cross(xu, xv)  # outward normal times the area element
                volume += 0.25 * np.einsum("ij,ij->i", x, n) / 3.0
                moment += 0.25 * 0.5 * x * x * n
    with np.errstate(invalid="ignore", divide="ignore"):
        centroid = moment / volume[:, None]
    return centroid, volume


def bad_elements(family: str, nodes: np.ndarray, volume: np.ndarray) -> np.ndarray:
    """Indices (ascending, int64) of the inverted or degenerate elements (module docstring).

    ``nodes``: (m, k, 3) corners; ``volume``: (m,) their volumes from
    :func:`element_centroids_and_volumes`.
    """
    longest = np.zeros(nodes.shape[0])
    for i, j in _EDGES[family]:
        longest = np.maximum(longest, np.linalg.norm(nodes[:, i] - nodes[:, j], axis=1))
    floor = DEGENERATE * longest**3
    bad = ~(volume > floor)
    for i, j, k, l in _CORNER_TETS[family]:
        bad |= ~(_tet_volumes(nodes[:, i], nodes[:, j], nodes[:, k], nodes[:, l]) > floor)
    return np.flatnonzero(bad)
