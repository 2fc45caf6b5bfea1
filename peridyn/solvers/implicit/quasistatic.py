"""``QuasiStatic``: load-stepped Newton solution of static equilibrium f + b = 0, step for step
as Peridigm's ``executeQuasiStatic`` (PERIDIGM_SEMANTICS.md §11.2).

Each load step t_k: the prescribed displacement increments are applied (Delta u on the
prescribed dofs, the rest 0), y = (x + u) + Delta u, v = Delta u / Delta t, and Newton iterations
on the residual r = (f + b) V (prescribed dofs zeroed; norm ||r||_2 + 20 ||r||_inf) run while the
norm exceeds the tolerance (absolute, or relative to the reaction norm) and at most ``Maximum
Solver Iterations`` times:

* iteration 1 of steps after the first (or of the first, with ``Initialize Predictor From
  Previous Solver``) takes the predictor Delta u += v_previous Delta t without a solve;
* otherwise the tangent K (analytic, or finite differences; prescribed rows/columns replaced by
  the mean absolute diagonal) is rebuilt and (-K) lhs = r solved (plain CG to 1e-4 by default,
  see :mod:`peridyn.solvers.linalg.linear`); a failed solve is retried once on a damped tangent
  (diag * ``Damped Newton Diagonal Scale Factor`` + ``Shift Factor`` * max|diag|), which also
  switches the rest of the step to damped Newton (tangent rebuilt every 8 iterations);
* the step length comes from Peridigm's line search (a secant estimate, then fixed candidate
  lists), 1 with ``Disable Heuristics``.

A step that ends above the tolerance is accepted, with a warning, when within 100 x the
tolerance (and its linear solves succeeded); otherwise, with ``Adaptive Load-Stepping``, the step
is halved and retried, up to the given numbers of reductions, after which the solver either
continues from the last converged step with explicit dynamics (``Switch to Verlet``) or stops.
A step that fails for good stops the run with a :class:`LoadStepError` (exit status 3) naming the
load step, its time and size, the residual and the tolerance; the output of the converged steps
is kept. (Peridigm prints "Aborting analysis" there, yet runs the following solver sections.)
With ``Model Reduction`` (``Type: Static Condensation``, :mod:`.model_reduction`) each
Newton system is solved by static (Guyan) condensation of a region's displacement components
onto the rest (:mod:`peridyn.solvers.linalg.guyan`): a direct solve, equal to the full one to
round-off. ``sim.stats["solvers"]`` records every attempt (``load_steps``: time, size, iterations, residual,
tolerance, outcome) and the number of halvings (``load_step_reductions``). Reactions:
``Force_Density`` (and ``Force`` = V f) at the prescribed points hold the
internal force at the converged configuration, i.e. the negated reactions, as Peridigm writes.
"""
from __future__ import annotations

import logging
import math
import time as _time
from typing import Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from ...core.services import RunServices
from ...core.state import SolverState
from ...core.errors import InputError, InstabilityError
from ...core.interfaces import Solver
from ...core.params import ModelParams
from ..section import SolverSection
from ..linalg.linear import METHODS, LinearSolver
from .model_reduction import ModelReductionParams
from ..monitors.progress import Progress
from .problem import (
    ImplicitProblem,
    LoadTimes,
    check_time_steps,
    load_times,
    planned_load_steps,
    solver_stats,
    threads_for,
)
from .load_steps import (
    DAMPED_TANGENT_INTERVAL,
    PURE_NEWTON_STEPS,
    LoadStepError,
    line_search,
    change_output_frequency,
    fmod_zero,
    halve_load_step,
    multiply_output_frequency,
    reduce_remaining_load_steps,
)

log = logging.getLogger("peridyn.solver")

#: with the AMG solver, a Newton step that reduced the residual this many times keeps its tangent
TANGENT_REUSE_GAIN = 1.0e3


class SwitchToVerletParams(ModelParams):
    fixed_dt: float | None = Field(None, alias="Fixed dt", gt=0, description="time step of the explicit continuation (T)")
    safety_factor: float | None = Field(None, alias="Safety Factor", gt=0, description="multiplies the critical time step when Fixed dt is not given (default 1)")
    output_frequency: int | None = Field(None, alias="Output Frequency", ge=1, description="new Output Frequency of every output")


