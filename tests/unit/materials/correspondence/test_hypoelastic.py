"""Hypoelastic correspondence family (PERIDIGM_CORRESPONDENCE.md §1, §5.2/§5.3/§5.6, §8, §11).

Kernels: Peridigm's SVD and pseudo-inverse against numpy, and the gradient weights' first-order
consistency (any affine velocity field gives its exact gradient, boundary points included).
Through the engine: a homogeneous deformation of a bar gives the classical stress, its velocity
gradient, Jacobian and Green-Lagrange strain, and the force across a mid-plane equals the
traction times the area (this exercises the bond-level chain, which the node-level outputs do
not); the plastic models follow the closed-form J2 uniaxial-strain curve (perfectly plastic and
power-law hardening), in the outputs and in the transmitted force. Deck errors are one InputError
(exit code 2) naming the parameter.
"""
from __future__ import annotations

import math
import textwrap

import netCDF4
import numpy as np
import pytest
from scipy.optimize import brentq

from peridyn.cli import main
from peridyn.core.errors import ExitCode, InputError
from peridyn.deck.files import dump_yaml
from peridyn.deck.model import load_deck
from peridyn.materials.correspondence import hypoelastic_kernels as HK
from peridyn.materials.correspondence import svd as SVD

K, G = 160e9, 80e9
LAM = K - 2.0 * G / 3.0
T_END = 1e-6
STEPS = 200
H = 1e-3  # lattice spacing
NY = 12  # points along y; the bar is 6 x 12 x 6 spacings, cut at mid-height
AREA = 36 * H * H


# ------------------------------------------------------------------------------------------------
# kernels
# ------------------------------------------------------------------------------------------------
def svd(a: np.ndarray):
    m, n = a.shape
    u = np.ascontiguousarray(a, dtype=float).ravel().copy()
    w, v, rv1 = np.zeros(n), np.zeros(n * n), np.zeros(n)
    assert SVD.dsvd(u, m, n, w, v, rv1)
    return u.reshape(m, n), w, v.reshape(n, n)


@pytest.mark.parametrize("shape", [(3, 3), (5, 3), (4, 4), (9, 9)])
def test_dsvd_is_a_singular_value_decomposition(shape):
    rng = np.random.default_rng(sum(shape))
    a = rng.normal(size=shape) * 10.0 ** rng.integers(-3, 4)
    u, w, v = svd(a)
    scale = np.abs(a).max()
    np.testing.assert_allclose(u @ np.diag(w) @ v.T, a, atol=1e-14 * scale * max(shape))
    np.testing.assert_allclose(u.T @ u, np.eye(shape[1]), atol=1e-14 * max(shape))
    np.testing.assert_allclose(v.T @ v, np.eye(shape[1]), atol=1e-14 * max(shape))
    assert (w >= 0.0).all()
    np.testing.assert_allclose(np.sort(w), np.sort(np.linalg.svd(a, compute_uv=False)), rtol=1e-13, atol=1e-14 * scale)


def pinv(M: np.ndarray, threshold: float) -> np.ndarray:
    n = M.shape[0]
    out = np.zeros(n * n)
    assert SVD.pseudo_inverse(np.ascontiguousarray(M, dtype=float).ravel(), n, threshold, out)
    return out.reshape(n, n)


def test_pseudo_inverse_inverts_full_rank_and_drops_the_null_space():
    rng = np.random.default_rng(3)
    B = rng.normal(size=(3, 3))
    M = B @ B.T + 0.1 * np.eye(3)  # symmetric positive definite, like a moment matrix
    np.testing.assert_allclose(pinv(M, 1e-12), np.linalg.inv(M), rtol=1e-12)
    # coplanar bonds: rank 2, the normal direction is dropped (never an error)
    q = rng.normal(size=(20, 2)) @ rng.normal(size=(2, 3))
    M2 = q.T @ q
    got = pinv(M2, 1e-10 * np.abs(M2).max())
    np.testing.assert_allclose(got, np.linalg.pinv(M2, rcond=1e-10), atol=1e-12 * np.abs(got).max())
    # everything below the threshold: zero
    np.testing.assert_array_equal(pinv(M, 1e6), np.zeros((3, 3)))


