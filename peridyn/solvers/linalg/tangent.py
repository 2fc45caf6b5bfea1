"""The tangent stiffness K = d(f V)/dy of the implicit solvers (PERIDIGM_SEMANTICS.md §11.1).

K is stored block-sparse (3x3 blocks, BSR) with rows and columns in **global-id order**, the
degree of freedom (g, c) at index 3 g + c as in Peridigm, so that matrix-vector products and
the Krylov solvers that reproduce Peridigm's (:mod:`peridyn.solvers.linalg.linear`) sum in Peridigm's
order. Sparsity: every point i couples all degrees of freedom of S_i = {i} U N_i (Peridigm's
pattern, including pairs that only share a neighbor); when every material's tangent couples
bonded pairs only (bond-based), the pattern is just the bonded pairs. NOX preconditioners use a
block-diagonal pattern.

Filling: each block's material adds its points' contributions through ``Material.tangent``
(analytic; see :mod:`peridyn.materials.tangents` for the derivation); a material without one
(or ``Apply Automatic Differentiation Jacobian: false`` on Elastic) gets Peridigm's central
finite differences: for every point i, each degree of freedom q of S_i (neighbors first, i last)
is moved by -eps and +eps, only point i's force state is re-evaluated (``precompute`` and
``force_state`` on a one-point view) and the column is ((F+ - F-)/eps * 0.5) * V_s.

Kinematic boundary conditions (``apply_kinematic_bc``): D = -(sum_k |K_kk|)/N_dof from the
diagonal before any change; rows and columns of prescribed degrees of freedom are zeroed and
their diagonal set to D.

Under MPI (``sim.comm.size > 1``) the matrix is stored **by subdomain**: K = sum over ranks of
K_r, where K_r holds the contributions of the points rank r owns (their families S_i), with rows
and columns numbered over the rank's local points: its owned points first (by global id), then
its ghosts (in local order). Peridigm's family-by-family pattern couples the whole of S_i, so a
row of an owned point receives contributions of other ranks' points whose columns can lie two
horizons away, beyond the ghost layer; keeping each rank's own contributions instead needs no
second ghost layer and no exchange of matrix entries when the tangent is rebuilt. Products
refresh the ghost entries of x through the engine's halo (``halo.exchange``), multiply by K_r and
add the ghost rows of the result into their owners (``halo.reverse_sum``). After every assembly
the diagonal blocks are consolidated on the owners (the ghost rows' diagonal blocks are added
into them and zeroed), so the diagonal and the 3x3 diagonal blocks of owned rows are those of
the assembled matrix, and the operations on the diagonal (kinematic BCs with a D reduced over all
ranks, damping with a global max, adding a mass term) work on owned rows only. Vectors handed to
the solvers hold the owned rows only (row order); reductions over them go through ``sim.comm``.
The assembled owned-by-owned block (block-Jacobi / AMG-per-rank preconditioners) and the whole
matrix on rank 0 (the direct solver) are built on request (:meth:`TangentMatrix.owned_block`,
:meth:`TangentMatrix.gather_to_root`).
"""
from __future__ import annotations

import dataclasses
import logging
import math
import time as _time
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from ...core.assembly import local_vector_force_kernel, scatter_local_kernel

log = logging.getLogger("peridyn.solver")


@dataclass
class TangentTarget:
    """What ``Material.tangent`` writes into: the BSR arrays of K in row (global-id) numbering
    and the maps a gather kernel needs.

    indptr (nrows+1,) int64; indices (nnzb,) int32 block columns (row numbering); data
    (nnzb, 3, 3) float64, ``data[p, d, c] = dF_(row,d)/dy_(col,c)`` (force per length);
    row_of_local / local_of_row map local point indices and rows (under MPI the rows are the
    rank's local points, owned then ghosts; nrows = number of local points); eval_rank (n,) is Peridigm's
    evaluation order of points (block, then global id); in_offsets, in_bonds, sources: the
    transposed neighbor list (incoming bonds of every point and the owner of every bond);
    nchunks: number of independent row chunks for ``prange``; max_degree / max_in: the longest
    neighbor list and incoming list (scratch sizes)."""

    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray
    row_of_local: np.ndarray
    local_of_row: np.ndarray
    eval_rank: np.ndarray
    in_offsets: np.ndarray
    in_bonds: np.ndarray
    sources: np.ndarray
    nrows: int
    nchunks: int
    max_degree: int
    max_in: int
    probe_length: float | None = None  #: the finite-difference probe of the block being filled (L)


