"""Pals (position-aware LPS): parameters, Lagrange multipliers, dilatation, energy, damage.

The conformance kit runs on Pals in test_conformance_builtin.py; these tests check what makes
Pals Pals: at every point, surface and corner points included, the multipliers make the
moment conditions of PERIDIGM_MODELS.md §4 hold, so the dilatation of a homogeneous deformation
is its volumetric strain and a simple shear stores the continuum energy.
"""
import math

import numpy as np
import pytest
from pydantic import ValidationError

from peridyn.materials import pals_kernels as kern
from peridyn.materials.pals import Pals, PalsParams
from peridyn.testing import build_simulation, cube_deck

K, MU = 160.0e9, 80.0e9
BASE = {"Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": MU}
H = 1.0e-3  # lattice spacing (m): not 1, so a missing length factor shows


def pals_sim(n=5, shape=None, damage=None, **params):
    mat = {"Material Model": "Pals", **BASE, **params}
    return build_simulation(cube_deck(mat, n=n, shape=shape, spacing=H, damage=damage))


def bases(xi):
    """The dilatation and deviatoric bases E_k, eps_k of one bond (6,) each."""
    a, b, c = xi
    r = math.sqrt((a * a + b * b) + c * c)
    E = np.array([a * a, b * b, c * c, 2 * a * b, 2 * a * c, 2 * b * c])
    eps = np.array([a * a / r - r / 3, b * b / r - r / 3, c * c / r - r / 3, 2 * a * b / r, 2 * a * c / r, 2 * b * c / r])
    return E, eps


# -- parameters ---------------------------------------------------------------------------------
def test_params_defaults_and_names():
    p = PalsParams.model_validate(BASE)
    assert p.dilatation_influence_function == "One" and p.deviatoric_influence_function == "One"
    p = PalsParams.model_validate({**BASE, "Dilatation Influence Function": "Gaussian", "Deviatoric Influence Function": "Parabolic Decay"})
    assert p.deviatoric_influence_function == "Parabolic Decay"


@pytest.mark.parametrize("bad", ["one", "1-zeta/horizon", "Cubic"])
def test_params_refuse_other_influence_functions(bad):
    with pytest.raises(ValidationError, match="Pals knows"):
        PalsParams.model_validate({**BASE, "Deviatoric Influence Function": bad})


def test_params_need_two_elastic_constants():
    with pytest.raises(ValidationError):
        PalsParams.model_validate({"Density": 1.0, "Bulk Modulus": 1.0e9})


def test_hourglass_coefficient_is_accepted_and_ignored():
    assert "Hourglass Coefficient" in PalsParams.ignored_keys


def test_named_influence_functions_need_a_constant_horizon():
    params = PalsParams.model_validate({**BASE, "Dilatation Influence Function": "Gaussian"})
    with pytest.raises(ValueError, match="constant horizon"):
        Pals(params, horizon=None)
    Pals(PalsParams.model_validate(BASE), horizon=None)  # One, One: the horizon is not used


# -- Lagrange multipliers -----------------------------------------------------------------------
def test_lu_solve_matches_numpy():
    rng = np.random.default_rng(0)
    A = rng.standard_normal((6, 6)) + 3 * np.eye(6)
    b = rng.standard_normal(6)
    z = b.copy()
    assert kern.lu_solve_6(A.copy(), z)
    np.testing.assert_allclose(z, np.linalg.solve(A, b), rtol=1e-12)
    assert not kern.lu_solve_6(np.zeros((6, 6)), np.ones(6))


@pytest.mark.parametrize(("w0", "s0"), [("One", "One"), ("Gaussian", "Parabolic Decay"), ("Parabolic Decay", "Gaussian")])
def test_moment_conditions_hold_at_every_point(w0, s0):
    """sum_j omega E_k V_j = (1,1,1,0,0,0) and sum_j sigma eps_k^2 V_j = (2/3,2/3,2/3,2,2,2) at
    every point of a small cube (corners and edges have a quarter of a family or less)."""
    sim = pals_sim(n=5, **{"Dilatation Influence Function": w0, "Deviatoric Influence Function": s0})
    mat, view = sim.blocks[0].material, sim.blocks[0].view
    x, V = sim.fields["Model_Coordinates"], sim.fields["Volume"]
    nl = sim.bonds
    delta = view.horizon
    for i in range(sim.num_owned):
        dil = np.zeros(6)
        dev = np.zeros(6)
        for b in range(nl.offsets[i], nl.offsets[i + 1]):
            j = nl.neighbors[b]
            xi = x[j] - x[i]
            r = float(np.linalg.norm(xi))
            E, eps = bases(xi)
            w = kern.dilatation_influence(mat.kind_w, delta, r, xi[0], xi[1], xi[2], mat.lam, i)
            s = kern.deviatoric_influence(mat.kind_s, delta, r, xi[0], xi[1], xi[2], mat.tau, i)
            dil += w * E * V[j]
            dev += s * eps * eps * V[j]
        np.testing.assert_allclose(dil, [1, 1, 1, 0, 0, 0], atol=1e-9)
        np.testing.assert_allclose(dev, [2 / 3, 2 / 3, 2 / 3, 2, 2, 2], rtol=1e-9)


