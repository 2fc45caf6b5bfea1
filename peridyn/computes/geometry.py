"""Computes that describe the model: ids, neighbor counts, radii, neighborhood volumes; and
the nonlinear iteration counter of implicit solvers."""
from __future__ import annotations

import math

import numpy as np

from ..core.fields import FieldSpec, Relation
from ..core.interfaces import Compute
from ..core.traversal import PointSum
from ..kernels import default_backend


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
        nodes = sim.element_nodes
        if "Neighbor_Volume" in sim.fields:
            weights = sim.fields["Neighbor_Volume"]
        elif nodes is not None:  # partial volumes, computed here only (no bond field is kept)
            from ..geometry.partial_volumes import fill_partial_volumes

            p = sim.deck.discretization.params
            weights = np.zeros(nl.num_bonds)
            fill_partial_volumes(sim, nodes, p.intersection_recursion_level, p.intersection_number_of_samples, nv=weights)
        out = vol[: nl.num_points].copy()
        s = sim.fields
        sequential_row_sum(nl.offsets, nl.neighbors, s["Bond_Length"], s["Model_Coordinates"], np.ascontiguousarray(weights, float), out,
                           sim.backend)
        return out


# Loop law (peridyn.core.traversal): the sum runs in out[i] itself, from V_i, one bond at a time
# (Peridigm's order; PointSum's accumulator starts at 0). args (weights (nb,) L^3, out (n,) L^3).
def running_sum_term(i, j, b, ex, ey, ez, L, z, p, args):
    """Adds the bond's weight to out[i]; contributes nothing to the law's own sum."""
    weights, out = args
    out[i] += weights[b]
    return 0.0


def running_sum_finish(i, acc, p, args):
    """out[i], the running sum (written back unchanged)."""
    return args[1][i]


ROW_SUM = PointSum(running_sum_term, finish=running_sum_finish)


def sequential_row_sum(offsets, neighbors, zeta, x, weights, out, backend=None):
    """out[i] += weights[offsets[i]] + ... in bond order, one addition at a time (Peridigm's
    order), for every row: the law ROW_SUM. offsets (n+1,), neighbors (nb,), zeta (nb,) bond
    lengths (L), x (n, 3) positions (L; the law reads no geometry), weights (nb,), out (n,)."""
    kernel = (backend or default_backend()).kernel(ROW_SUM)
    kernel(0, offsets.shape[0] - 1, offsets, neighbors, zeta, x, (weights, out), out)


class NonlinearSolverIterations(Compute):
    """Nonlinear iterations of all implicit solvers so far (global)."""

    name = "Nonlinear_Solver_Iterations"

    def outputs(self, sim):
        return [FieldSpec(self.name, Relation.GLOBAL)]

    def compute(self, sim):
        sim.fields[self.name][0] = float(sim.clock.nonlinear_iterations)
