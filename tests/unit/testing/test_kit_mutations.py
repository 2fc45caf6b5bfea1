"""Mutation tests of the kit (``peridyn.testing``): every classic bug, applied to each built-in
ordinary material (Elastic, Elastic Bond Based, Elastic Plastic and Viscoelastic in their elastic
range, Pals) and to the material ``peridyn new-plugin`` writes, fails the checks named in
``CAUGHT_BY``, while the models themselves pass every check.

The bugs are those of the issue: a doubled modulus, a force missing a factor of the bond length,
a per-point factor, an ignored density, a flipped sign, ignored bond damage
(:func:`peridyn.testing.mutants.material_mutant`); and for damage models: bonds that never
break, damage that heals, half the bonds ignored (``damage_mutant``).
"""
from __future__ import annotations

import importlib
import sys

import pytest

from peridyn.damage.critical_stretch import CriticalStretch
from peridyn.materials.elastic import Elastic
from peridyn.materials.elastic_bond_based import ElasticBondBased
from peridyn.materials.elastic_plastic import ElasticPlastic
from peridyn.materials.pals import Pals
from peridyn.materials.viscoelastic import Viscoelastic
from peridyn.plugins.scaffold import new_plugin
from peridyn.testing import DamageConformance, MaterialConformance
from peridyn.testing.mutants import (
    DAMAGE_MUTATIONS,
    MATERIAL_MUTATIONS,
    ModelPlugin,
    damage_mutant,
    material_mutant,
    run_checks,
)

TEMPLATE = "kit_mutation_template"  # the package new-plugin renders; class KitMutationTemplate

#: the models, their parameters (Density 1000 = the fixed density of the "density ignored" bug:
#: the kit must vary the density to see it) and whether their blocks use a fused kernel
MODELS = {
    "Elastic": ({"Density": 1000.0, "Bulk Modulus": 1.6e9, "Shear Modulus": 0.8e9}, True),
    "Elastic Bond Based": ({"Density": 1000.0, "Bulk Modulus": 1.3e9}, True),
    "template": ({"Density": 1000.0, "Bulk Modulus": 1.0e9}, False),
    # the newer ordinary models, in their elastic range (a yield stress far above the kit's strains)
    "Elastic Plastic": ({"Density": 1000.0, "Bulk Modulus": 1.6e9, "Shear Modulus": 0.8e9, "Yield Stress": 1.0e30}, True),
    "Viscoelastic": ({"Density": 1000.0, "Bulk Modulus": 1.6e9, "Shear Modulus": 0.8e9, "lambda_i": 0.5, "tau b": 1.0}, True),
    "Pals": ({"Density": 1000.0, "Bulk Modulus": 1.6e9, "Shear Modulus": 0.8e9}, False),
}
#: models without a stored energy (Peridigm defines none for them): the energy checks skip, and
#: the bugs must be caught by the force checks alone
NO_ENERGY = {"Elastic Plastic", "Viscoelastic"}
ENERGY_CHECKS = {"test_stored_energy_gives_the_stated_moduli", "test_force_is_minus_gradient_of_stored_energy"}

MODULI = "test_force_density_gives_the_stated_moduli"
ENERGY_MODULI = "test_stored_energy_gives_the_stated_moduli"
#: checks each bug must fail (every model defines a stored energy)
CAUGHT_BY = {
    "modulus doubled": [MODULI, ENERGY_MODULI],
    "bond length missing": [MODULI, "test_force_is_minus_gradient_of_stored_energy"],
    "per-point factor": ["test_interior_response_is_uniform"],
    "density ignored": ["test_density_is_the_stated_one"],
    "sign flipped": ["test_uniform_stretch_pulls_the_body_together", MODULI, ENERGY_MODULI],
    "damage ignored": ["test_fully_damaged_bonds_carry_no_force", "test_a_point_with_broken_bonds_is_cut_off"],
}
#: a fused kernel writes force densities itself: a per-point factor there breaks momentum too
#: (scalar force states cannot: the engine applies t_ij + t_ji to both ends of a bond)
CAUGHT_IN_FUSED_KERNELS = {
    "per-point factor": ["test_linear_momentum_is_conserved", "test_angular_momentum_is_conserved", "test_fused_and_generic_paths_agree"],
}
#: checks a model may skip: (model, check) -> why
MAY_SKIP = {
    ("template", "test_row_local_parts_give_the_same_forces"): "the template does not declare row_local",
    **{(m, "test_row_local_parts_give_the_same_forces"): "no row-local parts declared" for m in ("Elastic Plastic", "Viscoelastic", "Pals")},
    **{(m, "test_the_gpu_step_gives_the_cpu_forces"): "no GPU path declared" for m in ("template", "Elastic Plastic", "Viscoelastic", "Pals")},
}


