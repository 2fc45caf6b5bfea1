"""Outputs: which variables each ``Output`` section writes, when, and the computes behind them.

Only what an output asks for is computed, and only when that output actually writes (Peridigm
runs its computes inside each writer's write). Every writer keeps its own counter of write calls,
shared across solvers (PERIDIGM_SEMANTICS.md §9.2).
"""
from __future__ import annotations

import difflib
import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError, raise_collected
from .fields import FieldSpec, Relation, Temporal

if TYPE_CHECKING:  # pragma: no cover
    from .engine import Simulation

log = logging.getLogger("peridyn.output")

#: point fields every deck may write without a compute (allocated on request when not already)
STANDARD_FIELDS = {
    "Model_Coordinates": FieldSpec("Model_Coordinates", Relation.NODE, 3),
    "Coordinates": FieldSpec("Coordinates", Relation.NODE, 3),
    "Displacement": FieldSpec("Displacement", Relation.NODE, 3),
    "Velocity": FieldSpec("Velocity", Relation.NODE, 3),
    "Force_Density": FieldSpec("Force_Density", Relation.NODE, 3),
    "External_Force_Density": FieldSpec("External_Force_Density", Relation.NODE, 3),
    "Temperature": FieldSpec("Temperature", Relation.NODE),
    "Temperature_Change": FieldSpec("Temperature_Change", Relation.NODE),
    "Volume": FieldSpec("Volume", Relation.ELEMENT),
    "Horizon": FieldSpec("Horizon", Relation.ELEMENT),
    "Damage": FieldSpec("Damage", Relation.ELEMENT, 1, Temporal.TWO_STEP),
}

TENSOR_SUFFIXES = ("XX", "XY", "XZ", "YX", "YY", "YZ", "ZX", "ZY", "ZZ")


def component_names(spec: FieldSpec, name: str | None = None) -> list[str]:
    """Exodus names of a field's components: V -> VX VY VZ, T -> TXX..TZZ, others _1.._n."""
    name = name or spec.name
    n = int(spec.length)
    if n == 1:
        return [name]
    if n == 3:
        return [name + c for c in "XYZ"]
    if n == 9:
        return [name + c for c in TENSOR_SUFFIXES]
    return [f"{name}_{k + 1}" for k in range(n)]


@dataclass
class Variable:
    name: str
    spec: FieldSpec
    compute: object | None  #: the compute filling it (None: a plain field)

    @property
    def kind(self) -> str:
        if self.spec.relation is Relation.GLOBAL:
            return "global"
        if int(self.spec.length) == 1 and self.spec.relation is Relation.ELEMENT:
            return "element"
        if int(self.spec.length) in (3,) or self.spec.relation is Relation.NODE:
            return "nodal"
        return "element"


