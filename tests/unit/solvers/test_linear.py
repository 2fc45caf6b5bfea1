"""Linear solvers on a real tangent system: Peridigm's CG, sparse direct, AMG-preconditioned CG
and AztecOO-style GMRES must agree; CG reproduces the textbook recursion and its failure modes.

Tolerances: each iterative solver is run to a relative residual tol; for the SPD system
A = -K (cond(A) ~ 1e2..1e3 here) the error of the solution is at most cond(A) * tol relative to
the exact (direct, ~1e-15 cond) solution, so CG at 1e-10 is compared at 1e-6 and AMG at 1e-8
also at 1e-6."""
import numpy as np
import pytest

from peridyn.solvers.linalg.aztecoo import aztecoo_gmres as aztec_gmres
from peridyn.solvers.linalg.linear import LinearSolver, belos_cg, gdot, gnorm, gsum, pcg, seq_dot, seq_norm2
from peridyn.solvers.linalg.tangent import TangentMatrix
from peridyn.engine.session import run_sections


@pytest.fixture
def system(h):
    sim = h.build(h.box_deck(h.LPS, shape=(5, 4, 4)))
    h.perturb(sim, scale=1e-4)
    sim.evaluate_forces()
    T = TangentMatrix(sim)
    T.assemble()
    fixed = np.zeros((T.n, 3), dtype=bool)
    x = sim.fields["Model_Coordinates"][T.local_of_row]
    fixed[x[:, 0] < 1.0] = True  # clamp one face: A is then positive definite
    T.apply_kinematic_bc(fixed)
    T.scale(-1.0)
    rng = np.random.default_rng(7)
    b = rng.standard_normal(3 * T.n)
    b[fixed.reshape(-1)] = 0.0
    return T, b, x


def test_sequential_reductions():
    a = np.array([1e16, 1.0, -1e16, 1.0])
    assert seq_dot(a, np.ones(4)) == ((1e16 + 1.0) - 1e16) + 1.0  # left to right, no pairwise sum
    np.testing.assert_allclose(seq_norm2(np.array([3.0, 4.0])), 5.0, rtol=1e-15)


def test_direct_cg_amg_gmres_agree(system):
    T, b, x = system
    direct = LinearSolver("Direct")
    direct.set_matrix(T)
    xd = direct.solve(b).x
    A = T.to_scipy().toarray()
    np.testing.assert_allclose(A @ xd, b, rtol=0, atol=1e-10 * np.abs(b).max())
    cg = belos_cg(T.matvec, b, 1e-10, 10 * len(b))
    assert cg.converged
    amg = LinearSolver("AMG", tol=1e-8, coords=x)
    amg.set_matrix(T)
    ra = amg.solve(b)
    assert ra.converged
    gm = aztec_gmres(T.matvec, b, None, 1e-10, 300, 400)
    assert gm.converged
    scale = np.abs(xd).max()
    for sol in (cg.x, ra.x, gm.x):
        np.testing.assert_allclose(sol, xd, rtol=0, atol=1e-6 * scale)


def test_belos_cg_stops_at_the_relative_tolerance_of_the_recursive_residual(system):
    T, b, _ = system
    res = belos_cg(T.matvec, b, 1e-4, 10 * len(b))
    assert res.converged and res.iterations > 1
    r = b - T.matvec(res.x)
    # the recursive residual is below 1e-4; the true one agrees with it to round-off
    assert np.linalg.norm(r) <= 1.0001e-4 * np.linalg.norm(b)
    fewer = belos_cg(T.matvec, b, 1e-4, res.iterations - 1)
    assert not fewer.converged and "iterations" in fewer.message


def test_belos_cg_refuses_an_indefinite_matrix():
    A = np.diag([1.0, -1.0])
    res = belos_cg(lambda p, out: np.copyto(out, A @ p), np.array([0.0, 1.0]), 1e-8, 10)
    assert not res.converged and "positive" in res.message


def test_auto_picks_direct_for_small_systems(system):
    T, b, _ = system
    s = LinearSolver("Auto")
    s.set_matrix(T)
    assert s._chosen == "Direct"


def test_preconditioned_cg_reaches_the_direct_solution(system):
    """pcg (the Krylov method of the AMG solver under MPI) with and without a Jacobi
    preconditioner; serially its reductions are plain sums."""
    T, b, _ = system
    direct = LinearSolver("Direct")
    direct.set_matrix(T)
    xd = direct.solve(b).x
    d = T.diagonal()
    for precond in (None, lambda r: r / d):
        res = pcg(T.matvec, b, 1e-11, 1000, precond)
        assert res.converged and res.iterations > 1
        np.testing.assert_allclose(res.x, xd, rtol=0, atol=1e-7 * np.abs(xd).max())
    assert not pcg(T.matvec, b, 1e-11, 3).converged


def test_reductions_without_a_communicator_are_numpys():
    """gsum / gdot / gnorm with no communicator (or a one-process one) return numpy's values
    unchanged: the serial arithmetic of the solvers does not change."""
    from peridyn.parallel.comm import SerialComm

    rng = np.random.default_rng(3)
    a, c = rng.standard_normal(1000), rng.standard_normal(1000)
    for comm in (None, SerialComm()):
        assert gdot(comm, a, c) == np.dot(a, c)
        assert gnorm(comm, a) == np.linalg.norm(a)
        v = np.arange(3.0)
        assert gsum(comm, v) is v