class AdaptiveLoadSteppingParams(ModelParams):
    max_reductions_in_step: int = Field(alias="Maximum load step reductions in one step", ge=0, le=1_000, description="halvings allowed for one load step")
    max_total_reductions: int = Field(alias="Maximum total load step reductions", ge=0, le=1_000_000, description="halvings allowed in the whole solver")
    reduce_all_remaining: bool = Field(False, alias="Reduce all remaining load steps", description="after a halving, use the smaller step to the end")
    adaptive_output_frequency: bool = Field(False, alias="Adaptive output frequency", description="double every output frequency at each halving")
    switch_to_verlet: SwitchToVerletParams | None = Field(None, alias="Switch to Verlet", description="continue with Verlet when the reductions run out")

    @model_validator(mode="after")
    def _limits(self):
        if self.max_total_reductions < self.max_reductions_in_step:
            raise ValueError("'Maximum total load step reductions' cannot be smaller than 'Maximum load step reductions in one step'")
        return self


class LoadStepKeys(LoadTimes):
    """Keys every load-stepping implicit solver sublist shares."""

    relative_tolerance: float = Field(1.0e-6, alias="Relative Tolerance", gt=0, description="residual tolerance relative to the reaction norm")
    absolute_tolerance: float | None = Field(None, alias="Absolute Tolerance", gt=0, description="residual tolerance (force units); replaces the relative one")

    _check_times = field_validator("time_steps")(lambda cls, v: check_time_steps(v) if v is not None else v)


class QuasiStaticParams(LoadStepKeys):
    maximum_solver_iterations: int = Field(10, alias="Maximum Solver Iterations", ge=0, le=1_000_000, description="Newton iterations per load step")
    damped_newton_scale: float = Field(1.0001, alias="Damped Newton Diagonal Scale Factor", gt=0, description="damped Newton: the diagonal is multiplied by this")
    damped_newton_shift: float = Field(1.0e-5, alias="Damped Newton Diagonal Shift Factor", ge=0, description="damped Newton: plus this times the largest diagonal entry")
    belos_linear_solver: Literal["BlockCG", "BlockGMRES"] = Field("BlockCG", alias="Belos Linear Solver", description="Peridigm's Krylov method")
    belos_maximum_iterations: int | None = Field(None, alias="Belos Maximum Iterations", ge=1, le=100_000_000, description="Krylov iterations per solve (default: number of unknowns)")
    belos_relative_tolerance: float = Field(1.0e-4, alias="Belos Relative Tolerance", gt=0, lt=1, description="Krylov stopping tolerance, relative to the right-hand side")
    belos_print_status: bool = Field(False, alias="Belos Print Status", description="accepted; use --verbose")
    adaptive: AdaptiveLoadSteppingParams | None = Field(None, alias="Adaptive Load-Stepping", description="halve load steps that do not converge")
    linear_solver: Literal[METHODS] = Field(  # type: ignore[valid-type]
        "Adaptive", alias="Linear Solver",
        description="peridyn: Adaptive (default: Peridigm's CG while it converges within 300 iterations, then AMG-preconditioned CG), "
        "Belos (always Peridigm's CG/GMRES), Direct (sparse LU), AMG (AMG-preconditioned CG), Auto",
    )
    linear_solver_tolerance: float = Field(1.0e-8, alias="Linear Solver Tolerance", gt=0, lt=1, description="peridyn: relative tolerance of the AMG solver")
    model_reduction: ModelReductionParams | None = Field(
        None, alias="Model Reduction", description="static (Guyan) condensation of the Newton systems onto the points outside a region (a direct solve)"
    )
    ignored_keys = frozenset({"Verbose"})

    @model_validator(mode="after")
    def _reduction_solves(self):
        if self.model_reduction is not None and self.given("linear_solver") and self.linear_solver != "Direct":
            raise ValueError(
                f"'Model Reduction' solves the Newton systems directly (by condensation); 'Linear Solver: {self.linear_solver}' contradicts it: "
                "remove one of them"
            )
        return self


