"""Peridigm's bond-associated correspondence family (PERIDIGM_CORRESPONDENCE.md §1, §5.7, §8.2,
§9): the kernels against an independent transcription of the spec, the Newton radial return, the
models through the engine (homogeneous deformation, force flux, closed-form uniaxial-strain
curves) and the deck validation."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from peridyn.engine.run_services import RunServices
from peridyn.cli import main
from peridyn.core.errors import ExitCode, InstabilityError
from peridyn.core.influence import ONE
from peridyn.deck.files import dump_yaml
from peridyn.materials.correspondence import bond_associated_kernels as kern
from peridyn.materials.correspondence import bond_associated_gradients as grad
from peridyn.engine.session import run_sections

EMPTY = np.zeros(0)
K, G = 160e9, 80e9
LAM = K - 2.0 * G / 3.0
T_END = 1e-6
BA = "Elastic Bond Associated Correspondence"
EP = "Elastic Plastic Bond Associated Correspondence"
IH = "Isotropic Hardening Bond Associated Correspondence"
POWER = {"Yield Stress": 300e6, "Hardening Characteristic Strain": 0.002, "Hardening Exponent": 0.2}
SATURATION = {"Initial Yield Stress": 300e6, "Saturated Yield Stress": 500e6, "Exponential Constant": 200.0, "Linear Constant": 1e9}


# ------------------------------------------------------------------------------------------------
# an independent transcription of §5.7, §8.2 and §9 (numpy for the linear algebra)
# ------------------------------------------------------------------------------------------------
def hardening_curve(model, p):
    if model == kern.POWER_LAW:
        return (lambda e: p[0] * (1.0 + e / p[1]) ** p[2]), (lambda e: p[0] * p[2] / p[1] * (1.0 + e / p[1]) ** (p[2] - 1.0))
    return (lambda e: p[0] + (p[1] - p[0]) * (1.0 - math.exp(-p[2] * e)) + p[3] * e), (lambda e: p[2] * (p[1] - p[0]) * math.exp(-p[2] * e) + p[3])


def ref_radial_return(ref, model, p, sN, d, eqps_n, dt, Kb, Gs):
    sig, _ = ref.trial(sN, d, dt, Kb, Gs)
    s, _ = ref.dev(sig)
    t = ref.ssum(s, s)
    vm_tr = math.sqrt(1.5 * t)
    h, dh = hardening_curve(model, p)
    f = vm_tr - h(eqps_n)
    if f < 0.0:
        return sig, vm_tr, eqps_n
    nhat = [sk / max(1e-20, math.sqrt(t)) for sk in s]
    gam, e = 0.0, eqps_n
    while abs(f) > 1e-16 * Kb:
        dl = f / (3.0 * Gs + dh(e))
        gam += dl
        e += dl
        sig = [sig[k] - math.sqrt(6.0) * Gs * dl * nhat[k] for k in range(9)]
        f = vm_tr - 3.0 * Gs * gam - h(e)
    return sig, vm_tr - 3.0 * Gs * gam, e


def ref_stress(ref, model, p, sN, d, eqps_n, dt):
    if model == kern.ELASTIC:
        return ref.elastic(sN, d, dt, K, G), eqps_n
    if model == kern.PERFECT:
        sig, _, e = ref.elastic_plastic(sN, d, eqps_n, dt, K, G, p[0])
        return sig, e
    sig, _, e = ref_radial_return(ref, model, p, sN, d, eqps_n, dt, K, G)
    return sig, e


def ref_weights(x, volume, horizon, offsets, neighbors, damage=None):
    """ω = (1 - d) (influence One), M = Σ ω V Q⊗Q, M⁺ by the SVD with w > 1e-6 δ³, φ = ω M⁺ Q / δ."""
    n, nb = len(x), len(neighbors)
    omega, phi, m = np.zeros(nb), np.zeros((nb, 3)), np.zeros(n)
    for i in range(n):
        bs = range(offsets[i], offsets[i + 1])
        js = neighbors[offsets[i]:offsets[i + 1]]
        Q = (x[js] - x[i]) / horizon[i]
        w = np.array([1.0 - (damage[b] if damage is not None else 0.0) for b in bs])
        M = (Q * (w * volume[js])[:, None]).T @ Q
        U, s, Vh = np.linalg.svd(M)
        keep = s > 1e-6 * horizon[i] ** 3
        Mp = (Vh[keep].T / s[keep]) @ U[:, keep].T
        omega[offsets[i]:offsets[i + 1]] = w
        phi[offsets[i]:offsets[i + 1]] = w[:, None] * (Q @ Mp.T) / horizon[i]
        m[i] = (w * volume[js]).sum()
    return omega, phi, m


def ref_bond_forces(ref, c, model, p):
    """§9.3 steps 2-6 for every point: bond states at NP1 and the force state T."""
    x, y, v, vol, offsets, nbr, dt = c["x"], c["y"], c["v"], c["vol"], c["offsets"], c["nbr"], c["dt"]
    F, Fd = c["F"].reshape(-1, 3, 3), c["Fd"].reshape(-1, 3, 3)
    out = {"V": c["bV"].copy(), "R": c["bR"].copy(), "sig": np.zeros_like(c["bsig"]), "eqps": c["beqps"].copy(), "T": np.zeros((len(nbr), 3))}
    for i in range(len(x)):
        S = np.zeros((3, 3))
        P = {}
        for b in range(offsets[i], offsets[i + 1]):
            j, w = nbr[b], c["omega"][b]
            d = [0.0] * 9
            if w > 0.0:
                X = x[j] - x[i]
                L2 = X @ X
                Fb = 0.5 * (F[i] + F[j])
                Fb = Fb + np.outer((y[j] - y[i]) - Fb @ X, X) / L2
                Fbd = 0.5 * (Fd[i] + Fd[j])
                Fbd = Fbd + np.outer((v[j] - v[i]) - Fbd @ X, X) / L2
                Finv = np.linalg.inv(Fb)
                V1, R1, d = ref.ft((Fbd @ Finv).ravel().tolist(), c["bV"][b].tolist(), c["bR"][b].tolist(), dt)
                out["V"][b], out["R"][b] = V1, R1
            sig, e = ref_stress(ref, model, p, c["bsig"][b].tolist(), d, float(c["beqps"][b]), dt)
            out["sig"][b], out["eqps"][b] = sig, e
            if w > 0.0:
                R = np.array(R1).reshape(3, 3)
                P[b] = np.linalg.det(Fb) * (R @ np.array(sig).reshape(3, 3) @ R.T) @ Finv.T
                S += w * (0.5 / c["m"][i] + 0.5 / c["m"][j]) * vol[j] * P[b] @ (np.eye(3) - np.outer(X, X) / L2)
        for b, Pb in P.items():
            X = x[nbr[b]] - x[i]
            out["T"][b] = c["omega"][b] / c["m"][i] * Pb @ X / (X @ X) + S @ c["phi"][b]
    return out


def cloud(ref, m=5, seed=0, damaged=False):
    """A jittered lattice with random motion and random step-N bond states; kernels' inputs."""
    rng = np.random.default_rng(seed)
    h = 1e-3
    x = ref.lattice(m, spacing=h, jitter=0.15, seed=seed)
    horizon = 2.015 * h * (1.0 + 0.05 * rng.random(len(x)))
    offsets, nbr = ref.brute_bonds(x, horizon)
    n, nb = len(x), len(nbr)
    vol = h**3 * (1.0 + 0.2 * rng.random(n))
    u = x @ np.array([[0.01, 0.02, -0.01], [0.0, -0.015, 0.03], [0.02, 0.0, 0.01]]).T + 2e-6 * rng.standard_normal((n, 3))
    v = 50.0 * rng.standard_normal((n, 3))
    A = rng.standard_normal((nb, 3, 3))
    bV = (np.eye(3) + 0.01 * (A + A.transpose(0, 2, 1))).reshape(nb, 9)
    bR = np.array([ref.random_rotation(rng).ravel() for _ in range(nb)])
    A = rng.standard_normal((nb, 3, 3))
    bsig = (1e8 * (A + A.transpose(0, 2, 1))).reshape(nb, 9)
    damage = np.where(rng.random(nb) < 0.2, 1.0, 0.0) if damaged else EMPTY
    c = {"x": x, "y": x + u, "u": u, "v": v, "vol": vol, "horizon": horizon, "offsets": offsets, "nbr": nbr, "dt": 1e-8, "bV": bV, "bR": bR,
         "bsig": bsig, "beqps": 0.01 * rng.random(nb), "damage": damage}
    c["omega"], c["phi"], c["m"] = np.zeros(nb), np.zeros((nb, 3)), np.zeros(n)
    grad.initialize_kernel(0, n, offsets, nbr, x, vol, horizon, ONE, EMPTY, damage, c["omega"], c["phi"], c["m"])
    rows = [np.zeros((n, 3)) for _ in range(6)]
    grad.precompute_kernel(0, n, offsets, nbr, x, vol, horizon, ONE, EMPTY, EMPTY, EMPTY, EMPTY, c["omega"], c["phi"], u, v, *rows)
    c["F"] = np.concatenate(rows[:3], axis=1)
    c["Fd"] = np.concatenate(rows[3:], axis=1)
    return c


