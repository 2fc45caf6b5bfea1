"""The tangent K = d(f V)/dy: analytic kernels against finite differences of the assembled force,
symmetry, Peridigm's finite-difference tangent, and the kinematic boundary-condition treatment.

Tolerances. The reference is a central difference of the engine's force with step h = 1e-7 on
coordinates of size |y| < 7: the step itself is only represented to eps_mach |y| ~ 1.5e-15, a
relative error ~1.5e-8 in every column, while the O(h^2) truncation error is ~1e-14. So the
analytic tangent must agree to 1e-7 of the largest entry. Symmetry is exact up to summation
round-off (1e-13). Peridigm's finite-difference tangent uses eps = 1e-6 x the smallest element
radius (6.2e-7 here): the same kind of error, ~1e-8, checked at 1e-7.
"""
import numpy as np
import pytest

from peridyn.solvers.linalg.tangent import TangentMatrix

FD_RTOL = 1.0e-7
SYM_RTOL = 1.0e-13


def check_against_force(h, sim):
    T = TangentMatrix(sim)
    sim.evaluate_forces()
    T.assemble()
    A = T.to_scipy().toarray()
    Kfd = h.force_jacobian_fd(sim, T)
    scale = np.abs(Kfd).max()
    assert scale > 0
    np.testing.assert_allclose(A, Kfd, rtol=0, atol=FD_RTOL * scale)
    np.testing.assert_allclose(A, A.T, rtol=0, atol=SYM_RTOL * np.abs(A).max())
    return T, A


@pytest.mark.parametrize("material", ["LPS", "BOND_BASED"])
def test_analytic_tangent_is_the_derivative_of_the_force(h, material):
    sim = h.build(h.box_deck(getattr(h, material), shape=(4, 4, 3)))
    h.perturb(sim)
    T, A = check_against_force(h, sim)
    if material == "BOND_BASED":
        assert T.nnz < 9 * T.n * T.n  # bonded pairs only, not the family-by-family pattern


def test_lps_tangent_with_an_influence_function(h):
    tree = h.box_deck(h.LPS, shape=(4, 3, 3))
    tree["Discretization"]["Influence Function"] = "Parabolic Decay"
    sim = h.build(tree)
    h.perturb(sim, seed=3)
    check_against_force(h, sim)