class QuasiStaticSection(SolverSection):
    quasi_static: QuasiStaticParams = Field(alias="QuasiStatic", description="load-stepped static equilibrium")
    probe_length: float | None = Field(
        None, alias="Finite Difference Probe Length", gt=0, description="finite-difference tangent probe (L); default 1e-6 x the smallest element radius"
    )
    solve_for_displacement: bool = Field(True, alias="Solve For Displacement", description="unknowns: displacement (with Multiphysics, together with the pressure)")
    solve_for_pressure: bool = Field(False, alias="Solve For Pressure", description="unknowns: fluid pressure as a fourth dof per point (needs Multiphysics: 1)")

    @model_validator(mode="after")
    def _times(self):
        q = self.quasi_static
        if not ((self.given("final_time") and q.number_of_load_steps is not None) or q.time_steps is not None):
            raise ValueError(
                "no load steps: give 'Final Time' in the solver section with 'QuasiStatic > Number of Load Steps', or 'QuasiStatic > Time Steps'"
            )
        return self


class QuasiStatic(Solver):
    name = "QuasiStatic"
    Params = QuasiStaticSection
    implicit = True

    @classmethod
    def tangent_request(cls, params) -> str:
        """The tangent this solver allocates (see Simulation._rank_deficient_node_set)."""
        return "default"

    def planned_steps(self, sim) -> int | None:
        if self.params.quasi_static.model_reduction is not None:  # its input errors at set-up
            from .model_reduction import validate

            validate(sim, self.params.quasi_static.model_reduction, self.reduction_path)
        adaptive = self.params.quasi_static.adaptive
        if adaptive is not None and adaptive.switch_to_verlet is not None:  # its own limits, at set-up
            fallback_verlet(self, sim, self.params.initial_time, self.params.final_time)
        return planned_load_steps(self.params, self.params.quasi_static)

    @property
    def reduction_path(self) -> tuple[str, ...]:
        return (self.section, "QuasiStatic", "Model Reduction")

    def run(self, sim, state: SolverState, run: RunServices) -> SolverState:
        with threads_for(sim):
            if sim.deck.multiphysics:  # 4 dofs per point (PERIDIGM_MODELS.md §7)
                from .coupled import CoupledQuasiStaticRun

                CoupledQuasiStaticRun(self, sim, state, run).run()
            else:
                if self.params.solve_for_pressure or not self.params.solve_for_displacement:
                    from ...core.errors import InputError

                    raise InputError(
                        "QuasiStatic solves for the displacement; the fluid pressure is an unknown only in a Multiphysics deck",
                        file=sim.deck.file, path=(self.section,), fix="set 'Multiphysics: 1' at the top level (and use Multiphysics materials), or remove the Solve For keys",
                    )
                QuasiStaticRun(self, sim, state, run).run()
        return state


def fallback_verlet(solver: QuasiStatic, sim, t_start: float, t_final: float):
    """The ``Switch to Verlet`` continuation of ``solver`` over [t_start, t_final], after the
    estimate-and-limit rules of any Verlet section (InputError: no step would fit, or too many)."""
    from ..explicit.verlet import Verlet, VerletSection

    sw = solver.params.quasi_static.adaptive.switch_to_verlet
    verlet = {"Fixed dt": sw.fixed_dt} if sw.fixed_dt is not None else {"Safety Factor": sw.safety_factor if sw.safety_factor is not None else 1.0}
    params = VerletSection.model_validate({"Initial Time": t_start, "Final Time": t_final, "Verlet": verlet})
    fallback = Verlet(params, section=f"{solver.section} > Switch to Verlet")
    path = (solver.section, "QuasiStatic", "Adaptive Load-Stepping", "Switch to Verlet")
    try:
        steps = fallback.planned_steps(sim)
    except InputError as exc:
        raise InputError(exc.message, file=sim.deck.file, path=path, fix=exc.fix) from None
    sim.check_steps(steps, path, fallback.section)
    return fallback


