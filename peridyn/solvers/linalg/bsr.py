"""Point-block sparse matrices: B x B blocks (B degrees of freedom per point), rows and columns in
global-id order, stored by subdomain under MPI. What the 3-dof tangent of the implicit solvers
(:mod:`peridyn.solvers.linalg.tangent`) and the 4-dof tangent of the coupled solve
(:mod:`peridyn.solvers.linalg.coupled_tangent`) share: the row maps, the pattern, the kinematic
boundary conditions, damping, products, and the distributed views (see the tangent module's
docstring for the storage under MPI). The kernels take B from the shape of ``data``
(nnzb, B, B) and sum in the same order for every B (Peridigm's: ascending dof order).
"""
from __future__ import annotations

import time as _time

import numpy as np
from numba import njit, prange


@njit(cache=True, parallel=True)
def bsr_matvec_kernel(indptr, indices, data, x, out):
    """out = A x for a BxB-block BSR matrix; x, out (B nrows,). Each row component is summed from
    0.0 over the row's blocks in ascending column order, and within a block over its columns
    (Epetra's CrsMatrix product), so the result does not depend on the thread count. The
    components of a row are accumulated in one pass over its blocks: in registers for B <= 4,
    in ``out``'s own row beyond."""
    n = indptr.shape[0] - 1
    B = data.shape[1]
    for r in prange(n):
        o = B * r
        if B <= 4:
            a0 = 0.0
            a1 = 0.0
            a2 = 0.0
            a3 = 0.0
            for p in range(indptr[r], indptr[r + 1]):
                c0 = B * indices[p]
                for c in range(B):
                    xc = x[c0 + c]
                    a0 += data[p, 0, c] * xc
                    if B > 1:
                        a1 += data[p, 1, c] * xc
                    if B > 2:
                        a2 += data[p, 2, c] * xc
                    if B > 3:
                        a3 += data[p, 3, c] * xc
            out[o] = a0
            if B > 1:
                out[o + 1] = a1
            if B > 2:
                out[o + 2] = a2
            if B > 3:
                out[o + 3] = a3
            continue
        for d in range(B):
            out[o + d] = 0.0
        for p in range(indptr[r], indptr[r + 1]):
            c0 = B * indices[p]
            for c in range(B):
                xc = x[c0 + c]
                for d in range(B):
                    out[o + d] += data[p, d, c] * xc


@njit(cache=True)
def abs_diagonal_sum_kernel(data, diag_pos, n):
    """sum_k |A_kk| over the first n block rows (sequential, ascending dof order)."""
    total = 0.0
    for r in range(n):
        p = diag_pos[r]
        for d in range(data.shape[1]):
            total += abs(data[p, d, d])
    return total


@njit(cache=True)
def kinematic_bc_set_kernel(indptr, indices, data, diag_pos, fixed, D, nset):
    """Entries in a fixed row or column (fixed: (nrows, B) bool over owned and ghost rows) are
    zeroed; the diagonal of the fixed dofs of the first ``nset`` rows (the owned ones) is set
    to D (ghost rows keep 0: the owner holds the diagonal)."""
    n = indptr.shape[0] - 1
    B = data.shape[1]
    for r in range(n):
        for p in range(indptr[r], indptr[r + 1]):
            col = indices[p]
            for d in range(B):
                for c in range(B):
                    if fixed[r, d] or fixed[col, c]:
                        data[p, d, c] = 0.0
    for r in range(nset):
        p = diag_pos[r]
        for d in range(B):
            if fixed[r, d]:
                data[p, d, d] = D


