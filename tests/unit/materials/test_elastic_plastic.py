"""Elastic Plastic and Elastic Plastic Hardening (PERIDIGM_MODELS.md §1, §2): the force state and
the plastic state against an independent numpy transcription of the model, the traps of §15
(omega = 1 in the force, damage once in the norm, Disable Plasticity), parameter validation, the
shear correction factor, and the tangents against central differences of the assembled force.

Tolerances: the kernels and the transcription do the same operations, possibly in another order
(numpy sums), so 1e-12 relative. Tangents: central differences with h = 1e-10 on coordinates of
size 5e-3 (step represented to ~1e-18, relative error ~1e-8 of a column; truncation ~(h/u)^2 with
displacements u ~ 1e-6: 1e-8) -> 1e-6 of the largest entry.
"""
import math

import numpy as np
import pytest

from peridyn.core.errors import InputError
from peridyn.materials.deviatoric import update_delta_lambda, yield_value
from peridyn.solvers.linalg.tangent import TangentMatrix
from peridyn.testing import build_simulation, cube_deck
from peridyn.testing.physics_checks import set_bond_damage

SPACING = 1.0e-3
EP = {"Material Model": "Elastic Plastic", "Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 80.0e9, "Yield Stress": 1.7e9}
EPH = {**EP, "Material Model": "Elastic Plastic Hardening", "Hardening Modulus": 1.0e55}


def build(material, n=4, influence=None, damage=None):
    tree = cube_deck(material, n=n, spacing=SPACING, damage=damage)
    if influence is not None:
        tree["Discretization"]["Influence Function"] = influence
    return build_simulation(tree)


def deform(sim, strain=3e-3, seed=0):
    x = sim.fields["Model_Coordinates"]
    rng = np.random.default_rng(seed)
    F = np.eye(3) + strain * rng.standard_normal((3, 3))
    sim.fields["Coordinates"][:] = x @ F.T + 0.05 * strain * SPACING * rng.standard_normal(x.shape)


def omega_np(kind, zeta, delta):
    if kind == "Parabolic Decay":
        s = zeta / delta
        return np.where(s < 0.5, 1.0, -4.0 * s * s + 4.0 * s)
    return np.ones_like(zeta)


def reference(sim, K, mu, Y, H=None, influence=None):
    """Independent transcription of §1/§2: (t per bond, edp_np1, lam_np1)."""
    s, nl = sim.fields, sim.bonds
    x, y, V = s["Model_Coordinates"], s["Coordinates"], s["Volume"]
    blk = sim.blocks[0]
    d = s["Bond_Damage"] if "Bond_Damage" in s else np.zeros(nl.num_bonds)
    edp_n, lam_n = s.n("Deviatoric_Plastic_Extension"), s.n("Lambda")
    scf = s["Surface_Correction_Factor"] if "Surface_Correction_Factor" in s else np.ones(sim.num_local)
    t = np.zeros(nl.num_bonds)
    edp = np.zeros(nl.num_bonds)
    lam = np.zeros(sim.num_owned)
    for i in range(sim.num_owned):
        b = np.arange(nl.offsets[i], nl.offsets[i + 1])
        j = nl.neighbors[b]
        zeta = np.linalg.norm(x[j] - x[i], axis=1)
        L = np.linalg.norm(y[j] - y[i], axis=1)
        w = omega_np(influence, zeta, blk.horizon)
        m = np.sum(w * zeta**2 * V[j])
        theta = np.sum(3 * w * (1 - d[b]) * zeta * (L - zeta) * V[j]) / m
        alpha = scf[i] * 15 * mu / m
        c = 3 * K * theta / m
        ed = (L - zeta) - theta * zeta / 3
        ttr = alpha * (ed - edp_n[b])  # omega = 1
        n = math.sqrt(np.sum(((1 - d[b]) * ttr) ** 2 * V[j]))  # damage once
        Yp = scf[i] ** 2 * Y
        dl = 0.0
        if n * n / 2 > Yp:
            if H is None:
                dl = (n / math.sqrt(2 * Yp) - 1) / alpha
            else:  # smallest positive root of the backward-Euler yield condition
                roots = np.roots([
                    1.0, 2 / alpha + lam_n[i] + Yp / H, (H + 2 * alpha * H * lam_n[i] + 2 * alpha * Yp) / (alpha**2 * H),
                    (2 * H * lam_n[i] + 2 * Yp - n * n) / (2 * alpha**2 * H),
                ])
                pos = [r.real for r in roots if abs(r.imag) < 1e-9 * abs(r) and r.real > 0]
                dl = min(pos) if pos else 0.0
        if dl > 0:
            td = math.sqrt(2 * Yp) * ttr / n if H is None else ttr / (1 + alpha * dl)
            edp[b] = edp_n[b] + td * dl
        else:
            td = ttr
            edp[b] = edp_n[b]
        lam[i] = lam_n[i] + dl
        t[b] = (1 - d[b]) * (c * zeta + (1 - d[b]) * td)
    return t, edp, lam


def engine_state(sim):
    t = np.zeros(sim.bonds.num_bonds)
    blk = sim.blocks[0]
    blk.material.precompute(blk.view)
    blk.material.force_state(blk.view, t)
    s = sim.fields
    return t, s["Deviatoric_Plastic_Extension"].copy(), s["Lambda"][: sim.num_owned].copy()


def seed_state(sim, seed=1, scale=1e-7):
    """A previous plastic state: e^dp_N and lambda_N."""
    rng = np.random.default_rng(seed)
    s = sim.fields
    s.n("Deviatoric_Plastic_Extension")[:] = scale * rng.standard_normal(sim.bonds.num_bonds)
    s.n("Lambda")[:] = 1e-20 * rng.random(sim.num_local)


@pytest.mark.parametrize("influence", [None, "Parabolic Decay"])
@pytest.mark.parametrize("yield_stress", [1.7e9, 1.0e12])
def test_force_and_state_match_the_model(influence, yield_stress):
    sim = build({**EP, "Yield Stress": yield_stress}, influence=influence)
    deform(sim)
    seed_state(sim)
    K, mu = 160.0e9, 80.0e9
    Y = yield_value(yield_stress, sim.blocks[0].horizon)
    t, edp, lam = engine_state(sim)
    tr, edpr, lamr = reference(sim, K, mu, Y, influence=influence)
    np.testing.assert_allclose(t, tr, rtol=1e-11, atol=1e-12 * np.abs(tr).max())
    np.testing.assert_allclose(edp, edpr, rtol=1e-11, atol=1e-12 * np.abs(edpr).max())
    np.testing.assert_allclose(lam, lamr, rtol=1e-11, atol=1e-30)
    plastic = lam > sim.fields.n("Lambda")[: sim.num_owned]
    if yield_stress < 1e10:
        assert plastic.any()
        if influence is None:
            assert not plastic.all()  # both branches are exercised
    else:
        assert not plastic.any()


def test_damage_enters_the_norm_once_and_the_force_as_in_peridigm():
    sim = build(EP, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 10.0})
    deform(sim, seed=3)
    seed_state(sim, seed=4)
    rng = np.random.default_rng(5)
    set_bond_damage(sim, rng.random(sim.bonds.num_bonds) < 0.2, 1)
    t, edp, lam = engine_state(sim)
    tr, edpr, lamr = reference(sim, 160.0e9, 80.0e9, yield_value(1.7e9, sim.blocks[0].horizon))
    np.testing.assert_allclose(t, tr, rtol=1e-11, atol=1e-12 * np.abs(tr).max())
    np.testing.assert_allclose(edp, edpr, rtol=1e-11, atol=1e-12 * np.abs(edpr).max())
    np.testing.assert_allclose(lam, lamr, rtol=1e-11, atol=1e-30)


