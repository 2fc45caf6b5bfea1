"""Linear solvers for the implicit solvers' tangent systems A x = b (A a
:class:`~peridyn.solvers.linalg.tangent.TangentMatrix` after boundary conditions and scaling).

``Linear Solver`` (a peridyn key in the ``QuasiStatic`` / ``Implicit`` sublists) picks one:

* ``"Belos"`` (default): what Peridigm runs, reproduced operation for operation so that Peridigm
  decks give Peridigm's iterates and iteration counts: plain, unpreconditioned conjugate
  gradients (Belos ``BlockCG`` with block size 1, PERIDIGM_SEMANTICS.md §11.3) stopping at
  ``Belos Relative Tolerance`` (1e-4; 1e-10 in Implicit) on the recursively updated residual,
  or restarted GMRES when ``Belos Linear Solver: BlockGMRES``. Vectors are in global-id order
  and every dot product is a sequential sum, as in Epetra. The conformance cases' gold files and
  Newton iteration counts depend on this solver: a more exact solve converges the Newton
  iterations along a different path, and the QS velocities (= increment / load-step size, with
  load steps of a few microseconds) then differ by more than the tests' 5e-8.
* ``"Direct"``: sparse LU (SciPy's SuperLU) to machine precision, for small systems.
* ``"AMG"``: conjugate gradients (GMRES for unsymmetric matrices) preconditioned by smoothed
  aggregation algebraic multigrid (:mod:`.amg`: pyamg's hierarchy with the six rigid-body
  modes as near-null space, our Jacobi-smoothed cycle on the finest level) to ``Linear Solver Tolerance`` (default 1e-8). The hierarchy is
  built once and reused as the preconditioner of later tangents (the tangent changes little
  between Newton iterations), rebuilt when a solve needs more than twice the iterations of the
  first one or fails. For large systems, where unpreconditioned CG needs hundreds to thousands
  of iterations and a direct factorization too much memory.
* ``"Auto"``: ``Direct`` up to 3000 unknowns, ``AMG`` above.
* ``"Adaptive"`` (the QuasiStatic default): ``Belos`` while its plain CG converges within
  300 iterations, so that Peridigm's decks of ordinary size give Peridigm's iterates; the first
  solve that reaches 300 iterations switches the run to AMG-preconditioned CG at the same
  relative tolerance (logged once). A CG breakdown (an indefinite tangent) stays a failed solve,
  handled as Peridigm handles it (damped Newton, a failed load step). On the tensile test (37,875 unknowns) plain CG needs ~810 iterations per solve,
  the AMG-preconditioned one 27.

Under MPI (the TangentMatrix of a run on several ranks, see :mod:`peridyn.solvers.linalg.tangent`) every
vector holds the owned rows of its rank, products exchange ghost values through the engine's
halo, and every dot product and norm is the rank's sequential sum reduced with
``comm.allreduce_sum`` (the reduction order differs from the serial one: round-off only):

* ``"Belos"``: the same CG (or GMRES) recursion, distributed.
* ``"Direct"``: the matrix and the right-hand side are gathered to rank 0, which factors and
  solves; the solution is broadcast back. Meant for small systems (rank 0 holds everything).
* ``"AMG"``: distributed conjugate gradients (GMRES when unsymmetric) preconditioned by
  block-Jacobi with one smoothed-aggregation AMG hierarchy per rank, built on the rank's
  owned-by-owned block of the assembled matrix (:meth:`TangentMatrix.owned_block`).
* ``"Auto"``: as serially, by the global number of unknowns.

The functions below take ``comm`` (None or a one-process communicator: the serial arithmetic,
unchanged).

Measured on Peridigm's bar_qs_lps deck (12,000 unknowns, 17.1 M nonzeros, horizon 3 spacings;
benchmarks/quasistatic.py): the peridynamic tangent is well conditioned at this size (CG reaches
1e-8 in ~45 iterations), so Peridigm's plain CG is the fastest there; a sparse LU fills in
almost completely (minutes, 1.7 GiB).
"""
from __future__ import annotations

import logging
import math
import time as _time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

if TYPE_CHECKING:
    from .bsr import PointBlockMatrix

