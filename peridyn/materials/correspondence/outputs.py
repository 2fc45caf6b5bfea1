"""``Hourglass_Force_Density``: the hourglass part of the classic correspondence force
(PERIDIGM_CORRESPONDENCE.md §7), summed over blocks like Force_Density. Computed only when an
output asks for it, from the deformation gradients the materials left."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ...kernels.gathers import gather_vector_force_kernel
from ...core.fields import FieldSpec, Relation
from ...core.interfaces import Compute
from .classic import ClassicCorrespondence
from .forces import _hourglass_bond


@njit(cache=True, parallel=True, error_model="numpy")
def hourglass_states_kernel(start, stop, offsets, neighbors, x, y, horizon, F, c1, T):
    """T[b] = M(i→j) η for the bonds b = i→j of the rows [start, stop)."""
    for i in prange(start, stop):
        for b in range(offsets[i], offsets[i + 1]):
            T[b, 0], T[b, 1], T[b, 2] = _hourglass_bond(i, neighbors[b], x, y, F, c1, horizon[i])


class HourglassForceDensity(Compute):
    """Node vector (M L^-2 T^-2); zero where no classic correspondence material acts."""

    name = "Hourglass_Force_Density"

    def outputs(self, sim):
        return [FieldSpec("Hourglass_Force_Density", Relation.NODE, 3)]

    def compute(self, sim):
        out = sim.fields["Hourglass_Force_Density"]
        out[:] = 0.0
        blocks = [blk for blk in sim.blocks if isinstance(blk.material, ClassicCorrespondence) and blk.material.c1 != 0.0]
        if not blocks:
            return
        s, nl = sim.fields, sim.bonds
        T = np.zeros((nl.num_bonds, 3))
        for blk in blocks:
            hourglass_states_kernel(blk.start, blk.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Coordinates"],
                                    s["Horizon"], s["Deformation_Gradient"], float(blk.material.c1), T)
        in_offsets, in_bonds = nl.transpose()
        gather_vector_force_kernel(0, sim.num_local, nl.offsets, nl.neighbors, in_offsets, in_bonds, nl.sources(), s["Volume"], T, out)
        if sim.comm.size > 1:
            sim.halo.reverse_sum(out)