class OutputManager:
    """The computes and writers of all Output sections."""

    def __init__(self, sim: "Simulation") -> None:
        self.sim = sim
        sim.outputs = self  # computes look up variables through it while being checked
        deck = sim.deck
        registry = deck.registry
        errors: list[InputError] = []
        self.computes: dict[str, object] = {}  # creation order = Peridigm's
        self.variables: dict[str, Variable] = {}
        labels = {c.name: c for c in deck.computes}
        material_fields = self._model_fields()
        loader_name = deck.data_loader.field_name if deck.data_loader is not None else None

        def add_compute(name: str, obj) -> None:
            for dep in getattr(obj, "requires", lambda sim: [])(sim):
                resolve(dep, None)
            self.computes[name] = obj
            for spec in obj.outputs(sim):
                self.variables.setdefault(spec.name, Variable(spec.name, spec, obj))

        def resolve(name: str, path) -> Variable | None:
            if name in self.variables:
                return self.variables[name]
            if name in labels:
                return None  # created with the compute classes, below
            if registry.has("compute", name):
                cls = registry.get("compute", name, path=path or (), file=deck.file)
                if getattr(cls, "Params", None) is None:
                    add_compute(name, cls())
                    return self.variables.get(name)
            if name in material_fields:
                self.variables[name] = Variable(name, material_fields[name], None)
                return self.variables[name]
            if name in STANDARD_FIELDS:
                self.variables[name] = Variable(name, STANDARD_FIELDS[name], None)
                return self.variables[name]
            if loader_name is not None and name == loader_name:
                self.variables[name] = Variable(name, FieldSpec(name, Relation.NODE, 1, Temporal.TWO_STEP), None)
                return self.variables[name]
            if path is not None:
                known = sorted(set(STANDARD_FIELDS) | set(material_fields) | set(labels) | set(self._parameterless(registry)))
                close = difflib.get_close_matches(name, known, n=3, cutoff=0.6)
                fix = f"did you mean {' or '.join(map(repr, close))}?" if close else f"known variables: {', '.join(known)}"
                errors.append(InputError(f"unknown output variable {name!r}", file=deck.file, path=path, fix=fix))
            return None

        for out in deck.outputs:
            for var in out.variables:
                resolve(var, out.path + ("Output Variables", var))
        for entry in deck.computes:
            obj = entry.cls(entry.params, label=entry.name)
            add_compute(entry.name, obj)
        raise_collected(errors)
        for entry in deck.computes:
            problems = getattr(self.computes[entry.name], "check", lambda sim: [])(sim)
            for p in problems:
                errors.append(InputError(p, file=deck.file, path=entry.path))
        raise_collected(errors)
        from .writer import OutputWriter

        self.writers = [OutputWriter(sim, self, out) for out in deck.outputs]

    def _model_fields(self) -> dict[str, FieldSpec]:
        out: dict[str, FieldSpec] = {}
        for blk in self.sim.blocks:
            specs = blk.material.fields() + (blk.damage.fields() if blk.damage is not None else [])
            for spec in specs:
                if spec.relation is not Relation.BOND:
                    out.setdefault(spec.name, spec)
        return out

    @staticmethod
    def _parameterless(registry) -> list[str]:
        names = []
        for name in registry.names("compute"):
            try:
                cls = registry.get("compute", name)
            except InputError:
                continue
            if getattr(cls, "Params", None) is None:
                names.append(name)
        return names

    def field_specs(self) -> list[FieldSpec]:
        """Fields the outputs need allocated."""
        return [v.spec for v in self.variables.values() if v.spec.relation is not Relation.BOND]

    def blocks_with(self, name: str) -> list[bool]:
        """Truth table row: which blocks have the element variable ``name``."""
        var = self.variables[name]
        owners = getattr(var.compute, "blocks", None)
        if owners is not None:
            return [bool(owners(self.sim, blk)) for blk in self.sim.blocks]
        if var.compute is None and name not in STANDARD_FIELDS:
            return [
                any(s.name == name for s in blk.material.fields() + (blk.damage.fields() if blk.damage is not None else []))
                for blk in self.sim.blocks
            ]
        return [True] * len(self.sim.blocks)

    def initialize(self) -> None:
        for obj in self.computes.values():
            obj.initialize(self.sim)

    def run_computes(self, names) -> None:
        """Run the computes behind ``names`` (and their dependencies) in creation order."""
        wanted = set()
        for n in names:
            var = self.variables.get(n)
            if var is not None and var.compute is not None:
                wanted.add(id(var.compute))
        changed = True
        while changed:  # dependencies
            changed = False
            for obj in self.computes.values():
                if id(obj) in wanted:
                    for dep in getattr(obj, "requires", lambda sim: [])(self.sim):
                        d = self.variables.get(dep)
                        if d is not None and d.compute is not None and id(d.compute) not in wanted:
                            wanted.add(id(d.compute))
                            changed = True
        for obj in self.computes.values():
            if id(obj) in wanted:
                obj.compute(self.sim)

    def write(self, t: float) -> None:
        for w in self.writers:
            w.write(t)

    def close(self) -> None:
        for w in self.writers:
            w.close()
