"""``ImplicitDiffusion``: load-stepped steady-state solution of the nonlocal diffusion equation
for the temperature, step for step as Peridigm's ``executeImplicitDiffusion``
(PERIDIGM_MODELS.md §6.2).

The unknown is one temperature per point (the solver section sets ``Solve For Temperature: true``
and ``Solve For Displacement: false``). There is no capacity or time term: every load step solves
the steady state Q(T) = 0 (Q the materials' ``Flux_Divergence``, see
:mod:`peridyn.materials.diffusion`) with the prescribed temperatures of that step's time, so a
ramped boundary value gives a sequence of steady states, not a transient.

Start (t0): the kinematic conditions at (t0, t0) (``Prescribed Temperature`` sets T on its node
set), the body forces, then the **initial conditions again** (``Initial Temperature`` overwrites
the values just prescribed), and output at t0 with no evaluation (Flux_Divergence is still 0).

Each load step t_k:

1. the kinematic conditions at (t_k, t_{k-1}) set T on the prescribed points;
2. residual r_i = Q_i V_i with r = 0 on the prescribed points, norm ||r||_2 + 20 ||r||_inf (row
   order = global-id order, sequential sums); tolerance ``Absolute Tolerance``, else ``Relative
   Tolerance`` x ||R||_2 with R_i = Q_i V_i on the prescribed points (the reactions);
3. while the norm exceeds the tolerance and at most ``Maximum Solver Iterations`` times: the
   Jacobian K = d(Q V)/dT (exact, the flux is linear), prescribed rows and columns zeroed with
   the diagonal D = -(sum |K_kk|)/N, K scaled by -1, (-K) dT = r solved, dT zeroed on the
   prescribed points, T += dT (**no line search, no predictor, no damped retry**), new residual;
   a linear solve that fails sets the norm to 1e50 and ends the loop;
4. a step that ends above the tolerance is accepted with a warning within 100 x the tolerance;
   otherwise the run stops with :class:`DiffusionStepError` (exit status 3; Peridigm prints
   "Aborting analysis"), keeping the output of the converged steps. An accepted step is written
   and the N and NP1 states are swapped.

``Flux_Divergence`` in the output is the Q of the last residual: on the prescribed points it
holds the reactions (the heat the boundary supplies per unit volume).

Linear solver (``Linear Solver``, a peridyn key of the ``ImplicitDiffusion`` sublist):

* ``"Belos"``: what Peridigm configures for this solver: Belos ``BlockCG`` (or
  ``BlockGMRES``) to ``Belos Relative Tolerance`` (1e-4), preconditioned by an incomplete LU
  factorization with no fill, ILU(0) (Ifpack ``ILU``; Peridigm's other implicit solvers run CG
  without preconditioner, this one sets it). Under MPI the ILU(0) is per rank, on the rank's
  owned rows and columns (block Jacobi; Ifpack adds an overlap of one layer). The matrix is a
  weighted graph Laplacian (symmetric positive definite after the boundary rows, with volume
  weights), so CG is the right Krylov method, and the Newton loop only has to repeat the
  inexact solve 2 or 3 times to reach 1e-9.
* ``"Direct"``: sparse LU (SciPy's SuperLU), one Newton iteration to machine precision; under
  MPI the matrix is gathered to rank 0. Moderate sizes only: the 3D nonlocal stencil (~120
  neighbors per point for a horizon of 3 spacings) fills the factors quickly.
* ``"Auto"`` (default): ``Direct`` up to 3000 unknowns, ``Belos`` above. Measured on a cube
  with a horizon of 3 spacings (122 neighbors per point), one load step to 1e-10: 1728 unknowns
  0.32 s direct / 0.04 s Belos, 5832 unknowns 1.6 s / 0.09 s, 13 824 unknowns 6.8 s / 0.54 s
  (3 Newton iterations of 3 to 7 preconditioned CG iterations each). Small systems get the
  exact solve (one Newton iteration, the answer at round-off whatever the tolerance); large ones
  the Krylov solver, whose cost grows almost linearly.

Under MPI every rank holds the rows of its owned points (in global-id order); the matrix's
columns are the rank's local points (owned and ghosts), since the flux of a point involves its
family only; products exchange the ghost entries of x through the engine's halo.
"""
from __future__ import annotations

