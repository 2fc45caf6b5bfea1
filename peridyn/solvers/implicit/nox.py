"""``NOXQuasiStatic``: load-stepped static equilibrium solved the way Peridigm drives Trilinos
NOX (``executeNOXQuasiStatic``; PERIDIGM_SEMANTICS.md §11.4).

Per load step the prescribed displacement increments are added to u *before* solving, and NOX
solves F(s) = (f + b) V = 0 (prescribed dofs zeroed) for the remaining increment s, from the
predictor s_0 = v_previous dt (zero on prescribed dofs), with y = (x + u) + s and
v = s/dt + v_prescribed. The step converges when ||F||_2 < tolerance (absolute, or relative to
the reaction norm at y = x + u), fails (aborting the run) after ``Max Solver Iterations``
steps; each NOX step adds one to ``Nonlinear_Solver_Iterations`` (also the first, which only
checks the initial guess).

Directions (``Direction > Method``):

* ``Newton``: J d = -F by AztecOO's GMRES (restart ``Size of Krylov Subspace`` 300, ``Max
  Iterations`` 400, ``Tolerance`` 1e-10 relative to the initial residual; an unconverged
  solve is used anyway; NOX solves J x = F from x = 0 and takes d = -x). J is the tangent of
  :mod:`peridyn.solvers.linalg.tangent` (prescribed rows and columns replaced by the mean absolute
  diagonal), or, with ``Jacobian Operator: Matrix-Free`` and
  ``Peridigm Preconditioner`` ``Block 3x3`` or ``None``, Jacobian-free:
  J w = (F(s + delta w) - F(s))/delta with NOX's delta = lambda (lambda + ||s||/||w||),
  lambda = 1e-6. Preconditioners: none; in the matrix-free mode with ``Preconditioner: User
  Defined`` (Peridigm's "Block 3x3"), what Peridigm's set-up actually applies: Peridigm inverts
  the 3x3 diagonal blocks of the tangent in place and hands that matrix to AztecOO, whose
  default incomplete LU then factors it exactly (the blocks are dense), so the preconditioner
  multiplies by the diagonal blocks instead of dividing by them (rebuilt every ``Max Age Of
  Prec`` uses); with a tangent Jacobian and ``Preconditioner: AztecOO``, AztecOO's
  ``Aztec Preconditioner`` (``Jacobi`` with ``Steps``, or an incomplete LU) of the tangent.
* ``NonlinearCG``: preconditioned nonlinear conjugate gradients (Fletcher-Reeves or
  Polak-Ribiere, restarted every ``Restart Frequency`` steps); the preconditioner is
  ``AztecOO Preconditioner Iterations`` GMRES iterations on the tangent with the Aztec
  preconditioner, as NOX applies an AztecOO preconditioner.

Nonlinear solvers (``Nonlinear Solver``): ``Line Search Based`` (a direction, then a line
search) or ``Inexact Trust Region Based`` (NOX's dogleg / inexact-Newton trust region with the
``Trust Region`` options, :mod:`peridyn.solvers.implicit.trust_region`; needs the tangent as Jacobian:
the Cauchy direction uses J^T F).

Line searches (``Line Search > Method``): ``Full Step``; ``Polynomial`` (NOX's: step 1, then
quadratic/cubic backtracking on 0.5 ||F||^2 with the Armijo-Goldstein condition, slope F.(J d));
``Backtrack`` (halving); ``NonlinearCG`` (one secant step -(F.d)/(d.J d)).

Every GMRES solve is AztecOO's with its safeguards (:mod:`peridyn.solvers.linalg.aztecoo`): it stops
when the Hessenberg condition estimate passes ``Ill-Conditioning Threshold`` (1e11), which keeps
the null-space part of a singular tangent (a body free to move) at round-off size.
"""
from __future__ import annotations

import logging
import math
import time as _time

import numpy as np

