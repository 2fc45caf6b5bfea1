"""``Implicit``: Newmark-beta dynamics, as Peridigm's ``executeImplicit`` (PERIDIGM_SEMANTICS.md
§11.6).

Each step from (u_n, v_n, a_n), with the Newmark predictors

    u~ = u_n + (dt v_n + (dt^2 (1 - 2 beta)/2) a_n),    v~ = v_n + dt (1 - gamma) a_n,

u starts at u~ (so a = (u - u~)/(beta dt^2) = 0 and v = v~ + gamma dt a) and Newton iterations
solve the residual

    r = beta dt^2 (rho a - f - b)        (force density; zero on prescribed dofs; norm ||r||_2)

while ||r|| > ``Absolute Tolerance``, at most ``Maximum Solver Iterations`` + 1 times, each with
the Jacobian J = rho I - beta dt^2 K (K = d(f V)/dy, the quasi-static tangent), prescribed rows
and columns replaced by the mean absolute diagonal, and a CG solve to 1e-10 (a solve that does
not converge is used anyway, with a warning).

Peridigm's quirks, kept for its decks: the body force is evaluated at the start time of the step
(it lags one step); prescribed displacements are applied only at the initial time (their dofs
simply follow the Newmark predictor afterwards, their residual rows being zero); J mixes force
and force-density units, so it is the exact Jacobian of r only when the point volumes are 1 (the
iteration still converges to the same solution, linearly instead of quadratically); the
acceleration starts at the previous solver's (zero at the start of a run), not at (f + b)/rho.

With beta = 1/4, gamma = 1/2 (the defaults, the trapezoidal rule) the scheme is unconditionally
stable and conserves the energy of a linear system exactly.
"""
from __future__ import annotations

import logging
import time as _time
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from ...core.interfaces import Solver
from ...core.services import RunServices
from ...core.state import SolverState
from ...core.params import ModelParams
from ..section import SolverSection, count_steps
from ..linalg.linear import METHODS, LinearSolver
from .problem import ImplicitProblem, threads_for, solver_stats
from ..monitors.progress import Progress

log = logging.getLogger("peridyn.solver")


class ImplicitParams(ModelParams):
    fixed_dt: float = Field(alias="Fixed dt", gt=0, description="time step (T)")
    beta: float = Field(0.25, alias="Beta", gt=0, le=0.5, description="Newmark beta (1/4: trapezoidal rule)")
    gamma: float = Field(0.5, alias="Gamma", ge=0, le=1, description="Newmark gamma (1/2: no numerical damping)")
    absolute_tolerance: float = Field(1.0e-6, alias="Absolute Tolerance", gt=0, description="tolerance on ||beta dt^2 (rho a - f - b)|| (force density x time^2)")
    maximum_solver_iterations: int = Field(10, alias="Maximum Solver Iterations", ge=0, le=1_000_000, description="Newton iterations per step (Peridigm runs up to this + 1)")
    linear_solver: Literal[METHODS] = Field(  # type: ignore[valid-type]
        "Belos", alias="Linear Solver", description="peridyn: Belos (Peridigm's CG to 1e-10, default), Direct, AMG, Auto"
    )
    linear_solver_tolerance: float = Field(1.0e-10, alias="Linear Solver Tolerance", gt=0, lt=1, description="peridyn: relative tolerance of the AMG solver")
    ignored_keys = frozenset({"Verbose"})


class ImplicitSection(SolverSection):
    implicit: ImplicitParams = Field(alias="Implicit", description="Newmark-beta implicit dynamics")
    probe_length: float | None = Field(
        None, alias="Finite Difference Probe Length", gt=0, description="finite-difference tangent probe (L); default 1e-6 x the smallest element radius"
    )

    @model_validator(mode="after")
    def _final_time(self):
        if not self.given("final_time"):
            raise ValueError("the Implicit solver needs 'Final Time'")
        if self.final_time < self.initial_time:
            raise ValueError(f"'Final Time' ({self.final_time}) is before 'Initial Time' ({self.initial_time})")
        return self