@pytest.mark.parametrize("material", ["LPS", "BOND_BASED"])
def test_tangent_with_broken_bonds(h, material):
    tree = h.box_deck(getattr(h, material), shape=(4, 4, 3), damage={"Damage Model": "Critical Stretch", "Critical Stretch": 0.5})
    sim = h.build(tree)
    nl = sim.bonds
    rev = nl.reverse()
    rng = np.random.default_rng(1)
    broken = rng.choice(nl.num_bonds, nl.num_bonds // 5, replace=False)
    d = sim.fields.n("Bond_Damage")
    d[broken] = 1
    d[rev[broken]] = 1  # both ends: the model's damage is symmetric
    h.perturb(sim)
    sim.evaluate_forces()
    assert sim.fields["Bond_Damage"].sum() > 0
    check_against_force(h, sim)


@pytest.mark.parametrize("material", ["LPS", "BOND_BASED"])
def test_tangent_across_blocks_with_one_sided_bonds(h, tmp_path, material):
    sim = h.build(h.two_block_text_deck(tmp_path, getattr(h, material)), directory=tmp_path)
    assert (sim.bonds.reverse() < 0).any()  # some families are one-sided
    h.perturb(sim, seed=2)
    check_against_force(h, sim)


def test_partial_damage_analytic_against_peridigm_finite_differences(h):
    """Fractional bond damage (Peridigm's mixed (1-d)/(1-d)^2 factors): the analytic LPS tangent
    against Peridigm's per-point central differences of the force state."""
    tree = h.box_deck(h.LPS, shape=(4, 3, 3), damage={"Damage Model": "Critical Stretch", "Critical Stretch": 0.5})
    sim = h.build(tree)
    rng = np.random.default_rng(4)
    sim.fields.set("Bond_Damage", rng.uniform(0.0, 0.9, sim.bonds.num_bonds))
    h.perturb(sim)
    blk = sim.blocks[0]
    blk.material.precompute(blk.view)
    T = TangentMatrix(sim)
    T.assemble()
    A = T.to_scipy().toarray()
    F = TangentMatrix(sim)
    F._finite_difference(blk, 1.0e-6 * sim.discretization.min_element_radius)
    B = F.to_scipy().toarray()
    np.testing.assert_allclose(A, B, rtol=0, atol=FD_RTOL * np.abs(B).max())
    np.testing.assert_allclose(A, A.T, rtol=0, atol=SYM_RTOL * np.abs(A).max())


def test_finite_difference_path_when_the_deck_asks_for_it(h):
    """Apply Automatic Differentiation Jacobian: false gives Peridigm's central differences."""
    mat = dict(h.LPS, **{"Apply Automatic Differentiation Jacobian": False})
    sim = h.build(h.box_deck(mat, shape=(3, 3, 3)))
    h.perturb(sim)
    sim.evaluate_forces()
    assert sim.blocks[0].material.tangent(sim.blocks[0].view, None) is False
    T = TangentMatrix(sim)
    T.assemble()
    exact = h.build(h.box_deck(h.LPS, shape=(3, 3, 3)))
    exact.fields["Coordinates"][:] = sim.fields["Coordinates"]
    exact.evaluate_forces()
    E = TangentMatrix(exact)
    E.assemble()
    A, B = T.to_scipy().toarray(), E.to_scipy().toarray()
    np.testing.assert_allclose(A, B, rtol=0, atol=FD_RTOL * np.abs(B).max())


def test_kinematic_bc_treatment(h):
    """Rows and columns of prescribed dofs zeroed, their diagonal set to -(sum |K_kk|)/N_dof
    taken before any change (Peridigm's applyKinematicBC_InsertZerosAndSetDiagonal)."""
    sim = h.build(h.box_deck(h.LPS, shape=(3, 3, 2)))
    h.perturb(sim)
    sim.evaluate_forces()
    T = TangentMatrix(sim)
    T.assemble()
    A = T.to_scipy().toarray()
    rng = np.random.default_rng(5)
    fixed = rng.random((T.n, 3)) < 0.3
    D = T.apply_kinematic_bc(fixed)
    N = 3 * T.n
    np.testing.assert_allclose(D, -np.abs(np.diag(A)).sum() / N, rtol=1e-14)
    k = np.flatnonzero(fixed.reshape(-1))
    expected = A.copy()
    expected[k, :] = 0.0
    expected[:, k] = 0.0
    expected[k, k] = D
    np.testing.assert_array_equal(T.to_scipy().toarray(), expected)


def test_tangent_does_not_depend_on_the_thread_count(h):
    import numba

    sim = h.build(h.box_deck(h.LPS, shape=(4, 3, 3)))
    h.perturb(sim)
    sim.evaluate_forces()
    T = TangentMatrix(sim)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        T.assemble()
        one = T.data.copy()
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        T.assemble()
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(T.data, one)


def test_distributed_kernels_and_views_match_the_serial_ones(h):
    """The pieces the MPI path uses, run on one process: the BC kernel with a given D equals
    Peridigm's; the owned block and the matrix gathered to the root (mothership numbering) are
    the matrix; gathering and scattering a vector are inverse permutations."""
    from peridyn.solvers.linalg.bsr import abs_diagonal_sum_kernel, kinematic_bc_set_kernel

    sim = h.build(h.box_deck(h.LPS, shape=(4, 3, 2)))
    h.perturb(sim)
    sim.evaluate_forces()
    T = TangentMatrix(sim)
    T.assemble()
    A = T.to_scipy().toarray()
    m = sim.mothership_of_local[T.owned_local]
    dofs = (3 * m[:, None] + np.arange(3)).reshape(-1)
    G = T.gather_to_root().toarray()
    np.testing.assert_array_equal(G[np.ix_(dofs, dofs)], A)
    np.testing.assert_array_equal(T.owned_block().toarray(), A)
    v = np.random.default_rng(2).standard_normal(3 * T.n)
    full = T.gather_vector(v)
    np.testing.assert_array_equal(full[dofs], v)
    np.testing.assert_array_equal(T.scatter_vector(full), v)
    fixed = np.random.default_rng(5).random((T.n, 3)) < 0.3
    data = T.data.copy()
    D = (-1.0 * abs_diagonal_sum_kernel(data, T.diag_pos, T.n)) / (3 * T.n)
    kinematic_bc_set_kernel(T.indptr, T.indices, data, T.diag_pos, fixed, D, T.n)
    assert T.apply_kinematic_bc(fixed) == D
    np.testing.assert_array_equal(data, T.data)