import logging
import math
import time as _time
from typing import Literal

import numpy as np
from numba import njit, prange
from pydantic import Field, field_validator, model_validator

from ...core.services import RunServices
from ...core.state import SolverState
from ...core.errors import InputError, InstabilityError
from ...core.interfaces import Solver
from ..section import SolverSection
from ..linalg.linear import (
    LU_ORDERING,
    SolveResult,
    cg_direction_kernel,
    gmres,
    gsum,
    norm_inf,
    seq_dot,
    seq_norm2,
)
from .problem import LoadTimes, check_time_steps, load_times, planned_load_steps, threads_for

log = logging.getLogger("peridyn.solver")

AUTO_DIRECT_MAX_ROWS = 3000
METHODS = ("Belos", "Direct", "Auto")


class DiffusionStepError(InstabilityError):
    """An ImplicitDiffusion load step did not converge: the run stops (exit status 3), the
    output of the converged load steps is kept."""


class ImplicitDiffusionParams(LoadTimes):
    relative_tolerance: float = Field(1.0e-6, alias="Relative Tolerance", gt=0, description="residual tolerance relative to the norm of the reactions")
    absolute_tolerance: float | None = Field(None, alias="Absolute Tolerance", gt=0, description="residual tolerance (temperature x volume / time); replaces the relative one")
    maximum_solver_iterations: int = Field(10, alias="Maximum Solver Iterations", ge=0, le=1_000_000, description="Newton iterations per load step")
    belos_linear_solver: Literal["BlockCG", "BlockGMRES"] = Field("BlockCG", alias="Belos Linear Solver", description="Peridigm's Krylov method")
    belos_maximum_iterations: int | None = Field(None, alias="Belos Maximum Iterations", ge=1, le=100_000_000, description="Krylov iterations per solve (default: number of unknowns)")
    belos_relative_tolerance: float = Field(1.0e-4, alias="Belos Relative Tolerance", gt=0, lt=1, description="Krylov stopping tolerance, relative to the right-hand side")
    belos_print_status: bool = Field(False, alias="Belos Print Status", description="accepted; use --verbose")
    linear_solver: Literal[METHODS] = Field(  # type: ignore[valid-type]
        "Auto", alias="Linear Solver", description="peridyn: Auto (default: Direct up to 3000 unknowns, else Belos), Belos (Peridigm's ILU(0)-preconditioned CG), Direct (sparse LU)"
    )
    ignored_keys = frozenset({"Verbose"})

    _check_times = field_validator("time_steps")(lambda cls, v: check_time_steps(v) if v is not None else v)


class ImplicitDiffusionSection(SolverSection):
    solve_for_displacement: bool = Field(True, alias="Solve For Displacement", description="must be false for ImplicitDiffusion (Peridigm's default is true)")
    solve_for_temperature: bool = Field(False, alias="Solve For Temperature", description="must be true for ImplicitDiffusion: the temperature is the unknown")
    solve_for_concentration: bool = Field(False, alias="Solve For Concentration", description="not supported (must be false)")
    solve_for_pressure: bool = Field(False, alias="Solve For Pressure", description="not supported (must be false)")
    implicit_diffusion: ImplicitDiffusionParams = Field(alias="ImplicitDiffusion", description="load-stepped steady-state diffusion")

    @model_validator(mode="after")
    def _check(self):
        q = self.implicit_diffusion
        if not ((self.given("final_time") and q.number_of_load_steps is not None) or q.time_steps is not None):
            raise ValueError(
                "no load steps: give 'Final Time' in the solver section with 'ImplicitDiffusion > Number of Load Steps', or 'ImplicitDiffusion > Time Steps'"
            )
        if not self.solve_for_temperature or self.solve_for_displacement:
            raise ValueError(
                "ImplicitDiffusion solves for the temperature only: set 'Solve For Temperature' to true and 'Solve For Displacement' to false "
                f"(got {str(self.solve_for_temperature).lower()} and {str(self.solve_for_displacement).lower()}; Peridigm's defaults are false and true)"
            )
        if self.solve_for_concentration or self.solve_for_pressure:
            raise ValueError("ImplicitDiffusion solves for the temperature only: 'Solve For Concentration' and 'Solve For Pressure' must be false")
        return self


