"""The ``NOXQuasiStatic`` solver section: Peridigm's keys and the NOX / AztecOO option trees it
passes to NOX. The keys that change what runs are validated (with NOX's defaults and checks);
other NOX keys are accepted with a warning that peridyn does not use them."""
from __future__ import annotations

import difflib
import logging
from typing import Any, Literal

from pydantic import ConfigDict, Field, model_validator

from ...core.params import ModelParams
from ..section import SolverSection
from .quasistatic import LoadStepKeys
from .trust_region import TrustRegionOptions

log = logging.getLogger("peridyn.solver")

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
    "RCM Reordering", "Graph Fill", "Overlap", "Fill Factor", "Drop Tolerance",
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
    ill_conditioning_threshold: float = Field(
        1.0e11, alias="Ill-Conditioning Threshold", gt=1, description="AztecOO's GMRES stops when its Hessenberg condition estimate exceeds this"
    )


class NOXNewtonParams(_OptionTree):
    forcing_term_method: Literal["Constant", "Type 1", "Type 2"] = Field("Constant", alias="Forcing Term Method")
    # NOX's defaults (NOX::Direction::Newton::reset)
    forcing_term_initial_tolerance: float = Field(0.01, alias="Forcing Term Initial Tolerance", gt=0, lt=1)
    forcing_term_minimum_tolerance: float = Field(1.0e-4, alias="Forcing Term Minimum Tolerance", gt=0, lt=1)
    forcing_term_maximum_tolerance: float = Field(0.9, alias="Forcing Term Maximum Tolerance", gt=0, lt=1)
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


class NOXTrustRegionParams(_OptionTree):
    """``Trust Region`` options of NOX's Inexact Trust Region Based solver (NOX's defaults and
    checks, NOX_Solver_InexactTrustRegionBased.C ``init``)."""

    inner_iteration_method: Literal["Inexact Trust Region", "Standard Trust Region"] = Field(
        "Inexact Trust Region", alias="Inner Iteration Method", description="inexact (Cauchy/inexact-Newton dogleg) or standard dogleg trust region"
    )
    minimum_radius: float = Field(1.0e-6, alias="Minimum Trust Region Radius", gt=0, description="smallest trust region radius (length)")
    maximum_radius: float = Field(1.0e10, alias="Maximum Trust Region Radius", gt=0, description="largest radius, also the first one of the inexact method (length)")
    minimum_improvement_ratio: float = Field(1.0e-4, alias="Minimum Improvement Ratio", gt=0, description="actual/predicted reduction that accepts a step")
    contraction_trigger_ratio: float = Field(0.1, alias="Contraction Trigger Ratio", description="below this ratio the radius contracts")
    expansion_trigger_ratio: float = Field(0.75, alias="Expansion Trigger Ratio", description="above this ratio the radius expands")
    contraction_factor: float = Field(0.25, alias="Contraction Factor", gt=0, lt=1, description="radius multiplier on contraction")
    expansion_factor: float = Field(4.0, alias="Expansion Factor", gt=1, description="radius multiplier on expansion")
    recovery_step: float = Field(1.0, alias="Recovery Step", ge=0, description="step length along the recovery direction when no step is accepted")
    use_cauchy_in_newton_direction: bool = Field(False, alias="Use Cauchy in Newton Direction", description="start the Newton linear solve from the Cauchy step")
    use_ared_pred_ratio: bool = Field(False, alias="Use Ared/Pred Ratio Calculation", description="Walker's ratio on ||F|| instead of the merit function")
    use_dogleg_segment_minimization: bool = Field(False, alias="Use Dogleg Segment Minimization", description="inexact method: minimize the linear residual along the dogleg segment")
    use_counters: bool = Field(True, alias="Use Counters", description="accepted (the counters are kept in the solver statistics)")
    write_output_parameters: bool = Field(True, alias="Write Output Parameters", description="accepted")
    output: dict[str, Any] | None = Field(None, alias="Output", description="accepted (NOX writes its statistics here)")

    @model_validator(mode="after")
    def _nox_checks(self):
        self.options().check()
        return self

    def options(self) -> TrustRegionOptions:
        return TrustRegionOptions(
            inner_iteration_method=self.inner_iteration_method, minimum_radius=self.minimum_radius, maximum_radius=self.maximum_radius,
            minimum_improvement_ratio=self.minimum_improvement_ratio, contraction_trigger_ratio=self.contraction_trigger_ratio,
            expansion_trigger_ratio=self.expansion_trigger_ratio, contraction_factor=self.contraction_factor,
            expansion_factor=self.expansion_factor, recovery_step=self.recovery_step,
            use_cauchy_in_newton_direction=self.use_cauchy_in_newton_direction, use_ared_pred_ratio=self.use_ared_pred_ratio,
            use_dogleg_segment_minimization=self.use_dogleg_segment_minimization,
        )


class NOXSteepestDescentParams(_OptionTree):
    scaling_type: Literal["Quadratic Model Min", "2-Norm", "F 2-Norm", "None"] = Field(
        "Quadratic Model Min", alias="Scaling Type", description="scaling of the Cauchy (steepest descent) direction; the trust region sets Quadratic Model Min"
    )


class NOXCauchyDirectionParams(_OptionTree):
    method: Literal["Steepest Descent"] = Field("Steepest Descent", alias="Method", description="Cauchy direction of the trust region (Steepest Descent)")
    steepest_descent: NOXSteepestDescentParams = Field(default_factory=NOXSteepestDescentParams, alias="Steepest Descent")


class NOXQuasiStaticParams(LoadStepKeys):
    nonlinear_solver: Literal["Line Search Based", "Inexact Trust Region Based"] = Field(
        "Line Search Based", alias="Nonlinear Solver", description="NOX solver: Line Search Based or Inexact Trust Region Based"
    )
    trust_region: NOXTrustRegionParams = Field(default_factory=NOXTrustRegionParams, alias="Trust Region", description="Inexact Trust Region Based options")
    cauchy_direction: NOXCauchyDirectionParams = Field(
        default_factory=NOXCauchyDirectionParams, alias="Cauchy Direction", description="Inexact Trust Region Based: the Cauchy direction"
    )
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
        if q.nonlinear_solver == "Inexact Trust Region Based":
            if q.direction.method != "Newton":
                raise ValueError("NOXQuasiStatic > Direction > Method must be 'Newton' with 'Nonlinear Solver: Inexact Trust Region Based'")
            if self.matrix_free:
                raise ValueError(
                    "'Nonlinear Solver: Inexact Trust Region Based' needs the transposed Jacobian (the Cauchy direction J^T F), which NOX's "
                    "Matrix-Free operator does not provide: use a tangent Jacobian (drop 'Jacobian Operator: Matrix-Free' or set "
                    "'Peridigm Preconditioner' to \"Full Tangent\")"
                )
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
