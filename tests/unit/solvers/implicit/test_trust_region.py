"""NOX's Inexact Trust Region Based solver (peridyn.solvers.implicit.trust_region), AztecOO's GMRES
safeguards (peridyn.solvers.linalg.aztecoo) and the NOXQuasiStatic wiring."""
import math

import numpy as np
import pytest

from peridyn.core.errors import InputError
from peridyn.solvers.linalg.aztecoo import aztecoo_gmres, dlaic1
from peridyn.solvers.implicit.trust_region import (
    ForcingTermOptions,
    TransposeProduct,
    TrustRegionOptions,
    TrustRegionSolver,
)
from peridyn.engine.session import run_sections

A = np.array([[1.0, 0.3, -0.1], [0.2, 1.0, 0.1], [-0.1, 0.25, 1.0]])


class Dense:
    """F(x) = atan(A x) (componentwise arctan of a nonsymmetric linear map): J = diag(1 / (1 +
    (A x)^2)) A. Newton is affine invariant, so its iterates are those of the scalar Newton on
    atan(z) = 0 in z = A x, which overshoot and run away once |z| > 1.39: atan flattens out."""

    def __init__(self):
        self.evaluations = 0
        self.J = None

    def F(self, s):
        self.evaluations += 1
        return np.arctan(A @ s)

    def jacobian(self, s):
        z = A @ s
        self.J = (1.0 / (1.0 + z * z))[:, None] * A

    def apply_jacobian(self, d):
        return self.J @ d

    def apply_jacobian_transpose(self, d):
        return self.J.T @ d

    def solve(self, rhs, tol, x0):
        return np.linalg.solve(self.J, rhs), True

    def dot(self, a, b):
        return float(np.dot(a, b))

    def norm(self, a):
        return float(np.linalg.norm(a))


X0 = np.array([3.0, -2.5, 4.0])


def status(tol=1e-10, max_iter=60):
    def test(F, niter):
        nF = float(np.linalg.norm(F))
        if not math.isfinite(nF):
            return "failed"
        if nF < tol:
            return "converged"
        return "failed" if niter >= max_iter else "unconverged"

    return test


def run(options=None, x0=X0, problem=None):
    prob = problem or Dense()
    solver = TrustRegionSolver(prob, x0, options or TrustRegionOptions(), ForcingTermOptions(), status())
    steps = 0
    while solver.step() == "unconverged":
        steps += 1
        assert steps < 1000, "the solver neither converges nor fails"
    return solver, steps + 1


def test_plain_newton_overshoots_on_the_test_problem():
    """The control: full Newton steps from X0 do not converge (so the trust region is what makes
    the solver below work)."""
    prob = Dense()
    x = X0.copy()
    with np.errstate(all="ignore"):
        for _ in range(60):
            prob.jacobian(x)
            x = x - np.linalg.solve(prob.J, prob.F(x))
            if not np.all(np.isfinite(x)) or np.linalg.norm(x) > 1e8:
                break
        F = prob.F(x)
    assert not np.linalg.norm(F) < 1e-6


@pytest.mark.parametrize("method", ["Inexact Trust Region", "Standard Trust Region"])
def test_trust_region_converges_where_newton_overshoots(method):
    solver, steps = run(TrustRegionOptions(inner_iteration_method=method))
    assert solver.status == "converged"
    np.testing.assert_allclose(solver.s, 0.0, atol=1e-9)
    c = solver.counters
    # the region had to cut Newton steps back: Cauchy or dogleg steps, and rejected trials
    assert c.cauchy_steps + c.dogleg_steps >= 1
    assert c.inner_iterations > solver.niter
    # near the solution the full Newton step is accepted (fast local convergence)
    assert c.newton_steps >= 2
    assert steps <= 40


def test_inexact_trust_region_first_step_is_newton_inside_the_maximum_radius():
    """On a linear problem the first radius (the maximum, 1e10) holds the Newton step, whose
    actual and predicted reductions agree: one iteration, ratio 1, no cut."""
    K = np.array([[4.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 2.0]])
    b = np.array([1.0, -2.0, 0.5])

    class Linear(Dense):
        def F(self, s):
            return K @ s - b

        def jacobian(self, s):
            self.J = K

    solver, steps = run(problem=Linear(), x0=np.zeros(3))
    # one solver->step(): it checks the initial guess, then iterates once
    assert (steps, solver.niter, solver.counters.newton_steps, solver.counters.inner_iterations) == (1, 1, 1, 1)
    np.testing.assert_allclose(solver.s, np.linalg.solve(K, b), rtol=1e-12)
    assert solver.radius == 1.0e10  # ratio 1 > 0.75 expands the radius, capped at the maximum


