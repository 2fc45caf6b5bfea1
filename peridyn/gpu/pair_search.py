"""The GPU's binning for the contact pair search (:class:`~peridyn.contact.search.Binning`): what
of contact is the GPU's own. Everything else (the schedule, the candidate test, the rows, the
force, the displacement and distance checks) is :class:`~peridyn.contact.manager.ContactManager`
and the laws and functions every target compiles (``contact/pair_laws.py``,
``contact/short_range.py``), placed on the device by ``gpu/placement.py``.

The CPU sorts points by cell; here points are binned into cells of size r_b, each cell hashed
into one of M buckets (M a power of two >= 2 n); a count per bucket (atomics), an exclusive scan
and a scatter put the points of each bucket together; each point then gathers over the distinct
buckets of the 27 cells around its own, testing each candidate and placing it in the row with
``pair_laws.offer``, compiled for the GPU from the CPU's Python. A bucket holding points of
other cells (a hash collision) only adds candidates, which the test drops, so memory is
O(points) however far the bodies fly. The largest row and the number of pairs come back to the
host (two integers per gather); the same scan turns the row counts into CSR offsets.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import config, cuda, int64

from ..contact import pair_laws
from ..contact.search import Binning
from ..kernels.codegen import compile_function

#: threads per block of the scan (a power of two; few under the simulator, where each thread is a Python thread)
SCAN_THREADS = 2 if config.ENABLE_CUDASIM else 256
#: most blocks of the scan's first and last passes
SCAN_BLOCKS = 1 if config.ENABLE_CUDASIM else 1024
#: cell coordinates are clamped to +-CELL_CLAMP: far-flung points share the outermost cells, which only adds candidates
CELL_CLAMP = float(1 << 40)
#: cell coordinates enter the hash modulo 2^20 (cells 2^20 apart share buckets: more candidates, none lost)
CELL_BITS = (1 << 20) - 1


# -- device functions --------------------------------------------------------------------------------
@cuda.jit(device=True, inline=True)
def _cell(value, inv_h):
    c = value * inv_h
    if not c >= -CELL_CLAMP:  # NaN too
        c = -CELL_CLAMP
    if c > CELL_CLAMP:
        c = CELL_CLAMP
    return int(math.floor(c))


@cuda.jit(device=True, inline=True)
def _bucket(cx, cy, cz, mask):
    h = ((cx & CELL_BITS) * 73856093) ^ ((cy & CELL_BITS) * 19349663) ^ ((cz & CELL_BITS) * 83492791)
    return h & mask


#: the candidate test and the row insertion of every target, compiled for the GPU
_offer = compile_function(pair_laws.offer, cuda.jit(device=True, inline=True), retarget=True)


# -- the search --------------------------------------------------------------------------------------
@cuda.jit(cache=True)
def bucket_count(n, y, inv_h, mask, bucket_of, counts):
    """bucket_of[i] = the bucket of point i's cell; counts[b] += the points in bucket b."""
    for i in range(cuda.grid(1), n, cuda.gridsize(1)):
        b = _bucket(_cell(y[i, 0], inv_h), _cell(y[i, 1], inv_h), _cell(y[i, 2], inv_h), mask)
        bucket_of[i] = b
        cuda.atomic.add(counts, b, 1)


@cuda.jit(cache=True)
def scan_block_sums(counts, m, chunk, sums):
    """sums[b] = the sum of counts[b * chunk : (b + 1) * chunk] (one block per chunk)."""
    buf = cuda.shared.array(SCAN_THREADS, int64)
    t = cuda.threadIdx.x
    lo = cuda.blockIdx.x * chunk
    hi = min(lo + chunk, m)
    acc = 0
    for k in range(lo + t, hi, cuda.blockDim.x):
        acc += counts[k]
    buf[t] = acc
    cuda.syncthreads()
    s = SCAN_THREADS // 2
    while s > 0:
        if t < s:
            buf[t] += buf[t + s]
        cuda.syncthreads()
        s //= 2
    if t == 0:
        sums[cuda.blockIdx.x] = buf[0]


@cuda.jit(cache=True)
def scan_sums(sums, nb):
    """Exclusive scan of sums[:nb] in place (one thread: nb is at most SCAN_BLOCKS)."""
    if cuda.grid(1) == 0:
        acc = 0
        for b in range(nb):
            c = sums[b]
            sums[b] = acc
            acc += c


@cuda.jit(cache=True)
def scan_apply(counts, m, chunk, sums, start):
    """start[k] = sum of counts[:k] for k in [0, m]; block b scans its chunk from sums[b]."""
    buf = cuda.shared.array(SCAN_THREADS, int64)
    t = cuda.threadIdx.x
    lo = cuda.blockIdx.x * chunk
    hi = min(lo + chunk, m)
    base = sums[cuda.blockIdx.x]
    for tile in range(lo, hi, SCAN_THREADS):
        k = tile + t
        c = counts[k] if k < hi else 0
        buf[t] = c
        cuda.syncthreads()
        off = 1
        while off < SCAN_THREADS:
            a = buf[t - off] if t >= off else 0
            cuda.syncthreads()
            buf[t] += a
            cuda.syncthreads()
            off *= 2
        if k < hi:
            start[k] = base + buf[t] - c
        base += buf[SCAN_THREADS - 1]
        cuda.syncthreads()
    if hi == m and lo < hi and t == 0:
        start[m] = base


