"""ILU(0): the incomplete LU factorization with no fill, AztecOO's default subdomain
preconditioner (``AZ_ilu``, "Aztec Preconditioner: ilu").

A = L U + E where the unit lower triangular L and the upper triangular U together have exactly
the sparsity pattern of A (plus the diagonal, which is always part of the pattern, as in
AztecOO's MSR storage): the IKJ variant of Gaussian elimination without pivoting in which every
update that would land outside the pattern is dropped. On a pattern that produces no fill (a
tridiagonal or any other matrix whose exact LU factors stay inside its pattern) L U = A exactly.

What AztecOO does (``az_subdomain_solver.c``: ``AZ_ilu`` calls ``AZ_fact_rilu`` of
``az_rilu.c`` with omega = 0): the rows are sorted, each diagonal is first perturbed to
``d rthresh + sign(d) athresh`` (``AZ_rthresh``, ``AZ_athresh``; both 0 by default, where
``rthresh`` = 0 means 1, so nothing changes), then the same elimination runs with no pivoting
and **no check of the pivots**; the diagonal of U is stored inverted (``1/u_ii``). A zero pivot
therefore gives inf there and the Krylov solve fills with inf/NaN without a message; a tiny
pivot is used as it is.

What this module does: the same factorization, with the same optional diagonal perturbation
(``rthresh``, ``athresh``; AztecOO's defaults leave A unchanged). Tiny pivots are used as they
are (as AztecOO). Where AztecOO would silently produce inf/NaN, :class:`ILU0` raises
:class:`ZeroPivotError` naming the row instead: an exactly zero pivot, or a non-finite entry of
the factors (a pivot so small that the elimination overflowed, or a non-finite A).

Kernels are sequential ``@njit`` functions (deterministic; no fill means no reordering).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ...core.errors import ExitCode, PeridynError

#: status codes of :func:`ilu0_factor_kernel`
OK, ZERO_PIVOT, NOT_FINITE = 0, 1, 2


class ZeroPivotError(PeridynError):
    """ILU(0) met a zero pivot (or its factors overflowed) in ``row``: the matrix, or its
    incomplete factorization, is singular there."""

    exit_code = ExitCode.UNSTABLE

    def __init__(self, message: str, row: int) -> None:
        super().__init__(message)
        self.row = row


# ------------------------------------------------------------------------------------------------
# kernels
# ------------------------------------------------------------------------------------------------
@njit(cache=True)
def diagonal_positions_kernel(indptr, indices, diag):
    """diag[i] = position of (i, i) in ``indices`` (n,) or -1; indices sorted within rows.
    Returns the number of rows without a diagonal entry."""
    n = indptr.shape[0] - 1
    missing = 0
    for i in range(n):
        diag[i] = -1
        for p in range(indptr[i], indptr[i + 1]):
            if indices[p] == i:
                diag[i] = p
                break
            if indices[p] > i:
                break
        if diag[i] < 0:
            missing += 1
    return missing


@njit(cache=True)
def perturb_diagonal_kernel(data, diag, rthresh, athresh):
    """AztecOO's diagonal perturbation before the factorization: d -> d rthresh + athresh for
    d >= 0, d rthresh - athresh otherwise."""
    for i in range(diag.shape[0]):
        d = data[diag[i]]
        if d >= 0.0:
            data[diag[i]] = d * rthresh + athresh
        else:
            data[diag[i]] = d * rthresh - athresh


@njit(cache=True)
def ilu0_factor_kernel(indptr, indices, data, diag, work):
    """In-place ILU(0) of a CSR matrix (n rows; sorted column indices, no duplicates, every
    diagonal present at ``diag`` (n,)): afterwards the strictly lower part of ``data`` holds L
    (unit diagonal not stored) and the rest U. ``work`` (n,) int64 scratch, all -1 on entry and
    on return. Rows are eliminated in order, each by its lower entries in ascending column
    order (IKJ), updates outside the pattern dropped.

    Returns (status, row): (OK, -1), or the first row whose pivot is exactly zero (ZERO_PIVOT)
    or whose factored entries are not all finite (NOT_FINITE); the factorization stops there."""
    n = indptr.shape[0] - 1
    for i in range(n):
        start, end, di = indptr[i], indptr[i + 1], diag[i]
        for p in range(start, end):
            work[indices[p]] = p
        for p in range(start, di):
            k = indices[p]
            lik = data[p] / data[diag[k]]
            data[p] = lik
            for q in range(diag[k] + 1, indptr[k + 1]):
                w = work[indices[q]]
                if w >= 0:
                    data[w] -= lik * data[q]
        for p in range(start, end):
            work[indices[p]] = -1
        finite = True
        for p in range(start, end):
            if not np.isfinite(data[p]):
                finite = False
        if not finite:
            return NOT_FINITE, i
        if data[di] == 0.0:
            return ZERO_PIVOT, i
    return OK, -1


@njit(cache=True)
def ilu0_solve_kernel(indptr, indices, data, diag, r, z):
    """z = U^-1 L^-1 r with the factors of :func:`ilu0_factor_kernel`; r, z (n,) (may be the
    same array). Forward substitution with the unit lower L, then backward with U; each sum in
    ascending column order."""
    n = indptr.shape[0] - 1
    for i in range(n):
        acc = r[i]
        for p in range(indptr[i], diag[i]):
            acc -= data[p] * z[indices[p]]
        z[i] = acc
    for i in range(n - 1, -1, -1):
        acc = z[i]
        for p in range(diag[i] + 1, indptr[i + 1]):
            acc -= data[p] * z[indices[p]]
        z[i] = acc / data[diag[i]]


# ------------------------------------------------------------------------------------------------
def csr_pattern(A) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(indptr (n+1,) int64, indices (nnz,) int64, data (nnz,) float64) of the square matrix A
    (any scipy.sparse matrix or array; CSR/BSR and others are converted to CSR) with sorted
    column indices, duplicates summed, explicit zeros kept and a (zero) diagonal entry added
    to every row that has none. The arrays are new (A is not modified)."""
    import scipy.sparse as sp

    if not sp.issparse(A):
        raise TypeError(f"ILU(0) needs a scipy.sparse matrix, got {type(A).__name__}")
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ValueError(f"ILU(0) needs a square matrix, got shape {A.shape}")
    C = sp.csr_matrix(A, dtype=np.float64, copy=True)
    C.sum_duplicates()  # sorts the indices too; keeps explicit zeros
    n = C.shape[0]
    indptr = C.indptr.astype(np.int64)
    indices = C.indices.astype(np.int64)
    data = np.ascontiguousarray(C.data, dtype=np.float64)
    diag = np.empty(n, dtype=np.int64)
    if diagonal_positions_kernel(indptr, indices, diag):
        rows = np.repeat(np.arange(n), np.diff(indptr))
        missing = np.nonzero(diag < 0)[0]
        rows = np.concatenate([rows, missing])
        cols = np.concatenate([indices, missing])
        vals = np.concatenate([data, np.zeros(missing.size)])
        C = sp.csr_matrix((vals, (rows, cols)), shape=(n, n))
        C.sum_duplicates()
        indptr, indices = C.indptr.astype(np.int64), C.indices.astype(np.int64)
        data = np.ascontiguousarray(C.data, dtype=np.float64)
    return indptr, indices, data