def test_first_step_only_checks_a_converged_initial_guess():
    prob = Dense()
    solver = TrustRegionSolver(prob, np.zeros(3), TrustRegionOptions(), ForcingTermOptions(), status())
    assert solver.step() == "converged"
    assert (solver.niter, prob.evaluations) == (0, 1)


def test_recovery_step_when_the_radius_collapses():
    """A Jacobian that points the wrong way: no trial reduces f, the radius shrinks to the
    minimum and NOX takes the recovery step along the Cauchy direction."""

    class Wrong(Dense):
        def jacobian(self, s):
            self.J = -np.eye(3)  # the true Jacobian is ~ +I: every model step goes uphill

    solver = TrustRegionSolver(Wrong(), np.array([0.5, 0.2, -0.3]), TrustRegionOptions(minimum_radius=1e-3), ForcingTermOptions(), status(max_iter=1))
    solver.step()
    assert solver.counters.recovery_steps == 1
    assert solver.niter == 1


@pytest.mark.parametrize(
    "kw", [{"minimum_radius": 0.0}, {"maximum_radius": 1e-7}, {"contraction_trigger_ratio": 1e-5}, {"expansion_trigger_ratio": 0.05}, {"contraction_factor": 1.0}, {"expansion_factor": 1.0}, {"recovery_step": -1.0}]
)
def test_nox_parameter_checks(kw):
    with pytest.raises(ValueError, match="Trust Region"):
        TrustRegionOptions(**kw).check()


# -- AztecOO GMRES --------------------------------------------------------------------------------
def test_dlaic1_tracks_the_extreme_singular_values():
    rng = np.random.default_rng(3)
    n = 12
    R = np.triu(rng.standard_normal((n, n))) + 4.0 * np.eye(n)
    R[n - 1, n - 1] = 1e-6  # nearly singular last column
    big = small = abs(R[0, 0])
    xb = np.ones(1)
    xs = np.ones(1)
    for i in range(1, n):
        col = R[:i, i]
        big, s, c = dlaic1(1, xb, big, col, R[i, i])
        xb = np.append(s * xb, c)
        small, s, c = dlaic1(2, xs, small, col, R[i, i])
        xs = np.append(s * xs, c)
    sv = np.linalg.svd(R, compute_uv=False)
    assert sv[0] / 10 <= big <= sv[0] * 1.0000001
    assert sv[-1] * 0.9999999 <= small <= sv[-1] * 10


def test_aztecoo_gmres_solves_a_regular_system_like_a_direct_solver():
    rng = np.random.default_rng(0)
    M = np.eye(40) * 5 + rng.standard_normal((40, 40))
    b = rng.standard_normal(40)
    res = aztecoo_gmres(lambda x, out: np.dot(M, x, out=out), b, None, 1e-12, 300, 400)
    assert res.converged
    np.testing.assert_allclose(res.x, np.linalg.solve(M, b), rtol=1e-9)


def test_aztecoo_gmres_stops_on_a_singular_system_without_inflating_the_null_space():
    """A free body: a nonsymmetric operator with the constant vector in its null space (left and
    right). Asked for far more accuracy than round-off allows, AztecOO stops when the Hessenberg
    condition estimate passes 1e11; the solution keeps a round-off-sized null-space part."""
    rng = np.random.default_rng(1)
    n = 60
    M = rng.standard_normal((n, n))
    M = M - M.mean(axis=0, keepdims=True)
    M = M - M.mean(axis=1, keepdims=True)  # M 1 = 0 and 1^T M = 0
    S = M @ M.T + 0.3 * (M - M.T)  # nonsymmetric, same null space
    b = S @ rng.standard_normal(n)  # consistent: b is orthogonal to the constant vector
    res = aztecoo_gmres(lambda x, out: np.dot(S, x, out=out), b, None, 1e-30, 300, 400)
    assert "ill-conditioned" in res.message or "loss of precision" in res.message or "breakdown" in res.message
    assert res.iterations < 400
    assert abs(res.x.mean()) < 1e-8 * np.abs(res.x).max()
    assert np.linalg.norm(S @ res.x - b) < 1e-8 * np.linalg.norm(b)


