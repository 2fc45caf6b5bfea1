"""The Diffusion material: parameters, fields, the flux divergence by hand, its Jacobian, the
gather and conservation properties, the improved-quadrature weights and the refusal of
explicit dynamics."""
import math

import numpy as np
import pytest

from peridyn.core.errors import InputError, InstabilityError
from peridyn.testing import build_simulation, cube_deck

KAPPA = 2.5
DIFFUSION = {"Material Model": "Diffusion", "Coefficient": KAPPA}


def model(shape=(5, 5, 5), spacing=1.0, horizon=3.015, improved=False, **kw):
    material = dict(DIFFUSION, **({"Use Improved Quadrature": True} if improved else {}), **kw)
    return build_simulation(cube_deck(material, shape=shape, spacing=spacing, horizon_factor=horizon))


def flux(sim, T):
    sim.fields["Temperature"][: sim.num_owned] = T
    sim.evaluate_forces()
    return sim.fields["Flux_Divergence"][: sim.num_owned].copy()


def lattice_second_moment(m: float) -> float:
    """S = 6/(pi m^4) sum_{0<|n|<=m} n_x^2/|n| over the unit cubic lattice (spacing 1, V = 1):
    the flux of T = x^2 at a point with a full family is kappa S (continuum value: 2)."""
    r = np.arange(-math.ceil(m), math.ceil(m) + 1)
    X, Y, Z = np.meshgrid(r, r, r, indexing="ij")
    L = np.sqrt(X**2 + Y**2 + Z**2)
    sel = (L > 0) & (L <= m)
    return 6.0 / ((((math.pi * m) * m) * m) * m) * float(np.sum(X[sel] ** 2 / L[sel]))


# -- parameters ------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "params, message",
    [
        ({}, "Coefficient"),
        ({"Coefficient": 0.0}, "Coefficient"),
        ({"Coefficient": -1.0}, "Coefficient"),
        ({"Coefficient": float("nan")}, "Coefficient"),
        ({"Coefficient": 1.0, "Density": 1.0}, "Density"),
        ({"Coefficient": True}, "Coefficient"),
    ],
)
def test_bad_parameters_are_input_errors_with_the_deck_path(params, message):
    with pytest.raises(InputError) as exc:
        build_simulation(cube_deck(dict({"Material Model": "Diffusion"}, **params), n=3))
    text = str(exc.value)
    assert "Materials > M" in text and message in text


def test_a_string_horizon_is_refused():
    tree = cube_deck(DIFFUSION, n=3)
    tree["Blocks"]["B"]["Horizon"] = "1.5 + 0.0*x"
    with pytest.raises(InputError, match="constant horizon"):
        build_simulation(tree)


def test_fields_only_when_used():
    sim = model(shape=(3, 3, 3))
    assert "Temperature" in sim.fields and "Flux_Divergence" in sim.fields
    assert "Quadrature_Weights" not in sim.fields
    assert "Quadrature_Weights" in model(shape=(3, 3, 3), improved=True).fields
    elastic = build_simulation(cube_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 1.0}, n=3))
    assert "Flux_Divergence" not in elastic.fields


def test_no_density_no_elastic_constants():
    sim = model(shape=(3, 3, 3))
    mat = sim.blocks[0].material
    assert mat.density == 1.0
    with pytest.raises(InputError, match="ImplicitDiffusion"):
        _ = mat.bulk_modulus


# -- the flux -----------------------------------------------------------------------------------
def test_two_points_by_hand():
    """Q_1 = kappa 6/(pi delta^4 L) (T_2 - T_1) V_2 and Q_2 the opposite (equal volumes)."""
    h = 0.5
    delta = 1.5 * h
    sim = model(shape=(2, 1, 1), spacing=h, horizon=1.5)
    x = sim.fields["Model_Coordinates"][:2, 0]
    T = np.where(x < x.mean(), 300.0, 310.0)
    Q = flux(sim, T)
    V = h**3
    expected = KAPPA * (6.0 / ((((math.pi * delta) * delta) * delta) * delta * h)) * 10.0 * V
    np.testing.assert_allclose(Q[x < x.mean()], expected, rtol=1e-14)
    np.testing.assert_allclose(Q[x > x.mean()], -expected, rtol=1e-14)
    assert not np.any(sim.fields["Force_Density"])


