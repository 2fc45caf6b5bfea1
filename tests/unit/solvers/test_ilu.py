"""ILU(0) (peridyn.solvers.linalg.ilu, AztecOO's "ilu" preconditioner) against a dense reference: the
textbook IKJ elimination restricted to the pattern, in plain numpy.

Tolerances. Factors and solves are compared at 1e-12 relative to the largest entry: the kernel
and the reference do the same operations in the same order except that the reference runs the
updates of a row over its whole pattern (j ascending) instead of row k's U entries, which gives
the same sums term by term; only the triangular solves differ in summation order (round-off
~1e-15 x condition). Exactness on no-fill patterns: L U = A to 1e-13, solve to 1e-11 (the
matrices are well conditioned).
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from peridyn.engine.run_services import RunServices
from peridyn.core.errors import PeridynError
from peridyn.solvers.linalg.ilu import ILU0, ZeroPivotError, csr_pattern

RTOL = 1.0e-12


# ------------------------------------------------------------------------------------------------
# the dense reference
# ------------------------------------------------------------------------------------------------
def dense_ilu0(A: np.ndarray, pattern: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ILU(0) of the dense (n, n) A on the boolean (n, n) pattern (diagonal included): IKJ
    Gaussian elimination, updates outside the pattern dropped. Returns (L, U) dense."""
    n = A.shape[0]
    W = np.where(pattern, A, 0.0).astype(float)
    for i in range(1, n):
        for k in range(i):
            if not pattern[i, k]:
                continue
            W[i, k] /= W[k, k]
            for j in range(k + 1, n):
                if pattern[i, j]:
                    W[i, j] -= W[i, k] * W[k, j]
    return np.tril(W, -1) + np.eye(n), np.triu(W)


def dense_solve(L: np.ndarray, U: np.ndarray, r: np.ndarray) -> np.ndarray:
    """(L U)^-1 r by plain forward and backward substitution."""
    n = r.shape[0]
    y = np.zeros(n)
    for i in range(n):
        y[i] = r[i] - L[i, :i] @ y[:i]
    z = np.zeros(n)
    for i in range(n - 1, -1, -1):
        z[i] = (y[i] - U[i, i + 1 :] @ z[i + 1 :]) / U[i, i]
    return z


def pattern_of(A) -> np.ndarray:
    """Boolean (n, n) stored pattern of the sparse A (explicit zeros included) plus the diagonal."""
    C = sp.csr_matrix(A, copy=True)
    C.sum_duplicates()
    P = sp.csr_matrix((np.ones(C.nnz), C.indices, C.indptr), shape=C.shape).toarray() != 0
    return P | np.eye(C.shape[0], dtype=bool)


def check_against_reference(A, seed: int = 0) -> ILU0:
    """ILU0(A)'s factors and solve equal the dense reference's (A sparse)."""
    Ad = sp.csr_matrix(A).toarray()
    Lr, Ur = dense_ilu0(Ad, pattern_of(A))
    M = ILU0(A)
    L, U = (x.toarray() for x in M.factors())
    scale = np.abs(Ad).max()
    np.testing.assert_allclose(L, Lr, rtol=0, atol=RTOL * max(1.0, np.abs(Lr).max()))
    np.testing.assert_allclose(U, Ur, rtol=0, atol=RTOL * scale)
    r = np.random.default_rng(seed).standard_normal(Ad.shape[0])
    z_ref = dense_solve(Lr, Ur, r)
    np.testing.assert_allclose(M.solve(r), z_ref, rtol=0, atol=RTOL * np.abs(z_ref).max())
    return M


# ------------------------------------------------------------------------------------------------
# random test matrices
# ------------------------------------------------------------------------------------------------
def random_pattern_matrix(n: int, density: float, rng, *, symmetric: bool = False, dominance: float = 1.5) -> np.ndarray:
    """Dense (n, n) with random sparse off-diagonal entries and a diagonal ``dominance`` times
    the off-diagonal row sums (nonsingular pivots throughout the incomplete factorization)."""
    M = np.where(rng.random((n, n)) < density, rng.uniform(-1.0, 1.0, (n, n)), 0.0)
    np.fill_diagonal(M, 0.0)
    if symmetric:
        M = M + M.T
    d = dominance * np.abs(M).sum(axis=1) + 0.1
    return M + np.diag(d * (rng.choice([-1.0, 1.0], n) if not symmetric else 1.0))


