"""``Interface Aware`` damage (PERIDIGM_MODELS.md §8.1; Peridigm's
``Peridigm_InterfaceAwareDamageModel.cpp``).

A critical-stretch law whose threshold is the smaller of the two bond ends' critical stretches,
so that a bond between two blocks with different ``Critical Stretch`` values breaks at the
weaker one. Every point carries its model's value in the element field ``Critical_Stretch``
(exchanged to ghosts after initialize; 0 at points of blocks without this model, whose bonds
this model then leaves alone). A bond of point i to neighbor j breaks for good when

    s = (|eta| - |xi| - (a_T dT_i) |xi|) / |xi| > min(s_c,i, s_c,j)        (strict, tension only)

and is skipped when it is already damaged or when s_c,j = 0. ``Damage`` = broken bonds / bonds.

Rank deficiency: a point with at most two intact bonds left (broken >= n_i - 2, which includes
points with n_i <= 2 from the start) would make the implicit tangent singular. Peridigm then
breaks all of its bonds, adds it to the node set ``RANK_DEFICIENT_NODES`` and fixes its three
displacement components. This model breaks the bonds and records the point in
:attr:`InterfaceAware.rank_deficient` (a flag per local point) and
:meth:`InterfaceAware.take_new_rank_deficient` (the points found since the last call), for the
engine to fix; it logs one warning per point.

Bond damage is never reset (Peridigm has no N -> NP1 copy here): the NP1 array keeps every
bond broken by any evaluation of the step, trial configurations included. Peridigm's NP1 array
also alternates between two buffers from step to step, so that a bond broken at step n is
missing from step n + 1's damage unless it breaks again; here NP1 also takes the N values, so a
broken bond stays broken (docs/damage.md). Both give the same results while the loading only
grows (the reference cases).
"""
from __future__ import annotations

import logging

import numpy as np
from pydantic import Field

from ..core.bondmath import stretch_exceeds
from ..core.fields import FieldSpec, Relation, Temporal
from ..core.interfaces import BlockView, DamageModel
from ..core.params import ModelParams
from ..core.traversal import PointSum
from ..kernels import default_backend
from ..kernels.lengths import compiled_with_lengths

log = logging.getLogger("peridyn.damage")
EMPTY = np.zeros(0)


# Loop law (peridyn.core.traversal). Bond context (i, j, b, ex, ey, ez, L, z, p, args):
# (ex, ey, ez) = y_j - y_i, L = |y_j - y_i| (L) current, z = |xi| (L). args (s_c, critical, d_n,
# d_np1, dT, alpha_T, deficient, new, offsets): s_c this block's critical stretch; critical (n,)
# Critical_Stretch of every local point; d_n, d_np1 (nb,) bond damage (uint8); dT (n,) or empty;
# deficient, new (n,) uint8 flags (new: set for points found now); offsets (n+1,) the CSR rows.
def interface_aware_term(i, j, b, ex, ey, ez, L, z, p, args):
    """d = max(d_np1, d_n), set to 1 when the bond is intact, j has a critical stretch and
    s = (L - a_T dT_i z - z) / z > min(s_c, s_c,j) (strict); written to d_np1[b] and returned."""
    s_c, critical, d_n, d_np1, dT, alpha_T, deficient, new, offsets = args
    d = float(d_np1[b])
    dn = float(d_n[b])
    d = max(d, dn)
    s_j = critical[j]
    if d == 0.0 and s_j != 0.0:
        s_min = min(s_c, s_j)
        if dT.shape[0] > 0:
            broken = ((L - (alpha_T * dT[i]) * z) - z) / z > s_min
        else:
            broken = stretch_exceeds(ex * ex + ey * ey + ez * ez, z, s_min)
        if broken:
            d = 1.0
    d_np1[b] = d
    return d


def rank_deficiency_finish(i, total, p, args):
    """Damage_i = broken bonds / bonds (total: the sum of the bonds' d), after the
    rank-deficiency rule: a point not yet flagged with at most two intact bonds
    (total >= n_i - 2) gets every bond broken and deficient[i] = new[i] = 1."""
    s_c, critical, d_n, d_np1, dT, alpha_T, deficient, new, offsets = args
    lo = offsets[i]
    hi = offsets[i + 1]
    n = hi - lo
    if total >= n - 2 and deficient[i] == 0:
        deficient[i] = 1
        new[i] = 1
        for b in range(lo, hi):
            d_np1[b] = 1.0
        total = float(n)
    return total / n if n > 0 else 0.0


