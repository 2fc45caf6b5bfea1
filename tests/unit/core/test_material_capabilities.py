"""The Material contract's capabilities (peridyn.core.interfaces): every built-in material
declares them (read plainly, no AttributeError), elastic constants come from
``elastic_moduli()``, and a plugin material, not named like a built-in, that declares them
works with Critical Energy, J_Integral and Multiphysics exactly as the built-in one does."""
import math
import typing

import numpy as np
import pytest

from peridyn.computes.j_integral import elastic_constants
from peridyn.core.errors import InputError
from peridyn.core.interfaces import BondEnergy, ElasticModuli, ForceStateKind, Material, TangentCoupling
from peridyn.damage.critical_energy import CriticalEnergy, CriticalEnergyParams
from peridyn.materials.elastic import Elastic
from peridyn.materials.elastic_bond_based import ElasticBondBased
from peridyn.materials.multiphysics_elastic import MultiphysicsElastic
from peridyn.plugins.manager import get_registry
from peridyn.testing import build_simulation, cube_deck, isolated_registry
from peridyn.testing.mutants import ModelPlugin

BUILTIN = get_registry().names("material")
K, MU = 40e9, 24e9
ELASTIC = {"Density": 2000.0, "Bulk Modulus": K, "Shear Modulus": MU}
FLUID = {
    "Permeability": 1.0e-12, "Fluid density": 1.0e-9, "Fluid dynamic viscosity": 1.0e-8, "Fluid compressibility": 1.0e-9,
    "Fluid Reynolds viscosity temperature effect": 0.0, "Fluid linear thermal expansion": 0.0,
    "Permeability curve inflection damage": 0.1, "Max permeability": 1.0, "Permeability alpha": 0.25,
}


@pytest.mark.parametrize("name", BUILTIN)
def test_every_builtin_material_declares_the_capabilities(name):
    cls = get_registry().get("material", name)
    assert issubclass(cls, Material)
    assert cls.force_state_kind in typing.get_args(ForceStateKind)
    assert cls.tangent_coupling in typing.get_args(TangentCoupling)
    assert cls.bond_energy is None or cls.bond_energy in typing.get_args(BondEnergy)
    for flag in (cls.tangent_perturbs_velocity, cls.requires_constant_horizon, cls.multiphysics, cls.row_local):
        assert isinstance(flag, bool)
    assert isinstance(cls.precompute_fields, tuple) and isinstance(cls.ghost_inputs, tuple)
    # a multiphysics material names the bond field of its fluid flow (the coupled solver gathers it)
    assert (cls.flow_bond_field is not None) == cls.multiphysics
    assert cls.flow_bond_field is None or isinstance(cls.flow_bond_field, str)
    assert callable(cls.elastic_moduli)


# (deck name, parameters, (K, mu, planar, hookean) or None)
INSTANCES = [
    ("Elastic", ELASTIC, (K, MU, "3d", True)),
    ("Elastic Partial Volume", ELASTIC, (K, MU, "3d", True)),
    ("Linear LPS Partial Volume", ELASTIC, (K, MU, "3d", True)),
    ("Pals", ELASTIC, (K, MU, "3d", True)),
    ("Elastic Bond Based", {"Density": 1.0, "Bulk Modulus": K}, (K, 0.6 * K, "3d", True)),
    ("Elastic Bond Based", {"Density": 1.0, "Bulk Modulus": K, "Plane Stress": True, "Height": 0.1}, (K, 0.5 * K, "plane stress", True)),
    ("Elastic Plastic", {**ELASTIC, "Yield Stress": 1e8}, (K, MU, "3d", False)),
    ("Viscoelastic", {**ELASTIC, "lambda_i": 0.5, "tau b": 1.0}, (K, MU, "3d", False)),
    ("Multiphysics Elastic", {**ELASTIC, **FLUID}, (K, MU, "3d", False)),
    ("Elastic Correspondence", {**ELASTIC, "Hourglass Coefficient": 0.02}, (K, MU, "3d", True)),
    ("Elastic Plastic Correspondence", {**ELASTIC, "Hourglass Coefficient": 0.02, "Yield Stress": 1e8}, (K, MU, "3d", False)),
    ("Elastic Hypoelastic Correspondence", {**ELASTIC, "Actual Horizon": 1.0}, (K, MU, "3d", True)),
    ("Elastic Plastic Hypoelastic Correspondence", {**ELASTIC, "Actual Horizon": 1.0, "Yield Stress": 1e8}, (K, MU, "3d", False)),
    ("Elastic Bond Associated Correspondence", ELASTIC, (K, MU, "3d", True)),
    ("Elastic Plastic Bond Associated Correspondence", {**ELASTIC, "Yield Stress": 1e8}, (K, MU, "3d", False)),
    ("Elastic", {"Density": 1.0, "Young's Modulus": 70e9, "Poisson's Ratio": 0.2, "Plane Strain": True}, None),
    ("Diffusion", {"Coefficient": 2.5}, None),
]


@pytest.mark.parametrize("name, params, expected", INSTANCES)
def test_elastic_moduli_of_the_builtin_materials(name, params, expected):
    cls = get_registry().get("material", name)
    mat = cls(cls.Params.model_validate(params), horizon=1.0)
    moduli = mat.elastic_moduli()
    if name == "Diffusion":
        assert moduli is None
        return
    assert isinstance(moduli, ElasticModuli)
    if expected is None:  # plane strain from E, nu: the 2D bulk modulus lambda + mu
        E, nu = 70e9, 0.2
        lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
        assert (moduli.bulk, moduli.shear, moduli.planar) == (pytest.approx(lam + mu), pytest.approx(mu), "plane strain")
        assert moduli.youngs_and_poisson() == pytest.approx((E, nu), rel=1e-12)
        return
    assert (moduli.bulk, moduli.shear, moduli.planar, moduli.hookean) == (pytest.approx(expected[0]), pytest.approx(expected[1]), *expected[2:])
    assert moduli.bulk == mat.bulk_modulus


