"""The bond-stress damage models and Interface Aware written as loop laws (issue #20): the same
results on CPU threads and on one thread, and the Johnson Cook point sums against a
bond-by-bond reference."""
import numpy as np
import pytest

from peridyn.core.influence import GAUSSIAN, ONE, PARABOLIC_DECAY
from peridyn.damage.interface_aware import INTERFACE_AWARE
from peridyn.damage.johnson_cook import JOHNSON_COOK
from peridyn.damage.von_mises_stress import BOND_INVARIANTS, REFERENCE_WEIGHTED_VOLUME, VON_MISES_DAMAGE
from peridyn.kernels import default_backend
from peridyn.kernels.numba_cpu import SerialNumbaBackend
from peridyn.testing import build_simulation, cube_deck


@pytest.fixture(scope="module")
def bonds():
    sim = build_simulation(cube_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 1.0}, n=5))
    rng = np.random.default_rng(11)
    x = sim.fields["Model_Coordinates"]
    y = x + 0.03 * rng.standard_normal(x.shape)
    return sim.bonds, sim.fields["Bond_Length"], x, y, rng


def both_backends(law, nl, zeta, y, make_args, out_shape):
    """Runs ``law`` on fresh copies of the same inputs with both numba backends; returns the two
    (args, out) results."""
    results = []
    for backend in (default_backend(), SerialNumbaBackend()):
        args = make_args()
        out = np.zeros(out_shape)
        backend.kernel(law)(0, nl.num_points, nl.offsets, nl.neighbors, zeta, y, args, out)
        results.append((args, out))
    return results


def assert_same(results):
    (args_a, out_a), (args_b, out_b) = results
    np.testing.assert_array_equal(out_a, out_b)
    for a, b in zip(args_a, args_b):
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("kind", [ONE, PARABOLIC_DECAY, GAUSSIAN])
def test_von_mises_laws_on_one_thread(bonds, kind):
    nl, zeta, x, y, rng = bonds
    n, nb = x.shape[0], nl.num_bonds
    V, h, J, m_u = 1.0 + rng.random(n), 3.0 + rng.random(n), 0.5 + rng.random(n), 5.0 + rng.random(n)
    m_u[::5] = 0.0
    vm, d_n, S = 300.0 * rng.random(nb), rng.random(nb) * (rng.random(nb) < 0.3), rng.standard_normal((nb, 9))
    assert_same(both_backends(REFERENCE_WEIGHTED_VOLUME, nl, zeta, x, lambda: (V, h, kind), n))
    assert_same(both_backends(BOND_INVARIANTS, nl, zeta, y, lambda: (S, np.zeros(nb)), nb))
    res = both_backends(VON_MISES_DAMAGE, nl, zeta, y,
                        lambda: (V, J, h, kind, m_u, vm, 200.0, 1.2, 0.6, 0.3, d_n, np.zeros(nb), np.zeros(n)), n)
    assert_same(res)
    d = res[0][0][11]
    assert np.all(d >= d_n) and 0.0 < np.mean((d > 0) & (d < 1)) < 1.0
    assert np.all(res[0][1][::5] == 0.0)  # m_u = 0: no share


def test_johnson_cook_point_sums_by_bond_loop(bonds):
    nl, zeta, x, y, rng = bonds
    n, nb = x.shape[0], nl.num_bonds
    V, h, J, m_u = 1.0 + rng.random(n), 3.0 + rng.random(n), 0.5 + rng.random(n), 5.0 + rng.random(n)
    e_n, e_np1, tri, P_n = 0.1 * rng.random(nb), 0.1 * rng.random(nb), rng.standard_normal(nb), rng.random(nb)
    res = both_backends(JOHNSON_COOK, nl, zeta, y, lambda: (V, J, h, GAUSSIAN, m_u, e_n, e_np1, tri, 0.02, 0.01, 1.0, 0.3, 0.5, P_n,
                                                          np.zeros(nb), np.zeros(nb), np.full(n, 9.0), np.zeros(n)), n)
    assert_same(res)
    args, bbva = res[0]
    P, d, damage, flag = args[14], args[15], args[16], args[17]
    for i in range(0, nl.num_points, 7):
        bs = np.arange(nl.offsets[i], nl.offsets[i + 1])
        js = nl.neighbors[bs]
        L = np.linalg.norm(y[js] - y[i], axis=1)
        w = np.exp(-(L * L) / ((h[i] * h[i]) * 0.16))
        np.testing.assert_allclose(damage[i], np.sum(P[bs] * w / m_u[i] * J[js] * V[js]), rtol=1e-12)
        np.testing.assert_allclose(bbva[i], np.sum(d[bs] * w / m_u[i] * J[js] * V[js]), rtol=1e-12)
        assert flag[i] == (1.0 if bbva[i] > 0.5 else -1.0)


@pytest.mark.parametrize("thermal", [False, True])
def test_interface_aware_law_on_one_thread(bonds, thermal):
    nl, zeta, x, y, rng = bonds
    n, nb = x.shape[0], nl.num_bonds
    crit = 0.005 + 0.05 * rng.random(n)
    crit[::9] = 0.0
    d_n = (rng.random(nb) < 0.1).astype(np.uint8)
    d0 = (rng.random(nb) < 0.05).astype(np.uint8)
    deficient = (rng.random(n) < 0.1).astype(np.uint8)
    dT = rng.standard_normal(n) if thermal else np.zeros(0)
    res = both_backends(INTERFACE_AWARE, nl, zeta, y,
                        lambda: (0.02, crit, d_n, d0.copy(), dT, 0.01, deficient.copy(), np.zeros(n, np.uint8), nl.offsets), n)
    assert_same(res)
    args, damage = res[0]
    d = args[3]
    assert np.all(d >= np.maximum(d0, d_n))
    for i in range(nl.num_points):
        bs = slice(nl.offsets[i], nl.offsets[i + 1])
        assert damage[i] == pytest.approx(np.mean(d[bs]), rel=1e-14)
    assert np.all(args[7] <= 1) and np.all(args[6] >= deficient)
