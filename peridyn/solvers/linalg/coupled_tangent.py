"""The 4x4-block tangent of the coupled (displacement and fluid pressure) QuasiStatic solve:
K = d(f V, flow V)/d(y, p), 4 degrees of freedom per point (u_x, u_y, u_z, p), the dof (g, c) at
row 4 g + c (PERIDIGM_MODELS.md §7).

The same storage as :class:`peridyn.solvers.linalg.tangent.TangentMatrix` (Peridigm's pattern: every
point couples all dofs of S_i = {i} U N_i; rows in global-id order; under MPI stored by
subdomain, owned rows then ghost rows, diagonal blocks consolidated on their owners after every
assembly; products exchange x's ghost entries and add the ghost rows back to their owners),
with 4x4 blocks. The materials fill it through ``coupled_tangent(view, target)``. Provides what
:class:`peridyn.solvers.linalg.linear.LinearSolver` uses for its ``Belos`` (Peridigm's CG) and
``Direct`` methods: ``matvec``, ``ndof``, ``parallel``/``comm``, ``to_scipy``, ``gather_*``.
"""
from __future__ import annotations

import time as _time
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from .tangent import TangentMatrix, evaluation_rank

B = 4  #: dofs per point


@dataclass
class CoupledTangentTarget:
    """What ``Material.coupled_tangent`` writes into: BSR arrays (data (nnzb, 4, 4),
    ``data[p, d, c] = d(F_(row,d) V_row)/d(unknown_(col,c))``), the local-to-row map and
    Peridigm's evaluation order of the points."""

    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray
    row_of_local: np.ndarray
    eval_rank: np.ndarray


@njit(cache=True, parallel=True)
def bsr4_matvec_kernel(indptr, indices, data, x, out):
    """out = A x for a 4x4-block BSR matrix; each row summed from 0.0 in ascending column order."""
    n = indptr.shape[0] - 1
    for r in prange(n):
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        a3 = 0.0
        for p in range(indptr[r], indptr[r + 1]):
            c0 = 4 * indices[p]
            for c in range(4):
                xc = x[c0 + c]
                a0 += data[p, 0, c] * xc
                a1 += data[p, 1, c] * xc
                a2 += data[p, 2, c] * xc
                a3 += data[p, 3, c] * xc
        out[4 * r] = a0
        out[4 * r + 1] = a1
        out[4 * r + 2] = a2
        out[4 * r + 3] = a3


@njit(cache=True)
def abs_diagonal_sum4(data, diag_pos, n):
    """sum_k |A_kk| over the first n block rows (sequential, ascending dof order)."""
    total = 0.0
    for r in range(n):
        p = diag_pos[r]
        for d in range(4):
            total += abs(data[p, d, d])
    return total


@njit(cache=True)
def kinematic_bc4_kernel(indptr, indices, data, diag_pos, fixed, D, nset):
    """Zero every entry in a fixed row or column (fixed: (nrows, 4) bool) and set the diagonal
    of the fixed dofs of the first ``nset`` rows to D."""
    n = indptr.shape[0] - 1
    for r in range(n):
        for p in range(indptr[r], indptr[r + 1]):
            col = indices[p]
            for d in range(4):
                for c in range(4):
                    if fixed[r, d] or fixed[col, c]:
                        data[p, d, c] = 0.0
    for r in range(nset):
        p = diag_pos[r]
        for d in range(4):
            if fixed[r, d]:
                data[p, d, d] = D


