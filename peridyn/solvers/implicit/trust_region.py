"""NOX's ``Inexact Trust Region Based`` nonlinear solver (``NOX::Solver::InexactTrustRegionBased``),
step for step as Trilinos NOX does it, on an abstract problem F(s) = 0.

Written from NOX's source (``NOX_Solver_InexactTrustRegionBased.C``,
``NOX_Direction_Utils_InexactNewton.C``, ``NOX_Direction_Newton.C``,
``NOX_Direction_SteepestDescent.C``, ``NOX_MeritFunction_SumOfSquares.C``). The merit function is
f(s) = 0.5 ||F(s)||^2 and its quadratic model along d is m(d) = f + d.(J^T F) + 0.5 ||J d||^2.

One :meth:`TrustRegionSolver.step` is one NOX ``solver->step()``: the first one evaluates F at
the initial guess and checks the status tests, and every call that finds the status unconverged
performs one outer iteration:

``Inexact Trust Region`` (the default ``Inner Iteration Method``):

1. the forcing term eta (``Constant``: the linear solver ``Tolerance``; ``Type 1``/``Type 2``:
   Eisenstat-Walker, bounded by the ``Forcing Term ...`` options);
2. the Jacobian J at the current point s; the Cauchy point (steepest descent on f scaled to
   the minimum of the quadratic model, or the chosen ``Scaling Type``) c, its linear residual
   r_c = F + J c and eta_c = ||r_c|| / ||F||; on the first iteration the radius is the
   ``Maximum Trust Region Radius``;
3. inner iterations until a step is accepted (ratio >= ``Minimum Improvement Ratio``) or the
   radius has shrunk to ``Minimum Trust Region Radius`` with no acceptable step:

   * ||c|| >= radius: the Cauchy step scaled to the radius;
   * else eta_c <= eta: the Cauchy step;
   * else (the Newton direction n solved once, J n = -F to the relative tolerance eta): the
     Newton step if ||n|| <= radius (and no dogleg segment minimization), else the dogleg
     point c + tau (n - c) on the radius;

   ratio = (f_old - f_new) / |f_old - m(d)| (-1 when f does not decrease, or when the model
   decrease is below 1e-12 and f_new / f_old >= 0.5), or Walker's (||F_old|| - ||F_new||) /
   (||F_old|| - ||F_old + J d||) with ``Use Ared/Pred Ratio Calculation``. The radius contracts
   (x ``Contraction Factor``, from ||n|| after a Newton step, never below the minimum) when
   ratio < ``Contraction Trigger Ratio`` and expands (x ``Expansion Factor``, at most the
   maximum) when ratio > ``Expansion Trigger Ratio``;
4. a failed inner iteration takes the recovery step s_old + ``Recovery Step`` c (NOX uses the
   Cauchy direction in both of its branches) and resets the radius to ||n||.

``Standard Trust Region``: the Newton direction (NOX's Newton direction: forcing term, Jacobian,
linear solve, "Rescue Bad Newton Solve") and the Cauchy direction at the current point; the
first radius is ||n|| (2 x the minimum when smaller); inner iterations (while ratio < the
minimum ratio and radius > the minimum radius) take the Newton step inside the region, the
scaled Cauchy step when ||c|| >= radius, else the dogleg point on the radius; expansion also
needs the step length to equal the radius; a failed loop takes s_old + ``Recovery Step`` n.

Status tests are the caller's (Peridigm: finite ||F||, ||F||_2 < tolerance, iterations >= max).
Vectors are plain 1-D arrays; dot products and norms go through the problem (MPI reductions).
"""
from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numba import njit

log = logging.getLogger("peridyn.solver")

NEWTON, CAUCHY, DOGLEG = "Newton", "Cauchy", "Dogleg"


#: inner iterations of one NOX step before it counts as failed (the radius contracts by at most
#: 'Contraction Factor' < 1 per try, so a sound problem meets 'Minimum Trust Region Radius' long
#: before; a NaN radius, from a NaN Newton step, never would)
MAX_INNER_ITERATIONS = 10_000