# ------------------------------------------------------------------------------------------------
# kernels of the scalar CSR matrix (rows: owned points in global-id order; columns: local points)
# ------------------------------------------------------------------------------------------------
@njit(cache=True)
def pattern_kernel(local_of_row, offsets, neighbors, gid, indptr, indices, bond_pos, diag_pos):
    """Row r = point i = local_of_row[r] couples {i} U N_i, columns sorted by global id:
    fills indices (local column numbers), bond_pos[b] (entry of bond b = i->j) and diag_pos[r]."""
    n = local_of_row.shape[0]
    for r in range(n):
        i = local_of_row[r]
        lo, hi = offsets[i], offsets[i + 1]
        m = hi - lo + 1
        keys = np.empty(m, dtype=np.int64)
        for k in range(hi - lo):
            keys[k] = gid[neighbors[lo + k]]
        keys[m - 1] = gid[i]
        order = np.argsort(keys, kind="mergesort")
        base = indptr[r]
        for p in range(m):
            k = order[p]
            if k == m - 1:
                indices[base + p] = i
                diag_pos[r] = base + p
            else:
                indices[base + p] = neighbors[lo + k]
                bond_pos[lo + k] = base + p


@njit(cache=True, parallel=True)
def csr_matvec_kernel(indptr, indices, data, x_local, out):
    """out[r] = sum_p data[p] x_local[indices[p]], each row summed from 0.0 in column order."""
    for r in prange(indptr.shape[0] - 1):
        acc = 0.0
        for p in range(indptr[r], indptr[r + 1]):
            acc += data[p] * x_local[indices[p]]
        out[r] = acc


@njit(cache=True)
def abs_diagonal_sum_kernel(data, diag_pos):
    acc = 0.0
    for r in range(diag_pos.shape[0]):
        acc += abs(data[diag_pos[r]])
    return acc


@njit(cache=True)
def kinematic_bc_kernel(indptr, indices, data, diag_pos, fixed_row, fixed_local, D):
    """Zero the rows of fixed rows and the columns of fixed points, then set their diagonal to D."""
    for r in range(indptr.shape[0] - 1):
        if fixed_row[r]:
            for p in range(indptr[r], indptr[r + 1]):
                data[p] = 0.0
            data[diag_pos[r]] = D
        else:
            for p in range(indptr[r], indptr[r + 1]):
                if fixed_local[indices[p]]:
                    data[p] = 0.0


@njit(cache=True)
def pcg_update_kernel(x, r, p, Ap, alpha):
    """x += alpha p; r += (-alpha) Ap; returns r.r (sequential)."""
    na = -alpha
    acc = 0.0
    for k in range(x.shape[0]):
        x[k] = x[k] + alpha * p[k]
        r[k] = r[k] + na * Ap[k]
        acc += r[k] * r[k]
    return acc


