"""The loop laws of Linear LPS Partial Volume, Multiphysics Elastic, Diffusion and Pals (issue 20):
the built-in backends (numba on threads, numba serial) agree bit for bit, which also checks that
the laws' writes into their args (the partial-volume force's y and z sums, the Pals pressure, the
diffusion Jacobian's entries) are gather-safe; the branch-free laws of the common case (omega = 1,
no damage) give the general laws' results; the hand-written helpers of Pals' tangent repeat the
laws' arithmetic exactly; the diffusion Jacobian's diagonal is minus its row's sum.
"""
from pathlib import Path

import numpy as np
import pytest

from peridyn.kernels import compiled
from peridyn.materials import linear_lps_pv, multiphysics_elastic
from peridyn.materials import pals_kernels as kern
from peridyn.testing import build_simulation, cube_deck
from peridyn.testing.physics_checks import set_bond_damage

BACKENDS = ("numba", "numba-serial")
K, MU = 160.0e9, 79.3e9
LLPS = {"Material Model": "Linear LPS Partial Volume", "Density": 8.05, "Bulk Modulus": K, "Shear Modulus": MU}
PALS = {"Material Model": "Pals", "Density": 8.0, "Bulk Modulus": K, "Shear Modulus": MU,
        "Dilatation Influence Function": "Gaussian", "Deviatoric Influence Function": "Parabolic Decay"}
FLUID = {
    "Permeability": 0.7, "Fluid density": 1.1, "Fluid dynamic viscosity": 0.9, "Fluid compressibility": 1.0e-9,
    "Fluid Reynolds viscosity temperature effect": 0.3, "Fluid linear thermal expansion": 0.0,
    "Permeability curve inflection damage": 0.1, "Max permeability": 0.4, "Permeability alpha": 3.0,
}
MULTIPHYSICS = {"Material Model": "Multiphysics Elastic", "Density": 7800.0, "Bulk Modulus": 2.0, "Shear Modulus": 1.3,
                "Thermal Expansion Coefficient": 0.01, "Apply Shear Correction Factor": True, **FLUID}
DIFFUSION = {"Material Model": "Diffusion", "Coefficient": 2.5, "Use Improved Quadrature": True}
#: thermal strain in the damage model: both ends of a bond may differ (the reverse lookup is read)
DAMAGE = {"Damage Model": "Critical Stretch", "Critical Stretch": 1.0e3, "Thermal Expansion Coefficient": 1.0e-3}


def write_hex_mesh(path: Path, n: int) -> None:
    """An n^3 cube of unit HEX8 elements (Exodus), for partial volumes."""
    netCDF4 = pytest.importorskip("netCDF4")
    node = lambda i, j, k: i + (n + 1) * (j + (n + 1) * k)  # noqa: E731
    xyz = np.array([[i, j, k] for k in range(n + 1) for j in range(n + 1) for i in range(n + 1)], dtype=float)
    conn = [[node(i, j, k), node(i + 1, j, k), node(i + 1, j + 1, k), node(i, j + 1, k),
             node(i, j, k + 1), node(i + 1, j, k + 1), node(i + 1, j + 1, k + 1), node(i, j + 1, k + 1)]
            for k in range(n) for j in range(n) for i in range(n)]
    with netCDF4.Dataset(path, "w", format="NETCDF3_64BIT_OFFSET") as ds:
        for name, size in (("len_name", 33), ("num_dim", 3), ("num_nodes", len(xyz)), ("num_elem", len(conn)), ("num_el_blk", 1),
                           ("num_el_in_blk1", len(conn)), ("num_nod_per_el1", 8)):
            ds.createDimension(name, size)
        for d, c in enumerate("xyz"):
            ds.createVariable(f"coord{c}", "f8", ("num_nodes",))[:] = xyz[:, d]
        ds.createVariable("eb_prop1", "i4", ("num_el_blk",))[:] = [1]
        ds.createVariable("eb_status", "i4", ("num_el_blk",))[:] = [1]
        v = ds.createVariable("connect1", "i4", ("num_el_in_blk1", "num_nod_per_el1"))
        v.elem_type = "HEX8"
        v[:] = np.array(conn) + 1


def deformed(sim, seed: int, scale: float, damage: bool):
    """Random positions, temperature changes, pressures; 10 % of the bonds broken (at one end only
    for some) with ``damage``."""
    rng = np.random.default_rng(seed)
    s = sim.fields
    x = s["Model_Coordinates"]
    s["Coordinates"][:] = x + scale * rng.standard_normal(x.shape)
    if damage:
        set_bond_damage(sim, rng.random(sim.bonds.num_bonds) < 0.1, 1)
    for name, lo, hi in (("Temperature_Change", -2.0, 2.0), ("Fluid_Pressure_Y", -1.0, 1.0), ("Temperature", 290.0, 310.0)):
        if name in s:
            s[name][:] = rng.uniform(lo, hi, s[name].shape[0])
    return sim


