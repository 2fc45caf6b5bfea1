"""The coupled QuasiStatic solve: displacement and fluid pressure, 4 unknowns per point
(u_x, u_y, u_z, p), for decks with ``Multiphysics: 1`` (PERIDIGM_MODELS.md §7; Peridigm's
``executeQuasiStatic`` with ``analysisHasMultiphysics``).

Differences from the displacement-only solve (:mod:`peridyn.solvers.implicit.quasistatic`,
PERIDIGM_SEMANTICS.md §11.2):

* residual per point [(f + b) V, flow V] (``Flux_Density`` times volume), zero on the dofs of
  ``Prescribed Displacement`` and ``Prescribed Fluid Pressure U``; norm ||r||_2 + 20 ||r||_inf;
* trial state y = (x + u) + du, v = du / dt and p_Y = p_U + dp (no reference value),
  p_V = dp / dt; the predictor, Newton update and line search act on all four dofs; at the end
  of a load step u += du, p_U += dp, predictor <- (v, p_V);
* the tangent is the exact 4x4-block Jacobian (:mod:`peridyn.solvers.linalg.coupled_tangent`), with
  rows and columns of prescribed dofs replaced as for displacements (D over all 4 N dofs);
* the relative tolerance scales with the 4-dof reactions (f V, flow V on prescribed dofs);
* Peridigm's line search, multiphysics branch, evaluates its first candidate list (the secant
  estimate and 0.1 ... 1.0) all at the probe step 1e-4 lhs (it adds epsilon, not alpha, there):
  reproduced, since the Newton iterates of Peridigm's decks depend on it.

Linear solves: Peridigm's CG (``Belos``), or ``Direct``; ``AMG``/``Auto``/``Adaptive`` fall back
to Peridigm's CG (their near-null space is the displacement rigid-body modes).
"""
from __future__ import annotations

import logging
import math
import time as _time

import numpy as np

from ...kernels.gathers import gather_bond_scalar_kernel
from ...core.services import RunServices
from ...core.state import SolverState
from ...core.errors import InputError, InstabilityError
from ..linalg.coupled_tangent import CoupledTangent
from ..linalg.linear import LinearSolver, norm_inf, seq_dot, seq_norm2
from .load_steps import line_search
from .problem import load_times, solver_stats

log = logging.getLogger("peridyn.solver")


def flow_bond_field(sim) -> str:
    """The bond field of the per-bond fluid flow, declared by every block's material
    (``Material.flow_bond_field``): one name shared by all blocks."""
    names = {blk.material.flow_bond_field for blk in sim.blocks}
    if len(names) != 1 or None in names:
        listed = ", ".join(f"{blk.material.name!r}: {blk.material.flow_bond_field!r}" for blk in sim.blocks)
        raise InputError(
            f"the coupled QuasiStatic solve needs every block's material to declare one bond field of fluid flow (flow_bond_field), got {listed}",
            fix="use multiphysics materials that write their per-bond flow into the same field",
        )
    return names.pop()


