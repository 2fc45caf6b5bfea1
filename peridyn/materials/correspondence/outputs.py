"""``Hourglass_Force_Density``: the hourglass part of the classic correspondence force
(PERIDIGM_CORRESPONDENCE.md §7), summed over blocks like Force_Density. Computed only when an
output asks for it, from the deformation gradients the materials left: the loop law
``HOURGLASS_STATES`` gives the hourglass vector states of the blocks' bonds, which the engine's
gather sums at both ends."""
from __future__ import annotations

import numpy as np

from ...core.fields import FieldSpec, Relation
from ...core.interfaces import Compute
from ...core.traversal import BondMap
from ...kernels.gathers import gather_vector_force_kernel
from .classic import ClassicCorrespondence
from .forces import hourglass_bond


# Loop law (peridyn.core.traversal), run on reference positions: the bond context's (ex, ey, ez) =
# ξ = x_j - x_i and L = ζ = |ξ| (L). args (y (n, 3) current positions L, horizon (n,) L,
# F (n, 9) deformation gradients, c1 = 18 C K / π M L^-1 T^-2).
def hourglass_state(i, j, b, ex, ey, ez, L, z, p, args):
    """M(i→j) η of the bond b = i→j (force per volume squared), §7."""
    y, horizon, F, c1 = args
    return hourglass_bond(i, j, ex, ey, ez, L, y, F, c1, horizon[i])


#: the hourglass vector states T (nb, 3) of the bonds of a range of points
HOURGLASS_STATES = BondMap(hourglass_state, width=3, z_from_positions=True)


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
        kernel = sim.backend.kernel(HOURGLASS_STATES)
        for blk in blocks:
            kernel(blk.start, blk.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Model_Coordinates"],
                   (s["Coordinates"], s["Horizon"], s["Deformation_Gradient"], float(blk.material.c1)), T)
        in_offsets, in_bonds = nl.transpose()
        gather_vector_force_kernel(0, sim.num_local, nl.offsets, nl.neighbors, in_offsets, in_bonds, nl.sources(), s["Volume"], T, out)
        if sim.comm.size > 1:
            sim.halo.reverse_sum(out)