def scrambled_csr(Ad: np.ndarray, rng, *, explicit_zeros: int = 0, duplicates: int = 0) -> sp.csr_matrix:
    """Ad as a CSR matrix whose column indices are shuffled within each row, with
    ``explicit_zeros`` extra stored zeros and ``duplicates`` entries split into two halves."""
    n = Ad.shape[0]
    rows, cols = np.nonzero(Ad)
    vals = Ad[rows, cols]
    zr, zc = np.nonzero((Ad == 0) & ~np.eye(n, dtype=bool))
    pick = rng.choice(zr.size, min(explicit_zeros, zr.size), replace=False)
    rows, cols, vals = np.concatenate([rows, zr[pick]]), np.concatenate([cols, zc[pick]]), np.concatenate([vals, np.zeros(pick.size)])
    split = rng.choice(vals.size, min(duplicates, vals.size), replace=False)
    half = vals[split] * 0.5
    vals[split] -= half
    rows, cols, vals = np.concatenate([rows, rows[split]]), np.concatenate([cols, cols[split]]), np.concatenate([vals, half])
    indptr = np.zeros(n + 1, dtype=np.int32)
    np.add.at(indptr, rows + 1, 1)
    indptr = np.cumsum(indptr).astype(np.int32)
    indices = np.empty(rows.size, dtype=np.int32)
    data = np.empty(rows.size)
    for i in range(n):
        sel = np.nonzero(rows == i)[0]
        sel = sel[rng.permutation(sel.size)]
        indices[indptr[i] : indptr[i + 1]] = cols[sel]
        data[indptr[i] : indptr[i + 1]] = vals[sel]
    A = sp.csr_matrix((data, indices, indptr), shape=(n, n))
    A.has_sorted_indices = False
    return A


@pytest.mark.parametrize("seed", range(4))
def test_diagonally_dominant_nonsymmetric(seed):
    rng = np.random.default_rng(seed)
    Ad = random_pattern_matrix(40, 0.12, rng)
    check_against_reference(sp.csr_matrix(Ad), seed)


@pytest.mark.parametrize("seed", range(3))
def test_spd_factors_are_symmetric(seed):
    """On an SPD matrix ILU(0) is the incomplete Cholesky factorization in LDL^T form:
    U = diag(U) L^T."""
    rng = np.random.default_rng(10 + seed)
    Ad = random_pattern_matrix(35, 0.1, rng, symmetric=True, dominance=1.1)
    assert np.all(np.linalg.eigvalsh(Ad) > 0)
    M = check_against_reference(sp.csr_matrix(Ad), seed)
    L, U = (x.toarray() for x in M.factors())
    np.testing.assert_allclose(U, np.diag(np.diag(U)) @ L.T, rtol=0, atol=1e-13 * np.abs(U).max())


@pytest.mark.parametrize("seed", range(3))
def test_unsorted_indices_duplicates_and_explicit_zeros(seed):
    """Input CSR with shuffled column indices, duplicate entries (summed) and stored zeros (part
    of the pattern: they receive updates that would otherwise be dropped)."""
    rng = np.random.default_rng(20 + seed)
    Ad = random_pattern_matrix(30, 0.15, rng)
    A = scrambled_csr(Ad, rng, explicit_zeros=60, duplicates=25)
    np.testing.assert_array_equal(A.toarray(), Ad)
    M = check_against_reference(A, seed)
    # the explicit zeros matter: without them (pattern = nonzeros) the factors differ
    Lr, Ur = dense_ilu0(Ad, (Ad != 0) | np.eye(30, dtype=bool))
    L, U = (x.toarray() for x in M.factors())
    assert np.abs(L - Lr).max() + np.abs(U - Ur).max() > 1e-6
    assert A.has_sorted_indices is False  # the input is left as it was


def test_missing_diagonal_is_a_zero_in_the_pattern():
    """As in AztecOO's MSR storage the diagonal is always in the pattern: a row without a
    stored diagonal gets its pivot from the elimination."""
    A = sp.csr_matrix(np.array([[2.0, 1.0, 0.0], [4.0, 0.0, 1.0], [0.0, 1.0, 3.0]]))
    A.eliminate_zeros()
    assert A[1, 1] == 0 and A.nnz == 6
    M = check_against_reference(A)
    assert M.factors()[1].toarray()[1, 1] == pytest.approx(-2.0)
    _, indices, _ = csr_pattern(A)
    assert indices.size == 7


