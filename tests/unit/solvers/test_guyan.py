"""Static (Guyan) condensation (peridyn.solvers.linalg.guyan, QuasiStatic > Model Reduction).

The condensation eliminates the slaves with their own load, so its solution is the full
system's, exactly: the tests hold it to 1e-12 (matrices) and 1e-10 (whole QuasiStatic runs,
after Newton iterations and a line search, against ``Linear Solver: Direct``) relative to the
largest entry, where the two direct factorizations differ by round-off only (~1e-15 x the
condition number). Dropping the slaves' load (plain Guyan, x_s = -A_ss^-1 A_sm x_m whatever
b_s) misses them by O(1): the load-step residuals near a prescribed boundary sit on slaves.
"""
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from peridyn.core.errors import InputError
from peridyn.solvers.linalg.guyan import CondensedSolver, SingularCondensation, StaticCondensation
from peridyn.engine.session import run_sections

GUYAN = "Static Condensation"


def random_system(n, symmetric, seed=0):
    """A sparse, diagonally dominant (non-singular) n x n matrix and a right-hand side."""
    rng = np.random.default_rng(seed)
    A = sp.random(n, n, density=0.05, random_state=seed, data_rvs=rng.standard_normal).tocsr()
    if symmetric:
        A = A + A.T
    A = A + sp.diags(np.abs(A).sum(axis=1).A1 + 1.0)
    return A.tocsr(), rng.standard_normal(n)


@pytest.mark.parametrize("symmetric", [True, False])
@pytest.mark.parametrize("fraction", [0.0, 0.1, 0.5, 0.9, 1.0])
def test_condensed_solve_equals_the_full_solve(symmetric, fraction):
    A, b = random_system(240, symmetric)
    masters = np.random.default_rng(1).random(240) < fraction
    x = StaticCondensation(A, masters).solve(b)
    x_full = spla.splu(A.tocsc()).solve(b)
    assert np.max(np.abs(x - x_full)) <= 1.0e-12 * np.max(np.abs(x_full))


def test_without_slave_load_the_slaves_follow_guyan():
    """b_s = 0: x_s = -A_ss^-1 A_sm x_m, and A_r is Guyan's T^T A T with T = [I; -A_ss^-1 A_sm]."""
    A, b = random_system(150, symmetric=True, seed=3)
    masters = np.zeros(150, dtype=bool)
    masters[::4] = True
    m, s = np.flatnonzero(masters), np.flatnonzero(~masters)
    b[s] = 0.0
    cond = StaticCondensation(A, masters)
    x = cond.solve(b)
    D = A.toarray()
    X = -np.linalg.solve(D[np.ix_(s, s)], D[np.ix_(s, m)])
    np.testing.assert_allclose(x[s], X @ x[m], rtol=0, atol=1e-12 * np.abs(x).max())
    T = np.zeros((150, m.size))
    T[m] = np.eye(m.size)
    T[s] = X
    reduced = T.T @ D @ T  # Guyan's reduced stiffness; its load is T^T b = b_m when b_s = 0
    np.testing.assert_allclose(reduced @ x[m], b[m], rtol=0, atol=1e-10 * np.abs(b).max())


def test_a_singular_condensed_block_is_reported():
    A, b = random_system(60, symmetric=True)
    A = A.tolil()
    A[45, :] = 0.0
    A[:, 45] = 0.0  # slave 45 is held by nothing
    masters = np.arange(60) < 20
    with pytest.raises(SingularCondensation, match="A_ss"):
        StaticCondensation(A.tocsr(), masters)

    class Matrix:  # what CondensedSolver reads of a TangentMatrix
        def to_scipy(self):
            return A.tocsr()

    solver = CondensedSolver(~masters, np.zeros(60, dtype=bool))
    solver.set_matrix(Matrix())
    result = solver.solve(b)
    assert not result.converged and "singular" in result.message


def test_a_singular_reduced_matrix_is_reported():
    A, _ = random_system(60, symmetric=True)
    A = A.tolil()
    A[2, :] = 0.0
    A[:, 2] = 0.0  # a master held by nothing: A (and so A_r) is singular
    with pytest.raises(SingularCondensation, match="reduced"):
        StaticCondensation(A.tocsr(), np.arange(60) < 20)


