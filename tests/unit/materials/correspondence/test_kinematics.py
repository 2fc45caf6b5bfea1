"""Shape tensor, deformation gradient, velocity gradient and the rotation update
(PERIDIGM_CORRESPONDENCE.md §3, §4)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from peridyn.core.influence import GAUSSIAN, ONE, PARABOLIC_DECAY, TABLE
from peridyn.materials.correspondence.kinematics import (
    kinematics_kernel,
    shape_tensor_kernel,
    velocity_gradient_kernel,
)

EMPTY = np.zeros(0)
F0 = np.array([[1.02, 0.03, -0.01], [-0.02, 0.97, 0.05], [0.04, 0.01, 1.08]])
C0 = np.array([0.3, -1.2, 2.5])


def make_cloud(ref, m=9, h=0.1, seed=0):
    rng = np.random.default_rng(seed)
    x = ref.lattice(m, spacing=h, jitter=0.1, seed=seed)
    horizon = 3.015 * h * (1.0 + 0.08 * rng.random(len(x)))
    offsets, neighbors = ref.brute_bonds(x, horizon)
    volume = h**3 * (1.0 + 0.2 * rng.random(len(x)))
    return x, horizon, offsets, neighbors, volume


def brute_K(ref, x, horizon, offsets, neighbors, volume, kind):
    K = np.zeros((len(x), 3, 3))
    for i in range(len(x)):
        js = neighbors[offsets[i]:offsets[i + 1]]
        xi = x[js] - x[i]
        w = ref.omega_np(kind, np.linalg.norm(xi, axis=1), horizon[i]) * volume[js]
        K[i] = (w[:, None] * xi).T @ xi
    return K


@pytest.mark.parametrize("kind", [ONE, PARABOLIC_DECAY, GAUSSIAN])
def test_affine_deformation_gives_F0_and_K_inverse_matches_numpy(ref, kind):
    x, horizon, offsets, neighbors, volume = make_cloud(ref)
    n = len(x)
    y = x @ F0.T + C0
    Kinv = np.zeros((n, 9))
    F = np.zeros((n, 9))
    assert shape_tensor_kernel(0, n, offsets, neighbors, x, y, volume, horizon, kind, EMPTY, Kinv, F) == -1
    # N = F0 K for an affine map, so F = F0 at every point (boundary points included)
    np.testing.assert_allclose(F.reshape(n, 3, 3), np.broadcast_to(F0, (n, 3, 3)), atol=1e-12)
    K = brute_K(ref, x, horizon, offsets, neighbors, volume, kind)
    want = np.linalg.inv(K).reshape(n, 9)
    scale = np.abs(want).max(axis=1, keepdims=True)
    np.testing.assert_allclose(Kinv / scale, want / scale, atol=1e-12)


def test_subrange_only_and_table_influence(ref):
    """[start, stop) only is written; the TABLE kind reads omega_table per bond."""
    x, horizon, offsets, neighbors, volume = make_cloud(ref, m=6)
    n = len(x)
    y = x @ F0.T
    table = np.random.default_rng(3).uniform(0.5, 1.5, len(neighbors))
    Kinv = np.full((n, 9), 7.0)
    F = np.full((n, 9), 7.0)
    assert shape_tensor_kernel(50, 120, offsets, neighbors, x, y, volume, horizon, TABLE, table, Kinv, F) == -1
    assert np.all(Kinv[:50] == 7.0) and np.all(Kinv[120:] == 7.0) and np.all(F[120:] == 7.0)
    np.testing.assert_allclose(F[50:120].reshape(-1, 3, 3), np.broadcast_to(F0, (70, 3, 3)), atol=1e-12)
    for i in (50, 77, 119):
        js = neighbors[offsets[i]:offsets[i + 1]]
        xi = x[js] - x[i]
        w = table[offsets[i]:offsets[i + 1]] * volume[js]
        np.testing.assert_allclose(Kinv[i].reshape(3, 3), np.linalg.inv((w[:, None] * xi).T @ xi), rtol=1e-10)


@pytest.mark.parametrize("kind", [ONE, PARABOLIC_DECAY, GAUSSIAN, TABLE])
def test_kinematics_follow_the_spec_bit_for_bit(ref, kind):
    x, horizon, offsets, neighbors, volume = make_cloud(ref, m=6, seed=1)
    n = len(x)
    rng = np.random.default_rng(2)
    y = x @ F0.T + 0.003 * rng.normal(size=x.shape)
    v = 0.5 * rng.normal(size=x.shape)
    table = rng.uniform(0.5, 1.5, len(neighbors)) if kind == TABLE else EMPTY
    VN = np.tile(np.eye(3).ravel(), (n, 1)) + 0.01 * rng.normal(size=(n, 9))
    RN = np.array([ref.random_rotation(rng).ravel() for _ in range(n)])
    dt = 1.3e-4
    out = [np.zeros((n, 9)) for _ in range(5)]
    assert kinematics_kernel(0, n, offsets, neighbors, x, y, v, volume, horizon, kind, table, VN, RN, dt, *out) == (-1, -1)
    Kinv, F, V1, R1, d = out
    L = np.zeros((n, 9))
    assert velocity_gradient_kernel(0, n, offsets, neighbors, x, v, volume, horizon, kind, table, Kinv, F, L) == -1
    for i in (0, 17, 100, n - 1):
        want = ref.kinematics_point(i, offsets, neighbors, x, y, v, volume, horizon, kind, table, VN[i], RN[i], dt)
        for name, got in (("Kinv", Kinv), ("F", F), ("V", V1), ("R", R1), ("d", d), ("L", L)):
            assert list(got[i]) == want[name], name


def test_affine_velocity_gives_L_and_a_symmetric_rate_is_unrotated(ref):
    """v = Ḟ0 x with L0 = Ḟ0 F0⁻¹ symmetric: L = L0 to round-off; from V = R = I, d = L0 and
    R_NP1 = I to round-off, V_NP1 = I + dt L0."""
    x, horizon, offsets, neighbors, volume = make_cloud(ref, m=7, seed=4)
    n = len(x)
    L0 = np.array([[0.4, 0.1, -0.2], [0.1, -0.3, 0.05], [-0.2, 0.05, 0.2]])
    Fdot0 = L0 @ F0
    y = x @ F0.T + C0
    v = x @ Fdot0.T + np.array([1.0, 2.0, 3.0])
    I9 = np.tile(np.eye(3).ravel(), (n, 1))
    dt = 1e-3
    Kinv, F, V1, R1, d = (np.zeros((n, 9)) for _ in range(5))
    assert kinematics_kernel(0, n, offsets, neighbors, x, y, v, volume, horizon, PARABOLIC_DECAY, EMPTY, I9, I9, dt, Kinv, F, V1, R1, d) == (-1, -1)
    L = np.zeros((n, 9))
    velocity_gradient_kernel(0, n, offsets, neighbors, x, v, volume, horizon, PARABOLIC_DECAY, EMPTY, Kinv, F, L)
    np.testing.assert_allclose(L.reshape(n, 3, 3), np.broadcast_to(L0, (n, 3, 3)), atol=1e-12)
    np.testing.assert_allclose(d.reshape(n, 3, 3), np.broadcast_to(L0, (n, 3, 3)), atol=1e-12)
    np.testing.assert_allclose(R1.reshape(n, 3, 3), np.broadcast_to(np.eye(3), (n, 3, 3)), atol=1e-14)
    np.testing.assert_allclose(V1.reshape(n, 3, 3), np.broadcast_to(np.eye(3) + dt * L0, (n, 3, 3)), atol=1e-14)


def test_rigid_rotation_of_the_cloud_is_a_pure_spin(ref):
    """y = R_θ x, v = W y (W skew, rate 3 about an oblique axis): F = R_θ, L = W, d = 0 to
    round-off, V stays I and R_NP1 = Q R_N with Q the spin over dt."""
    x, horizon, offsets, neighbors, volume = make_cloud(ref, m=6, seed=5)
    n = len(x)
    axis = np.array([1.0, -2.0, 0.5])
    Rth = ref.rodrigues(axis, 0.7)
    a = axis / np.linalg.norm(axis) * 3.0
    W = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    y = x @ Rth.T
    v = y @ W.T
    I9 = np.tile(np.eye(3).ravel(), (n, 1))
    RN = np.tile(Rth.ravel(), (n, 1))
    dt = 1e-4
    Kinv, F, V1, R1, d = (np.zeros((n, 9)) for _ in range(5))
    assert kinematics_kernel(0, n, offsets, neighbors, x, y, v, volume, horizon, ONE, EMPTY, I9, RN, dt, Kinv, F, V1, R1, d) == (-1, -1)
    np.testing.assert_allclose(F.reshape(n, 3, 3), np.broadcast_to(Rth, (n, 3, 3)), atol=1e-12)
    assert np.abs(d).max() < 1e-11 * 3.0
    np.testing.assert_allclose(V1.reshape(n, 3, 3), np.broadcast_to(np.eye(3), (n, 3, 3)), atol=1e-14)
    theta = 3.0 * dt
    Q = np.eye(3) + math.sin(theta) / 3.0 * W - (1.0 - math.cos(theta)) / 9.0 * (W @ W)  # Peridigm's Q (§4.2 step 8)
    np.testing.assert_allclose(R1.reshape(n, 3, 3), np.broadcast_to(Q @ Rth, (n, 3, 3)), atol=1e-13)


def test_singular_shape_tensor_and_deformation_gradient_are_flagged(ref):
    """det == 0.0 exactly: a family on one lattice line (K = diag(k, 0, 0)) or no family at all
    (K = 0) is a singular shape tensor; a family collapsed onto its point (N = 0) a singular F.
    The first flagged point of [start, stop) is returned."""
    x = ref.lattice(4)  # spacing 1, exact coordinates
    n = len(x)
    horizon = np.full(n, 1.5)
    offsets, neighbors = ref.brute_bonds(x, horizon)
    volume = np.ones(n)
    rows = [list(neighbors[offsets[i]:offsets[i + 1]]) for i in range(n)]
    rows[21] = [j for j in range(n) if j != 21 and np.all(x[j, 1:] == x[21, 1:])]  # same y and z
    rows[30] = []
    assert len(rows[21]) == 3
    offsets = np.concatenate([[0], np.cumsum([len(r) for r in rows])]).astype(np.int64)
    neighbors = np.array([j for r in rows for j in r], dtype=np.int32)
    Kinv, F, V1, R1, d = (np.zeros((n, 9)) for _ in range(5))
    I9 = np.tile(np.eye(3).ravel(), (n, 1))
    assert shape_tensor_kernel(0, n, offsets, neighbors, x, x, volume, horizon, ONE, EMPTY, Kinv, F) == 21
    assert np.all(Kinv[21] == 0.0) and np.all(F[21] == 0.0) and np.all(Kinv[30] == 0.0)
    assert shape_tensor_kernel(22, n, offsets, neighbors, x, x, volume, horizon, ONE, EMPTY, Kinv, F) == 30
    assert shape_tensor_kernel(31, n, offsets, neighbors, x, x, volume, horizon, ONE, EMPTY, Kinv, F) == -1
    assert kinematics_kernel(22, n, offsets, neighbors, x, x, x, volume, horizon, ONE, EMPTY, I9, I9, 1e-3, Kinv, F, V1, R1, d) == (30, 30)
    y = x.copy()
    y[neighbors[offsets[12]:offsets[13]]] = y[12]
    assert kinematics_kernel(10, 20, offsets, neighbors, x, y, x, volume, horizon, ONE, EMPTY, I9, I9, 1e-3, Kinv, F, V1, R1, d) == (-1, 12)
    assert np.all(F[12] == 0.0)