class TrustRegionError(RuntimeError):
    """NOX throws "NOX Error" (an invalid dogleg computation, a bad parameter)."""


class TrustRegionProblem(Protocol):
    """What the solver needs from the problem (all vectors of one length, row order)."""

    def F(self, s: np.ndarray) -> np.ndarray:
        """The residual at s (also sets the model state to s)."""

    def jacobian(self, s: np.ndarray) -> None:
        """Compute (assemble) the Jacobian at s; the products below use the last one."""

    def apply_jacobian(self, d: np.ndarray) -> np.ndarray:
        """J d."""

    def apply_jacobian_transpose(self, d: np.ndarray) -> np.ndarray:
        """J^T d."""

    def solve(self, rhs: np.ndarray, tol: float, x0: np.ndarray | None) -> tuple[np.ndarray, bool]:
        """(x, converged): J x = rhs to the relative tolerance ``tol`` from x0 (None: zero)."""

    def dot(self, a: np.ndarray, b: np.ndarray) -> float: ...

    def norm(self, a: np.ndarray) -> float: ...


@dataclass(frozen=True)
class ForcingTermOptions:
    """``Direction > Newton`` forcing term options (NOX defaults)."""

    method: str = "Constant"  # Constant, Type 1, Type 2
    tolerance: float = 1.0e-10  # Linear Solver > Tolerance (NOX's Newton direction sets 1e-10)
    initial: float = 0.01
    minimum: float = 1.0e-4
    maximum: float = 0.9
    alpha: float = 1.5
    gamma: float = 0.9
    rescue_bad_newton_solve: bool = True


@dataclass(frozen=True)
class TrustRegionOptions:
    """The ``Trust Region`` and ``Cauchy Direction`` options (NOX defaults)."""

    inner_iteration_method: str = "Inexact Trust Region"
    minimum_radius: float = 1.0e-6
    maximum_radius: float = 1.0e10
    minimum_improvement_ratio: float = 1.0e-4
    contraction_trigger_ratio: float = 0.1
    expansion_trigger_ratio: float = 0.75
    contraction_factor: float = 0.25
    expansion_factor: float = 4.0
    recovery_step: float = 1.0
    use_cauchy_in_newton_direction: bool = False
    use_ared_pred_ratio: bool = False
    use_dogleg_segment_minimization: bool = False
    cauchy_scaling: str = "Quadratic Model Min"  # 2-Norm, F 2-Norm, Quadratic Model Min, None

    def check(self) -> None:
        """NOX's checks in ``init`` (a violation is "Invalid <name>")."""
        bad = None
        if not self.minimum_radius > 0.0:
            bad = "Minimum Trust Region Radius"
        elif not self.maximum_radius > self.minimum_radius:
            bad = "Maximum Trust Region Radius"
        elif not self.minimum_improvement_ratio > 0.0:
            bad = "Minimum Improvement Ratio"
        elif self.contraction_trigger_ratio < self.minimum_improvement_ratio:
            bad = "Contraction Trigger Ratio"
        elif not self.expansion_trigger_ratio > self.contraction_trigger_ratio:
            bad = "Expansion Trigger Ratio"
        elif not 0.0 < self.contraction_factor < 1.0:
            bad = "Contraction Factor"
        elif not self.expansion_factor > 1.0:
            bad = "Expansion Factor"
        elif self.recovery_step < 0.0:
            bad = "Recovery Step"
        if bad is not None:
            raise ValueError(f"invalid 'Trust Region > {bad}' (NOX requires: minimum radius > 0, maximum radius > minimum, "
                             "improvement ratio > 0, contraction trigger >= improvement ratio, expansion trigger > contraction "
                             "trigger, 0 < contraction factor < 1, expansion factor > 1, recovery step >= 0)")


