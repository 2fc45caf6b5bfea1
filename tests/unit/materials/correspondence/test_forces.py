"""Force densities, Partial_Stress and the hourglass force in gather form
(PERIDIGM_CORRESPONDENCE.md §6 step 4, §7)."""
from __future__ import annotations

import numpy as np
import pytest

from peridyn.core.bonds import NeighborList
from peridyn.core.influence import ONE, PARABOLIC_DECAY
from peridyn.materials.correspondence.forces import (
    force_kernel,
    hourglass_kernel,
    partial_stress_kernel,
)
from peridyn.materials.correspondence.kinematics import shape_tensor_kernel

EMPTY = np.zeros(0)
K_BULK = 1.6e11
C_HG = 0.02


def random_cloud(ref, n=120, seed=0, shuffle=True):
    """Random points in the unit cube, per-point horizons 0.35-0.5 (one-sided families), rows in
    random order, random volumes; the transposed lists as the engine builds them."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.0, 1.0, (n, 3))
    horizon = rng.uniform(0.35, 0.5, n)
    offsets, neighbors = ref.brute_bonds(x, horizon, shuffle_seed=seed if shuffle else None)
    nl = NeighborList(offsets, neighbors)
    in_offsets, in_bonds = nl.transpose()
    volume = rng.uniform(0.5, 1.5, n) * 1e-3
    return x, horizon, nl.offsets, nl.neighbors, in_offsets, in_bonds, nl.sources(), volume


def test_one_sided_families_are_present(ref):
    x, _, offsets, neighbors, *_ = random_cloud(ref)
    rows = [set(neighbors[offsets[i]:offsets[i + 1]]) for i in range(len(x))]
    assert sum(i not in rows[j] for i in range(len(x)) for j in rows[i]) > 100


@pytest.mark.parametrize("kind", [ONE, PARABOLIC_DECAY])
def test_force_gather_conserves_momentum_and_equals_peridigms_scatter(ref, kind):
    x, horizon, offsets, neighbors, in_offsets, in_bonds, sources, volume = random_cloud(ref)
    n = len(x)
    A = np.random.default_rng(1).normal(size=(n, 9)) * 1e9
    f = np.zeros((n, 3))
    force_kernel(0, n, offsets, neighbors, in_offsets, in_bonds, sources, x, volume, horizon, kind, EMPTY, A, f)
    momentum = (volume[:, None] * f).sum(axis=0)
    assert np.abs(momentum).max() < 1e-13 * (volume[:, None] * np.abs(f)).sum()
    f_ref, S_ref = ref.scatter_forces(offsets, neighbors, x, volume, horizon, kind, EMPTY, A)
    # in_bonds ascending by source (NeighborList.transpose): the scatter's own summation order
    np.testing.assert_array_equal(f, f_ref)
    S = np.zeros((n, 9))
    partial_stress_kernel(0, n, offsets, neighbors, x, volume, horizon, kind, EMPTY, A, S)
    np.testing.assert_array_equal(S, S_ref)
    # any other in-bond order changes only the round-off
    perm_bonds = in_bonds.copy()
    rng = np.random.default_rng(2)
    for t in range(n):
        lo, hi = in_offsets[t], in_offsets[t + 1]
        perm_bonds[lo:hi] = rng.permutation(perm_bonds[lo:hi])
    f2 = np.zeros((n, 3))
    force_kernel(0, n, offsets, neighbors, in_offsets, perm_bonds, sources, x, volume, horizon, kind, EMPTY, A, f2)
    np.testing.assert_allclose(f2, f_ref, rtol=0, atol=1e-12 * np.abs(f_ref).max())


def test_force_subrange_and_table(ref):
    x, horizon, offsets, neighbors, in_offsets, in_bonds, sources, volume = random_cloud(ref, seed=3)
    n = len(x)
    rng = np.random.default_rng(4)
    A = rng.normal(size=(n, 9))
    table = rng.uniform(0.2, 2.0, len(neighbors))
    f = np.full((n, 3), 9.0)
    force_kernel(20, 60, offsets, neighbors, in_offsets, in_bonds, sources, x, volume, horizon, 3, table, A, f)
    assert np.all(f[:20] == 9.0) and np.all(f[60:] == 9.0)
    f_ref, _ = ref.scatter_forces(offsets, neighbors, x, volume, horizon, 3, table, A)
    np.testing.assert_array_equal(f[20:60], f_ref[20:60])


def test_uniform_stress_gives_no_interior_force_and_partial_stress_equals_P(ref):
    """A uniform Piola stress P with A_i = P K_i⁻¹ (K from the same weights ω V_j): the force
    density vanishes where i and all its neighbours have point-symmetric families (lattice
    points two sites or more from the surface, families reaching one site per axis, uniform
    volumes), not at the surface; and Partial_Stress_i = A_i K_i = P at every point."""
    h = 0.5
    x = ref.lattice(8, spacing=h)
    n = len(x)
    horizon = np.full(n, 1.515 * h)
    offsets, neighbors = ref.brute_bonds(x, horizon)
    nl = NeighborList(offsets, neighbors)
    in_offsets, in_bonds = nl.transpose()
    volume = np.full(n, h**3)
    Kinv, F = np.zeros((n, 9)), np.zeros((n, 9))
    assert shape_tensor_kernel(0, n, nl.offsets, nl.neighbors, x, x, volume, horizon, PARABOLIC_DECAY, EMPTY, Kinv, F) == -1
    P = np.array([[3.0, 1.0, -0.5], [0.4, -2.0, 0.7], [0.2, 0.1, 1.5]]) * 1e8
    A = np.einsum("ab,nbc->nac", P, Kinv.reshape(n, 3, 3)).reshape(n, 9)
    f = np.zeros((n, 3))
    force_kernel(0, n, nl.offsets, nl.neighbors, in_offsets, in_bonds, nl.sources(), x, volume, horizon, PARABOLIC_DECAY, EMPTY, A, f)
    index = np.rint(x / h)
    interior = np.all((index >= 2) & (index <= 5), axis=1)
    assert interior.sum() == 64
    scale = np.abs(f).max()
    assert np.abs(f[interior]).max() < 1e-12 * scale
    surface = np.any((index == 0) | (index == 7), axis=1)
    assert np.all(np.linalg.norm(f[surface], axis=1) > 1e-3 * scale)
    S = np.zeros((n, 9))
    partial_stress_kernel(0, n, nl.offsets, nl.neighbors, x, volume, horizon, PARABOLIC_DECAY, EMPTY, A, S)
    np.testing.assert_allclose(S.reshape(n, 3, 3), np.broadcast_to(P, (n, 3, 3)), rtol=0, atol=1e-12 * np.abs(P).max())


def deformed(ref, x, offsets, neighbors, volume, horizon, y):
    n = len(x)
    Kinv, F = np.zeros((n, 9)), np.zeros((n, 9))
    assert shape_tensor_kernel(0, n, offsets, neighbors, x, y, volume, horizon, ONE, EMPTY, Kinv, F) == -1
    return F


def test_hourglass_force_vanishes_for_affine_and_matches_the_scatter_otherwise(ref):
    x, horizon, offsets, neighbors, in_offsets, in_bonds, sources, volume = random_cloud(ref, seed=5)
    n = len(x)
    F0 = np.array([[1.05, 0.02, 0.0], [-0.03, 0.98, 0.01], [0.02, 0.0, 1.01]])
    y_aff = x @ F0.T + np.array([0.1, 0.2, -0.3])
    wobble = 0.01 * np.sin(7.0 * x[:, [1, 2, 0]])
    y = y_aff + wobble
    hg_aff = np.zeros((n, 3))
    hourglass_kernel(0, n, offsets, neighbors, in_offsets, in_bonds, sources, x, y_aff, volume, horizon,
                     deformed(ref, x, offsets, neighbors, volume, horizon, y_aff), K_BULK, C_HG, hg_aff)
    F = deformed(ref, x, offsets, neighbors, volume, horizon, y)
    hg = np.zeros((n, 3))
    hourglass_kernel(0, n, offsets, neighbors, in_offsets, in_bonds, sources, x, y, volume, horizon, F, K_BULK, C_HG, hg)
    assert np.abs(hg_aff).max() < 1e-11 * np.abs(hg).max()
    assert np.all(np.linalg.norm(hg, axis=1) > 0.0)
    momentum = (volume[:, None] * hg).sum(axis=0)
    assert np.abs(momentum).max() < 1e-13 * (volume[:, None] * np.abs(hg)).sum()
    want = ref.scatter_hourglass(offsets, neighbors, x, y, volume, horizon, F, K_BULK, C_HG)
    np.testing.assert_array_equal(hg, want)
    # subrange, and linear in the coefficient
    hg2 = np.full((n, 3), 4.0)
    hourglass_kernel(10, 30, offsets, neighbors, in_offsets, in_bonds, sources, x, y, volume, horizon, F, K_BULK, 2.0 * C_HG, hg2)
    assert np.all(hg2[:10] == 4.0) and np.all(hg2[30:] == 4.0)
    np.testing.assert_allclose(hg2[10:30], 2.0 * hg[10:30], rtol=1e-14, atol=0.0)


def test_hourglass_force_resists_a_zero_energy_mode(ref):
    """Moving one point off the affine field: its hourglass force pushes it back (h·η > 0 on its
    own bonds makes M < 0, i.e. a pull towards where F says the neighbours should be)."""
    x = ref.lattice(6, spacing=1.0)
    n = len(x)
    horizon = np.full(n, 2.015)
    offsets, neighbors = ref.brute_bonds(x, horizon)
    nl = NeighborList(offsets, neighbors)
    in_offsets, in_bonds = nl.transpose()
    volume = np.ones(n)
    k = 2 * 36 + 2 * 6 + 2  # an interior point
    y = x.copy()
    push = np.array([0.01, -0.02, 0.015])
    y[k] += push
    F = deformed(ref, x, nl.offsets, nl.neighbors, volume, horizon, y)
    hg = np.zeros((n, 3))
    hourglass_kernel(0, n, nl.offsets, nl.neighbors, in_offsets, in_bonds, nl.sources(), x, y, volume, horizon, F, K_BULK, C_HG, hg)
    assert hg[k] @ push < -0.9 * np.linalg.norm(hg[k]) * np.linalg.norm(push)