from ...core.services import RunServices
from ...core.state import SolverState
from ...core.errors import ExitCode, PeridynError
from ...core.interfaces import Solver
from ..linalg.aztecoo import aztecoo_gmres
from ..linalg.linear import gdot, gnorm
from ..monitors.progress import Progress
from .problem import (
    ImplicitProblem,
    load_times,
    planned_load_steps,
    solver_stats,
    threads_for,
)
from .nox_group import NOXGroup
from .nox_params import (  # noqa: F401 (re-exported)
    NOX_OTHER_KEYS,
    NOXLinearSolverParams,
    NOXQuasiStaticParams,
    NOXQuasiStaticSection,
)
from .trust_region import (
    ForcingTermOptions,
    TrustRegionError,
    TrustRegionOptions,
    TrustRegionSolver,
)

log = logging.getLogger("peridyn.solver")


class NOXConvergenceError(PeridynError):
    """A NOX load step did not converge (Peridigm aborts the run)."""

    exit_code = ExitCode.UNSTABLE


# ------------------------------------------------------------------------------------------------
class NOXQuasiStatic(Solver):
    name = "NOXQuasiStatic"
    Params = NOXQuasiStaticSection
    implicit = True

    def planned_steps(self, sim) -> int | None:
        return planned_load_steps(self.params, self.params.nox)

    @classmethod
    def tangent_request(cls, params) -> str:
        """The tangent this solver allocates (see Simulation._rank_deficient_node_set)."""
        if params.peridigm_preconditioner is None:
            return "default"
        return "block diagonal" if params.block_tangent else "full"

    def run(self, sim, state: SolverState, run: RunServices) -> SolverState:
        p = self.params
        if p.peridigm_preconditioner is None and p.nox.direction.method == "Newton" and p.linear_params.jacobian_operator == "Matrix-Free":
            log.warning(
                "%s: 'Jacobian Operator: Matrix-Free' without 'Peridigm Preconditioner' assembles the full tangent "
                "(Peridigm's default preconditioner is 'Full Tangent') and solves with it; for a Jacobian-free solve "
                "set 'Peridigm Preconditioner' to \"None\" or \"Block 3x3\"",
                self.section,
            )
        with threads_for(sim):
            NOXRun(self, sim, state, run).run()
        return state


