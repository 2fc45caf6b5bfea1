"""Exact results of the elastic models: the hand-calculated two-point case, uniform expansion,
small homogeneous strains in the bulk."""
import numpy as np
import pytest

from peridyn.testing import build_simulation, cube_deck

K, MU = 130.0e9, 78.0e9


def two_points(material):
    tree = cube_deck(material, n=1)
    g = tree["Discretization"]["TensorProduct3DMeshGenerator"]
    g.update({"X Length": 2.0, "Number Points X": 2, "Y Length": 1.0, "Z Length": 1.0})
    tree["Blocks"]["B"]["Horizon"] = 1.5
    return build_simulation(tree)


def test_two_points_lps_hand_calculation():
    """x0 = 0.5, x1 = 1.5, V = 1, omega = 1: m = 1; stretching the bond by e gives
    theta = 3e at both points, a = 15 mu, c = 3e (3K - 5 mu) and t = c zeta + a e = 9 K e at each
    end, so the points pull on each other with 18 K e; the stored energy is 9 K e^2 in all."""
    sim = two_points({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": K, "Shear Modulus": MU})
    e = 1.0e-4
    x = sim.fields["Model_Coordinates"]
    np.testing.assert_array_equal(x[:, 0], [0.5, 1.5])
    y = sim.fields["Coordinates"]
    y[1, 0] += e
    f = sim.evaluate_forces()
    np.testing.assert_allclose(sim.fields["Weighted_Volume"], [1.0, 1.0], rtol=1e-15)
    np.testing.assert_allclose(sim.fields["Dilatation"], [3 * e, 3 * e], rtol=1e-10)
    np.testing.assert_allclose(f[:, 0], [18 * K * e, -18 * K * e], rtol=1e-10)
    np.testing.assert_allclose(f[:, 1:], 0.0, atol=0.0)
    np.testing.assert_allclose(sim.stored_energy(), 9 * K * e * e, rtol=1e-10)


def test_two_points_bond_based_hand_calculation():
    """c = 18 K / (pi delta^4); the pair force is c s V = c e (|xi| = 1)."""
    sim = two_points({"Material Model": "Elastic Bond Based", "Density": 1.0, "Bulk Modulus": K})
    c = 18 * K / (np.pi * 1.5**4)
    e = 2.0e-4
    sim.fields["Coordinates"][1, 0] += e
    f = sim.evaluate_forces()
    np.testing.assert_allclose(f[:, 0], [c * e, -c * e], rtol=1e-12)
    np.testing.assert_allclose(sim.stored_energy(), 0.5 * c * e * e, rtol=1e-10)


@pytest.mark.parametrize("influence", ["One", "Parabolic Decay", "Gaussian", "1.0/zeta"])
def test_uniform_expansion_gives_exact_dilatation_everywhere(influence):
    """y = (1 + eps) x: e = eps |xi| for every bond, so theta = 3 eps exactly, surface included."""
    tree = cube_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": K, "Shear Modulus": MU}, n=6)
    tree["Discretization"]["Influence Function"] = influence
    sim = build_simulation(tree)
    eps = 1.0e-3
    sim.fields["Coordinates"][:] = sim.fields["Model_Coordinates"] * (1 + eps)
    sim.evaluate_forces()
    np.testing.assert_allclose(sim.fields["Dilatation"], 3 * eps, rtol=1e-12)


def test_linear_displacement_gives_the_exact_dilatation_in_the_bulk():
    """y = x + H x with a small general H: in the bulk (full, symmetric families) theta = tr H
    up to the geometric nonlinearity O(|H|^2)."""
    n = 15
    sim = build_simulation(cube_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": K, "Shear Modulus": MU}, n=n))
    H = 1e-6 * np.array([[1.0, 0.4, -0.3], [0.2, -2.0, 0.5], [0.1, 0.7, 0.5]])
    x = sim.fields["Model_Coordinates"]
    sim.fields["Coordinates"][:] = x + x @ H.T
    sim.evaluate_forces()
    interior = np.all((x > 3.5) & (x < n - 3.5), axis=1)
    assert interior.sum() > 0
    np.testing.assert_allclose(sim.fields["Dilatation"][interior], np.trace(H), rtol=1e-5)
    # and a homogeneous deformation produces no force where every neighbor's family is full
    deep = np.all((x > 6.5 - 0.1) & (x < n - 6.5 + 0.1), axis=1)
    assert deep.sum() > 0
    f = sim.fields["Force_Density"]
    np.testing.assert_allclose(f[deep], 0.0, atol=1e-4 * np.abs(f).max())