def run_force_kernel(c, model, p):
    n, nb = len(c["x"]), len(c["nbr"])
    plastic = model != kern.ELASTIC
    node = {k: np.zeros((n, 9)) for k in ("V", "R", "d", "sig", "cauchy")}
    VN, RN = np.tile(np.eye(3).ravel(), (n, 1)), np.tile(np.eye(3).ravel(), (n, 1))
    out = {"V": np.zeros((nb, 9)), "R": np.zeros((nb, 9)), "sig": np.zeros((nb, 9)), "eqps": np.zeros(nb) if plastic else EMPTY,
           "T": np.zeros((nb, 3))}
    rows = [np.ascontiguousarray(c[k][:, 3 * r:3 * r + 3]) for k in ("F", "Fd") for r in range(3)]
    bad, code = kern.force_kernel(
        0, n, c["offsets"], c["nbr"], c["x"], c["y"], c["v"], c["vol"], c["m"], c["omega"], c["phi"], *rows,
        VN, RN, node["V"], node["R"], node["d"], np.zeros((n, 9)), node["sig"], node["cauchy"], np.zeros(n),
        np.zeros(n) if plastic else EMPTY, np.zeros(n) if plastic else EMPTY, np.zeros(n) if plastic else EMPTY,
        np.zeros((0, 9)), np.zeros((0, 9)), c["bV"], c["bR"], out["V"], out["R"], c["bsig"], out["sig"],
        c["beqps"] if plastic else EMPTY, out["eqps"], model, K, G, *p, c["dt"], np.zeros((nb, 9)), out["T"],
    )
    assert (bad, code) == (-1, 0)
    return out, node


