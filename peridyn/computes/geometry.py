"""Computes that describe the model: ids, neighbor counts, radii, neighborhood volumes; and
the nonlinear iteration counter of implicit solvers."""
from __future__ import annotations

import math

import numpy as np

from ..core.fields import FieldSpec, Relation
from ..core.interfaces import Compute


class _Constant(Compute):
    """A point quantity fixed at set-up (filled once in ``initialize``)."""

    def outputs(self, sim):
        return [FieldSpec(self.name, Relation.ELEMENT)]

    def initialize(self, sim):
        sim.fields[self.name][: sim.num_local] = self.values(sim)

    def compute(self, sim):
        pass

    def values(self, sim) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError


class ElementId(_Constant):
    """Global id + 1 (Exodus element number)."""

    name = "Element_Id"

    def values(self, sim):
        return sim.gid + 1


class BlockId(_Constant):
    name = "Block_Id"

    def values(self, sim):
        ids = np.array([blk.block_id for blk in sim.blocks], dtype=float)
        return ids[sim.block_index]


class ProcNum(_Constant):
    """The MPI rank owning the point."""

    name = "Proc_Num"

    def values(self, sim):
        return np.full(sim.num_local, float(sim.comm.rank))


class NumberOfNeighbors(_Constant):
    """Neighbors after bond filters, broken bonds included."""

    name = "Number_Of_Neighbors"

    def values(self, sim):
        return sim.bonds.counts().astype(float)


class Radius(_Constant):
    """Radius of the sphere of the point's volume, (3 V / 4 pi)^(1/3) (L)."""

    name = "Radius"

    def values(self, sim):
        return np.power((0.75 / math.acos(-1.0)) * sim.fields["Volume"], 1.0 / 3.0)


class NeighborhoodVolume(_Constant):
    """V_i + sum_j V_j over the family (L^3)."""

    name = "Neighborhood_Volume"

    def values(self, sim):
        nl = sim.bonds
        vol = sim.fields["Volume"]
        owner = np.repeat(np.arange(nl.num_points), nl.counts())
        return vol + np.bincount(owner, weights=vol[nl.neighbors], minlength=nl.num_points)


class NonlinearSolverIterations(Compute):
    """Nonlinear iterations of all implicit solvers so far (global)."""

    name = "Nonlinear_Solver_Iterations"

    def outputs(self, sim):
        return [FieldSpec(self.name, Relation.GLOBAL)]

    def compute(self, sim):
        sim.fields[self.name][0] = float(sim.nonlinear_iterations)
