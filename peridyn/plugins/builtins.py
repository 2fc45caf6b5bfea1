"""The built-in models, registered like any plugin. Only names and import paths live here: a
model's module is imported when a deck uses it, so a scene imports only what it needs."""
from __future__ import annotations

from .hookspecs import hookimpl


@hookimpl
def peridyn_discretizations():
    return [
        ("PdQuickGrid", "peridyn.io.quickgrid:PdQuickGrid"),
        ("Exodus", "peridyn.io.exodus_mesh:ExodusMesh"),
        ("Text File", "peridyn.io.textfile:TextFile"),
    ]


@hookimpl
def peridyn_materials():
    return [
        ("Elastic", "peridyn.materials.elastic:Elastic"),
        ("Elastic Bond Based", "peridyn.materials.elastic_bond_based:ElasticBondBased"),
    ]


@hookimpl
def peridyn_damage_models():
    return [
        ("Critical Stretch", "peridyn.damage.critical_stretch:CriticalStretch"),
        ("Time Dependent Critical Stretch", "peridyn.damage.critical_stretch:TimeDependentCriticalStretch"),
        ("Initial Damage", "peridyn.damage.initial_damage:InitialDamage"),
    ]


@hookimpl
def peridyn_contact_models():
    return []


@hookimpl
def peridyn_solvers():
    return [
        ("Verlet", "peridyn.solvers.verlet:Verlet"),
        ("QuasiStatic", "peridyn.solvers.quasistatic:QuasiStatic"),
        ("NOXQuasiStatic", "peridyn.solvers.nox:NOXQuasiStatic"),
        ("Implicit", "peridyn.solvers.implicit:Implicit"),
    ]


@hookimpl
def peridyn_boundary_conditions():
    module = "peridyn.core.boundary"
    return [
        ("INITIAL_VELOCITY", f"{module}:InitialVelocity"),
        ("INITIAL_DISPLACEMENT", f"{module}:InitialDisplacement"),
        ("INITIAL_TEMPERATURE", f"{module}:InitialTemperature"),
        ("PRESCRIBED_DISPLACEMENT", f"{module}:PrescribedDisplacement"),
        ("PRESCRIBED_TEMPERATURE", f"{module}:PrescribedTemperature"),
        ("BODY_FORCE", f"{module}:BodyForce"),
    ]


@hookimpl
def peridyn_computes():
    from ..computes import BUILTIN_COMPUTES

    return list(BUILTIN_COMPUTES)
