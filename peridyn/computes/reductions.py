"""Parametrised computes from ``Compute Class Parameters``: reductions of a field over a block
or a node set, and the value at the point nearest a location (PERIDIGM_SEMANTICS.md §8.5)."""
from __future__ import annotations

import sys
from typing import Literal

import numpy as np
from pydantic import Field

from ..core.fields import FieldSpec, Relation
from ..core.interfaces import Compute
from ..core.params import ModelParams

DBL_MIN = sys.float_info.min  # Peridigm starts "Maximum" here, not at -inf


class BlockDataParams(ModelParams):
    calculation_type: Literal["Minimum", "Maximum", "Sum"] = Field(alias="Calculation Type", description="Minimum, Maximum or Sum")
    block: str = Field(alias="Block", description="block name, e.g. block_1")
    variable: str = Field(alias="Variable", description="a scalar or vector point field, e.g. Force")
    output_label: str = Field(alias="Output Label", description="name of the global output variable")
    verbose: bool = Field(False, alias="Verbose")


class NodeSetDataParams(ModelParams):
    calculation_type: Literal["Minimum", "Maximum", "Sum"] = Field(alias="Calculation Type", description="Minimum, Maximum or Sum")
    node_set: str = Field(alias="Node Set", description="a node set of the mesh, by its name in the mesh (e.g. nodelist_1)")
    variable: str = Field(alias="Variable", description="a scalar or vector point field")
    output_label: str = Field(alias="Output Label", description="name of the global output variable")
    verbose: bool = Field(False, alias="Verbose")


class NearestPointDataParams(ModelParams):
    x: float = Field(alias="X", description="location (L)")
    y: float = Field(alias="Y", description="location (L)")
    z: float = Field(alias="Z", description="location (L)")
    variable: str = Field(alias="Variable", description="a scalar or vector point field")
    output_label: str = Field(alias="Output Label", description="name of the global output variable")
    verbose: bool = Field(False, alias="Verbose")


def _reduce(values: np.ndarray, kind: str, comm) -> np.ndarray:
    """Column-wise reduction of (k,) or (k, c) values over the points of all ranks."""
    width = int(np.prod(values.shape[1:])) if values.ndim > 1 else 1
    values = values.reshape(values.shape[0], width)
    if kind == "Sum":
        local = values.sum(axis=0) if values.shape[0] else np.zeros(values.shape[1])
        return comm.allreduce_sum(local)
    if kind == "Minimum":
        local = np.minimum(values.min(axis=0), sys.float_info.max) if values.shape[0] else np.full(values.shape[1], sys.float_info.max)
        return comm.allreduce_min(local)
    local = np.maximum(values.max(axis=0), DBL_MIN) if values.shape[0] else np.full(values.shape[1], DBL_MIN)
    return comm.allreduce_max(local)


class _FieldReduction(Compute):
    @classmethod
    def output_label(cls, params) -> str:
        return params.output_label

    def _variable_spec(self, sim) -> FieldSpec | None:
        var = self.params.variable
        manager = sim.outputs
        if manager is not None and var in manager.variables:
            return manager.variables[var].spec
        if var in sim.fields:
            return sim.fields.specs[var]
        return None

    def requires(self, sim) -> list[str]:
        return [self.params.variable]

    def check(self, sim) -> list[str]:
        spec = self._variable_spec(sim)
        if spec is None:
            return [f"Variable {self.params.variable!r} is not a field of this model"]
        if int(spec.length) not in (1, 3) or spec.relation in (Relation.BOND, Relation.GLOBAL):
            return [f"Variable {self.params.variable!r} must be a scalar or vector point field"]
        return []

    def outputs(self, sim):
        spec = self._variable_spec(sim)
        length = int(spec.length) if spec is not None else 1
        return [FieldSpec(self.label, Relation.GLOBAL, length)]

    def _write(self, sim, values: np.ndarray) -> None:
        sim.fields[self.label][:] = _reduce(values, self.params.calculation_type, sim.comm)


class BlockData(_FieldReduction):
    name = "Block_Data"
    Params = BlockDataParams

    def check(self, sim):
        problems = super().check(sim)
        if not any(blk.name == self.params.block for blk in sim.blocks):
            problems.append(f"Block {self.params.block!r} is not a block of this model ({', '.join(b.name for b in sim.blocks)})")
        return problems

    def compute(self, sim):
        blk = next(b for b in sim.blocks if b.name == self.params.block)
        self._write(sim, sim.fields[self.params.variable][blk.start : blk.stop])


class NodeSetData(_FieldReduction):
    """Reduction over a node set of the mesh (Peridigm looks it up among the mesh's node sets by
    their raw names)."""

    name = "Node_Set_Data"
    Params = NodeSetDataParams

    def check(self, sim):
        problems = super().check(sim)
        if self.params.node_set not in sim.discretization.node_sets:
            names = ", ".join(sim.discretization.node_sets) or "none"
            problems.append(f"Node Set {self.params.node_set!r} is not a node set of the mesh (mesh node sets: {names})")
        return problems

    def initialize(self, sim):
        members = sim.local_of_mothership[np.asarray(sim.discretization.node_sets[self.params.node_set], dtype=np.int64)]
        members = members[(members >= 0) & (members < sim.num_owned)]  # this rank's points
        # Peridigm visits the points block by block, then in owned order
        self.points = np.sort(members)

    def compute(self, sim):
        self._write(sim, sim.fields[self.params.variable][self.points])


class NearestPointData(_FieldReduction):
    """The value at the point nearest (X, Y, Z) in the reference configuration (ties: the
    smallest global id)."""

    name = "Nearest_Point_Data"
    Params = NearestPointDataParams

    def initialize(self, sim):
        p = self.params
        x = sim.fields["Model_Coordinates"][: sim.num_owned]
        d2 = ((x[:, 0] - p.x) ** 2 + (x[:, 1] - p.y) ** 2) + (x[:, 2] - p.z) ** 2
        if d2.size:
            best = d2.min()
            candidates = np.nonzero(d2 == best)[0]
            k = int(candidates[np.argmin(sim.gid[candidates])])
            mine = (float(best), int(sim.gid[k]))
        else:
            k, mine = -1, (np.inf, -1)
        # the nearest point over all ranks; ties go to the smallest global id
        winner = min(c for c in sim.comm.allgather(mine) if c[1] >= 0) if sim.num_global else (np.inf, -1)
        self.point = k if mine == winner else None

    def compute(self, sim):
        spec = self._variable_spec(sim)
        length = int(spec.length)
        if self.point is not None:
            value = np.atleast_1d(np.asarray(sim.fields[self.params.variable][self.point], dtype=float)).copy()
        else:
            value = np.zeros(length)
        sim.fields[self.label][:] = sim.comm.allreduce_sum(value)