log = logging.getLogger("peridyn.solver")

AUTO_DIRECT_MAX_DOFS = 3000
#: SuperLU's column ordering for the sparse LU: minimum degree on the structure of A^T + A, for
#: tangents whose structure is (nearly) symmetric, as bonds are; on a 22,680-dof plate it
#: factors in 1.19 s against 2.14 s with SuperLU's default (COLAMD), with 19 % less fill
LU_ORDERING = "MMD_AT_PLUS_A"
#: "Adaptive": Peridigm's plain CG while it converges within this many iterations
ADAPTIVE_BELOS_ITERATIONS = 300
METHODS = ("Belos", "Direct", "AMG", "Auto", "Adaptive")


# ------------------------------------------------------------------------------------------------
# sequential reductions (Epetra order)
# ------------------------------------------------------------------------------------------------
@njit(cache=True)
def seq_dot(a, b):
    """sum_k a_k b_k, left to right from 0.0 (reference BLAS DDOT)."""
    acc = 0.0
    for k in range(a.shape[0]):
        acc += a[k] * b[k]
    return acc


@njit(cache=True)
def seq_norm2(a):
    """sqrt(sum_k a_k^2), the sum left to right from 0.0 (Epetra Norm2)."""
    acc = 0.0
    for k in range(a.shape[0]):
        acc += a[k] * a[k]
    return math.sqrt(acc)


@njit(cache=True)
def norm_inf(a):
    """max_k |a_k| (Epetra NormInf)."""
    m = 0.0
    for k in range(a.shape[0]):
        v = abs(a[k])
        if v > m:
            m = v
    return m


@njit(cache=True)
def cg_update_kernel(x, r, p, Ap, alpha):
    """x += alpha p; r += (-alpha) Ap (Epetra Update), returns r.r."""
    na = -alpha
    acc = 0.0
    for k in range(x.shape[0]):
        x[k] = x[k] + alpha * p[k]
        r[k] = r[k] + na * Ap[k]
        acc += r[k] * r[k]
    return acc


@njit(cache=True)
def cg_direction_kernel(p, r, beta):
    """p = r + beta p."""
    for k in range(p.shape[0]):
        p[k] = r[k] + beta * p[k]


def is_parallel(comm) -> bool:
    return comm is not None and comm.size > 1


def gsum(comm, value):
    """``value`` summed over ranks (a scalar or an array); itself on one process."""
    return comm.allreduce_sum(value) if is_parallel(comm) else value


def gdot(comm, a: np.ndarray, b: np.ndarray) -> float:
    """a . b of distributed vectors (numpy's dot on one process)."""
    if is_parallel(comm):
        return comm.allreduce_sum(float(np.dot(a, b)))
    return np.dot(a, b)


def gnorm(comm, a: np.ndarray) -> float:
    """||a||_2 of a distributed vector (numpy's norm on one process)."""
    if is_parallel(comm):
        return math.sqrt(comm.allreduce_sum(float(np.dot(a, a))))
    return np.linalg.norm(a)


# ------------------------------------------------------------------------------------------------
@dataclass
class SolveResult:
    x: np.ndarray
    converged: bool
    iterations: int
    message: str = ""


def belos_cg(matvec, b: np.ndarray, tol: float, maxiter: int, comm=None) -> SolveResult:
    """Belos BlockCG with block size 1, as Peridigm configures it (no preconditioner), from
    x = 0: stops as converged when ||r||/||b|| <= tol (r the recursively updated residual,
    checked before every iteration), as not converged after ``maxiter`` iterations or when
    p.Ap is not positive (Belos throws; Peridigm treats it as a failed solve). ``comm``: the
    communicator of distributed vectors (dot products reduced over ranks)."""
    n = b.shape[0]
    x = np.zeros(n)
    r = b.copy()
    rho0 = math.sqrt(gsum(comm, seq_dot(b, b))) if is_parallel(comm) else seq_norm2(b)
    if rho0 == 0.0:
        return SolveResult(x, True, 0)
    p = r.copy()
    rz = gsum(comm, seq_dot(r, r))
    Ap = np.empty(n)
    it = 0
    rnorm = rho0
    while True:
        if rnorm / rho0 <= tol:
            return SolveResult(x, True, it)
        if it >= maxiter:
            return SolveResult(x, False, it, f"CG reached {maxiter} iterations (relative residual {rnorm / rho0:.3g})")
        it += 1
        matvec(p, Ap)
        pAp = gsum(comm, seq_dot(p, Ap))
        if not (pAp > 0.0 and math.isfinite(pAp)):
            return SolveResult(x, False, it, f"CG met the curvature p.Ap = {pAp:.3g} (the matrix is not positive definite, or the load overflows)")
        alpha = rz / pAp
        rz_old = rz
        rz = gsum(comm, cg_update_kernel(x, r, p, Ap, alpha))
        rnorm = math.sqrt(rz)
        beta = rz / rz_old
        cg_direction_kernel(p, r, beta)