def test_bsr_input_keeps_the_block_pattern():
    """A 3x3-block BSR matrix (the tangent's format): every entry of every stored block is in
    the pattern, zeros included."""
    rng = np.random.default_rng(5)
    nb = 8
    mask = (rng.random((nb, nb)) < 0.35) | np.eye(nb, dtype=bool)
    blocks = rng.uniform(-1, 1, (nb, nb, 3, 3)) * (rng.random((nb, nb, 3, 3)) < 0.7)
    Ad = np.zeros((3 * nb, 3 * nb))
    for a, b in zip(*np.nonzero(mask)):
        Ad[3 * a : 3 * a + 3, 3 * b : 3 * b + 3] = blocks[a, b]
    Ad += np.diag(1.5 * np.abs(Ad).sum(axis=1) + 0.1)
    A = sp.bsr_matrix(Ad, blocksize=(3, 3))
    A = sp.bsr_matrix((A.data, A.indices, A.indptr), shape=A.shape)  # keep stored zeros
    assert A.nnz == 9 * mask.sum()
    M = check_against_reference(A)
    assert M.indices.size == 9 * mask.sum()


# ------------------------------------------------------------------------------------------------
# no fill: ILU(0) is the exact LU
# ------------------------------------------------------------------------------------------------
def tridiagonal(n: int, rng) -> np.ndarray:
    return np.diag(rng.uniform(3, 4, n)) + np.diag(rng.uniform(-1, 1, n - 1), 1) + np.diag(rng.uniform(-1, 1, n - 1), -1)


def arrow(n: int, rng) -> np.ndarray:
    """Diagonal plus a dense last row and column: eliminating in order creates no fill."""
    Ad = np.diag(rng.uniform(3, 4, n))
    Ad[-1, :-1] = rng.uniform(-1, 1, n - 1)
    Ad[:-1, -1] = rng.uniform(-1, 1, n - 1)
    Ad[-1, -1] = n
    return Ad


@pytest.mark.parametrize("make", [tridiagonal, arrow])
def test_no_fill_pattern_gives_the_exact_lu(make):
    rng = np.random.default_rng(7)
    Ad = make(50, rng)
    M = check_against_reference(sp.csr_matrix(Ad))
    L, U = M.factors()
    np.testing.assert_allclose((L @ U).toarray(), Ad, rtol=0, atol=1e-13 * np.abs(Ad).max())
    r = rng.standard_normal(50)
    x = np.linalg.solve(Ad, r)
    np.testing.assert_allclose(M.solve(r), x, rtol=0, atol=1e-11 * np.abs(x).max())


def test_ilu0_is_exact_on_the_pattern():
    """L U - A vanishes on A's pattern (the defining property) and not off it (there was fill)."""
    rng = np.random.default_rng(8)
    Ad = random_pattern_matrix(40, 0.15, rng)
    M = ILU0(sp.csr_matrix(Ad))
    L, U = M.factors()
    E = (L @ U).toarray() - Ad
    P = pattern_of(sp.csr_matrix(Ad))
    assert np.abs(E[P]).max() < 1e-13 * np.abs(Ad).max()
    assert np.abs(E[~P]).max() > 1e-6


# ------------------------------------------------------------------------------------------------
# pivots, shapes, empty
# ------------------------------------------------------------------------------------------------
def test_zero_pivot_raises_naming_the_row():
    with pytest.raises(ZeroPivotError, match="zero pivot in row 0 of the 2 x 2") as e:
        ILU0(sp.csr_matrix(np.array([[0.0, 1.0], [1.0, 0.0]])))
    assert isinstance(e.value, PeridynError) and e.value.row == 0
    # a pivot that becomes zero in the elimination
    with pytest.raises(ZeroPivotError, match="zero pivot in row 2 ") as e:
        ILU0(sp.csr_matrix(np.array([[1.0, 0.0, 2.0], [0.0, 1.0, 0.0], [3.0, 0.0, 6.0]])))
    assert e.value.row == 2


def test_overflowing_factors_raise_instead_of_inf():
    """A tiny pivot is used as it is (as AztecOO) but non-finite factors are an error."""
    A = sp.csr_matrix(np.array([[1e-300, 1e300], [1e300, 1.0]]))
    with pytest.raises(ZeroPivotError, match="row 1 .* not finite"):
        ILU0(A)
    tiny = np.array([[1e-12, 1.0], [1.0, 1.0]])  # tiny, finite: accepted, exact (no fill)
    M = ILU0(sp.csr_matrix(tiny))
    r = np.array([1.0, 2.0])
    np.testing.assert_allclose(tiny @ M.solve(r), r, rtol=1e-3)


def test_aztec_diagonal_thresholds():
    """AZ_athresh/AZ_rthresh: d -> d rthresh + sign(d) athresh (sign(0) = +) before factoring."""
    Ad = np.array([[0.0, 1.0, 0.0], [1.0, -2.0, 1.0], [0.0, 1.0, 4.0]])
    M = ILU0(sp.csr_matrix(Ad), athresh=0.5, rthresh=2.0)
    Ap = Ad.copy()
    Ap[np.diag_indices(3)] = [0.5, -4.5, 8.5]
    Lr, Ur = dense_ilu0(Ap, pattern_of(sp.csr_matrix(Ad)))
    np.testing.assert_allclose(M.factors()[1].toarray(), Ur, rtol=0, atol=1e-15)
    np.testing.assert_allclose(M.factors()[0].toarray(), Lr, rtol=0, atol=1e-15)


