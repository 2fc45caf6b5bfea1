"""Viscoelastic (PERIDIGM_MODELS.md §3): the force state and the back extension against an
independent numpy transcription, the limits (lambda_i = 0 and dt = 0 are the elastic LPS, the
state advances through the end-of-step swap as Peridigm's Coordinates N does), parameter
validation, and the finite-difference tangent against central differences of the force.

Tolerances as in test_elastic_plastic.py: same operations, other summation order -> 1e-11; the
tangent against central differences with h = 1e-10 -> 1e-6 of the largest entry.
"""
import math

import numpy as np
import pytest

from peridyn.core.errors import InputError
from peridyn.materials.deviatoric import relaxation_constants
from peridyn.solvers.linalg.tangent import TangentMatrix
from peridyn.testing import build_simulation, cube_deck
from peridyn.testing.physics_checks import set_bond_damage

SPACING = 1.0e-3
K, MU = 160.0e9, 80.0e9
VE = {"Material Model": "Viscoelastic", "Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": MU, "lambda_i": 0.6, "tau b": 2.0e-6}
LPS = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": MU}


def build(material, n=4, damage=None, influence=None):
    tree = cube_deck(material, n=n, spacing=SPACING, damage=damage)
    if influence is not None:
        tree["Discretization"]["Influence Function"] = influence
    return build_simulation(tree)


def random_y(sim, strain, seed):
    x = sim.fields["Model_Coordinates"]
    rng = np.random.default_rng(seed)
    F = np.eye(3) + strain * rng.standard_normal((3, 3))
    return x @ F.T + 0.05 * strain * SPACING * rng.standard_normal(x.shape)


def previous_state(sim, seed=2):
    """A step N: positions y_N (its extensions and dilatation) and a back extension e^b_N."""
    s, nl = sim.fields, sim.bonds
    yN = random_y(sim, 2e-3, seed)
    i = nl.sources()
    s.n("Viscoelastic_Bond_Extension")[:] = np.linalg.norm(yN[nl.neighbors] - yN[i], axis=1) - s["Bond_Length"]
    s.n("Dilatation")[:] = 1e-3 * np.random.default_rng(seed).standard_normal(sim.num_local)
    s.n("Deviatoric_Back_Extension")[:] = 1e-7 * np.random.default_rng(seed + 1).standard_normal(nl.num_bonds)


def reference(sim, lam_i, tau, dt):
    """Independent transcription of §3: (t, e^b_NP1) per bond."""
    s, nl = sim.fields, sim.bonds
    x, y, m, theta = s["Model_Coordinates"], s["Coordinates"], s["Weighted_Volume"], s["Dilatation"]
    d = s["Bond_Damage"] if "Bond_Damage" in s else np.zeros(nl.num_bonds)
    c1 = tau / dt
    decay = math.exp(-1 / c1)
    beta = 1 - c1 * (1 - decay)
    t = np.zeros(nl.num_bonds)
    eb = np.zeros(nl.num_bonds)
    for i in range(sim.num_owned):
        b = np.arange(nl.offsets[i], nl.offsets[i + 1])
        j = nl.neighbors[b]
        zeta = np.linalg.norm(x[j] - x[i], axis=1)
        D = 1 - d[b]
        edN = D * s.n("Viscoelastic_Bond_Extension")[b] - s.n("Dilatation")[i] * zeta / 3
        edNP1 = D * (np.linalg.norm(y[j] - y[i], axis=1) - zeta) - theta[i] * zeta / 3
        eb[b] = edN * (1 - decay) + s.n("Deviatoric_Back_Extension")[b] * decay + beta * (edNP1 - edN)
        alpha = 15 * MU / m[i]
        td = (1 - lam_i) * alpha * edNP1 + lam_i * alpha * (edNP1 - eb[b])
        t[b] = D * (3 * K * theta[i] / m[i] * zeta + td)
    return t, eb


def engine(sim):
    t = np.zeros(sim.bonds.num_bonds)
    blk = sim.blocks[0]
    blk.material.precompute(blk.view)
    blk.material.force_state(blk.view, t)
    return t, sim.fields["Deviatoric_Back_Extension"].copy()


@pytest.mark.parametrize("influence", [None, "Parabolic Decay"])
def test_force_and_back_extension_match_the_model(influence):
    sim = build(VE, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 10.0}, influence=influence)
    previous_state(sim)
    set_bond_damage(sim, np.random.default_rng(4).random(sim.bonds.num_bonds) < 0.15, 1)
    sim.fields["Coordinates"][:] = random_y(sim, 3e-3, seed=3)
    dt = 7.0e-7
    sim.set_time_step(dt)
    t, eb = engine(sim)
    tr, ebr = reference(sim, 0.6, 2.0e-6, dt)
    np.testing.assert_allclose(t, tr, rtol=1e-11, atol=1e-12 * np.abs(tr).max())
    np.testing.assert_allclose(eb, ebr, rtol=1e-11, atol=1e-12 * np.abs(ebr).max())