def preconditioned_cg(matvec, precond, b: np.ndarray, tol: float, maxiter: int, comm=None) -> SolveResult:
    """Conjugate gradients with a left preconditioner (Belos ``BlockCG``, block size 1, as
    Peridigm's ImplicitDiffusion sets it up) from x = 0: before every iteration it stops as
    converged when ||r||_2 <= tol ||b||_2 (r the recursively updated, unpreconditioned residual),
    as failed after ``maxiter`` iterations or when p.Ap is not positive. Dot products are
    sequential sums (numba, no BLAS threads), reduced over ranks with ``comm``."""
    n = b.shape[0]
    x = np.zeros(n)
    r = b.copy()
    rr = gsum(comm, seq_dot(r, r))
    rho0 = math.sqrt(rr)
    if rho0 == 0.0:
        return SolveResult(x, True, 0)
    z = precond(r)
    p = z.copy()
    rz = gsum(comm, seq_dot(r, z))
    Ap = np.empty(n)
    it = 0
    while True:
        rnorm = math.sqrt(rr)
        if rnorm <= tol * rho0:
            return SolveResult(x, True, it)
        if it >= maxiter:
            return SolveResult(x, False, it, f"CG reached {maxiter} iterations (relative residual {rnorm / rho0:.3g})")
        it += 1
        matvec(p, Ap)
        pAp = gsum(comm, seq_dot(p, Ap))
        if not (pAp > 0.0 and math.isfinite(pAp)):
            return SolveResult(x, False, it, f"CG met the curvature p.Ap = {pAp:.3g} (the matrix is not positive definite)")
        alpha = rz / pAp
        rr = gsum(comm, pcg_update_kernel(x, r, p, Ap, alpha))
        z = precond(r)
        rz_old = rz
        rz = gsum(comm, seq_dot(r, z))
        cg_direction_kernel(p, z, rz / rz_old)


