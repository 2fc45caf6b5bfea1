"""The force evaluation of a simulation (:meth:`peridyn.engine.simulation.Simulation.evaluate_forces`):
what every solver and every target's step calls to turn positions into force densities."""
from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..core.interfaces import BlockView, Simulation
from ..kernels.gathers import gather_scalar_force_kernel, gather_vector_force_kernel

if TYPE_CHECKING:  # pragma: no cover
    from .blocks import Block


def evaluate_forces(sim: Simulation) -> np.ndarray:
    """Peridigm's evalModel on ``sim``: ghosts refreshed, damage, precompute, force (fused per block
    where the material can, else force states gathered over the bonds, reactions on ghosts sent
    to their owners). Returns Force_Density (num_local, 3), M L^-2 T^-2; rows 0:num_owned hold
    the owned points' forces."""
    if sim.overlap:
        return _evaluate_forces_overlapped(sim)
    parallel = sim.comm.size > 1
    if parallel:
        sim.halo.exchange(sim.fields["Coordinates"])
        if "Temperature_Change" in sim.fields:
            sim.halo.exchange(sim.fields["Temperature_Change"])
        for name in sim.ghost_inputs:
            sim.halo.exchange(sim.fields[name])
    for blk in sim.blocks:
        if blk.damage is not None and not blk.damage_adopted:
            blk.damage.update(blk.view)
    for blk in sim.blocks:
        if blk.damage_adopted:
            blk.material.precompute_with_damage(blk.view)
        else:
            blk.material.precompute(blk.view)
    if parallel:
        for name in sim.precompute_fields:
            sim.halo.exchange(sim.fields[name])
    f = sim.fields["Force_Density"]
    pending = []
    for blk in sim.blocks:
        if not blk.group:
            continue  # computed with its group
        if not (blk.fused and blk.material.force_fused(blk.fused_view or blk.view, f)):
            pending.extend(blk.group)
    reverse = parallel and _reverse_pass(sim, bool(pending))
    if pending:
        scalar = any(blk.material.force_state_kind == "scalar" for blk in pending)
        vector = any(blk.material.force_state_kind == "vector" for blk in pending)
        if scalar and sim.bond_force is None:
            sim.bond_force = np.zeros(sim.bonds.num_bonds)
        if vector and sim.bond_force_vector is None:  # non-ordinary materials only
            sim.bond_force_vector = np.zeros((sim.bonds.num_bonds, 3))
        t, T = sim.bond_force, sim.bond_force_vector
        for blk in pending:
            blk.material.force_state(blk.view, T if blk.material.force_state_kind == "vector" else t)
        nl = sim.bonds
        in_offsets, in_bonds = nl.transpose()
        sources = nl.sources()
        y, vol = sim.fields["Coordinates"], sim.fields["Volume"]
        ranges = [(blk.start, blk.stop) for blk in pending]
        if parallel and sim.num_local > sim.num_owned:
            # reactions of this rank's bonds on ghosts go to the ghosts' owners
            ranges.append((sim.num_owned, sim.num_local))
        for lo, hi in ranges:
            if t is not None:
                gather_scalar_force_kernel(lo, hi, nl.offsets, nl.neighbors, in_offsets, in_bonds, sources, y, vol, t, f)
            else:
                f[lo:hi] = 0.0
            if T is not None:
                gather_vector_force_kernel(lo, hi, nl.offsets, nl.neighbors, in_offsets, in_bonds, sources, vol, T, f)
    if reverse:
        if not pending:
            f[sim.num_owned:] = 0.0  # this rank's fused kernels leave its ghost rows as they were
        sim.halo.reverse_sum(f)
    return f


def _reverse_pass(sim: Simulation, local: bool) -> bool:
    """Whether this evaluation sends ghost rows' forces to their owners: where any rank gathers
    force states (``local``: this rank does), every rank takes part, also one whose own blocks
    were all computed fused (its points may be another rank's ghosts). Decided collectively at
    the first evaluation; which blocks a rank gathers does not change during a run (the models
    decide it from the bonds), which is checked."""
    if sim.reverse_forces is None:
        sim.reverse_forces = bool(sim.comm.allreduce_max(int(local)))
    if local and not sim.reverse_forces:
        raise RuntimeError("a rank gathers force states it did not gather at the first evaluation")
    return sim.reverse_forces

def _evaluate_forces_overlapped(sim: Simulation) -> np.ndarray:
    """``evaluate_forces`` under MPI with fused, row-local models: each phase first computes
    the rows without ghost neighbors while the ghosts' positions (then their precomputed
    fields) travel, then the rest. Every row is computed exactly as without overlap."""
    f = sim.fields["Force_Density"]
    halo = sim.halo
    if "Temperature_Change" in sim.fields:
        halo.exchange(sim.fields["Temperature_Change"])
    pending = halo.begin(sim.fields["Coordinates"])
    _precompute_rows(sim, interior=True)
    halo.end(pending)
    _precompute_rows(sim, interior=False)
    pending = [halo.begin(sim.fields[name]) for name in sim.precompute_fields]
    _force_rows(sim, f, interior=True)
    for p in pending:
        halo.end(p)
    _force_rows(sim, f, interior=False)
    return f

def _rows_view(blk: "Block", interior: bool) -> BlockView | None:
    """The part of ``blk``'s view without ghost neighbors, or the rest; None when empty."""
    if interior:
        return replace(blk.view, stop=blk.split) if blk.split > blk.start else None
    return replace(blk.view, start=blk.split) if blk.stop > blk.split else None

def _precompute_rows(sim: Simulation, interior: bool) -> None:
    for blk in sim.blocks:
        view = _rows_view(blk, interior)
        if view is None:
            continue
        if blk.damage_adopted:
            blk.material.precompute_with_damage(view)
        else:
            if blk.damage is not None:
                blk.damage.update(view)
            blk.material.precompute(view)

def _force_rows(sim: Simulation, f: np.ndarray, interior: bool) -> None:
    for lead in sim.blocks:
        for blk in lead.group:  # the lead's material computes its whole group
            view = _rows_view(blk, interior)
            if view is not None and not lead.material.force_fused(view, f):
                raise RuntimeError(f"material {lead.material.name!r} declares row_local but its force_fused declined block {blk.name!r}")
