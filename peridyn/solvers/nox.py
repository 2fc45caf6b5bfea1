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
  :mod:`peridyn.solvers.tangent` (prescribed rows and columns replaced by the mean absolute
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

Line searches (``Line Search > Method``): ``Full Step``; ``Polynomial`` (NOX's: step 1, then
quadratic/cubic backtracking on 0.5 ||F||^2 with the Armijo-Goldstein condition, slope F.(J d));
``Backtrack`` (halving); ``NonlinearCG`` (one secant step -(F.d)/(d.J d)).
"""
from __future__ import annotations

import difflib
import logging
import math
import time as _time
from typing import Any, Literal

import numpy as np
from pydantic import ConfigDict, Field, model_validator

from ..core.interfaces import Solver
from ..core.params import ModelParams
from ..core.errors import PeridynError, ExitCode
from .common import SolverSection
from .linear import aztec_gmres, gdot, gnorm
from .newton import ImplicitProblem, load_times, planned_load_steps, solver_stats, threads_for
from .quasistatic import LoadStepKeys

log = logging.getLogger("peridyn.solver")


class NOXConvergenceError(PeridynError):
    """A NOX load step did not converge (Peridigm aborts the run)."""

    exit_code = ExitCode.UNSTABLE


# ------------------------------------------------------------------------------------------------
# parameters: the NOX option trees are accepted; the keys that change what runs are validated
# ------------------------------------------------------------------------------------------------
#: bounds on work multipliers, far above any useful value: a larger count is a typo that would run
#: for ever (iterations, sweeps) or allocate without bound (Krylov vectors of every unknown)
MAX_ITERATIONS = 1_000_000
MAX_SWEEPS = 1_000
MAX_KRYLOV_SPACE = 10_000

#: NOX, AztecOO and Ifpack options Peridigm decks carry that peridyn accepts without using them
#: (a key close to one of these, or to a key peridyn uses, is taken for a typo)
NOX_OTHER_KEYS = frozenset({
    "Maximum Step", "Recovery Step Type", "Sufficient Decrease", "Interval Width", "Curvature Condition",
    "Optimize Slope Calculation", "Allowed Relative Increase", "Use Counters", "Throw Error on Prec Failure",
    "RCM Reordering", "Graph Fill", "Overlap", "Ill-Conditioning Threshold", "Fill Factor", "Drop Tolerance",
    "Preconditioner Operator", "Output Frequency", "Output Solver Details", "Output Processor",
    "Output Precision", "Output Information", "Output Stream", "Error Stream", "Compute Scaling Manually",
    "Preconditioner Reuse Policy", "Max Age Of Prec", "Restart Frequency", "Reduction Factor",
    "Max Backtrack Iterations", "Minimum Step", "Default Step", "Recovery Step", "Max Iters",
})


class _OptionTree(ModelParams):
    """A NOX/AztecOO option list: the keys below are validated, other NOX keys are accepted
    with a warning that peridyn does not use them; a key that looks like a mistyped known key
    (``Max Iteration`` for ``Max Iterations``) is an error."""

    model_config = ConfigDict(frozen=True, extra="allow", populate_by_name=True, allow_inf_nan=False)

    @model_validator(mode="after")
    def _unknown_keys(self):
        extra = [k for k in (self.model_extra or {}) if k not in NOX_OTHER_KEYS]
        if not extra:
            return self
        known = self.deck_names() + sorted(NOX_OTHER_KEYS)
        for key in extra:
            close = difflib.get_close_matches(str(key), known, n=1, cutoff=0.85)
            if close:
                raise ValueError(f"unknown key {key!r}: did you mean {close[0]!r}?")
        log.warning("%s: %s not used by peridyn (accepted as NOX options)", type(self).__name__.removeprefix("NOX").removesuffix("Params"),
                    ", ".join(repr(k) for k in extra))
        return self


class NOXLinearSolverParams(_OptionTree):
    jacobian_operator: Literal["Matrix-Free", "Have Jacobian", "Finite Difference", "Use Jacobian"] | None = Field(
        None, alias="Jacobian Operator", description="Matrix-Free: Jacobian-free Newton-Krylov (with Peridigm Preconditioner Block 3x3 or None)"
    )
    preconditioner: Literal["None", "AztecOO", "User Defined", "Ifpack", "New Ifpack", "ML"] = Field("None", alias="Preconditioner")
    aztec_solver: Literal["GMRES"] = Field("GMRES", alias="Aztec Solver", description="Krylov method (GMRES only)")
    max_iterations: int = Field(400, alias="Max Iterations", ge=1, le=MAX_ITERATIONS)
    tolerance: float = Field(1.0e-10, alias="Tolerance", gt=0, lt=1)
    kspace: int = Field(300, alias="Size of Krylov Subspace", ge=1, le=MAX_KRYLOV_SPACE)
    orthogonalization: Literal["Classical", "Modified"] = Field("Classical", alias="Orthogonalization")
    convergence_test: Literal["r0"] = Field("r0", alias="Convergence Test")
    zero_initial_guess: bool = Field(False, alias="Zero Initial Guess")
    aztec_preconditioner: Literal["ilu", "ilut", "Jacobi", "Symmetric Gauss-Seidel", "Polynomial", "Least-squares Polynomial"] = Field(
        "ilu", alias="Aztec Preconditioner"
    )
    steps: int = Field(3, alias="Steps", ge=1, le=MAX_SWEEPS, description="Jacobi sweeps of the Aztec preconditioner")
    preconditioner_iterations: int = Field(1, alias="AztecOO Preconditioner Iterations", ge=1, le=MAX_SWEEPS)


class NOXNewtonParams(_OptionTree):
    forcing_term_method: Literal["Constant", "Type 1", "Type 2"] = Field("Constant", alias="Forcing Term Method")
    forcing_term_initial_tolerance: float = Field(1.0e-4, alias="Forcing Term Initial Tolerance", gt=0, lt=1)
    forcing_term_minimum_tolerance: float = Field(1.0e-6, alias="Forcing Term Minimum Tolerance", gt=0, lt=1)
    forcing_term_maximum_tolerance: float = Field(0.01, alias="Forcing Term Maximum Tolerance", gt=0, lt=1)
    forcing_term_alpha: float = Field(1.5, alias="Forcing Term Alpha", gt=0)
    forcing_term_gamma: float = Field(0.9, alias="Forcing Term Gamma", gt=0)
    rescue_bad_newton_solve: bool = Field(True, alias="Rescue Bad Newton Solve")
    linear_solver: NOXLinearSolverParams = Field(default_factory=NOXLinearSolverParams, alias="Linear Solver")


class NOXNonlinearCGParams(_OptionTree):
    restart_frequency: int = Field(10, alias="Restart Frequency", ge=1)
    precondition: Literal["On", "Off"] = Field("Off", alias="Precondition")
    orthogonalize: Literal["Fletcher-Reeves", "Polak-Ribiere"] = Field("Fletcher-Reeves", alias="Orthogonalize")
    update_jacobian: int = Field(1, alias="Update Jacobian", ge=1, description="rebuild the tangent every this many tangent requests")
    linear_solver: NOXLinearSolverParams = Field(default_factory=NOXLinearSolverParams, alias="Linear Solver")


class NOXDirectionParams(_OptionTree):
    method: Literal["Newton", "NonlinearCG"] = Field(alias="Method", description="Newton or NonlinearCG (what Peridigm supports)")
    newton: NOXNewtonParams = Field(default_factory=NOXNewtonParams, alias="Newton")
    nonlinear_cg: NOXNonlinearCGParams = Field(default_factory=NOXNonlinearCGParams, alias="Nonlinear CG")


class NOXPolynomialParams(_OptionTree):
    default_step: float = Field(1.0, alias="Default Step", gt=0)
    max_iters: int = Field(100, alias="Max Iters", ge=1, le=MAX_ITERATIONS)
    minimum_step: float = Field(1.0e-12, alias="Minimum Step", gt=0)
    recovery_step: float | None = Field(None, alias="Recovery Step", gt=0)
    interpolation_type: Literal["Cubic", "Quadratic", "Quadratic3"] = Field("Cubic", alias="Interpolation Type")
    sufficient_decrease_condition: Literal["Armijo-Goldstein", "Ared/Pred", "None"] = Field("Armijo-Goldstein", alias="Sufficient Decrease Condition")
    alpha_factor: float = Field(1.0e-4, alias="Alpha Factor", gt=0, lt=1)
    min_bounds_factor: float = Field(0.1, alias="Min Bounds Factor", gt=0, lt=1)
    max_bounds_factor: float = Field(0.5, alias="Max Bounds Factor", gt=0, le=1)
    force_interpolation: bool = Field(False, alias="Force Interpolation")


class NOXLineSearchParams(_OptionTree):
    method: Literal["Full Step", "Backtrack", "Polynomial", "NonlinearCG", "More'-Thuente"] = Field("Full Step", alias="Method")
    polynomial: NOXPolynomialParams = Field(default_factory=NOXPolynomialParams, alias="Polynomial")


class NOXQuasiStaticParams(LoadStepKeys):
    nonlinear_solver: Literal["Line Search Based"] = Field("Line Search Based", alias="Nonlinear Solver", description="NOX solver (Line Search Based)")
    max_solver_iterations: int = Field(50, alias="Max Solver Iterations", ge=1, le=MAX_ITERATIONS, description="NOX steps per load step before the run fails")
    max_age_of_prec: int = Field(200, alias="Max Age Of Prec", ge=1, description="matrix-free mode: uses of the block preconditioner before it is rebuilt")
    preconditioner_reuse_policy: Literal["Reuse", "Rebuild", "Recompute"] | None = Field(None, alias="Preconditioner Reuse Policy")
    verbose: bool = Field(False, alias="Verbose", description="accepted; use --verbose")
    direction: NOXDirectionParams = Field(alias="Direction", description="NOX direction (Method: Newton or NonlinearCG)")
    line_search: NOXLineSearchParams = Field(default_factory=NOXLineSearchParams, alias="Line Search")
    printing: dict[str, Any] | None = Field(None, alias="Printing", description="accepted (NOX printing options)")
    solver_options: dict[str, Any] | None = Field(None, alias="Solver Options", description="accepted (NOX solver options)")
    status_tests: dict[str, Any] | None = Field(None, alias="Status Tests", description="accepted; Peridigm builds its own status tests")


class NOXQuasiStaticSection(SolverSection):
    nox: NOXQuasiStaticParams = Field(alias="NOXQuasiStatic", description="NOX-driven load-stepped static equilibrium")
    peridigm_preconditioner: Literal["Full Tangent", "Block 3x3", "None"] | None = Field(
        None, alias="Peridigm Preconditioner", description="tangent Peridigm builds: Full Tangent (default), Block 3x3 or None (both: 3x3 diagonal blocks)"
    )
    jacobian_diagnostics: bool = Field(False, alias="Jacobian Diagnostics", description="accepted")
    probe_length: float | None = Field(
        None, alias="Finite Difference Probe Length", gt=0, description="finite-difference tangent probe (L); default 1e-6 x the smallest element radius"
    )

    @model_validator(mode="after")
    def _check(self):
        q = self.nox
        if not ((self.given("final_time") and q.number_of_load_steps is not None) or q.time_steps is not None):
            raise ValueError(
                "no load steps: give 'Final Time' in the solver section with 'NOXQuasiStatic > Number of Load Steps', or 'NOXQuasiStatic > Time Steps'"
            )
        if self.matrix_free:
            lin = q.direction.newton.linear_solver
            if lin.preconditioner not in ("User Defined", "None"):
                raise ValueError(
                    "NOXQuasiStatic > Direction > Newton > Linear Solver > Preconditioner must be 'User Defined' or 'None' with a Matrix-Free "
                    f"Jacobian and the Peridigm {self.peridigm_preconditioner} preconditioner (got {lin.preconditioner!r})"
                )
            if q.preconditioner_reuse_policy not in (None, "Reuse"):
                raise ValueError("NOXQuasiStatic > Preconditioner Reuse Policy must be 'Reuse' for Jacobian-free Newton-Krylov")
        if q.line_search.method == "More'-Thuente":
            raise ValueError("NOXQuasiStatic > Line Search > Method 'More'-Thuente' is not supported; use Polynomial, Backtrack, Full Step or NonlinearCG")
        return self

    @property
    def block_tangent(self) -> bool:
        return self.peridigm_preconditioner in ("Block 3x3", "None")

    @property
    def linear_params(self) -> NOXLinearSolverParams:
        d = self.nox.direction
        return d.newton.linear_solver if d.method == "Newton" else d.nonlinear_cg.linear_solver

    @property
    def matrix_free(self) -> bool:
        return self.nox.direction.method == "Newton" and self.linear_params.jacobian_operator == "Matrix-Free" and self.block_tangent


# ------------------------------------------------------------------------------------------------
class NOXQuasiStatic(Solver):
    name = "NOXQuasiStatic"
    Params = NOXQuasiStaticSection

    def planned_steps(self, sim) -> int | None:
        return planned_load_steps(self.params, self.params.nox)

    @classmethod
    def tangent_request(cls, params) -> str:
        """The tangent this solver allocates (see Simulation._rank_deficient_node_set)."""
        if params.peridigm_preconditioner is None:
            return "default"
        return "block diagonal" if params.block_tangent else "full"

    def run(self, sim) -> None:
        p = self.params
        if p.peridigm_preconditioner is None and p.nox.direction.method == "Newton" and p.linear_params.jacobian_operator == "Matrix-Free":
            log.warning(
                "%s: 'Jacobian Operator: Matrix-Free' without 'Peridigm Preconditioner' assembles the full tangent "
                "(Peridigm's default preconditioner is 'Full Tangent') and solves with it; for a Jacobian-free solve "
                "set 'Peridigm Preconditioner' to \"None\" or \"Block 3x3\"",
                self.section,
            )
        with threads_for(sim):
            NOXRun(self, sim).run()


class NOXRun:
    """One NOXQuasiStatic solver run (all vectors of the NOX problem are in row order)."""

    LAMBDA = 1.0e-6  # NOX::Epetra::MatrixFree perturbation parameter

    def __init__(self, solver: NOXQuasiStatic, sim) -> None:
        self.solver = solver
        self.sim = sim
        self.p = solver.params
        self.q = solver.params.nox
        self.section = solver.section
        kind = "block diagonal" if self.p.block_tangent else "full"
        self.problem = ImplicitProblem(sim, kind, section=solver.section)
        self.n = sim.num_owned
        f = sim.fields
        self.x, self.u, self.y, self.v = f["Model_Coordinates"], f["Displacement"], f["Coordinates"], f["Velocity"]
        self.dt = 1.0
        self.v_bc = np.zeros((self.n, 3))
        self.jacobian_requests = 0
        self.linear_iterations = 0
        self.comm = self.problem.comm  # None serially

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
        from .ilu import ILU0

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
        res = aztec_gmres(matvec, F, None, tol, lin.kspace, lin.max_iterations, precond, classical=lin.orthogonalization == "Classical", comm=self.comm)
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
                z = aztec_gmres(T.matvec, F, None, 0.0, lin.kspace, lin.preconditioner_iterations, precond, classical=lin.orthogonalization == "Classical", comm=self.comm).x
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
                if temp > 0.5 * step:
                    temp = 0.5 * step
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
            self.sim.nonlinear_iterations += 1
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
                f"{self.section}: load step {step_index} (t = {self.sim.time:.6g}) did not converge in {q.max_solver_iterations} NOX steps "
                f"(||F|| = {float(self._norm(F)):.4g}, tolerance {tol:.4g}); Peridigm aborts here too"
            )
        self.set_state(s)  # y and v as at the last residual evaluation
        return s

    def status(self, F: np.ndarray, tol: float, niter: int) -> str:
        """NOX status tests, OR-combined: finite value, ||F||_2 < tol, iterations >= max."""
        nF = self.problem.norm2(F)
        if not math.isfinite(nF):
            return "failed"
        if nF < tol:
            return "converged"
        if niter >= self.q.max_solver_iterations:
            return "failed"
        return "unconverged"

    # -- the solver -----------------------------------------------------------------------------
    def run(self) -> None:
        sim, p, q = self.sim, self.p, self.q
        prob = self.problem
        wall0 = _time.perf_counter()
        times = load_times(p, q, path=(self.section, "NOXQuasiStatic"), file=sim.deck.file)
        n = self.n
        if not p.initialize_predictor:
            self.v[:] = 0.0
        t_cur = t_prev = times[0]
        sim.time_prev = sim.time = t_cur
        sim.apply_kinematic(t_cur, t_prev)
        sim.apply_body_forces(t_cur)
        sim.write_output(t_cur)
        log.info(
            "%s: NOXQuasiStatic (%s%s), %d load steps from t = %.6g to %.6g, %d unknowns",
            self.section, q.direction.method, ", Jacobian-free" if p.matrix_free else "", len(times) - 1, times[0], times[-1], 3 * sim.num_global,
        )
        du = np.zeros((sim.num_local, 3))
        saved = sim.delta_u
        sim.delta_u = du
        steps = 0
        try:
            for k in range(1, len(times)):
                t_prev, t_cur = t_cur, times[k]
                self.dt = t_cur - t_prev
                sim.set_time_step(self.dt)  # rate-form materials integrate over the load step
                sim.time_prev, sim.time = t_prev, t_cur
                du[:] = 0.0
                guess = self.v[:n] * self.dt
                guess[prob.fixed_local] = 0.0
                self.v[:] = 0.0
                sim.apply_kinematic(t_cur, t_prev)
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
                sim.write_output(t_cur)
                sim.advance()
                steps += 1
        finally:
            sim.delta_u = saved
            solver_stats(sim, self.section, "NOXQuasiStatic", steps, _time.perf_counter() - wall0, prob, linear_iterations=self.linear_iterations)
