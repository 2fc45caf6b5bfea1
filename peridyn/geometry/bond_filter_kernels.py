"""The cut tests of the bond filters as numba kernels, with Peridigm's formulas, operation order
and tolerances (see :mod:`peridyn.geometry.bond_filters`)."""
from __future__ import annotations

import math

from numba import njit, prange

PLANE_PARALLEL_TOL = 1.0e-14  #: |den| below this: the bond is parallel to a Rectangular_Plane
PLANE_EDGE_TOL = 1.0e-15  #: slack of the in-rectangle test
DISK_PARALLEL_TOL = 1.0e-15  #: |den| below this: the bond is parallel to a Disk
POLYGON_TOL = 1.0e-14  #: parallel test and barycentric slack of triangles and quads

#: element types an Exodus Mesh filter accepts (upper-cased, as Peridigm compares them)
POLYGON_ELEMENT_TYPES = ("TRI", "TRI3", "TRIANGLE", "QUAD", "QUAD4")


# ------------------------------------------------------------------------------------------------
# Kernels
# ------------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def _plane_kernel(x, offsets, neighbors, rows, n, r0, ua, ub, a, b, flags):
    """Rectangular_Plane test (FinitePlane::bondIntersectInfinitePlane + bondIntersect).

    Serial: a few flops per bond (tens of millions of bonds per second), and a serial kernel
    compiles in a third of the time of a parallel one.

    x (n_pts,3) float64 positions; offsets (k+1,) int64; neighbors (B,) int; rows (k,) int64 the
    point of each row; n, r0, ua, ub (3,) float64 normal, corner, side and bottom directions;
    a side length, b bottom length; flags (B,) bool, set to True where cut (never cleared).
    """
    zero = PLANE_EDGE_TOL
    one = 1.0 + zero
    for r in range(offsets.size - 1):
        i = rows[r]
        p00 = x[i, 0]
        p01 = x[i, 1]
        p02 = x[i, 2]
        num = (r0[0] - p00) * n[0] + (r0[1] - p01) * n[1] + (r0[2] - p02) * n[2]
        for bd in range(offsets[r], offsets[r + 1]):
            if flags[bd]:
                continue
            j = neighbors[bd]
            e0 = x[j, 0] - p00
            e1 = x[j, 1] - p01
            e2 = x[j, 2] - p02
            den = e0 * n[0] + e1 * n[1] + e2 * n[2]
            if abs(den) < PLANE_PARALLEL_TOL:
                continue
            t = num / den
            if t >= 0.0 and t <= 1.0:
                d0 = (p00 + t * e0) - r0[0]
                d1 = (p01 + t * e1) - r0[1]
                d2 = (p02 + t * e2) - r0[2]
                aa = d0 * ua[0] + d1 * ua[1] + d2 * ua[2]
                bb = d0 * ub[0] + d1 * ub[1] + d2 * ub[2]
                if -zero < aa and aa / a < one and -zero < bb and bb / b < one:
                    flags[bd] = True


@njit(cache=True, error_model="numpy")
def _disk_kernel(x, offsets, neighbors, rows, c, n, radius, flags):
    """Disk test (DiskFilter::bondIntersectsDisk). Arguments as :func:`_plane_kernel`; c (3,)
    center, n (3,) normal, radius (length)."""
    r2 = radius * radius
    for r in range(offsets.size - 1):
        i = rows[r]
        p00 = x[i, 0]
        p01 = x[i, 1]
        p02 = x[i, 2]
        num = (c[0] - p00) * n[0] + (c[1] - p01) * n[1] + (c[2] - p02) * n[2]
        for bd in range(offsets[r], offsets[r + 1]):
            if flags[bd]:
                continue
            j = neighbors[bd]
            e0 = x[j, 0] - p00
            e1 = x[j, 1] - p01
            e2 = x[j, 2] - p02
            den = e0 * n[0] + e1 * n[1] + e2 * n[2]
            if abs(den) < DISK_PARALLEL_TOL:
                continue
            t = num / den
            if t < 0.0 or t > 1.0:
                continue
            q0 = (p00 + t * e0) - c[0]
            q1 = (p01 + t * e1) - c[1]
            q2 = (p02 + t * e2) - c[2]
            if q0 * q0 + q1 * q1 + q2 * q2 < r2:
                flags[bd] = True


@njit(cache=True, error_model="numpy")
def _in_triangle(a0, a1, a2, b0, b1, b2, c0, c1, c2, tol):
    """Barycentric test of TriangleFilter::pointInTriangle; a = v3 - v1, b = v2 - v1, c = X - v1."""
    dot00 = a0 * a0 + a1 * a1 + a2 * a2
    dot01 = a0 * b0 + a1 * b1 + a2 * b2
    dot02 = a0 * c0 + a1 * c1 + a2 * c2
    dot11 = b0 * b0 + b1 * b1 + b2 * b2
    dot12 = b0 * c0 + b1 * c1 + b2 * c2
    alpha = (dot11 * dot02 - dot01 * dot12) / (dot00 * dot11 - dot01 * dot01)
    beta = (dot00 * dot12 - dot01 * dot02) / (dot00 * dot11 - dot01 * dot01)
    return (alpha > -tol) and (beta > -tol) and (alpha + beta < 1.0 + 2.0 * tol)


