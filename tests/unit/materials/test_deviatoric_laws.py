"""The loop laws of Elastic Plastic, Elastic Plastic Hardening and Viscoelastic (issue 20,
:mod:`peridyn.materials.deviatoric`): the force paths are laws compiled by the run's backend,
while the tangents' probes keep per-point helpers with their own bond loops. The two must do the
same arithmetic in the same order, so they are compared bit for bit here; so are the built-in
backends, and the shear correction factor of a view and of the view-less entry point.
"""
import numpy as np
import pytest

from peridyn.materials.deviatoric import plastic_bonds, plastic_point, point_theta, visco_bonds
from peridyn.materials.elastic_plastic_hardening import shear_correction_kernel
from peridyn.testing import build_simulation, cube_deck
from peridyn.testing.physics_checks import set_bond_damage

SPACING = 1.0e-3
K, MU = 160.0e9, 80.0e9
# yield stresses that leave some points elastic at the strains of ``prepared`` (omega = 1)
EP = {"Material Model": "Elastic Plastic", "Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": MU, "Yield Stress": 3.5e9}
EPH = {**EP, "Material Model": "Elastic Plastic Hardening", "Hardening Modulus": 1.0e55}
VE = {"Material Model": "Viscoelastic", "Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": MU, "lambda_i": 0.6, "tau b": 2.0e-6}
MODELS = {"plastic": EP, "hardening": EPH, "visco": VE}
STATE = {"plastic": ("Deviatoric_Plastic_Extension", "Lambda"), "hardening": ("Deviatoric_Plastic_Extension", "Lambda"),
         "visco": ("Deviatoric_Back_Extension", "Viscoelastic_Bond_Extension")}
DAMAGE = {"Damage Model": "Critical Stretch", "Critical Stretch": 10.0}


def prepared(material, *, influence=None, damage=False, backend=None, seed=0):
    """A deformed n = 4 cube with a previous state (N buffers), 10 % of its bonds broken when
    ``damage``, and a time step (the viscoelastic relaxation constants depend on it)."""
    tree = cube_deck(material, n=4, spacing=SPACING, damage=DAMAGE if damage else None)
    if influence is not None:
        tree["Discretization"]["Influence Function"] = influence
    sim = build_simulation(tree, backend=backend)
    s, nl = sim.fields, sim.bonds
    rng = np.random.default_rng(seed)
    x = s["Model_Coordinates"]
    F = np.eye(3) + 3e-3 * rng.standard_normal((3, 3))
    s["Coordinates"][:] = x @ F.T + 0.05 * 3e-3 * SPACING * rng.standard_normal(x.shape)
    for name in STATE["visco" if "lambda_i" in material else "plastic"] + ("Dilatation",):
        s.n(name)[:] = 1e-7 * rng.standard_normal(s.n(name).shape)
    if "Lambda" in s:
        s.n("Lambda")[:] = 1e-26 * rng.random(sim.num_local)  # H lambda_N below Y (H = 1e55)
    if damage:
        set_bond_damage(sim, rng.random(nl.num_bonds) < 0.1, 1)
    sim.set_time_step(4e-7)
    return sim


def law_path(sim):
    """theta, the force states and the new state from the material's laws (generic path)."""
    blk = sim.blocks[0]
    t = np.zeros(sim.bonds.num_bonds)
    blk.material.precompute(blk.view)
    blk.material.force_state(blk.view, t)
    s = sim.fields
    names = STATE["visco" if blk.material.name == "Viscoelastic" else "plastic"]
    return [s["Dilatation"].copy(), t] + [s[k].copy() for k in names]