def gmres(matvec, b: np.ndarray, tol: float, restart: int, max_restarts: int, precond=None, x0=None, comm=None) -> SolveResult:
    """Restarted GMRES (modified Gram-Schmidt, Givens rotations), right-preconditioned by
    ``precond`` (a function v -> M^-1 v) when given; stops when ||b - A x|| <= tol ||b||.
    ``comm``: the communicator of distributed vectors."""
    n = b.shape[0]
    ntot = int(gsum(comm, n))
    x = np.zeros(n) if x0 is None else x0.copy()
    bnorm = float(gnorm(comm, b))
    if bnorm == 0.0:
        return SolveResult(np.zeros(n), True, 0)
    total = 0
    Av = np.empty(n)
    for cycle in range(max_restarts + 1):
        matvec(x, Av)
        r = b - Av
        beta = float(gnorm(comm, r))
        if beta <= tol * bnorm:
            return SolveResult(x, True, total)
        m = min(restart, ntot)
        V = np.zeros((m + 1, n))
        Z = np.zeros((m, n)) if precond is not None else None
        H = np.zeros((m + 1, m))
        cs = np.zeros(m)
        sn = np.zeros(m)
        g = np.zeros(m + 1)
        g[0] = beta
        V[0] = r / beta
        k_done = 0
        for k in range(m):
            z = precond(V[k]) if precond is not None else V[k]
            if Z is not None:
                Z[k] = z
            matvec(z, Av)
            w = Av.copy()
            for i in range(k + 1):
                H[i, k] = float(gdot(comm, V[i], w))
                w -= H[i, k] * V[i]
            H[k + 1, k] = float(gnorm(comm, w))
            if H[k + 1, k] > 0.0:
                V[k + 1] = w / H[k + 1, k]
            for i in range(k):
                t = cs[i] * H[i, k] + sn[i] * H[i + 1, k]
                H[i + 1, k] = -sn[i] * H[i, k] + cs[i] * H[i + 1, k]
                H[i, k] = t
            denom = math.hypot(H[k, k], H[k + 1, k])
            cs[k] = H[k, k] / denom if denom > 0 else 1.0
            sn[k] = H[k + 1, k] / denom if denom > 0 else 0.0
            H[k, k] = denom
            H[k + 1, k] = 0.0
            g[k + 1] = -sn[k] * g[k]
            g[k] = cs[k] * g[k]
            total += 1
            k_done = k + 1
            if abs(g[k + 1]) <= tol * bnorm or H[k, k] == 0.0:
                break
        yk = np.linalg.solve(np.triu(H[:k_done, :k_done]), g[:k_done]) if k_done else np.zeros(0)
        basis = Z if Z is not None else V
        x = x + yk @ basis[:k_done]
    matvec(x, Av)
    rel = float(gnorm(comm, b - Av)) / bnorm
    return SolveResult(x, rel <= tol, total, "" if rel <= tol else f"GMRES stopped at relative residual {rel:.3g}")


#: why CG stops when the preconditioned residual r.z is not positive (a preconditioner that is
#: not positive definite, or one that returns zero for a non-zero residual)
_INDEFINITE_PRECONDITIONER = "CG met r.z <= 0 (the preconditioner is not positive definite for this matrix)"