@dataclass
class TrustRegionCounters:
    """NOX's ``Trust Region > Output`` statistics."""

    cauchy_steps: int = 0
    newton_steps: int = 0
    dogleg_steps: int = 0
    inner_iterations: int = 0
    recovery_steps: int = 0


class TrustRegionSolver:
    """One NOX InexactTrustRegionBased solver on ``problem`` from the initial guess ``s0``.
    ``status(F, niter) -> "converged" | "failed" | "unconverged"`` is the status test."""

    def __init__(self, problem: TrustRegionProblem, s0: np.ndarray, options: TrustRegionOptions, forcing: ForcingTermOptions,
                 status: Callable[[np.ndarray, int], str]) -> None:
        options.check()
        self.p = problem
        self.o = options
        self.ft = forcing
        self.status_test = status
        self.s = np.array(s0, dtype=float)
        self.F = None  # F at s (computed by the first step)
        self.niter = 0
        self.status = "unconverged"
        self.radius = 0.0
        self.newton = np.zeros_like(self.s)  # NOX keeps the last Newton direction between iterations
        self.eta = -1.0  # the forcing term of the last iteration (adjusted for Cauchy/dogleg steps)
        self.tolerance = forcing.tolerance  # the linear solver Tolerance NOX keeps in the parameter list
        self.s_old: np.ndarray | None = None
        self.F_old: np.ndarray | None = None
        self.counters = TrustRegionCounters()
        self.linear_failures = 0

    # -- small helpers -----------------------------------------------------------------------
    def _merit(self, F: np.ndarray) -> float:
        n = self.p.norm(F)
        return 0.5 * n * n

    def _quadratic_model(self, d: np.ndarray, F_old: np.ndarray, f_old: float) -> tuple[float, np.ndarray]:
        """(m(d), J d): SumOfSquares::computeQuadraticModel at the old point."""
        p = self.p
        m = f_old
        m += p.dot(d, p.apply_jacobian_transpose(F_old))
        Jd = p.apply_jacobian(d)
        m += 0.5 * p.dot(Jd, Jd)
        return m, Jd

    def _cauchy(self, F: np.ndarray) -> np.ndarray:
        """NOX::Direction::SteepestDescent at the point whose Jacobian was computed last."""
        p = self.p
        g = p.apply_jacobian_transpose(F)
        scaling = self.o.cauchy_scaling
        if scaling == "Quadratic Model Min":
            Jg = p.apply_jacobian(g)
            return g * (-1.0 * p.dot(g, g) / p.dot(Jg, Jg))
        if scaling == "2-Norm":
            return g * (-1.0 / p.norm(g))
        if scaling == "F 2-Norm":
            return g * (-1.0 / p.norm(F))
        return g * -1.0

    def _forcing_term(self, eta_km1: float) -> float:
        """eta_k (NOX's InexactNewton utilities / Newton direction): at the start of an outer
        iteration, with s, F the current point and s_old, F_old the previous one, whose
        Jacobian is still the last one computed."""
        ft = self.ft
        if ft.method == "Constant":
            return ft.tolerance
        if self.niter == 0:
            eta = ft.initial
        else:
            p = self.p
            normf = p.norm(self.F)
            normoldf = p.norm(self.F_old)
            if ft.method == "Type 1":
                pred = p.apply_jacobian(self.s - self.s_old)
                pred = pred + self.F_old
                eta = abs(normf - p.norm(pred)) / normoldf
                golden = (1.0 + math.sqrt(5.0)) / 2.0
                safe = eta_km1 ** golden
                if safe > 0.1:
                    eta = max(eta, safe)
            else:
                eta = ft.gamma * (normf / normoldf) ** ft.alpha
                safe = ft.gamma * eta_km1 ** ft.alpha
                if safe > 0.1:
                    eta = max(eta, safe)
            eta = min(ft.maximum, max(eta, ft.minimum))
        return eta

    def _solve_newton(self, F: np.ndarray, tol: float, x0: np.ndarray | None) -> tuple[np.ndarray, bool]:
        """-x with J x = F (NOX's applyJacobianInverse, then scale -1)."""
        x, ok = self.p.solve(F, tol, x0)
        if not ok:
            self.linear_failures += 1
        return -x, ok

    # -- NOX solver->step() ------------------------------------------------------------------
    def step(self) -> str:
        if self.niter == 0 and self.F is None:
            self.F = self.p.F(self.s)
            self.status = self.status_test(self.F, self.niter)
        if self.status != "unconverged":
            return self.status
        if self.o.inner_iteration_method == "Standard Trust Region":
            self._iterate_standard()
        else:
            self._iterate_inexact()
        self.status = self.status_test(self.F, self.niter)
        return self.status

    # -- Inexact Trust Region ----------------------------------------------------------------
    def _iterate_inexact(self) -> None:
        p, o = self.p, self.o
        eta_last = self.eta
        eta = self._forcing_term(eta_last if eta_last >= 0.0 else self.tolerance)
        self.tolerance = eta
        s_old, F_old = self.s, self.F
        self.s_old, self.F_old = s_old, F_old
        p.jacobian(s_old)
        cauchy = self._cauchy(F_old)
        f_old = self._merit(F_old)
        r_cauchy = p.apply_jacobian(cauchy) + F_old
        norm_F = p.norm(F_old)
        eta_cauchy = p.norm(r_cauchy) / norm_F
        ratio = -1.0
        if self.niter == 0:
            self.radius = o.maximum_radius
        norm_c = p.norm(cauchy)
        tau = 0.0
        computed_newton = False
        step_type = CAUCHY
        self.niter += 1
        inner = "unconverged"
        s_new = F_new = None
        tries = 0
        while inner == "unconverged":
            self.counters.inner_iterations += 1
            tries += 1
            if norm_c >= self.radius:
                step_type, step, d = CAUCHY, self.radius / norm_c, cauchy
            elif eta_cauchy <= eta:
                step_type, step, d = CAUCHY, 1.0, cauchy
            else:
                if not computed_newton:
                    x0 = cauchy.copy() if o.use_cauchy_in_newton_direction else None
                    self.newton, _ = self._solve_newton(F_old, eta, x0)
                    computed_newton = True
                newton = self.newton
                if p.norm(newton) <= self.radius and not o.use_dogleg_segment_minimization:
                    step_type, step, d = NEWTON, 1.0, newton
                else:
                    z = newton - cauchy
                    s_dot_z = p.dot(cauchy, z)
                    norm_z = p.norm(z)
                    r2 = self.radius * self.radius - norm_c * norm_c
                    root = math.sqrt(s_dot_z * s_dot_z + norm_z * norm_z * r2)
                    if s_dot_z <= 0.0:
                        tau = (-1.0 * s_dot_z + root) / (norm_z * norm_z)
                    else:
                        tau = r2 / (s_dot_z + root)
                    if o.use_dogleg_segment_minimization:
                        r_newton = p.apply_jacobian(newton) + F_old
                        diff = r_cauchy - r_newton
                        nd = p.norm(diff)
                        tau = min(p.dot(r_cauchy, diff) / (nd * nd), tau)
                    step_type, step, d = DOGLEG, 1.0, cauchy + tau * z
            s_new = s_old + step * d
            F_new = p.F(s_new)
            f_new = self._merit(F_new)
            if not f_new < f_old:  # NOX: f_new >= f_old; also a non-finite F (NOX would loop for ever)
                ratio = -1.0
            elif o.use_ared_pred_ratio:
                lin = p.apply_jacobian(d) + F_old
                ratio = (norm_F - p.norm(F_new)) / (norm_F - p.norm(lin))
            else:
                m, _ = self._quadratic_model(d, F_old, f_old)
                denominator = abs(f_old - m)
                ratio = (f_old - f_new) / denominator
                if denominator < 1.0e-12 and f_new / f_old >= 0.5:
                    ratio = -1.0
            log.debug("trust region: radius %.3e ratio %.3g f %.6e old %.6e %s", self.radius, ratio, math.sqrt(2 * f_new), math.sqrt(2 * f_old), step_type)
            if ratio >= o.minimum_improvement_ratio:
                inner = "converged"
            elif self.radius <= o.minimum_radius or tries >= MAX_INNER_ITERATIONS:
                inner = "failed"
            if ratio < o.contraction_trigger_ratio:
                if step_type == NEWTON:
                    self.radius = p.norm(self.newton)
                self.radius = max(o.contraction_factor * self.radius, o.minimum_radius)
            elif ratio > o.expansion_trigger_ratio:
                self.radius = min(o.expansion_factor * self.radius, o.maximum_radius)
        self._count(step_type)
        if step_type == CAUCHY:
            eta = 1.0 - (p.norm(d) / norm_c) * (1.0 - eta_cauchy)
        elif step_type == DOGLEG:
            eta = eta_cauchy - tau * (eta_cauchy - eta)
        self.eta = eta
        if inner == "failed":
            log.debug("trust region: inner iteration failed; recovery step %g along the Cauchy direction", o.recovery_step)
            self.counters.recovery_steps += 1
            s_new = s_old + o.recovery_step * cauchy
            F_new = p.F(s_new)
            self.radius = p.norm(self.newton)
        self.s, self.F = s_new, F_new

    # -- Standard Trust Region ---------------------------------------------------------------
    def _iterate_standard(self) -> None:
        p, o = self.p, self.o
        ft = self.ft
        s_old, F_old = self.s, self.F
        # NOX::Direction::Newton::compute: forcing term (eta_{k-1} from the parameter list), J, solve
        eta = self._forcing_term(self.tolerance) if ft.method != "Constant" else ft.tolerance
        self.tolerance = eta
        p.jacobian(s_old)
        newton, ok = self._solve_newton(F_old, eta, None)
        if not ok and not ft.rescue_bad_newton_solve:
            raise TrustRegionError("unable to solve the Newton system ('Rescue Bad Newton Solve' is false)")
        self.newton = newton
        cauchy = self._cauchy(F_old)
        if self.niter == 0:
            self.radius = p.norm(newton)
            if self.radius < o.minimum_radius:
                self.radius = 2 * o.minimum_radius
        self.niter += 1
        self.s_old, self.F_old = s_old, F_old
        f_old = self._merit(F_old)
        norm_F = p.norm(F_old)
        ratio = -1.0
        step_type = NEWTON
        s_new, F_new = s_old, F_old
        tries = 0
        while ratio < o.minimum_improvement_ratio and self.radius > o.minimum_radius and tries < MAX_INNER_ITERATIONS:
            self.counters.inner_iterations += 1
            tries += 1
            norm_n = p.norm(newton)
            norm_c = p.norm(cauchy)
            if norm_n <= self.radius:
                step_type, step, d = NEWTON, 1.0, newton
            elif norm_c >= self.radius:
                step_type, step, d = CAUCHY, self.radius / norm_c, cauchy
            else:
                a = newton - cauchy
                cta = p.dot(cauchy, a)
                ctc = p.dot(cauchy, cauchy)
                ata = p.dot(a, a)
                tmp = (cta * cta) - ((ctc - (self.radius * self.radius)) * ata)
                if tmp < 0:
                    raise TrustRegionError("invalid dogleg computation")
                gamma = (math.sqrt(tmp) - cta) / ata
                if gamma < 0 or gamma > 1:
                    raise TrustRegionError("invalid trust region step")
                step_type, step, d = DOGLEG, 1.0, (1.0 - gamma) * cauchy + gamma * newton
            dx = step * p.norm(d)
            s_new = s_old + step * d
            F_new = p.F(s_new)
            f_new = self._merit(F_new)
            if not math.isfinite(f_new):  # NOX would loop for ever on a NaN ratio
                ratio = -1.0
            elif o.use_ared_pred_ratio:
                lin = p.apply_jacobian(d) + F_old
                ratio = (norm_F - p.norm(F_new)) / (norm_F - p.norm(lin))
            elif f_new >= f_old:
                ratio = -1.0
            else:
                m, _ = self._quadratic_model(d, F_old, f_old)
                denominator = abs(f_old - m)
                ratio = (f_old - f_new) / denominator
                if denominator < 1.0e-12 and f_new / f_old >= 0.5:
                    ratio = -1.0
            log.debug("trust region: radius %.3e ratio %.3g f %.6e old %.6e %s", self.radius, ratio, math.sqrt(2 * f_new), math.sqrt(2 * f_old), step_type)
            if ratio < o.contraction_trigger_ratio:
                if step_type == NEWTON:
                    self.radius = norm_n
                self.radius = max(o.contraction_factor * self.radius, o.minimum_radius)
            elif ratio > o.expansion_trigger_ratio and dx == self.radius:
                self.radius = min(o.expansion_factor * self.radius, o.maximum_radius)
        self._count(step_type)
        if self.radius <= o.minimum_radius and ratio < o.minimum_improvement_ratio:
            log.debug("trust region: recovery step %g along the Newton direction", o.recovery_step)
            self.counters.recovery_steps += 1
            s_new = s_old + o.recovery_step * newton
            F_new = p.F(s_new)
            self.radius = p.norm(newton)
        self.s, self.F = s_new, F_new

    def _count(self, step_type: str) -> None:
        c = self.counters
        if step_type == NEWTON:
            c.newton_steps += 1
        elif step_type == CAUCHY:
            c.cauchy_steps += 1
        else:
            c.dogleg_steps += 1