def helper_path(sim):
    """The same quantities from the tangents' per-point helpers, point by point."""
    blk = sim.blocks[0]
    mat, view = blk.material, blk.view
    s, nl = sim.fields, sim.bonds
    kind, delta, table = mat._common(view)
    d = mat._damage(view)
    zeta, y, V, m = s["Bond_Length"], s["Coordinates"], s["Volume"], s["Weighted_Volume"]
    theta = s["Dilatation"].copy()
    t = np.zeros(nl.num_bonds)
    b1, b2 = np.zeros(nl.num_bonds), np.zeros(nl.num_bonds)
    lam = s["Lambda"].copy() if "Lambda" in s else None
    for i in range(view.start, view.stop):
        theta[i] = point_theta(i, nl.offsets, nl.neighbors, zeta, y, V, m[i], kind, delta, table, d)
        if mat.name == "Viscoelastic":
            decay, beta = mat._constants(view)
            visco_bonds(i, 0, nl.offsets, nl.neighbors, zeta, y, m[i], s.n("Dilatation")[i], theta[i], mat.K, mat.mu, float(mat.params.lambda_i),
                        decay, beta, d, s.n("Viscoelastic_Bond_Extension"), s.n("Deviatoric_Back_Extension"), t, b2, b1)
        else:
            scf = mat._scf(view)
            sc = scf[i] if scf.shape[0] else 1.0
            lam_n = s.n("Lambda")[i]
            alpha, c, n, dlam, plastic = plastic_point(i, nl.offsets, nl.neighbors, zeta, y, V, m[i], theta[i], mat.K, mat.mu, sc, mat.Y, mat.H,
                                                       mat.hardening, d, s.n("Deviatoric_Plastic_Extension"), lam_n)
            lam[i] = lam_n + dlam if plastic else lam_n
            plastic_bonds(i, 0, nl.offsets, nl.neighbors, zeta, y, theta[i], alpha, c, n, dlam, plastic, (sc * sc) * mat.Y, mat.hardening, d,
                          s.n("Deviatoric_Plastic_Extension"), t, b1)
    return [theta, t, b1, lam] if lam is not None else [theta, t, b1, b2]


@pytest.mark.parametrize("damage", [False, True], ids=["intact", "damaged"])
@pytest.mark.parametrize("influence", [None, "Parabolic Decay"], ids=["omega1", "parabolic"])
@pytest.mark.parametrize("model", list(MODELS))
def test_laws_equal_the_tangent_probe_helpers(model, influence, damage):
    sim = prepared(MODELS[model], influence=influence, damage=damage, seed=3)
    laws = law_path(sim)
    helpers = helper_path(sim)
    for a, b in zip(laws, helpers):
        np.testing.assert_array_equal(a, b)
    if model != "visco":
        lam_n = sim.fields.n("Lambda")[: sim.num_owned]
        plastic = laws[3][: sim.num_owned] > lam_n
        assert plastic.any()  # the plastic branch ran
        if influence is None:
            assert not plastic.all()  # and the elastic one


@pytest.mark.parametrize("fused", [True, False], ids=["pair-force", "force-state"])
@pytest.mark.parametrize("model", list(MODELS))
def test_backends_agree_bit_for_bit(model, fused):
    results = []
    for backend in ("numba", "numba-serial"):
        sim = prepared(MODELS[model], damage=True, backend=backend, seed=5)
        blk = sim.blocks[0]
        assert blk.fused
        blk.fused = fused
        f = sim.evaluate_forces().copy()
        results.append([f] + [sim.fields[k].copy() for k in STATE[model] + ("Dilatation",)])
    for a, b in zip(*results):
        np.testing.assert_array_equal(a, b)
    assert np.abs(results[0][0]).max() > 0


@pytest.mark.parametrize("influence", [None, "Parabolic Decay"], ids=["omega1", "parabolic"])
def test_shear_correction_of_a_view_and_without_one_agree(influence):
    sim = prepared(EPH, influence=influence)
    blk = sim.blocks[0]
    s, nl = sim.fields, sim.bonds
    kind, delta, table = blk.material._common(blk.view)
    out = np.zeros(sim.num_local)
    shear_correction_kernel(blk.start, blk.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Volume"], s["Weighted_Volume"], kind, delta, table, out)
    np.testing.assert_array_equal(out[blk.start : blk.stop], s["Surface_Correction_Factor"][blk.start : blk.stop])
    assert np.all(out[blk.start : blk.stop] > 0) and np.ptp(out[blk.start : blk.stop]) > 0  # corners and interior differ