# ------------------------------------------------------------------------------------------------
# kernels
# ------------------------------------------------------------------------------------------------
@njit(cache=True, parallel=True)
def bsr_matvec_kernel(indptr, indices, data, x, out):
    """out = A x for a 3x3-block BSR matrix; x, out (3 nrows,). Each row is summed from 0.0 in
    ascending column order (Epetra's CrsMatrix product), so the result does not depend on the
    thread count."""
    n = indptr.shape[0] - 1
    for r in prange(n):
        # the three components of the row in one pass over its blocks (each summed in the
        # same order as three separate passes would: the same bits, a third of the reads)
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        for p in range(indptr[r], indptr[r + 1]):
            c0 = 3 * indices[p]
            x0 = x[c0]
            x1 = x[c0 + 1]
            x2 = x[c0 + 2]
            a0 += data[p, 0, 0] * x0
            a0 += data[p, 0, 1] * x1
            a0 += data[p, 0, 2] * x2
            a1 += data[p, 1, 0] * x0
            a1 += data[p, 1, 1] * x1
            a1 += data[p, 1, 2] * x2
            a2 += data[p, 2, 0] * x0
            a2 += data[p, 2, 1] * x1
            a2 += data[p, 2, 2] * x2
        out[3 * r] = a0
        out[3 * r + 1] = a1
        out[3 * r + 2] = a2


@njit(cache=True)
def kinematic_bc_kernel(indptr, indices, data, diag_pos, fixed):
    """Peridigm's applyKinematicBC_InsertZerosAndSetDiagonal on a BSR matrix: D = (-1 * sum
    |A_kk|)/N_dof (sequential, ascending dof order, before any change), then rows and columns of
    the fixed dofs (fixed: (nrows, 3) bool) are zeroed and their diagonal set to D. Returns D."""
    n = indptr.shape[0] - 1
    D = (-1.0 * abs_diagonal_sum_kernel(data, diag_pos, n)) / (3 * n) if n > 0 else 0.0
    any_fixed = False
    for r in range(n):
        for d in range(3):
            if fixed[r, d]:
                any_fixed = True
    if any_fixed:
        kinematic_bc_set_kernel(indptr, indices, data, diag_pos, fixed, D, n)
    return D


@njit(cache=True)
def local_force_kernel(i, offsets, neighbors, y, volume, t, out):
    """Force density of point i's bonds only, on S_i = [N_i..., i]: out (3 (|N_i| + 1),), zeroed
    here (M L^-2 T^-2). t: scalar force states (only i's bonds are read)."""
    o = offsets[i]
    ns = offsets[i + 1] - o + 1
    for k in range(3 * ns):
        out[k] = 0.0
    fx = 0.0
    fy = 0.0
    fz = 0.0
    Vi = volume[i]
    for b in range(o, offsets[i + 1]):
        j = neighbors[b]
        ex = y[j, 0] - y[i, 0]
        ey = y[j, 1] - y[i, 1]
        ez = y[j, 2] - y[i, 2]
        L = math.sqrt(ex * ex + ey * ey + ez * ez)
        if L > 0.0:
            s = t[b] / L
            k = 3 * (b - o)
            out[k] -= s * ex * Vi
            out[k + 1] -= s * ey * Vi
            out[k + 2] -= s * ez * Vi
            fx += s * ex * volume[j]
            fy += s * ey * volume[j]
            fz += s * ez * volume[j]
    k = 3 * (ns - 1)
    out[k] = fx
    out[k + 1] = fy
    out[k + 2] = fz


@njit(cache=True)
def damp_diagonal_kernel(data, diag_pos, scale, shift):
    """Peridigm's quasiStaticsDampTangent: d = diag * scale (per entry), then d += shift * max|d|,
    written back to the diagonal."""
    n = diag_pos.shape[0]
    dmax = 0.0
    for r in range(n):
        p = diag_pos[r]
        for d in range(3):
            v = data[p, d, d] * scale
            data[p, d, d] = v
            if abs(v) > dmax:
                dmax = abs(v)
    for r in range(n):
        p = diag_pos[r]
        for d in range(3):
            data[p, d, d] = data[p, d, d] + shift * dmax