@njit(cache=True)
def damp_diagonal_kernel(data, diag_pos, scale, shift):
    """Peridigm's quasiStaticsDampTangent: d = diag * scale (per entry), then d += shift * max|d|,
    written back to the diagonal."""
    n = diag_pos.shape[0]
    B = data.shape[1]
    dmax = 0.0
    for r in range(n):
        p = diag_pos[r]
        for d in range(B):
            v = data[p, d, d] * scale
            data[p, d, d] = v
            if abs(v) > dmax:
                dmax = abs(v)
    for r in range(n):
        p = diag_pos[r]
        for d in range(B):
            data[p, d, d] = data[p, d, d] + shift * dmax


class PointBlockMatrix:
    """A BxB-block sparse matrix over the points (``block`` = B dofs per point), rows in global-id
    order: ``n`` owned points (vectors handed to solvers have B n entries, owned rows in row
    order), ``nrows`` stored block rows (n serially; owned then ghost points under MPI), ``ndof``
    unknowns of the whole model. Subclasses fill ``data`` (nnzb, B, B) in ``assemble``."""

    block: int

    def __init__(self, sim, block: int, pattern: str = "family") -> None:
        """``pattern``: "family" (Peridigm's: all dofs of S_i), "pairs" (bonded pairs only) or
        "block diagonal"."""
        self._t0 = _time.perf_counter()
        self.sim = sim
        self.block = block
        self.comm = sim.comm
        self.parallel = sim.comm.size > 1
        n = sim.num_owned
        self.n = n
        nrows = int(sim.num_local) if self.parallel else n
        self.nrows = nrows
        self.ndof = block * int(sim.num_global)
        gid = np.asarray(sim.gid[:n], dtype=np.int64)
        self.local_of_row = np.concatenate([np.argsort(gid, kind="stable"), np.arange(n, nrows)]).astype(np.int64)
        self.row_of_local = np.empty(nrows, dtype=np.int64)
        self.row_of_local[self.local_of_row] = np.arange(nrows)
        self.owned_local = self.local_of_row[:n]
        self.eval_rank = evaluation_rank(sim)
        if pattern == "block diagonal":
            self.indptr = np.arange(nrows + 1, dtype=np.int64)
            self.indices = np.arange(nrows, dtype=np.int32)
        else:
            self.indptr, self.indices = self.point_pattern(pattern == "pairs")
        self.data = np.zeros((self.indices.shape[0], block, block))
        rows = np.repeat(np.arange(nrows), np.diff(self.indptr))
        where = np.nonzero(self.indices == rows)[0]
        self.diag_pos = np.empty(nrows, dtype=np.int64)
        self.diag_pos[rows[where]] = where
        if self.parallel:
            self._buf = np.zeros((nrows, block))
            self._xe = np.zeros(block * nrows)
            self._ye = np.zeros(block * nrows)
        self.assembly_time = 0.0
        self.assemblies = 0

    def _allocated(self) -> None:
        """Records the allocation time (subclasses call it at the end of their ``__init__``)."""
        self.allocation_time = _time.perf_counter() - self._t0

    def point_pattern(self, pairs_only: bool) -> tuple[np.ndarray, np.ndarray]:
        """Block pattern (indptr (nrows+1,) int64, indices int32) in row numbering: every point i
        couples the whole of S_i = {i} U N_i (Peridigm's), or, ``pairs_only``, the bonded pairs."""
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
        """Stored scalar entries (B^2 per block; this rank's under MPI)."""
        return self.block * self.block * int(self.indices.shape[0])

    @property
    def shape(self) -> tuple[int, int]:
        """Shape of the stored matrix (under MPI: this rank's K_r over its local points)."""
        return (self.block * self.nrows, self.block * self.nrows)

    def nbytes(self) -> int:
        return self.data.nbytes + self.indices.nbytes + self.indptr.nbytes

    def consolidate_diagonal(self) -> None:
        """MPI: add the diagonal blocks of ghost rows into their owners' and zero them there."""
        n, B = self.n, self.block
        blocks = np.empty((self.nrows, B, B))
        blocks[self.local_of_row] = self.data[self.diag_pos]
        self.sim.halo.reverse_sum(blocks)
        self.data[self.diag_pos[:n]] = blocks[self.owned_local]
        self.data[self.diag_pos[n:]] = 0.0

    # -- operations -----------------------------------------------------------------------------
    def apply_kinematic_bc(self, fixed_rows: np.ndarray) -> float:
        """Peridigm's applyKinematicBC_InsertZerosAndSetDiagonal: D = -(sum |K_kk|)/N_dof from the
        diagonal before any change (summed over all ranks), then the rows and columns of the fixed
        dofs ((n, B) bool, owned rows in row order; ghost rows' flags from their owners) are
        zeroed and their diagonal set to D; returns D."""
        total = float(abs_diagonal_sum_kernel(self.data, self.diag_pos, self.n))
        if self.parallel:
            total = self.comm.allreduce_sum(total)
        D = (-1.0 * total) / self.ndof if self.ndof > 0 else 0.0
        kinematic_bc_set_kernel(self.indptr, self.indices, self.data, self.diag_pos, self.extend_flags(fixed_rows), D, self.n)
        return D

    def extend_flags(self, fixed_rows: np.ndarray) -> np.ndarray:
        """(nrows, B) bool: the owned rows' flags ``fixed_rows`` ((n, B), row order) followed
        by those of the ghost rows, taken from their owners (one halo exchange)."""
        B = self.block
        if not self.parallel:
            return np.ascontiguousarray(fixed_rows, dtype=np.bool_)
        buf = np.zeros((self.nrows, B))
        buf[self.owned_local] = fixed_rows
        self.sim.halo.exchange(buf)
        out = np.empty((self.nrows, B), dtype=np.bool_)
        out[: self.n] = fixed_rows
        out[self.n :] = buf[self.n :] > 0.5
        return out

    def scale(self, factor: float) -> None:
        np.multiply(self.data, factor, out=self.data)

    def add_to_diagonal(self, values: np.ndarray) -> None:
        """K_kk += values[k] for every owned dof k (row order, (B n,))."""
        B = self.block
        v = values.reshape(self.n, B)
        dp = self.diag_pos[: self.n]
        for d in range(B):
            self.data[dp, d, d] = self.data[dp, d, d] + v[:, d]

    def damp(self, scale: float, shift: float) -> None:
        """Peridigm's quasiStaticsDampTangent: diag *= scale, then += shift * max|diag| (max over
        all ranks)."""
        B = self.block
        if not self.parallel:
            damp_diagonal_kernel(self.data, self.diag_pos, scale, shift)
            return
        dp = self.diag_pos[: self.n]
        dmax = 0.0
        for d in range(B):
            v = self.data[dp, d, d] * scale
            self.data[dp, d, d] = v
            if v.size:
                dmax = max(dmax, float(np.max(np.abs(v))))
        dmax = self.comm.allreduce_max(dmax)
        for d in range(B):
            self.data[dp, d, d] = self.data[dp, d, d] + shift * dmax

    def diagonal(self) -> np.ndarray:
        """(B n,) diagonal of the owned rows in row order (the assembled values)."""
        dp = self.diag_pos[: self.n]
        return np.stack([self.data[dp, d, d] for d in range(self.block)], axis=1).reshape(-1)

    def matvec(self, x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """out = K x for x of the owned rows (B n,); under MPI a collective call: x's ghost
        entries come from their owners and the ghost rows of K_r x go back to them."""
        B = self.block
        if out is None:
            out = np.empty(B * self.n)
        if not self.parallel:
            bsr_matvec_kernel(self.indptr, self.indices, self.data, x, out)
            return out
        n = self.n
        buf, xe, ye = self._buf, self._xe, self._ye
        halo = self.sim.halo
        buf[self.owned_local] = x.reshape(n, B)
        halo.exchange(buf)
        xe[: B * n] = x
        xe[B * n :] = buf[n:].reshape(-1)
        bsr_matvec_kernel(self.indptr, self.indices, self.data, xe, ye)
        buf[self.local_of_row] = ye.reshape(self.nrows, B)
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
        """(n, B, B) diagonal blocks of the owned rows (row order; the assembled values)."""
        return self.data[self.diag_pos[: self.n]].copy()

    def owned_block(self):
        """The owned-by-owned block of the assembled matrix as a scipy CSR matrix (B n x B n):
        the matrix itself serially; under MPI (a collective call) this rank's K_r restricted to
        its owned rows and columns plus the entries other ranks hold in ghost rows of this
        rank's points whose columns are also this rank's points. What block-Jacobi and
        AMG-per-rank preconditioners factor."""
        B = self.block
        import scipy.sparse as sp

        n = self.n
        A = self.to_scipy(copy=True).tocsr()
        if not self.parallel:
            return A
        sim = self.sim
        A = A[: B * n, : B * n].tocoo()
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
            d, c = np.meshgrid(np.arange(B), np.arange(B), indexing="ij")
            ri = (B * r_loc[:, None, None] + d[None]).reshape(-1)
            ci = (B * c_loc[:, None, None] + c[None]).reshape(-1)
            extra = sp.coo_matrix((blk.reshape(-1), (ri, ci)), shape=(B * n, B * n))
            A = sp.coo_matrix((np.concatenate([A.data, extra.data]), (np.concatenate([A.row, extra.row]), np.concatenate([A.col, extra.col]))), shape=(B * n, B * n))
        A = A.tocsr()
        A.sum_duplicates()
        return A

    def gather_to_root(self):
        """The whole assembled matrix as a scipy CSC matrix on rank 0 (None on other ranks), with
        dof B m + c for mothership index m (collective). For small systems: rank 0 holds it all."""
        B = self.block
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
        d, c = np.meshgrid(np.arange(B), np.arange(B), indexing="ij")
        ri = (B * mr[:, None, None] + d[None]).reshape(-1)
        ci = (B * mc[:, None, None] + c[None]).reshape(-1)
        A = sp.coo_matrix((blk.reshape(-1), (ri, ci)), shape=(self.ndof, self.ndof)).tocsc()
        A.sum_duplicates()
        return A

    def gather_vector(self, v: np.ndarray):
        """(B n,) owned rows -> (ndof,) in mothership order on rank 0 (None elsewhere)."""
        sim = self.sim
        full = sim.comm.gather_points(self.to_local(v), sim.mothership_of_local[: self.n], sim.num_global)
        return None if full is None else full.reshape(-1)

    def scatter_vector(self, full: np.ndarray | None) -> np.ndarray:
        """Inverse of :meth:`gather_vector` (collective): rank 0's (ndof,) vector in mothership
        order -> this rank's owned rows (B n,)."""
        B = self.block
        sim = self.sim
        full = sim.comm.bcast(full)
        return self.to_rows(full.reshape(-1, B)[sim.mothership_of_local[: self.n]])

    # -- ordering of vectors --------------------------------------------------------------------
    def to_rows(self, a: np.ndarray) -> np.ndarray:
        """Local (n, B) point array -> (B n,) vector of the owned rows in row (global-id) order."""
        return np.ascontiguousarray(a[: self.n][self.owned_local]).reshape(-1)

    def to_local(self, v: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """(B n,) row-order vector -> local (n, B) (written into ``out`` when given)."""
        B = self.block
        if out is None:
            out = np.empty((self.n, B))
        out[self.owned_local] = v.reshape(self.n, B)
        return out


def evaluation_rank(sim) -> np.ndarray:
    """(n,) position of every local point in Peridigm's evaluation order: blocks in block order,
    points by global id inside a block."""
    n = sim.num_owned
    order = np.lexsort((sim.gid[:n], sim.block_index[:n]))
    rank = np.empty(n, dtype=np.int64)
    rank[order] = np.arange(n)
    return rank
