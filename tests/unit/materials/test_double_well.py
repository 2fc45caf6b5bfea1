"""``Nonlocal Double Well State`` (peridyn.materials.double_well): its constants from the moduli
and G_c, a two-point hand calculation past both inflections, the bond model it reduces to at
Poisson's ratio 1/4, the conformance kit in the small-strain regime, bad input."""
from __future__ import annotations

import math

import numpy as np
import pytest

from peridyn.core.errors import InputError
from peridyn.materials.double_well import double_well_constants
from peridyn.testing import MaterialConformance
from peridyn.testing.harness import build_simulation, cube_deck

DW = "Nonlocal Double Well State"
E, NU, GC = 200.0e9, 0.3, 1.0e3
GC_LINEAR = 1.0e10  #: beta r s^2 and Betabar delta theta^2 < 1e-6 at the kit's strains


def energy(sim) -> np.ndarray:
    blk = sim.blocks[0]
    W = np.zeros(sim.num_local)
    blk.material.stored_energy_density(blk.view, W)
    return W


def test_constants_from_moduli_and_fracture_energy():
    """3D: the bonds give lambda_b = mu_b = 2 C beta / 5 = mu, the dilatation's small-strain
    energy Cbar Betabar theta^2 = (lambda - mu) / 2 tr(eps)^2, and G_c = 3 C / 2 + 2 Cbar; planar:
    C beta / 2 = mu, (lambda* - mu) / 2 with lambda* = K - mu, G_c = 4 C / pi + 2 Cbar."""
    mu = E / (2 * (1 + NU))
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    K3 = lam + 2 * mu / 3
    C, beta, cb, bb = double_well_constants(K3, mu, GC, 3)
    assert bb == beta
    assert 2 * C * beta / 5 == pytest.approx(mu, rel=1e-14)
    assert cb * bb == pytest.approx((lam - mu) / 2, rel=1e-14)
    assert 1.5 * C + 2 * cb == pytest.approx(GC, rel=1e-14)
    C, beta, cb, bb = double_well_constants(K3, mu, GC, 3, beta_bar=1.0e9)
    assert (bb, cb * bb, 2 * C * beta / 5, 1.5 * C + 2 * cb) == pytest.approx((1.0e9, (lam - mu) / 2, mu, GC), rel=1e-14)
    K2 = lam + mu  # plane strain
    C, beta, cb, bb = double_well_constants(K2, mu, GC, 2)
    assert (C * beta / 2, cb * bb, 4 * C / math.pi + 2 * cb) == pytest.approx((mu, (K2 - mu - mu) / 2, GC), rel=1e-14)
    # nu = 1/4: no dilatational part, the RNP bond model's constants (beta = 9 K / (4 G_c))
    C, beta, cb, bb = double_well_constants(K3, 0.6 * K3, GC, 3)
    assert cb == pytest.approx(0.0, abs=1e-12 * GC) and beta == pytest.approx(9 * K3 / (4 * GC), rel=1e-14) and C == pytest.approx(2 * GC / 3, rel=1e-14)
    with pytest.raises(ValueError, match="lambda >= mu"):
        double_well_constants(K3, 0.7 * K3, GC, 3)
    with pytest.raises(ValueError, match="Beta Bar"):
        double_well_constants(K3, mu, GC, 3, beta_bar=1.0)


def test_two_points_by_hand(tmp_path):
    """theta_a = J (|eta| - |xi|) V_b / F, F = 4 pi delta^4 / 3; force on a
    [4 J C beta s e^(-beta r s^2) / F + (P_a + P_b) J / F] V_b with P = 2 Cbar Betabar theta
    e^(-Betabar delta theta^2); energy J C (1 - e^(-beta r s^2)) / F V_b + Cbar / delta
    (1 - e^(-Betabar delta theta_a^2)); J = 4, r = 1, V_a = 1, V_b = 2."""
    (tmp_path / "pts.txt").write_text("0 0 0 1 1.0\n1 0 0 1 2.0\n")
    entry = {"Material Model": DW, "Density": 1.0, "Bulk Modulus": 10.0, "Shear Modulus": 3.0, "Gc": 4.0}
    tree = {"Discretization": {"Type": "Text File", "Input Mesh File": "pts.txt"}, "Materials": {"M": entry},
            "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": 1.5}}}
    sim = build_simulation(tree, directory=tmp_path)
    m = sim.blocks[0].material
    C, beta, cb, bb = double_well_constants(10.0, 3.0, 4.0, 3)
    assert (m.C, m.beta, m.c_bar, m.beta_bar) == pytest.approx((C, beta, cb, bb), rel=1e-15)
    delta, J, Va, Vb = 1.5, 4.0, 1.0, 2.0
    F = 4 * math.pi / 3 * delta**4
    x = sim.fields["Model_Coordinates"]
    a = int(np.argmin(x[:, 0]))
    theta_c = m.critical_dilatation()
    assert theta_c == pytest.approx(1 / math.sqrt(2 * bb * delta), rel=1e-15)
    for s in (1e-3, 0.3, 1.0, 3.0):
        sim.fields["Coordinates"][:] = x
        sim.fields["Coordinates"][1 - a, 0] = x[1 - a, 0] * (1 + s)
        f = sim.evaluate_forces()
        th_a, th_b = J * s * Vb / F, J * s * Va / F
        P = [2 * cb * bb * th * math.exp(-bb * delta * th * th) for th in (th_a, th_b)]
        # |eta| - |xi| of a stretch s loses eps / s to cancellation
        np.testing.assert_allclose(sim.fields["Dilatation"][[a, 1 - a]], [th_a, th_b], rtol=1e-10)
        bond = 4 * J * C * beta * s * math.exp(-beta * s * s) / F
        assert f[a, 0] == pytest.approx((bond + (P[0] + P[1]) * J / F) * Vb, rel=1e-10)
        W = energy(sim)[a]
        assert W == pytest.approx(J * C * (1 - math.exp(-beta * s * s)) / F * Vb + cb / delta * (1 - math.exp(-bb * delta * th_a**2)), rel=1e-10)