@njit(cache=True)
def abs_diagonal_sum_kernel(data, diag_pos, n):
    """sum_k |A_kk| over the first n block rows (sequential, ascending dof order)."""
    total = 0.0
    for r in range(n):
        p = diag_pos[r]
        for d in range(3):
            total += abs(data[p, d, d])
    return total


@njit(cache=True)
def kinematic_bc_set_kernel(indptr, indices, data, diag_pos, fixed, D, nset):
    """The distributed form of :func:`kinematic_bc_kernel` with D given (reduced over ranks):
    entries in a fixed row or column (fixed: (nrows, 3) bool over owned and ghost rows) are
    zeroed; the diagonal of the fixed dofs of the first ``nset`` rows (the owned ones) is set
    to D (ghost rows keep 0: the owner holds the diagonal)."""
    n = indptr.shape[0] - 1
    for r in range(n):
        for p in range(indptr[r], indptr[r + 1]):
            col = indices[p]
            for d in range(3):
                for c in range(3):
                    if fixed[r, d] or fixed[col, c]:
                        data[p, d, c] = 0.0
    for r in range(nset):
        p = diag_pos[r]
        for d in range(3):
            if fixed[r, d]:
                data[p, d, d] = D


# ------------------------------------------------------------------------------------------------
def evaluation_rank(sim) -> np.ndarray:
    """(n,) position of every local point in Peridigm's evaluation order: blocks in block order,
    points by global id inside a block."""
    n = sim.num_owned
    order = np.lexsort((sim.gid[:n], sim.block_index[:n]))
    rank = np.empty(n, dtype=np.int64)
    rank[order] = np.arange(n)
    return rank


