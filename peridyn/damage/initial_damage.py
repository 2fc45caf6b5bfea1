"""``Initial Damage``: bonds cut by bond filters start broken and stay so (PERIDIGM_SEMANTICS.md
§5.4). The bonds stay in the neighbor lists (Number_Of_Neighbors and the weighted volume count
them); Damage is the broken-bond count over the neighbor count."""
from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from ..core.interfaces import BlockView, DamageModel
from ..core.params import ModelParams


class InitialDamageParams(ModelParams):
    bond_filters: dict[str, dict[str, Any]] = Field(
        alias="Bond Filters", description="filters (Rectangular_Plane or Exodus Mesh) whose cut bonds start broken"
    )


class InitialDamage(DamageModel):
    name = "Initial Damage"
    Params = InitialDamageParams
    bond_damage_dtype = "uint8"
    row_local = True
    devices = frozenset({"cpu", "gpu"})

    def initialize(self, block: BlockView) -> None:
        from ..geometry.bond_filters import flag_bonds, make_filter

        s, nl = block.fields, block.bonds
        deck_dir = self.options.get("deck_dir")
        path = tuple(self.options.get("path", ("Damage Models",)))
        filters = [
            make_filter(raw, deck_dir=deck_dir, path=path + ("Bond Filters", name), for_initial_damage=True)
            for name, raw in self.params.bond_filters.items()
        ]
        rows = np.arange(block.start, block.stop)
        lo, hi = nl.offsets[block.start], nl.offsets[block.stop]
        sub_offsets = nl.offsets[block.start : block.stop + 1] - lo
        flags = flag_bonds(s["Model_Coordinates"], sub_offsets, nl.neighbors[lo:hi], filters, rows=rows)
        for d in (s["Bond_Damage"], s.n("Bond_Damage")):
            d[lo:hi] = flags
        counts = np.diff(sub_offsets)
        sums = np.bincount(np.repeat(np.arange(len(rows)), counts), weights=flags, minlength=len(rows))
        damage = np.where(counts > 0, sums / np.maximum(counts, 1), 0.0)
        for d in (s["Damage"], s.n("Damage")):
            d[block.start : block.stop] = damage

    def update(self, block: BlockView) -> None:
        """Initial damage does not evolve."""
