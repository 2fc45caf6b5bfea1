"""Element-horizon intersections and partial volumes of hexahedral cells.

``Discretization > Compute Element-Horizon Intersections`` (PERIDIGM_MODELS.md §5.2, §14) makes
the family of a point the mesh elements that *intersect* its horizon sphere, and gives every bond
the part of the neighbour's cell that lies inside the sphere.

**Neighbour list** (reproduces Peridigm, ``removeNonintersectingNeighborsFromNeighborList`` and
``hexahedronSphereIntersection``): a Euclidean search of radius delta_i + h_max (h_max the
largest node-to-node distance of any element), then every candidate element is kept unless it
lies entirely outside the ball (x_i, delta_i): all 8 nodes strictly inside -> inside; some ->
intersects; none -> each face is split into four triangles around its barycentre and each is
tested with Ericson's separating-axis triangle/sphere test; all outside -> outside. List order
is kept.

**Partial volumes** (peridyn's own quadrature, written from the description of the deck
parameters; Peridigm's library for them is not public): the cell is the trilinear image of the
unit cube. A sub-cube is *inside* when its 8 mapped corners are strictly within the sphere and
then counts with its exact volume (Peridigm's 24-tetrahedra hexahedron volume of the mapped
corners); it is *outside* when its bounding ball (mapped centre, largest corner distance) does
not reach the sphere; otherwise it is split into 8 children, down to ``level`` levels, and a
finest cut sub-cube is integrated by ``samples``^3 midpoint samples of the indicator function,
each weighted by det J times its reference volume. An element classified inside at the top level
gets exactly its cell volume V_j; a cut cell's sum is not capped at V_j. Deterministic. Measured
accuracy (tests/unit/geometry/test_partial_volumes.py): one cut cell 2e-2 at the default level 2
/ 2 samples, falling roughly like (2^level samples)^-2.5; the neighbourhood volume of a grid converges
to 4/3 pi delta^3 with order ~2 in h. At the default settings the values equal Peridigm's
``Neighborhood_Volume`` of its ``NeighborhoodVolume`` case to round-off (docs/interfaces.md).

Bond fields (only when a model or compute asks for them):

* ``Neighbor_Volume`` of bond i->j: |cell_j ∩ B(x_i, delta_i)| (L^3);
* ``Self_Volume`` of bond i->j: |cell_i ∩ B(x_j, delta_j)| (L^3), the weight of the reaction on j.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, prange

__all__ = [
    "INSIDE",
    "INTERSECTS",
    "OUTSIDE",
    "PARTIAL_VOLUME_FIELDS",
    "fill_partial_volumes",
    "hexahedron_sphere_intersection",
    "intersecting_neighbors",
    "max_element_dimension",
    "partial_volume",
    "partial_volumes_kernel",
    "triangle_sphere_intersection",
]

INSIDE, INTERSECTS, OUTSIDE = 0, 1, 2
#: the bond fields this module fills
PARTIAL_VOLUME_FIELDS = ("Neighbor_Volume", "Self_Volume")

# the 4 triangles (node, node, face barycentre) of each hexahedron face, Peridigm's order
_FACE_NODES = np.array([[0, 1, 4, 5], [1, 2, 5, 6], [2, 3, 6, 7], [0, 3, 4, 7], [0, 1, 2, 3], [4, 5, 6, 7]], dtype=np.int64)
_FACE_TRIS = np.array(
    [
        [[1, 0], [5, 1], [4, 5], [0, 4]],
        [[2, 1], [6, 2], [5, 6], [1, 5]],
        [[3, 2], [7, 3], [6, 7], [2, 6]],
        [[0, 3], [3, 7], [7, 4], [4, 0]],
        [[0, 1], [1, 2], [2, 3], [3, 0]],
        [[5, 4], [4, 7], [7, 6], [6, 5]],
    ],
    dtype=np.int64,
)
# reference coordinates of the Exodus HEX8 nodes
_REF = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=np.float64)


@njit(cache=True, inline="always")
def _dot(a0, a1, a2, b0, b1, b2):
    return (a0 * b0 + a1 * b1) + a2 * b2


@njit(cache=True)
def triangle_sphere_intersection(p, q, r, c, radius):
    """Peridigm's ``triangleSphereIntersection`` (Ericson's separating-axis test), same
    operations: INSIDE (all three nodes strictly inside), INTERSECTS or OUTSIDE.
    p, q, r: (3,) triangle nodes; c: (3,) sphere centre; radius (L)."""
    A0, A1, A2 = p[0] - c[0], p[1] - c[1], p[2] - c[2]
    B0, B1, B2 = q[0] - c[0], q[1] - c[1], q[2] - c[2]
    C0, C1, C2 = r[0] - c[0], r[1] - c[1], r[2] - c[2]
    rr = radius * radius
    aa = _dot(A0, A1, A2, A0, A1, A2)
    bb = _dot(B0, B1, B2, B0, B1, B2)
    cc = _dot(C0, C1, C2, C0, C1, C2)
    inside = (1 if aa < rr else 0) + (1 if bb < rr else 0) + (1 if cc < rr else 0)
    if inside == 1 or inside == 2:
        return INTERSECTS
    if inside == 3:
        return INSIDE
    AB0, AB1, AB2 = B0 - A0, B1 - A1, B2 - A2
    BC0, BC1, BC2 = C0 - B0, C1 - B1, C2 - B2
    CA0, CA1, CA2 = A0 - C0, A1 - C1, A2 - C2
    T0, T1, T2 = C0 - A0, C1 - A1, C2 - A2
    N0 = AB1 * T2 - AB2 * T1
    N1 = AB2 * T0 - AB0 * T2
    N2 = AB0 * T1 - AB1 * T0
    d = _dot(A0, A1, A2, N0, N1, N2)
    e = _dot(N0, N1, N2, N0, N1, N2)
    if d * d / e > rr:
        return OUTSIDE
    ab = _dot(A0, A1, A2, B0, B1, B2)
    ac = _dot(A0, A1, A2, C0, C1, C2)
    bc = _dot(B0, B1, B2, C0, C1, C2)
    if ab > aa and ac > aa:
        return OUTSIDE
    if ab > bb and bc > bb:
        return OUTSIDE
    if ac > cc and bc > cc:
        return OUTSIDE
    # edges AB, BC, CA: the projection Q of the centre P = 0 on the edge's line
    for k in range(3):
        if k == 0:
            S0, S1, S2, E0, E1, E2, O0, O1, O2 = A0, A1, A2, AB0, AB1, AB2, C0, C1, C2
        elif k == 1:
            S0, S1, S2, E0, E1, E2, O0, O1, O2 = B0, B1, B2, BC0, BC1, BC2, A0, A1, A2
        else:
            S0, S1, S2, E0, E1, E2, O0, O1, O2 = C0, C1, C2, CA0, CA1, CA2, B0, B1, B2
        sp_e = _dot(0.0 - S0, 0.0 - S1, 0.0 - S2, E0, E1, E2)
        e_e = _dot(E0, E1, E2, E0, E1, E2)
        t = sp_e / e_e
        Q0, Q1, Q2 = S0 + t * E0, S1 + t * E1, S2 + t * E2
        QP0, QP1, QP2 = 0.0 - Q0, 0.0 - Q1, 0.0 - Q2
        qp_qp = _dot(QP0, QP1, QP2, QP0, QP1, QP2)
        qp_qo = _dot(QP0, QP1, QP2, O0 - Q0, O1 - Q1, O2 - Q2)
        if qp_qp > rr and qp_qo < 0.0:
            return OUTSIDE
    return INTERSECTS


@njit(cache=True)
def hexahedron_sphere_intersection(nodes, c, radius):
    """Peridigm's ``hexahedronSphereIntersection`` of an 8-node element. nodes (8, 3) (L),
    c (3,) sphere centre, radius (L). Returns INSIDE, INTERSECTS or OUTSIDE."""
    rr = radius * radius
    n_in = 0
    for k in range(8):
        dx = nodes[k, 0] - c[0]
        dy = nodes[k, 1] - c[1]
        dz = nodes[k, 2] - c[2]
        if (dx * dx + dy * dy) + dz * dz < rr:
            n_in += 1
    if n_in == 8:
        return INSIDE
    if n_in > 0:
        return INTERSECTS
    f = np.empty(3)
    all_outside = True
    for face in range(6):
        a, b, cc, d = _FACE_NODES[face, 0], _FACE_NODES[face, 1], _FACE_NODES[face, 2], _FACE_NODES[face, 3]
        for k in range(3):
            f[k] = 0.25 * (((nodes[a, k] + nodes[b, k]) + nodes[cc, k]) + nodes[d, k])
        for t in range(4):
            res = triangle_sphere_intersection(nodes[_FACE_TRIS[face, t, 0]], nodes[_FACE_TRIS[face, t, 1]], f, c, radius)
            if res == INTERSECTS:
                return INTERSECTS
            if res == INSIDE:
                all_outside = False
    return OUTSIDE if all_outside else INSIDE


def max_element_dimension(hex_nodes: np.ndarray) -> float:
    """Peridigm's ``computeMaxElementDimension``: sqrt of the largest squared node-to-node
    distance ((dx*dx + dy*dy) + dz*dz) over all element node pairs. hex_nodes (n, 8, 3) (L)."""
    best = 0.0
    for a in range(8):
        for b in range(a + 1, 8):
            d = hex_nodes[:, a, :] - hex_nodes[:, b, :]
            s = (d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2]
            if s.size:
                best = max(best, float(s.max()))
    return math.sqrt(best)


@njit(cache=True)
def _filter_kernel(points, offsets, neighbors, x, horizon, hex_nodes, keep):
    for q in range(points.shape[0]):
        p = points[q]
        for b in range(offsets[q], offsets[q + 1]):
            keep[b] = hexahedron_sphere_intersection(hex_nodes[neighbors[b]], x[p], horizon[p]) != OUTSIDE


def intersecting_neighbors(x: np.ndarray, horizon: np.ndarray, points: np.ndarray, hex_nodes: np.ndarray, dtype=np.int32) -> tuple[np.ndarray, np.ndarray]:
    """Peridigm's neighbour lists with element-horizon intersections.

    x (n, 3) element centroids (L); horizon (n,) (L); points (k,) int64 mothership indices whose
    rows are wanted; hex_nodes (n, 8, 3) element nodes (L). Returns CSR (offsets (k+1,) int64,
    neighbors ``dtype``) in ascending index order: the elements that are not entirely outside
    the ball (x_i, delta_i)."""
    from .neighbors import radius_search

    h_max = max_element_dimension(hex_nodes)
    offsets, neighbors = radius_search(x, horizon + h_max, points, dtype=np.int64)
    keep = np.zeros(neighbors.size, dtype=np.bool_)
    _filter_kernel(np.asarray(points, dtype=np.int64), offsets, neighbors, x, horizon, hex_nodes, keep)
    counts = np.add.reduceat(keep.astype(np.int64), offsets[:-1]) if neighbors.size else np.zeros(len(points), np.int64)
    counts[np.diff(offsets) == 0] = 0
    new = np.zeros(offsets.size, dtype=np.int64)
    np.cumsum(counts, out=new[1:])
    return new, neighbors[keep].astype(dtype)


# ------------------------------------------------------------------------------------------------
# the quadrature
# ------------------------------------------------------------------------------------------------
@njit(cache=True, inline="always")
def _map(nodes, u, v, w):
    """Trilinear image (X0, X1, X2) of reference point (u, v, w) and det J there (no allocation;
    shape functions and sums in node order)."""
    X0 = 0.0
    X1 = 0.0
    X2 = 0.0
    J00 = J01 = J02 = J10 = J11 = J12 = J20 = J21 = J22 = 0.0
    for k in range(8):
        ra = _REF[k, 0] == 1.0
        rb = _REF[k, 1] == 1.0
        rc = _REF[k, 2] == 1.0
        a = u if ra else 1.0 - u
        b = v if rb else 1.0 - v
        c = w if rc else 1.0 - w
        sa = 1.0 if ra else -1.0
        sb = 1.0 if rb else -1.0
        sc = 1.0 if rc else -1.0
        n = a * b * c
        du = sa * b * c
        dv = a * sb * c
        dw = a * b * sc
        p0, p1, p2 = nodes[k, 0], nodes[k, 1], nodes[k, 2]
        X0 += n * p0
        X1 += n * p1
        X2 += n * p2
        J00 += du * p0
        J01 += dv * p0
        J02 += dw * p0
        J10 += du * p1
        J11 += dv * p1
        J12 += dw * p1
        J20 += du * p2
        J21 += dv * p2
        J22 += dw * p2
    det = (J00 * (J11 * J22 - J12 * J21) - J01 * (J10 * J22 - J12 * J20)) + J02 * (J10 * J21 - J11 * J20)
    return X0, X1, X2, det


@njit(cache=True)
def partial_volume(nodes, c, radius, level, samples):
    """|cell ∩ B(c, radius)| (L^3) of a trilinear hexahedron by the adaptive quadrature of the
    module docstring. nodes (8, 3) (L); c (3,); level >= 0; samples >= 1."""
    rr = radius * radius
    # explicit stack of sub-cubes (u0, v0, w0, size, depth)
    cap = 8 * (level + 1) + 1
    su = np.empty(cap)
    sv = np.empty(cap)
    sw = np.empty(cap)
    sz = np.empty(cap)
    sd = np.empty(cap, dtype=np.int64)
    top = 0
    su[0] = 0.0
    sv[0] = 0.0
    sw[0] = 0.0
    sz[0] = 1.0
    sd[0] = 0
    top = 1
    total = 0.0
    p = np.empty((8, 3))  # scratch of _subhex_volume
    f = np.empty((6, 3))
    while top > 0:
        top -= 1
        u0, v0, w0, h, depth = su[top], sv[top], sw[top], sz[top], sd[top]
        # classify by the mapped corners and the bounding ball
        n_in = 0
        cx, cy, cz, _ = _map(nodes, u0 + 0.5 * h, v0 + 0.5 * h, w0 + 0.5 * h)
        rad2 = 0.0
        for k in range(8):
            X0, X1, X2, _ = _map(nodes, u0 + h * _REF[k, 0], v0 + h * _REF[k, 1], w0 + h * _REF[k, 2])
            dx, dy, dz = X0 - c[0], X1 - c[1], X2 - c[2]
            if (dx * dx + dy * dy) + dz * dz < rr:
                n_in += 1
            ex, ey, ez = X0 - cx, X1 - cy, X2 - cz
            rad2 = max(rad2, (ex * ex + ey * ey) + ez * ez)
        dc = math.sqrt(((cx - c[0]) ** 2 + (cy - c[1]) ** 2) + (cz - c[2]) ** 2)
        if n_in == 8:
            total += _subhex_volume(nodes, u0, v0, w0, h, p, f)
            continue
        if dc - math.sqrt(rad2) >= radius:
            continue
        if depth < level:
            half = 0.5 * h
            for a in range(2):
                for b in range(2):
                    for e in range(2):
                        su[top] = u0 + a * half
                        sv[top] = v0 + b * half
                        sw[top] = w0 + e * half
                        sz[top] = half
                        sd[top] = depth + 1
                        top += 1
            continue
        step = h / samples
        acc = 0.0
        for a in range(samples):
            for b in range(samples):
                for e in range(samples):
                    X0, X1, X2, det = _map(nodes, u0 + (a + 0.5) * step, v0 + (b + 0.5) * step, w0 + (e + 0.5) * step)
                    dx, dy, dz = X0 - c[0], X1 - c[1], X2 - c[2]
                    if (dx * dx + dy * dy) + dz * dz < rr:
                        acc += det
        total += acc * step * step * step
    return total


_TETS24 = np.array(
    [[1, 0, 0], [5, 1, 0], [4, 5, 0], [0, 4, 0], [2, 1, 1], [6, 2, 1], [5, 6, 1], [1, 5, 1], [3, 2, 2], [7, 3, 2], [6, 7, 2], [2, 6, 2],
     [0, 3, 3], [3, 7, 3], [7, 4, 3], [4, 0, 3], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [5, 4, 5], [4, 7, 5], [7, 6, 5], [6, 5, 5]],
    dtype=np.int64,
)


@njit(cache=True)
def hex_volume(p):
    """Peridigm's hexahedron volume (24 tetrahedra around the face centres and the centre,
    sequential sum; io/exodus_mesh.hex_centroid_and_volume). p (8, 3) nodes (L); returns L^3."""
    return _hex_volume(p, np.empty((6, 3)))


@njit(cache=True)
def _hex_volume(p, f):
    """hex_volume with the face-centre scratch f (6, 3) given."""
    for k in range(6):
        a, b, c, d = _FACE_NODES[k, 0], _FACE_NODES[k, 1], _FACE_NODES[k, 2], _FACE_NODES[k, 3]
        for q in range(3):
            f[k, q] = 0.25 * (((p[a, q] + p[b, q]) + p[c, q]) + p[d, q])
    ctr0 = 0.5 * (f[4, 0] + f[5, 0])
    ctr1 = 0.5 * (f[4, 1] + f[5, 1])
    ctr2 = 0.5 * (f[4, 2] + f[5, 2])
    vol = 0.0
    for t in range(24):
        A, B, F = _TETS24[t, 0], _TETS24[t, 1], _TETS24[t, 2]
        a0, a1, a2 = p[B, 0] - p[A, 0], p[B, 1] - p[A, 1], p[B, 2] - p[A, 2]
        b0, b1, b2 = f[F, 0] - p[A, 0], f[F, 1] - p[A, 1], f[F, 2] - p[A, 2]
        c0, c1, c2 = ctr0 - p[A, 0], ctr1 - p[A, 1], ctr2 - p[A, 2]
        vol += ((a0 * (b1 * c2 - b2 * c1) + a1 * (b2 * c0 - b0 * c2)) + a2 * (b0 * c1 - b1 * c0)) / 6.0
    return vol


@njit(cache=True)
def _subhex_volume(nodes, u0, v0, w0, h, p, f):
    """hex_volume of the sub-hexahedron whose corners are the images of the reference sub-cube's
    (p (8, 3), f (6, 3) scratch)."""
    for k in range(8):
        X0, X1, X2, _ = _map(nodes, u0 + h * _REF[k, 0], v0 + h * _REF[k, 1], w0 + h * _REF[k, 2])
        p[k, 0] = X0
        p[k, 1] = X1
        p[k, 2] = X2
    return _hex_volume(p, f)


@njit(cache=True, parallel=True)
def partial_volumes_kernel(start, stop, offsets, neighbors, x, horizon, nodes, volume, level, samples, nv, sv):
    """Partial volumes of the bonds of points [start, stop) (local indices).

    x (n, 3) centroids, horizon (n,), nodes (n, 8, 3) element nodes, volume (n,) cell volumes;
    nv (nb,) <- |cell_j ∩ B(x_i, delta_i)|; sv (nb,) <- |cell_i ∩ B(x_j, delta_j)| (skipped when
    empty). Elements entirely inside the ball get exactly V; a cut element's quadrature is not capped at V
    (the midpoint samples of a distorted cell can exceed it by round-off-sized amounts, as Peridigm's do)."""
    want_self = sv.shape[0] > 0
    for i in prange(start, stop):
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            where = hexahedron_sphere_intersection(nodes[j], x[i], horizon[i])
            if where == INSIDE:
                nv[b] = volume[j]
            elif where == OUTSIDE:
                nv[b] = 0.0
            else:
                nv[b] = partial_volume(nodes[j], x[i], horizon[i], level, samples)
            if want_self:
                where = hexahedron_sphere_intersection(nodes[i], x[j], horizon[j])
                if where == INSIDE:
                    sv[b] = volume[i]
                elif where == OUTSIDE:
                    sv[b] = 0.0
                else:
                    sv[b] = partial_volume(nodes[i], x[j], horizon[j], level, samples)


def fill_partial_volumes(sim: Any, hex_nodes: np.ndarray, level: int, samples: int, nv: np.ndarray | None = None, sv: np.ndarray | None = None) -> None:
    """Fill ``nv`` and ``sv`` (default: the ``Neighbor_Volume`` / ``Self_Volume`` bond fields
    when declared) for the owned points of ``sim``. hex_nodes (num_global, 8, 3) in mothership
    order. Points without a field are skipped; nothing is allocated here."""
    s = sim.fields
    if nv is None:
        nv = s.get("Neighbor_Volume", None)
    if sv is None:
        sv = s.get("Self_Volume", None)
    if nv is None and sv is None:
        return
    nl = sim.bonds
    nodes = np.ascontiguousarray(hex_nodes[sim.mothership_of_local])
    horizon = np.ascontiguousarray(sim.horizon_local, dtype=np.float64)
    nv_out = nv if nv is not None else np.zeros(nl.num_bonds)
    partial_volumes_kernel(0, sim.num_owned, nl.offsets, nl.neighbors, s["Model_Coordinates"], horizon, nodes, s["Volume"],
                           int(level), int(samples), nv_out, sv if sv is not None else np.zeros(0))
