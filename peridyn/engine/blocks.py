"""Blocks of a model and their fusion: which runs of blocks one fused kernel computes whole
(called by :class:`peridyn.engine.simulation.Simulation` at set-up)."""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..core.interfaces import BlockView, DamageModel, Material
from .kernels import crossing_blocks_kernel


@dataclass
class Block:
    """One block of the model: its points (a local range), material and damage model."""

    index: int
    name: str
    block_id: int
    material_name: str
    material: Material
    damage: DamageModel | None
    horizon: float | None  #: constant horizon, or None when it varies in space
    horizon_text: str | float
    start: int = 0
    stop: int = 0
    fused: bool = False
    damage_adopted: bool = False  #: the material applies the damage model's rule in its own loop
    view: BlockView | None = None
    path: tuple[str, ...] = ()
    #: blocks whose forces this block's fused kernel computes: itself, or a run of neighboring
    #: blocks with the same models and horizon (see Simulation._check_fusion); empty when another
    #: block computes this one's forces
    group: list["Block"] = field(default_factory=list)
    fused_view: BlockView | None = None  #: the view over the whole group (None: ``view``)
    #: under MPI: the block's rows without ghost neighbors come first, [start, split), then
    #: the rows with ghost neighbors, [split, stop) (see Simulation._order_points)
    split: int = 0

    @property
    def density(self) -> float:
        return self.material.density


# ------------------------------------------------------------------------------------------------
# kernels


@dataclass
class FusionPlan:
    """Which blocks the generic path computes and how the force evaluation runs."""

    generic_blocks: list["Block"]  #: blocks no fused kernel covers (force state + gather)
    overlap: bool  #: MPI: compute rows without ghost neighbors while halo messages travel
    bond_force: np.ndarray | None  #: (num_bonds,) scalar force states of the generic blocks, or None


def plan_fusion(sim: Any) -> FusionPlan:
    """A block is fused (one kernel computes both ends of its bonds) when no bond crosses
    its boundary in either direction, its horizon is constant and its families are
    symmetric. Neighboring blocks with the same models (equal parameters) and the same
    constant horizon form one group, fused as a whole when no bond leaves the group: a deck
    that splits one material into several blocks (grips and gauge section, say) keeps the
    fused kernel."""
    nl = sim.bonds
    groups = fusion_groups(sim)
    group_of_block = np.zeros(len(sim.blocks), dtype=np.int64)
    for g, members in enumerate(groups):
        for blk in members:
            group_of_block[blk.index] = g
    open_mask = np.zeros(len(groups), dtype=np.bool_)
    if len(groups) > 1 and nl.num_bonds:
        crossing_blocks_kernel(sim.num_owned, nl.offsets, nl.neighbors, group_of_block[sim.block_index], open_mask)
    open_mask = sim.comm.allreduce_max(open_mask.astype(np.int64)) > 0
    maybe_one_sided = bool(sim.deck.discretization.bond_filters)
    parallel = sim.comm.size > 1
    reverse = None
    for g, members in enumerate(groups):
        lead = members[0]
        start, stop = lead.start, members[-1].stop
        fused = not open_mask[g] and lead.horizon is not None
        if parallel:
            # a ghost's bond back to an owned point lives on another rank: both ends can be
            # computed here only when they provably agree (symmetric or no damage)
            fused = fused and not maybe_one_sided and (lead.damage is None or lead.damage.symmetric)
        elif fused and maybe_one_sided and stop > start:
            if reverse is None:
                reverse = nl.reverse()
            fused = bool(np.all(reverse[nl.offsets[start] : nl.offsets[stop]] >= 0))
        for blk in members:
            blk.view.closed = fused
            blk.fused = fused and blk is lead
            blk.group = [blk]
            blk.fused_view = None
        if fused and len(members) > 1:
            lead.group = list(members)
            lead.fused_view = replace(lead.view, stop=stop, name="+".join(b.name for b in members))
            for blk in members[1:]:
                blk.group = []
    covered = {blk.index for blk in sim.blocks if blk.fused for blk in blk.group}
    generic_blocks = [blk for blk in sim.blocks if blk.index not in covered]
    # under MPI, compute the rows without ghost neighbors while the halo messages travel
    # (needs fused blocks and models that promise to touch only a view's rows)
    overlap = (
        parallel
        and not generic_blocks
        and all(blk.material.row_local and (blk.damage is None or blk.damage.row_local) for blk in sim.blocks)
    )
    bond_force = None
    if any(blk.material.force_state_kind == "scalar" for blk in generic_blocks):
        bond_force = np.zeros(nl.num_bonds)
        nl.transpose()
        nl.sources()
    return FusionPlan(generic_blocks, bool(overlap), bond_force)

def fusion_groups(sim: Any) -> list[list[Block]]:
    """Runs of consecutive blocks (contiguous point ranges) that one fused kernel may
    compute together: same material and damage model classes with equal parameters, the
    same constant horizon, no per-bond influence table and the same damage treatment."""

    def signature(blk):
        d = blk.damage
        return (
            type(blk.material), blk.material.params, None if d is None else (type(d), d.params),
            blk.horizon, blk.damage_adopted,
        )

    groups: list[list[Block]] = []
    table = bool(sim.influence.needs_table)
    for blk in sim.blocks:
        if (
            groups
            and not table
            and blk.horizon is not None
            and groups[-1][-1].stop == blk.start
            and signature(groups[-1][-1]) == signature(blk)
        ):
            groups[-1].append(blk)
        else:
            groups.append([blk])
    return groups


def block_id_from_name(name: str, names_by_id: dict[int, str]) -> int | None:
    """Peridigm: the block id is the integer after the last '_' of the name; a mesh block whose
    own name matches is found by name first."""
    for bid, mesh_name in names_by_id.items():
        if mesh_name == name:
            return bid
    tail = name.rsplit("_", 1)[-1]
    try:
        return int(tail)
    except ValueError:
        return None