def pcg(matvec, b: np.ndarray, tol: float, maxiter: int, precond=None, comm=None) -> SolveResult:
    """Preconditioned conjugate gradients from x = 0 (``precond``: v -> M^-1 v, symmetric
    positive definite), stopping when the recursive residual ||r|| <= tol ||b||; distributed
    with ``comm``. The AMG solver's Krylov method under MPI."""
    n = b.shape[0]
    x = np.zeros(n)
    bnorm = float(gnorm(comm, b))
    if bnorm == 0.0:
        return SolveResult(x, True, 0)
    r = b.copy()
    z = precond(r) if precond is not None else r.copy()
    p = z.copy()
    rz = float(gdot(comm, r, z))
    if not rz > 0.0:
        return SolveResult(x, False, 0, _INDEFINITE_PRECONDITIONER)
    Ap = np.empty(n)
    rnorm = bnorm
    for it in range(1, maxiter + 1):
        matvec(p, Ap)
        pAp = float(gdot(comm, p, Ap))
        if not pAp > 0.0:
            return SolveResult(x, False, it, "CG met a non-positive curvature p.Ap (the matrix or the preconditioner is not positive definite)")
        alpha = rz / pAp
        x += alpha * p
        r -= alpha * Ap
        rnorm = float(gnorm(comm, r))
        if rnorm <= tol * bnorm:
            return SolveResult(x, True, it)
        z = precond(r) if precond is not None else r.copy()
        rz_old = rz
        rz = float(gdot(comm, r, z))
        if not rz > 0.0:
            return SolveResult(x, False, it, _INDEFINITE_PRECONDITIONER)
        p *= rz / rz_old
        p += z
    return SolveResult(x, False, maxiter, f"CG reached {maxiter} iterations (relative residual {rnorm / bnorm:.3g})")


