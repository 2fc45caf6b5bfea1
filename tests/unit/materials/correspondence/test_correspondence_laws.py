"""The correspondence loop laws (issue #20) against the per-point helpers that stay hand-written for
the finite-difference tangents' probes (one family inside a parallel iteration): the same bits,
on both numba backends; and the corners of the laws (a point without bonds, failure codes)."""
from __future__ import annotations

import numpy as np
import pytest

from peridyn.core.influence import ONE, PARABOLIC_DECAY
from peridyn.kernels.numba_cpu import NumbaBackend, SerialNumbaBackend
from peridyn.materials.correspondence import bond_associated_kernels as BK
from peridyn.materials.correspondence import bond_associated_gradients as BKG
from peridyn.materials.correspondence import hypoelastic_kernels as HK
from peridyn.materials.correspondence.classic import BOND_STATES, BOND_STATES_HOURGLASS
from peridyn.materials.correspondence.forces import _force_state, _hourglass_bond, partial_stress_kernel
from peridyn.materials.correspondence.kinematics import kinematics_kernel, shape_tensor_kernel

EMPTY = np.zeros(0)
BACKENDS = [NumbaBackend(), SerialNumbaBackend()]
K, G = 160.0e9, 80.0e9


def cloud(ref, m=5, seed=0, h=1e-3):
    """A jittered lattice, per-point horizons (one-sided families), volumes, a deformation and
    velocities."""
    rng = np.random.default_rng(seed)
    x = ref.lattice(m, spacing=h, jitter=0.15, seed=seed)
    horizon = 2.015 * h * (1.0 + 0.05 * rng.random(len(x)))
    offsets, nbr = ref.brute_bonds(x, horizon)
    vol = h**3 * (1.0 + 0.2 * rng.random(len(x)))
    A = np.array([[0.01, 0.02, -0.01], [0.0, -0.015, 0.03], [0.02, 0.0, 0.01]])
    u = x @ A.T + 2e-6 * rng.standard_normal(x.shape)
    v = 50.0 * rng.standard_normal(x.shape)
    return rng, x, horizon, offsets, nbr, vol, u, v


def bond_tensors(ref, rng, nb, scale):
    """Random step-N bond states: stretch near I, rotations, symmetric stresses (nb, 9) each."""
    A = rng.standard_normal((nb, 3, 3))
    V = (np.eye(3) + 0.01 * (A + A.transpose(0, 2, 1))).reshape(nb, 9)
    R = np.array([ref.random_rotation(rng).ravel() for _ in range(nb)])
    A = rng.standard_normal((nb, 3, 3))
    S = (scale * (A + A.transpose(0, 2, 1))).reshape(nb, 9)
    return V, R, S


