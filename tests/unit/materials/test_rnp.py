"""``Regularized Nonlinear Bond`` (NLMech's RNP bond model, peridyn.materials.rnp): the
relations between its constants, the moduli and G_c; its small-strain limit (``Elastic Bond
Based``); a two-point hand calculation past the inflection stretch; irreversible fracture;
the conformance kit in the small-strain regime; bad input."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from peridyn.core.errors import InputError
from peridyn.materials.rnp import influence_coefficient, moduli_and_energy, potential_constants
from peridyn.testing import MaterialConformance
from peridyn.testing.harness import build_simulation, cube_deck

RNP = "Regularized Nonlinear Bond"
K, GC = 130.0e9, 1.0e3
#: a G_c so large that beta r s^2 < 1e-6 at the kit's strains (1e-3): the small-strain regime
GC_LINEAR = 1.0e10


def energy(sim, W: np.ndarray) -> np.ndarray:
    """Stored energy density (n,) of the one-block model at its current positions."""
    blk = sim.blocks[0]
    blk.material.stored_energy_density(blk.view, W)
    return W


# -- relations ---------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["Constant", "Linear", "Gaussian"])
@pytest.mark.parametrize("dim", [2, 3])
def test_influence_functions_have_unit_moment(kind, dim):
    a = influence_coefficient(kind, dim)
    J = {"Constant": lambda r: a, "Linear": lambda r: a * (1.0 - r), "Gaussian": lambda r: a * math.exp(-r * r / 0.2)}[kind]
    assert quad(lambda r: J(r) * r**dim, 0.0, 1.0)[0] == pytest.approx(1.0, rel=1e-12)


def test_constants_from_moduli_and_fracture_energy():
    """Closed forms: in 3D the pair micromodulus c(r) = 4 J C beta / (4 pi delta^4 / 3) gives
    lambda = (2 pi / 15) int c r^3 dr = 2 C beta M / 5 (so K = 5 lambda / 3), and G_c = int over
    xi_n > 0 of xi_n 2 J C / (4 pi delta^4 / 3) = pi int_0^delta r^3 (...) dr = 3 C M / 2; in 2D
    (per thickness) lambda = (pi / 8) int c r^2 dr = C beta M / 2 = mu, K = lambda + mu, and
    G_c = 2 int_0^delta r^2 2 J C / (pi delta^3) dr = 4 C M / pi."""
    delta, M = 3.0e-3, 1.0
    for dim in (2, 3):
        C, beta = potential_constants(K, GC, dim)
        vol = 4.0 * math.pi / 3.0 * delta**4 if dim == 3 else math.pi * delta**3
        J = dim + 1.0  # the constant influence function of unit moment
        c = 4.0 * J * C * beta / vol
        if dim == 3:
            lam = 2.0 * math.pi / 15.0 * quad(lambda r: c * r**3, 0.0, delta)[0]
            K_measured = 5.0 * lam / 3.0
            G_measured = math.pi * quad(lambda r: r**3 * 2.0 * J * C / vol, 0.0, delta)[0]
        else:
            lam = math.pi / 8.0 * quad(lambda r: c * r**2, 0.0, delta)[0]
            K_measured = 2.0 * lam
            G_measured = 2.0 * quad(lambda r: r**2 * 2.0 * J * C / vol, 0.0, delta)[0]
        assert K_measured == pytest.approx(K, rel=1e-12)
        assert G_measured == pytest.approx(GC, rel=1e-12)
        assert moduli_and_energy(C, beta, dim, M) == pytest.approx((K, GC), rel=1e-14)
    assert potential_constants(K, GC, 3) == pytest.approx((2.0 * GC / 3.0, 9.0 * K / (4.0 * GC)), rel=1e-14)
    assert potential_constants(K, GC, 2) == pytest.approx((math.pi * GC / 4.0, 4.0 * K / (math.pi * GC)), rel=1e-14)


def test_material_reports_its_constants():
    E, KIc = 200.0e9, 2.0e6
    sim = build_simulation(cube_deck({"Material Model": RNP, "Density": 7800.0, "Young's Modulus": E, "KIc": KIc}, n=4))
    m = sim.blocks[0].material
    nu = 0.25
    assert m.K == pytest.approx(E / (3.0 * (1.0 - 2.0 * nu)), rel=1e-14)
    assert m.Gc == pytest.approx(KIc**2 * (1.0 - nu * nu) / E, rel=1e-14)
    assert m.elastic_moduli().youngs_and_poisson() == pytest.approx((E, nu), rel=1e-12)
    r = 2.0
    assert m.inflection_stretch(r) == pytest.approx(1.0 / math.sqrt(2.0 * m.beta * r), rel=1e-15)
    sim = build_simulation(cube_deck({"Material Model": RNP, "Density": 1.0, "C": 3.0, "Beta": 5.0}, n=4))
    m = sim.blocks[0].material
    assert (m.K, m.Gc) == pytest.approx((2.0 * 3.0 * 5.0 / 3.0, 1.5 * 3.0), rel=1e-14)


# -- small-strain limit ------------------------------------------------------------------------
@pytest.mark.parametrize(
    "planar, shape",
    [({}, (6, 6, 6)), ({"Plane Strain": True, "Height": 2e-3}, (9, 9, 1)), ({"Plane Stress": True, "Height": 1e-3}, (9, 9, 1))],
)
def test_small_strain_limit_is_elastic_bond_based(planar, shape):
    """At strain 1e-6 (beta r s^2 ~ 1e-6) force density and stored energy equal the linear
    bond-based model's to 1e-5, point by point."""
    base = {"Density": 7800.0, "Young's Modulus": 200.0e9, **planar}
    out = []
    for entry in ({"Material Model": "Elastic Bond Based", **base}, {"Material Model": RNP, "Gc": GC, **base}):
        sim = build_simulation(cube_deck(entry, shape=shape, spacing=1e-3))
        x = sim.fields["Model_Coordinates"]
        rng = np.random.default_rng(3)
        u = 1e-6 * 1e-3 * rng.standard_normal(x.shape)
        if shape[2] == 1:
            u[:, 2] = 0.0
        sim.fields["Coordinates"][:] = x + u
        f = sim.evaluate_forces().copy()
        W = np.zeros(len(x))
        energy(sim, W)
        out.append((f, W))
    (f0, W0), (f1, W1) = out
    np.testing.assert_allclose(f1, f0, rtol=0, atol=1e-5 * np.abs(f0).max())
    np.testing.assert_allclose(W1, W0, rtol=1e-5)