class DiffusionMatrix:
    """J = d(Q V)/dT in CSR form: one row per owned point (global-id order), columns the local
    points (owned then ghosts) sorted by global id within each row. Serially the columns map
    one to one onto rows (:meth:`to_scipy`)."""

    def __init__(self, sim) -> None:
        self.sim = sim
        self.comm = sim.comm
        self.parallel = sim.comm.size > 1
        n = sim.num_owned
        self.n = n
        self.local_of_row = np.argsort(sim.gid[:n], kind="stable").astype(np.int64)
        self.row_of_local = np.full(sim.num_local, -1, dtype=np.int64)
        self.row_of_local[self.local_of_row] = np.arange(n, dtype=np.int64)
        nl = sim.bonds
        offsets = nl.offsets
        counts = (offsets[1 : n + 1] - offsets[:n]) + 1
        self.indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(counts[self.local_of_row], out=self.indptr[1:])
        nnz = int(self.indptr[-1])
        self.indices = np.zeros(nnz, dtype=np.int64)
        self.bond_pos = np.zeros(max(int(offsets[n]), 0), dtype=np.int64)
        self.diag_pos = np.zeros(n, dtype=np.int64)
        pattern_kernel(self.local_of_row, offsets, nl.neighbors, sim.gid, self.indptr, self.indices, self.bond_pos, self.diag_pos)
        self.data = np.zeros(nnz)
        self._x_local = np.zeros(sim.num_local)
        self.assemblies = 0
        self.assembly_time = 0.0

    @property
    def nnz(self) -> int:
        return int(self.indptr[-1])

    def assemble(self, sim) -> None:
        t0 = _time.perf_counter()
        self.data[:] = 0.0
        for blk in sim.blocks:
            blk.material.flux_jacobian(blk.view, self.row_of_local, self.bond_pos, self.diag_pos, self.data)
        self.assemblies += 1
        self.assembly_time += _time.perf_counter() - t0

    def apply_kinematic_bc(self, fixed_local: np.ndarray) -> float:
        """Peridigm's applyKinematicBC_InsertZerosAndSetDiagonal; fixed_local (num_local,) bool
        (ghosts included). Returns D."""
        total = abs_diagonal_sum_kernel(self.data, self.diag_pos)
        if self.parallel:
            total = self.comm.allreduce_sum(total)
        D = (-1.0 * total) / self.sim.num_global
        fixed_row = fixed_local[self.local_of_row]
        kinematic_bc_kernel(self.indptr, self.indices, self.data, self.diag_pos, fixed_row, fixed_local, D)
        return D

    def scale(self, factor: float) -> None:
        self.data *= factor

    def matvec(self, x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """out = J x for x (n,) in row order (collective under MPI)."""
        xl = self._x_local
        xl[self.local_of_row] = x
        if self.parallel:
            self.sim.halo.exchange(xl)
        if out is None:
            out = np.empty(self.n)
        csr_matvec_kernel(self.indptr, self.indices, self.data, xl, out)
        return out

    def to_scipy(self, owned_only: bool = False):
        """The matrix in row numbering (n x n); under MPI (owned_only) the owned-by-owned block."""
        import scipy.sparse as sp

        cols = self.row_of_local[self.indices]
        rows = np.repeat(np.arange(self.n), np.diff(self.indptr))
        keep = cols >= 0
        return sp.csr_matrix((self.data[keep], (rows[keep], cols[keep])), shape=(self.n, self.n))

    def gather_to_root(self):
        """The whole matrix (global-id numbering) on rank 0, None elsewhere (collective)."""
        import scipy.sparse as sp

        gid = self.sim.gid
        rows = gid[self.local_of_row][np.repeat(np.arange(self.n), np.diff(self.indptr))]
        pieces = self.comm.gather((rows, gid[self.indices], self.data.copy()))
        if pieces is None:
            return None
        N = self.sim.num_global
        r = np.concatenate([p[0] for p in pieces])
        c = np.concatenate([p[1] for p in pieces])
        v = np.concatenate([p[2] for p in pieces])
        return sp.csr_matrix((v, (r, c)), shape=(N, N))

    def gather_vector(self, v: np.ndarray):
        pieces = self.comm.gather((self.sim.gid[self.local_of_row], v))
        if pieces is None:
            return None
        full = np.zeros(self.sim.num_global)
        for g, vals in pieces:
            full[g] = vals
        return full

    def scatter_vector(self, full) -> np.ndarray:
        full = self.comm.bcast(full)
        return np.asarray(full)[self.sim.gid[self.local_of_row]]


class DiffusionLinearSolver:
    """Solves (-J) x = b for the current values of a :class:`DiffusionMatrix` (see the module
    docstring for the methods)."""

    def __init__(self, method: str, belos_method: str, tol: float, maxiter: int | None) -> None:
        self.method = method
        self.belos_method = belos_method
        self.tol = tol
        self.maxiter = maxiter
        self.iterations = 0
        self.solves = 0
        self.solve_time = 0.0
        self.setup_time = 0.0
        self.chosen = method

    def solve(self, A: DiffusionMatrix, b: np.ndarray) -> SolveResult:
        comm = A.comm if A.parallel else None
        nrows = A.sim.num_global
        method = self.method
        if method == "Auto":
            method = "Direct" if nrows <= AUTO_DIRECT_MAX_ROWS else "Belos"
        self.chosen = method
        t0 = _time.perf_counter()
        if method == "Direct":
            import scipy.sparse.linalg as spla

            if comm is not None:
                M = A.gather_to_root()
                full = A.gather_vector(b)
                xf = spla.splu(M.tocsc(), permc_spec=LU_ORDERING).solve(full) if M is not None else None
                self.setup_time += _time.perf_counter() - t0
                x = A.scatter_vector(xf)
            else:
                lu = spla.splu(A.to_scipy().tocsc(), permc_spec=LU_ORDERING)
                self.setup_time += _time.perf_counter() - t0
                x = lu.solve(b)
            ok = bool(np.all(np.isfinite(x)))
            if comm is not None:
                ok = bool(comm.allreduce_min(int(ok)))
            res = SolveResult(x, ok, 1, "" if ok else "the direct solver produced non-finite values (singular matrix?)")
        else:
            from ..linalg.ilu import ILU0, ZeroPivotError

            try:
                ilu = ILU0(A.to_scipy(owned_only=True)) if A.n else None
                failed = ""
            except ZeroPivotError as exc:
                ilu, failed = None, str(exc)
            if comm is not None:
                failed = "; ".join(m for m in comm.allgather(failed) if m)
            self.setup_time += _time.perf_counter() - t0
            if failed:
                res = SolveResult(np.zeros(A.n), False, 0, failed)
            else:
                precond = ilu.solve if ilu is not None else (lambda v: v.copy())
                maxiter = self.maxiter if self.maxiter is not None else nrows
                if self.belos_method == "BlockGMRES":
                    res = gmres(A.matvec, b, self.tol, restart=500, max_restarts=10, precond=precond, comm=comm)
                else:
                    res = preconditioned_cg(A.matvec, precond, b, self.tol, maxiter, comm=comm)
        self.solve_time += _time.perf_counter() - t0
        self.iterations += res.iterations
        self.solves += 1
        return res


class ImplicitDiffusion(Solver):
    name = "ImplicitDiffusion"
    Params = ImplicitDiffusionSection

    def planned_steps(self, sim) -> int | None:
        return planned_load_steps(self.params, self.params.implicit_diffusion)

    def run(self, sim, state: SolverState, run: RunServices) -> SolverState:
        with threads_for(sim):
            ImplicitDiffusionRun(self, sim, state, run).run()
        return state


class ImplicitDiffusionRun:
    """State of one ImplicitDiffusion solver run."""

    def __init__(self, solver: ImplicitDiffusion, sim, state: SolverState, services: RunServices) -> None:
        self.sim = sim
        self.state = state
        self.services = services
        self.section = solver.section
        self.p = solver.params
        self.q = solver.params.implicit_diffusion
        self._check_materials()
        n = sim.num_owned
        self.n = n
        f = sim.fields
        self.T = f["Temperature"]
        self.Q = f["Flux_Divergence"]
        self.volume = f["Volume"][:n]
        #: points a Prescribed Temperature condition sets (local, ghosts included under MPI)
        fixed = np.zeros(sim.num_local)
        for c in sim.kinematic:
            if c.target == "temperature":
                fixed[c.points] = 1.0
        if sim.comm.size > 1:
            sim.halo.exchange(fixed)
        self.fixed_local = fixed > 0.5
        self.fixed_owned = self.fixed_local[:n]
        self.matrix = DiffusionMatrix(sim)
        self.rows = self.matrix.local_of_row
        q = self.q
        self.linear = DiffusionLinearSolver(q.linear_solver, q.belos_linear_solver, q.belos_relative_tolerance, q.belos_maximum_iterations)
        self.evaluations = 0

    def _check_materials(self) -> None:
        sim = self.sim
        bad = [blk for blk in sim.blocks if not blk.material.diffusion]
        if bad:
            blk = bad[0]
            raise InputError(
                f"the ImplicitDiffusion solver needs a diffusion material in every block; block {blk.name!r} has {blk.material.name!r}",
                file=sim.deck.file,
                path=("Blocks",) + tuple(blk.path[1:2]) + ("Material",),
                fix="use the 'Diffusion' material model",
            )

    # -- norms (row order, sequential sums; reduced over ranks) -----------------------------------
    def norm2(self, v: np.ndarray) -> float:
        comm = self.sim.comm
        if comm.size > 1:
            return math.sqrt(comm.allreduce_sum(seq_dot(v, v)))
        return seq_norm2(v)

    def residual(self) -> tuple[float, np.ndarray]:
        """Peridigm's computeQuasiStaticResidual for the temperature: (||r||_2 + 20 ||r||_inf, r)
        with r = Q V (rows), zero on the prescribed points."""
        sim = self.sim
        sim.evaluate_forces()
        self.evaluations += 1
        r = self.Q[: self.n] * self.volume
        r[self.fixed_owned] = 0.0
        rr = np.ascontiguousarray(r[self.rows])
        return self.norm2(rr) + 20.0 * sim.comm.allreduce_max(norm_inf(rr)), rr

    def reaction_norm(self) -> float:
        R = np.where(self.fixed_owned, self.Q[: self.n] * self.volume, 0.0)
        return self.norm2(np.ascontiguousarray(R[self.rows]))

    # -- the run ----------------------------------------------------------------------------------
    def run(self) -> None:
        sim, q = self.sim, self.q
        wall0 = _time.perf_counter()
        times = load_times(self.p, q, path=(self.section, "ImplicitDiffusion"), file=sim.deck.file)
        t_cur = t_prev = times[0]
        self.state.time_prev = self.state.time = t_cur
        sim.apply_kinematic(t_cur, t_prev, self.state)
        sim.apply_body_forces(t_cur)
        for c in sim.conditions:  # Peridigm applies the initial conditions again, after the BCs
            if c.stage == "initial":
                c.apply_initial(sim)
        self.services.write_output(t_cur)
        log.info("%s: ImplicitDiffusion, %d load steps, %d unknowns", self.section, len(times) - 1, sim.num_global)
        attempts = []
        steps_done = 0
        for step in range(1, len(times)):
            t_prev = t_cur
            t_cur = times[step]
            self.state.time_prev, self.state.time = t_prev, t_cur
            sim.set_time_step(t_cur - t_prev)
            sim.apply_kinematic(t_cur, t_prev, self.state)
            sim.apply_body_forces(t_cur)
            res, r = self.residual()
            if q.absolute_tolerance is not None:
                tol = q.absolute_tolerance
            else:
                tol = q.relative_tolerance * self.reaction_norm()
            it = 1
            failure = ""
            while res > tol and it <= q.maximum_solver_iterations:
                self.state.nonlinear_iterations += 1
                log.debug("%s: load step %d, iteration %d: residual %.6g (tolerance %.6g)", self.section, step, it, res, tol)
                A = self.matrix
                A.assemble(sim)
                A.apply_kinematic_bc(self.fixed_local)
                A.scale(-1.0)
                result = self.linear.solve(A, r)
                if not result.converged:
                    failure = result.message or "the linear solver did not converge"
                    log.warning("%s: load step %d: %s", self.section, step, failure)
                    res = 1.0e50
                    break
                dT = result.x
                dT[self.fixed_owned[self.rows]] = 0.0
                self.T[self.rows] += 1.0 * dT
                res, r = self.residual()
                it += 1
            attempts.append({"step": step, "time": t_cur, "iterations": it - 1, "residual": res, "tolerance": tol})
            if res > tol:
                if res < 100.0 * tol and not failure:
                    log.warning("%s: load step %d (t = %.6g): residual %.4g above the tolerance %.4g; accepting it (within 100x)", self.section, step, t_cur, res, tol)
                else:
                    self._stats(wall0, steps_done, attempts)
                    raise DiffusionStepError(
                        f"{self.section}: load step {step} (t = {t_cur:.6g}) did not converge: residual {res:.4g}, tolerance {tol:.4g}"
                        + (f" ({failure})" if failure else f" after {q.maximum_solver_iterations} iterations")
                        + "; raise 'Maximum Solver Iterations' or use 'Linear Solver: Direct'"
                    )
            log.info("%s: load step %d (t = %.6g): %d iterations, residual %.4g (tolerance %.4g)", self.section, step, t_cur, it - 1, res, tol)
            self.services.write_output(t_cur)
            sim.advance()
            steps_done += 1
        self._stats(wall0, steps_done, attempts)

    def _stats(self, wall0: float, steps: int, attempts: list) -> None:
        sim = self.sim
        lin = self.linear
        sim.stats.setdefault("solvers", []).append({
            "section": self.section,
            "method": "ImplicitDiffusion",
            "steps": steps,
            "wall": _time.perf_counter() - wall0,
            "bond_evaluations": self.evaluations * sim.bonds.num_bonds,
            "point_steps": steps * sim.num_global,
            "force_evaluations": self.evaluations,
            "tangent_nonzeros": self.matrix.nnz,
            "tangent_assemblies": self.matrix.assemblies,
            "tangent_assembly_time": self.matrix.assembly_time,
            "nonlinear_iterations": self.state.nonlinear_iterations,
            "linear_solver": lin.chosen,
            "linear_iterations": lin.iterations,
            "linear_solves": lin.solves,
            "linear_solve_time": lin.solve_time,
            "linear_setup_time": lin.setup_time,
            "load_steps": attempts,
        })