@pytest.mark.parametrize("case", ["lambda_i = 0", "dt = 0"])
def test_elastic_limits_are_the_lps_with_omega_one(case):
    sim = build({**VE, "lambda_i": 0.0} if case == "lambda_i = 0" else VE)
    if case == "lambda_i = 0":
        previous_state(sim)
        sim.set_time_step(1e-7)
    lps = build(LPS)
    y = random_y(sim, 3e-3, seed=5)
    sim.fields["Coordinates"][:] = y
    lps.fields["Coordinates"][:] = y
    f = sim.evaluate_forces().copy()
    np.testing.assert_allclose(f, lps.evaluate_forces(), rtol=1e-10, atol=1e-11 * np.abs(f).max())


def test_relaxation_constants():
    decay, beta = relaxation_constants(2.0, 0.5)
    assert decay == pytest.approx(math.exp(-0.25), rel=1e-15)
    assert beta == pytest.approx(1 - 4 * (1 - math.exp(-0.25)), rel=1e-14)
    assert relaxation_constants(2.0, 0.0) == (1.0, 0.0)


def test_state_advances_with_the_step_swap():
    """After the swap, the N extension is the extension at the previous positions (Peridigm's
    Coordinates N), and the N back extension the previous NP1 one."""
    sim = build(VE)
    sim.set_time_step(1e-7)
    y1 = random_y(sim, 2e-3, seed=8)
    sim.fields["Coordinates"][:] = y1
    sim.evaluate_forces()
    eb1 = sim.fields["Deviatoric_Back_Extension"].copy()
    sim.advance()
    nl = sim.bonds
    ext = np.linalg.norm(y1[nl.neighbors] - y1[nl.sources()], axis=1) - sim.fields["Bond_Length"]
    np.testing.assert_allclose(sim.fields.n("Viscoelastic_Bond_Extension"), ext, rtol=1e-12, atol=1e-20)
    np.testing.assert_array_equal(sim.fields.n("Deviatoric_Back_Extension"), eb1)
    assert np.abs(eb1).max() > 0


@pytest.mark.parametrize(
    "params",
    [
        {"lambda_i": 1.5},
        {"lambda_i": -0.1},
        {"tau b": 0.0},
        {"tau b": float("nan")},
        {"Apply Automatic Differentiation Jacobian": False},
        {"Apply Shear Correction Factor": False},
        {"Thermal Expansion Coefficient": 0.0},
    ],
)
def test_bad_parameters_are_refused_with_the_deck_path(params):
    with pytest.raises(InputError) as info:
        build({**VE, **params})
    assert "Materials" in str(info.value)


@pytest.mark.parametrize("missing", ["lambda_i", "tau b"])
def test_required_parameters(missing):
    with pytest.raises(InputError, match=missing):
        build({k: v for k, v in VE.items() if k != missing})


def test_finite_difference_tangent_is_the_derivative_of_the_force():
    sim = build(VE, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 10.0})
    previous_state(sim, seed=9)
    set_bond_damage(sim, np.random.default_rng(10).random(sim.bonds.num_bonds) < 0.1, 1)
    sim.fields["Coordinates"][:] = random_y(sim, 3e-3, seed=11)
    sim.set_time_step(5e-7)
    T = TangentMatrix(sim)
    sim.evaluate_forces()
    eb = sim.fields["Deviatoric_Back_Extension"].copy()
    T.assemble()
    np.testing.assert_array_equal(sim.fields["Deviatoric_Back_Extension"], eb)  # probes never write the state
    A = T.to_scipy().toarray()
    n = sim.num_owned
    y = sim.fields["Coordinates"]
    V = sim.fields["Volume"][:n, None]
    J = np.zeros_like(A)
    h = 1e-10
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


def test_tangent_does_not_depend_on_the_thread_count():
    import numba

    sim = build(VE)
    previous_state(sim, seed=12)
    sim.fields["Coordinates"][:] = random_y(sim, 3e-3, seed=13)
    sim.set_time_step(5e-7)
    mats = []
    before = numba.get_num_threads()
    try:
        for threads in (1, max(2, min(before, numba.config.NUMBA_NUM_THREADS))):
            numba.set_num_threads(threads)
            T = TangentMatrix(sim)
            sim.evaluate_forces()
            T.assemble()
            mats.append(T.to_scipy().toarray())
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(mats[0], mats[1])


def test_fused_path_gives_the_generic_forces_and_state():
    sim = build(VE, n=5, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 10.0})
    previous_state(sim, seed=21)
    set_bond_damage(sim, np.random.default_rng(22).random(sim.bonds.num_bonds) < 0.1, 1)
    sim.fields["Coordinates"][:] = random_y(sim, 3e-3, seed=23)
    sim.set_time_step(4e-7)
    blk = sim.blocks[0]
    assert blk.fused and blk.material.force_fused(blk.view, np.zeros((sim.num_local, 3)))
    names = ("Deviatoric_Back_Extension", "Viscoelastic_Bond_Extension")
    fused = sim.evaluate_forces().copy()
    state = [sim.fields[k].copy() for k in names]
    blk.fused = False
    generic = sim.evaluate_forces()
    np.testing.assert_allclose(fused, generic, rtol=0, atol=1e-13 * np.abs(generic).max())
    for k, before in zip(names, state):
        np.testing.assert_array_equal(sim.fields[k], before)