# ------------------------------------------------------------------------------------------------
# through the deck
# ------------------------------------------------------------------------------------------------
def bar(h, tmp_path, reduction=None, linear="Direct", steps=2, pull=0.02):
    """A two-block LPS bar (block_1: x < 3, block_2: x > 3, 6 x 4 x 4 points), clamped at x < 1
    (all components) and pulled along x at x > 5; x = 2.5 holds the 'Middle Node Set'."""
    tree = h.two_block_text_deck(tmp_path, h.LPS)
    q = {"Number of Load Steps": steps, "Relative Tolerance": 1.0e-10, "Maximum Solver Iterations": 10}
    if linear is not None:
        q["Linear Solver"] = linear
    if reduction is not None:
        q["Model Reduction"] = reduction
    g = np.stack(np.meshgrid(*[np.arange(n) + 0.5 for n in (6, 4, 4)], indexing="ij"), axis=-1).reshape(-1, 3)
    ids = lambda mask: " ".join(str(i + 1) for i in np.flatnonzero(mask))  # noqa: E731
    tree["Boundary Conditions"] = {
        "Left Node Set": ids(g[:, 0] < 1.0),
        "Right Node Set": ids(g[:, 0] > 5.0),
        "Middle Node Set": ids(np.abs(g[:, 0] - 2.5) < 0.1),
        **{f"L{c}": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": c, "Value": "0.0"} for c in "xyz"},
        "RX": {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "x", "Value": f"{pull}*t"},
    }
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0, "QuasiStatic": q}
    return tree


def run(h, tree, tmp_path):
    sim = h.build(tree, directory=tmp_path)
    run_sections(sim)
    st = sim.stats["solvers"][-1]
    assert st["converged"]
    return sim.fields["Displacement"][: sim.num_owned].copy(), st


@pytest.mark.parametrize(
    "reduction",
    [
        {"Type": GUYAN, "Reduction Blocks": "block_2"},  # holds the pulled end: prescribed x, free y and z
        {"Type": GUYAN, "Reduction Blocks": 1},  # holds the clamped end
        {"Type": GUYAN, "Reduction Node Set": "Middle Node Set"},  # a slice through the bar
    ],
)
def test_quasistatic_run_with_condensation_equals_the_full_run(h, tmp_path, reduction):
    u_full, full = run(h, bar(h, tmp_path), tmp_path)
    u, st = run(h, bar(h, tmp_path, reduction), tmp_path)
    assert np.max(np.abs(u - u_full)) <= 1.0e-10 * np.max(np.abs(u_full))
    assert st["linear_solver"] == GUYAN and full["linear_solver"] == "Direct"
    # LPS is geometrically non-linear: several Newton iterations, each on a new condensation
    assert st["nonlinear_iterations"] == full["nonlinear_iterations"] > 2
    z = st["model_reduction"]
    assert z["slaves"] > 0 and z["masters"] > 0 and z["condensations"] == st["tangent_assemblies"]


def test_tensile_bar_condensed_onto_its_gauge_section(h, tmp_path):
    """The tensile test of peridyn.testing.tensile (small: 3 x 3 points across, horizon 2
    spacings) with its grips condensed: the same displacements and Young's modulus as the full
    solve, to round-off."""
    from peridyn.testing.tensile import tensile_bar

    def measure(q):
        solver = {"Initial Time": 0.0, "Final Time": 1.0,
                  "QuasiStatic": {"Number of Load Steps": 1, "Relative Tolerance": 1.0e-8, **q}}
        bar_ = tensile_bar(h.LPS, tmp_path, ratio=2.015, horizon=1.0e-3, section=1.0, solver=solver)
        sim = h.build(bar_.tree, directory=tmp_path)
        run_sections(sim)
        return sim.fields["Displacement"][: sim.num_owned].copy(), bar_.youngs_modulus(sim), sim.stats["solvers"][-1]

    u_full, e_full, _ = measure({"Linear Solver": "Direct"})
    u, e, st = measure({"Model Reduction": {"Type": GUYAN, "Reduction Blocks": "block_1 block_3"}})
    assert st["model_reduction"]["slaves"] > 0
    assert np.max(np.abs(u - u_full)) <= 1.0e-10 * np.max(np.abs(u_full))
    np.testing.assert_allclose(e, e_full, rtol=1.0e-10)