def test_weighted_volume_is_fifteen_halves_everywhere():
    """m_i = sum sigma |xi|^2 V = (3/2)(sum_{k<3} 2/3 + (1/2) sum_{k>=3} 2) = 15/2 whenever the
    deviatoric moments hold (PERIDIGM_MODELS.md §4: 7.5 on the 7x7x7 cube)."""
    sim = pals_sim(n=5, **{"Deviatoric Influence Function": "Gaussian"})
    np.testing.assert_allclose(sim.fields["Weighted_Volume"][: sim.num_owned], 7.5, rtol=1e-10)


def test_multiplier_outputs_and_normalizations():
    mat = {"Material Model": "Pals", **BASE}
    outputs = {"Output Filename": "o", "Output Frequency": 1,
               "Output Variables": {"Lagrange_Multiplier_Dilatation_1": True, "Lagrange_Multiplier_Deviatoric_6": True,
                                    "Dilatation_Normalization": True, "Deviatoric_Normalization": True}}
    sim = build_simulation(cube_deck(mat, n=4, spacing=H, extra={"Output": outputs}))
    m = sim.blocks[0].material
    s = sim.fields
    np.testing.assert_array_equal(s["Lagrange_Multiplier_Dilatation_1"], m.lam[:, 0])
    np.testing.assert_array_equal(s["Lagrange_Multiplier_Deviatoric_6"], m.tau[:, 5])
    assert np.all(s["Dilatation_Normalization"] == 1.0) and np.all(s["Deviatoric_Normalization"] == 1.0)
    assert "Lagrange_Multiplier_Dilatation_2" not in s  # only what the deck asks for


def test_planar_family_gets_the_degeneracy_fix():
    """A single layer of points (z = const): the z moments vanish, the corresponding multipliers
    are fixed at zero and the in-plane conditions still hold."""
    sim = pals_sim(shape=(5, 5, 1))
    m = sim.blocks[0].material
    np.testing.assert_array_equal(m.lam[: sim.num_owned, [2, 4, 5]], 0.0)
    np.testing.assert_array_equal(m.tau[: sim.num_owned, [2, 4, 5]], 0.0)
    assert np.all(np.isfinite(m.lam)) and np.all(np.isfinite(m.tau))


# -- dilatation, energy -------------------------------------------------------------------------
def test_dilatation_of_a_homogeneous_strain_is_its_trace_at_every_point():
    """theta = tr(eps) at surface points too (LPS underestimates it there)."""
    sim = pals_sim(n=5)
    x = sim.fields["Model_Coordinates"]
    Hgrad = 1e-6 * np.array([[1.0, 0.3, -0.2], [0.3, -0.4, 0.5], [-0.2, 0.5, 2.0]])
    sim.fields["Coordinates"][:] = x + x @ Hgrad.T
    sim.evaluate_forces()
    np.testing.assert_allclose(sim.fields["Dilatation"][: sim.num_owned], np.trace(Hgrad), rtol=1e-5)


def test_simple_shear_stores_the_continuum_energy_at_every_point():
    """A simple shear gamma stores mu gamma^2 / 2 per volume at every point, surface included:
    the deviatoric moment of eps_3 = 2ab/r fixes it (no 1/2 on Pals' deviatoric sum)."""
    gamma = 2e-6
    sim = pals_sim(n=5)
    x = sim.fields["Model_Coordinates"]
    y = x.copy()
    y[:, 0] += gamma * x[:, 1]
    sim.fields["Coordinates"][:] = y
    sim.evaluate_forces()
    W = np.zeros(sim.num_local)
    sim.blocks[0].material.stored_energy_density(sim.blocks[0].view, W)
    np.testing.assert_allclose(W[: sim.num_owned], MU * gamma**2 / 2, rtol=1e-4)