@dataclass
class LinearSolver:
    """Solves A x = b for the current matrix of a TangentMatrix.

    method: one of METHODS; tol / maxiter: relative tolerance and iteration limit of the
    iterative methods (Belos: Peridigm's values); belos_method: "BlockCG" or "BlockGMRES";
    symmetric: whether A is symmetric (CG or GMRES acceleration for AMG); coords: (n, 3)
    reference coordinates in row order (AMG near-null space; under MPI the owned points').
    Under MPI (a distributed TangentMatrix) every call is collective: see the module docstring."""

    method: str = "Belos"
    tol: float = 1.0e-4
    maxiter: int | None = None
    belos_method: str = "BlockCG"
    symmetric: bool = True
    coords: np.ndarray | None = None
    solve_time: float = 0.0
    setup_time: float = 0.0
    iterations: int = 0
    solves: int = 0
    switched: bool = False
    _matrix: object = field(default=None, repr=False)
    _prepared: object = field(default=None, repr=False)
    _chosen: str = field(default="", repr=False)
    _amg_iterations: int | None = field(default=None, repr=False)  #: of the first solve with the current hierarchy

    def chosen(self, ndof: int) -> str:
        if self.method == "Auto":
            return "Direct" if ndof <= AUTO_DIRECT_MAX_DOFS else "AMG"
        if self.method == "Adaptive":
            return "AMG" if self.switched else "Belos"
        return self.method

    def set_matrix(self, T: PointBlockMatrix) -> None:
        """Use the current values of the tangent ``T`` (call again after they change)."""
        self._matrix = T
        self._chosen = self.chosen(T.ndof)
        if self._chosen != "AMG":
            self._prepared = None
        elif self._prepared is not None and self._comm is None:
            self._prepared.update(T.diagonal())  # the hierarchy stays a good preconditioner for a while

    @property
    def _comm(self):
        T = self._matrix
        return T.comm if T.parallel else None

    def _prepare(self):
        t0 = _time.perf_counter()
        T = self._matrix
        parallel = self._comm is not None
        if self._chosen == "Direct":
            import scipy.sparse.linalg as spla

            if parallel:
                A = T.gather_to_root()
                self._prepared = spla.splu(A, permc_spec=LU_ORDERING) if A is not None and A.shape[0] else "remote"
            else:
                A = T.to_scipy(copy=True).tocsc()
                self._prepared = spla.splu(A, permc_spec=LU_ORDERING)
        elif self._chosen == "AMG":
            A = T.owned_block() if parallel else T.to_scipy()  # pyamg reads A; nothing keeps it after the set-up
            self._prepared = self._amg_preconditioner(A)
            del A
            self._amg_iterations = None
        self.setup_time += _time.perf_counter() - t0

    def _amg_preconditioner(self, A):
        """Smoothed-aggregation AMG (:mod:`.amg`) of A: serially the whole matrix, on the
        tangent's compiled product; under MPI this rank's owned block (block-Jacobi with AMG per
        rank), on that block's product."""
        from .amg import AMGPreconditioner

        if self._comm is None:
            T = self._matrix
            return AMGPreconditioner(A, T.matvec, self.coords, self.symmetric)

        def owned(x, out):
            out[:] = A @ x
            return out

        return AMGPreconditioner(A, owned, self.coords, self.symmetric)

    def solve(self, b: np.ndarray) -> SolveResult:
        T = self._matrix
        if self._prepared is None and self._chosen in ("Direct", "AMG"):
            self._prepare()
        t0 = _time.perf_counter()
        comm = self._comm
        n = b.shape[0]
        maxiter = self.maxiter if self.maxiter is not None else int(gsum(comm, n))
        if self._chosen == "Belos":
            if self.belos_method == "BlockGMRES":
                res = gmres(T.matvec, b, self.tol, restart=500, max_restarts=10, comm=comm)
            elif self.method == "Adaptive" and maxiter > ADAPTIVE_BELOS_ITERATIONS:
                res = belos_cg(T.matvec, b, self.tol, ADAPTIVE_BELOS_ITERATIONS, comm=comm)
                if not res.converged and res.iterations >= ADAPTIVE_BELOS_ITERATIONS:  # slow, not broken down
                    log.info(
                        "Linear solver: Peridigm's plain conjugate gradients did not converge in %d iterations; "
                        "AMG-preconditioned conjugate gradients from here on (set 'Linear Solver: Belos' to keep Peridigm's)",
                        ADAPTIVE_BELOS_ITERATIONS,
                    )
                    self.switched = True
                    self._chosen = "AMG"
                    self.iterations += res.iterations
                    self.solve_time += _time.perf_counter() - t0
                    return self.solve(b)
            else:
                res = belos_cg(T.matvec, b, self.tol, maxiter, comm=comm)
        elif self._chosen == "Direct":
            if comm is not None:
                full = T.gather_vector(b)
                xf = self._prepared.solve(full) if full is not None and full.size else full
                x = T.scatter_vector(xf)
                ok = bool(comm.allreduce_min(int(np.all(np.isfinite(x)))))
            else:
                x = self._prepared.solve(b)
                ok = bool(np.all(np.isfinite(x)))
            res = SolveResult(x, ok, 1, "" if ok else "the direct solver produced non-finite values (singular matrix?)")
        else:
            res = self._amg_solve(b, maxiter)
            first = self._amg_iterations
            if not res.converged or (first is not None and res.iterations > 2 * max(first, 5)):
                self._prepared = None  # stale hierarchy: rebuild for the current tangent
                self._prepare()
                res = self._amg_solve(b, maxiter)
            if self._amg_iterations is None:
                self._amg_iterations = res.iterations
        self.solve_time += _time.perf_counter() - t0
        self.iterations += res.iterations
        self.solves += 1
        return res

    def _amg_solve(self, b: np.ndarray, maxiter: int) -> SolveResult:
        T = self._matrix
        if self._prepared is None:
            self._prepare()
        comm = self._comm
        M = self._prepared
        if self.symmetric:
            res = pcg(T.matvec, b, self.tol, maxiter, M, comm=comm)
        else:
            res = gmres(T.matvec, b, self.tol, restart=200, max_restarts=max(1, maxiter // 200), precond=M, comm=comm)
        x, its = res.x, res.iterations
        bnorm = float(gnorm(comm, b))
        rel = (float(gnorm(comm, b - T.matvec(x))) / bnorm) if bnorm > 0 else 0.0
        ok = bool(np.isfinite(rel) and rel <= 10.0 * self.tol)
        return SolveResult(x, ok, its, "" if ok else f"AMG-{'CG' if self.symmetric else 'GMRES'} stopped at relative residual {rel:.3g}")

