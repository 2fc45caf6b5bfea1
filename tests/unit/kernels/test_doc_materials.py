"""The two materials docs/architecture.md shows (docs/examples/): written with loop laws in about 80
lines each, they pass the conformance suite every material passes, and the LPS one computes the
built-in Elastic's forces."""
from __future__ import annotations

import importlib
import sys
from pathlib import Path

import numpy as np

from peridyn.plugins.hookspecs import hookimpl
from peridyn.testing import MaterialConformance, build_simulation, cube_deck, isolated_registry

EXAMPLES = Path(__file__).resolve().parents[3] / "docs" / "examples"
sys.path.insert(0, str(EXAMPLES))
lps_material = importlib.import_module("lps_material")
correspondence_material = importlib.import_module("correspondence_material")
sys.path.remove(str(EXAMPLES))

PARAMS = {"Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 79.3e9}


class DocPlugin:
    @hookimpl
    def peridyn_materials(self):
        return [("Doc LPS", "lps_material:DocLPS"), ("Doc Correspondence", "correspondence_material:DocCorrespondence")]


class TestDocLPS(MaterialConformance):
    material = "Doc LPS"
    params = PARAMS
    plugins = (DocPlugin(),)


class TestDocCorrespondence(MaterialConformance):
    material = "Doc Correspondence"
    params = PARAMS
    plugins = (DocPlugin(),)
    central = False


def test_the_doc_lps_is_the_builtin_elastic():
    damage = {"Damage Model": "Critical Stretch", "Critical Stretch": 0.002}
    forces, energies = [], []
    for model in ("Doc LPS", "Elastic"):
        with isolated_registry(DocPlugin()) as reg:
            sim = build_simulation(cube_deck({"Material Model": model, **PARAMS}, n=7, spacing=1e-3, damage=damage), registry=reg)
            sim.fields["Coordinates"][:] += 3e-6 * np.random.default_rng(4).standard_normal(sim.fields["Coordinates"].shape)
            forces.append(sim.evaluate_forces().copy())
            energies.append(sim.stored_energy())
            assert np.count_nonzero(sim.fields["Bond_Damage"])
    np.testing.assert_allclose(forces[0], forces[1], rtol=1e-9, atol=1e-9 * np.abs(forces[1]).max())
    assert energies[0] == np.float64(energies[1]) or abs(energies[0] - energies[1]) <= 1e-9 * abs(energies[1])


def test_the_examples_are_about_eighty_lines():
    for path in EXAMPLES.glob("*.py"):
        code = [line for line in path.read_text().splitlines() if line.strip() and not line.lstrip().startswith("#")]
        assert len(code) <= 100, f"{path.name}: {len(code)} lines of code"