def test_force_state_of_one_bond_by_hand():
    """t = (p omega) r + (2 mu sigma) (e - theta r / 3) for one bond of a deformed cube, with
    omega, sigma, theta and p from the formulas of §4 evaluated in numpy."""
    sim = pals_sim(n=4)
    x = sim.fields["Model_Coordinates"]
    rng = np.random.default_rng(2)
    y = x + 1e-3 * H * rng.standard_normal(x.shape)
    sim.fields["Coordinates"][:] = y
    sim.evaluate_forces()
    mat, view = sim.blocks[0].material, sim.blocks[0].view
    nl, V = sim.bonds, sim.fields["Volume"]
    i = 0
    theta = p = 0.0
    parts = []
    for b in range(nl.offsets[i], nl.offsets[i + 1]):
        j = nl.neighbors[b]
        xi = x[j] - x[i]
        r = float(np.linalg.norm(xi))
        e = float(np.linalg.norm(y[j] - y[i])) - r
        E, eps = bases(xi)
        w = 1.0 + float(mat.lam[i] @ (E * np.array([1, 1, 1, 1, 1, 1])))
        s = 1.0 + float(mat.tau[i] @ (eps * eps))
        theta += w * r * e * V[j]
        p += -(2 * MU * s * r / 3) * e * V[j]
        parts.append((b, w, s, r, e))
    p += (K + 2 * MU * 7.5 / 9) * theta
    np.testing.assert_allclose(sim.fields["Dilatation"][i], theta, rtol=1e-9)
    np.testing.assert_allclose(sim.fields["Pals_Pressure"][i], p, rtol=1e-9)
    t = np.zeros(nl.num_bonds)
    mat.force_state(view, t)
    for b, w, s, r, e in parts:
        np.testing.assert_allclose(t[b], p * w * r + 2 * MU * s * (e - theta * r / 3), rtol=1e-8, atol=1e-12 * abs(p))


# -- damage (a difference from Peridigm, whose Pals ignores it) ---------------------------------
def test_broken_bonds_drop_out_of_dilatation_and_force():
    dmg = {"Damage Model": "Critical Stretch", "Critical Stretch": 1.0e3}
    sim = pals_sim(n=4, damage=dmg)
    x = sim.fields["Model_Coordinates"]
    sim.fields["Coordinates"][:] = x * (1 + 1e-4)
    sim.evaluate_forces()
    theta0 = sim.fields["Dilatation"].copy()
    nl = sim.bonds
    i = 5
    sim.fields["Bond_Damage"][nl.offsets[i] : nl.offsets[i + 1]] = 1
    sim.fields.n("Bond_Damage")[nl.offsets[i] : nl.offsets[i + 1]] = 1
    sim.evaluate_forces()
    assert sim.fields["Dilatation"][i] == 0.0 and sim.fields["Pals_Pressure"][i] == 0.0
    np.testing.assert_array_equal(sim.fields["Dilatation"][:i], theta0[:i])


# -- implicit tangent -----------------------------------------------------------------------------
def test_compiled_finite_difference_tangent_is_the_solvers_one_and_the_force_derivative():
    """The compiled tangent equals the solvers' Python finite-difference path bit for bit
    (same probes and order), and is the derivative of the assembled force."""
    from peridyn.solvers.linalg.tangent import TangentMatrix

    dmg = {"Damage Model": "Critical Stretch", "Critical Stretch": 1.0e3}
    sim = pals_sim(n=4, damage=dmg, **{"Deviatoric Influence Function": "Gaussian"})
    x = sim.fields["Model_Coordinates"]
    rng = np.random.default_rng(5)
    broken = rng.random(sim.bonds.num_bonds) < 0.1
    sim.fields["Bond_Damage"][broken] = 1
    sim.fields.n("Bond_Damage")[broken] = 1
    y = sim.fields["Coordinates"]
    y[:] = x + 2e-3 * H * rng.standard_normal(x.shape)
    T = TangentMatrix(sim)
    sim.evaluate_forces()
    T.assemble()
    A = T.to_scipy().toarray()
    mat = sim.blocks[0].material
    mat.tangent = lambda view, target: False  # the solvers' Python path
    T.assemble()
    np.testing.assert_array_equal(T.to_scipy().toarray(), A)
    n = sim.num_owned
    V = sim.fields["Volume"][:n, None]
    J = np.zeros_like(A)
    h = 1e-6 * H
    for q in range(n):
        col = 3 * T.row_of_local[q]
        for c in range(3):
            orig = y[q, c]
            y[q, c] = orig + h
            fp = T.to_rows(sim.evaluate_forces()[:n] * V)
            y[q, c] = orig - h
            fm = T.to_rows(sim.evaluate_forces()[:n] * V)
            y[q, c] = orig
            J[:, col + c] = (fp - fm) / (2 * h)
    np.testing.assert_allclose(A, J, rtol=0, atol=1e-6 * np.abs(J).max())


def test_the_discretization_influence_function_does_not_change_pals():
    """Trap 1 of PERIDIGM_MODELS.md §15: Pals uses its own omega_0 and sigma_0, never the
    discretization's ``Influence Function``."""
    forces = []
    for influence in (None, "Parabolic Decay"):
        tree = cube_deck({"Material Model": "Pals", **BASE}, n=4, spacing=H)
        if influence:
            tree["Discretization"]["Influence Function"] = influence
        sim = build_simulation(tree)
        x = sim.fields["Model_Coordinates"]
        sim.fields["Coordinates"][:] = x + 1e-3 * H * np.random.default_rng(3).standard_normal(x.shape)
        forces.append(sim.evaluate_forces().copy())
    np.testing.assert_array_equal(forces[0], forces[1])