class CoupledTangent:
    """K = d(f V, flow V)/d(y, p) of the owned points, 4x4-block sparse (see module docstring).
    ``n`` owned points; vectors handed to the solvers have 4 n entries in row order."""

    parallel: bool

    def __init__(self, sim) -> None:
        t0 = _time.perf_counter()
        self.sim = sim
        self.comm = sim.comm
        self.parallel = sim.comm.size > 1
        n = sim.num_owned
        self.n = n
        nrows = int(sim.num_local) if self.parallel else n
        self.nrows = nrows
        self.ndof = B * int(sim.num_global)
        gid = np.asarray(sim.gid[:n], dtype=np.int64)
        self.local_of_row = np.concatenate([np.argsort(gid, kind="stable"), np.arange(n, nrows)]).astype(np.int64)
        self.row_of_local = np.empty(nrows, dtype=np.int64)
        self.row_of_local[self.local_of_row] = np.arange(nrows)
        self.owned_local = self.local_of_row[:n]
        self.eval_rank = evaluation_rank(sim)
        self.indptr, self.indices = TangentMatrix._pattern(self, False)  # the same point pattern
        self.data = np.zeros((self.indices.shape[0], B, B))
        rows = np.repeat(np.arange(nrows), np.diff(self.indptr))
        where = np.nonzero(self.indices == rows)[0]
        self.diag_pos = np.empty(nrows, dtype=np.int64)
        self.diag_pos[rows[where]] = where
        if self.parallel:
            self._buf = np.zeros((nrows, B))
            self._xe = np.zeros(B * nrows)
            self._ye = np.zeros(B * nrows)
        self.allocation_time = _time.perf_counter() - t0
        self.assembly_time = 0.0
        self.assemblies = 0

    # -- properties -----------------------------------------------------------------------------
    @property
    def nnz(self) -> int:
        return B * B * int(self.indices.shape[0])

    @property
    def shape(self) -> tuple[int, int]:
        return (B * self.nrows, B * self.nrows)

    def nbytes(self) -> int:
        return self.data.nbytes + self.indices.nbytes + self.indptr.nbytes

    # -- assembly -------------------------------------------------------------------------------
    def assemble(self) -> None:
        """K at the current Coordinates and Fluid_Pressure_Y (bond damage as it stands)."""
        t0 = _time.perf_counter()
        sim = self.sim
        if self.parallel:
            sim.halo.exchange(sim.fields["Coordinates"])
            sim.halo.exchange(sim.fields["Fluid_Pressure_Y"])
            if "Temperature_Change" in sim.fields:
                sim.halo.exchange(sim.fields["Temperature_Change"])
        self.data[:] = 0.0
        for blk in sim.blocks:
            blk.material.precompute(blk.view)
        if self.parallel:
            for name in sim.precompute_fields:
                sim.halo.exchange(sim.fields[name])
        target = CoupledTangentTarget(self.indptr, self.indices, self.data, self.row_of_local, self.eval_rank)
        for blk in sim.blocks:
            blk.material.coupled_tangent(blk.view, target)
        if self.parallel:
            n = self.n
            blocks = np.empty((self.nrows, B, B))
            blocks[self.local_of_row] = self.data[self.diag_pos]
            sim.halo.reverse_sum(blocks)
            self.data[self.diag_pos[:n]] = blocks[self.owned_local]
            self.data[self.diag_pos[n:]] = 0.0
        self.assembly_time += _time.perf_counter() - t0
        self.assemblies += 1

    # -- operations -----------------------------------------------------------------------------
    def extend_flags(self, fixed_rows: np.ndarray) -> np.ndarray:
        """(nrows, 4) bool: the owned rows' flags followed by the ghost rows' (from their owners)."""
        if not self.parallel:
            return np.ascontiguousarray(fixed_rows, dtype=np.bool_)
        buf = np.zeros((self.nrows, B))
        buf[self.owned_local] = fixed_rows
        self.sim.halo.exchange(buf)
        out = np.empty((self.nrows, B), dtype=np.bool_)
        out[: self.n] = fixed_rows
        out[self.n :] = buf[self.n :] > 0.5
        return out

    def apply_kinematic_bc(self, fixed_rows: np.ndarray) -> float:
        """Peridigm's applyKinematicBC_InsertZerosAndSetDiagonal over the 4 dofs of every point:
        D = (-1 sum |K_kk|)/N_dof, fixed rows and columns zeroed, their diagonal set to D."""
        total = abs_diagonal_sum4(self.data, self.diag_pos, self.n)
        if self.parallel:
            total = self.comm.allreduce_sum(float(total))
        D = (-1.0 * total) / self.ndof if self.ndof > 0 else 0.0
        kinematic_bc4_kernel(self.indptr, self.indices, self.data, self.diag_pos, self.extend_flags(fixed_rows), D, self.n)
        return D

    def scale(self, factor: float) -> None:
        np.multiply(self.data, factor, out=self.data)

    def damp(self, scale: float, shift: float) -> None:
        """Peridigm's quasiStaticsDampTangent: diag *= scale, then += shift * max|diag|."""
        dp = self.diag_pos[: self.n]
        dmax = 0.0
        for d in range(B):
            v = self.data[dp, d, d] * scale
            self.data[dp, d, d] = v
            if v.size:
                dmax = max(dmax, float(np.max(np.abs(v))))
        if self.parallel:
            dmax = self.comm.allreduce_max(dmax)
        for d in range(B):
            self.data[dp, d, d] = self.data[dp, d, d] + shift * dmax

    def diagonal(self) -> np.ndarray:
        dp = self.diag_pos[: self.n]
        return np.stack([self.data[dp, d, d] for d in range(B)], axis=1).reshape(-1)

    def matvec(self, x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """out = K x for x of the owned rows (4 n,) (collective under MPI)."""
        if out is None:
            out = np.empty(B * self.n)
        if not self.parallel:
            bsr4_matvec_kernel(self.indptr, self.indices, self.data, x, out)
            return out
        n = self.n
        buf, xe, ye = self._buf, self._xe, self._ye
        halo = self.sim.halo
        buf[self.owned_local] = x.reshape(n, B)
        halo.exchange(buf)
        xe[: B * n] = x
        xe[B * n :] = buf[n:].reshape(-1)
        bsr4_matvec_kernel(self.indptr, self.indices, self.data, xe, ye)
        buf[self.local_of_row] = ye.reshape(self.nrows, B)
        halo.reverse_sum(buf)
        out[:] = buf[self.owned_local].reshape(-1)
        return out

    def to_scipy(self, copy: bool = False):
        import scipy.sparse as sp

        return sp.bsr_matrix((self.data.copy() if copy else self.data, self.indices, self.indptr), shape=self.shape)

    def gather_to_root(self):
        """The whole matrix as scipy CSC on rank 0 (None elsewhere), dof 4 m + c (collective)."""
        import scipy.sparse as sp

        sim = self.sim
        rows = np.repeat(np.arange(self.nrows), np.diff(self.indptr))
        m_row = sim.mothership_of_local[self.local_of_row]
        keep = np.ones(rows.size, dtype=bool)
        keep[self.diag_pos[self.n :]] = False
        piece = (m_row[rows[keep]], m_row[self.indices[keep].astype(np.int64)], self.data[keep])
        pieces = sim.comm.gather(piece)
        if pieces is None:
            return None
        mr = np.concatenate([p[0] for p in pieces])
        mc = np.concatenate([p[1] for p in pieces])
        blk = np.concatenate([p[2] for p in pieces])
        d, c = np.meshgrid(np.arange(B), np.arange(B), indexing="ij")
        ri = (B * mr[:, None, None] + d[None]).reshape(-1)
        ci = (B * mc[:, None, None] + c[None]).reshape(-1)
        A = sp.coo_matrix((blk.reshape(-1), (ri, ci)), shape=(self.ndof, self.ndof)).tocsc()
        A.sum_duplicates()
        return A

    def gather_vector(self, v: np.ndarray):
        sim = self.sim
        full = sim.comm.gather_points(self.to_local(v), sim.mothership_of_local[: self.n], sim.num_global)
        return None if full is None else full.reshape(-1)

    def scatter_vector(self, full: np.ndarray | None) -> np.ndarray:
        sim = self.sim
        full = sim.comm.bcast(full)
        return self.to_rows(full.reshape(-1, B)[sim.mothership_of_local[: self.n]])

    # -- ordering of vectors --------------------------------------------------------------------
    def to_rows(self, a: np.ndarray) -> np.ndarray:
        """Local (n, 4) point array -> (4 n,) row-order vector of the owned rows."""
        return np.ascontiguousarray(a[: self.n][self.owned_local]).reshape(-1)

    def to_local(self, v: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """(4 n,) row-order vector -> local (n, 4)."""
        if out is None:
            out = np.empty((self.n, B))
        out[self.owned_local] = v.reshape(self.n, B)
        return out