# -- two points by hand --------------------------------------------------------------------------
def two_points(tmp_path, **params):
    (tmp_path / "pts.txt").write_text("0 0 0 1 1.0\n1 0 0 1 2.0\n")
    entry = {"Material Model": RNP, "Density": 1.0, "C": 3.0, "Beta": 5.0, **params}
    tree = {
        "Discretization": {"Type": "Text File", "Input Mesh File": "pts.txt"},
        "Materials": {"M": entry},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": 1.5}},
    }
    return build_simulation(tree, directory=tmp_path)


def pull(sim, s: float) -> tuple[float, float]:
    """Stretch the bond to s; (force density on the point at the origin along x, its stored
    energy density)."""
    x = sim.fields["Model_Coordinates"]
    a = int(np.argmin(x[:, 0]))
    sim.fields["Coordinates"][:] = x
    sim.fields["Coordinates"][1 - a, 0] = x[1 - a, 0] * (1.0 + s)
    f = sim.evaluate_forces()
    W = energy(sim, np.zeros(2))
    return float(f[a, 0]), float(W[a])


def test_two_points_by_hand_past_the_inflection(tmp_path):
    """Pair force 4 J C beta s exp(-beta r s^2) / (4 pi delta^4 / 3) V_b and energy
    J C (1 - exp(-beta r s^2)) / (4 pi delta^4 / 3) V_b with J = 4, r = 1, V_b = 2: the force
    peaks at the inflection stretch s_c = (2 beta r)^-1/2 and falls past it."""
    sim = two_points(tmp_path)
    C, beta, delta, r, Vb, J = 3.0, 5.0, 1.5, 1.0, 2.0, 4.0
    vol = 4.0 * math.pi / 3.0 * delta**4
    sc = 1.0 / math.sqrt(2.0 * beta * r)
    for s in (1e-3, 0.5 * sc, sc, 2.0 * sc, 5.0 * sc):
        f, W = pull(sim, s)
        assert f == pytest.approx(4.0 * J * C * beta * s * math.exp(-beta * r * s * s) / vol * Vb, rel=1e-12)
        assert W == pytest.approx(J * C * (1.0 - math.exp(-beta * r * s * s)) / vol * Vb, rel=1e-12)
    peak = pull(sim, sc)[0]
    assert pull(sim, 0.99 * sc)[0] < peak and pull(sim, 1.01 * sc)[0] < peak
    assert pull(sim, 50.0 * sc)[1] == pytest.approx(J * C / vol * Vb, rel=1e-12)  # the well's depth