# ------------------------------------------------------------------------------------------------
# kernels
# ------------------------------------------------------------------------------------------------
def test_gradient_weights_reproduce_affine_fields_and_match_the_reference(ref):
    c = cloud(ref)
    omega, phi, m = ref_weights(c["x"], c["vol"], c["horizon"], c["offsets"], c["nbr"])
    np.testing.assert_array_equal(c["omega"], omega)
    np.testing.assert_allclose(c["phi"], phi, rtol=1e-10, atol=1e-10 * np.abs(phi).max())
    np.testing.assert_allclose(c["m"], m, rtol=1e-14)
    # order-1 weights differentiate an affine field exactly, boundary points included
    A = np.array([[0.01, 0.02, -0.01], [0.0, -0.015, 0.03], [0.02, 0.0, 0.01]])
    c2 = dict(c, u=c["x"] @ A.T)
    rows = [np.zeros((len(c["x"]), 3)) for _ in range(6)]
    grad.precompute_kernel(0, len(c["x"]), c["offsets"], c["nbr"], c["x"], c["vol"], c["horizon"], ONE, EMPTY, EMPTY, EMPTY, EMPTY,
                           c["omega"], c["phi"], c2["u"], c["x"] @ (2.0 * A).T, *rows)
    F = np.stack(rows[:3], axis=1)
    np.testing.assert_allclose(F, np.broadcast_to(np.eye(3) + A, F.shape), atol=1e-12)
    np.testing.assert_allclose(np.stack(rows[3:], axis=1), np.broadcast_to(2.0 * A, F.shape), atol=1e-12)