def test_disable_plasticity_is_the_elastic_lps_with_omega_one():
    sim = build({**EP, "Yield Stress": 1.0, "Disable Plasticity": True})
    assert sim.blocks[0].material.Y == math.inf
    lps = build({"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 80.0e9})
    deform(sim, strain=0.05)
    lps.fields["Coordinates"][:] = sim.fields["Coordinates"]
    f = sim.evaluate_forces().copy()
    np.testing.assert_allclose(f, lps.evaluate_forces(), rtol=1e-10, atol=1e-12 * np.abs(f).max())
    assert not sim.fields["Lambda"].any()


def test_hardening_state_lies_on_the_hardened_yield_surface():
    """After a plastic step ||t^d||^2 / 2 = Y_p + H lambda_NP1 (the cubic's equation)."""
    H = 1.0e55  # of the order of Y alpha: hardening comparable to the yield value
    sim = build({**EPH, "Hardening Modulus": H, "Apply Shear Correction Factor": False, "Yield Stress": 1.0e9})
    deform(sim)
    t, edp, lam = engine_state(sim)
    tr, edpr, lamr = reference(sim, 160.0e9, 80.0e9, yield_value(1.0e9, sim.blocks[0].horizon), H=H)
    np.testing.assert_allclose(t, tr, rtol=1e-9, atol=1e-10 * np.abs(tr).max())
    np.testing.assert_allclose(edp, edpr, rtol=1e-9, atol=1e-10 * np.abs(edpr).max())
    np.testing.assert_allclose(lam, lamr, rtol=1e-9, atol=1e-30)
    s, nl = sim.fields, sim.bonds
    Y = yield_value(1.0e9, sim.blocks[0].horizon)
    m, theta, V = s["Weighted_Volume"], s["Dilatation"], s["Volume"]
    checked = 0
    for i in np.flatnonzero(lam > 0):
        b = np.arange(nl.offsets[i], nl.offsets[i + 1])
        td = t[b] - 3 * 160.0e9 * theta[i] / m[i] * s["Bond_Length"][b]
        norm2 = np.sum(td**2 * V[nl.neighbors[b]])
        assert norm2 / 2 == pytest.approx(Y + H * lam[i], rel=1e-9)
        checked += 1
    assert checked > 0


def test_update_delta_lambda_solves_the_cubic():
    """Peridigm's closed-form (Cardano) root, as coded, loses digits to cancellation: over these
    samples it agrees with numpy's companion-matrix root to 3e-6 at worst, so 1e-5."""
    rng = np.random.default_rng(0)
    for _ in range(300):
        alpha, Yp, H = 10 ** rng.uniform(-2, 2), 10 ** rng.uniform(-2, 2), 10 ** rng.uniform(-3, 3)
        lam_n = rng.uniform(0, 1)
        n = math.sqrt(2 * (Yp + H * lam_n)) * rng.uniform(1.0, 5.0)
        x = update_delta_lambda(n, lam_n, Yp, alpha, H)
        roots = np.roots([1, 2 / alpha + lam_n + Yp / H, (H + 2 * alpha * H * lam_n + 2 * alpha * Yp) / (alpha**2 * H), (2 * H * lam_n + 2 * Yp - n * n) / (2 * alpha**2 * H)])
        assert x == pytest.approx(min(r.real for r in roots if abs(r.imag) <= 1e-9 * abs(r) and r.real > 0), rel=1e-5)
        assert (n / (1 + alpha * x)) ** 2 / 2 == pytest.approx(Yp + H * (lam_n + x), rel=1e-4)
    assert update_delta_lambda(1.0, 0.0, 1.0, 1.0, 1.0) == 0.0  # inside the (hardened) yield surface: no flow


def test_shear_correction_factor_is_peridigms_inverted_ratio():
    sim = build(EPH, n=6)
    s, nl = sim.fields, sim.bonds
    x, V, m = s["Model_Coordinates"], s["Volume"], s["Weighted_Volume"]
    g = 1e-6
    for i in (0, 43, 100):
        b = np.arange(nl.offsets[i], nl.offsets[i + 1])
        j = nl.neighbors[b]
        dx = x[j] - x[i]
        zeta = np.linalg.norm(dx, axis=1)
        best = 0.0
        for a, c in ((0, 1), (2, 0), (1, 2)):  # XY, ZX, YZ
            yj = x[j].copy()
            yj[:, a] += g * dx[:, c]
            yj[:, c] += g * dx[:, a]
            e = np.linalg.norm(yj - x[i], axis=1) - zeta
            theta = np.sum(3 * zeta * e * V[j]) / m[i]
            ed = e - theta * zeta / 3
            best = max(best, np.sum(ed * ed * V[j]))
        expected = 1.0 / (4 * g * g * m[i] / best / 15)
        assert s["Surface_Correction_Factor"][i] == pytest.approx(expected, rel=1e-6)
    off = build({**EPH, "Apply Shear Correction Factor": False})
    assert np.all(off.fields["Surface_Correction_Factor"][: off.num_owned] == 1.0)


@pytest.mark.parametrize(
    "params",
    [
        {"Yield Stress": None},
        {"Yield Stress": -1.0},
        {"Yield Stress": float("nan")},
        {"Yield Stress": float("inf")},
        {"Thermal Expansion Coefficient": 0.0},
        {"Planar Problem": True},
        {"Density": 0.0},
    ],
)
def test_bad_parameters_are_refused_with_the_deck_path(params):
    material = {**EP, **params}
    material = {k: v for k, v in material.items() if v is not None}
    with pytest.raises(InputError) as info:
        build(material)
    assert "Materials" in str(info.value)


def test_hardening_needs_its_modulus_and_refuses_thermal_expansion():
    with pytest.raises(InputError, match="Hardening Modulus"):
        build({k: v for k, v in EPH.items() if k != "Hardening Modulus"})
    with pytest.raises(InputError, match="Thermal Expansion Coefficient"):
        build({**EPH, "Thermal Expansion Coefficient": 1e-5})


def test_planar_yield_value_and_ignored_shear_correction():
    sim = build({**EP, "Planar Problem": True, "Thickness": 2e-3, "Apply Shear Correction Factor": True})
    delta = sim.blocks[0].horizon
    assert sim.blocks[0].material.Y == pytest.approx(75.0 * 1.7e9**2 / (8 * math.pi * 2e-3 * delta**4), rel=1e-14)


def fd_jacobian(sim, T, h=1e-10):
    n = sim.num_owned
    y = sim.fields["Coordinates"]
    V = sim.fields["Volume"][:n, None]
    J = np.zeros((3 * n, 3 * n))
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
    sim.evaluate_forces()
    return J


def assembled(sim):
    T = TangentMatrix(sim)
    sim.evaluate_forces()
    T.assemble()
    return T, T.to_scipy().toarray()


@pytest.mark.parametrize(
    "material",
    [
        EP,
        {**EP, "Yield Stress": 1.0e12},
        {**EPH, "Yield Stress": 1.0e9, "Apply Automatic Differentiation Jacobian": True},
    ],
    ids=["plastic", "elastic", "hardening"],
)
@pytest.mark.parametrize("influence", [None, "Parabolic Decay"])
def test_exact_tangent_is_the_derivative_of_the_force(material, influence):
    sim = build(material, n=4, influence=influence, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 10.0})
    deform(sim, seed=11)
    seed_state(sim, seed=12)
    set_bond_damage(sim, np.random.default_rng(13).random(sim.bonds.num_bonds) < 0.1, 1)
    sim.evaluate_forces()
    state = [sim.fields[k].copy() for k in ("Deviatoric_Plastic_Extension", "Lambda")]
    T, A = assembled(sim)
    for k, before in zip(("Deviatoric_Plastic_Extension", "Lambda"), state):
        np.testing.assert_array_equal(sim.fields[k], before)  # the tangent never writes the state
    J = fd_jacobian(sim, T)
    scale = np.abs(J).max()
    np.testing.assert_allclose(A, J, rtol=0, atol=1e-6 * scale)
    if material is EP:
        assert (sim.fields["Lambda"][: sim.num_owned] > sim.fields.n("Lambda")[: sim.num_owned]).any()


@pytest.mark.parametrize("material", [{**EP, "Apply Automatic Differentiation Jacobian": False}, EPH], ids=["ep", "eph"])
def test_finite_difference_tangent_matches_the_exact_one(material):
    sim = build(material, n=4)
    deform(sim, seed=21)
    seed_state(sim, seed=22)
    _, A = assembled(sim)
    exact = build({**material, "Apply Automatic Differentiation Jacobian": True}, n=4)
    exact.fields["Coordinates"][:] = sim.fields["Coordinates"]
    for k in ("Deviatoric_Plastic_Extension", "Lambda"):
        exact.fields.n(k)[:] = sim.fields.n(k)
    _, B = assembled(exact)
    np.testing.assert_allclose(A, B, rtol=0, atol=1e-5 * np.abs(B).max())


@pytest.mark.parametrize("material", [EP, EPH], ids=["exact", "finite-differences"])
def test_tangent_does_not_depend_on_the_thread_count(material):
    """Local blocks are computed in parallel batches whose size follows the thread count, and
    added in Peridigm's point order: the matrix must be the same bit for bit."""
    import numba

    sim = build(material, n=4)
    deform(sim, seed=31)
    seed_state(sim, seed=32)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        _, one = assembled(sim)
        numba.set_num_threads(max(2, min(before, numba.config.NUMBA_NUM_THREADS)))
        _, many = assembled(sim)
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(one, many)


def test_compiled_finite_differences_equal_the_solvers_generic_path():
    """The compiled probes do the generic path's arithmetic (precompute and force_state on a
    one-point view, PERIDIGM_SEMANTICS.md §11.1), so the matrices agree bit for bit."""
    sim = build(EPH, n=4)
    deform(sim, seed=41)
    seed_state(sim, seed=42)
    T, A = assembled(sim)
    blk = sim.blocks[0]
    T.data[:] = 0.0
    T._finite_difference(blk, 1e-6 * float(sim.discretization.min_element_radius))  # the default probe
    np.testing.assert_array_equal(T.to_scipy().toarray(), A)


@pytest.mark.parametrize("material", [EP, {**EPH, "Yield Stress": 1.0e9}], ids=["perfect", "hardening"])
def test_fused_path_gives_the_generic_forces_and_state(material):
    """The fused kernel computes both bond ends itself (the far end's e^dp_N and damage through
    the reverse bond); forces agree to round-off and the new state bit for bit."""
    sim = build(material, n=5, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 10.0})
    deform(sim, seed=51)
    seed_state(sim, seed=52)
    set_bond_damage(sim, np.random.default_rng(53).random(sim.bonds.num_bonds) < 0.1, 1)
    blk = sim.blocks[0]
    assert blk.fused and blk.material.force_fused(blk.view, np.zeros((sim.num_local, 3)))
    fused = sim.evaluate_forces().copy()
    state = [sim.fields[k].copy() for k in ("Deviatoric_Plastic_Extension", "Lambda")]
    assert (state[1] > 0).any()
    blk.fused = False
    generic = sim.evaluate_forces()
    np.testing.assert_allclose(fused, generic, rtol=0, atol=1e-13 * np.abs(generic).max())
    for k, before in zip(("Deviatoric_Plastic_Extension", "Lambda"), state):
        np.testing.assert_array_equal(sim.fields[k], before)