def test_linear_problem_under_a_prescribed_displacement(h, tmp_path):
    """K u = 0 on the free components with the pulled end's u_x prescribed: the Newton system of
    a linear problem, right-hand side -K_fp u_p. The condensed solve (through CondensedSolver on
    the bar's tangent after its boundary conditions, the middle slice condensed) gives the
    masters and the recovered slaves of the full solve."""
    from peridyn.solvers.implicit.model_reduction import condensed_solver
    from peridyn.solvers.implicit.problem import ImplicitProblem
    from peridyn.solvers.implicit.quasistatic import QuasiStaticParams

    sim = h.build(bar(h, tmp_path), directory=tmp_path)
    prob = ImplicitProblem(sim)
    T = prob.assemble_tangent()
    K = T.to_scipy(copy=True).tocsr()  # before the boundary conditions
    fixed = prob.fixed_flat
    x = T.to_rows(sim.fields["Model_Coordinates"][: sim.num_owned]).reshape(-1, 3)  # row order
    pulled = np.zeros_like(x, dtype=bool)
    pulled[:, 0] = x[:, 0] > 5.0
    u_p = np.where(pulled.reshape(-1), 0.02, 0.0)  # the clamped end's prescribed values are 0
    assert np.all(fixed[u_p != 0.0])
    b = -(K @ u_p)
    b[fixed] = 0.0
    T.apply_kinematic_bc(prob.fixed_rows)
    params = QuasiStaticParams.model_validate({"Model Reduction": {"Type": GUYAN, "Reduction Node Set": "Middle Node Set"}})
    solver = condensed_solver(sim, T, params.model_reduction, ("Solver", "QuasiStatic", "Model Reduction"))
    solver.set_matrix(T)
    result = solver.solve(b)
    x_full = spla.splu(T.to_scipy(copy=True).tocsc()).solve(b)
    assert result.converged and np.all(result.x[fixed] == 0.0)
    slaves = np.flatnonzero(~fixed)[~solver.masters]
    masters = np.flatnonzero(~fixed)[solver.masters]
    assert slaves.size == 16 * 3 and masters.size > slaves.size  # the 16 points of the slice, free
    scale = np.abs(x_full).max()
    assert np.max(np.abs(result.x[masters] - x_full[masters])) <= 1.0e-10 * scale
    assert np.max(np.abs(result.x[slaves] - x_full[slaves])) <= 1.0e-10 * scale


def test_plain_guyan_would_not_do(h, tmp_path):
    """The same run, if the slaves' load were dropped (b_s = 0), does not reach the full
    solution: the check above can fail."""
    from peridyn.solvers.linalg import guyan
    from peridyn.solvers.implicit.load_steps import LoadStepError

    u_full, _ = run(h, bar(h, tmp_path, steps=1), tmp_path)
    original = guyan.StaticCondensation.solve

    def guyan_only(self, b):
        b = b.copy()
        b[self.s] = 0.0
        return original(self, b)

    guyan.StaticCondensation.solve = guyan_only
    try:
        sim = h.build(bar(h, tmp_path, {"Type": GUYAN, "Reduction Blocks": "block_2"}, steps=1), directory=tmp_path)
        try:
            run_sections(sim)
        except LoadStepError:  # its Newton steps are wrong: the load step does not converge
            return
        u = sim.fields["Displacement"][: sim.num_owned]
    finally:
        guyan.StaticCondensation.solve = original
    assert np.max(np.abs(u - u_full)) > 1.0e-3 * np.max(np.abs(u_full))


# ------------------------------------------------------------------------------------------------
# bad input
# ------------------------------------------------------------------------------------------------
def error_for(h, tmp_path, reduction, linear=None):
    with pytest.raises(InputError) as info:
        sim = h.build(bar(h, tmp_path, reduction, linear=linear), directory=tmp_path)
        sim.plan_solvers()  # set-up: what a run does before its first step
    text = info.value.one_line()
    assert "\n" not in text
    return text