@pytest.mark.parametrize("backend", BACKENDS, ids=lambda b: b.name)
@pytest.mark.parametrize("damaged", [False, True])
@pytest.mark.parametrize("model", [HK.ELASTIC, HK.PERFECTLY_PLASTIC, HK.POWER_LAW])
def test_hypoelastic_laws_are_the_per_point_helpers_bit_for_bit(ref, backend, damaged, model):
    rng, x, horizon, offsets, nbr, vol, u, v = cloud(ref, seed=1)
    n, nb = len(x), len(nbr)
    y = x + u
    J_N = 1.0 + 0.01 * rng.standard_normal(n)
    bd = np.where(rng.random(nb) < 0.2, 1.0, 0.0) if damaged else EMPTY
    dt = 1e-7
    lo, hi = 10, n - 7

    def precompute_laws():
        phi, L, J1, m0, wv = np.zeros((nb, 3)), np.zeros((n, 9)), np.zeros(n), np.zeros(n), np.zeros(n)
        bad = HK.precompute_kernel(lo, hi, offsets, nbr, y, v, vol, horizon, J_N, bd, PARABOLIC_DECAY, EMPTY, dt, phi, L, J1, m0, wv,
                                   backend=backend, x=x)
        return bad, phi, L, J1, m0, wv

    def precompute_points():
        phi, L, J1, m0, wv = np.zeros((nb, 3)), np.zeros((n, 9)), np.zeros(n), np.zeros(n), np.zeros(n)
        bad = sum(HK.precompute_point(i, offsets, nbr, y, v, vol, horizon, J_N, bd, PARABOLIC_DECAY, EMPTY, offsets[lo], dt, phi, L, J1,
                                      m0, wv) for i in range(lo, hi))
        return bad, phi, L, J1, m0, wv

    got, want = precompute_laws(), precompute_points()
    for a, b in zip(got, want):
        np.testing.assert_array_equal(a, b)
    assert np.abs(got[2][lo:hi]).max() > 0.0
    phi, L, J1, m0, wv = np.zeros((len(nbr), 3)), np.zeros((n, 9)), np.zeros(n), np.zeros(n), np.zeros(n)
    HK.precompute_kernel(0, n, offsets, nbr, y, v, vol, horizon, J_N, bd, PARABOLIC_DECAY, EMPTY, dt, phi, L, J1, m0, wv)  # every family
    Vb, Rb, Sb = bond_tensors(ref, rng, nb, 1e8)
    eb = 0.001 * rng.random(nb) if model != HK.ELASTIC else EMPTY
    prm = (model, K, G, 50.0e6, 1.0e-3 if model == HK.POWER_LAW else 1.0, 0.2 if model == HK.POWER_LAW else 0.0)

    def outputs():
        return [np.zeros((nb, 9)) for _ in range(3)] + [np.zeros(nb) if model != HK.ELASTIC else EMPTY, np.zeros((n, 9)), np.zeros((nb, 3))]

    law = outputs()
    force = (v, vol, horizon, J_N, bd, PARABOLIC_DECAY, EMPTY, int(offsets[lo]), dt, L, m0, phi, Vb, Rb, Sb, eb, *prm, *law[:5])
    backend.kernel(HK.BOND_STRESS)(lo, hi, offsets, nbr, x, y, force, law[4])
    backend.kernel(HK.BOND_FORCE)(lo, hi, offsets, nbr, x, y, force, law[5])
    pts = outputs()
    for i in range(lo, hi):
        HK.bond_force_point(i, offsets, nbr, y, v, vol, horizon, J_N, bd, PARABOLIC_DECAY, EMPTY, offsets[lo], dt, L, m0, phi, Vb, Rb, Sb,
                            eb, *prm, *pts)
    for a, b in zip(law, pts):
        np.testing.assert_array_equal(a, b)
    assert np.isfinite(law[5]).all() and np.abs(law[5]).max() > 0.0 and np.abs(law[4][lo:hi]).max() > 0.0


def ba_inputs(ref, seed, damaged):
    rng, x, horizon, offsets, nbr, vol, u, v = cloud(ref, seed=seed)
    bond_damage = np.where(rng.random(len(nbr)) < 0.2, 1.0, 0.0) if damaged else EMPTY
    return rng, x, horizon, offsets, nbr, vol, u, v, bond_damage