def test_adaptive_is_peridigms_cg_while_it_converges_quickly(system):
    T, b, x = system
    belos = LinearSolver("Belos", tol=1e-4)
    belos.set_matrix(T)
    adaptive = LinearSolver("Adaptive", tol=1e-4, coords=x)
    adaptive.set_matrix(T)
    rb, ra = belos.solve(b), adaptive.solve(b)
    assert ra.iterations == rb.iterations
    np.testing.assert_array_equal(ra.x, rb.x)
    assert not adaptive.switched


def test_adaptive_switches_to_amg_when_cg_is_slow_and_stays_there(system, monkeypatch, caplog):
    import peridyn.solvers.linalg.linear as L

    T, b, x = system
    plain = belos_cg(T.matvec, b, 1e-8, 10 * len(b))
    monkeypatch.setattr(L, "ADAPTIVE_BELOS_ITERATIONS", 3)
    s = LinearSolver("Adaptive", tol=1e-8, coords=x)
    s.set_matrix(T)
    with caplog.at_level("INFO", logger="peridyn.solver"):
        res = s.solve(b)
    assert s.switched and "AMG-preconditioned" in caplog.text
    assert res.converged
    assert np.linalg.norm(b - T.matvec(res.x)) <= 1e-7 * np.linalg.norm(b)
    s.set_matrix(T)  # a new tangent: the run keeps the AMG solver
    again = s.solve(b)
    assert s._chosen == "AMG" and again.converged
    # the preconditioner earns its keep: far fewer iterations than plain CG on the same system
    assert again.iterations < plain.iterations / 2


def test_adaptive_keeps_a_cg_breakdown_a_failure():
    """An indefinite tangent breaks Peridigm's CG down: that is a failed solve (Peridigm then damps
    the tangent or fails the load step), not a reason to switch solvers."""
    n = 400  # more unknowns than the adaptive CG limit: the adaptive branch runs
    d = np.ones(n)
    d[-1] = -1.0

    class Matrix:
        ndof = n  # what LinearSolver reads of a tangent
        parallel = False

        def matvec(self, p, out=None):
            out = np.empty(n) if out is None else out
            np.multiply(d, p, out=out)
            return out

    s = LinearSolver("Adaptive", tol=1e-8)
    s.set_matrix(Matrix())
    b = np.zeros(n)
    b[-1] = 1.0
    res = s.solve(b)
    assert not res.converged and "positive" in res.message
    assert not s.switched


def _qs_run(h, monkeypatch, limit: int | None, steps: int = 4):
    """A bar pulled in ``steps`` QuasiStatic load steps (default linear solver: Adaptive); with
    ``limit`` the adaptive CG limit is lowered so that this small model switches to AMG."""
    import peridyn.solvers.linalg.linear as L

    if limit is not None:
        monkeypatch.setattr(L, "ADAPTIVE_BELOS_ITERATIONS", limit)
    shape = (8, 3, 3)
    tree = h.box_deck(h.LPS, shape=shape)
    sim0 = h.build(tree)
    x, gid = sim0.discretization.x, sim0.discretization.gid

    def ids(mask):
        return " ".join(str(g + 1) for g in gid[mask])

    tree["Boundary Conditions"] = {
        "Left Node Set": ids(x[:, 0] < 1.0),
        "Right Node Set": ids(x[:, 0] > shape[0] - 1.0),
        **{f"L{c}": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": c, "Value": "0.0"} for c in "xyz"},
        "RX": {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "x", "Value": "0.02*t"},
    }
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": steps, "Relative Tolerance": 1e-10}}
    sim = h.build(tree)
    run_sections(sim)
    return sim, sim.stats["solvers"][-1]


def test_after_the_switch_to_amg_a_good_tangent_is_kept_and_the_answer_is_unchanged(h, monkeypatch):
    peridigm_sim, peridigm = _qs_run(h, monkeypatch, None)
    assert peridigm["tangent_reuses"] == 0  # Peridigm's path: a tangent at every Newton iteration
    fast_sim, fast = _qs_run(h, monkeypatch, 2)
    assert fast["linear_solver"] == "AMG" and fast["converged"]
    assert fast["tangent_reuses"] >= 1
    u, u_ref = fast_sim.fields["Displacement"], peridigm_sim.fields["Displacement"]
    np.testing.assert_allclose(u, u_ref, rtol=0, atol=1e-8 * np.abs(u_ref).max())


@pytest.mark.parametrize("precond", [lambda r: np.zeros_like(r), lambda r: -r])
def test_pcg_with_a_preconditioner_that_is_not_positive_definite_fails_cleanly(precond):
    """A degenerate AMG hierarchy (one point) returned zero: r.z = 0 divided by zero (exit 1)."""
    A = np.diag([2.0, 3.0, 4.0])
    res = pcg(lambda v, out: np.copyto(out, A @ v), np.ones(3), 1e-10, 50, precond)
    assert not res.converged and "preconditioner is not positive definite" in res.message
