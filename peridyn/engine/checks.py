"""Checks of the model the engine builds, before anything runs: points with finite positions and
positive volumes, no two points at one place, and bonds (a model without any is refused; points
without neighbors are named in a warning)."""
from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError

log = logging.getLogger("peridyn.engine")


def mesh_file(disc: Any, deck_file: str) -> str:
    """The mesh file the points came from, or the deck for generated points."""
    return disc.source if disc.source and Path(disc.source).is_file() else deck_file


def finite_points(disc: Any, file: str, path: tuple[str, ...]) -> None:
    """Every point needs a finite position (L) and a positive finite volume (L^3)."""
    bad = ~np.isfinite(disc.x).all(axis=1) | ~(np.isfinite(disc.volume) & (disc.volume > 0))
    if np.any(bad):
        i = int(np.argmax(bad))
        raise InputError(
            f"point {int(disc.gid[i]) + 1} has position {tuple(float(c) for c in disc.x[i])} and volume {float(disc.volume[i])!r}",
            file=file, path=path, fix="every point needs a finite position and a positive finite volume",
        )


def no_coincident_points(sim: Any, disc: Any) -> None:
    """No bond of zero reference length (``Bond_Length`` filled): two points at one place."""
    zeta = sim.fields["Bond_Length"]
    if zeta.size and not zeta.min() > 0.0:
        b = int(np.argmin(zeta))
        i = int(np.searchsorted(sim.bonds.offsets, b, side="right")) - 1
        j = int(sim.bonds.neighbors[b])
        x = sim.fields["Model_Coordinates"][i]
        raise InputError(
            f"points {int(sim.gid[i]) + 1} and {int(sim.gid[j]) + 1} are at the same position {tuple(float(c) for c in x)}",
            file=mesh_file(disc, sim.deck.file), path=sim.deck.discretization.path,
            fix="remove duplicate points from the mesh, or give the generator a finite extent",
        )


def connected(sim: Any) -> None:
    """Refuse a model without a single bond; warn about points without neighbors."""
    if sim.num_bonds_global == 0 and sim.num_global > 1:
        spacing = float(np.cbrt(np.median(sim.discretization.volume)))
        horizons = ", ".join(f"{blk.name}: {blk.horizon_text}" for blk in sim.blocks)
        if sim.deck.contact is not None:  # points that interact by contact only
            log.warning("no point has a neighbor (horizons %s, point spacing about %.3g): only contact acts", horizons, spacing)
            return
        raise InputError(
            f"no point has a neighbor: the horizons ({horizons}) are below the point spacing (about {spacing:.3g})",
            file=sim.deck.file, path=("Blocks",), fix="give horizons of about three point spacings",
        )
    counts = sim.bonds.counts()[: sim.num_owned]
    lonely = np.nonzero(counts == 0)[0]
    total = sim.comm.allreduce_sum(int(lonely.size))
    if total:
        ids = ", ".join(str(int(g) + 1) for g in sim.gid[lonely[:5]])
        log.warning(
            "%d point(s) have no neighbors (e.g. point %s): they feel no internal force and move freely; "
            "check the horizon against the point spacing",
            total,
            ids or "on another rank",
        )