@pytest.mark.parametrize("backend", BACKENDS, ids=lambda b: b.name)
@pytest.mark.parametrize("damaged", [False, True])
def test_bond_associated_weights_and_gradients_are_the_per_point_helpers_bit_for_bit(ref, backend, damaged):
    rng, x, horizon, offsets, nbr, vol, u, v, bd = ba_inputs(ref, 2, damaged)
    n, nb = len(x), len(nbr)
    lo, hi = 5, n - 3
    om, phi, m = np.zeros(nb), np.zeros((nb, 3)), np.zeros(n)
    BKG.initialize_kernel(lo, hi, offsets, nbr, x, vol, horizon, PARABOLIC_DECAY, EMPTY, bd, om, phi, m, backend=backend)
    om2, phi2 = np.zeros(nb), np.zeros((nb, 3))
    for i in range(lo, hi):
        BKG.gradient_weights_point(i, offsets, nbr, x, vol, horizon, PARABOLIC_DECAY, EMPTY, bd, om2, phi2)
    np.testing.assert_array_equal(om, om2)
    np.testing.assert_array_equal(phi, phi2)
    for i in range(lo, hi):
        acc = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            acc += om[b] * vol[nbr[b]]
        assert m[i] == acc
    # damage grows at every third point: those recompute ω and φ, the others keep theirs
    dN, dNP1 = np.zeros(n), np.zeros(n)
    dNP1[::3] = 0.5
    bd_new = np.where(rng.random(nb) < 0.3, 1.0, 0.0)
    rows = [np.zeros((n, 3)) for _ in range(6)]
    om_l, phi_l = om.copy(), phi.copy()
    BKG.precompute_kernel(lo, hi, offsets, nbr, x, vol, horizon, PARABOLIC_DECAY, EMPTY, dN, dNP1, bd_new, om_l, phi_l, u, v, *rows,
                         backend=backend)
    rows2 = [np.zeros((n, 3)) for _ in range(6)]
    om_p, phi_p = om.copy(), phi.copy()
    for i in range(lo, hi):
        if dNP1[i] - dN[i] > 1.0e-15:
            BKG.gradient_weights_point(i, offsets, nbr, x, vol, horizon, PARABOLIC_DECAY, EMPTY, bd_new, om_p, phi_p)
        BKG.deformation_gradient_point(i, offsets, nbr, vol, phi_p, u, v, *rows2)
    for a, b in zip([om_l, phi_l, *rows], [om_p, phi_p, *rows2]):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(om_l, om)


@pytest.mark.parametrize("backend", BACKENDS, ids=lambda b: b.name)
def test_bond_associated_deformation_gradient_of_a_point_without_bonds_is_the_identity(ref, backend):
    _, x, horizon, offsets, nbr, vol, u, v, _ = ba_inputs(ref, 3, False)
    n = len(x)
    keep = np.ones(len(nbr), dtype=bool)
    keep[offsets[7]:offsets[8]] = False  # point 7 loses its family
    counts = np.diff(offsets) - np.array([0] * 7 + [offsets[8] - offsets[7]] + [0] * (n - 8))
    offsets2 = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    nbr2 = nbr[keep]
    phi = np.random.default_rng(0).standard_normal((len(nbr2), 3))
    rows = [np.full((n, 3), 9.0) for _ in range(6)]
    BKG.precompute_kernel(0, n, offsets2, nbr2, x, vol, horizon, ONE, EMPTY, EMPTY, EMPTY, EMPTY, np.zeros(len(nbr2)), phi, u, v, *rows,
                         backend=backend)
    rows2 = [np.full((n, 3), 9.0) for _ in range(6)]
    for i in range(n):
        BKG.deformation_gradient_point(i, offsets2, nbr2, vol, phi, u, v, *rows2)
    for a, b in zip(rows, rows2):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(np.stack(rows[:3], axis=1)[7], np.eye(3))
    np.testing.assert_array_equal(np.stack(rows[3:], axis=1)[7], np.zeros((3, 3)))


def ba_force_case(ref, seed, damaged, model):
    rng, x, horizon, offsets, nbr, vol, u, v, bd = ba_inputs(ref, seed, damaged)
    n, nb = len(x), len(nbr)
    om, phi, m = np.zeros(nb), np.zeros((nb, 3)), np.zeros(n)
    BKG.initialize_kernel(0, n, offsets, nbr, x, vol, horizon, ONE, EMPTY, bd, om, phi, m)
    rows = [np.zeros((n, 3)) for _ in range(6)]
    BKG.precompute_kernel(0, n, offsets, nbr, x, vol, horizon, ONE, EMPTY, EMPTY, EMPTY, EMPTY, om, phi, u, v, *rows)
    Vb, Rb, Sb = bond_tensors(ref, rng, nb, 1e8)
    eb = 0.01 * rng.random(nb) if model != BK.ELASTIC else EMPTY
    return x, x + u, v, vol, m, om, phi, rows, offsets, nbr, Vb, Rb, Sb, eb