class QuasiStaticRun:
    """State of one QuasiStatic solver run."""

    def __init__(self, solver: QuasiStatic, sim, state: SolverState, services: RunServices) -> None:
        self.solver = solver
        self.sim = sim
        self.state = state
        self.services = services
        self.p = solver.params
        self.q = solver.params.quasi_static
        self.section = solver.section
        self.problem = ImplicitProblem(sim, state, "full", section=solver.section)
        n = sim.num_owned
        self.n = n
        f = sim.fields
        self.x = f["Model_Coordinates"]
        self.u = f["Displacement"]
        self.y = f["Coordinates"]
        self.v = f["Velocity"]
        self.du = np.zeros((sim.num_local, 3))
        T = self.problem.tangent
        q = self.q
        if q.model_reduction is not None:
            from .model_reduction import condensed_solver

            self.linear = condensed_solver(sim, T, q.model_reduction, solver.reduction_path)
        else:
            self.linear = self.linear_solver(T)
        self.heuristics = not self.p.disable_heuristics
        self.dt = 1.0
        self.tangent_reuses = 0
        self.residuals: list[list[float]] = []  # per load step attempt: residual norm before each iteration and at the end
        self.attempts: list[dict] = []  # per load step attempt: step, time, dt, iterations, residual, tolerance, outcome
        self.progress = Progress(1, enabled=False)  # the run's bar, made when it starts
        self.step = 0  # the load step being solved
        self.failure: str | None = None  # why the last Newton loop stopped early (a failed linear solve)

    def linear_solver(self, T) -> LinearSolver:
        """The deck's ``Linear Solver`` on tangent T."""
        q = self.q
        return LinearSolver(
            method=q.linear_solver,
            tol=q.belos_relative_tolerance if q.linear_solver in ("Belos", "Adaptive") else q.linear_solver_tolerance,
            maxiter=q.belos_maximum_iterations if q.linear_solver in ("Belos", "Adaptive") else q.belos_maximum_iterations or 2000,
            belos_method=q.belos_linear_solver,
            symmetric=True,
            coords=T.to_rows(self.x).reshape(self.n, 3),
        )

    # -- state ----------------------------------------------------------------------------------
    def set_trial(self, du: np.ndarray) -> None:
        """y = (x + u) + du, v = du / dt."""
        np.add(self.x, self.u, out=self.y)
        self.y += du
        np.divide(du, self.dt, out=self.v)

    def trial_residual(self, du: np.ndarray) -> tuple[float, np.ndarray]:
        self.set_trial(du)
        return self.problem.qs_residual()

    # -- line search ----------------------------------------------------------------------------
    def line_search(self, r: np.ndarray, lhs_rows: np.ndarray, lhs: np.ndarray) -> float:
        """Peridigm's quasiStaticsLineSearch: the step length along lhs."""
        prob = self.problem
        du0 = self.du.copy()
        rho0, r0 = prob.qs_residual()
        if not math.isfinite(rho0):
            raise InstabilityError(
                f"{self.section}: load step {self.step} (t = {self.state.time:.6g}): the residual is not finite; the load step is too large or the model is unstable"
            )
        if rho0 == 0.0:
            return 0.0
        return line_search(self.trial_residual, du0, lhs, lhs_rows, rho0, r0, prob.dot, self.section)

    def reuse_tangent(self, history: list[float]) -> bool:
        """Keep the last assembled tangent for this Newton iteration? Only once the run has left
        Peridigm's linear solver for AMG (``Linear Solver: Adaptive`` on a system plain CG could
        not solve in 300 iterations: Peridigm's iterates are not reproduced there anyway), and
        only while the last step with it reduced the residual at least ``TANGENT_REUSE_GAIN``
        times (a tangent that still gives Newton's convergence; a worse step reassembles)."""
        if not self.linear.switched or self.linear._chosen != "AMG" or len(history) < 2:
            return False
        return history[-1] <= history[-2] / TANGENT_REUSE_GAIN

    # -- one load step --------------------------------------------------------------------------
    def newton(self, step: int, predictor: np.ndarray, use_predictor_first: bool) -> tuple[float, float, int]:
        """Newton iterations of one load step from the current du; returns (residual norm,
        tolerance, iterations + 1). ``self.failure`` says why the loop stopped early (a linear
        solve failed: Peridigm's residual 1e50, a step that is never accepted), else None."""
        prob, q = self.problem, self.q
        self.step = step
        self.failure = None
        T = prob.tangent
        res, r = prob.qs_residual()
        if q.absolute_tolerance is not None:
            tol = q.absolute_tolerance
        else:
            tol = q.relative_tolerance * prob.reaction_norm()
        it = 1
        damped = False
        history = [res]
        self.residuals.append(history)
        while res > tol and it <= q.maximum_solver_iterations:
            self.state.nonlinear_iterations += 1
            log.debug("%s: load step %d, iteration %d: residual %.6g (tolerance %.6g)", self.section, step, it, res, tol)
            self.progress.note(iteration=it, residual=res, tolerance=tol)
            if it == 1 and (step > 1 or use_predictor_first) and self.heuristics:
                lhs = predictor * self.dt
                lhs[prob.fixed_local] = 0.0
                ok = True
            else:
                if it > PURE_NEWTON_STEPS and not damped and self.heuristics:
                    log.info("%s: switching to damped Newton", self.section)
                    damped = True
                if not damped or fmod_zero(it - PURE_NEWTON_STEPS - 1, DAMPED_TANGENT_INTERVAL):
                    if self.reuse_tangent(history):
                        self.tangent_reuses += 1
                    else:
                        prob.assemble_tangent(self.p.probe_length)
                        T.apply_kinematic_bc(prob.fixed_rows)
                        T.scale(-1.0)
                        if damped:
                            T.damp(q.damped_newton_scale, q.damped_newton_shift)
                        self.linear.set_matrix(T)
                result = self.linear.solve(r)
                if not result.converged and self.heuristics:
                    log.info("%s: linear solve failed (%s); switching to damped Newton", self.section, result.message)
                    if not damped:
                        T.damp(q.damped_newton_scale, q.damped_newton_shift)
                        self.linear.set_matrix(T)
                    damped = True
                    result = self.linear.solve(r)
                ok = result.converged
                if ok:
                    lhs = prob.to_local(result.x)
                else:
                    self.failure = f"the linear solve of iteration {it} failed ({result.message})"
            if not ok:
                break
            lhs[prob.fixed_local] = 0.0
            lhs_rows = prob.to_rows(lhs)
            alpha = self.line_search(r, lhs_rows, prob.pad(lhs)) if self.heuristics else 1.0
            self.du[: self.n] += alpha * lhs
            res, r = self.trial_residual(self.du)
            history.append(res)
            it += 1
        return res, tol, it

    # -- the solver -----------------------------------------------------------------------------
    def run(self) -> None:
        sim, p, q = self.sim, self.p, self.q
        wall0 = _time.perf_counter()
        times = load_times(p, q, path=(self.section, "QuasiStatic"), file=sim.deck.file)
        n = self.n
        predictor = self.v[:n].copy() if p.initialize_predictor else np.zeros((n, 3))
        self.v[:] = 0.0
        t_cur = t_prev = times[0]
        self.state.time_prev = self.state.time = t_cur
        sim.apply_kinematic(t_cur, t_prev, self.state)
        sim.apply_body_forces(t_cur)
        self.services.write_output(t_cur)
        nnz = sim.comm.allreduce_sum(int(self.problem.tangent.nnz))  # stored by all ranks (ghost rows included)
        log.info("%s: QuasiStatic, %d load steps from t = %.6g to %.6g, %d unknowns, tangent %d nonzeros",
                 self.section, len(times) - 1, times[0], times[-1], 3 * sim.num_global, nnz)
        self.progress = Progress(len(times) - 1, self.section, enabled=self.services.progress, unit="load step")

        adaptive = q.adaptive
        t_final = times[-1]
        failed_this_step = 0
        total_failures = 0
        convergence_failed_in_step = False
        retry = False
        failed_qs = False
        completed = 0
        saved_delta_u = self.state.delta_u
        self.state.delta_u = self.du
        try:
            step = 1
            while step < len(times):
                if adaptive is None or not retry:
                    t_prev = t_cur
                retry = False
                t_cur = times[step]
                self.dt = t_cur - t_prev
                sim.set_time_step(self.dt)  # rate-form materials integrate over the load step
                self.state.time_prev, self.state.time = t_prev, t_cur
                self.du[:] = 0.0
                sim.apply_kinematic(t_cur, t_prev, self.state)
                sim.apply_body_forces(t_cur)
                self.set_trial(self.du)
                res, tol, it = self.newton(step, predictor, p.initialize_predictor)
                outcome = "converged" if self.failure is None and res <= tol else "accepted" if self.failure is None and res < 100.0 * tol else "failed"
                if outcome == "accepted":
                    log.warning("%s: load step %d (t = %.6g): accepting residual %.4g, above the tolerance %.4g", self.section, step, t_cur, res, tol)
                elif outcome == "failed":
                    what = self.describe_failure(step, t_cur, res, tol, it)
                    if adaptive is not None:
                        failed_this_step += 1
                        total_failures += 1
                        if total_failures <= adaptive.max_total_reductions and failed_this_step <= adaptive.max_reductions_in_step:
                            outcome = "cut back"
                            log.warning("%s: halving it", what)
                            retry = True
                            convergence_failed_in_step = True
                        else:
                            what += (
                                f"; no more load step reductions allowed ({total_failures - 1} made, at most "
                                f"{adaptive.max_reductions_in_step} per step and {adaptive.max_total_reductions} in all)"
                            )
                    if not retry:
                        failed_qs = True
                self.attempts.append(
                    {"step": step, "time": t_cur, "dt": self.dt, "iterations": it - 1, "residual": res, "tolerance": tol, "outcome": outcome}
                )
                if failed_qs:
                    break
                if adaptive is not None and retry:
                    halve_load_step(times, step, t_prev, self.dt)
                    self.progress.retotal(len(times) - 1)
                    if adaptive.adaptive_output_frequency:
                        multiply_output_frequency(self.services.files.writers, 2.0)
                    continue  # same index, now the shorter step
                if adaptive is not None and adaptive.reduce_all_remaining and convergence_failed_in_step:
                    reduce_remaining_load_steps(times, step, t_cur, self.dt, t_final)
                    self.progress.retotal(len(times) - 1)
                if it >= q.maximum_solver_iterations and q.maximum_solver_iterations > 0:
                    log.info("%s: load step %d used the maximum number of nonlinear iterations", self.section, step)
                convergence_failed_in_step = False
                failed_this_step = 0
                self.u[:n] += self.du[:n]
                predictor = self.v[:n].copy()
                self.services.write_output(t_cur)
                sim.advance()
                completed += 1
                log.info("%s: load step %d of %d (t = %.6g) %s: residual %.4g (tolerance %.4g) after %d iteration(s)",
                         self.section, step, len(times) - 1, t_cur, outcome, res, tol, it - 1,
                         extra={"fields": {"event": "load_step", "section": self.section, "step": step, "steps": len(times) - 1,
                                           "time": t_cur, "outcome": outcome, "residual": res, "tolerance": tol, "iterations": it - 1}})
                self.progress.update(step, residual=res, tolerance=tol)
                step += 1
        finally:
            self.state.delta_u = saved_delta_u
            self.progress.close()
        lin = self.linear
        solver_stats(
            sim, self.section, "QuasiStatic", completed, _time.perf_counter() - wall0, self.problem,
            linear_solver=lin._chosen or lin.method, linear_solve_time=lin.solve_time, linear_setup_time=lin.setup_time,
            linear_iterations=lin.iterations, linear_solves=lin.solves, converged=not failed_qs, residuals=self.residuals,
            load_steps=self.attempts, load_step_reductions=sum(a["outcome"] == "cut back" for a in self.attempts),
            tangent_reuses=self.tangent_reuses, **({"model_reduction": lin.summary()} if self.q.model_reduction is not None else {}),
        )
        if failed_qs:
            if adaptive is not None and adaptive.switch_to_verlet is not None:
                log.warning("%s", what)
                self.switch_to_verlet(t_prev, t_final, predictor)
            else:
                more = "'Adaptive Load-Stepping'" if adaptive is None else "more load step reductions"
                raise LoadStepError(
                    f"{what}; the run stops at the last converged load step (t = {t_prev:.6g}): use smaller load steps, more "
                    f"'Maximum Solver Iterations' or {more}"
                )

    def describe_failure(self, step: int, t: float, res: float, tol: float, it: int) -> str:
        """One line naming the load step, its time and size, the residual and the tolerance."""
        text = (
            f"{self.section}: load step {step} (t = {t:.6g}, step size {self.dt:.4g}) did not converge: residual {res:.4g} "
            f"after {it - 1} iteration(s) (tolerance {tol:.4g}, 'Maximum Solver Iterations' {self.q.maximum_solver_iterations})"
        )
        return (text + f"; {self.failure}") if self.failure is not None else text

    def switch_to_verlet(self, t_start: float, t_final: float, predictor: np.ndarray) -> None:
        sim = self.sim
        sw = self.q.adaptive.switch_to_verlet
        log.warning("%s: too many load step reductions; continuing with explicit dynamics (Verlet) from t = %.6g", self.section, t_start)
        if sw.output_frequency is not None:
            change_output_frequency(self.services.files.writers, sw.output_frequency)
        try:
            verlet = fallback_verlet(self.solver, sim, t_start, t_final)
        except InputError as exc:
            raise LoadStepError(f"{self.section} > Switch to Verlet cannot continue the run from t = {t_start:.6g}: {exc.message}") from None
        n = self.n
        np.add(self.x, self.u, out=self.y)
        self.v[:n] = predictor
        verlet.run(sim, self.state, self.services)