@pytest.mark.parametrize("planar, shape", [({}, (6, 6, 6)), ({"Plane Strain": True, "Height": 1e-3}, (9, 9, 1))])
def test_poisson_quarter_is_the_bond_model(planar, shape):
    """At nu = 1/4 (lambda = mu) the dilatation's well is empty and the forces and energies are
    the RNP bond model's, at a finite deformation (strain 1e-3, past the linear regime)."""
    base = {"Density": 7800.0, "Young's Modulus": 200.0e9, "Gc": 50.0, **planar}
    out = []
    for entry in ({"Material Model": "Regularized Nonlinear Bond", **base}, {"Material Model": DW, "Poisson's Ratio": 0.25, **base}):
        sim = build_simulation(cube_deck(entry, shape=shape, spacing=1e-3))
        x = sim.fields["Model_Coordinates"]
        u = 1e-3 * 1e-3 * np.random.default_rng(5).standard_normal(x.shape)
        if shape[2] == 1:
            u[:, 2] = 0.0
        sim.fields["Coordinates"][:] = x + u
        out.append((sim.evaluate_forces().copy(), energy(sim)))
    np.testing.assert_allclose(out[1][0], out[0][0], rtol=0, atol=1e-12 * np.abs(out[0][0]).max())
    np.testing.assert_allclose(out[1][1], out[0][1], rtol=1e-12)


def test_uniform_expansion_energy_is_the_bulk_one():
    """Under a uniform expansion tr(eps) = 3 e0 (e0 = 1e-6) the energy density of a point whose
    neighbors' families are whole is 9 K e0^2 / 2 up to the lattice's quadrature of the
    family integrals (horizon 3.015 spacings, Linear influence: measured 0.964 of it, and the
    dilatation 0.971 of 3 e0; 5 % allowed)."""
    entry = {"Material Model": DW, "Density": 1.0, "Young's Modulus": E, "Poisson's Ratio": NU, "Gc": GC, "Influence Function Type": "Linear"}
    sim = build_simulation(cube_deck(entry, n=14, spacing=1e-3))
    x = sim.fields["Model_Coordinates"]
    c = x.mean(axis=0)
    e0 = 1e-6
    sim.fields["Coordinates"][:] = x + e0 * (x - c)
    sim.evaluate_forces()
    i = int(np.argmin(np.linalg.norm(x - c, axis=1)))
    K = E / (3 * (1 - 2 * NU))
    assert energy(sim)[i] / (4.5 * K * e0 * e0) == pytest.approx(1.0, abs=0.05)
    assert sim.fields["Dilatation"][i] / (3 * e0) == pytest.approx(1.0, abs=0.05)


class TestDoubleWellConformance(MaterialConformance):
    material = DW
    params = {"Density": 7800.0, "Young's Modulus": E, "Poisson's Ratio": NU, "Gc": GC_LINEAR}


class TestDoubleWellConformancePlaneStrainLinear(MaterialConformance):
    material = DW
    params = {"Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 60.0e9, "Gc": GC_LINEAR, "Influence Function Type": "Linear",
              "Plane Strain": True, "Height": 1e-3}


GOOD = {"Material Model": DW, "Density": 7800.0, "Young's Modulus": E, "Poisson's Ratio": NU, "Gc": GC}


@pytest.mark.parametrize(
    "change, words",
    [
        ({"Gc": None}, "Gc"),
        ({"KIc": 1.0e6}, "Gc"),
        ({"Poisson's Ratio": None}, "two of"),
        ({"Bulk Modulus": 1.0e11}, "two of"),
        ({"Poisson's Ratio": 0.2}, "lambda >= mu"),
        ({"Poisson's Ratio": 0.3, "Plane Stress": True, "Height": 1e-3}, "lambda >= mu"),
        ({"Beta Bar": 1.0}, "Beta Bar"),
        ({"Beta Bar": -1.0}, "Beta Bar"),
        ({"Gc": float("inf")}, "Gc"),
        ({"Influence Function Type": "One"}, "Influence Function Type"),
        ({"Plane Stress": True}, "Height"),
        ({"Density": -1.0}, "Density"),
    ],
)
def test_bad_parameters_are_refused_with_the_deck_path(change, words):
    entry = {k: v for k, v in {**GOOD, **change}.items() if v is not None}
    with pytest.raises(InputError) as info:
        build_simulation(cube_deck(entry, n=4))
    message = str(info.value)
    assert "Materials" in message and words in message, message