@pytest.mark.parametrize("backend", BACKENDS, ids=lambda b: b.name)
@pytest.mark.parametrize(("model", "p"), [(BK.ELASTIC, (0.0, 0.0, 0.0, 0.0)), (BK.PERFECT, (1.5e8, 0.0, 0.0, 0.0)),
                                          (BK.POWER_LAW, (1.2e8, 0.002, 0.2, 0.0)), (BK.SATURATION, (1.2e8, 3e8, 200.0, 1e9))])
def test_bond_associated_force_laws_are_bond_point_bit_for_bit(ref, backend, model, p):
    x, y, v, vol, m, om, phi, rows, offsets, nbr, Vb, Rb, Sb, eb = ba_force_case(ref, 4, True, model)
    n, nb = len(x), len(nbr)
    plastic = model != BK.ELASTIC
    dt = 1e-8

    def run(laws):
        out = [np.zeros((nb, 9)), np.zeros((nb, 9)), np.zeros((nb, 9)), np.zeros(nb) if plastic else EMPTY, np.zeros((nb, 9)),
               np.zeros((nb, 3))]
        if laws:
            I9 = np.tile(np.eye(3).ravel(), (n, 1))
            node = [np.zeros((n, 9)) for _ in range(5)]
            bad, code = BK.force_kernel(0, n, offsets, nbr, x, y, v, vol, m, om, phi, *rows, I9, I9, node[0], node[1], node[2],
                                        np.zeros((n, 9)), node[3], node[4], np.zeros(n), np.zeros(n) if plastic else EMPTY,
                                        np.zeros(n) if plastic else EMPTY, np.zeros(n) if plastic else EMPTY, np.zeros((0, 9)),
                                        np.zeros((0, 9)), Vb, Rb, out[0], out[1], Sb, out[2], eb, out[3], model, K, G, *p, dt, out[4],
                                        out[5], backend=backend)
            assert (bad, code) == (-1, 0)
        else:
            for i in range(n):
                assert BK.bond_point(i, offsets, nbr, x, y, v, vol, m, om, phi, *rows, Vb, Rb, out[0], out[1], Sb, out[2], eb, out[3], model,
                                     K, G, *p, dt, out[4], out[5]) == 0
        return out

    for a, b in zip(run(True), run(False)):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("backend", BACKENDS, ids=lambda b: b.name)
def test_bond_associated_failures_are_reported_as_by_the_hand_written_sequence(ref, backend):
    """A singular node F at point 20 and a singular bond F (F̄ = 0, η = 0) at point 40 whose own F
    is regular: the first point of a range with a problem is reported with its node's code, else
    its first failing bond's, as node_point then bond_point per point report them."""
    x, y, v, vol, m, om, phi, rows, offsets, nbr, Vb, Rb, Sb, eb = ba_force_case(ref, 5, False, BK.ELASTIC)
    n, nb = len(x), len(nbr)
    for r in rows[:3]:
        r[20] = 0.0
    i = 40
    j = nbr[offsets[i]]
    y = y.copy()
    for r in rows[:3]:
        r[j] = -r[i]
    y[j] = y[i]
    I9 = np.tile(np.eye(3).ravel(), (n, 1))

    def arrays():
        return ([np.zeros((n, 9)) for _ in range(6)], np.zeros(n), [np.zeros((nb, 9)) for _ in range(4)], np.zeros((nb, 3)))

    def laws(start):
        node, vm, bond, T = arrays()
        return BK.force_kernel(start, n, offsets, nbr, x, y, v, vol, m, om, phi, *rows, I9, I9, node[0], node[1], node[2], node[3], node[4],
                               node[5], vm, EMPTY, EMPTY, EMPTY, np.zeros((0, 9)), np.zeros((0, 9)), Vb, Rb, bond[0], bond[1], Sb, bond[2],
                               EMPTY, EMPTY, BK.ELASTIC, K, G, 0.0, 0.0, 0.0, 0.0, 1e-8, bond[3], T, backend=backend)

    def by_points(start):
        node, vm, bond, T = arrays()
        for k in range(start, n):
            a = BK.node_point(k, *rows, I9, I9, node[0], node[1], node[2], node[3], node[4], node[5], vm, EMPTY, EMPTY, EMPTY,
                              np.zeros((0, 9)), np.zeros((0, 9)), BK.ELASTIC, K, G, 0.0, 0.0, 0.0, 0.0, 1e-8)
            c = BK.bond_point(k, offsets, nbr, x, y, v, vol, m, om, phi, *rows, Vb, Rb, bond[0], bond[1], Sb, bond[2], EMPTY, EMPTY,
                              BK.ELASTIC, K, G, 0.0, 0.0, 0.0, 0.0, 1e-8, bond[3], T)
            if a or c:
                return k, a if a else c
        return -1, 0

    got = {start: laws(start) for start in (0, 11, 20, 21, 41, max(i, j) + 1)}
    assert got == {start: by_points(start) for start in got}
    assert got[20] == (20, BK.SINGULAR_NODE_F)
    assert BK.SINGULAR_BOND_F in {code for _, code in got.values()}


