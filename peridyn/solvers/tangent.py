"""The tangent stiffness K = d(f V)/dy of the implicit solvers (PERIDIGM_SEMANTICS.md §11.1).

K is stored block-sparse (3x3 blocks, BSR) with rows and columns in **global-id order**, the
degree of freedom (g, c) at index 3 g + c as in Peridigm, so that matrix-vector products and
the Krylov solvers that reproduce Peridigm's (:mod:`peridyn.solvers.linear`) sum in Peridigm's
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
"""
from __future__ import annotations

import dataclasses
import logging
import math
import time as _time
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

log = logging.getLogger("peridyn.solver")


@dataclass
class TangentTarget:
    """What ``Material.tangent`` writes into: the BSR arrays of K in row (global-id) numbering
    and the maps a gather kernel needs.

    indptr (nrows+1,) int64; indices (nnzb,) int32 block columns (row numbering); data
    (nnzb, 3, 3) float64, ``data[p, d, c] = dF_(row,d)/dy_(col,c)`` (force per length);
    row_of_local / local_of_row map local point indices and rows; eval_rank (n,) is Peridigm's
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
        for d in range(3):
            acc = 0.0
            for p in range(indptr[r], indptr[r + 1]):
                c0 = 3 * indices[p]
                acc += data[p, d, 0] * x[c0]
                acc += data[p, d, 1] * x[c0 + 1]
                acc += data[p, d, 2] * x[c0 + 2]
            out[3 * r + d] = acc


@njit(cache=True)
def kinematic_bc_kernel(indptr, indices, data, diag_pos, fixed):
    """Peridigm's applyKinematicBC_InsertZerosAndSetDiagonal on a BSR matrix: D = (-1 * sum
    |A_kk|)/N_dof (sequential, ascending dof order, before any change), then rows and columns of
    the fixed dofs (fixed: (nrows, 3) bool) are zeroed and their diagonal set to D. Returns D."""
    n = indptr.shape[0] - 1
    total = 0.0
    for r in range(n):
        p = diag_pos[r]
        for d in range(3):
            total += abs(data[p, d, d])
    D = (-1.0 * total) / (3 * n) if n > 0 else 0.0
    any_fixed = False
    for r in range(n):
        for d in range(3):
            if fixed[r, d]:
                any_fixed = True
    if not any_fixed:
        return D
    for r in range(n):
        for p in range(indptr[r], indptr[r + 1]):
            col = indices[p]
            for d in range(3):
                for c in range(3):
                    if fixed[r, d] or fixed[col, c]:
                        data[p, d, c] = 0.0
        p = diag_pos[r]
        for d in range(3):
            if fixed[r, d]:
                data[p, d, d] = D
    return D


@njit(cache=True)
def scatter_local_kernel(rows, Kloc, indptr, indices, data):
    """data += a dense local matrix Kloc (3 ns, 3 ns) whose points are rows (ns,) (row numbers),
    entries outside the pattern dropped. Serial (finite-difference path)."""
    ns = rows.shape[0]
    for a in range(ns):
        r = rows[a]
        lo = indptr[r]
        hi = indptr[r + 1]
        for b in range(ns):
            col = rows[b]
            # binary search of col in indices[lo:hi] (ascending)
            left = lo
            right = hi
            while left < right:
                mid = (left + right) // 2
                if indices[mid] < col:
                    left = mid + 1
                else:
                    right = mid
            if left < hi and indices[left] == col:
                for d in range(3):
                    for c in range(3):
                        data[left, d, c] += Kloc[3 * a + d, 3 * b + c]


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
    global-id order (see module docstring).

    ``kind``: "full" (Peridigm's pattern), or "block diagonal" (3x3 diagonal blocks only)."""

    def __init__(self, sim, kind: str = "full") -> None:
        t0 = _time.perf_counter()
        self.sim = sim
        self.kind = kind
        n = sim.num_owned
        self.n = n
        gid = np.asarray(sim.gid[:n], dtype=np.int64)
        self.local_of_row = np.argsort(gid, kind="stable").astype(np.int64)
        self.row_of_local = np.empty(n, dtype=np.int64)
        self.row_of_local[self.local_of_row] = np.arange(n)
        self.eval_rank = evaluation_rank(sim)
        nl = sim.bonds
        self.in_offsets, self.in_bonds = nl.transpose()
        self.sources = nl.sources()
        counts = nl.counts()[:n]
        in_counts = np.diff(self.in_offsets)[:n] if n else np.zeros(0, np.int64)
        self.max_degree = int(counts.max()) if n else 0
        self.max_in = int(in_counts.max()) if n else 0
        if kind == "block diagonal":
            self.indptr = np.arange(n + 1, dtype=np.int64)
            self.indices = np.arange(n, dtype=np.int32)
        else:
            pairs_only = all(getattr(blk.material, "tangent_coupling", "family") == "pairs" for blk in sim.blocks)
            self.indptr, self.indices = self._pattern(pairs_only)
        self.data = np.zeros((self.indices.shape[0], 3, 3))
        rows = np.repeat(np.arange(n), np.diff(self.indptr))
        where = np.nonzero(self.indices == rows)[0]
        self.diag_pos = np.empty(n, dtype=np.int64)
        self.diag_pos[rows[where]] = where
        self.nchunks = max(1, min(n, 8 * _num_threads()))
        self.allocation_time = _time.perf_counter() - t0
        self.assembly_time = 0.0
        self.assemblies = 0
        self._fd_scratch = None

    # -- pattern --------------------------------------------------------------------------------
    def _pattern(self, pairs_only: bool) -> tuple[np.ndarray, np.ndarray]:
        import scipy.sparse as sp

        n = self.n
        nl = self.sim.bonds
        counts = nl.counts()[:n]
        owner = np.repeat(np.arange(n, dtype=np.int64), counts)
        nb = nl.neighbors[: nl.offsets[n]].astype(np.int64)
        keep = nb < n  # (ghost columns belong to other ranks' rows; serial: none)
        r_owner = self.row_of_local[owner[keep]]
        r_nb = self.row_of_local[nb[keep]]
        if pairs_only:
            rows = np.concatenate([np.arange(n), r_owner, r_nb])
            cols = np.concatenate([np.arange(n), r_nb, r_owner])
            P = sp.csr_matrix((np.ones(rows.size, dtype=np.int8), (rows, cols)), shape=(n, n))
        else:
            # B[i, s] = 1 for s in S_i; P = B^T B couples every pair of a common family
            rows = np.concatenate([np.arange(n), r_owner])
            cols = np.concatenate([np.arange(n), r_nb])
            B = sp.csr_matrix((np.ones(rows.size, dtype=np.float32), (rows, cols)), shape=(n, n))
            P = (B.T.tocsr() @ B).tocsr()
        P.sum_duplicates()
        P.sort_indices()
        return P.indptr.astype(np.int64), P.indices.astype(np.int32)

    # -- properties -----------------------------------------------------------------------------
    @property
    def nnz(self) -> int:
        """Stored scalar entries (9 per block)."""
        return 9 * int(self.indices.shape[0])

    @property
    def shape(self) -> tuple[int, int]:
        return (3 * self.n, 3 * self.n)

    def nbytes(self) -> int:
        return self.data.nbytes + self.indices.nbytes + self.indptr.nbytes

    def target(self) -> TangentTarget:
        return TangentTarget(
            self.indptr, self.indices, self.data, self.row_of_local, self.local_of_row, self.eval_rank,
            self.in_offsets, self.in_bonds, self.sources, self.n, self.nchunks, self.max_degree, self.max_in,
        )

    # -- filling --------------------------------------------------------------------------------
    def assemble(self, probe_length: float | None = None) -> None:
        """K at the current Coordinates (bond damage as it stands): zero, then every block's
        material adds its points' contributions (analytic tangent or finite differences)."""
        t0 = _time.perf_counter()
        sim = self.sim
        self.data[:] = 0.0
        for blk in sim.blocks:
            blk.material.precompute(blk.view)
        target = self.target()
        for blk in sim.blocks:
            if not blk.material.tangent(blk.view, target):
                eps = _probe_length(sim, blk, probe_length)
                self._finite_difference(blk, eps)
        self.assembly_time += _time.perf_counter() - t0
        self.assemblies += 1

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
        if self._fd_scratch is None:
            self._fd_scratch = np.zeros(nl.num_bonds)
        t = self._fd_scratch
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
                    y[q, c] = orig - eps
                    mat.precompute(vi)
                    mat.force_state(vi, t)
                    local_force_kernel(i, nl.offsets, nl.neighbors, y, volume, t, Fm)
                    y[q, c] = orig + eps
                    mat.precompute(vi)
                    mat.force_state(vi, t)
                    local_force_kernel(i, nl.offsets, nl.neighbors, y, volume, t, Fp)
                    y[q, c] = orig
                    Kloc[:, 3 * a + c] = (((Fp - Fm) / eps) * 0.5) * Vs
            mat.precompute(vi)  # leave point i's state as at the unperturbed configuration
            keep = S < self.n
            rows = self.row_of_local[S[keep]]
            if not keep.all():
                idx = np.flatnonzero(np.repeat(keep, 3))
                Kloc = Kloc[np.ix_(idx, idx)]
            scatter_local_kernel(rows, np.ascontiguousarray(Kloc), self.indptr, self.indices, self.data)

    # -- operations -----------------------------------------------------------------------------
    def apply_kinematic_bc(self, fixed_rows: np.ndarray) -> float:
        """Zero the rows and columns of fixed dofs ((nrows, 3) bool, row order) and set their
        diagonal to D = -(sum |K_kk|)/N_dof; returns D."""
        return kinematic_bc_kernel(self.indptr, self.indices, self.data, self.diag_pos, fixed_rows)

    def scale(self, factor: float) -> None:
        np.multiply(self.data, factor, out=self.data)

    def add_to_diagonal(self, values: np.ndarray) -> None:
        """K_kk += values[k] for every dof k (row order, (3 nrows,))."""
        v = values.reshape(self.n, 3)
        for d in range(3):
            self.data[self.diag_pos, d, d] = self.data[self.diag_pos, d, d] + v[:, d]

    def damp(self, scale: float, shift: float) -> None:
        damp_diagonal_kernel(self.data, self.diag_pos, scale, shift)

    def diagonal(self) -> np.ndarray:
        """(3 nrows,) diagonal in row order."""
        return np.stack([self.data[self.diag_pos, d, d] for d in range(3)], axis=1).reshape(-1)

    def matvec(self, x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        if out is None:
            out = np.empty(3 * self.n)
        bsr_matvec_kernel(self.indptr, self.indices, self.data, x, out)
        return out

    def to_scipy(self, copy: bool = False):
        """The matrix as ``scipy.sparse.bsr_matrix`` (shares the arrays unless ``copy``)."""
        import scipy.sparse as sp

        return sp.bsr_matrix((self.data.copy() if copy else self.data, self.indices, self.indptr), shape=self.shape)

    def copy_data(self) -> np.ndarray:
        return self.data.copy()

    def diagonal_blocks(self) -> np.ndarray:
        """(nrows, 3, 3) diagonal blocks (row order)."""
        return self.data[self.diag_pos].copy()

    # -- ordering of vectors --------------------------------------------------------------------
    def to_rows(self, a: np.ndarray) -> np.ndarray:
        """Local (n, 3) point array -> (3 nrows,) vector in row (global-id) order."""
        return np.ascontiguousarray(a[: self.n][self.local_of_row]).reshape(-1)

    def to_local(self, v: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """(3 nrows,) row-order vector -> local (n, 3) (written into ``out`` when given)."""
        if out is None:
            out = np.empty((self.n, 3))
        out[self.local_of_row] = v.reshape(self.n, 3)
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
