"""Static (Guyan) condensation of the implicit solvers' linear systems A x = b.

The unknowns are split into masters m (kept) and slaves s (condensed):

    [A_mm  A_ms] [x_m]   [b_m]
    [A_sm  A_ss] [x_s] = [b_s]

A_ss is factorized once per matrix (sparse LU, SuperLU), the slaves are eliminated and the
reduced (Schur complement) system

    A_r x_m = b_r,    A_r = A_mm - A_ms A_ss^-1 A_sm,    b_r = b_m - A_ms A_ss^-1 b_s

is solved for the masters; the slaves are recovered as x_s = A_ss^-1 (b_s - A_sm x_m). With no
load on the slaves (b_s = 0) this is Guyan's x_s = -A_ss^-1 A_sm x_m. Because the load on the
slaves is condensed too, the result is the solution of the full system, exactly (to round-off),
for any matrix with a non-singular A_ss and any right-hand side: for a Newton step of a
non-linear problem as well as for a linear problem. It is a direct solver, no approximation.

Only the masters coupled to a slave (the interface: rows of A_ms, columns of A_sm that are not
zero) receive a correction, so A_r = A_mm plus a dense interface block; A_r is solved by a dense
LU (LAPACK) up to :data:`DENSE_REDUCED_MAX` masters and by a sparse LU above.

:class:`CondensedSolver` offers the interface of :class:`~.linear.LinearSolver` for a
:class:`~.tangent.TangentMatrix` after its kinematic boundary conditions: the prescribed degrees
of freedom (rows and columns zeroed, a diagonal D) are decoupled and solved on their own
(x = b / D), the rest is condensed. Serial only (the callers refuse MPI runs).
"""
from __future__ import annotations

import logging
import time as _time
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .linear import LU_ORDERING, SolveResult

log = logging.getLogger("peridyn.solver")

#: the reduced matrix is factorized dense (LAPACK) up to this many masters, sparse above
DENSE_REDUCED_MAX = 4000
#: columns of A_ss^-1 A_sm formed at a time (bounds the dense scratch to n_slaves x this)
CHUNK_COLUMNS = 256


class SingularCondensation(RuntimeError):
    """A_ss or the reduced matrix is singular: the condensation cannot be formed."""


@dataclass
class CondensationSizes:
    """What a condensation holds: numbers of masters, slaves and interface masters (rows, columns
    of the dense correction), the reduced matrix's stored entries and the set-up time (s)."""

    masters: int
    slaves: int
    interface_rows: int
    interface_columns: int
    reduced_nonzeros: int
    setup_time: float


class StaticCondensation:
    """The condensation of one sparse matrix ``A`` (n, n) onto ``masters``.

    A: any scipy sparse matrix; masters: (n,) bool, True on the kept unknowns. The slaves'
    block A_ss and the reduced matrix A_r are factorized here (SingularCondensation when either
    is singular); :meth:`solve` then costs two A_ss solves, one A_r solve and three sparse
    products. Units are those of A and b (the tangent: force / length, force)."""

    def __init__(self, A, masters: np.ndarray) -> None:
        t0 = _time.perf_counter()
        A = sp.csr_matrix(A)
        masters = np.asarray(masters, dtype=bool)
        if masters.shape != (A.shape[0],) or A.shape[0] != A.shape[1]:
            raise ValueError(f"masters {masters.shape} do not match the square matrix {A.shape}")
        self.m = np.flatnonzero(masters)
        self.s = np.flatnonzero(~masters)
        m, s = self.m, self.s
        A_m = A[m]
        A_s = A[s]
        self.A_mm = A_m[:, m].tocsr()
        self.A_ms = A_m[:, s].tocsr()
        self.A_sm = A_s[:, m].tocsc()
        A_ss = A_s[:, s].tocsc()
        self.lu_ss = _splu(A_ss, "the condensed block A_ss") if s.size else None
        A_r, rows, cols = self._reduced()
        self.dense = m.size <= DENSE_REDUCED_MAX
        if self.dense:
            self.lu_r = _dense_lu(A_r.toarray()) if m.size else None
        else:
            self.lu_r = _splu(A_r.tocsc(), "the reduced matrix A_r")
        self.sizes = CondensationSizes(int(m.size), int(s.size), int(rows.size), int(cols.size), int(A_r.nnz), _time.perf_counter() - t0)

    def _reduced(self):
        """A_r = A_mm - A_ms A_ss^-1 A_sm, the correction formed on the interface only, in
        column chunks of A_ss^-1 A_sm; returns (A_r as CSR, interface rows, interface columns)."""
        A_ms, A_sm = self.A_ms, self.A_sm
        rows = np.flatnonzero(np.diff(A_ms.indptr))  # masters whose row reaches a slave
        cols = np.flatnonzero(np.diff(A_sm.indptr))  # masters a slave's row reaches
        if rows.size == 0 or cols.size == 0:
            return self.A_mm, rows, cols
        A_ms_i = A_ms[rows]
        A_sm_i = A_sm[:, cols]
        correction = np.empty((rows.size, cols.size))
        for start in range(0, cols.size, CHUNK_COLUMNS):
            stop = min(start + CHUNK_COLUMNS, cols.size)
            X = self.lu_ss.solve(A_sm_i[:, start:stop].toarray())  # A_ss^-1 A_sm, (n_s, chunk)
            correction[:, start:stop] = A_ms_i @ X
        if not np.all(np.isfinite(correction)):
            raise SingularCondensation("A_ss^-1 A_sm is not finite: the condensed block is singular")
        nm = self.m.size
        C = sp.csr_matrix((correction.ravel(), (np.repeat(rows, cols.size), np.tile(cols, rows.size))), shape=(nm, nm))
        return (self.A_mm - C).tocsr(), rows, cols

    def solve(self, b: np.ndarray) -> np.ndarray:
        """x (n,) with A x = b (b: (n,)); non-finite entries when A_r or A_ss is near-singular."""
        m, s = self.m, self.s
        x = np.empty_like(b, dtype=float)
        b_m = b[m]
        if s.size:
            z = self.lu_ss.solve(b[s])  # the slaves' response to their own load, masters held
            b_r = b_m - self.A_ms @ z
        else:
            b_r = b_m
        if m.size:
            x_m = sla.lu_solve(self.lu_r, b_r, check_finite=False) if self.dense else self.lu_r.solve(b_r)
        else:
            x_m = b_r
        x[m] = x_m
        if s.size:
            x[s] = self.lu_ss.solve(b[s] - self.A_sm @ x_m)
        return x