@pytest.mark.parametrize("backend", BACKENDS, ids=lambda b: b.name)
@pytest.mark.parametrize("c1", [0.0, 2.5e9])
def test_classic_bond_states_and_partial_stress_are_the_hand_written_bond_physics(ref, backend, c1):
    rng, x, horizon, offsets, nbr, vol, u, v = cloud(ref, seed=6)
    n, nb = len(x), len(nbr)
    y = x + u
    Kinv, F = np.zeros((n, 9)), np.zeros((n, 9))
    assert shape_tensor_kernel(0, n, offsets, nbr, x, y, vol, horizon, PARABOLIC_DECAY, EMPTY, Kinv, F, backend=backend) == -1
    A = 1e12 * rng.standard_normal((n, 9))
    T = np.zeros((nb, 3))
    backend.kernel(BOND_STATES_HOURGLASS if c1 != 0.0 else BOND_STATES)(0, n, offsets, nbr, x, x, (y, horizon, PARABOLIC_DECAY, EMPTY, A, F, c1), T)
    S = np.zeros((n, 9))
    partial_stress_kernel(0, n, offsets, nbr, x, vol, horizon, PARABOLIC_DECAY, EMPTY, A, S, backend=backend)
    for i in range(n):
        S_want = np.zeros(9)
        for b in range(offsets[i], offsets[i + 1]):
            j = nbr[b]
            tx, ty, tz, X0, X1, X2 = _force_state(A, i, x, j, horizon[i], PARABOLIC_DECAY, EMPTY, b)
            want = [tx, ty, tz]
            if c1 != 0.0:
                h = _hourglass_bond(i, j, x, y, F, c1, horizon[i])
                want = [want[k] + h[k] for k in range(3)]
            assert list(T[b]) == want
            for a, t in enumerate((tx, ty, tz)):
                for c, X in enumerate((X0, X1, X2)):
                    S_want[3 * a + c] += (t * X) * vol[j]
        assert list(S[i]) == list(S_want)


def test_both_backends_give_the_same_kinematics(ref):
    rng, x, horizon, offsets, nbr, vol, u, v = cloud(ref, seed=7)
    n = len(x)
    VN = np.tile(np.eye(3).ravel(), (n, 1)) + 0.01 * rng.standard_normal((n, 9))
    RN = np.array([ref.random_rotation(rng).ravel() for _ in range(n)])
    outs = []
    for backend in BACKENDS:
        out = [np.zeros((n, 9)) for _ in range(5)]
        assert kinematics_kernel(3, n - 2, offsets, nbr, x, x + u, v, vol, horizon, PARABOLIC_DECAY, EMPTY, VN, RN, 1e-6, *out,
                                 backend=backend) == (-1, -1)
        outs.append(out)
    for a, b in zip(*outs):
        np.testing.assert_array_equal(a, b)