class NOXRun:
    """One NOXQuasiStatic solver run (all vectors of the NOX problem are in row order)."""

    LAMBDA = 1.0e-6  # NOX::Epetra::MatrixFree perturbation parameter

    def __init__(self, solver: NOXQuasiStatic, sim, state: SolverState, services: RunServices) -> None:
        self.solver = solver
        self.sim = sim
        self.state = state
        self.services = services
        self.p = solver.params
        self.q = solver.params.nox
        self.section = solver.section
        kind = "block diagonal" if self.p.block_tangent else "full"
        self.problem = ImplicitProblem(sim, state, kind, section=solver.section)
        self.n = sim.num_owned
        f = sim.fields
        self.x, self.u, self.y, self.v = f["Model_Coordinates"], f["Displacement"], f["Coordinates"], f["Velocity"]
        self.dt = 1.0
        self.v_bc = np.zeros((self.n, 3))
        self.jacobian_requests = 0
        self.linear_iterations = 0
        self.trust_region_counters = [0, 0, 0, 0, 0]  # Newton, Cauchy, dogleg steps, inner iterations, recovery steps
        self.comm = self.problem.comm  # None serially
        self.progress = Progress(1, enabled=False)  # the run's bar, made when it starts
        self.last_status = (0, math.nan, math.nan)  # NOX step, ||F||, tolerance of the last status test

    # -- reductions over ranks (numpy's serially) -----------------------------------------------
    def _dot(self, a: np.ndarray, b: np.ndarray) -> float:
        return gdot(self.comm, a, b)

    def _norm(self, a: np.ndarray) -> float:
        return gnorm(self.comm, a)

    # -- the NOX interface ----------------------------------------------------------------------
    def set_state(self, s: np.ndarray) -> None:
        """y = (x + u) + s, v = s/dt + v_prescribed (s in row order)."""
        n = self.n
        sl = self.problem.to_local(s)
        np.add(self.x[:n], self.u[:n], out=self.y[:n])
        self.y[:n] += sl
        np.divide(sl, self.dt, out=self.v[:n])
        self.v[:n] += self.v_bc

    def F(self, s: np.ndarray) -> np.ndarray:
        self.set_state(s)
        return self.problem.force_vector()

    def jacobian(self, s: np.ndarray, update_every: int = 1) -> None:
        """Peridigm's evaluateNOX(Jac): the tangent at s with the BC modification (not negated),
        rebuilt when the request counter is a multiple of ``update_every``."""
        if self.jacobian_requests % update_every == 0:
            self.set_state(s)
            T = self.problem.assemble_tangent(self.p.probe_length)
            T.apply_kinematic_bc(self.problem.fixed_rows)
        self.jacobian_requests += 1

    # -- preconditioners ------------------------------------------------------------------------
    def block_preconditioner(self, s: np.ndarray):
        """What AztecOO applies for Peridigm's Block 3x3 preconditioner (see module docstring):
        the product with the BC-modified 3x3 diagonal blocks of the tangent at s."""
        self.jacobian(s)
        blocks = self.problem.tangent.diagonal_blocks()
        lin = self.p.linear_params
        if lin.aztec_preconditioner == "Jacobi":
            inv = np.linalg.inv(blocks)
            d = np.einsum("kii->ki", inv).reshape(-1)
            steps = lin.steps

            def apply(r):
                z = r / d
                for _ in range(steps - 1):
                    z = z + (r - np.einsum("kij,kj->ki", inv, z.reshape(-1, 3)).reshape(-1)) / d
                return z

            return apply

        def apply(r):
            return np.einsum("kij,kj->ki", blocks, r.reshape(-1, 3)).reshape(-1)

        return apply

    def aztec_preconditioner(self):
        """AztecOO's preconditioner built from the current tangent (``Aztec Preconditioner``)."""
        T = self.problem.tangent
        lin = self.p.linear_params
        if lin.aztec_preconditioner in ("Jacobi", "Symmetric Gauss-Seidel", "Polynomial", "Least-squares Polynomial"):
            d = T.diagonal().copy()
            d[d == 0.0] = 1.0
            steps = lin.steps
            tmp = np.empty_like(d)

            def apply(r):
                z = r / d
                for _ in range(steps - 1):
                    T.matvec(z, tmp)
                    z = z + (r - tmp) / d
                return z

            return apply
        from ..linalg.ilu import ILU0

        # under MPI: block-Jacobi, an incomplete LU of each rank's owned block (AztecOO's
        # domain decomposition without overlap); ILU(0) on the tangent's pattern (AZ_ilu)
        A = T.owned_block() if T.parallel else T.to_scipy(copy=True)
        if A.shape[0] == 0:
            return lambda r: r.copy()
        return ILU0(A).solve

    # -- directions -----------------------------------------------------------------------------
    def newton_direction(self, s: np.ndarray, F: np.ndarray) -> np.ndarray:
        lin = self.p.linear_params
        precond = None
        if self.p.matrix_free:
            norm_s = float(np.sqrt(self._dot(s, s)))

            def matvec(w, out):
                nw = float(np.sqrt(self._dot(w, w)))
                if nw == 0.0:
                    nw = 1.0
                eta = self.LAMBDA * (self.LAMBDA + norm_s / nw)
                fp = self.F(s + eta * w)
                np.subtract(fp, F, out=out)
                out *= 1.0 / eta

            if lin.preconditioner != "None":
                if self.prec is None or self.prec_age >= self.q.max_age_of_prec:
                    self.prec = self.block_preconditioner(s)
                    self.prec_age = 0
                self.prec_age += 1
                precond = self.prec
        else:
            self.jacobian(s)
            T = self.problem.tangent
            matvec = T.matvec
            if lin.preconditioner != "None":
                precond = self.aztec_preconditioner()
        # NOX's Epetra group zeroes the Newton vector, solves J x = F and negates x; with a
        # Jacobian-free operator J(-w) != -J(w), so the sign of the right-hand side matters
        tol = self.forcing_tolerance()
        res = aztecoo_gmres(
            matvec, F, None, tol, lin.kspace, lin.max_iterations, precond, classical=lin.orthogonalization == "Classical", comm=self.comm,
            ill_cond_thresh=lin.ill_conditioning_threshold,
        )
        res.x = -res.x
        self.linear_iterations += res.iterations
        if not res.converged:
            if not self.q.direction.newton.rescue_bad_newton_solve:
                raise NOXConvergenceError(f"{self.section}: the linear solve of a Newton step failed ({res.message})")
            log.debug("%s: %s; using the direction anyway", self.section, res.message)
        return res.x

    def forcing_tolerance(self) -> float:
        nt = self.q.direction.newton
        if nt.forcing_term_method == "Constant" or self.prev_norm is None:
            return self.p.linear_params.tolerance if nt.forcing_term_method == "Constant" else nt.forcing_term_initial_tolerance
        if nt.forcing_term_method == "Type 2":
            eta = nt.forcing_term_gamma * (self.cur_norm / self.prev_norm) ** nt.forcing_term_alpha
        else:
            eta = abs(self.cur_norm - self.prev_linear_residual) / self.prev_norm
        return min(max(eta, nt.forcing_term_minimum_tolerance), nt.forcing_term_maximum_tolerance)

    def ncg_direction(self, s: np.ndarray, F: np.ndarray, niter: int, F_old: np.ndarray | None) -> np.ndarray:
        cg = self.q.direction.nonlinear_cg
        lin = cg.linear_solver
        if cg.precondition == "On":
            self.jacobian(s, cg.update_jacobian)
            T = self.problem.tangent
            precond = self.aztec_preconditioner() if lin.preconditioner == "AztecOO" else None
            if lin.preconditioner == "None":
                z = F.copy()
            else:
                z = aztecoo_gmres(
                    T.matvec, F, None, 0.0, lin.kspace, lin.preconditioner_iterations, precond, classical=lin.orthogonalization == "Classical",
                    comm=self.comm, ill_cond_thresh=lin.ill_conditioning_threshold,
                ).x
        else:
            z = F.copy()
        d = -z
        beta = 0.0
        if niter != 0:
            denom = float(self._dot(self.old_descent, F_old))
            if cg.orthogonalize == "Polak-Ribiere":
                beta = float(self._dot(d - self.old_descent, F)) / denom
                beta = max(beta, 0.0)
            else:
                beta = float(self._dot(d, F)) / denom
            if niter % cg.restart_frequency == 0:
                beta = 0.0
        self.old_descent = d.copy()
        d = d + beta * self.old_dir
        self.old_dir = d.copy()
        return d

    def apply_jacobian(self, s: np.ndarray, F: np.ndarray, d: np.ndarray) -> np.ndarray:
        """J d at s (the directional derivative a line search needs)."""
        if self.p.matrix_free:
            nd = float(np.sqrt(self._dot(d, d))) or 1.0
            eta = self.LAMBDA * (self.LAMBDA + float(np.sqrt(self._dot(s, s))) / nd)
            return (self.F(s + eta * d) - F) / eta
        update = self.q.direction.nonlinear_cg.update_jacobian if self.q.direction.method == "NonlinearCG" else 1
        self.jacobian(s, update)
        return self.problem.tangent.matvec(d)

    # -- line searches --------------------------------------------------------------------------
    def line_search(self, s: np.ndarray, F: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ls = self.q.line_search
        if ls.method == "Full Step":
            s_new = s + d
            return s_new, self.F(s_new)
        if ls.method == "NonlinearCG":
            Jd = self.apply_jacobian(s, F, d)
            step = -float(self._dot(F, d)) / float(self._dot(d, Jd))
            s_new = s + step * d
            return s_new, self.F(s_new)
        if ls.method == "Backtrack":
            step = 1.0
            old = float(self._norm(F))
            for _ in range(100):
                s_new = s + step * d
                F_new = self.F(s_new)
                if float(self._norm(F_new)) < old:
                    return s_new, F_new
                step *= 0.5
            s_new = s + d
            return s_new, self.F(s_new)
        return self.polynomial(s, F, d)

    def polynomial(self, s: np.ndarray, F: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """NOX::LineSearch::Polynomial (merit 0.5 ||F||^2, Armijo-Goldstein)."""
        pp = self.q.line_search.polynomial
        nf = float(self._norm(F))
        oldf = 0.5 * nf * nf
        # the slope first (a matrix-free product evaluates F at a probe), then the trial point
        slope = float(self._dot(self.apply_jacobian(s, F, d), F))
        step = pp.default_step
        s_new = s + step * d
        F_new = self.F(s_new)
        nn = float(self._norm(F_new))
        newf = 0.5 * nn * nn
        cond = pp.sufficient_decrease_condition

        def sufficient(newf, step):
            if cond == "None":
                return True
            if cond == "Ared/Pred":
                return newf <= oldf * (1.0 - pp.alpha_factor * (1.0 - (1.0 - step * (1.0 - self.forcing_tolerance()))))
            return newf <= oldf + pp.alpha_factor * step * slope

        failed = slope >= 0
        ok = False if (failed or pp.force_interpolation) else sufficient(newf, step)
        n_iters = 1
        prevf = 0.0
        prev_step = 0.0
        first = True
        while not ok and not failed:
            if n_iters > pp.max_iters:
                failed = True
                break
            n_iters += 1
            if first or pp.interpolation_type == "Quadratic":
                temp = -(slope * step * step) / (2.0 * (newf - oldf - step * slope))
                first = False
            else:
                t1 = newf - oldf - step * slope
                t2 = prevf - oldf - prev_step * slope
                a = 1.0 / (step - prev_step) * (t1 / (step * step) - t2 / (prev_step * prev_step))
                b = 1.0 / (step - prev_step) * (-1.0 * t1 * prev_step / (step * step) + t2 * step / (prev_step * prev_step))
                disc = b * b - 3.0 * a * slope
                if disc < 0:
                    failed = True
                    break
                temp = -slope / (2.0 * b) if abs(a) < 1.0e-12 else (-b + math.sqrt(disc)) / (3.0 * a)
                temp = min(temp, 0.5 * step)
            prev_step, prevf = step, newf
            if temp < pp.min_bounds_factor * step:
                step *= pp.min_bounds_factor
            elif n_iters > 2 and temp > pp.max_bounds_factor * step:
                step *= pp.max_bounds_factor
            else:
                step = temp
            if step < pp.minimum_step:
                failed = True
                break
            s_new = s + step * d
            F_new = self.F(s_new)
            nn = float(self._norm(F_new))
            newf = 0.5 * nn * nn
            ok = sufficient(newf, step)
        if failed:
            step = pp.recovery_step if pp.recovery_step is not None else pp.default_step
            log.debug("%s: line search failed; using the recovery step %g", self.section, step)
            s_new = s + step * d
            F_new = self.F(s_new)
        return s_new, F_new

    # -- one load step --------------------------------------------------------------------------
    def solve_step(self, s: np.ndarray, tol: float, step_index: int) -> np.ndarray:
        """NOX's solver (a new one per load step, as Peridigm builds it) on F(s) = 0 from s;
        returns the converged s."""
        if self.q.nonlinear_solver == "Inexact Trust Region Based":
            return self.trust_region(s, tol, step_index)
        return self.line_search_based(s, tol, step_index)

    def trust_region(self, s: np.ndarray, tol: float, step_index: int) -> np.ndarray:
        """NOX's InexactTrustRegionBased solver (:mod:`peridyn.solvers.implicit.trust_region`)."""
        q = self.q
        nt = q.direction.newton
        forcing = ForcingTermOptions(
            method=nt.forcing_term_method, tolerance=self.p.linear_params.tolerance, initial=nt.forcing_term_initial_tolerance,
            minimum=nt.forcing_term_minimum_tolerance, maximum=nt.forcing_term_maximum_tolerance, alpha=nt.forcing_term_alpha,
            gamma=nt.forcing_term_gamma, rescue_bad_newton_solve=nt.rescue_bad_newton_solve,
        )
        options = q.trust_region.options()
        options = TrustRegionOptions(**{**options.__dict__, "cauchy_scaling": q.cauchy_direction.steepest_descent.scaling_type})
        solver = TrustRegionSolver(NOXGroup(self), s, options, forcing, lambda F, niter: self.status(F, tol, niter))
        status = "unconverged"
        try:
            while status == "unconverged":
                # one NOX solver->step() per pass, counted as Peridigm counts it
                self.state.nonlinear_iterations += 1
                status = solver.step()
                log.debug("%s: load step %d, NOX step %d: ||F|| = %.6g (tolerance %.6g)", self.section, step_index, solver.niter,
                          float(self._norm(solver.F)), tol)
        except TrustRegionError as e:
            raise NOXConvergenceError(f"{self.section}: load step {step_index} (t = {self.state.time:.6g}): NOX trust region: {e}") from None
        c = solver.counters
        self.trust_region_counters = [a + b for a, b in zip(self.trust_region_counters, (c.newton_steps, c.cauchy_steps, c.dogleg_steps, c.inner_iterations, c.recovery_steps))]
        if status != "converged":
            raise NOXConvergenceError(
                f"{self.section}: load step {step_index} (t = {self.state.time:.6g}) did not converge in {q.max_solver_iterations} NOX steps "
                f"(||F|| = {float(self._norm(solver.F)):.4g}, tolerance {tol:.4g}); Peridigm aborts here too"
            )
        self.set_state(solver.s)  # y and v as at the last residual evaluation
        return solver.s

    def line_search_based(self, s: np.ndarray, tol: float, step_index: int) -> np.ndarray:
        """NOX's LineSearchBased solver on F(s) = 0 from s; returns the converged s."""
        q = self.q
        self.prec = None
        self.prec_age = 0
        self.prev_norm = None
        self.cur_norm = None
        self.prev_linear_residual = 0.0
        self.old_descent = np.zeros_like(s)
        self.old_dir = np.zeros_like(s)
        self.jacobian_requests = 0
        F = self.F(s)
        niter = 0
        F_old = None
        status = self.status(F, tol, niter)
        while True:
            # one NOX solver->step(): Peridigm counts every call; the first one also checks the
            # initial guess and returns at once when it already converged
            self.state.nonlinear_iterations += 1
            if status != "unconverged":
                break
            nF = float(self._norm(F))
            self.cur_norm = nF
            if q.direction.method == "Newton":
                d = self.newton_direction(s, F)
                if q.direction.newton.forcing_term_method == "Type 1":
                    self.prev_linear_residual = float(self._norm(F + self.apply_jacobian(s, F, d)))
            else:
                d = self.ncg_direction(s, F, niter, F_old)
            niter += 1
            F_old = F
            self.prev_norm = nF
            s, F = self.line_search(s, F, d)
            status = self.status(F, tol, niter)
            log.debug("%s: load step %d, NOX step %d: ||F|| = %.6g (tolerance %.6g)", self.section, step_index, niter, float(self._norm(F)), tol)
            if status != "unconverged":
                break
        if status != "converged":
            raise NOXConvergenceError(
                f"{self.section}: load step {step_index} (t = {self.state.time:.6g}) did not converge in {q.max_solver_iterations} NOX steps "
                f"(||F|| = {float(self._norm(F)):.4g}, tolerance {tol:.4g}); Peridigm aborts here too"
            )
        self.set_state(s)  # y and v as at the last residual evaluation
        return s

    def status(self, F: np.ndarray, tol: float, niter: int) -> str:
        """NOX status tests, OR-combined: finite value, ||F||_2 < tol, iterations >= max."""
        nF = self.problem.norm2(F)
        self.last_status = (niter, nF, tol)
        self.progress.note(iteration=niter, residual=nF, tolerance=tol)
        if not math.isfinite(nF):
            return "failed"
        if nF < tol:
            return "converged"
        if niter >= self.q.max_solver_iterations:
            return "failed"
        return "unconverged"

    # -- the solver -----------------------------------------------------------------------------
    def run(self) -> None:
        sim, p, q, state = self.sim, self.p, self.q, self.state
        prob = self.problem
        wall0 = _time.perf_counter()
        times = load_times(p, q, path=(self.section, "NOXQuasiStatic"), file=sim.deck.file)
        n = self.n
        if not p.initialize_predictor:
            self.v[:] = 0.0
        t_cur = t_prev = times[0]
        state.time_prev = state.time = t_cur
        sim.apply_kinematic(t_cur, t_prev, state)
        sim.apply_body_forces(t_cur)
        self.services.write_output(t_cur)
        log.info(
            "%s: NOXQuasiStatic (%s%s), %d load steps from t = %.6g to %.6g, %d unknowns",
            self.section, q.direction.method, ", Jacobian-free" if p.matrix_free else "", len(times) - 1, times[0], times[-1], 3 * sim.num_global,
        )
        du = np.zeros((sim.num_local, 3))
        saved = state.delta_u
        state.delta_u = du
        steps = 0
        self.progress = Progress(len(times) - 1, self.section, enabled=self.services.progress, unit="load step")
        try:
            for k in range(1, len(times)):
                t_prev, t_cur = t_cur, times[k]
                self.dt = t_cur - t_prev
                sim.set_time_step(self.dt)  # rate-form materials integrate over the load step
                state.time_prev, state.time = t_prev, t_cur
                du[:] = 0.0
                guess = self.v[:n] * self.dt
                guess[prob.fixed_local] = 0.0
                self.v[:] = 0.0
                sim.apply_kinematic(t_cur, t_prev, state)
                self.u[:n] += du[:n]
                self.v_bc = self.v[:n].copy()
                sim.apply_body_forces(t_cur)
                s0 = prob.to_rows(guess)
                if q.absolute_tolerance is not None:
                    tol = q.absolute_tolerance
                else:
                    np.add(self.x[:n], self.u[:n], out=self.y[:n])
                    prob.force_vector()
                    tol = q.relative_tolerance * prob.reaction_norm()
                s = self.solve_step(s0, tol, k)
                sl = prob.to_local(s)
                np.divide(sl, self.dt, out=self.v[:n])
                self.v[:n] += self.v_bc
                self.u[:n] += sl
                self.services.write_output(t_cur)
                sim.advance()
                steps += 1
                niter, nF, tol = self.last_status
                log.info("%s: load step %d of %d (t = %.6g): ||F|| %.4g (tolerance %.4g) after %d NOX step(s)",
                         self.section, k, len(times) - 1, t_cur, nF, tol, niter,
                         extra={"fields": {"event": "load_step", "section": self.section, "step": k, "steps": len(times) - 1,
                                           "time": t_cur, "residual": nF, "tolerance": tol, "iterations": niter}})
                self.progress.update(k, residual=nF, tolerance=tol)
        finally:
            self.progress.close()
            state.delta_u = saved
            extra = {}
            if q.nonlinear_solver == "Inexact Trust Region Based":
                extra["trust_region"] = dict(zip(("newton_steps", "cauchy_steps", "dogleg_steps", "inner_iterations", "recovery_steps"), self.trust_region_counters))
            solver_stats(sim, self.section, "NOXQuasiStatic", steps, _time.perf_counter() - wall0, prob, linear_iterations=self.linear_iterations, **extra)