@pytest.fixture(scope="module")
def template_class(tmp_path_factory):
    """The material class of a freshly rendered ``peridyn new-plugin --kind material``."""
    root = new_plugin(TEMPLATE, directory=tmp_path_factory.mktemp("scaffold"))
    sys.path.insert(0, str(root / "src"))
    try:
        yield importlib.import_module(f"{TEMPLATE}.model").KitMutationTemplate
    finally:
        sys.path.remove(str(root / "src"))
        for name in [m for m in sys.modules if m == TEMPLATE or m.startswith(TEMPLATE + ".")]:
            del sys.modules[name]


def material_class(model: str, template_class) -> type:
    return {"Elastic": Elastic, "Elastic Bond Based": ElasticBondBased, "template": template_class, "Elastic Plastic": ElasticPlastic,
            "Viscoelastic": Viscoelastic, "Pals": Pals}[model]


def material_suite(model: str, cls: type, label: str) -> type:
    """A MaterialConformance subclass for ``cls`` registered under a deck name of its own."""
    name = f"{model} ({label})"
    params, _ = MODELS[model]
    plugin = ModelPlugin(materials={name: cls})
    return type("MutantSuite", (MaterialConformance,), {"material": name, "params": params, "plugins": (plugin,)})


@pytest.mark.parametrize("model", list(MODELS))
def test_the_unmutated_model_passes_every_check(model, template_class):
    cls = material_class(model, template_class)
    results = run_checks(material_suite(model, cls, "as is"))
    assert len(results) >= 17
    for check, outcome in results.items():
        if outcome.status == "skipped" and ((model, check) in MAY_SKIP or (model in NO_ENERGY and check in ENERGY_CHECKS)):
            continue
        assert outcome.status == "passed", f"{model}: {check} {outcome.status}: {outcome.message}"


@pytest.mark.parametrize("mutation", MATERIAL_MUTATIONS)
@pytest.mark.parametrize("model", list(MODELS))
def test_the_kit_catches_the_bug(model, mutation, template_class):
    base = material_class(model, template_class)
    checks = CAUGHT_BY[mutation] + (CAUGHT_IN_FUSED_KERNELS.get(mutation, []) if MODELS[model][1] else [])
    if model in NO_ENERGY:
        checks = [c for c in checks if c not in ENERGY_CHECKS]
    results = run_checks(material_suite(model, material_mutant(base, mutation), mutation), checks)
    missed = {check: f"{o.status} {o.message}".strip() for check, o in results.items() if not o.failed}
    assert not missed, f"{model} with the bug '{mutation}' passes checks that should catch it: {missed}"


CAUGHT_DAMAGE_BUG_BY = {
    "never breaks": ["test_large_stretch_breaks_bonds_for_good", "test_uniform_stretch_damages_every_bond"],
    "heals": ["test_large_stretch_breaks_bonds_for_good"],
    "breaks half": ["test_uniform_stretch_damages_every_bond", "test_point_damage_follows_bond_damage", "test_declared_symmetry_holds"],
}


def damage_suite(cls: type, label: str) -> type:
    name = f"Critical Stretch ({label})"
    plugin = ModelPlugin(damage_models={name: cls})
    return type("DamageMutantSuite", (DamageConformance,), {"damage": name, "params": {"Critical Stretch": 0.01}, "plugins": (plugin,)})


def test_the_unmutated_damage_model_passes_every_check():
    results = run_checks(damage_suite(CriticalStretch, "as is"))
    assert len(results) >= 7
    assert all(o.status == "passed" for o in results.values()), results


@pytest.mark.parametrize("mutation", DAMAGE_MUTATIONS)
def test_the_damage_kit_catches_the_bug(mutation):
    results = run_checks(damage_suite(damage_mutant(CriticalStretch, mutation), mutation), CAUGHT_DAMAGE_BUG_BY[mutation])
    missed = {check: f"{o.status} {o.message}".strip() for check, o in results.items() if not o.failed}
    assert not missed, f"Critical Stretch with the bug '{mutation}' passes checks that should catch it: {missed}"


def test_a_crashing_check_is_an_error_not_a_catch():
    """run_checks tells an assertion (the check caught something) from a crash."""

    class Suite:
        def test_asserts(self):
            assert False, "caught"

        def test_crashes(self):
            raise KeyError("Bond_Damage")

        def test_skips(self):
            pytest.skip("not applicable")

        def test_passes(self):
            pass

    results = run_checks(Suite)
    assert {k: o.status for k, o in results.items()} == {
        "test_asserts": "failed", "test_crashes": "error", "test_passes": "passed", "test_skips": "skipped",
    }
