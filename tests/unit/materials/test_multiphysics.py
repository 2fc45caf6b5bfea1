"""Multiphysics Elastic: deck rules, the plugin-author suite (with p = 0 it is the LPS solid),
the pressure term of the force, and the exact 4x4-block Jacobian against central differences."""
import tempfile
from typing import ClassVar

import numpy as np
import pytest

from peridyn.core.errors import InputError
from peridyn.materials.multiphysics_elastic import MultiphysicsElasticParams
from peridyn.solvers.implicit.coupled import CoupledProblem
from peridyn.solvers.linalg.coupled_tangent import CoupledTangent
from peridyn.testing import MaterialConformance, build_simulation, cube_deck
from peridyn.testing.harness import scattered_deck

FLUID = {
    "Permeability": 1.0e-12, "Fluid density": 1.0e-9, "Fluid dynamic viscosity": 1.0e-8, "Fluid compressibility": 1.0e-9,
    "Fluid Reynolds viscosity temperature effect": 0.0, "Fluid linear thermal expansion": 0.0,
    "Permeability curve inflection damage": 0.1, "Max permeability": 1.0, "Permeability alpha": 0.25,
}
MATERIAL = {"Material Model": "Multiphysics Elastic", "Density": 7800.0, "Bulk Modulus": 130.0e9, "Shear Modulus": 78.0e9, **FLUID}
MULTI = {"Multiphysics": 1}


class TestMultiphysicsElasticSuite(MaterialConformance):
    material = "Multiphysics Elastic"
    params: ClassVar[dict] = {k: v for k, v in MATERIAL.items() if k != "Material Model"}

    def simulation(self, n: int = 5, *, params=None, **kw):
        kw.setdefault("spacing", self.spacing)
        return build_simulation(cube_deck(self.material_entry(params), n=n, extra=MULTI, **kw))

    def scattered_simulation(self, n: int = 6, *, seed: int = 0, damage=None):
        with tempfile.TemporaryDirectory() as tmp:
            tree = scattered_deck(self.material_entry(), tmp, n=n, spacing=self.spacing, seed=seed, damage=damage)
            tree.update(MULTI)
            return build_simulation(tree, directory=tmp, output_dir=tmp)


# -- deck rules ------------------------------------------------------------------------------------
def test_finite_difference_jacobian_is_refused():
    with pytest.raises(ValueError, match="only the exact"):
        MultiphysicsElasticParams.model_validate({**{k: v for k, v in MATERIAL.items() if k != "Material Model"},
                                                   "Apply Automatic Differentiation Jacobian": False})


def test_required_fluid_parameters():
    params = {k: v for k, v in MATERIAL.items() if k not in ("Material Model", "Permeability")}
    with pytest.raises(ValueError, match="Permeability"):
        MultiphysicsElasticParams.model_validate(params)


@pytest.mark.parametrize("value", [2, 0, 1.5, True])
def test_multiphysics_must_be_one(value):
    with pytest.raises(InputError, match="must be 1"):
        build_simulation(cube_deck(MATERIAL, n=3, extra={"Multiphysics": value}))


def test_every_material_must_be_multiphysics():
    with pytest.raises(InputError, match="not multiphysics compatible"):
        build_simulation(cube_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 1.0}, n=3, extra=MULTI))


def test_multiphysics_material_needs_the_flag():
    with pytest.raises(InputError, match="needs multiphysics enabled"):
        build_simulation(cube_deck(MATERIAL, n=3))


def test_pressure_fields_only_in_multiphysics_decks():
    sim = build_simulation(cube_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 1.0}, n=3))
    assert not any(name in sim.fields for name in ("Fluid_Pressure_Y", "Fluid_Pressure_U", "Flux_Density", "Fluid_Flow_Bond"))
    sim = build_simulation(cube_deck(MATERIAL, n=3, extra=MULTI))
    assert all(name in sim.fields for name in ("Fluid_Pressure_Y", "Fluid_Pressure_U", "Fluid_Pressure_V", "Flux_Density"))
    assert "Surface_Correction_Factor" not in sim.fields  # only with Apply Shear Correction Factor


