"""The computes' bond loops written as loop laws (issue #20): deformation gradient, neighborhood
volume and the J-integral's displacement gradient against plain bond-by-bond references, and
the same results on CPU threads and on one thread."""
import numpy as np
import pytest

from peridyn.computes.deformation_gradient import DEFORMATION_GRADIENT, DeformationGradient
from peridyn.computes.geometry import sequential_row_sum
from peridyn.computes.j_integral import displacement_gradient
from peridyn.kernels import default_backend
from peridyn.kernels.numba_cpu import SerialNumbaBackend
from peridyn.testing import build_simulation, cube_deck

ELASTIC = {"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 1.0}


@pytest.fixture(scope="module")
def sim():
    sim = build_simulation(cube_deck(ELASTIC, n=5))
    x = sim.fields["Model_Coordinates"]
    sim.fields["Coordinates"][:] = x + 0.02 * np.random.default_rng(3).standard_normal(x.shape)
    return sim


def test_deformation_gradient_matches_a_bond_by_bond_reference(sim):
    c = DeformationGradient()
    c.initialize(sim)
    F, Kinv = c._run(sim)
    nl, s = sim.bonds, sim.fields
    x, y, V = s["Model_Coordinates"], s["Coordinates"], s["Volume"]
    for i in range(sim.num_owned):
        js = nl.neighbors[nl.offsets[i] : nl.offsets[i + 1]]
        xi, eta = x[js] - x[i], y[js] - y[i]
        K = np.einsum("b,ba,bc->ac", V[js], xi, xi)  # omega = 1
        N = np.einsum("b,ba,bc->ac", V[js], eta, xi)
        np.testing.assert_allclose(Kinv[i].reshape(3, 3), np.linalg.inv(K), rtol=1e-10)
        np.testing.assert_allclose(F[i].reshape(3, 3), N @ np.linalg.inv(K), rtol=1e-10, atol=1e-12)


def test_deformation_gradient_is_the_same_on_one_thread(sim):
    nl, s, n = sim.bonds, sim.fields, sim.num_owned
    results = []
    for backend in (default_backend(), SerialNumbaBackend()):
        F, Kinv, singular, det = np.zeros((sim.num_local, 9)), np.zeros((sim.num_local, 9)), np.zeros(sim.num_local, np.int8), np.zeros(sim.num_local)
        args = (s["Coordinates"], s["Volume"], sim.horizon_local, sim.influence.kind, np.zeros(0), F, Kinv, singular)
        backend.kernel(DEFORMATION_GRADIENT)(0, n, nl.offsets, nl.neighbors, s["Bond_Length"], s["Model_Coordinates"], args, det)
        results.append((F, Kinv, det))
    for a, b in zip(*results):
        np.testing.assert_array_equal(a, b)
    assert np.all(results[0][2][:n] > 0.0)  # out: det K


def test_neighborhood_volume_sums_from_the_point_volume_in_bond_order(sim):
    nl, s = sim.bonds, sim.fields
    w = np.random.default_rng(5).random(nl.num_bonds) * 1e-3
    out = s["Volume"][: nl.num_points] + 1.0
    want = out.copy()
    for i in range(nl.num_points):
        acc = want[i]
        for b in range(nl.offsets[i], nl.offsets[i + 1]):
            acc += w[b]
        want[i] = acc
    sequential_row_sum(nl.offsets, nl.neighbors, s["Bond_Length"], s["Model_Coordinates"], w, out)
    np.testing.assert_array_equal(out, want)


def test_displacement_gradient_of_an_affine_field(sim):
    nl, s = sim.bonds, sim.fields
    x = s["Model_Coordinates"]
    A = np.array([[1e-3, 2e-4, 0.0], [-3e-4, 5e-4, 1e-4], [0.0, 2e-4, -1e-3]])
    y = x + x @ A.T + 0.1  # u = A x + translation
    pts = np.array([3, 7, 62, 100], dtype=np.int64)
    H = displacement_gradient(pts, nl.offsets, nl.neighbors, s["Bond_Length"], x, y, s["Volume"], np.zeros(0))
    assert H.shape == (4, 9)
    for h in H:
        np.testing.assert_allclose(h.reshape(3, 3), A, atol=1e-15)
    broken = np.ones(nl.num_bonds)  # every bond broken: no family, zero gradient
    np.testing.assert_array_equal(displacement_gradient(pts, nl.offsets, nl.neighbors, s["Bond_Length"], x, y, s["Volume"], broken), 0.0)
