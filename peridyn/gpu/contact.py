"""Short Range Force contact on the GPU: the pair search and the contact force of
:class:`peridyn.contact.manager.ContactManager` with positions, velocities and pairs on the device.

The schedule is the manager's (a search every ``Search Frequency`` steps; the short list of pairs
within r_b = R_c + skin rebuilt at every search and whenever a point moved more than skin / 2
since the last build), and so are the pairs and the force: each point's row is sorted by global
id and the force kernel sums it in the CPU kernel's order (``short_range_force_kernel``).

The short list is built on the device with a hashed cell grid: points are binned into cells of
size r_b, each cell hashed into one of M buckets (M a power of two >= 2 n); a count per bucket
(atomics), an exclusive scan and a scatter put the points of each bucket together; each point then
gathers over the distinct buckets of the 27 cells around its own into a fixed-capacity row. A
bucket holding points of other cells (a hash collision) only adds candidates, which the distance
test drops, so memory is O(points) however far the bodies fly. A row longer than the capacity
sets the largest count, read back with the number of pairs (two integers per build); the host
grows the capacity and gathers again, as the CPU search does. Per step one number crosses to the
host: the largest displacement since the last build.
"""
from __future__ import annotations

import math
import time as _time
from typing import Any

import numpy as np
from numba import config, cuda, int64

from ..contact import short_range
from ..core.interfaces import VISIT_FROM_PARTNER, VISIT_FROM_POINT, ContactPairs

#: threads per block of the scan (a power of two; few under the simulator, where each thread is a Python thread)
SCAN_THREADS = 2 if config.ENABLE_CUDASIM else 256
#: most blocks of the scan's first and last passes
SCAN_BLOCKS = 1 if config.ENABLE_CUDASIM else 1024
#: cell coordinates are clamped to +-CELL_CLAMP: far-flung points share the outermost cells, which only adds candidates
CELL_CLAMP = float(1 << 40)
#: cell coordinates enter the hash modulo 2^20 (cells 2^20 apart share buckets: more candidates, none lost)
CELL_BITS = (1 << 20) - 1
BIG = np.iinfo(np.int64).max


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