# ------------------------------------------------------------------------------------------------
# J^T x for the 3x3-block tangent (the gradient J^T F of the merit function)
# ------------------------------------------------------------------------------------------------
@njit(cache=True)
def bsr_rmatvec_kernel(indptr, indices, data, x, out):
    """out = A^T x for a square 3x3-block CSR matrix A (nrows block rows; x, out (3 nrows,));
    serial: each stored block scatters into its column's rows."""
    nrows = indptr.shape[0] - 1
    for k in range(out.shape[0]):
        out[k] = 0.0
    for i in range(nrows):
        x0 = x[3 * i]
        x1 = x[3 * i + 1]
        x2 = x[3 * i + 2]
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            for c in range(3):
                out[3 * j + c] += data[k, 0, c] * x0 + data[k, 1, c] * x1 + data[k, 2, c] * x2


class TransposeProduct:
    """y = K^T x for a :class:`~peridyn.solvers.linalg.tangent.TangentMatrix` K (owned rows in row
    order). Under MPI, K = sum over ranks of each rank's subdomain part K_r (owned and ghost
    rows), so K^T x gathers x's ghost entries, multiplies by K_r^T and sends the ghost rows
    back to their owners, as the forward product does (a collective call)."""

    def __init__(self, tangent) -> None:
        self.T = tangent
        T = tangent
        if T.parallel:
            self._buf = np.zeros((T.nrows, 3))
            self._xe = np.zeros(3 * T.nrows)
            self._ye = np.zeros(3 * T.nrows)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        T = self.T
        out = np.empty(3 * T.n)
        if not T.parallel:
            bsr_rmatvec_kernel(T.indptr, T.indices, T.data, x, out)
            return out
        n = T.n
        buf, xe, ye = self._buf, self._xe, self._ye
        halo = T.sim.halo
        buf[T.owned_local] = x.reshape(n, 3)
        halo.exchange(buf)
        xe[: 3 * n] = x
        xe[3 * n :] = buf[n:].reshape(-1)
        bsr_rmatvec_kernel(T.indptr, T.indices, T.data, xe, ye)
        buf[T.local_of_row] = ye.reshape(T.nrows, 3)
        halo.reverse_sum(buf)
        out[:] = buf[T.owned_local].reshape(-1)
        return out