class TangentMatrix:
    """K = d(f V)/dy of the owned points (serial: all points), 3x3-block sparse, rows in
    global-id order (see module docstring; under MPI the subdomain part K_r of this rank, with
    owned and ghost rows).

    ``kind``: "full" (Peridigm's pattern), or "block diagonal" (3x3 diagonal blocks only).

    ``n`` is the number of owned points (vectors given to and returned by the solvers have
    3 n entries, owned rows in global-id order); ``nrows`` the number of stored block rows (n
    serially; owned plus ghost points under MPI); ``ndof`` the number of unknowns of the whole
    model."""

    def __init__(self, sim, kind: str = "full") -> None:
        t0 = _time.perf_counter()
        self.sim = sim
        self.kind = kind
        self.comm = sim.comm
        self.parallel = sim.comm.size > 1
        n = sim.num_owned
        self.n = n
        nrows = int(sim.num_local) if self.parallel else n
        self.nrows = nrows
        self.ndof = 3 * int(sim.num_global)
        gid = np.asarray(sim.gid[:n], dtype=np.int64)
        self.local_of_row = np.concatenate([np.argsort(gid, kind="stable"), np.arange(n, nrows)]).astype(np.int64)
        self.row_of_local = np.empty(nrows, dtype=np.int64)
        self.row_of_local[self.local_of_row] = np.arange(nrows)
        self.owned_local = self.local_of_row[:n]
        self.eval_rank = evaluation_rank(sim)
        nl = sim.bonds
        self.in_offsets, self.in_bonds = nl.transpose()
        self.sources = nl.sources()
        counts = nl.counts()[:n]
        in_counts = np.diff(self.in_offsets)[:nrows] if nrows else np.zeros(0, np.int64)
        self.max_degree = int(counts.max()) if n else 0
        self.max_in = int(in_counts.max()) if in_counts.size else 0
        if kind == "block diagonal":
            self.indptr = np.arange(nrows + 1, dtype=np.int64)
            self.indices = np.arange(nrows, dtype=np.int32)
        else:
            pairs_only = all(blk.material.tangent_coupling == "pairs" for blk in sim.blocks)
            self.indptr, self.indices = self._pattern(pairs_only)
        self.data = np.zeros((self.indices.shape[0], 3, 3))
        rows = np.repeat(np.arange(nrows), np.diff(self.indptr))
        where = np.nonzero(self.indices == rows)[0]
        self.diag_pos = np.empty(nrows, dtype=np.int64)
        self.diag_pos[rows[where]] = where
        self.nchunks = max(1, min(nrows, 8 * _num_threads()))
        if self.parallel:
            self._buf = np.zeros((nrows, 3))
            self._xe = np.zeros(3 * nrows)
            self._ye = np.zeros(3 * nrows)
        self.allocation_time = _time.perf_counter() - t0
        self.assembly_time = 0.0
        self.assemblies = 0
        self._fd_scratch = None
        self._fd_scratch_vector = None

    # -- pattern --------------------------------------------------------------------------------
    def _pattern(self, pairs_only: bool) -> tuple[np.ndarray, np.ndarray]:
        import scipy.sparse as sp

        n = self.n
        m = self.nrows
        nl = self.sim.bonds
        counts = nl.counts()[:n]
        owner = np.repeat(np.arange(n, dtype=np.int64), counts)
        nb = nl.neighbors[: nl.offsets[n]].astype(np.int64)
        r_owner = self.row_of_local[owner]
        r_nb = self.row_of_local[nb]  # under MPI ghost columns are rows of this rank's matrix too
        if pairs_only:
            rows = np.concatenate([np.arange(m), r_owner, r_nb])
            cols = np.concatenate([np.arange(m), r_nb, r_owner])
            P = sp.csr_matrix((np.ones(rows.size, dtype=np.int8), (rows, cols)), shape=(m, m))
        else:
            # B[i, s] = 1 for s in S_i (i owned); P = B^T B couples every pair of a common family
            rows = np.concatenate([np.arange(n), r_owner])
            cols = np.concatenate([np.arange(n), r_nb])
            B = sp.csr_matrix((np.ones(rows.size, dtype=np.float32), (rows, cols)), shape=(n, m))
            P = (B.T.tocsr() @ B).tocsr()
            if m > n:  # every ghost row has its diagonal (it is in some owned point's family)
                P = (P + sp.identity(m, dtype=np.float32, format="csr")).tocsr()
        P.sum_duplicates()
        P.sort_indices()
        return P.indptr.astype(np.int64), P.indices.astype(np.int32)

    # -- properties -----------------------------------------------------------------------------
    @property
    def nnz(self) -> int:
        """Stored scalar entries (9 per block; this rank's under MPI)."""
        return 9 * int(self.indices.shape[0])

    @property
    def shape(self) -> tuple[int, int]:
        """Shape of the stored matrix (under MPI: this rank's K_r over its local points)."""
        return (3 * self.nrows, 3 * self.nrows)

    def nbytes(self) -> int:
        return self.data.nbytes + self.indices.nbytes + self.indptr.nbytes

    def target(self) -> TangentTarget:
        return TangentTarget(
            self.indptr, self.indices, self.data, self.row_of_local, self.local_of_row, self.eval_rank,
            self.in_offsets, self.in_bonds, self.sources, self.nrows, self.nchunks, self.max_degree, self.max_in,
        )

    # -- filling --------------------------------------------------------------------------------
    def assemble(self, probe_length: float | None = None) -> None:
        """K at the current Coordinates (bond damage as it stands): zero, then every block's
        material adds its points' contributions (analytic tangent or finite differences).
        Under MPI the ghost positions are refreshed first and the diagonal blocks consolidated
        on their owners afterwards."""
        t0 = _time.perf_counter()
        sim = self.sim
        if self.parallel:
            sim.halo.exchange(sim.fields["Coordinates"])
            if "Temperature_Change" in sim.fields:
                sim.halo.exchange(sim.fields["Temperature_Change"])
        self.data[:] = 0.0
        for blk in sim.blocks:
            blk.material.precompute(blk.view)
        target = self.target()
        for blk in sim.blocks:
            target.probe_length = _probe_length(sim, blk, probe_length)
            if not blk.material.tangent(blk.view, target):
                self._finite_difference(blk, target.probe_length)
        if self.parallel:
            self._consolidate_diagonal()
        self.assembly_time += _time.perf_counter() - t0
        self.assemblies += 1

    def _consolidate_diagonal(self) -> None:
        """Add the diagonal blocks of ghost rows into their owners' and zero them there."""
        n = self.n
        blocks = np.empty((self.nrows, 3, 3))
        blocks[self.local_of_row] = self.data[self.diag_pos]
        self.sim.halo.reverse_sum(blocks)
        self.data[self.diag_pos[:n]] = blocks[self.owned_local]
        self.data[self.diag_pos[n:]] = 0.0

    def _finite_difference(self, blk, eps: float) -> None:
        """Peridigm's central-difference tangent of one block (Material::computeFiniteDifferenceJacobian).

        Runs on one thread: every kernel call covers a single point, where a parallel launch
        costs more than the work."""
        import numba

        before = numba.get_num_threads()
        numba.set_num_threads(1)
        try:
            self._finite_difference_points(blk, eps)
        finally:
            numba.set_num_threads(before)

    def _finite_difference_points(self, blk, eps: float) -> None:
        sim = self.sim
        mat = blk.material
        view = blk.view
        s = sim.fields
        nl = sim.bonds
        y = s["Coordinates"]
        volume = s["Volume"]
        vector = mat.force_state_kind == "vector"
        if vector:
            if self._fd_scratch_vector is None:
                self._fd_scratch_vector = np.zeros((nl.num_bonds, 3))
            t = self._fd_scratch_vector
        else:
            if self._fd_scratch is None:
                self._fd_scratch = np.zeros(nl.num_bonds)
            t = self._fd_scratch
        # rate-form materials: Peridigm's probe moves the velocity by eps/dt with the position
        v = s["Velocity"] if mat.tangent_perturbs_velocity else None
        dv = eps / view.time_step if v is not None and view.time_step > 0 else 0.0

        def local(out):
            if vector:
                local_vector_force_kernel(i, nl.offsets, nl.neighbors, volume, t, out)
            else:
                local_force_kernel(i, nl.offsets, nl.neighbors, y, volume, t, out)
        pts = np.arange(blk.start, blk.stop)
        pts = pts[np.argsort(self.eval_rank[pts], kind="stable")]
        for i in pts:
            i = int(i)
            o, e = int(nl.offsets[i]), int(nl.offsets[i + 1])
            S = np.concatenate([nl.neighbors[o:e].astype(np.int64), [i]])
            ns = S.shape[0]
            vi = dataclasses.replace(view, start=i, stop=i + 1)
            Fp = np.empty(3 * ns)
            Fm = np.empty(3 * ns)
            Kloc = np.empty((3 * ns, 3 * ns))
            Vs = np.repeat(volume[S], 3)
            for a in range(ns):
                q = int(S[a])
                for c in range(3):
                    orig = y[q, c]
                    vorig = v[q, c] if v is not None else 0.0
                    y[q, c] = orig - eps
                    if v is not None:
                        v[q, c] = vorig - dv
                    mat.precompute(vi)
                    mat.force_state(vi, t)
                    local(Fm)
                    y[q, c] = orig + eps
                    if v is not None:
                        v[q, c] = vorig + dv
                    mat.precompute(vi)
                    mat.force_state(vi, t)
                    local(Fp)
                    y[q, c] = orig
                    if v is not None:
                        v[q, c] = vorig
                    Kloc[:, 3 * a + c] = (((Fp - Fm) / eps) * 0.5) * Vs
            mat.precompute(vi)  # leave point i's state as at the unperturbed configuration
            keep = S < self.nrows
            rows = self.row_of_local[S[keep]]
            if not keep.all():
                idx = np.flatnonzero(np.repeat(keep, 3))
                Kloc = Kloc[np.ix_(idx, idx)]
            scatter_local_kernel(rows, np.ascontiguousarray(Kloc), self.indptr, self.indices, self.data)

    # -- operations -----------------------------------------------------------------------------
    def apply_kinematic_bc(self, fixed_rows: np.ndarray) -> float:
        """Zero the rows and columns of fixed dofs ((n, 3) bool, owned rows in row order) and
        set their diagonal to D = -(sum |K_kk|)/N_dof; returns D. Under MPI the sum runs over
        all ranks (N_dof global) and the ghost rows' fixed flags come from their owners."""
        if not self.parallel:
            return kinematic_bc_kernel(self.indptr, self.indices, self.data, self.diag_pos, fixed_rows)
        total = self.comm.allreduce_sum(float(abs_diagonal_sum_kernel(self.data, self.diag_pos, self.n)))
        D = (-1.0 * total) / self.ndof if self.ndof > 0 else 0.0
        kinematic_bc_set_kernel(self.indptr, self.indices, self.data, self.diag_pos, self.extend_flags(fixed_rows), D, self.n)
        return D

    def extend_flags(self, fixed_rows: np.ndarray) -> np.ndarray:
        """(nrows, 3) bool: the owned rows' flags ``fixed_rows`` ((n, 3), row order) followed
        by those of the ghost rows, taken from their owners (one halo exchange)."""
        if not self.parallel:
            return np.ascontiguousarray(fixed_rows, dtype=np.bool_)
        buf = np.zeros((self.nrows, 3))
        buf[self.owned_local] = fixed_rows
        self.sim.halo.exchange(buf)
        out = np.empty((self.nrows, 3), dtype=np.bool_)
        out[: self.n] = fixed_rows
        out[self.n :] = buf[self.n :] > 0.5
        return out

    def scale(self, factor: float) -> None:
        np.multiply(self.data, factor, out=self.data)

    def add_to_diagonal(self, values: np.ndarray) -> None:
        """K_kk += values[k] for every owned dof k (row order, (3 n,))."""
        v = values.reshape(self.n, 3)
        dp = self.diag_pos[: self.n]
        for d in range(3):
            self.data[dp, d, d] = self.data[dp, d, d] + v[:, d]

    def damp(self, scale: float, shift: float) -> None:
        if not self.parallel:
            damp_diagonal_kernel(self.data, self.diag_pos, scale, shift)
            return
        dp = self.diag_pos[: self.n]
        dmax = 0.0
        for d in range(3):
            v = self.data[dp, d, d] * scale
            self.data[dp, d, d] = v
            if v.size:
                dmax = max(dmax, float(np.max(np.abs(v))))
        dmax = self.comm.allreduce_max(dmax)
        for d in range(3):
            self.data[dp, d, d] = self.data[dp, d, d] + shift * dmax

    def diagonal(self) -> np.ndarray:
        """(3 n,) diagonal of the owned rows in row order (the assembled values)."""
        dp = self.diag_pos[: self.n]
        return np.stack([self.data[dp, d, d] for d in range(3)], axis=1).reshape(-1)

    def matvec(self, x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """out = K x for x of the owned rows (3 n,); under MPI a collective call: x's ghost
        entries come from their owners and the ghost rows of K_r x go back to them."""
        if out is None:
            out = np.empty(3 * self.n)
        if not self.parallel:
            bsr_matvec_kernel(self.indptr, self.indices, self.data, x, out)
            return out
        n = self.n
        buf, xe, ye = self._buf, self._xe, self._ye
        halo = self.sim.halo
        buf[self.owned_local] = x.reshape(n, 3)
        halo.exchange(buf)
        xe[: 3 * n] = x
        xe[3 * n :] = buf[n:].reshape(-1)
        bsr_matvec_kernel(self.indptr, self.indices, self.data, xe, ye)
        buf[self.local_of_row] = ye.reshape(self.nrows, 3)
        halo.reverse_sum(buf)
        out[:] = buf[self.owned_local].reshape(-1)
        return out

    def to_scipy(self, copy: bool = False):
        """The stored matrix as ``scipy.sparse.bsr_matrix`` (shares the arrays unless ``copy``;
        under MPI this rank's K_r over its local points, see :meth:`owned_block`)."""
        import scipy.sparse as sp

        return sp.bsr_matrix((self.data.copy() if copy else self.data, self.indices, self.indptr), shape=self.shape)

    def copy_data(self) -> np.ndarray:
        return self.data.copy()

    def diagonal_blocks(self) -> np.ndarray:
        """(n, 3, 3) diagonal blocks of the owned rows (row order; the assembled values)."""
        return self.data[self.diag_pos[: self.n]].copy()

    # -- distributed views ----------------------------------------------------------------------
    def owned_block(self):
        """The owned-by-owned block of the assembled matrix as a scipy CSR matrix (3 n x 3 n):
        the matrix itself serially; under MPI (a collective call) this rank's K_r restricted to
        its owned rows and columns plus the entries other ranks hold in ghost rows of this
        rank's points whose columns are also this rank's points. What block-Jacobi and
        AMG-per-rank preconditioners factor."""
        import scipy.sparse as sp

        n = self.n
        A = self.to_scipy(copy=True).tocsr()
        if not self.parallel:
            return A
        sim = self.sim
        A = A[: 3 * n, : 3 * n].tocoo()
        # entries of ghost rows g whose column k is a ghost owned by the same rank as g
        owner_row = np.full(self.nrows, sim.comm.rank, dtype=np.int64)
        m_row = sim.mothership_of_local[self.local_of_row]
        owner_row[n:] = sim.owner[m_row[n:]]
        rows = np.repeat(np.arange(self.nrows), np.diff(self.indptr))
        cols = self.indices.astype(np.int64)
        sel = (rows >= n) & (cols >= n)
        sel[sel] = owner_row[rows[sel]] == owner_row[cols[sel]]
        sel[sel] = rows[sel] != cols[sel]  # the diagonal blocks are consolidated already
        pos = np.nonzero(sel)[0]
        dest = owner_row[rows[pos]]
        sends = []
        for r in range(sim.comm.size):
            k = pos[dest == r]
            sends.append((m_row[rows[k]], m_row[cols[k]], self.data[k]) if k.size else None)
        received = [x for x in sim.comm.alltoall(sends) if x is not None]
        if received:
            mr = np.concatenate([x[0] for x in received])
            mc = np.concatenate([x[1] for x in received])
            blk = np.concatenate([x[2] for x in received])
            r_loc = self.row_of_local[sim.local_of_mothership[mr]]
            c_loc = self.row_of_local[sim.local_of_mothership[mc]]
            d, c = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")
            ri = (3 * r_loc[:, None, None] + d[None]).reshape(-1)
            ci = (3 * c_loc[:, None, None] + c[None]).reshape(-1)
            extra = sp.coo_matrix((blk.reshape(-1), (ri, ci)), shape=(3 * n, 3 * n))
            A = sp.coo_matrix((np.concatenate([A.data, extra.data]), (np.concatenate([A.row, extra.row]), np.concatenate([A.col, extra.col]))), shape=(3 * n, 3 * n))
        A = A.tocsr()
        A.sum_duplicates()
        return A

    def gather_to_root(self):
        """The whole assembled matrix as a scipy CSC matrix on rank 0 (None on other ranks), with
        dof 3 m + c for mothership index m (collective). For small systems: rank 0 holds it all."""
        import scipy.sparse as sp

        sim = self.sim
        rows = np.repeat(np.arange(self.nrows), np.diff(self.indptr))
        m_row = sim.mothership_of_local[self.local_of_row]
        keep = np.ones(rows.size, dtype=bool)
        keep[self.diag_pos[self.n :]] = False  # consolidated (zero)
        piece = (m_row[rows[keep]], m_row[self.indices[keep].astype(np.int64)], self.data[keep])
        pieces = sim.comm.gather(piece)
        if pieces is None:
            return None
        mr = np.concatenate([p[0] for p in pieces])
        mc = np.concatenate([p[1] for p in pieces])
        blk = np.concatenate([p[2] for p in pieces])
        d, c = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")
        ri = (3 * mr[:, None, None] + d[None]).reshape(-1)
        ci = (3 * mc[:, None, None] + c[None]).reshape(-1)
        A = sp.coo_matrix((blk.reshape(-1), (ri, ci)), shape=(self.ndof, self.ndof)).tocsc()
        A.sum_duplicates()
        return A

    def gather_vector(self, v: np.ndarray):
        """(3 n,) owned rows -> (ndof,) in mothership order on rank 0 (None elsewhere)."""
        sim = self.sim
        full = sim.comm.gather_points(self.to_local(v), sim.mothership_of_local[: self.n], sim.num_global)
        return None if full is None else full.reshape(-1)

    def scatter_vector(self, full: np.ndarray | None) -> np.ndarray:
        """Inverse of :meth:`gather_vector` (collective): rank 0's (ndof,) vector in mothership
        order -> this rank's owned rows (3 n,)."""
        sim = self.sim
        full = sim.comm.bcast(full)
        return self.to_rows(full.reshape(-1, 3)[sim.mothership_of_local[: self.n]])

    # -- ordering of vectors --------------------------------------------------------------------
    def to_rows(self, a: np.ndarray) -> np.ndarray:
        """Local (n, 3) point array -> (3 n,) vector of the owned rows in row (global-id) order."""
        return np.ascontiguousarray(a[: self.n][self.owned_local]).reshape(-1)

    def to_local(self, v: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """(3 n,) row-order vector -> local (n, 3) (written into ``out`` when given)."""
        if out is None:
            out = np.empty((self.n, 3))
        out[self.owned_local] = v.reshape(self.n, 3)
        return out


def _num_threads() -> int:
    import numba

    return int(numba.get_num_threads())


def _probe_length(sim, blk, probe_length: float | None) -> float:
    """Finite-difference probe: the material's ``Finite Difference Probe Length``, else the
    solver's, else 1e-6 * minElementRadius (Peridigm's default)."""
    own = getattr(blk.material.params, "finite_difference_probe_length", None)
    if own is not None:
        return float(own)
    if probe_length is not None:
        return float(probe_length)
    return 1.0e-6 * float(sim.discretization.min_element_radius)
