"""Tools for plugin authors: build small models in memory and run the conformance suites.

A material plugin's tests can be as short as::

    from peridyn.testing import MaterialConformance

    class TestMyMaterial(MaterialConformance):
        material = "My Material"
        params = {"Density": 1000.0, "Bulk Modulus": 1.0e9}

pytest collects the inherited checks: parameter validation, zero force under rigid motion,
momentum conservation, agreement of the fused and generic force paths, independence from the
thread count, and forces that are the derivative of the stored energy.

:mod:`peridyn.testing.tensile` builds Peridigm's tensile test on a straight bar (reaction forces
over gauge strain) to measure the Young's modulus a material gives.
"""
from __future__ import annotations

from .harness import build_simulation, cube_deck, isolated_registry, node_set_ids
from .suites import DamageConformance, MaterialConformance

__all__ = ["build_simulation", "cube_deck", "isolated_registry", "node_set_ids", "MaterialConformance", "DamageConformance"]