# ------------------------------------------------------------------------------------------------
# plugin materials that declare the capabilities, under names no built-in has
# ------------------------------------------------------------------------------------------------
class Springs(Material):
    """A bare contract implementation (no built-in base): the bond-based micropotential."""

    name = "Third Party Springs"
    Params = ElasticBondBased.Params
    bond_energy = "pair"

    def __init__(self, params, *, horizon, options=None):
        super().__init__(params, horizon=horizon, options=options)
        self.K = params.bulk()
        self.c = 18.0 * self.K / (math.pi * horizon**4)

    density = property(lambda self: self.params.density)
    bulk_modulus = property(lambda self: self.K)

    def elastic_moduli(self):
        return ElasticModuli(self.K, 0.6 * self.K, "3d", micromodulus=self.c)

    def force_state(self, block, t):
        raise NotImplementedError


class ThirdPartyLPS(Elastic):
    """A plugin's LPS solid: Elastic's kernels under another name, declaring the capability and
    the moduli itself."""

    name = "Third Party LPS"
    bond_energy = "lps"

    def elastic_moduli(self):
        return ElasticModuli(self.K, self.mu, "3d")


class ThirdPartyPoro(MultiphysicsElastic):
    name = "Third Party Poro"  # no 'Multiphysics' in the name: the flag decides
    multiphysics = True


def critical_stretch(material) -> float:
    damage = CriticalEnergy(CriticalEnergyParams.model_validate({"Critical Energy": 250.0}))
    damage.bind_material(material)
    return damage.s_c


def test_a_bare_contract_material_is_asked_not_named():
    params = ElasticBondBased.Params.model_validate({"Density": 1.0, "Bulk Modulus": K})
    builtin, plugin = ElasticBondBased(params, horizon=3e-3), Springs(params, horizon=3e-3)
    assert critical_stretch(plugin) == critical_stretch(builtin)
    assert elastic_constants(plugin) == elastic_constants(builtin)


def test_a_material_without_the_capabilities_is_refused():
    class Silent(Springs):
        name = "Silent"
        bond_energy = None

        def elastic_moduli(self):
            return None

    mat = Silent(ElasticBondBased.Params.model_validate({"Density": 1.0, "Bulk Modulus": K}), horizon=3e-3)
    with pytest.raises(ValueError, match="bond_energy"):
        critical_stretch(mat)
    with pytest.raises(ValueError, match="gives no elastic constants"):
        elastic_constants(mat)


def _lps_deck(model: str) -> dict:
    j = {"Compute Class": "J_Integral", "Crack Tip X": 2.5e-3, "Crack Tip Y": 2.5e-3, "Inner Radius": 1e-3, "Outer Radius": 2.2e-3,
         "Thickness": 5e-3}
    return cube_deck({"Material Model": model, **ELASTIC}, n=5, spacing=1e-3, damage={"Damage Model": "Critical Energy", "Critical Energy": 250.0},
                     extra={"Compute Class Parameters": {"J": j}})


def test_plugin_lps_works_with_critical_energy_and_j_integral_like_elastic():
    with isolated_registry(ModelPlugin(materials={"Third Party LPS": ThirdPartyLPS})):
        plugin = build_simulation(_lps_deck("Third Party LPS"))
    builtin = build_simulation(_lps_deck("Elastic"))
    assert plugin.blocks[0].damage.s_c == builtin.blocks[0].damage.s_c
    for sim in (plugin, builtin):
        x = sim.fields["Model_Coordinates"]
        sim.fields["Coordinates"][:] = x + 0.1 * np.column_stack([x[:, 0] ** 2, 0.0 * x[:, 1], 0.0 * x[:, 2]])  # not in equilibrium: J != 0
    j = builtin.outputs.computes["J"].value(builtin)
    assert abs(j) > 1.0
    assert plugin.outputs.computes["J"].value(plugin) == j


def test_plugin_multiphysics_material_is_recognised_by_its_flag():
    with isolated_registry(ModelPlugin(materials={"Third Party Poro": ThirdPartyPoro})):
        sim = build_simulation(cube_deck({"Material Model": "Third Party Poro", **ELASTIC, **FLUID}, n=3, extra={"Multiphysics": 1}))
        assert sim.deck.multiphysics
        with pytest.raises(InputError, match="needs multiphysics enabled"):
            build_simulation(cube_deck({"Material Model": "Third Party Poro", **ELASTIC, **FLUID}, n=3))


@pytest.mark.parametrize("name", BUILTIN)
def test_a_material_with_a_probe_length_key_hands_it_to_the_tangent(name):
    """Every material whose deck keys include 'Finite Difference Probe Length' returns it from
    ``finite_difference_probe_length()`` (the tangent reads it there, over the solver's); the
    others keep the contract's None."""
    from types import SimpleNamespace

    cls = get_registry().get("material", name)
    own = SimpleNamespace(params=SimpleNamespace(finite_difference_probe_length=1.25e-7))
    if "finite_difference_probe_length" in cls.Params.model_fields:
        assert cls.finite_difference_probe_length(own) == 1.25e-7
    else:
        assert cls.finite_difference_probe_length is Material.finite_difference_probe_length