class CoupledProblem:
    """Residual r = [(f + b) V, flow V] (row order, 4 per point, prescribed dofs zeroed), its
    norms, the reactions and the 4x4-block tangent."""

    def __init__(self, sim, state: SolverState | None = None) -> None:
        self.sim = sim
        self.state = state if state is not None else SolverState()  #: the section's (None: a fresh one)
        self.comm = sim.comm if sim.comm.size > 1 else None
        n = sim.num_owned
        self.n = n
        self.tangent = CoupledTangent(sim)
        fixed = np.zeros((n, 4), dtype=bool)
        fixed[:, :3] = sim.prescribed_dofs[:n]
        for c in sim.kinematic:
            if c.target == "fluid_pressure":
                fixed[c.points, 3] = True
        self.fixed_local = fixed
        self.fixed_rows = np.ascontiguousarray(fixed[self.tangent.owned_local])
        f = sim.fields
        self.volume = f["Volume"][:n]
        self.has_body_force = "External_Force_Density" in f
        self.evaluations = 0
        nl = sim.bonds
        self._in_offsets, self._in_bonds = nl.transpose()
        self._sources = nl.sources()
        self.flow_field = flow_bond_field(sim)

    # -- vectors --------------------------------------------------------------------------------
    def to_rows(self, a: np.ndarray) -> np.ndarray:
        return self.tangent.to_rows(a)

    def to_local(self, v: np.ndarray, out=None) -> np.ndarray:
        return self.tangent.to_local(v, out)

    def norm2(self, v: np.ndarray) -> float:
        if self.comm is not None:
            return math.sqrt(self.comm.allreduce_sum(seq_dot(v, v)))
        return seq_norm2(v)

    def norm_inf(self, v: np.ndarray) -> float:
        return self.sim.comm.allreduce_max(norm_inf(v))

    def dot(self, a: np.ndarray, b: np.ndarray) -> float:
        return self.sim.comm.allreduce_sum(seq_dot(a, b))

    # -- residual -------------------------------------------------------------------------------
    def flow(self) -> np.ndarray:
        """Flux_Density (pressure per time) of every owned point from the per-bond flows the
        materials wrote in the last force evaluation (ghost rows' sums go to their owners)."""
        sim = self.sim
        s = sim.fields
        out = s["Flux_Density"]
        nl = sim.bonds
        hi = sim.num_local if sim.comm.size > 1 else sim.num_owned
        gather_bond_scalar_kernel(0, hi, nl.offsets, nl.neighbors, self._in_offsets, self._in_bonds, self._sources, s["Volume"], s[self.flow_field], out)
        if sim.comm.size > 1:  # also without ghosts of its own (see engine.forces)
            sim.halo.reverse_sum(out)
        return out

    def unknowns_force(self) -> np.ndarray:
        """Evaluate forces and flow at the current Coordinates and Fluid_Pressure_Y: (n, 4)
        [f, flow] (internal force density and flow density, no body force)."""
        n = self.n
        fd = self.sim.evaluate_forces()[:n]
        flow = self.flow()[:n]
        self.evaluations += 1
        F = np.empty((n, 4))
        F[:, :3] = fd
        F[:, 3] = flow
        return F

    def residual_vector(self) -> np.ndarray:
        n = self.n
        F = self.unknowns_force()
        if self.has_body_force:
            F[:, :3] += self.sim.fields["External_Force_Density"][:n]
        F *= self.volume[:, None]
        F[self.fixed_local] = 0.0
        if not np.all(np.isfinite(F)):
            raise InstabilityError("the coupled residual is not finite (NaN returned by the force or fluid flow evaluation)")
        return self.to_rows(F)

    def qs_residual(self) -> tuple[float, np.ndarray]:
        r = self.residual_vector()
        return self.norm2(r) + 20.0 * self.norm_inf(r), r

    def reaction_norm(self) -> float:
        """||R||_2, R = [f, flow] V on the prescribed dofs (last evaluation), 0 elsewhere."""
        n = self.n
        s = self.sim.fields
        F = np.empty((n, 4))
        F[:, :3] = s["Force_Density"][:n]
        F[:, 3] = s["Flux_Density"][:n]
        R = np.where(self.fixed_local, F * self.volume[:, None], 0.0)
        return self.norm2(self.to_rows(R))


