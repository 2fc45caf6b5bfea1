"""3x3 helpers and the Flanagan-Taylor kernel (PERIDIGM_CORRESPONDENCE.md §0.1, §4.2)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from peridyn.materials.correspondence import tensor as T
from peridyn.materials.correspondence.stress import elastic_stress_kernel

EMPTY = np.zeros(0)


def arr(t):
    return np.array(t, dtype=float).reshape(3, 3)


def flat(m):
    return np.ascontiguousarray(np.asarray(m, dtype=float).reshape(9))


# -- Inv3 -------------------------------------------------------------------------------------------
def test_inv3_matches_numpy_and_the_spec_formula(ref):
    rng = np.random.default_rng(1)
    for _ in range(200):
        M = rng.normal(size=(3, 3)) * 10.0 ** rng.uniform(-3, 3)
        inv, det, ok = T.inv3(flat(M))
        assert ok
        np.testing.assert_allclose(arr(inv), np.linalg.inv(M), rtol=1e-9, atol=1e-12 * np.abs(np.linalg.inv(M)).max())
        assert det == pytest.approx(np.linalg.det(M), rel=1e-10)
        r_inv, r_det, _ = ref.inv3(list(flat(M)))
        assert list(inv) == r_inv and det == r_det  # the minors/determinant formula, bit for bit


def test_inv3_singular_gives_zeros_and_a_failure():
    M = flat([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 5.0]])  # rank 2, det exactly 0.0
    inv, det, ok = T.inv3(M)
    assert not ok and det == 0.0 and inv == (0.0,) * 9
    inv, det, ok = T.inv3(flat(np.zeros((3, 3))))
    assert not ok and inv == (0.0,) * 9


# -- MatMul -----------------------------------------------------------------------------------------
def test_matmul_variants_match_numpy(ref):
    rng = np.random.default_rng(2)
    for _ in range(50):
        A = rng.normal(size=(3, 3))
        B = rng.normal(size=(3, 3))
        a, b = flat(A), flat(B)
        for got, want in (
            (T.matmul(a, b), A @ B),
            (T.matmul_nt(a, b), A @ B.T),
            (T.matmul_tn(a, b), A.T @ B),
            (T.matmul_scaled(a, b, 2.5), 2.5 * (A @ B)),
            (T.matmul_nt_scaled(a, b, -0.3), -0.3 * (A @ B.T)),
            (T.matmul_tn_scaled(a, b, 7.0), 7.0 * (A.T @ B)),
        ):
            np.testing.assert_allclose(arr(got), want, rtol=1e-13, atol=1e-14)
        la, lb = list(a), list(b)
        assert list(T.matmul(a, b)) == ref.mm(la, lb)
        assert list(T.matmul_nt(a, b)) == ref.mm(la, lb, tb=True)
        assert list(T.matmul_tn(a, b)) == ref.mm(la, lb, ta=True)
        assert list(T.matmul_nt_scaled(a, b, 0.7)) == ref.mm(la, lb, tb=True, alpha=0.7)


def test_matmul_sums_left_to_right():
    """(A_r0 B_0c + A_r1 B_1c) + A_r2 B_2c: with 1e16, 1, -1e16 only this order gives 0.0
    (1e16 + 1 rounds to 1e16); 1e16 + (1 - 1e16) or (1e16 - 1e16) + 1 would give 2 or 1."""
    a = flat([[1e16, 1.0, -1e16], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    ones = flat(np.ones((3, 3)))
    assert T.matmul(a, ones)[0] == 0.0
    assert T.matmul_nt(a, ones)[0] == 0.0
    assert T.matmul_tn(flat(arr(a).T), ones)[0] == 0.0


def test_alpha_is_applied_after_the_sum_and_skipped_for_one():
    rng = np.random.default_rng(3)
    differs = 0
    for _ in range(200):
        a, b = flat(rng.normal(size=(3, 3))), flat(rng.normal(size=(3, 3)))
        alpha = float(rng.uniform(0.1, 3.0))
        plain = T.matmul(a, b)
        scaled = T.matmul_scaled(a, b, alpha)
        assert scaled == tuple(v * alpha for v in plain)
        before = tuple((a[3 * r] * alpha * b[c] + a[3 * r + 1] * alpha * b[3 + c]) + a[3 * r + 2] * alpha * b[6 + c] for r in range(3) for c in range(3))
        differs += scaled != before
        assert T.matmul_scaled(a, b, 1.0) == plain
    assert differs > 0  # the two orders are distinguishable, so the check above means something


# -- Flanagan-Taylor ------------------------------------------------------------------------------
def spin(axis, rate):
    a = np.asarray(axis, float) / np.linalg.norm(axis) * rate
    return flat([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def rotate_for(L, nsteps, dt):
    """Run FT nsteps times from V = R = I with a constant L; checks V = I and d = 0 exactly on
    the way and that the elastic update keeps a zero stress at zero. Returns R."""
    V = T.IDENTITY
    R = T.IDENTITY
    sigma = np.zeros((1, 9))
    nxt = np.zeros((1, 9))
    for _ in range(nsteps):
        V, R, d = T.flanagan_taylor(L, V, R, dt)
        assert V == T.IDENTITY
        assert all(x == 0.0 for x in d)
        elastic_stress_kernel(0, 1, np.array([d]), sigma, dt, 1.6e11, 8.0e10, EMPTY, EMPTY, 0.0, nxt)
        sigma, nxt = nxt, sigma
    assert np.all(sigma == 0.0)
    return arr(R)


@pytest.mark.parametrize("axis", [(0.0, 0.0, 1.0), (1.0, 2.0, -3.0)])
def test_rigid_rotation_rate_integrates_to_the_closed_form_rotation_stress_free(ref, axis):
    """L = constant skew spin |w| = 2 about ``axis``, V = I: d = 0 and V = I exactly, so the stress
    stays zero; R approaches the 90-degree rotation about the axis with an error O(dt).

    Peridigm's Q = I + s1 Ω + s2 Ω² has s2 = -(1 - cos θ)/|Ω|² (θ = dt |Ω|; spec §4.2 step 8),
    the opposite sign of the exact exponential's, so Q = r Rot(φ) off the axis with
    r = |(2 - cos θ, sin θ)| = 1 + O(θ²) and φ = atan2(sin θ, 2 - cos θ) = θ + O(θ³): each step is
    right to O(dt²) and after N steps R = a aᵀ + r^N (cos Nφ (I - a aᵀ) + sin Nφ [a]x). Both the
    discrete closed form (to round-off) and the first-order convergence to the exact rotation
    are checked.
    """
    rate = 2.0
    a = np.asarray(axis) / np.linalg.norm(axis)
    Kx = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    errors = []
    for nsteps in (500, 1000, 2000):
        dt = (math.pi / 2.0) / rate / nsteps
        R = rotate_for(spin(axis, rate), nsteps, dt)
        th = dt * rate
        r = math.hypot(2.0 - math.cos(th), math.sin(th))
        phi = math.atan2(math.sin(th), 2.0 - math.cos(th))
        discrete = np.outer(a, a) + r**nsteps * (math.cos(nsteps * phi) * (np.eye(3) - np.outer(a, a)) + math.sin(nsteps * phi) * Kx)
        np.testing.assert_allclose(R, discrete, atol=1e-12)
        np.testing.assert_allclose(R @ a, a, atol=1e-12)  # the axis is kept
        errors.append(np.abs(R - ref.rodrigues(axis, math.pi / 2.0)).max())
    assert errors[-1] < 2e-3
    assert errors[1] / errors[0] == pytest.approx(0.5, rel=0.01)  # global error O(dt): local O(dt²)
    assert errors[2] / errors[1] == pytest.approx(0.5, rel=0.01)


def test_pure_stretch_rate_gives_d_equal_to_L_and_no_rotation():
    L = flat([[0.3, 0.1, -0.2], [0.1, -0.5, 0.05], [-0.2, 0.05, 0.7]])  # symmetric
    dt = 1e-3
    V1, R1, d = T.flanagan_taylor(L, T.IDENTITY, T.IDENTITY, dt)
    assert R1 == T.IDENTITY
    assert d == tuple(L)
    np.testing.assert_array_equal(arr(V1), np.eye(3) + dt * arr(L))


def levi_civita():
    e = np.zeros((3, 3, 3))
    for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        e[i, j, k] = 1.0
        e[i, k, j] = -1.0
    return e


def test_stretch_with_rotation_matches_flanagan_taylor_in_tensor_form():
    """Spin, stretch and a non-trivial V_N, R_N against F&T written with tensors (numpy):
    z_i = ε_ikj D_jm V_mk, w_i = -1/2 ε_ijk W_jk, ω = w + (tr V I - V)⁻¹ z, Ω_ij = ε_ikj ω_k,
    Q = I + sin(θ)/|ω| Ω - (1 - cos θ)/|ω|² Ω², R_NP1 = Q R_N, V_NP1 = V_N + dt (L V_N - V_N Ω),
    d = R_NP1ᵀ D R_NP1."""
    rng = np.random.default_rng(4)
    eps = levi_civita()
    for _ in range(20):
        L = arr(spin(rng.normal(size=3), 1.5)) + 0.3 * rng.normal(size=(3, 3))
        RN = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        B = rng.normal(size=(3, 3))
        VN = np.eye(3) + 0.05 * (B + B.T)
        dt = 1e-2
        V1, R1, d = T.flanagan_taylor(flat(L), flat(VN), flat(RN), dt)
        D = 0.5 * (L + L.T)
        W = 0.5 * (L - L.T)
        z = np.einsum("ikj,jm,mk->i", eps, D, VN)
        w = -0.5 * np.einsum("ijk,jk->i", eps, W)
        om = w + np.linalg.solve(np.trace(VN) * np.eye(3) - VN, z)
        Om = np.einsum("ikj,k->ij", eps, om)
        mag = np.linalg.norm(om)
        Q = np.eye(3) + math.sin(dt * mag) / mag * Om - (1.0 - math.cos(dt * mag)) / mag**2 * (Om @ Om)
        np.testing.assert_allclose(arr(R1), Q @ RN, atol=1e-14)
        np.testing.assert_allclose(arr(V1), VN + dt * (L @ VN - VN @ Om), atol=1e-14)
        np.testing.assert_allclose(arr(d), arr(R1).T @ D @ arr(R1), atol=1e-14)
        np.testing.assert_allclose(arr(d), arr(d).T, atol=1e-14)


def test_flanagan_taylor_follows_the_spec_bit_for_bit(ref):
    rng = np.random.default_rng(5)
    for k in range(100):
        L = rng.normal(size=9) * 10.0 ** rng.uniform(-3, 1)
        VN = flat(np.eye(3) + 0.05 * rng.normal(size=(3, 3)))
        RN = flat(np.linalg.qr(rng.normal(size=(3, 3)))[0])
        dt = float(10.0 ** rng.uniform(-6, -2))
        if k == 0:
            VN = flat(np.zeros((3, 3)))  # singular (tr V) I - V: ignored
        got = T.flanagan_taylor(L, VN, RN, dt)
        want = ref.ft(list(L), list(VN), list(RN), dt)
        for g, w in zip(got, want):
            assert list(g) == w
