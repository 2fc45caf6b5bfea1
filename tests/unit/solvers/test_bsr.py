"""Point-block sparse matrices (solvers/linalg/bsr.py): one implementation for every block size;
products, boundary conditions and damping against dense arithmetic for B = 1, 3 and 4, and the
product's summation order independent of the thread count."""
from __future__ import annotations

import numba
import numpy as np
import pytest
import scipy.sparse as sp

from peridyn.solvers.linalg.bsr import abs_diagonal_sum_kernel, bsr_matvec_kernel, damp_diagonal_kernel, kinematic_bc_set_kernel


def random_bsr(B: int, n: int = 30, seed: int = 0):
    rng = np.random.default_rng(seed)
    P = sp.random(n, n, density=0.2, random_state=seed, format="csr") + sp.identity(n, format="csr")
    P.sum_duplicates()
    P.sort_indices()
    indptr, indices = P.indptr.astype(np.int64), P.indices.astype(np.int32)
    data = rng.standard_normal((indices.size, B, B))
    rows = np.repeat(np.arange(n), np.diff(indptr))
    diag_pos = np.empty(n, dtype=np.int64)
    where = np.nonzero(indices == rows)[0]
    diag_pos[rows[where]] = where
    return indptr, indices, data, diag_pos


def dense(indptr, indices, data):
    B = data.shape[1]
    return sp.bsr_matrix((data, indices, indptr), shape=(B * (indptr.size - 1),) * 2).toarray()


@pytest.mark.parametrize("B", [1, 3, 4, 6])
def test_product_boundary_conditions_and_damping_are_the_dense_ones(B):
    indptr, indices, data, diag_pos = random_bsr(B)
    n = indptr.size - 1
    A = dense(indptr, indices, data)
    x = np.random.default_rng(1).standard_normal(B * n)
    out = np.full(B * n, np.nan)
    bsr_matvec_kernel(indptr, indices, data, x, out)
    np.testing.assert_allclose(out, A @ x, rtol=1e-12, atol=1e-12)

    assert abs_diagonal_sum_kernel(data, diag_pos, n) == pytest.approx(np.abs(np.diag(A)).sum(), rel=1e-14)
    fixed = np.random.default_rng(2).random((n, B)) < 0.3
    D = -7.5
    bc = data.copy()
    kinematic_bc_set_kernel(indptr, indices, bc, diag_pos, fixed, D, n)
    expect = A.copy()
    f = fixed.reshape(-1)
    expect[f, :] = 0.0
    expect[:, f] = 0.0
    expect[np.flatnonzero(f), np.flatnonzero(f)] = D
    np.testing.assert_array_equal(dense(indptr, indices, bc), expect)

    damped = data.copy()
    damp_diagonal_kernel(damped, diag_pos, 0.5, 0.1)
    d = np.diag(A) * 0.5
    expect = A.copy()
    np.fill_diagonal(expect, d + 0.1 * np.abs(d).max())
    np.testing.assert_allclose(dense(indptr, indices, damped), expect, rtol=1e-15, atol=0)


@pytest.mark.parametrize("B", [3, 4])
def test_product_is_the_same_on_one_and_two_threads(B):
    indptr, indices, data, _ = random_bsr(B, n=400, seed=3)
    x = np.random.default_rng(4).standard_normal(B * (indptr.size - 1))
    outs = []
    before = numba.get_num_threads()
    try:
        for threads in sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)}):
            numba.set_num_threads(threads)
            out = np.empty_like(x)
            bsr_matvec_kernel(indptr, indices, data, x, out)
            outs.append(out)
    finally:
        numba.set_num_threads(before)
    for out in outs[1:]:
        np.testing.assert_array_equal(out, outs[0])
    # each component summed from 0 over blocks, then columns, in ascending order (Epetra's)
    r = 7
    o = B * r
    acc = np.zeros(B)
    for p in range(indptr[r], indptr[r + 1]):
        for c in range(B):
            for d in range(B):
                acc[d] += data[p, d, c] * x[B * indices[p] + c]
    np.testing.assert_array_equal(outs[0][o : o + B], acc)