# -- the tangent's transposed product and the NOXQuasiStatic wiring -----------------------------
def test_transpose_product_is_the_transposed_tangent(h):
    sim = h.build(h.box_deck(h.LPS, shape=(4, 3, 3)))
    h.perturb(sim)
    from peridyn.solvers.linalg.tangent import TangentMatrix

    T = TangentMatrix(sim, "full")
    T.assemble()
    K = T.to_scipy().toarray()
    x = np.random.default_rng(2).standard_normal(K.shape[0])
    np.testing.assert_allclose(TransposeProduct(T)(x), K.T @ x, rtol=1e-12, atol=1e-12 * np.abs(K).max())


def nox_bar(h, nox, **kw):
    from tests.unit.solvers.implicit.test_implicit_solvers import bar_deck

    return bar_deck(h, {"Initial Time": 0.0, "Final Time": 1.0, "NOXQuasiStatic": nox}, **kw)


def test_nox_trust_region_reaches_the_quasistatic_equilibrium(h):
    from tests.unit.solvers.implicit.test_implicit_solvers import QS, bar_deck

    nox = {"Number of Load Steps": 2, "Relative Tolerance": 1e-10, "Nonlinear Solver": "Inexact Trust Region Based", "Direction": {"Method": "Newton"},
           "Trust Region": {"Minimum Improvement Ratio": 1e-4, "Use Counters": True}}
    sim = h.build(nox_bar(h, nox))
    run_sections(sim)
    ref = h.build(bar_deck(h, QS))
    run_sections(ref)
    u, u_ref = sim.fields["Displacement"], ref.fields["Displacement"]
    np.testing.assert_allclose(u, u_ref, rtol=0, atol=1e-7 * np.abs(u_ref).max())
    st = sim.stats["solvers"][0]["trust_region"]
    assert st["newton_steps"] >= 2 and st["recovery_steps"] == 0


@pytest.mark.parametrize(
    "extra, words",
    [
        ({"Trust Region": {"Contraction Factor": 1.5}}, "Contraction Factor"),
        ({"Trust Region": {"Expansion Trigger Ratio": 0.01}}, "Expansion Trigger Ratio"),
        ({"Trust Region": {"Inner Iteration Method": "Exact"}}, "Inner Iteration Method"),
        ({"Direction": {"Method": "NonlinearCG"}}, "must be 'Newton'"),
        ({"Direction": {"Method": "Newton", "Newton": {"Linear Solver": {"Jacobian Operator": "Matrix-Free"}}}, "Peridigm Preconditioner": "None"}, "transposed Jacobian"),
    ],
)
def test_nox_trust_region_parameters_are_validated(h, extra, words):
    nox = {"Number of Load Steps": 1, "Nonlinear Solver": "Inexact Trust Region Based", "Direction": {"Method": "Newton"}}
    pre = extra.pop("Peridigm Preconditioner", None)
    nox.update(extra)
    tree = nox_bar(h, nox)
    if pre is not None:
        tree["Solver"]["Peridigm Preconditioner"] = pre
    with pytest.raises(InputError) as info:
        h.build(tree)
    assert words in info.value.one_line()


def test_unknown_trust_region_keys_are_accepted_with_a_warning(h, caplog):
    nox = {"Number of Load Steps": 1, "Nonlinear Solver": "Inexact Trust Region Based", "Direction": {"Method": "Newton"},
           "Trust Region": {"Some NOX Option": 3}}
    with caplog.at_level("WARNING"):
        h.build(nox_bar(h, nox))
    assert "Some NOX Option" in caplog.text


@pytest.mark.parametrize(
    "options, forcing",
    [
        ({"use_ared_pred_ratio": True}, {}),
        ({"use_dogleg_segment_minimization": True}, {}),
        ({"use_cauchy_in_newton_direction": True}, {}),
        ({"cauchy_scaling": "2-Norm"}, {}),
        ({"cauchy_scaling": "F 2-Norm"}, {}),
        ({"inner_iteration_method": "Standard Trust Region", "use_ared_pred_ratio": True}, {}),
        ({}, {"method": "Type 1"}),
        ({}, {"method": "Type 2"}),
        ({"inner_iteration_method": "Standard Trust Region"}, {"method": "Type 2"}),
    ],
)
def test_trust_region_options_converge(options, forcing):
    prob = Dense()
    solver = TrustRegionSolver(prob, X0, TrustRegionOptions(**options), ForcingTermOptions(**forcing), status(max_iter=200))
    while solver.step() == "unconverged":
        pass
    assert solver.status == "converged"
    if forcing:
        assert solver.tolerance != ForcingTermOptions().tolerance  # the forcing term replaced the constant tolerance