# -- pressure in the force ----------------------------------------------------------------------------
def test_uniform_pressure_pushes_a_family_apart():
    """At rest, a uniform pressure p gives t = -(3 omega/m) p zeta on every bond: the force of
    an interior point vanishes by symmetry; a corner point is pulled outward... i.e. pushed away
    from its neighbors (force pointing out of the body)."""
    sim = build_simulation(cube_deck(MATERIAL, n=4, spacing=1.0, extra=MULTI))
    sim.fields["Fluid_Pressure_Y"][:] = 1.0e3
    f = sim.evaluate_forces()
    x = sim.fields["Model_Coordinates"]
    centre = x.mean(axis=0)
    outward = np.einsum("ij,ij->i", f, x - centre)
    assert np.all(outward > 0.0)
    sim.fields["Fluid_Pressure_Y"][:] = 0.0
    assert np.abs(sim.evaluate_forces()).max() == 0.0


# -- the exact Jacobian ----------------------------------------------------------------------------
def coupled_state(sim, seed, damage=False):
    rng = np.random.default_rng(seed)
    x = sim.fields["Model_Coordinates"]
    sim.fields["Coordinates"][:] = x + 0.02 * rng.standard_normal(x.shape)
    sim.fields["Fluid_Pressure_Y"][:] = rng.uniform(-1.0, 1.0, x.shape[0])
    if damage:
        d = rng.uniform(0.0, 0.6, sim.bonds.num_bonds)
        sim.fields["Bond_Damage"][:] = d
        sim.fields.n("Bond_Damage")[:] = d
    if "Temperature_Change" in sim.fields:
        sim.fields["Temperature_Change"][:] = rng.uniform(-2.0, 2.0, x.shape[0])


def unknowns_rows(prob):
    F = prob.unknowns_force() * prob.volume[:, None]
    return prob.to_rows(F)


@pytest.mark.parametrize("variant", ["plain", "damage", "thermal", "shear correction"])
def test_jacobian_matches_central_differences(variant):
    """d(f V, flow V)/d(y, p) of the analytic 4x4-block tangent against central differences of
    the residual (every column, all points), on a deformed, pressurised 3x3x2 block."""
    mat = {**MATERIAL, "Bulk Modulus": 2.0, "Shear Modulus": 1.3, "Permeability": 0.7, "Fluid density": 1.1,
           "Fluid dynamic viscosity": 0.9, "Max permeability": 0.4, "Permeability alpha": 3.0}
    damage = None
    if variant == "damage":
        damage = {"Damage Model": "Critical Stretch", "Critical Stretch": 1.0e3}
    if variant == "thermal":
        mat.update({"Thermal Expansion Coefficient": 0.01, "Fluid Reynolds viscosity temperature effect": 0.3})
    if variant == "shear correction":
        mat["Apply Shear Correction Factor"] = True
    sim = build_simulation(cube_deck(mat, shape=(3, 3, 2), spacing=1.0, damage=damage, extra=MULTI))
    coupled_state(sim, seed=5, damage=damage is not None)
    prob = CoupledProblem(sim)
    T = CoupledTangent(sim)
    T.assemble()
    K = T.to_scipy().toarray()
    n = sim.num_owned
    eps = 1.0e-6
    J = np.zeros_like(K)
    for i in range(n):
        row = int(T.row_of_local[i])
        for c in range(4):
            field = sim.fields["Coordinates"] if c < 3 else sim.fields["Fluid_Pressure_Y"]
            idx = (i, c) if c < 3 else i
            orig = field[idx]
            field[idx] = orig + eps
            fp = unknowns_rows(prob)
            field[idx] = orig - eps
            fm = unknowns_rows(prob)
            field[idx] = orig
            J[:, 4 * row + c] = (fp - fm) / (2.0 * eps)
    scale = np.abs(J).max()
    np.testing.assert_allclose(K, J, atol=1e-7 * scale, rtol=1e-6)
    # the coupling blocks are not zero: the check sees both of them
    assert np.abs(K[3::4, :][:, np.r_[0:K.shape[1]].reshape(-1, 4)[:, :3].ravel()]).max() > 1e-3 * scale
    assert np.abs(K[np.r_[0:K.shape[0]].reshape(-1, 4)[:, :3].ravel(), 3::4]).max() > 1e-3 * scale