INTERFACE_AWARE = PointSum(interface_aware_term, finish=rank_deficiency_finish)


def interface_aware_kernel(start, stop, offsets, neighbors, zeta, y, s_c, critical, d_n, d_np1, dT, alpha_T, deficient, new, damage):
    """Update the bond damage d_np1 (never reset; N values kept) and the Damage of the points
    [start, stop); apply the rank-deficiency rule: the law INTERFACE_AWARE with the arguments of
    the hand-written kernel it replaced (callers without a BlockView). Shapes: zeta (nb,)
    reference bond lengths (L); y (n, 3) (L); damage (n,); the rest as in the law's args."""
    args = (s_c, critical, d_n, d_np1, dT, alpha_T, deficient, new, offsets)
    default_backend().kernel(INTERFACE_AWARE)(start, stop, offsets, neighbors, zeta, y, args, damage)


class InterfaceAwareParams(ModelParams):
    critical_stretch: float = Field(alias="Critical Stretch", gt=0, description="stretch (dimensionless) above which a bond breaks; a bond between two blocks uses the smaller of their values")
    thermal_expansion_coefficient: float | None = Field(
        None, alias="Thermal Expansion Coefficient", description="subtracts a_T dT_i from the stretch (1/temperature); independent of the material's"
    )


class InterfaceAware(DamageModel):
    """Peridigm's ``Interface Aware`` damage model (see the module docstring)."""

    name = "Interface Aware"
    Params = InterfaceAwareParams
    bond_damage_dtype = "uint8"  # bonds are whole or broken
    row_local = True

    def __init__(self, params: InterfaceAwareParams, *, options=None) -> None:
        super().__init__(params, options=options)
        self.s_c = float(params.critical_stretch)
        self.alpha_T = params.thermal_expansion_coefficient
        #: (n_local,) uint8: 1 at points the rank-deficiency rule removed (for the rest of the run)
        self.rank_deficient = np.zeros(0, dtype=np.uint8)
        self._new = np.zeros(0, dtype=np.uint8)
        self._pending: list[int] = []

    def fields(self) -> list[FieldSpec]:
        specs = super().fields()
        specs.append(FieldSpec("Critical_Stretch", Relation.ELEMENT, 1, Temporal.CONSTANT, halo=True))
        if self.alpha_T is not None:
            specs += [FieldSpec("Temperature", Relation.NODE), FieldSpec("Temperature_Change", Relation.NODE, halo=True)]
        return specs

    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        lo, hi = nl.offsets[block.start], nl.offsets[block.stop]
        s["Bond_Damage"][lo:hi] = 0
        s["Damage"][block.start : block.stop] = 0.0
        s["Critical_Stretch"][block.start : block.stop] = self.s_c
        self.rank_deficient = np.zeros(s.num_points, dtype=np.uint8)
        self._new = np.zeros(s.num_points, dtype=np.uint8)

    def update(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        if self.rank_deficient.shape[0] != s.num_points:
            self.rank_deficient = np.zeros(s.num_points, dtype=np.uint8)
            self._new = np.zeros(s.num_points, dtype=np.uint8)
        dT = s["Temperature_Change"] if self.alpha_T is not None else EMPTY
        args = (self.s_c, s["Critical_Stretch"], s.n("Bond_Damage"), s["Bond_Damage"], dT, float(self.alpha_T or 0.0), self.rank_deficient,
                self._new, nl.offsets)
        compiled_with_lengths(block, INTERFACE_AWARE)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], args,
                                         s["Damage"])
        found = np.flatnonzero(self._new[block.start : block.stop]) + block.start
        if not found.size:
            return
        self._new[found] = 0
        self._pending.extend(int(i) for i in found)
        gid = block.extras.get("gid")
        ids = [int(gid[i]) + 1 if gid is not None else int(i) + 1 for i in found[:5]]
        log.warning("Interface Aware: %d point(s) of block %s (%s%s) have at most two intact bonds left: all their bonds are "
                    "broken and they are removed from the linear system (RANK_DEFICIENT_NODES)",
                    found.size, block.name, ", ".join(map(str, ids)), ", ..." if found.size > 5 else "")

    def take_new_rank_deficient(self) -> np.ndarray:
        """Local indices of the points the rank-deficiency rule removed since the last call
        (for the engine: add them to ``RANK_DEFICIENT_NODES`` and fix their displacements)."""
        out = np.array(self._pending, dtype=np.int64)
        self._pending.clear()
        return out