class ILU0:
    """ILU(0) of a square sparse matrix A (n x n), applied by :meth:`solve` (see the module
    docstring for the pattern and the pivot policy).

    ``rthresh``, ``athresh``: AztecOO's diagonal perturbation (``AZ_rthresh``, ``AZ_athresh``)
    before the factorization; the defaults (1, 0) leave A unchanged.

    Attributes: ``n``; ``indptr`` (n+1,), ``indices`` (nnz,), ``data`` (nnz,) the factors in
    CSR form (strictly lower part: L without its unit diagonal; the rest: U); ``diag`` (n,)
    positions of the diagonal. Raises :class:`ZeroPivotError` on a zero pivot or non-finite
    factors."""

    def __init__(self, A, *, rthresh: float = 1.0, athresh: float = 0.0) -> None:
        self.indptr, self.indices, self.data = csr_pattern(A)
        n = self.indptr.shape[0] - 1
        self.n = n
        self.diag = np.empty(n, dtype=np.int64)
        diagonal_positions_kernel(self.indptr, self.indices, self.diag)
        if rthresh != 1.0 or athresh != 0.0:
            perturb_diagonal_kernel(self.data, self.diag, float(rthresh), float(athresh))
        work = np.full(n, -1, dtype=np.int64)
        status, row = ilu0_factor_kernel(self.indptr, self.indices, self.data, self.diag, work)
        if status == ZERO_PIVOT:
            raise ZeroPivotError(f"incomplete LU (ILU(0)): zero pivot in row {row} of the {n} x {n} matrix", row)
        if status == NOT_FINITE:
            raise ZeroPivotError(
                f"incomplete LU (ILU(0)): the factors of row {row} of the {n} x {n} matrix are not finite "
                "(a pivot too close to zero before it, or a non-finite matrix entry)",
                row,
            )

    @property
    def shape(self) -> tuple[int, int]:
        return (self.n, self.n)

    def solve(self, r: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """z = (L U)^-1 r for r (n,) float64; written into ``out`` (n,) when given (may be r).
        Raises :class:`ZeroPivotError` if a finite r gives a non-finite z (overflow)."""
        r = np.asarray(r, dtype=np.float64)
        if r.shape != (self.n,):
            raise ValueError(f"ILU(0) solve: r must have shape ({self.n},), got {r.shape}")
        finite_r = bool(np.isfinite(r).all())  # before the solve: out may be r
        z = np.empty(self.n) if out is None else out
        ilu0_solve_kernel(self.indptr, self.indices, self.data, self.diag, r, z)
        if finite_r and not np.isfinite(z).all():
            row = int(np.nonzero(~np.isfinite(z))[0].max())
            raise ZeroPivotError(f"incomplete LU (ILU(0)): the solve overflowed in row {row} of the {self.n} x {self.n} matrix", row)
        return z

    __call__ = solve

    def factors(self):
        """(L, U) as scipy CSR matrices (n x n): L unit lower triangular, U upper triangular,
        both on A's pattern (explicit zeros kept)."""
        import scipy.sparse as sp

        n = self.n
        rows = np.repeat(np.arange(n), np.diff(self.indptr))
        lower = self.indices < rows
        eye = np.arange(n)
        L = sp.csr_matrix(
            (np.concatenate([self.data[lower], np.ones(n)]), (np.concatenate([rows[lower], eye]), np.concatenate([self.indices[lower], eye]))),
            shape=(n, n),
        )
        U = sp.csr_matrix((self.data[~lower], (rows[~lower], self.indices[~lower])), shape=(n, n))
        return L, U