def test_quadratic_field_gives_kappa_times_the_lattice_sum():
    """For T = x^2 (+ any linear part) the flux at a point with a full family is kappa S exactly,
    with S the lattice sum (2 in the continuum: the model is kappa Laplacian(T))."""
    sim = model(shape=(7, 7, 7))
    x = sim.fields["Model_Coordinates"][: sim.num_owned]
    Q = flux(sim, x[:, 0] ** 2 - 3.0 * x[:, 1] + 0.5 * x[:, 2] + 7.0)
    centre = np.all(np.abs(x - 3.5) < 0.1, axis=1)
    S = lattice_second_moment(3.015)
    assert abs(S / 2.0 - 1.0) < 0.1
    np.testing.assert_allclose(Q[centre], KAPPA * S, rtol=1e-12)


def test_gather_is_conservative_with_volume_weights():
    """sum_i Q_i V_i = 0 for any temperature (every bond appears at both ends with opposite
    signs), and a uniform temperature gives no flux."""
    sim = model(shape=(4, 5, 3))
    n = sim.num_owned
    V = sim.fields["Volume"][:n]
    rng = np.random.default_rng(1)
    Q = flux(sim, 300.0 + rng.standard_normal(n))
    assert abs(float(np.dot(Q, V))) < 1e-12 * float(np.abs(Q * V).sum())
    assert np.all(flux(sim, np.full(n, 273.0)) == 0.0)


def test_non_finite_temperature_stops():
    sim = model(shape=(3, 3, 3))
    T = np.full(sim.num_owned, 1.0)
    T[4] = np.inf
    with pytest.raises(InstabilityError, match="not finite"):
        flux(sim, T)


@pytest.mark.parametrize("improved", [False, True])
def test_jacobian_is_the_derivative_of_q_v(improved):
    """The assembled d(Q V)/dT equals central differences of the engine's Q V (the flux is linear:
    they agree to round-off)."""
    from peridyn.solvers.implicit.diffusion import DiffusionMatrix

    sim = model(shape=(4, 3, 3), improved=improved)
    n = sim.num_owned
    V = sim.fields["Volume"][:n]
    T0 = 300.0 + np.random.default_rng(2).standard_normal(n)
    A = DiffusionMatrix(sim)
    A.assemble(sim)
    J = A.to_scipy().toarray()
    eps = 1e-3
    for q in range(n):
        T = T0.copy()
        T[q] += eps
        plus = flux(sim, T) * V
        T[q] -= 2 * eps
        minus = flux(sim, T) * V
        col = (plus - minus) / (2 * eps)
        np.testing.assert_allclose(J[A.row_of_local[:n], A.row_of_local[q]], col, atol=1e-9 * np.abs(col).max())


# -- improved quadrature ------------------------------------------------------------------------------
def test_improved_weights_are_exact_for_quadratics_at_every_point():
    """With the improved weights, Q = kappa Laplacian(T) for every quadratic T at every point,
    also where a free surface cuts the family (the plain volumes give neither)."""
    sim = model(shape=(6, 6, 6), improved=True)
    x = sim.fields["Model_Coordinates"][: sim.num_owned]
    Q_lin = flux(sim, 273.0 + 2.0 * x[:, 0] - x[:, 1] + 0.5 * x[:, 2])
    assert np.abs(Q_lin).max() < 1e-11
    X, Y, Z = x[:, 0], x[:, 1], x[:, 2]
    T = X**2 + 2.0 * Y**2 - 0.5 * Z**2 + X * Y - 3.0 * Y * Z + X
    Q = flux(sim, T)
    np.testing.assert_allclose(Q, KAPPA * (2.0 + 4.0 - 1.0), rtol=1e-9)
    plain = model(shape=(6, 6, 6))
    assert np.abs(flux(plain, T) - KAPPA * 5.0).max() > 1.0


def test_improved_weights_are_close_to_the_volumes_inside():
    """At a point with a full (symmetric) family the weights only correct the second moment:
    they stay within 20 % of the volumes and sum to about the family's volume."""
    sim = model(shape=(7, 7, 7), improved=True)
    x = sim.fields["Model_Coordinates"][: sim.num_owned]
    i = int(np.argmin(np.abs(x - 3.5).sum(axis=1)))
    nl = sim.bonds
    w = sim.fields["Quadrature_Weights"][nl.offsets[i] : nl.offsets[i + 1]]
    assert np.all(np.abs(w - 1.0) < 0.2)


# -- the transport conformance kit -------------------------------------------------------------------
from peridyn.testing import TransportConformance  # noqa: E402


class TestDiffusionKit(TransportConformance):
    material = "Diffusion"
    params = {"Coefficient": KAPPA}


class TestDiffusionImprovedQuadratureKit(TransportConformance):
    material = "Diffusion"
    params = {"Coefficient": KAPPA, "Use Improved Quadrature": True}
    conservative = False  # per-point weights differ at a bond's two ends (exact for quadratics instead)
