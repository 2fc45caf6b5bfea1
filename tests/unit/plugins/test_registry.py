"""Plugin discovery: built-ins, third-party distributions through entry points, conflicts and
broken plugins."""
import logging
import sys
import textwrap

import numpy as np
import pytest

from peridyn.core.errors import InputError
from peridyn.plugins import manager
from peridyn.testing import build_simulation, cube_deck


def fake_distribution(root, dist, module, body, entry_name=None):
    """Write an installed-looking distribution: a module and its *.dist-info with an entry
    point in the 'peridyn' group."""
    (root / f"{module}.py").write_text(textwrap.dedent(body))
    info = root / f"{dist}-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(f"[peridyn]\n{entry_name or module} = {module}\n")


MATERIAL = '''
from peridyn.plugins.hookspecs import hookimpl

@hookimpl
def peridyn_materials():
    # the bond-based model under another name: enough to prove the deck finds it
    return [("Third Party Springs", "peridyn.materials.elastic_bond_based:ElasticBondBased")]
'''


@pytest.fixture
def site(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delenv(manager.AUTOLOAD_ENV, raising=False)
    yield tmp_path
    for name in [m for m in sys.modules if m.startswith("fake_")]:
        del sys.modules[name]


def test_builtins_are_registered_without_importing_models():
    reg = manager.build_registry(autoload=False)
    assert {"Elastic", "Elastic Bond Based"} <= set(reg.names("material"))
    assert "Verlet" in reg.names("solver")
    assert reg.entry("material", "Elastic").plugin == "peridyn.plugins.builtins"


def test_third_party_material_from_a_distribution_runs_in_a_deck(site):
    fake_distribution(site, "fake-springs", "fake_springs", MATERIAL)
    reg = manager.build_registry()
    assert reg.entry("material", "Third Party Springs").plugin == "fake_springs"
    sim = build_simulation(cube_deck({"Material Model": "Third Party Springs", "Density": 1000.0, "Bulk Modulus": 1e9}, n=3), registry=reg)
    sim.fields["Coordinates"][:] = sim.fields["Model_Coordinates"] * 1.01
    f = sim.evaluate_forces()
    assert np.abs(f).max() > 0


def test_autoload_can_be_switched_off(site, monkeypatch):
    fake_distribution(site, "fake-springs", "fake_springs", MATERIAL)
    monkeypatch.setenv(manager.AUTOLOAD_ENV, "1")
    assert "Third Party Springs" not in manager.build_registry().names("material")


def test_two_plugins_claiming_one_name_is_an_error_naming_both(site):
    body = MATERIAL.replace("peridyn.materials.elastic_bond_based:ElasticBondBased", "peridyn.materials.elastic:Elastic")
    fake_distribution(site, "fake-one", "fake_one", body.replace("Third Party Springs", "Elastic"))
    with pytest.raises(manager.PluginError) as err:
        manager.build_registry()
    assert "peridyn.plugins.builtins" in str(err.value) and "fake_one" in str(err.value)


def test_broken_plugin_is_reported_once_and_fatal_only_when_used(site, caplog):
    fake_distribution(site, "fake-broken", "fake_broken", "raise ImportError('needs libfoo')\n")
    with caplog.at_level(logging.WARNING, logger="peridyn.plugins"):
        reg = manager.build_registry()
    warnings = [r for r in caplog.records if "fake_broken" in r.getMessage()]
    assert len(warnings) == 1 and "needs libfoo" in warnings[0].getMessage()
    # a deck that does not need it runs
    build_simulation(cube_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 1.0}, n=2), registry=reg)
    # a deck naming an unknown model is told about the broken plugin
    with pytest.raises(InputError) as err:
        build_simulation(cube_deck({"Material Model": "Foo Material", "Density": 1.0}, n=2), registry=reg)
    assert "fake_broken" in str(err.value) and "needs libfoo" in str(err.value)


def test_plugin_module_failing_when_its_model_is_used(site):
    fake_distribution(site, "fake-lazy", "fake_lazy", MATERIAL.replace("peridyn.materials.elastic_bond_based:ElasticBondBased", "fake_lazy_missing:Model"))
    reg = manager.build_registry()
    with pytest.raises(InputError, match="could not be loaded from plugin 'fake_lazy'"):
        build_simulation(cube_deck({"Material Model": "Third Party Springs", "Density": 1.0}, n=2), registry=reg)


CONTRACTLESS = '''
from peridyn.core.params import ModelParams
from peridyn.core.interfaces import Material
from peridyn.plugins.hookspecs import hookimpl


class Loose:  # looks like a material, is not one
    name = "Loose"
    Params = ModelParams


class NoKeys(Material):  # a material with no deck keys declared
    name = "No Keys"


@hookimpl
def peridyn_materials():
    return [("Loose Springs", "fake_loose:Loose"), ("Keyless Springs", "fake_loose:NoKeys")]
'''


@pytest.mark.parametrize("name, words", [("Loose Springs", "is not a subclass of peridyn.core.interfaces.Material"),
                                         ("Keyless Springs", "declares no Params")])
def test_a_model_class_that_breaks_its_contract_is_refused_by_name(site, name, words):
    """The engine reads a model's contract members without probing, so the registry refuses a
    class that is not the contract's subclass or declares no Params, naming it."""
    fake_distribution(site, "fake-loose", "fake_loose", CONTRACTLESS)
    reg = manager.build_registry()
    with pytest.raises(InputError, match="could not be loaded from plugin 'fake_loose'") as err:
        build_simulation(cube_deck({"Material Model": name, "Density": 1.0}, n=2), registry=reg)
    assert words in str(err.value)
    assert isinstance(reg.all_classes("material")[name], TypeError)
