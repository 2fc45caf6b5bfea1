"""The CSR bond structure every kernel uses (DESIGN.md decision 6).

The bonds of point ``i`` are ``neighbors[offsets[i]:offsets[i+1]]``, and any per-bond array (bond
damage, partial volumes) is aligned with ``neighbors``. Lists are *full*: a bond i->j is stored in
i's row and, when j's family contains i, also as j->i in j's row. With horizons that differ
between points the relation can be one-sided (j in i's family, i not in j's):
:meth:`NeighborList.reverse` is then -1 for that bond and the incoming bonds of a point are found
through :meth:`NeighborList.transpose`.

Memory: a :class:`NeighborList` costs 4 bytes per bond (int32 ``neighbors``) plus 8 bytes per
point (int64 ``offsets``); :meth:`~NeighborList.reverse` adds 4 bytes per bond, and
:meth:`~NeighborList.transpose` and :meth:`~NeighborList.sources` another 4 each, only when asked.
The kernels loop over rows with ``prange`` and every iteration writes only its own row.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit, prange

__all__ = ["NeighborList", "shellsort", "shell_argsort"]

INT32_MAX = np.iinfo(np.int32).max


# ------------------------------------------------------------------------------------------------
# Small sorts (hand-written: numba's generic sort/argsort take seconds to compile)
# ------------------------------------------------------------------------------------------------
_GAPS = np.array([1, 4, 10, 23, 57, 132, 301, 701, 1750, 4376, 10941, 27353, 68383, 170958,
                  427396, 1068491, 2671228, 6678071, 16695178, 41737946, 104344866, 260862166,
                  652155416, 1630388541], dtype=np.int64)


@njit(cache=True)
def shellsort(a, lo, hi):
    """Sort a[lo:hi] ascending in place (Shell sort, Ciura gaps, then x2.5)."""
    n = hi - lo
    g = 0
    while g + 1 < _GAPS.size and _GAPS[g + 1] < n:
        g += 1
    while g >= 0:
        gap = _GAPS[g]
        for i in range(lo + gap, hi):
            v = a[i]
            j = i
            while j - gap >= lo and a[j - gap] > v:
                a[j] = a[j - gap]
                j -= gap
            a[j] = v
        g -= 1


@njit(cache=True)
def shell_argsort(vals, perm):
    """perm[:] = the permutation sorting vals ascending, ties by position (so: stable)."""
    n = vals.size
    for i in range(n):
        perm[i] = i
    g = 0
    while g + 1 < _GAPS.size and _GAPS[g + 1] < n:
        g += 1
    while g >= 0:
        gap = _GAPS[g]
        for i in range(gap, n):
            p = perm[i]
            v = vals[p]
            j = i
            while j >= gap:
                q = perm[j - gap]
                w = vals[q]
                if w > v or (w == v and q > p):
                    perm[j] = q
                    j -= gap
                else:
                    break
            perm[j] = p
        g -= 1


# ------------------------------------------------------------------------------------------------
# The CSR structure
# ------------------------------------------------------------------------------------------------
@dataclass(eq=False)
class NeighborList:
    """Bonds of ``num_points`` points in CSR form.

    Attributes
    ----------
    offsets: int64, shape (n+1,); row i is ``neighbors[offsets[i]:offsets[i+1]]``.
    neighbors: int32, shape (num_bonds,); local point index of the far end of each bond. A row
        must not hold the same point twice (true of every list the search produces).
    row_key: optional, shape (>= num_targets,), integer or float; when every row is in ascending
        ``row_key[neighbor]`` order (e.g. rows sorted by global id with :func:`sort_rows`), give
        it and :meth:`reverse` searches by key (fast) instead of sorting each row first. Ignored
        (the general method runs) if some row is not in that order.

    Derived arrays (:meth:`reverse`, :meth:`transpose`, :meth:`sources`) are computed on first
    use and cached; the arrays must not be modified afterwards (make a new ``NeighborList``).
    """

    offsets: np.ndarray
    neighbors: np.ndarray
    row_key: np.ndarray | None = None
    _reverse: np.ndarray | None = field(default=None, init=False, repr=False)
    _transpose: tuple[np.ndarray, np.ndarray] | None = field(default=None, init=False, repr=False)
    _sources: np.ndarray | None = field(default=None, init=False, repr=False)
    _derived: dict = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self) -> None:
        self.offsets = np.ascontiguousarray(self.offsets, dtype=np.int64)
        nb = np.asarray(self.neighbors)
        if nb.dtype != np.int32:
            if nb.size and (nb.max() > INT32_MAX or nb.min() < 0):
                raise ValueError("neighbor indices do not fit in int32")
            nb = nb.astype(np.int32)
        self.neighbors = np.ascontiguousarray(nb)
        if self.row_key is not None:
            self.row_key = np.ascontiguousarray(self.row_key)
            if self.neighbors.size and self.row_key.size <= int(self.neighbors.max()):
                raise ValueError("row_key must have an entry for every point a bond names")
        if self.offsets.ndim != 1 or self.offsets.size < 1:
            raise ValueError("offsets must be a 1-D array of length num_points + 1")
        if self.offsets[0] != 0 or self.offsets[-1] != self.neighbors.size:
            raise ValueError(
                f"offsets[0] must be 0 and offsets[-1] ({self.offsets[-1]}) must equal the number "
                f"of bonds ({self.neighbors.size})"
            )
        if self.neighbors.size > INT32_MAX:
            raise ValueError("more than 2**31 - 1 bonds: bond positions do not fit in int32")

    @property
    def num_points(self) -> int:
        """Number of rows (points with a neighbor list)."""
        return int(self.offsets.size - 1)

    @property
    def num_bonds(self) -> int:
        """Total number of bonds (entries of ``neighbors``)."""
        return int(self.neighbors.size)

    def counts(self) -> np.ndarray:
        """Neighbors per point: int64, shape (num_points,)."""
        return np.diff(self.offsets)

    def reverse(self) -> np.ndarray:
        """Position of the opposite bond: int32, shape (num_bonds,).

        For bond b = i->j, ``reverse()[b]`` is the position of j->i in j's row, or -1 when j's row
        does not contain i (one-sided family) or j has no row (j >= num_points). Exact for any row
        order. Cost: O(B log d) with B bonds and d bonds per row, by binary search of i in row j
        when rows are in ascending index order or in ascending ``row_key`` order; otherwise each
        row's sorting permutation is computed first (O(B d^0.3) more, and an int32 temporary of
        B entries while it runs).
        """
        if self._reverse is None:
            out = np.empty(self.num_bonds, dtype=np.int32)
            if self.num_bonds:
                if _count_unsorted_rows(self.offsets, self.neighbors) == 0:
                    _reverse_sorted(self.offsets, self.neighbors, out)
                elif self.row_key is not None and _count_unsorted_rows_by_key(
                    self.offsets, self.neighbors, self.row_key
                ) == 0:
                    _reverse_keyed(self.offsets, self.neighbors, self.row_key, out)
                else:
                    perm = _row_argsort(self.offsets, self.neighbors)
                    _reverse_perm(self.offsets, self.neighbors, perm, out)
                    del perm
            self._reverse = out
        return self._reverse

    def num_targets(self) -> int:
        """Number of points bonds can point to: max(num_points, max neighbor + 1)."""
        if self.num_bonds == 0:
            return self.num_points
        return max(self.num_points, int(self.neighbors.max()) + 1)

    def transpose(self) -> tuple[np.ndarray, np.ndarray]:
        """Incoming bonds of every point: ``(in_offsets, in_bonds)``.

        ``in_offsets`` int64, shape (m+1,) with m = :meth:`num_targets` (= num_points unless bonds
        point past the last row); ``in_bonds[in_offsets[t]:in_offsets[t+1]]`` (int32) are the
        positions b of the bonds whose target is t, in ascending source order. O(B), serial
        counting sort. When :meth:`reverse` has been computed, every bond has a reverse and the
        rows are ascending, the answer is ``(offsets, reverse())`` itself (no new memory).
        """
        if self._transpose is None:
            if (
                self._reverse is not None
                and (self.num_bonds == 0 or int(self._reverse.min()) >= 0)
                and _count_unsorted_rows(self.offsets, self.neighbors) == 0
            ):
                self._transpose = (self.offsets, self._reverse)
                return self._transpose
            m = self.num_targets()
            in_offsets = np.zeros(m + 1, dtype=np.int64)
            in_bonds = np.empty(self.num_bonds, dtype=np.int32)
            if self.num_bonds:
                _transpose_fill(self.offsets, self.neighbors, in_offsets, in_bonds)
            self._transpose = (in_offsets, in_bonds)
        return self._transpose

    def sources(self) -> np.ndarray:
        """Owner point of every bond: int32, shape (num_bonds,)."""
        if self._sources is None:
            self._sources = np.repeat(np.arange(self.num_points, dtype=np.int32), self.counts())
        return self._sources

    def derived(self, key: str, make):
        """``make()`` computed once and kept with the list (arrays that depend only on the bonds
        and on data fixed for the list's life, e.g. reference positions); None results are kept.
        Arrays and tuples of arrays among them count in :meth:`nbytes`."""
        if key not in self._derived:
            self._derived[key] = make()
        return self._derived[key]

    def nbytes(self) -> int:
        """Bytes held: offsets, neighbors and whichever derived arrays have been computed."""
        total = self.offsets.nbytes + self.neighbors.nbytes
        if self._reverse is not None:
            total += self._reverse.nbytes
        if self._transpose is not None:
            total += self._transpose[0].nbytes + self._transpose[1].nbytes
        if self._sources is not None:
            total += self._sources.nbytes
        for value in self._derived.values():
            for a in value if isinstance(value, tuple) else (value,):
                total += getattr(a, "nbytes", 0)
        return int(total)


@njit(cache=True)
def _count_unsorted_rows(offsets, neighbors):
    """Number of rows not in strictly ascending order. offsets (n+1,), neighbors (B,)."""
    n = offsets.size - 1
    bad = 0
    for i in range(n):
        for b in range(offsets[i] + 1, offsets[i + 1]):
            if neighbors[b] <= neighbors[b - 1]:
                bad += 1
                break
    return bad


@njit(parallel=True, cache=True)
def _reverse_sorted(offsets, neighbors, out):
    """reverse() when every row is ascending: find i in row j. out int32 (B,).

    First guess: for bond number k of row i (d_i bonds), i is bond d_j - 1 - k of row j, which
    holds whenever the two neighborhoods mirror each other (the interior of a lattice); a
    binary search of row j otherwise.
    """
    n = offsets.size - 1
    for i in prange(n):
        s = offsets[i]
        di = offsets[i + 1] - s
        for b in range(s, s + di):
            j = neighbors[b]
            r = -1
            if j >= 0 and j < n:
                lo = offsets[j]
                end = offsets[j + 1]
                g = end - 1 - (b - s)
                if g >= lo and neighbors[g] == i:
                    r = g
                else:
                    hi = end
                    while lo < hi:
                        mid = (lo + hi) >> 1
                        if neighbors[mid] < i:
                            lo = mid + 1
                        else:
                            hi = mid
                    if lo < end and neighbors[lo] == i:
                        r = lo
            out[b] = r


@njit(cache=True)
def _count_unsorted_rows_by_key(offsets, neighbors, key):
    """Number of rows not in ascending key[neighbor] order (ties allowed)."""
    n = offsets.size - 1
    bad = 0
    for i in range(n):
        for b in range(offsets[i] + 1, offsets[i + 1]):
            if key[neighbors[b]] < key[neighbors[b - 1]]:
                bad += 1
                break
    return bad


@njit(parallel=True, cache=True)
def _reverse_keyed(offsets, neighbors, key, out):
    """reverse() when every row is ascending in key[neighbor]: the mirror guess of
    :func:`_reverse_sorted`, else a lower-bound search for key[i] in row j and a scan of the
    entries with that key."""
    n = offsets.size - 1
    for i in prange(n):
        s = offsets[i]
        ki = key[i]
        for b in range(s, offsets[i + 1]):
            j = neighbors[b]
            r = -1
            if j >= 0 and j < n:
                lo = offsets[j]
                end = offsets[j + 1]
                g = end - 1 - (b - s)
                if g >= lo and neighbors[g] == i:
                    r = g
                else:
                    hi = end
                    while lo < hi:
                        mid = (lo + hi) >> 1
                        if key[neighbors[mid]] < ki:
                            lo = mid + 1
                        else:
                            hi = mid
                    while lo < end and key[neighbors[lo]] == ki:
                        if neighbors[lo] == i:
                            r = lo
                            break
                        lo += 1
            out[b] = r


@njit(parallel=True, cache=True)
def _row_argsort(offsets, neighbors):
    """Per row, the permutation (int32, local to the row) that sorts the row ascending.

    Sorts packed int64 values (neighbor << 32 | position), so there is no indirection in the
    comparisons; neighbors must be >= 0 (they are point indices).
    """
    n = offsets.size - 1
    perm = np.empty(neighbors.size, dtype=np.int32)
    for i in prange(n):
        s = offsets[i]
        e = offsets[i + 1]
        if e > s:
            buf = np.empty(e - s, dtype=np.int64)
            for k in range(e - s):
                buf[k] = (np.int64(neighbors[s + k]) << 32) | k
            shellsort(buf, 0, e - s)
            for k in range(e - s):
                perm[s + k] = np.int32(buf[k] & 0xFFFFFFFF)
    return perm


@njit(parallel=True, cache=True)
def _reverse_perm(offsets, neighbors, perm, out):
    """reverse() for rows in any order: the mirror guess of :func:`_reverse_sorted` (it holds
    for rows sorted by any key that orders space consistently, such as lattice global ids), else
    a binary search through each row's sorting permutation ``perm`` (int32, local to rows)."""
    n = offsets.size - 1
    for i in prange(n):
        s = offsets[i]
        for b in range(s, offsets[i + 1]):
            j = neighbors[b]
            r = -1
            if j >= 0 and j < n:
                base = offsets[j]
                end = offsets[j + 1]
                g = end - 1 - (b - s)
                if g >= base and neighbors[g] == i:
                    r = g
                else:
                    lo = 0
                    hi = end - base
                    m = hi
                    while lo < hi:
                        mid = (lo + hi) >> 1
                        if neighbors[base + perm[base + mid]] < i:
                            lo = mid + 1
                        else:
                            hi = mid
                    if lo < m:
                        pos = base + perm[base + lo]
                        if neighbors[pos] == i:
                            r = pos
            out[b] = r


@njit(cache=True)
def _transpose_fill(offsets, neighbors, in_offsets, in_bonds):
    """Counting sort of bond positions by target, sources ascending (serial).

    offsets (n+1,) int64; neighbors (B,); in_offsets (m+1,) int64 zeros on entry, filled here;
    in_bonds (B,) int32 output.
    """
    for b in range(neighbors.size):
        in_offsets[neighbors[b] + 1] += 1
    m = in_offsets.size - 1
    for t in range(m):
        in_offsets[t + 1] += in_offsets[t]
    pos = in_offsets[:-1].copy()
    n = offsets.size - 1
    for i in range(n):
        for b in range(offsets[i], offsets[i + 1]):
            t = neighbors[b]
            in_bonds[pos[t]] = b
            pos[t] += 1