def simulation(model: str, backend: str, tmp_path: Path):
    if model.startswith("partial volume"):
        damage = model == "partial volume"
        tmp_path.mkdir(parents=True, exist_ok=True)
        write_hex_mesh(tmp_path / "m.g", 4)
        tree = {
            "Discretization": {"Type": "Exodus", "Input Mesh File": "m.g", "Compute Element-Horizon Intersections": True,
                               "Influence Function": "Parabolic Decay"},
            "Materials": {"M": {**LLPS, "Use Partial Volume": True}},
            "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": 1.6}},
        }
        if damage:
            tree["Blocks"]["B"]["Damage Model"] = "D"
            tree["Damage Models"] = {"D": DAMAGE}
        sim = build_simulation(tree, directory=tmp_path, output_dir=tmp_path, backend=backend)
        assert sim.blocks[0].fused and sim.blocks[0].view.damage_symmetric != damage
        return deformed(sim, 1, 1e-3, damage)
    if model == "linear lps plain":
        return deformed(build_simulation(cube_deck(LLPS, n=4, spacing=1e-3), backend=backend), 2, 1e-6, False)
    if model == "multiphysics plain":
        mat = {k: v for k, v in MULTIPHYSICS.items() if k not in ("Thermal Expansion Coefficient", "Apply Shear Correction Factor")}
        return deformed(build_simulation(cube_deck(mat, shape=(4, 3, 3), spacing=1.0, extra={"Multiphysics": 1}), backend=backend), 3, 0.02, False)
    if model == "linear lps":
        tree = cube_deck(LLPS, n=4, spacing=1e-3, damage=DAMAGE)
        tree["Discretization"]["Influence Function"] = "Gaussian"
        return deformed(build_simulation(tree, backend=backend), 2, 1e-6, True)
    if model == "multiphysics":
        tree = cube_deck(MULTIPHYSICS, shape=(4, 3, 3), spacing=1.0, damage=DAMAGE, extra={"Multiphysics": 1})
        return deformed(build_simulation(tree, backend=backend), 3, 0.02, True)
    if model == "diffusion":
        return deformed(build_simulation(cube_deck(DIFFUSION, shape=(5, 4, 4), spacing=0.7), backend=backend), 4, 0.0, False)
    return deformed(build_simulation(cube_deck(PALS, n=4, spacing=1e-3, damage=DAMAGE), backend=backend), 5, 2e-6, True)


FIELDS = ("Weighted_Volume", "Dilatation", "Pals_Pressure", "Fluid_Flow_Bond", "Flux_Divergence", "Quadrature_Weights")


@pytest.mark.parametrize("model", ["linear lps", "linear lps plain", "partial volume", "multiphysics", "multiphysics plain", "diffusion", "pals"])
def test_backends_agree_bit_for_bit(model, tmp_path):
    results = []
    for backend in BACKENDS:
        sim = simulation(model, backend, tmp_path / backend)
        f = sim.evaluate_forces().copy()
        out = [f] + [sim.fields[k].copy() for k in FIELDS if k in sim.fields]
        if model == "diffusion":
            from peridyn.solvers.implicit.diffusion import DiffusionMatrix

            A = DiffusionMatrix(sim)
            A.assemble(sim)
            out.append(A.data.copy())
        else:
            W = np.zeros(sim.num_local)
            sim.blocks[0].material.stored_energy_density(sim.blocks[0].view, W)
            out.append(W)
        results.append(out)
    for a, b in zip(*results):
        np.testing.assert_array_equal(a, b)
    assert np.abs(results[0][-1]).max() > 0 and np.abs(results[0][1]).max() > 0