def test_pseudo_inverse_drops_the_directions_below_the_threshold():
    rng = np.random.default_rng(3)
    B = rng.standard_normal((3, 2))
    M = B @ B.T  # rank 2: Peridigm's invertAndCond never fails, it drops the null direction
    Mp = grad.pseudo_inverse(M, 1e-9)
    np.testing.assert_allclose(Mp, np.linalg.pinv(M), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(M @ Mp @ M, M, atol=1e-12)
    np.testing.assert_array_equal(grad.pseudo_inverse(np.zeros((3, 3)), 0.0), np.zeros((3, 3)))
    full = M + np.eye(3)
    np.testing.assert_allclose(grad.pseudo_inverse(full, 1e-9), np.linalg.inv(full), rtol=1e-12)


def test_damage_growth_recomputes_the_weights_but_keeps_the_weighted_volume(ref):
    c = cloud(ref, damaged=True)
    omega0, phi0, _ = ref_weights(c["x"], c["vol"], c["horizon"], c["offsets"], c["nbr"], c["damage"])
    np.testing.assert_array_equal(c["omega"], omega0)  # broken bonds: ω = 0 from the start
    np.testing.assert_allclose(c["phi"], phi0, rtol=1e-10, atol=1e-10 * np.abs(phi0).max())
    n = len(c["x"])
    m0 = c["m"].copy()
    bond_damage = np.ones(len(c["nbr"]))  # every bond broken now; only points whose Damage grew see it
    dN, dNP1 = np.zeros(n), np.zeros(n)
    dNP1[::3] = 0.5
    rows = [np.zeros((n, 3)) for _ in range(6)]
    omega, phi = c["omega"].copy(), c["phi"].copy()
    grad.precompute_kernel(0, n, c["offsets"], c["nbr"], c["x"], c["vol"], c["horizon"], ONE, EMPTY, dN, dNP1, bond_damage,
                           omega, phi, c["u"], c["v"], *rows)
    for i in range(n):
        sl = slice(c["offsets"][i], c["offsets"][i + 1])
        if i % 3 == 0:
            assert not omega[sl].any() and not phi[sl].any()
            np.testing.assert_array_equal(np.stack(rows[:3], axis=1)[i], np.eye(3))  # no bond left: F = I
        else:
            np.testing.assert_array_equal(omega[sl], c["omega"][sl])
            np.testing.assert_array_equal(phi[sl], c["phi"][sl])
    np.testing.assert_array_equal(c["m"], m0)


@pytest.mark.parametrize(("model", "p"), [
    (kern.ELASTIC, (0.0, 0.0, 0.0, 0.0)),
    (kern.PERFECT, (1.5e8, 0.0, 0.0, 0.0)),
    (kern.POWER_LAW, (1.2e8, 0.002, 0.2, 0.0)),
    (kern.SATURATION, (1.2e8, 3e8, 200.0, 1e9)),
])
@pytest.mark.parametrize("damaged", [False, True])
def test_force_state_matches_the_reference(ref, model, p, damaged):
    c = cloud(ref, seed=1, damaged=damaged)
    got, node = run_force_kernel(c, model, p)
    want = ref_bond_forces(ref, c, model, p)
    for key in ("V", "R", "sig"):
        np.testing.assert_allclose(got[key], want[key], rtol=1e-9, atol=1e-9 * np.abs(want[key]).max(), err_msg=key)
    if model != kern.ELASTIC:
        np.testing.assert_allclose(got["eqps"], want["eqps"], rtol=1e-9, atol=1e-14)
        assert (got["eqps"] > c["beqps"]).mean() > 0.5  # the bonds went plastic
    scale = np.abs(want["T"]).max()
    np.testing.assert_allclose(got["T"], want["T"], rtol=1e-8, atol=1e-9 * scale)
    if damaged:
        assert not got["T"][c["omega"] == 0.0].any()
        np.testing.assert_array_equal(got["V"][c["omega"] == 0.0], c["bV"][c["omega"] == 0.0])  # V, R kept, d = 0
    # the node level: L = Ḟ F⁻¹ and the Flanagan-Taylor update of the (identity) N state
    i = 7
    L = c["Fd"][i].reshape(3, 3) @ np.linalg.inv(c["F"][i].reshape(3, 3))
    _, R1, d = ref.ft(L.ravel().tolist(), np.eye(3).ravel().tolist(), np.eye(3).ravel().tolist(), c["dt"])
    np.testing.assert_allclose(node["d"][i], d, rtol=1e-10, atol=1e-10 * np.abs(d).max())
    np.testing.assert_allclose(node["R"][i], R1, atol=1e-14)


@pytest.mark.parametrize(("model", "p"), [(kern.POWER_LAW, (300e6, 0.002, 0.2, 0.0)), (kern.SATURATION, (300e6, 500e6, 200.0, 1e9))])
@pytest.mark.parametrize("eqps_n", [0.0, 0.02])
def test_newton_radial_return_converges_to_the_hardening_curve(ref, model, p, eqps_n):
    h, _ = hardening_curve(model, p)
    d = np.array([-0.2, 0.3, 0.0, 0.3, 1.0, -0.1, 0.0, -0.1, -0.3])
    sN = np.diag([-1e8, 2e8, 0.5e8]).ravel()
    for dt in (2e-3, 1e-2, 5e-2):  # from just plastic to a large increment
        sig, vm, e, triax, its = kern.stress_update(model, sN, d, eqps_n, dt, K, G, *p)
        s = sig - np.trace(sig.reshape(3, 3)) / 3.0 * np.eye(3).ravel()
        assert 1 <= its <= 8  # quadratic convergence
        assert abs(vm - h(e)) <= 1e-16 * K + 4 * math.ulp(vm)  # on the hardened yield surface (Newton's tolerance)
        assert math.sqrt(1.5 * s @ s) == pytest.approx(vm, rel=1e-12)
        assert triax == pytest.approx(np.trace(sig.reshape(3, 3)) / 3.0 / vm, rel=1e-14)
        # the plastic multiplier is the root of vm_tr - 3 G Γ = σ_h(eqps_N + Γ)
        trial = np.array(ref.trial(sN.tolist(), d.tolist(), dt, K, G)[0])
        st = trial - np.trace(trial.reshape(3, 3)) / 3.0 * np.eye(3).ravel()
        vm_tr = math.sqrt(1.5 * st @ st)
        gam = brentq(lambda g, top=vm_tr: top - 3.0 * G * g - h(eqps_n + g), 0.0, vm_tr / (3.0 * G))
        assert e - eqps_n == pytest.approx(gam, rel=1e-12)
        np.testing.assert_allclose(sig, ref_radial_return(ref, model, p, sN.tolist(), d.tolist(), eqps_n, dt, K, G)[0], rtol=1e-13, atol=1.0)
    # elastic below the curve: the trial stress, eqps unchanged, no iteration
    sig, vm, e, _, its = kern.stress_update(model, np.zeros(9), d, eqps_n, 1e-5, K, G, *p)
    assert (its, e) == (0, eqps_n) and vm < h(eqps_n)


def test_newton_radial_return_gives_up_after_100_iterations():
    # a tolerance that cannot be met (1e-16 K < 0): Peridigm aborts after 100 iterations
    d = np.zeros(9)
    d[4] = 1.0
    _, _, _, _, its = kern.stress_update(kern.POWER_LAW, np.zeros(9), d, 0.0, 1e-2, -1.0, G, 300e6, 0.002, 0.2, 0.0)
    assert its == kern.MAX_NEWTON + 1


# ------------------------------------------------------------------------------------------------
# through the engine
# ------------------------------------------------------------------------------------------------
def deck(material: dict, u, outputs, *, n=6, horizon=3.015, steps=200) -> dict:
    h = 1e-3
    return {
        "Discretization": {"Type": "Shapes", "Shapes": {"Body": {"Shape": "Box", "Block": "block_1", "Min": [0, 0, 0], "Max": [n * h] * 3, "Spacing": h}}},
        "Materials": {"M": {"Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": G, **material}},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": horizon * h}},
        "Boundary Conditions": {
            f"U{c}": {"Type": "Prescribed Displacement", "Node Set": "Body", "Coordinate": c, "Value": expr} for c, expr in zip("xyz", u)
        },
        "Solver": {"Final Time": T_END, "Verlet": {"Fixed dt": T_END / steps}},
        "Output": {"Output Filename": "run", "Output Frequency": steps, "Output Variables": {name: True for name in outputs}},
    }


def simulate(tmp_path, tree):
    """Run the deck in-process; returns the simulation after its last step (two-step fields hold
    the last evaluation in their N arrays after the final swap)."""
    from peridyn.deck.model import load_deck
    from peridyn.engine.simulation import Simulation

    (tmp_path / "d.yaml").write_text(dump_yaml(tree))
    sim = Simulation(load_deck(tmp_path / "d.yaml"), output_dir=tmp_path)
    run = RunServices.of(sim)
    run_sections(sim, run=run)
    run.close(complete=True)
    return sim


def affine(E) -> tuple[str, str, str]:
    return tuple("+".join(f"({float(E[a, b])!r})*{'xyz'[b]}*t/{T_END!r}" for b in range(3)) for a in range(3))


def test_homogeneous_deformation_gives_the_classical_stress_at_every_bond(tmp_path):
    E = np.array([[1.0, 0.3, -0.2], [0.3, -0.5, 0.4], [-0.2, 0.4, 0.7]]) * 1e-5
    sim = simulate(tmp_path, deck({"Material Model": BA, "Hourglass Coefficient": 0.0}, affine(E), ["Cauchy_Stress", "Green_Lagrange_Strain"]))
    s, n = sim.fields, sim.num_owned
    expected = LAM * np.trace(E) * np.eye(3) + 2.0 * G * E
    # the rate form integrates the small strain exactly up to O(|E|^2) (relative O(|E|))
    for name in ("Cauchy_Stress", "Unrotated_Cauchy_Stress"):
        got = s.n(name)[:n].reshape(-1, 3, 3)
        np.testing.assert_allclose(got, np.broadcast_to(expected, got.shape), atol=1e-4 * np.abs(expected).max(), err_msg=name)
    bonds = s.n("Bond_Unrotated_Cauchy_Stress").reshape(-1, 3, 3)
    np.testing.assert_allclose(bonds, np.broadcast_to(expected, bonds.shape), atol=1e-4 * np.abs(expected).max())
    gl = s.n("Green_Lagrange_Strain")[:n].reshape(-1, 3, 3)
    np.testing.assert_allclose(gl, np.broadcast_to(E, gl.shape), atol=1e-4 * np.abs(E).max())
    owner = np.repeat(np.arange(n), np.diff(sim.bonds.offsets[:n + 1]))
    m = np.bincount(owner, weights=s["Volume"][sim.bonds.neighbors[:sim.bonds.offsets[n]]])  # influence One
    np.testing.assert_allclose(s["Weighted_Volume"][:n], m, rtol=1e-13)


def test_the_force_through_a_plane_is_the_stress_times_its_area(tmp_path):
    """Σ f_i V_i over the points above y = L/2 is what the lower half exerts on them: -σ·e_y A.
    Deep inside (3 horizons from the faces) a homogeneous stress leaves no force."""
    E = np.zeros((3, 3))
    E[1, 1], E[0, 0], E[0, 1], E[1, 0] = 1e-5, 0.3e-5, 0.2e-5, 0.2e-5
    n, h = 14, 1e-3
    sim = simulate(tmp_path, deck({"Material Model": BA}, affine(E), ["Force"], n=n, horizon=2.015, steps=10))
    s, own = sim.fields, sim.num_owned
    x, f, V = s["Model_Coordinates"][:own], s["Force_Density"][:own], s["Volume"][:own]
    expected = LAM * np.trace(E) * np.eye(3) + 2.0 * G * E
    upper = x[:, 1] > n * h / 2
    flux = (f[upper] * V[upper, None]).sum(axis=0) / (n * h) ** 2
    np.testing.assert_allclose(flux, -expected[1], atol=1e-3 * np.abs(expected).max())
    deep = np.all((x > 6.05 * h) & (x < (n - 6.05) * h), axis=1)
    assert deep.sum() == 8
    assert np.abs(f[deep]).max() < 1e-12 * np.abs(expected).max() / h


@pytest.mark.parametrize(("material", "curve"), [
    ({"Material Model": EP, "Yield Stress": 300e6}, lambda ep: 300e6),
    ({"Material Model": IH, "Hardening Rule": "Power-law", "Hardening Parameters": POWER}, lambda ep: 300e6 * (1.0 + ep / 0.002) ** 0.2),
    ({"Material Model": IH, "Hardening Rule": "Saturation type exponential", "Hardening Parameters": SATURATION},
     lambda ep: 300e6 + 200e6 * (1.0 - math.exp(-200.0 * ep)) + 1e9 * ep),
])
def test_uniaxial_strain_follows_the_closed_form_curve(tmp_path, material, curve):
    """e_yy = e t/T: elastic until 2 G e reaches the yield stress, then eqps solves
    2 G (e - 3/2 eqps) = σ_h(eqps), and the von Mises stress σ_yy - σ_xx is σ_h(eqps)."""
    e_total = 1e-2
    sim = simulate(tmp_path, deck(material, ("0.0", f"{e_total!r}*y*t/{T_END!r}", "0.0"),
                                  ["Cauchy_Stress", "Von_Mises_Stress", "Equivalent_Plastic_Strain", "Stress_Triaxiality"]))
    s, n = sim.fields, sim.num_owned
    ep = brentq(lambda q: 2.0 * G * (e_total - 1.5 * q) - curve(q), 0.0, e_total)
    sig = s.n("Cauchy_Stress")[:n].reshape(-1, 3, 3)
    # finite-strain rate form against the small-strain closed form: within 2 %
    np.testing.assert_allclose(s["Von_Mises_Stress"][:n], curve(ep), rtol=2e-2)
    np.testing.assert_allclose(sig[:, 1, 1] - sig[:, 0, 0], curve(ep), rtol=2e-2)
    np.testing.assert_allclose(s.n("Equivalent_Plastic_Strain")[:n], ep, rtol=2.5e-2)
    np.testing.assert_allclose(s.n("Bond_Equivalent_Plastic_Strain"), ep, rtol=2.5e-2)  # every bond yields alike
    np.testing.assert_allclose(s["Stress_Triaxiality"][:n], np.trace(sig, axis1=1, axis2=2) / 3.0 / s["Von_Mises_Stress"][:n], rtol=1e-12)


def test_a_return_that_does_not_converge_stops_the_run(tmp_path):
    tree = deck({"Material Model": IH, "Hardening Rule": "Power-law", "Hardening Parameters": POWER}, ("0.0", "0.0", "0.0"), [], steps=1)
    sim = simulate(tmp_path, tree)
    sim.blocks[0].material.K = -1.0  # 1e-16 K < 0: no residual is small enough
    sim.fields.n("Bond_Unrotated_Cauchy_Stress")[:] = np.diag([-1e9, 2e9, -1e9]).ravel()
    with pytest.raises(InstabilityError, match="radial return did not converge"):
        sim.evaluate_forces()


def test_a_singular_deformation_gradient_stops_the_run(tmp_path):
    sim = simulate(tmp_path, deck({"Material Model": BA}, ("0.0", "0.0", "0.0"), [], steps=1))
    mat, s = sim.blocks[0].material, sim.fields
    precompute = mat.precompute

    def flattening(view):  # every point's F loses its third row: det F == 0.0 exactly
        precompute(view)
        s["Deformation_Gradient_Z"][:] = 0.0

    mat.precompute = flattening
    with pytest.raises(InstabilityError, match="deformation gradient of point .* is singular"):
        sim.evaluate_forces()


# ------------------------------------------------------------------------------------------------
# deck validation (§1)
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("material", "message"), [
    ({"Material Model": IH, "Hardening Rule": "Linear", "Hardening Parameters": POWER}, "Hardening Rule"),
    ({"Material Model": IH, "Hardening Rule": "Power-law"}, "missing required key 'Hardening Parameters'"),
    ({"Material Model": IH, "Hardening Rule": "Saturation type exponential", "Hardening Parameters": POWER}, "'Initial Yield Stress'"),
    ({"Material Model": IH, "Hardening Rule": "Power-law", "Hardening Parameters": {**POWER, "Yield Strength": 1.0}}, "Yield Strength"),
    ({"Material Model": EP}, "missing required key 'Yield Stress'"),
    ({"Material Model": BA, "Gradient Order Of Accuracy": 2}, "'Gradient Order Of Accuracy' = 2 is not supported"),
    ({"Material Model": BA, "Thermal Expansion Coefficient": 1e-5}, "Thermal Expansion Coefficient"),
    ({"Material Model": BA, "Apply Shear Correction Factor": False}, "Apply Shear Correction Factor"),
])
def test_bad_parameters_are_one_input_error(tmp_path, capsys, material, message):
    (tmp_path / "d.yaml").write_text(dump_yaml(deck(material, ("0.0", "0.0", "0.0"), [])))
    assert main(["check", str(tmp_path / "d.yaml")]) == ExitCode.INPUT_ERROR
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and message in err[0], err


def test_hourglass_coefficient_and_the_default_order_are_accepted(tmp_path):
    tree = deck({"Material Model": IH, "Hardening Rule": "Saturation type exponential", "Hardening Parameters": SATURATION,
                 "Hourglass Coefficient": 0.0, "Gradient Order Of Accuracy": 1}, ("0.0", "0.0", "0.0"), [])
    (tmp_path / "d.yaml").write_text(dump_yaml(tree))
    assert main(["check", str(tmp_path / "d.yaml")]) == ExitCode.OK