@cuda.jit(cache=True)
def bucket_scatter(n, bucket_of, start, counts, points):
    """points[start[b]:start[b + 1]] = the points of bucket b (in no fixed order); counts back to 0."""
    for i in range(cuda.grid(1), n, cuda.gridsize(1)):
        b = bucket_of[i]
        points[start[b] + cuda.atomic.sub(counts, b, 1) - 1] = i


@cuda.jit(cache=True)
def gather_pairs(n, y, inv_h, mask, start, points, s, gid, x, near2, block, cross_block, rb2, rs2, bond_offsets, bond_neighbors,
                 bond_gid, one_offsets, one_gid, cap, rows, row_visits, counts, totals):
    """Row p of ``rows`` (rows[p * cap : p * cap + counts[p]], sorted by gid) = the partners j
    of point p (``pair_laws.pair_visits``; its arguments from ``s`` to ``one_gid``), ``row_visits`` their
    visit bits; counts[p] > cap: the row did not fit. totals[0] = max counts[p], totals[1] =
    sum counts[p] (both zero on entry)."""
    seen = cuda.local.array(27, int64)
    for p in range(cuda.grid(1), n, cuda.gridsize(1)):
        cx = _cell(y[p, 0], inv_h)
        cy = _cell(y[p, 1], inv_h)
        cz = _cell(y[p, 2], inv_h)
        y0 = y[p, 0]
        y1 = y[p, 1]
        y2 = y[p, 2]
        base = p * cap
        cnt = 0
        m = 0
        for ix in range(cx - 1, cx + 2):
            for iy in range(cy - 1, cy + 2):
                for iz in range(cz - 1, cz + 2):
                    b = _bucket(ix, iy, iz, mask)
                    dup = False
                    for r in range(m):
                        if seen[r] == b:
                            dup = True
                    if dup:
                        continue
                    seen[m] = b
                    m += 1
                    for t in range(start[b], start[b + 1]):
                        j = points[t]
                        if j != p:
                            cnt = _offer(p, j, y, j, y0, y1, y2, s, gid, x, near2, block, cross_block, rb2, rs2, bond_offsets,
                                         bond_neighbors, bond_gid, one_offsets, one_gid, rows, row_visits, base, cnt, cap)
        counts[p] = cnt
        cuda.atomic.max(totals, 0, cnt)
        cuda.atomic.add(totals, 1, cnt)


@cuda.jit(cache=True)
def fill_int(a, value):
    for i in range(cuda.grid(1), a.shape[0], cuda.gridsize(1)):
        a[i] = value


class BucketSearch(Binning):
    """The GPU's binning (see the module docstring) on the CUDA backend ``backend``."""

    def __init__(self, backend: Any, num_owned: int, rb: float) -> None:
        super().__init__(backend, num_owned, rb)
        n = num_owned
        m = 2
        while m < 2 * n:
            m *= 2
        self.mask = m - 1
        self.num_buckets = m
        self.bucket_of = backend.zeros(max(n, 1), np.int64)
        self.bucket_counts = backend.zeros(m, np.int64)
        self.bucket_start = backend.zeros(m + 1, np.int64)
        self.points = backend.zeros(max(n, 1), np.int64)
        self.scan_sums = backend.zeros(SCAN_BLOCKS, np.int64)
        self.totals = backend.zeros(2, np.int64)
        self.y: Any = None

    def _scan(self, counts: Any, m: int, start: Any) -> None:
        """start[k] = sum of counts[:k] for k in [0, m] (device arrays)."""
        blocks = max(1, min(SCAN_BLOCKS, (m + SCAN_THREADS - 1) // SCAN_THREADS))
        chunk = (m + blocks - 1) // blocks
        scan_block_sums[blocks, SCAN_THREADS](counts, m, chunk, self.scan_sums)
        scan_sums[1, 1](self.scan_sums, blocks)
        scan_apply[blocks, SCAN_THREADS](counts, m, chunk, self.scan_sums, start)

    def bin(self, y: Any) -> None:
        grid = self.backend.grid(self.num_owned)
        fill_int[self.backend.grid(self.num_buckets)](self.bucket_counts, 0)
        bucket_count[grid](self.num_owned, y, 1.0 / self.rb, self.mask, self.bucket_of, self.bucket_counts)
        self._scan(self.bucket_counts, self.num_buckets, self.bucket_start)
        bucket_scatter[grid](self.num_owned, self.bucket_of, self.bucket_start, self.bucket_counts, self.points)
        self.y = y

    def gather(self, cap: int, test: tuple) -> tuple[int, int]:
        self.totals.copy_to_device(np.zeros(2, np.int64))
        gather_pairs[self.backend.grid(self.num_owned)](self.num_owned, self.y, 1.0 / self.rb, self.mask, self.bucket_start, self.points,
                                                        *test, cap, self.rows, self.row_visits, self.counts, self.totals)
        largest, total = (int(v) for v in self.totals.copy_to_host())
        return largest, total

    def offsets(self) -> Any:
        offsets = self.backend.zeros(self.num_owned + 1, np.int64)
        if self.num_owned:
            self._scan(self.counts, self.num_owned, offsets)
        return offsets