def test_irreversible_fracture_keeps_a_bond_broken(tmp_path):
    """With Irreversible Bond Fracture a bond pulled past Check Sc Factor x s_c stays broken
    when brought back (no force; its energy is the work that broke it); without, it heals."""
    sc = 1.0 / math.sqrt(2.0 * 5.0 * 1.0)
    vol = 4.0 * math.pi / 3.0 * 1.5**4
    for irreversible in (False, True):
        sim = two_points(tmp_path, **{"Irreversible Bond Fracture": irreversible, "Check Sc Factor": 1.5})
        assert ("Bond_Fracture" in sim.fields) is irreversible
        assert pull(sim, 1.4 * sc)[0] > 0.0  # below the breaking stretch: intact
        sim.advance()
        assert pull(sim, 0.5 * sc)[0] > 0.0
        f = pull(sim, 1.6 * sc)[0]
        assert f == 0.0 if irreversible else f > 0.0
        sim.advance()
        f, W = pull(sim, 0.5 * sc)
        if irreversible:
            assert f == 0.0
            assert W == pytest.approx(4.0 * 3.0 * (1.0 - math.exp(-1.5**2 / 2.0)) / vol * 2.0, rel=1e-12)
        else:
            assert f > 0.0


# -- the kit in the small-strain regime ----------------------------------------------------------
class TestRNPConformance(MaterialConformance):
    material = RNP
    params = {"Density": 7800.0, "Bulk Modulus": 130.0e9, "Gc": GC_LINEAR}


class TestRNPConformanceLinearInfluence(MaterialConformance):
    material = RNP
    params = {"Density": 7800.0, "Young's Modulus": 200.0e9, "Gc": GC_LINEAR, "Influence Function Type": "Linear"}


class TestRNPConformanceGaussianPlaneStress(MaterialConformance):
    material = RNP
    params = {"Density": 7800.0, "Young's Modulus": 200.0e9, "Gc": GC_LINEAR, "Influence Function Type": "Gaussian", "Plane Stress": True, "Height": 1e-3}


class TestRNPConformanceIrreversible(MaterialConformance):
    material = RNP
    params = {"Density": 7800.0, "Bulk Modulus": 130.0e9, "Gc": GC_LINEAR, "Irreversible Bond Fracture": True, "Check Sc Factor": 3.0}


# -- bad input -----------------------------------------------------------------------------------
GOOD = {"Material Model": RNP, "Density": 7800.0, "Bulk Modulus": K, "Gc": GC}


@pytest.mark.parametrize(
    "change, words",
    [
        ({"Gc": None}, "Gc"),
        ({"KIc": 1.0e6}, "Gc"),
        ({"Bulk Modulus": None}, "Bulk Modulus"),
        ({"Young's Modulus": 200.0e9}, "Bulk Modulus"),
        ({"Gc": -1.0}, "Gc"),
        ({"Gc": float("nan")}, "Gc"),
        ({"Bulk Modulus": float("inf")}, "Bulk Modulus"),
        ({"C": 1.0}, "Beta"),
        ({"C": 1.0, "Beta": 2.0}, "not both"),
        ({"Influence Function Type": "Parabolic"}, "Influence Function Type"),
        ({"Irreversible Bond Fracture": True, "Check Sc Factor": 0.0}, "Check Sc Factor"),
        ({"Plane Strain": True}, "Height"),
        ({"Plane Strain": True, "Plane Stress": True, "Height": 1.0}, "cannot both"),
        ({"Density": 0.0}, "Density"),
        ({"Critical Stretch": 0.1}, "Critical Stretch"),
    ],
)
def test_bad_parameters_are_refused_with_the_deck_path(change, words):
    entry = {k: v for k, v in {**GOOD, **change}.items() if v is not None}
    with pytest.raises(InputError) as info:
        build_simulation(cube_deck(entry, n=4))
    message = str(info.value)
    assert "Materials" in message and words in message