def test_gradient_weights_reproduce_affine_velocity_fields_exactly(ref):
    """First-order consistency of §8.2-§8.3: with v = A y + c the velocity gradient is A at every
    point (boundary points with one-sided families too), J_NP1 = J_N (1 + tr A dt), and the
    weights satisfy Σ_j (η ⊗ φ) V'_j = I."""
    rng = np.random.default_rng(7)
    y = ref.lattice(5, spacing=1.0, jitter=0.2, seed=1)
    n = len(y)
    horizon = np.full(n, 2.1)
    offsets, neighbors = ref.brute_bonds(y, horizon)
    A = rng.normal(size=(3, 3))
    v = y @ A.T + rng.normal(size=3)
    volume = rng.uniform(0.8, 1.2, n)
    J_N = rng.uniform(0.9, 1.1, n)
    dt = 1e-3
    phi = np.zeros((len(neighbors), 3))
    L, J1, m0, wv = np.zeros((n, 9)), np.zeros(n), np.zeros(n), np.zeros(n)
    bad = HK.precompute_kernel(0, n, offsets, neighbors, y, v, volume, horizon, J_N, np.zeros(0), 0, np.zeros(0), dt, phi, L, J1, m0, wv)
    assert bad == 0
    np.testing.assert_allclose(L.reshape(n, 3, 3), np.broadcast_to(A, (n, 3, 3)), atol=1e-12 * np.abs(A).max())
    np.testing.assert_allclose(J1, J_N * (1.0 + np.trace(A) * dt), rtol=1e-14)
    for i in (0, n // 2, n - 1):
        js = neighbors[offsets[i] : offsets[i + 1]]
        eta = y[js] - y[i]
        np.testing.assert_allclose(np.einsum("ba,bc,b->ac", eta, phi[offsets[i] : offsets[i + 1]], J_N[js] * volume[js]), np.eye(3), atol=1e-12)
        np.testing.assert_allclose(m0[i], (J_N[js] * volume[js]).sum(), rtol=1e-14)  # influence function One, no damage
    np.testing.assert_array_equal(wv, m0)


# ------------------------------------------------------------------------------------------------
# through the engine
# ------------------------------------------------------------------------------------------------
def deck(material: dict, u: tuple[str, str, str], outputs: list[str], influence: str | None = None) -> dict:
    """A 6 x 12 x 6 lattice bar (spacing 1 mm) in two halves ("Bottom", "Top"), every point
    following the prescribed displacement u(x, y, z, t). Neighbor lists from a horizon of
    3.015 mm, the model's Actual Horizon 2.9 mm."""
    half = NY / 2 * H
    shapes = {
        "Bottom": {"Shape": "Box", "Block": "block_1", "Min": [0.0, 0.0, 0.0], "Max": [6 * H, half, 6 * H], "Spacing": H},
        "Top": {"Shape": "Box", "Block": "block_1", "Min": [0.0, half, 0.0], "Max": [6 * H, NY * H, 6 * H], "Spacing": H},
    }
    disc = {"Type": "Shapes", "Shapes": shapes}
    if influence is not None:
        disc["Influence Function"] = influence
    return {
        "Discretization": disc,
        "Materials": {"M": {"Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": G, "Actual Horizon": 2.9 * H, **material}},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": 3.015 * H}},
        "Boundary Conditions": {
            f"U{c}{part}": {"Type": "Prescribed Displacement", "Node Set": part, "Coordinate": c, "Value": expr}
            for c, expr in zip("xyz", u) for part in ("Bottom", "Top")
        },
        "Solver": {"Final Time": T_END, "Verlet": {"Fixed dt": T_END / STEPS}},
        "Output": {"Output Filename": "run", "Output Frequency": STEPS // 8, "Output Variables": {name: True for name in outputs}},
    }


def run(tmp_path, tree) -> netCDF4.Dataset:
    (tmp_path / "d.yaml").write_text(dump_yaml(tree))
    assert main(["run", str(tmp_path / "d.yaml"), "--output-dir", str(tmp_path), "-q", "--no-progress"]) == ExitCode.OK
    return netCDF4.Dataset(tmp_path / "run.e")


def _names(ds, kind: str) -> list[str]:
    return ["".join(c.decode() for c in row if c) for row in ds[f"name_{kind}_var"][:].data]


def tensor(ds, name: str) -> np.ndarray:
    """(frames, points, 3, 3) of an element tensor output (one block)."""
    names = _names(ds, "elem")
    comps = [ds[f"vals_elem_var{names.index(name + a + b) + 1}eb1"][:].data for a in "XYZ" for b in "XYZ"]
    return np.stack(comps, axis=-1).reshape(comps[0].shape + (3, 3))


def scalar(ds, name: str) -> np.ndarray:
    return ds[f"vals_elem_var{_names(ds, 'elem').index(name) + 1}eb1"][:].data


def top_force(ds) -> np.ndarray:
    """(frames, 3): the summed Force (force density x volume) on the points above mid-height,
    i.e. what the bottom half exerts on the top half: -σ·e_y times the cross-section."""
    names = _names(ds, "nod")
    F = np.stack([ds[f"vals_nod_var{names.index('Force' + c) + 1}"][:].data for c in "XYZ"], axis=-1)
    top = ds["coordy"][:].data > NY / 2 * H
    return F[:, top].sum(axis=1)


@pytest.mark.parametrize("influence", [None, "Parabolic Decay", "1.0 - 0.5*zeta/horizon"])
def test_homogeneous_deformation_gives_the_classical_stress_and_traction(tmp_path, influence):
    # small strain e(t) = E t / T_END with a general symmetric E: sigma = lam tr(e) I + 2 G e
    E = np.array([[1.0, 0.3, -0.2], [0.3, -0.5, 0.4], [-0.2, 0.4, 0.7]]) * 1e-5
    u = tuple("+".join(f"({float(E[a, b])!r})*{'xyz'[b]}*t/{T_END!r}" for b in range(3)) for a in range(3))
    outputs = ["Cauchy_Stress", "Unrotated_Cauchy_Stress", "Von_Mises_Stress", "Velocity_Gradient", "Jacobian_Determinant",
               "Green_Lagrange_Strain", "Horizon", "Force"]
    with run(tmp_path, deck({"Material Model": "Elastic Hypoelastic Correspondence"}, u, outputs, influence)) as ds:
        sigma = tensor(ds, "Cauchy_Stress")[-1]
        unrotated = tensor(ds, "Unrotated_Cauchy_Stress")[-1]
        vm = scalar(ds, "Von_Mises_Stress")[-1]
        L = tensor(ds, "Velocity_Gradient")[-1]
        J = scalar(ds, "Jacobian_Determinant")[-1]
        gl = tensor(ds, "Green_Lagrange_Strain")[-1]
        horizon = scalar(ds, "Horizon")[-1]
        traction = top_force(ds)[-1]
    expected = LAM * np.trace(E) * np.eye(3) + 2.0 * G * E
    # the rate form integrates the small strain exactly up to O(|E|) relative
    np.testing.assert_allclose(sigma, np.broadcast_to(expected, sigma.shape), atol=1e-4 * np.abs(expected).max())
    np.testing.assert_allclose(unrotated, sigma, atol=1e-4 * np.abs(expected).max())  # no rotation
    dev = expected - np.trace(expected) / 3.0 * np.eye(3)
    np.testing.assert_allclose(vm, math.sqrt(1.5 * (dev * dev).sum()), rtol=1e-4)
    # L on the current configuration: Ḟ F⁻¹ with F = I + E at the end, exact for affine motion
    np.testing.assert_allclose(L, np.broadcast_to(E / T_END @ np.linalg.inv(np.eye(3) + E), L.shape), atol=1e-9 * np.abs(E / T_END).max())
    np.testing.assert_allclose(J - 1.0, np.linalg.det(np.eye(3) + E) - 1.0, rtol=1e-4)
    np.testing.assert_allclose(gl, np.broadcast_to(E + 0.5 * E.T @ E, gl.shape), atol=1e-4 * np.abs(E).max())
    np.testing.assert_array_equal(horizon, 2.9 * H)  # Actual Horizon replaces the block's horizon
    # the bond-level chain: the force the bottom half exerts on the top half is -σ e_y A
    np.testing.assert_allclose(traction, -expected[:, 1] * AREA, rtol=1e-2, atol=1e-2 * np.abs(expected).max() * AREA)


def hardening_curve(eqps, sy, ec, n):
    return sy if ec is None else sy * (1.0 + eqps / ec) ** n


@pytest.mark.parametrize("hardening", [None, (2e-3, 0.3)], ids=["perfectly-plastic", "power-law"])
def test_uniaxial_strain_follows_the_closed_form_j2_curve(tmp_path, hardening):
    """Uniaxial strain e_yy = e t/T: elastic until the von Mises stress 2 G e reaches sigma_y;
    then the plastic strain is eqps diag(-1/2, 1, -1/2) and sigma_yy - sigma_xx =
    2 G (e - 3/2 eqps) = sigma_h(eqps) (sigma_y, or sigma_y (1 + eqps/eps_c)^n), with the mean
    stress K e: the transmitted force must be -(K e + 2/3 q) A."""
    sy, e_total = 300e6, 1e-2
    mat = {"Material Model": "Elastic Plastic Hypoelastic Correspondence", "Yield Stress": sy}
    ec = n = None
    if hardening is not None:
        ec, n = hardening
        mat.update({"Material Model": "Isotropic Hardening Hypoelastic Correspondence", "Hardening Characteristic Strain": ec,
                    "Hardening Exponent": n})
    u = ("0.0", f"{e_total!r}*y*t/{T_END!r}", "0.0")
    outputs = ["Cauchy_Stress", "Equivalent_Plastic_Strain", "Von_Mises_Stress", "Stress_Triaxiality", "Force"]
    with run(tmp_path, deck(mat, u, outputs)) as ds:
        sigma = tensor(ds, "Cauchy_Stress")
        eqps = scalar(ds, "Equivalent_Plastic_Strain")
        vm = scalar(ds, "Von_Mises_Stress")
        triax = scalar(ds, "Stress_Triaxiality")
        force = top_force(ds)[:, 1]
        t = ds["time_whole"][:].data
    e = e_total * t / T_END
    ep = np.array([brentq(lambda x, ee=ee: 2 * G * (ee - 1.5 * x) - hardening_curve(x, sy, ec, n), 0.0, ee) if 2 * G * ee > sy else 0.0
                   for ee in e])
    assert ep[-1] > 0.4 * e_total  # deep in the plastic range
    q = sigma[:, :, 1, 1] - sigma[:, :, 0, 0]
    expect_q = np.where(ep > 0, [hardening_curve(x, sy, ec, n) for x in ep], 2 * G * e)
    # finite strain rate form vs the small-strain closed form: within 2 %
    np.testing.assert_allclose(q.mean(axis=1), expect_q, rtol=2e-2)
    np.testing.assert_allclose(eqps.mean(axis=1), ep, atol=2e-2 * e_total)
    np.testing.assert_allclose(vm, np.abs(q), rtol=1e-12, atol=1e-6)
    if hardening is not None:  # the power law hardens: well above sigma_y at the end
        assert q[-1].min() > 1.3 * sy
    plastic = ep > 0
    mean = (sigma[:, :, 0, 0] + sigma[:, :, 1, 1] + sigma[:, :, 2, 2]) / 3.0
    np.testing.assert_allclose(triax[plastic], mean[plastic] / vm[plastic], rtol=1e-12)
    np.testing.assert_allclose(force, -(K * e + 2.0 / 3.0 * expect_q) * AREA, rtol=1e-2)


# ------------------------------------------------------------------------------------------------
# deck errors
# ------------------------------------------------------------------------------------------------
DECK = """
Discretization:
  Type: Shapes
  Shapes:
    Body: {{Shape: Box, Block: block_1, Min: [0.0, 0.0, 0.0], Max: [0.004, 0.004, 0.004], Spacing: 0.001}}
Materials:
  M:
    Material Model: "{model}"
    Density: 7800.0
    Young's Modulus: 200.0e9
    Poisson's Ratio: 0.25
{extra}
Blocks:
  B: {{Block Names: block_1, Material: M, Horizon: 0.0031}}
Solver:
  Final Time: 1.0e-8
  Verlet: {{Fixed dt: 1.0e-9}}
Output:
  Output Filename: out
  Output Frequency: 1
  Output Variables: {{{outputs}}}
"""
ISO = "Isotropic Hardening Hypoelastic Correspondence"
HARD = {"Yield Stress": "300.0e6", "Hardening Characteristic Strain": "0.002", "Hardening Exponent": "0.3"}


def write_deck(tmp_path, model: str, params: dict[str, str], outputs: str = "Displacement: true"):
    extra = textwrap.indent("\n".join(f"{k}: {v}" for k, v in params.items()), "    ")
    path = tmp_path / "deck.yaml"
    path.write_text(DECK.format(model=model, extra=extra, outputs=outputs))
    return path


@pytest.mark.parametrize(
    ("model", "params", "needle"),
    [
        ("Elastic Hypoelastic Correspondence", {}, "Actual Horizon"),
        ("Elastic Hypoelastic Correspondence", {"Actual Horizon": "0.0"}, "Actual Horizon"),
        ("Elastic Hypoelastic Correspondence", {"Actual Horizon": "0.003", "Gradient Order Of Accuracy": "2"}, "Gradient Order Of Accuracy"),
        ("Elastic Hypoelastic Correspondence", {"Actual Horizon": "0.003", "Thermal Expansion Coefficient": "1.0e-5"},
         "Thermal Expansion Coefficient"),
        ("Elastic Hypoelastic Correspondence", {"Actual Horizon": "0.003", "Apply Shear Correction Factor": "false"},
         "Apply Shear Correction Factor"),
        ("Elastic Plastic Hypoelastic Correspondence", {"Actual Horizon": "0.003"}, "Yield Stress"),
        (ISO, {"Actual Horizon": "0.003", "Yield Stress": "300.0e6", "Hardening Characteristic Strain": "0.002"}, "Hardening Exponent"),
        (ISO, {"Actual Horizon": "0.003", **HARD, "Hardening Rule": '"Power-law"'}, "Hardening Rule"),
        (ISO, {"Actual Horizon": "0.003", **HARD, "Hardening Characteristic Strain": "0.0"}, "Hardening Characteristic Strain"),
    ],
)
def test_parameter_errors_are_one_input_error_naming_the_key(tmp_path, model, params, needle):
    path = write_deck(tmp_path, model, params)
    with pytest.raises(InputError) as info:
        load_deck(path)
    assert needle in str(info.value)
    assert len(getattr(info.value, "errors", [info.value])) == 1
    assert main(["run", str(path), "--output-dir", str(tmp_path), "-q", "--no-progress"]) == ExitCode.INPUT_ERROR


def test_hourglass_coefficient_is_accepted_and_ignored(tmp_path):
    path = write_deck(tmp_path, ISO, {"Actual Horizon": "0.003", **HARD, "Hourglass Coefficient": "0.02"})
    load_deck(path)
    assert main(["run", str(path), "--output-dir", str(tmp_path), "-q", "--no-progress"]) == ExitCode.OK


def test_the_deformation_gradient_output_is_refused(tmp_path):
    """Peridigm registers Deformation_Gradient twice with different specifications and stops; so
    does peridyn (the compute class would give the shape-tensor F, not the material's)."""
    path = write_deck(tmp_path, "Elastic Hypoelastic Correspondence", {"Actual Horizon": "0.003"}, "Deformation_Gradient: true")
    assert main(["run", str(path), "--output-dir", str(tmp_path), "-q", "--no-progress"]) == ExitCode.INPUT_ERROR