def _splu(A, what: str):
    try:
        return spla.splu(A, permc_spec=LU_ORDERING)
    except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
        raise SingularCondensation(f"{what} is singular ({exc})") from None


def _dense_lu(A: np.ndarray):
    with warnings.catch_warnings():  # a vanishing pivot is reported below, as an error
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        lu = sla.lu_factor(A, check_finite=False)
    diag = np.abs(np.diag(lu[0]))
    if diag.size and not (np.all(np.isfinite(diag)) and diag.min() > np.finfo(float).eps * diag.max()):
        raise SingularCondensation("the reduced matrix A_r is singular (a pivot vanishes)")
    return lu


class CondensedSolver:
    """``LinearSolver``'s interface (set_matrix, solve, the counters) on a static condensation
    of a TangentMatrix after its kinematic boundary conditions.

    condensed: (ndof,) bool in row order (dof 3 g + c), True on the slaves; fixed: (ndof,) bool,
    True on the prescribed dofs (decoupled by ``apply_kinematic_bc``: solved as b / D and kept
    out of both sets). The condensation is formed at the first solve after each
    :meth:`set_matrix` (a new tangent), and reused by the solves that follow."""

    method = "Static Condensation"
    switched = False  # never leaves its method (LinearSolver's Adaptive switch)
    _chosen = "Static Condensation"

    def __init__(self, condensed: np.ndarray, fixed: np.ndarray) -> None:
        self.fixed = np.asarray(fixed, dtype=bool)
        self.free = np.flatnonzero(~self.fixed)
        self.masters = ~np.asarray(condensed, dtype=bool)[self.free]  # within the free dofs
        self.solve_time = 0.0
        self.setup_time = 0.0
        self.iterations = 0
        self.solves = 0
        self.condensations = 0
        self._matrix = None
        self._cond: StaticCondensation | None = None
        self.sizes: CondensationSizes | None = None

    def set_matrix(self, T) -> None:
        """Use the current values of TangentMatrix ``T`` (call again after they change)."""
        self._matrix = T
        self._cond = None

    def _condense(self) -> None:
        t0 = _time.perf_counter()
        A = self._matrix.to_scipy().tocsr()
        self._diag = A.diagonal()
        self._cond = StaticCondensation(A[self.free][:, self.free], self.masters)
        self.sizes = self._cond.sizes
        self.condensations += 1
        self.setup_time += _time.perf_counter() - t0
        if self.condensations == 1:
            z = self.sizes
            log.info(
                "Static condensation: %d unknowns condensed onto %d masters (%d x %d interface block), reduced matrix %d nonzeros, %.3g s",
                z.slaves, z.masters, z.interface_rows, z.interface_columns, z.reduced_nonzeros, z.setup_time,
            )

    def solve(self, b: np.ndarray) -> SolveResult:
        """x with A x = b (b, x: (ndof,) row order); a failed result when A_ss or A_r is singular."""
        if self._cond is None:
            try:
                self._condense()
            except SingularCondensation as exc:
                return SolveResult(np.full_like(b, np.nan), False, 0, f"static condensation: {exc}")
        t0 = _time.perf_counter()
        x = np.empty_like(b, dtype=float)
        fixed = self.fixed
        x[fixed] = b[fixed] / self._diag[fixed]
        x[self.free] = self._cond.solve(b[self.free])
        ok = bool(np.all(np.isfinite(x)))
        self.solve_time += _time.perf_counter() - t0
        self.iterations += 1
        self.solves += 1
        return SolveResult(x, ok, 1, "" if ok else "static condensation produced non-finite values (singular matrix?)")

    def summary(self) -> dict:
        """Sizes of the last condensation and how many were formed (for ``sim.stats``)."""
        out = dict(self.sizes.__dict__) if self.sizes is not None else {}
        out["condensations"] = self.condensations
        return out