@njit(cache=True, error_model="numpy")
def _polygon_cuts(V, nv, normal, k, p00, p01, p02, p10, p11, p12):
    """Whether segment p0 -> p1 crosses polygon k (TriangleFilter / QuadFilter).

    V (m,4,3) float64 vertices (v1..v4; v4 unused for triangles); nv (m,) int64 vertex counts
    (3 or 4); normal (m,3) float64 unit normals as Peridigm computes them.
    """
    n0 = normal[k, 0]
    n1 = normal[k, 1]
    n2 = normal[k, 2]
    v10 = V[k, 0, 0]
    v11 = V[k, 0, 1]
    v12 = V[k, 0, 2]
    num = (v10 - p00) * n0 + (v11 - p01) * n1 + (v12 - p02) * n2
    den = (p10 - p00) * n0 + (p11 - p01) * n1 + (p12 - p02) * n2
    if abs(den) < POLYGON_TOL:
        return False
    t = num / den
    if t < 0.0 or t > 1.0:
        return False
    X0 = p00 + t * (p10 - p00)
    X1 = p01 + t * (p11 - p01)
    X2 = p02 + t * (p12 - p02)
    a0 = V[k, 2, 0] - v10
    a1 = V[k, 2, 1] - v11
    a2 = V[k, 2, 2] - v12
    b0 = V[k, 1, 0] - v10
    b1 = V[k, 1, 1] - v11
    b2 = V[k, 1, 2] - v12
    c0 = X0 - v10
    c1 = X1 - v11
    c2 = X2 - v12
    if _in_triangle(a0, a1, a2, b0, b1, b2, c0, c1, c2, POLYGON_TOL):
        return True
    if nv[k] == 4:
        d0 = V[k, 3, 0] - v10
        d1 = V[k, 3, 1] - v11
        d2 = V[k, 3, 2] - v12
        return _in_triangle(a0, a1, a2, d0, d1, d2, c0, c1, c2, POLYGON_TOL)
    return False


@njit(parallel=True, cache=True, error_model="numpy")
def _polygons_kernel(x, offsets, neighbors, rows, V, nv, normal, plo, phi, always,
                     glo, cs, dims, cell_start, cell_polys, flags):
    """Exodus Mesh test of every bond against the polygons near it.

    Arguments as :func:`_plane_kernel`, plus the polygons (see :func:`_polygon_cuts`), their
    padded bounding boxes plo, phi (m,3); ``always`` (a,) int64 polygons tested against every
    bond (ill-conditioned ones); the grid: glo (3,) origin, cs (3,) cell edges, dims (3,) int64
    cells per axis, cell_start (ncells+1,) int64 and cell_polys the polygons of each cell.
    """
    nx = dims[0]
    ny = dims[1]
    nz = dims[2]
    ghi0 = glo[0] + cs[0] * nx
    ghi1 = glo[1] + cs[1] * ny
    ghi2 = glo[2] + cs[2] * nz
    for r in prange(offsets.size - 1):
        i = rows[r]
        p00 = x[i, 0]
        p01 = x[i, 1]
        p02 = x[i, 2]
        for bd in range(offsets[r], offsets[r + 1]):
            if flags[bd]:
                continue
            j = neighbors[bd]
            p10 = x[j, 0]
            p11 = x[j, 1]
            p12 = x[j, 2]
            cut = False
            for q in range(always.size):
                if _polygon_cuts(V, nv, normal, always[q], p00, p01, p02, p10, p11, p12):
                    cut = True
                    break
            if not cut:
                lo0 = min(p00, p10)
                hi0 = max(p00, p10)
                lo1 = min(p01, p11)
                hi1 = max(p01, p11)
                lo2 = min(p02, p12)
                hi2 = max(p02, p12)
                if (hi0 >= glo[0] and lo0 <= ghi0 and hi1 >= glo[1] and lo1 <= ghi1
                        and hi2 >= glo[2] and lo2 <= ghi2):
                    ix0 = min(max(int(math.floor((lo0 - glo[0]) / cs[0])), 0), nx - 1)
                    ix1 = min(max(int(math.floor((hi0 - glo[0]) / cs[0])), 0), nx - 1)
                    iy0 = min(max(int(math.floor((lo1 - glo[1]) / cs[1])), 0), ny - 1)
                    iy1 = min(max(int(math.floor((hi1 - glo[1]) / cs[1])), 0), ny - 1)
                    iz0 = min(max(int(math.floor((lo2 - glo[2]) / cs[2])), 0), nz - 1)
                    iz1 = min(max(int(math.floor((hi2 - glo[2]) / cs[2])), 0), nz - 1)
                    for iz in range(iz0, iz1 + 1):
                        for iy in range(iy0, iy1 + 1):
                            for ix in range(ix0, ix1 + 1):
                                cell = (iz * ny + iy) * nx + ix
                                for s in range(cell_start[cell], cell_start[cell + 1]):
                                    k = cell_polys[s]
                                    if (phi[k, 0] < lo0 or plo[k, 0] > hi0 or phi[k, 1] < lo1
                                            or plo[k, 1] > hi1 or phi[k, 2] < lo2 or plo[k, 2] > hi2):
                                        continue
                                    if _polygon_cuts(V, nv, normal, k, p00, p01, p02, p10, p11, p12):
                                        cut = True
                                        break
                                if cut:
                                    break
                            if cut:
                                break
                        if cut:
                            break
            if cut:
                flags[bd] = True