PATH = "Solver > QuasiStatic > Model Reduction"


@pytest.mark.parametrize(
    "reduction, linear, path, words",
    [
        ({"Type": GUYAN}, None, PATH, "needs the region"),
        ({"Type": "Craig Bampton", "Reduction Blocks": "block_2"}, None, PATH + " > Type", "Static Condensation"),
        ({"Reduction Blocks": "block_2"}, None, PATH, "missing required key 'Type'"),
        ({"Type": GUYAN, "Reduction Blocks": " , "}, None, PATH + " > Reduction Blocks", "names no block"),
        ({"Type": GUYAN, "Reduction Blocks": "block_2", "Number of Modes": 3}, None, PATH, "Number of Modes"),
        ({"Type": GUYAN, "Reduction Blocks": "block_2"}, "AMG", "Solver > QuasiStatic", "contradicts"),
        ({"Type": GUYAN, "Reduction Blocks": "block_7"}, None, PATH + " > Reduction Blocks", "block_1 (id 1), block_2 (id 2)"),
        ({"Type": GUYAN, "Reduction Node Set": "Top Node Set"}, None, PATH + " > Reduction Node Set", "unknown node set"),
        ({"Type": GUYAN, "Reduction Blocks": "block_1, block_2"}, None, PATH, "no free master"),
        ({"Type": GUYAN, "Reduction Node Set": "Left Node Set"}, None, PATH, "nothing to condense"),
    ],
)
def test_bad_model_reduction_input(h, tmp_path, reduction, linear, path, words):
    text = error_for(h, tmp_path, reduction, linear)
    assert path in text and words in text


def test_an_empty_node_set_is_refused(h, tmp_path):
    (tmp_path / "empty.txt").write_text("# no point\n")
    tree = bar(h, tmp_path, {"Type": GUYAN, "Reduction Node Set": "Empty Node Set"})
    tree["Boundary Conditions"]["Empty Node Set"] = "empty.txt"
    with pytest.raises(InputError) as info:
        h.build(tree, directory=tmp_path).plan_solvers()
    text = info.value.one_line()
    assert PATH + " > Reduction Node Set" in text and "is empty: nothing to condense" in text


def test_direct_linear_solver_is_accepted_with_condensation(h, tmp_path):
    sim = h.build(bar(h, tmp_path, {"Type": GUYAN, "Reduction Blocks": "block_2"}, linear="Direct"), directory=tmp_path)
    sim.plan_solvers()


def test_an_unsupported_part_of_the_region_is_refused(h, tmp_path):
    """A second, unbonded bar (x > 20) condensed: with the masters held it could float (its
    A_ss is singular)."""
    tree = bar(h, tmp_path, {"Type": GUYAN, "Reduction Blocks": "block_2"})
    mesh = tmp_path / "two_blocks.txt"
    lines = mesh.read_text().splitlines()
    far = [" ".join([f"{float(p.split()[0]) + 20.0:.1f}"] + p.split()[1:3] + ["2", "1.0"]) for p in lines[1:] if p.split()[3] == "1"]
    mesh.write_text("\n".join(lines + far) + "\n")
    with pytest.raises(InputError) as info:
        h.build(tree, directory=tmp_path).plan_solvers()
    text = info.value.one_line()
    assert PATH in text and "bonded to no master" in text and "ids 97, 98" in text


@pytest.mark.parametrize(("ranks", "multiphysics", "words"), [(2, False, "runs on one process"), (1, True, "Multiphysics deck is not supported")])
def test_mpi_and_multiphysics_runs_are_refused(ranks, multiphysics, words):
    from types import SimpleNamespace

    from peridyn.solvers.implicit.model_reduction import refuse_unsupported

    sim = SimpleNamespace(comm=SimpleNamespace(size=ranks), deck=SimpleNamespace(file="deck.yaml", multiphysics=multiphysics))
    with pytest.raises(InputError) as info:
        refuse_unsupported(sim, ("Solver", "QuasiStatic", "Model Reduction"))
    assert words in info.value.one_line() and PATH in info.value.one_line()
