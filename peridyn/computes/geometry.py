"""Computes that describe the model: ids, neighbor counts, radii, neighborhood volumes; and
the nonlinear iteration counter of implicit solvers."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

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
    """V_i + sum_j w_j over the family (L^3), a sequential sum from V_i (PERIDIGM_MODELS.md §14):
    w_j = the bond's partial volume (``Compute Element-Horizon Intersections``) or V_j."""

    name = "Neighborhood_Volume"

    def values(self, sim):
        nl = sim.bonds
        vol = sim.fields["Volume"]
        weights = vol[nl.neighbors]
        nodes = getattr(sim, "element_nodes", None)
        if "Neighbor_Volume" in sim.fields:
            weights = sim.fields["Neighbor_Volume"]
        elif nodes is not None:  # partial volumes, computed here only (no bond field is kept)
            from ..geometry.partial_volumes import fill_partial_volumes

            p = sim.deck.discretization.params
            weights = np.zeros(nl.num_bonds)
            fill_partial_volumes(sim, nodes, p.intersection_recursion_level, p.intersection_number_of_samples, nv=weights)
        out = vol[: nl.num_points].copy()
        sequential_row_sum(nl.offsets, weights, out)
        return out


@njit(cache=True)
def sequential_row_sum(offsets, weights, out):
    """out[i] += weights[offsets[i]] + ... in bond order, one addition at a time (Peridigm's
    order). offsets (n+1,), weights (nb,), out (n,)."""
    for i in range(offsets.shape[0] - 1):
        acc = out[i]
        for b in range(offsets[i], offsets[i + 1]):
            acc += weights[b]
        out[i] = acc


class NonlinearSolverIterations(Compute):
    """Nonlinear iterations of all implicit solvers so far (global)."""

    name = "Nonlinear_Solver_Iterations"

    def outputs(self, sim):
        return [FieldSpec(self.name, Relation.GLOBAL)]

    def compute(self, sim):
        sim.fields[self.name][0] = float(sim.nonlinear_iterations)