@cuda.jit(device=True, inline=True)
def _in_sorted(values, lo, hi, key, table):
    """Whether table[values[k]] == key for some k in [lo, hi) (values sorted by table value)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        t = table[values[mid]]
        if t < key:
            lo = mid + 1
        elif t > key:
            hi = mid
        else:
            return True
    return False


@cuda.jit(device=True, inline=True)
def _in_sorted_plain(values, lo, hi, key):
    while lo < hi:
        mid = (lo + hi) >> 1
        t = values[mid]
        if t < key:
            lo = mid + 1
        elif t > key:
            hi = mid
        else:
            return True
    return False


#: the CPU model's force of one visit (``short_range._visit_term``), compiled for the GPU: the
#: contact physics is written once
_visit_term = cuda.jit(device=True, inline=True)(short_range._visit_term.py_func)


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
def gather_pairs(n, y, s, gid, inv_h, mask, start, points, rb2, rs2, bond_offsets, bond_neighbors, bond_gid, one_offsets, one_gid,
                 x, near2, block, cross_block, cap, rows, row_visits, counts, totals):
    """Row p of ``rows`` (rows[p * cap : p * cap + counts[p]], sorted by gid) = the partners j
    of point p: |y_j - y_p| <= r_b, |s_j - s_p| <= R_s, not bonded both ways (``pair_search_kernel``'s
    tests); ``row_visits`` their visit bits. counts[p] > cap: the row did not fit.
    totals[0] = max counts[p], totals[1] = sum counts[p] (both zero on entry)."""
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
                        if j == p:
                            continue
                        dx = y[j, 0] - y0
                        dy = y[j, 1] - y1
                        dz = y[j, 2] - y2
                        if not (dx * dx + dy * dy) + dz * dz <= rb2:
                            continue
                        ex = s[j, 0] - s[p, 0]
                        ey = s[j, 1] - s[p, 1]
                        ez = s[j, 2] - s[p, 2]
                        if not (ex * ex + ey * ey) + ez * ez <= rs2:
                            continue
                        gj = gid[j]
                        fx = x[j, 0] - x[p, 0]
                        fy = x[j, 1] - x[p, 1]
                        fz = x[j, 2] - x[p, 2]
                        if (fx * fx + fy * fy) + fz * fz < near2[p] and (cross_block or block[j] == block[p]):
                            node = False
                        else:
                            node = not _in_sorted(bond_neighbors, bond_offsets[p], bond_offsets[p + 1], gj, bond_gid)
                        partner = node
                        if one_offsets[p + 1] > one_offsets[p] and _in_sorted_plain(one_gid, one_offsets[p], one_offsets[p + 1], gj):
                            partner = not node
                        if not (node or partner):
                            continue
                        if cnt < cap:
                            k = cnt
                            while k > 0 and gid[rows[base + k - 1]] > gj:
                                rows[base + k] = rows[base + k - 1]
                                row_visits[base + k] = row_visits[base + k - 1]
                                k -= 1
                            rows[base + k] = j
                            row_visits[base + k] = (VISIT_FROM_POINT if node else 0) | (VISIT_FROM_PARTNER if partner else 0)
                        cnt += 1
        counts[p] = cnt
        cuda.atomic.max(totals, 0, cnt)
        cuda.atomic.add(totals, 1, cnt)


@cuda.jit(cache=True)
def max_displacement2(n, y, y0, out):
    """out[0] = max(out[0], max_i |y_i - y0_i|^2), a NaN counted as infinity (a rebuild)."""
    m = 0.0
    for i in range(cuda.grid(1), n, cuda.gridsize(1)):
        dx = y[i, 0] - y0[i, 0]
        dy = y[i, 1] - y0[i, 1]
        dz = y[i, 2] - y0[i, 2]
        d = (dx * dx + dy * dy) + dz * dz
        if not d <= m:
            m = d if d == d else math.inf
    cuda.atomic.max(out, 0, m)


@cuda.jit(cache=True)
def copy_rows(n, src, dst):
    """dst[:n] = src[:n] for (n, 3) arrays."""
    for i in range(cuda.grid(1), n, cuda.gridsize(1)):
        for c in range(3):
            dst[i, c] = src[i, c]


@cuda.jit(cache=True)
def fill_int(a, value):
    for i in range(cuda.grid(1), a.shape[0], cuda.gridsize(1)):
        a[i] = value


# -- the force ---------------------------------------------------------------------------------------
@cuda.jit(cache=True)
def short_range_force(n, cap, counts, rows, row_visits, gid, block, horizon, y, v, volume, rc, k, mu, out, f, step_min):
    """out[p] = the contact force density on point p (M L^-2 T^-2), gathered over its row in the
    order of ``short_range_force_kernel``; f[p] += out[p]; step_min[0] = min(step_min[0], the
    smallest squared distance of a listed pair)."""
    rc2 = rc * rc
    for p in range(cuda.grid(1), n, cuda.gridsize(1)):
        lo = p * cap
        hi = lo + counts[p]
        fx = 0.0
        fy = 0.0
        fz = 0.0
        if lo < hi:
            bp = block[p]
            gp = gid[p]
            cur = -1
            while True:  # one accumulator per block of the visiting point, blocks in order
                nb = bp if bp > cur else BIG
                for q in range(lo, hi):
                    b = block[rows[q]]
                    if cur < b and b < nb:
                        nb = b
                if nb == BIG:
                    break
                cur = nb
                ax = 0.0
                ay = 0.0
                az = 0.0
                for phase in range(3):
                    # phase 0: visits of partners before p; 1: p's own visits; 2: partners after p
                    if bp != cur and phase != 0:
                        break
                    for q in range(lo, hi):
                        j = rows[q]
                        if phase == 1:
                            if not row_visits[q] & VISIT_FROM_POINT:
                                continue
                            delta = horizon[p]
                        else:
                            if block[j] != cur or not row_visits[q] & VISIT_FROM_PARTNER:
                                continue
                            if bp == cur and (gid[j] > gp) != (phase == 2):
                                continue
                            delta = horizon[j]
                        active, tx, ty, tz = _visit_term(p, j, delta, y, v, volume, rc, rc2, k, mu)
                        if active:
                            ax += tx
                            ay += ty
                            az += tz
                fx += ax
                fy += ay
                fz += az
            d2 = math.inf
            for q in range(lo, hi):
                j = rows[q]
                dx = y[j, 0] - y[p, 0]
                dy = y[j, 1] - y[p, 1]
                dz = y[j, 2] - y[p, 2]
                d = (dx * dx + dy * dy) + dz * dz
                if d < d2:
                    d2 = d
            cuda.atomic.min(step_min, 0, d2)
        out[p, 0] = 0.0 + fx
        out[p, 1] = 0.0 + fy
        out[p, 2] = 0.0 + fz
        f[p, 0] += out[p, 0]
        f[p, 1] += out[p, 1]
        f[p, 2] += out[p, 2]


@cuda.jit(cache=True)
def track_min_distance(step_min, running, t):
    """running = (smallest pair distance, its time): updated from step_min[0] (a squared
    distance) as ``ContactManager.add_force`` does; step_min[0] reset to infinity."""
    if cuda.grid(1) == 0:
        d2 = step_min[0]
        md = running[0]
        if d2 < md * md:
            running[0] = math.sqrt(d2)
            running[1] = t
        step_min[0] = math.inf


# -- the host side -----------------------------------------------------------------------------------
class DeviceContact:
    """The contact of one GPU Verlet run: ``begin_step`` and ``add_force`` are those of the
    run's :class:`~peridyn.contact.manager.ContactManager` with fields on the device (``dev``, a
    :class:`~peridyn.gpu.state.DeviceModel`). The manager's statistics are updated in place
    (``manager.stats``), so its ``summary`` and ``diagnosis`` speak for the GPU run."""

    def __init__(self, manager: Any, dev: Any) -> None:
        if manager.ghosts is not None:
            raise NotImplementedError("contact on GPUs under MPI is not built")
        self.manager = manager
        self.model = manager.model
        if "gpu" not in type(self.model).devices:
            raise NotImplementedError(f"the contact model {self.model.name!r} has no GPU kernels")
        self.dev = dev
        b = self.backend = dev.backend
        sim = manager.sim
        self.n = n = manager.num_owned
        self.stats = manager.stats
        self.rc = float(self.model.params.contact_radius)
        self.k = float(self.model.params.spring_constant)
        self.gid = b.asarray(manager.gid)
        self.block = b.asarray(manager.block)
        self.horizon = b.asarray(manager.horizon)
        self.near2 = b.asarray(np.ascontiguousarray(manager.near2, dtype=np.float64))
        self.bond_gid = b.asarray(np.ascontiguousarray(sim.gid, dtype=np.int64))
        self.one_offsets = b.asarray(manager.one_offsets)
        self.one_gid = b.asarray(manager.one_gid if manager.one_gid.size else np.zeros(1, np.int64))
        self.s = b.asarray(np.array(manager.s, dtype=np.float64))
        self.y_build = b.zeros((n, 3))
        m = 2
        while m < 2 * n:
            m *= 2
        self.mask = m - 1
        self.num_buckets = m
        self.bucket_of = b.zeros(max(n, 1), np.int64)
        self.bucket_counts = b.zeros(m, np.int64)
        self.bucket_start = b.zeros(m + 1, np.int64)
        self.points = b.zeros(max(n, 1), np.int64)
        self.scan_blocks = max(1, min(SCAN_BLOCKS, (m + SCAN_THREADS - 1) // SCAN_THREADS))
        self.scan_chunk = (m + self.scan_blocks - 1) // self.scan_blocks
        self.scan_sums = b.zeros(self.scan_blocks, np.int64)
        self.counts = b.zeros(max(n, 1), np.int64)
        self.totals = b.zeros(2, np.int64)
        self.scalar = b.zeros(1)
        self.step_min = b.asarray(np.full(1, math.inf))
        self.running_min = b.asarray(np.array([manager.stats["min_distance"], manager.stats["min_distance_time"]], dtype=np.float64))
        self.cap = 0  # capacity of the current rows (0: no rows yet)
        self.rows = None
        self.row_visits = None
        self.valid = False  # the rows are the short list of the current search

    # -- what the explicit solver calls ----------------------------------------------------------
    def begin_step(self, step: int) -> None:
        """Start of explicit step ``step`` (1, 2, ...), before the first half kick: a search is
        due when step % Search Frequency == 0, on the current (previous step's) positions."""
        if step % self.manager.frequency == 0:
            copy_rows[self.backend.grid(self.n)](self.n, self.dev.fields["Coordinates"], self.s)
            self.valid = False
            self.stats["searches"] += 1

    def add_force(self, f: Any, t: float, step: int) -> None:
        """Contact_Force_Density of the points (device field, (n, 3), M L^-2 T^-2) at the
        current positions and velocities, added to the device force density f (n, 3). Step 0
        uses the friction law's value at t = 0."""
        t0 = _time.perf_counter()
        if step > 0:
            self.model.begin_step(t)
        fields = self.dev.fields
        y = fields["Coordinates"]
        if not self.valid or self._moved_too_far(y):
            self._build(y)
        n = self.n
        out = fields["Contact_Force_Density"]
        short_range_force[self.backend.grid(n)](n, self.cap, self.counts, self.rows, self.row_visits, self.gid, self.block, self.horizon, y,
                                                fields["Velocity"], fields["Volume"], self.rc, self.k, float(self.model.mu), out, f,
                                                self.step_min)
        track_min_distance[1, 1](self.step_min, self.running_min, float(t))
        self.stats["force_time"] += _time.perf_counter() - t0
        self.stats["force_calls"] += 1

    # -- pairs ----------------------------------------------------------------------------------
    def _moved_too_far(self, y: Any) -> bool:
        self.scalar.copy_to_device(np.zeros(1))
        max_displacement2[self.backend.grid(self.n)](self.n, y, self.y_build, self.scalar)
        m = float(self.scalar.copy_to_host()[0])
        return not 2.0 * math.sqrt(m) < self.manager.skin

    def _build(self, y: Any) -> None:
        t0 = _time.perf_counter()
        mgr = self.manager
        b = self.backend
        n = self.n
        grid = b.grid(n)
        fields = self.dev.fields
        inv_h = 1.0 / mgr.rb
        fill_int[b.grid(self.num_buckets)](self.bucket_counts, 0)
        bucket_count[grid](n, y, inv_h, self.mask, self.bucket_of, self.bucket_counts)
        scan_block_sums[self.scan_blocks, SCAN_THREADS](self.bucket_counts, self.num_buckets, self.scan_chunk, self.scan_sums)
        scan_sums[1, 1](self.scan_sums, self.scan_blocks)
        scan_apply[self.scan_blocks, SCAN_THREADS](self.bucket_counts, self.num_buckets, self.scan_chunk, self.scan_sums, self.bucket_start)
        bucket_scatter[grid](n, self.bucket_of, self.bucket_start, self.bucket_counts, self.points)
        cap = mgr.capacity
        passes = 0
        while True:
            passes += 1
            if cap != self.cap:
                self.rows = b.zeros(max(n * cap, 1), np.int32)
                self.row_visits = b.zeros(max(n * cap, 1), np.uint8)
                self.cap = cap
            self.totals.copy_to_device(np.zeros(2, np.int64))
            gather_pairs[grid](n, y, self.s, self.gid, inv_h, self.mask, self.bucket_start, self.points, mgr.rb * mgr.rb,
                               mgr.search_radius * mgr.search_radius, self.dev.bonds.offsets, self.dev.bonds.neighbors, self.bond_gid,
                               self.one_offsets, self.one_gid, fields["Model_Coordinates"], self.near2, self.block, bool(mgr.cross_block),
                               cap, self.rows, self.row_visits, self.counts, self.totals)
            largest, total = (int(v) for v in self.totals.copy_to_host())
            if largest <= cap:
                break
            cap = max(largest + largest // 4, 2 * cap)  # overflow: grow and gather again
        copy_rows[grid](n, y, self.y_build)
        self.valid = True
        st = self.stats
        st["overflows"] += passes - 1
        mgr.capacity = max(16, cap if passes > 1 else min(cap, 2 * largest + 8))
        st["builds"] += 1
        st["pairs"] = total
        st["max_pairs"] = max(st["max_pairs"], total)
        st["build_time"] += _time.perf_counter() - t0

    def pairs(self) -> ContactPairs | None:
        """The current short list as host CSR arrays (what ``manager.pairs`` holds on the CPU),
        None before the first build. Copies the rows back: for tests and output frames."""
        if self.rows is None:
            return None
        n = self.n
        counts = self.counts.copy_to_host()[:n]
        rows = self.rows.copy_to_host()
        visits = self.row_visits.copy_to_host()
        offsets = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(counts, out=offsets[1:])
        take = (np.arange(n, dtype=np.int64) * self.cap).repeat(counts) + (np.arange(offsets[-1]) - offsets[:-1].repeat(counts))
        return ContactPairs(offsets, np.ascontiguousarray(rows[take], np.int32), np.ascontiguousarray(visits[take], np.uint8))

    def to_host(self) -> None:
        """Give the manager the short list, the smallest pair distance so far and the search's
        positions, so that its ``potential_energy`` (on the host fields, downloaded by the
        caller), ``diagnosis`` and a checkpoint answer for the GPU run."""
        md, when = self.running_min.copy_to_host()
        self.stats["min_distance"] = float(md)
        self.stats["min_distance_time"] = float(when)
        self.manager.pairs = self.pairs()
        self.s.copy_to_host(self.manager.s)  # the search's reference positions and where the list was built: a checkpoint's
        if self.valid:
            self.manager.y_build = self.y_build.copy_to_host()

    # -- what the manager computes on the host -------------------------------------------------------
    def potential_energy(self) -> float | None:
        """The contact springs' energy (M L^2 T^-2) at the host fields' positions: the caller
        downloads ``Coordinates`` first (an output frame)."""
        self.to_host()
        return self.manager.potential_energy()

    def stable_time_step(self) -> float:
        """The manager's stable time step estimate with the contact springs (T; set-up data only)."""
        return self.manager.stable_time_step()

    def summary(self) -> dict[str, Any]:
        """``ContactManager.summary`` of the GPU run (force_time counts kernel launches, not
        their completion, unless the caller synchronizes)."""
        md, when = self.running_min.copy_to_host()
        self.stats["min_distance"] = float(md)
        self.stats["min_distance_time"] = float(when)
        return self.manager.summary()
