"""Tools for plugin authors: build small models in memory and run the conformance suites.

A material plugin's tests can be as short as::

    from peridyn.testing import MaterialConformance

    class TestMyMaterial(MaterialConformance):
        material = "My Material"
        params = {"Density": 1000.0, "Bulk Modulus": 1.0e9}

pytest collects the inherited checks: parameter validation; the stated bulk and shear moduli
under quadratic displacement fields (force density) and homogeneous strains (stored energy);
the same force at every interior point; a stretched body that pulls itself together; linear
and angular momentum on irregular point clouds; broken bonds that carry no force; the stated
density and bulk modulus; forces that are minus the gradient of the stored energy; zero force
under rigid motion; agreement of the fused and generic force paths and of row-local parts;
independence from the thread count (:mod:`peridyn.testing.physics_checks` gives the
tolerances). :class:`DamageConformance` does the same for damage models, and
:class:`ContactConformance` for contact models (:mod:`peridyn.testing.contact_suite`) and
:class:`NonOrdinaryConformance` for rate-form, vector force-state materials such as the
correspondence family (:mod:`peridyn.testing.nonordinary`), and :class:`TransportConformance`
for transport materials such as ``Diffusion`` (:mod:`peridyn.testing.transport`).

:mod:`peridyn.testing.probes` holds the measurements (moduli of a lattice model, interior
points); :mod:`peridyn.testing.mutants` derives buggy variants of a model and runs a suite's
checks on them outside pytest, to see what the suite catches.

:mod:`peridyn.testing.tensile` builds Peridigm's tensile test on a straight bar (reaction forces
over gauge strain) to measure the Young's modulus a material gives.
"""
from __future__ import annotations

from .harness import (
    build_simulation,
    cube_deck,
    isolated_registry,
    node_set_ids,
    scattered_deck,
)
from .contact_suite import ContactConformance
from .nonordinary import NonOrdinaryConformance
from .transport import TransportConformance
from .suites import DamageConformance, MaterialConformance

__all__ = [
    "ContactConformance",
    "NonOrdinaryConformance",
    "TransportConformance",
    "DamageConformance",
    "MaterialConformance",
    "build_simulation",
    "cube_deck",
    "isolated_registry",
    "node_set_ids",
    "scattered_deck",
]