class Implicit(Solver):
    name = "Implicit"
    Params = ImplicitSection
    implicit = True

    def planned_time_step(self, sim) -> float:
        return float(self.params.implicit.fixed_dt)

    @classmethod
    def tangent_request(cls, params) -> str:
        """The tangent this solver allocates (see Simulation._rank_deficient_node_set)."""
        return "default"

    def planned_steps(self, sim) -> int:
        p = self.params
        return count_steps(p.initial_time, p.final_time, p.implicit.fixed_dt, source="'Fixed dt'", file=sim.deck.file,
                           path=(self.section, "Implicit"))

    def run(self, sim, state: SolverState, run: RunServices) -> SolverState:
        with threads_for(sim):
            self._run(sim, state, run)
        return state

    def _run(self, sim, state: SolverState, run: RunServices) -> None:
        p = self.params
        ip = p.implicit
        wall0 = _time.perf_counter()
        prob = ImplicitProblem(sim, state, "full", section=self.section)
        T = prob.tangent
        n = sim.num_owned
        f = sim.fields
        x, u, y, v = f["Model_Coordinates"], f["Displacement"], f["Coordinates"], f["Velocity"]
        rho = sim.density_per_point()[:n]
        a = state.acceleration
        if a is None:
            a = state.acceleration = np.zeros((sim.num_local, 3))
        dt = ip.fixed_dt
        beta, gamma = ip.beta, ip.gamma
        dt2 = dt * dt
        t0 = p.initial_time
        nsteps = self.planned_steps(sim)
        lin = LinearSolver(
            method=ip.linear_solver,
            tol=1.0e-10 if ip.linear_solver == "Belos" else ip.linear_solver_tolerance,
            maxiter=None if ip.linear_solver == "Belos" else 2000,
            symmetric=True,
            coords=T.to_rows(x).reshape(n, 3),
        )
        rho_rows = np.repeat(rho[T.owned_local], 3)
        has_b = prob.has_body_force
        b = f["External_Force_Density"] if has_b else None
        fixed = prob.fixed_local
        c_u = (0.5 * dt2) * (1.0 - 2.0 * beta)
        inv_bdt2 = 1.0 / (beta * dt2)
        jscale = ((-beta) * dt) * dt

        t_cur = t_prev = t0
        state.time_prev = state.time = t_cur
        sim.apply_kinematic(t_cur, t_prev, state)
        sim.apply_body_forces(t_cur)
        run.write_output(t_cur)
        log.info("%s: Implicit (Newmark beta = %g, gamma = %g), dt = %.6g, %d steps, %d unknowns", self.section, beta, gamma, dt, nsteps, 3 * sim.num_global)

        def residual() -> tuple[float, np.ndarray]:
            fd = sim.evaluate_forces()[:n]
            prob.evaluations += 1
            sim.apply_body_forces(t_cur)  # t_cur is still the step's start time: Peridigm lags the body force
            acc = rho[:, None] * a[:n] - fd
            if has_b:
                acc -= b[:n]
            r = (beta * dt2) * acc
            r[fixed] = 0.0
            rr = prob.to_rows(r)
            return prob.norm2(rr), rr

        warned = 0
        progress = Progress(nsteps, self.section, enabled=run.progress)
        for step in range(nsteps):
            un = u[:n].copy()
            vn = v[:n].copy()
            an = a[:n].copy()
            u2 = un + (dt * vn + c_u * an)
            v2 = vn + (dt * (1.0 - gamma)) * an
            u[:n] = u2
            a[:n] = (u[:n] + (-1.0) * u2) * inv_bdt2
            v[:n] = v2 + (dt * gamma) * a[:n]
            np.add(x, u, out=y)
            res, r = residual()
            it = 0
            while res > ip.absolute_tolerance and it <= ip.maximum_solver_iterations:
                state.nonlinear_iterations += 1
                log.debug("%s: step %d, iteration %d: residual %.6g", self.section, step + 1, it, res)
                progress.note(iteration=it, residual=res, tolerance=ip.absolute_tolerance)
                prob.assemble_tangent(p.probe_length)
                T.scale(jscale)
                T.add_to_diagonal(rho_rows)
                T.apply_kinematic_bc(prob.fixed_rows)
                lin.set_matrix(T)
                result = lin.solve(-r)
                if not result.converged:
                    warned += 1
                    log.warning("%s: step %d: the linear solver did not converge (%s); proceeding with its result", self.section, step + 1, result.message)
                u[:n] += prob.to_local(result.x)
                np.add(x, u, out=y)
                a[:n] = (u[:n] - u2) * inv_bdt2
                v[:n] = v2 + (dt * gamma) * a[:n]
                res, r = residual()
                it += 1
            if res > ip.absolute_tolerance:
                log.warning("%s: step %d (t = %.6g) ended with residual %.4g above the tolerance %.4g", self.section, step + 1, t0 + (step + 1) * dt, res, ip.absolute_tolerance)
            t_prev = t_cur
            t_cur = t0 + (step + 1) * dt
            state.time_prev, state.time = t_prev, t_cur
            run.write_output(t_cur)
            sim.advance()
            log.debug("%s: step %d of %d (t = %.6g): residual %.4g (tolerance %.4g) after %d iteration(s)", self.section, step + 1, nsteps,
                      t_cur, res, ip.absolute_tolerance, it, extra={"fields": {"event": "step", "section": self.section, "step": step + 1,
                                                                              "steps": nsteps, "time": t_cur, "residual": res, "iterations": it}})
            progress.update(step + 1, residual=res, tolerance=ip.absolute_tolerance)
        progress.close()
        solver_stats(
            sim, self.section, "Implicit", nsteps, _time.perf_counter() - wall0, prob,
            dt=dt, linear_solver=lin._chosen or lin.method, linear_solve_time=lin.solve_time, linear_setup_time=lin.setup_time,
            linear_iterations=lin.iterations, linear_solves=lin.solves,
        )
