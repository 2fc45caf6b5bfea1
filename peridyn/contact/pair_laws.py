"""The per-candidate and per-point pieces of contact, written once for every target.

The test of one candidate pair and its place in a row (``offer``: ``pair_visits``, ``row_insert``) are
device-agnostic functions: the CPU's cell-list search (``contact/search.py``) inlines them as
numba functions, the GPU's bucket search (``gpu/pair_search.py``) compiles the same Python as CUDA
device functions (``codegen.compile_function(..., retarget=True)``). Everything else a step does
with contact is a point law (``core/traversal.py``) that each backend compiles: the copy of the
padded rows into CSR pairs, the largest displacement since the last build, the smallest pair
distance and its running record, and the vector copies and sums of the schedule.

Shapes: positions (n, 3) (L), owned points 0:num_owned then contact ghosts (MPI); rows padded
to ``cap`` entries a point (``rows[p * cap + k]``), CSR pairs as in
:class:`~peridyn.core.interfaces.ContactPairs`.
"""
from __future__ import annotations

import math

from numba import njit

from ..core.interfaces import VISIT_FROM_PARTNER, VISIT_FROM_POINT
from ..core.traversal import PointReduction, PointUpdate


@njit(cache=True, inline="always")
def _bisect(values, lo, hi, key, table, indirect):
    """Whether the key of values[k] (table[values[k]] when ``indirect``, else values[k]) is
    ``key`` for some k in [lo, hi) (values sorted by their key)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        t = table[values[mid]] if indirect else values[mid]
        if t < key:
            lo = mid + 1
        elif t > key:
            hi = mid
        else:
            return True
    return False


@njit(cache=True, inline="always")
def in_sorted(values, lo, hi, key, table):
    """Whether table[values[k]] == key for some k in [lo, hi) (values sorted by table value)."""
    return _bisect(values, lo, hi, key, table, True)


@njit(cache=True, inline="always")
def in_sorted_plain(values, lo, hi, key):
    """Whether values[k] == key for some k in [lo, hi) (values sorted)."""
    return _bisect(values, lo, hi, key, values, False)


@njit(cache=True, inline="always")
def pair_visits(p, j, yj, t, y0, y1, y2, s, gid, x, near2, block, cross_block, rb2, rs2, bond_offsets, bond_neighbors,
                bond_gid, one_offsets, one_gid):
    """The visit bits (``VISIT_FROM_POINT`` | ``VISIT_FROM_PARTNER``; 0: not a pair) of candidate
    j != p of point p. (y0, y1, y2) = y_p and yj[t] = y_j: the current positions in whatever
    order the binning keeps them (L). A pair is kept when |y_j - y_p| <= r_b (rb2 = r_b^2),
    |s_j - s_p| <= R_s at the last search's positions s (rs2 = R_s^2; Peridigm's search list,
    PERIDIGM_CONTACT.md §3.3, both inclusive) and the two are not bonded both ways (broken bonds
    count). Bond rows (bond_offsets, bond_neighbors) are sorted by bond_gid[neighbor]; one_gid
    rows (sorted) are the partners bonded one way only. Shortcut: j is in p's bond list, without
    a search of it, when |x_j - x_p|^2 < near2[p] (reference positions x; near2 < 0 disables
    it) and the blocks agree or ``cross_block`` (bonds between blocks are kept)."""
    dx = yj[t, 0] - y0
    dy = yj[t, 1] - y1
    dz = yj[t, 2] - y2
    if not (dx * dx + dy * dy) + dz * dz <= rb2:
        return 0
    ex = s[j, 0] - s[p, 0]
    ey = s[j, 1] - s[p, 1]
    ez = s[j, 2] - s[p, 2]
    if not (ex * ex + ey * ey) + ez * ez <= rs2:
        return 0
    gj = gid[j]
    fx = x[j, 0] - x[p, 0]
    fy = x[j, 1] - x[p, 1]
    fz = x[j, 2] - x[p, 2]
    if (fx * fx + fy * fy) + fz * fz < near2[p] and (cross_block or block[j] == block[p]):
        node = False
    else:
        node = not in_sorted(bond_neighbors, bond_offsets[p], bond_offsets[p + 1], gj, bond_gid)
    partner = node
    if one_offsets[p + 1] > one_offsets[p] and in_sorted_plain(one_gid, one_offsets[p], one_offsets[p + 1], gj):
        partner = not node
    if not (node or partner):
        return 0
    return (VISIT_FROM_POINT if node else 0) | (VISIT_FROM_PARTNER if partner else 0)


@njit(cache=True, inline="always")
def row_insert(rows, row_visits, base, cnt, cap, j, bits, gid):
    """Pair (j, bits) into the row rows[base : base + cnt] (sorted by gid, ``cnt`` entries so
    far), kept sorted; nothing is written when the row is full (cnt >= cap): the caller counts
    the pair all the same and the row is gathered again with a larger capacity."""
    if cnt < cap:
        gj = gid[j]
        k = cnt
        while k > 0 and gid[rows[base + k - 1]] > gj:
            rows[base + k] = rows[base + k - 1]
            row_visits[base + k] = row_visits[base + k - 1]
            k -= 1
        rows[base + k] = j
        row_visits[base + k] = bits


@njit(cache=True, inline="always")
def offer(p, j, yj, t, y0, y1, y2, s, gid, x, near2, block, cross_block, rb2, rs2, bond_offsets, bond_neighbors, bond_gid,
          one_offsets, one_gid, rows, row_visits, base, cnt, cap):
    """Candidate j of point p tested (``pair_visits``, the arguments up to ``one_gid``) and, a
    pair, placed in p's row (``row_insert``, the rest). Returns the row's new count."""
    bits = pair_visits(p, j, yj, t, y0, y1, y2, s, gid, x, near2, block, cross_block, rb2, rs2, bond_offsets, bond_neighbors,
                       bond_gid, one_offsets, one_gid)
    if not bits:
        return cnt
    row_insert(rows, row_visits, base, cnt, cap, j, bits, gid)
    return cnt + 1


def _compact(p, args):
    """Row p of the padded buffer into the CSR arrays; args (cap, rows, row_visits, offsets,
    partners, visits)."""
    cap, rows, row_visits, offsets, partners, visits = args
    base = p * cap
    o = offsets[p]
    for k in range(offsets[p + 1] - o):
        partners[o + k] = rows[base + k]
        visits[o + k] = row_visits[base + k]


def _displacement2(i, args):
    """|y_i - y0_i|^2 (L^2), a NaN counted as infinity (a rebuild); args (y, y0)."""
    y, y0 = args
    dx = y[i, 0] - y0[i, 0]
    dy = y[i, 1] - y0[i, 1]
    dz = y[i, 2] - y0[i, 2]
    d = (dx * dx + dy * dy) + dz * dz
    return d if d == d else math.inf


def _row_min_distance2(p, args):
    """The smallest squared distance (L^2) of point p's listed pairs (inf for none); args
    (offsets, partners, y)."""
    offsets, partners, y = args
    m = math.inf
    for q in range(offsets[p], offsets[p + 1]):
        j = partners[q]
        dx = y[j, 0] - y[p, 0]
        dy = y[j, 1] - y[p, 1]
        dz = y[j, 2] - y[p, 2]
        d = (dx * dx + dy * dy) + dz * dz
        if d < m:
            m = d
    return m


def _track_min_distance(i, args):
    """running = (smallest pair distance so far (L), its time (T)) updated by this step's
    smallest squared distance step_min[0] at time t; args (step_min, running, t); one item."""
    step_min, running, t = args
    d2 = step_min[0]
    md = running[0]
    if d2 < md * md:
        running[0] = math.sqrt(d2)
        running[1] = t


def _copy_vectors(i, args):
    """out[i, :] = values[i, :]; args (values, out)."""
    values, out = args
    for c in range(3):
        out[i, c] = values[i, c]


def _add_vectors(i, args):
    """out[i, :] += values[i, :]; args (values, out)."""
    values, out = args
    for c in range(3):
        out[i, c] += values[i, c]


COMPACT = PointUpdate(_compact)
MAX_DISPLACEMENT2 = PointReduction(_displacement2, combine="max")
MIN_PAIR_DISTANCE2 = PointReduction(_row_min_distance2, combine="min")
TRACK_MIN_DISTANCE = PointUpdate(_track_min_distance)
COPY_VECTORS = PointUpdate(_copy_vectors)
ADD_VECTORS = PointUpdate(_add_vectors)