def test_empty_matrix_and_shapes():
    M = ILU0(sp.csr_matrix((0, 0)))
    assert M.shape == (0, 0)
    assert M.solve(np.zeros(0)).shape == (0,)
    M = ILU0(sp.csr_matrix(np.array([[2.0]])))
    np.testing.assert_array_equal(M.solve(np.array([3.0])), [1.5])
    with pytest.raises(ValueError, match="shape"):
        M.solve(np.zeros(2))
    with pytest.raises(ValueError, match="square"):
        ILU0(sp.csr_matrix(np.ones((2, 3))))
    with pytest.raises(TypeError):
        ILU0(np.eye(2))


def test_solve_in_place():
    rng = np.random.default_rng(9)
    M = ILU0(sp.csr_matrix(random_pattern_matrix(20, 0.2, rng)))
    r = rng.standard_normal(20)
    z = M.solve(r)
    out = r.copy()
    assert M.solve(out, out=out) is out
    np.testing.assert_array_equal(out, z)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(n=st.integers(1, 12), density=st.floats(0.0, 0.6), seed=st.integers(0, 2**32 - 1), dominance=st.floats(1.05, 3.0))
def test_hypothesis_random_small_matrices(n, density, seed, dominance):
    rng = np.random.default_rng(seed)
    Ad = random_pattern_matrix(n, density, rng, dominance=dominance)
    check_against_reference(scrambled_csr(Ad, rng, explicit_zeros=n, duplicates=n // 2), seed % 1000)


# ------------------------------------------------------------------------------------------------
# a tangent matrix and the NOX preconditioner
# ------------------------------------------------------------------------------------------------
def test_owned_block_of_a_tangent(h):
    """The tangent of a perturbed box with kinematic BCs (BSR, 3x3 blocks, explicit zeros):
    the rows and columns of a contiguous range of points (what a rank owns, in global-id
    order) and the whole matrix."""
    from peridyn.solvers.linalg.tangent import TangentMatrix

    sim = h.build(h.box_deck(h.LPS, shape=(4, 3, 3)))
    h.perturb(sim)
    sim.evaluate_forces()
    T = TangentMatrix(sim)
    T.assemble()
    fixed = np.zeros((T.n, 3), dtype=bool)
    fixed[:3] = True
    T.apply_kinematic_bc(fixed)
    A = T.to_scipy(copy=True)
    assert (A.tocsr().data == 0).any()  # zeroed BC rows/columns stay in the pattern
    check_against_reference(A)
    rows = np.arange(3 * 7, 3 * 25)  # points 7..24: a rank's owned block
    check_against_reference(A.tocsr()[rows][:, rows])


def test_nox_aztec_ilu_preconditioner_is_ilu0_of_the_tangent(h):
    """NOXQuasiStatic's "Aztec Preconditioner: ilu" (serially: the whole BC-modified tangent)."""
    from peridyn.core.state import SolverState
    from peridyn.solvers.implicit.nox import NOXRun

    tree = h.box_deck(h.LPS, shape=(5, 3, 3))
    tree["Boundary Conditions"] = {
        "Left Node Set": "1 2 3 4 5 6 7 8 9",
        **{f"L{c}": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": c, "Value": "0.0"} for c in "xyz"},
    }
    lin = {"Preconditioner": "AztecOO", "Aztec Preconditioner": "ilu"}
    tree["Solver"] = {"Final Time": 1.0, "NOXQuasiStatic": {"Number of Load Steps": 1, "Direction": {"Method": "Newton", "Newton": {"Linear Solver": lin}}}}
    sim = h.build(tree)
    entry = sim.deck.solvers[0]
    run = NOXRun(entry.cls(entry.params, section=entry.section), sim, SolverState(), RunServices.of(sim, write=False))
    h.perturb(sim)
    s = np.zeros(3 * run.n)
    run.jacobian(s)
    apply = run.aztec_preconditioner()
    Ad = run.problem.tangent.to_scipy(copy=True).toarray()
    Lr, Ur = dense_ilu0(Ad, pattern_of(run.problem.tangent.to_scipy()))
    r = np.random.default_rng(3).standard_normal(Ad.shape[0])
    z_ref = dense_solve(Lr, Ur, r)
    np.testing.assert_allclose(apply(r), z_ref, rtol=0, atol=RTOL * np.abs(z_ref).max())