def test_plain_laws_are_the_general_laws_with_omega_one_and_no_damage():
    """The branch-free laws of the common case (what ``precompute`` and ``force_state`` pick)
    equal the general laws bit for bit where they apply."""
    sim = simulation("linear lps plain", "numba", None)
    sim.evaluate_forces()
    blk = sim.blocks[0]
    mat, view = blk.material, blk.view
    assert mat._plain(view)
    s, nl = sim.fields, sim.bonds
    args = mat._args(view)
    theta = [np.zeros(sim.num_local), np.zeros(sim.num_local)]
    T = [np.zeros((nl.num_bonds, 3)), np.zeros((nl.num_bonds, 3))]
    for k, (dil, force) in enumerate(((linear_lps_pv.DILATATION, linear_lps_pv.FORCE_STATE),
                                      (linear_lps_pv.DILATATION_PLAIN, linear_lps_pv.FORCE_STATE_PLAIN))):
        mat._run(view, dil, args, theta[k])
        mat._run(view, force, args, T[k])
    np.testing.assert_array_equal(theta[0], theta[1])
    np.testing.assert_array_equal(T[0], T[1])
    assert np.abs(T[0]).max() > 0

    sim = simulation("multiphysics plain", "numba", None)
    sim.evaluate_forces()
    blk = sim.blocks[0]
    mat, view = blk.material, blk.view
    assert mat._plain(view)
    s, nl = sim.fields, sim.bonds
    kind, delta, table = mat._common(view)
    dT, aT = mat._dT(view)
    run = lambda law, args, out: compiled(view, law)(view.start, view.stop, nl.offsets, nl.neighbors, s["Bond_Length"],  # noqa: E731
                                                     s["Coordinates"], args, out)
    dil_args = (s["Volume"], s["Weighted_Volume"], kind, delta, table, mat._damage(view), dT, aT)
    force_args = (s["Weighted_Volume"], s["Dilatation"], mat.scf(view), s["Fluid_Pressure_Y"], mat.K, mat.mu, kind, delta, table,
                  mat._damage(view), dT, aT)
    out = []
    for dil, force in ((multiphysics_elastic.DILATATION, multiphysics_elastic.COUPLED_FORCE_STATE),
                       (multiphysics_elastic.DILATATION_PLAIN, multiphysics_elastic.COUPLED_FORCE_STATE_PLAIN)):
        theta, t = np.zeros(sim.num_local), np.zeros(nl.num_bonds)
        run(dil, dil_args, theta)
        run(force, force_args, t)
        out.append((theta, t))
    np.testing.assert_array_equal(out[0][0], out[1][0])
    np.testing.assert_array_equal(out[0][1], out[1][1])
    assert np.abs(out[0][1]).max() > 0


def test_linear_lps_never_reads_bond_lengths(tmp_path):
    """Linear LPS works on reference bonds with |xi| from the positions: the lazy Bond_Length
    field is never allocated (forces, partial volumes, energy)."""
    for model in ("linear lps plain", "partial volume without damage"):
        sim = simulation(model, "numba", tmp_path / model.replace(" ", "_"))
        sim.evaluate_forces()
        W = np.zeros(sim.num_local)
        sim.blocks[0].material.stored_energy_density(sim.blocks[0].view, W)
        assert not sim.fields.allocated("Bond_Length"), model


def test_pals_tangent_helpers_repeat_the_laws():
    """The finite-difference tangent re-evaluates theta, p and the force state with per-point
    helpers: they equal the laws' results bit for bit (with broken bonds)."""
    sim = simulation("pals", "numba", None)
    sim.evaluate_forces()
    blk = sim.blocks[0]
    mat, view = blk.material, blk.view
    s, nl = sim.fields, sim.bonds
    t = np.zeros(nl.num_bonds)
    mat.force_state(view, t)
    d = s["Bond_Damage"]
    assert d.any()
    two_mu = 2.0 * mat.mu
    for i in range(view.start, view.stop):
        th, p = kern.point_theta_p(i, nl.offsets, nl.neighbors, s["Bond_Length"], s["Coordinates"], s["Volume"], mat.W, mat.Sg,
                                   s["Weighted_Volume"][i], mat.K, two_mu, d)
        assert (th, p) == (s["Dilatation"][i], s["Pals_Pressure"][i])
        ti = np.zeros(nl.offsets[i + 1] - nl.offsets[i])
        kern.point_force_state(i, nl.offsets, nl.neighbors, s["Bond_Length"], s["Coordinates"], mat.W, mat.Sg, th, p, two_mu, d, ti, 0)
        np.testing.assert_array_equal(ti, t[nl.offsets[i] : nl.offsets[i + 1]])


def test_diffusion_jacobian_diagonal_is_minus_the_row_sum():
    """J_ii = -sum_j J_ij, summed in bond order (the law's sum of -J_ij), bit for bit."""
    from peridyn.solvers.implicit.diffusion import DiffusionMatrix

    sim = simulation("diffusion", "numba", None)
    A = DiffusionMatrix(sim)
    A.assemble(sim)
    nl = sim.bonds
    for i in range(sim.num_owned):
        acc = 0.0
        for b in range(nl.offsets[i], nl.offsets[i + 1]):
            acc += -A.data[A.bond_pos[b]]
        assert A.data[A.diag_pos[A.row_of_local[i]]] == acc
    assert np.abs(A.data[A.bond_pos]).min() > 0