class CoupledQuasiStaticRun:
    """One coupled QuasiStatic solver run (see module docstring)."""

    def __init__(self, solver, sim, state: SolverState, services: RunServices) -> None:
        from .load_steps import DAMPED_TANGENT_INTERVAL, PURE_NEWTON_STEPS

        self.pure_newton_steps = PURE_NEWTON_STEPS
        self.damped_interval = DAMPED_TANGENT_INTERVAL
        self.solver = solver
        self.sim = sim
        self.state = state
        self.services = services
        self.p = solver.params
        self.q = solver.params.quasi_static
        self.section = solver.section
        self.check_deck()
        self.problem = CoupledProblem(sim, state)
        n = sim.num_owned
        self.n = n
        f = sim.fields
        self.x = f["Model_Coordinates"]
        self.u = f["Displacement"]
        self.y = f["Coordinates"]
        self.v = f["Velocity"]
        self.pU = f["Fluid_Pressure_U"]
        self.pY = f["Fluid_Pressure_Y"]
        self.pV = f["Fluid_Pressure_V"]
        nl = sim.num_local
        self.du = np.zeros((nl, 3))
        self.dp = np.zeros(nl)
        q = self.q
        method = "Direct" if q.linear_solver == "Direct" else "Belos"
        if q.linear_solver not in ("Direct", "Belos", "Adaptive"):
            log.info("%s: the coupled displacement-pressure system is solved with Peridigm's CG ('Linear Solver: %s' is for displacements only)",
                     self.section, q.linear_solver)
        self.linear = LinearSolver(
            method=method, tol=q.belos_relative_tolerance, maxiter=q.belos_maximum_iterations, belos_method=q.belos_linear_solver, symmetric=False,
        )
        #: "Adaptive" (the default): when Peridigm's CG fails on the unsymmetric coupled matrix,
        #: restarted GMRES from then on (a Peridigm deck whose solves converge never gets there)
        self.fallback = (
            LinearSolver(method="Belos", tol=q.belos_relative_tolerance, belos_method="BlockGMRES", symmetric=False)
            if q.linear_solver == "Adaptive" and q.belos_linear_solver == "BlockCG" else None
        )
        self.switched = False
        self.heuristics = not self.p.disable_heuristics
        self.dt = 1.0
        self.residuals: list[list[float]] = []
        self.attempts: list[dict] = []
        self.step = 0
        self.failure: str | None = None

    def check_deck(self) -> None:
        p, sim = self.p, self.sim
        path = (self.section,)
        if not (p.solve_for_displacement and p.solve_for_pressure):
            raise InputError(
                "a Multiphysics deck solves for displacement and fluid pressure together",
                file=sim.deck.file, path=path, fix="set 'Solve For Displacement' and 'Solve For Pressure' to true in this solver section",
            )
        if p.initialize_predictor:
            raise InputError(
                "'Initialize Predictor From Previous Solver' cannot be combined with Multiphysics (a 3-dof velocity cannot start a 4-dof predictor)",
                file=sim.deck.file, path=path + ("Initialize Predictor From Previous Solver",), fix="remove the key",
            )
        if self.q.adaptive is not None and self.q.adaptive.switch_to_verlet is not None:
            raise InputError(
                "'Switch to Verlet' is not available with Multiphysics (Verlet does not advance the fluid pressure)",
                file=sim.deck.file, path=path + ("QuasiStatic", "Adaptive Load-Stepping", "Switch to Verlet"), fix="remove the sublist",
            )

    # -- state ----------------------------------------------------------------------------------
    def set_trial(self, du: np.ndarray, dp: np.ndarray) -> None:
        """y = (x + u) + du, v = du / dt, p_Y = p_U + dp, p_V = dp / dt."""
        np.add(self.x, self.u, out=self.y)
        self.y += du
        np.divide(du, self.dt, out=self.v)
        np.add(self.pU, dp, out=self.pY)
        np.divide(dp, self.dt, out=self.pV)

    def trial_residual(self, D: np.ndarray) -> tuple[float, np.ndarray]:
        """Residual at the increments D (n_local, 4)."""
        self.set_trial(D[:, :3], D[:, 3])
        return self.problem.qs_residual()

    def increments(self) -> np.ndarray:
        D = np.empty((self.sim.num_local, 4))
        D[:, :3] = self.du
        D[:, 3] = self.dp
        return D

    def pad(self, a: np.ndarray) -> np.ndarray:
        nl = self.sim.num_local
        if a.shape[0] == nl:
            return a
        out = np.zeros((nl, 4))
        out[: a.shape[0]] = a
        return out

    # -- line search ----------------------------------------------------------------------------
    def line_search(self, lhs_rows: np.ndarray, lhs: np.ndarray) -> float:
        """Peridigm's quasiStaticsLineSearch, multiphysics branch (see module docstring)."""
        prob = self.problem
        D0 = self.increments()
        rho0, r0 = prob.qs_residual()
        if not math.isfinite(rho0):
            raise InstabilityError(f"{self.section}: load step {self.step}: the residual is not finite")
        if rho0 == 0.0:
            return 0.0
        return line_search(self.trial_residual, D0, lhs, lhs_rows, rho0, r0, prob.dot, self.section, first_pass_at_epsilon=True)

    # -- one load step --------------------------------------------------------------------------
    def newton(self, step: int, predictor: np.ndarray) -> tuple[float, float, int]:
        prob, q = self.problem, self.q
        self.step = step
        self.failure = None
        T = prob.tangent
        res, r = prob.qs_residual()
        tol = q.absolute_tolerance if q.absolute_tolerance is not None else q.relative_tolerance * prob.reaction_norm()
        it = 1
        damped = False
        history = [res]
        self.residuals.append(history)
        n = self.n
        while res > tol and it <= q.maximum_solver_iterations:
            self.state.nonlinear_iterations += 1
            log.debug("%s: load step %d, iteration %d: residual %.6g (tolerance %.6g)", self.section, step, it, res, tol)
            if it == 1 and step > 1 and self.heuristics:
                lhs = predictor * self.dt
                lhs[prob.fixed_local] = 0.0
                ok = True
            else:
                if it > self.pure_newton_steps and not damped and self.heuristics:
                    damped = True
                if not damped or math.fmod(it - self.pure_newton_steps - 1, self.damped_interval) == 0.0:
                    T.assemble()
                    T.apply_kinematic_bc(prob.fixed_rows)
                    T.scale(-1.0)
                    if damped:
                        T.damp(q.damped_newton_scale, q.damped_newton_shift)
                    self.linear.set_matrix(T)
                    if self.fallback is not None:
                        self.fallback.set_matrix(T)
                result = (self.fallback if self.switched else self.linear).solve(r)
                if not result.converged and self.fallback is not None and not self.switched:
                    log.info("%s: Peridigm's conjugate gradients failed on the coupled system (%s); GMRES from here on "
                             "(set 'Linear Solver: Belos' to keep Peridigm's)", self.section, result.message)
                    self.switched = True
                    result = self.fallback.solve(r)
                if not result.converged and self.heuristics:
                    log.info("%s: linear solve failed (%s); switching to damped Newton", self.section, result.message)
                    if not damped:
                        T.damp(q.damped_newton_scale, q.damped_newton_shift)
                        self.linear.set_matrix(T)
                        if self.fallback is not None:
                            self.fallback.set_matrix(T)
                    damped = True
                    result = (self.fallback if self.switched else self.linear).solve(r)
                ok = result.converged
                if ok:
                    lhs = prob.to_local(result.x)
                else:
                    self.failure = f"the linear solve of iteration {it} failed ({result.message})"
            if not ok:
                break
            lhs[prob.fixed_local] = 0.0
            lhs_rows = prob.to_rows(lhs)
            alpha = self.line_search(lhs_rows, self.pad(lhs)) if self.heuristics else 1.0
            self.du[:n] += alpha * lhs[:, :3]
            self.dp[:n] += alpha * lhs[:, 3]
            res, r = self.trial_residual(self.increments())
            history.append(res)
            it += 1
        return res, tol, it

    # -- the solver -----------------------------------------------------------------------------
    def run(self) -> None:
        from .load_steps import (
            LoadStepError,
            halve_load_step,
            multiply_output_frequency,
            reduce_remaining_load_steps,
        )

        sim, p, q = self.sim, self.p, self.q
        wall0 = _time.perf_counter()
        times = load_times(p, q, path=(self.section, "QuasiStatic"), file=sim.deck.file)
        n = self.n
        predictor = np.zeros((n, 4))
        self.v[:] = 0.0
        self.pV[:] = 0.0
        t_cur = t_prev = times[0]
        self.state.time_prev = self.state.time = t_cur
        saved = self.state.delta_u, self.state.delta_p
        self.state.delta_u, self.state.delta_p = self.du, self.dp
        try:
            sim.apply_kinematic(t_cur, t_prev, self.state)
            sim.apply_body_forces(t_cur)
            self.services.write_output(t_cur)
            log.info("%s: QuasiStatic with fluid pressure, %d load steps from t = %.6g to %.6g, %d unknowns, tangent %d nonzeros",
                     self.section, len(times) - 1, times[0], times[-1], 4 * sim.num_global, sim.comm.allreduce_sum(int(self.problem.tangent.nnz)))
            adaptive = q.adaptive
            t_final = times[-1]
            failed_this_step = total_failures = 0
            cut_in_step = retry = failed = False
            completed = 0
            what = ""
            step = 1
            while step < len(times):
                if adaptive is None or not retry:
                    t_prev = t_cur
                retry = False
                t_cur = times[step]
                self.dt = t_cur - t_prev
                sim.set_time_step(self.dt)
                self.state.time_prev, self.state.time = t_prev, t_cur
                self.du[:] = 0.0
                self.dp[:] = 0.0
                sim.apply_kinematic(t_cur, t_prev, self.state)
                sim.apply_body_forces(t_cur)
                self.set_trial(self.du, self.dp)
                res, tol, it = self.newton(step, predictor)
                ok = self.failure is None
                outcome = "converged" if ok and res <= tol else "accepted" if ok and res < 100.0 * tol else "failed"
                if outcome == "accepted":
                    log.warning("%s: load step %d (t = %.6g): accepting residual %.4g, above the tolerance %.4g", self.section, step, t_cur, res, tol)
                elif outcome == "failed":
                    what = (f"{self.section}: load step {step} (t = {t_cur:.6g}, step size {self.dt:.4g}) did not converge: residual {res:.4g} "
                            f"after {it - 1} iteration(s) (tolerance {tol:.4g})" + (f"; {self.failure}" if self.failure else ""))
                    if adaptive is not None:
                        failed_this_step += 1
                        total_failures += 1
                        if total_failures <= adaptive.max_total_reductions and failed_this_step <= adaptive.max_reductions_in_step:
                            outcome, retry, cut_in_step = "cut back", True, True
                            log.warning("%s: halving it", what)
                    failed = not retry
                self.attempts.append({"step": step, "time": t_cur, "dt": self.dt, "iterations": it - 1, "residual": res, "tolerance": tol, "outcome": outcome})
                if failed:
                    break
                if retry:
                    halve_load_step(times, step, t_prev, self.dt)
                    if adaptive.adaptive_output_frequency:
                        multiply_output_frequency(self.services.files.writers, 2.0)
                    continue
                if adaptive is not None and adaptive.reduce_all_remaining and cut_in_step:
                    reduce_remaining_load_steps(times, step, t_cur, self.dt, t_final)
                cut_in_step = False
                failed_this_step = 0
                self.u[:n] += self.du[:n]
                self.pU[:n] += self.dp[:n]
                predictor[:, :3] = self.v[:n]
                predictor[:, 3] = self.pV[:n]
                self.services.write_output(t_cur)
                sim.advance()
                completed += 1
                step += 1
        finally:
            self.state.delta_u, self.state.delta_p = saved
        lin = self.linear
        solver_stats(
            sim, self.section, "QuasiStatic", completed, _time.perf_counter() - wall0, self.problem,
            linear_solver=lin._chosen or lin.method, linear_solve_time=lin.solve_time, linear_setup_time=lin.setup_time,
            linear_iterations=lin.iterations, linear_solves=lin.solves, converged=not failed, residuals=self.residuals,
            load_steps=self.attempts, load_step_reductions=sum(a["outcome"] == "cut back" for a in self.attempts), unknowns_per_point=4,
        )
        if failed:
            raise LoadStepError(f"{what}; the run stops at the last converged load step (t = {t_prev:.6g})")
