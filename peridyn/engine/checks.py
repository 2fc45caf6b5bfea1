"""Checks of the model the engine builds, before anything runs: points with finite positions and
positive volumes, no two points at one place, and bonds (a model without any is refused; points
without neighbors are named in a warning)."""
from __future__ import annotations

import logging
from typing import Any

import numpy as np

from ..core.errors import InputError, is_file
from . import plausibility

log = logging.getLogger("peridyn.engine")


def mesh_file(disc: Any, deck_file: str) -> str:
    """The mesh file the points came from, or the deck for generated points."""
    return disc.source if disc.source and is_file(disc.source) else deck_file


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
    """No bond of zero reference length: two points at one place (bond lengths computed from
    the reference positions, without allocating Bond_Length)."""
    from .kernels import shortest_bond_kernel

    nl = sim.bonds
    shortest, b = shortest_bond_kernel(sim.num_local, nl.offsets, nl.neighbors, sim.fields["Model_Coordinates"])
    if b >= 0 and not shortest > 0.0:
        b = int(b)
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
        hint = plausibility.no_neighbor_hint(sim)
        if sim.deck.contact is not None:  # points that interact by contact only
            log.warning("no point has a neighbor (horizons %s, point spacing about %.3g): only contact acts%s", horizons, spacing,
                        f"; {hint}" if hint else "")
            return
        raise InputError(
            f"no point has a neighbor: the horizons ({horizons}) are below the point spacing (about {spacing:.3g})"
            + (f"; {hint.partition(' give ')[0]}" if hint else ""),
            file=sim.deck.file, path=("Blocks",), fix=f"give {hint.partition(' give ')[2]}" if hint else "give horizons of about three point spacings",
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


#: a horizon above this many times the model's size (its bounding box diagonal, or the point
#: spacing for a single point) is refused: every point is already a neighbor of every other at
#: one model size, so a larger horizon only shrinks the micromoduli (1/delta^4) towards zero
HORIZON_PER_EXTENT = 1.0e3
#: horizons whose 4th power (micromodulus 18 K / (pi delta^4), Peridigm's stable time step)
#: under- or overflows a double are refused
_TINY4 = float(np.finfo(np.float64).tiny) ** 0.25 * (1.0 + 1.0e-12)
_HUGE4 = float(np.finfo(np.float64).max) ** 0.25 * (1.0 - 1.0e-12)


def horizon_scale(sim: Any, disc: Any, horizon: np.ndarray) -> None:
    """Refuse horizons (numbers or evaluated expressions, L) that are absurd for the model: far
    above its size, or so large or small that delta^4 (the micromodulus, the stable time step)
    or delta^3 (neighborhood volumes) cannot be represented."""
    if not horizon.size:
        return
    with np.errstate(all="ignore"):
        spacing = float(np.cbrt(np.median(disc.volume))) if disc.volume.size else 0.0
        span = np.ptp(disc.x, axis=0) if disc.x.size else np.zeros(3)
        extent = float(np.sqrt(np.sum(span * span)))
    size = extent + spacing
    for k, (name, _bid, entry) in enumerate(sim.block_specs):
        mask = sim.block_index_mothership == k
        if not np.any(mask):
            continue
        h = horizon[mask]
        i = int(np.argmax(h))
        big, small = float(h[i]), float(h.min())
        where = entry.path + ("Horizon",)
        text = "" if isinstance(entry.horizon, (int, float)) else f" (the expression gives it at ({', '.join(f'{c:g}' for c in disc.x[mask][i])}))"
        if not (_TINY4 <= small and big <= _HUGE4):
            bad = big if big > _HUGE4 else small
            raise InputError(
                f"horizon {bad:g} in block {name!r} cannot be used: its 4th power (micromodulus, stable time step) "
                f"{'overflows' if bad > _HUGE4 else 'underflows'} a double{text}",
                file=sim.deck.file, path=where, fix=f"give a horizon of about three point spacings (spacing about {spacing:.3g})",
            )
        if np.isfinite(size) and size > 0 and big > HORIZON_PER_EXTENT * size:
            raise InputError(
                f"horizon {big:g} in block {name!r} is {big / size:.3g} times the model's size ({size:.3g}){text}: every point "
                "is a neighbor of every other long before that, and the micromoduli (1/horizon^4) would vanish",
                file=sim.deck.file, path=where, fix=f"give a horizon of about three point spacings (spacing about {spacing:.3g})",
            )
    plausibility.check_geometry(sim, disc, horizon)


#: horizon/spacing below this gives a handful of neighbors per point (the peridynamic sums then
#: resolve little); a warning says so
MIN_HORIZON_PER_SPACING = 2.0


def horizon_spacing(sim: Any) -> None:
    """One warning per block whose mean horizon is below two point spacings (spacing taken as
    the cube root of the points' volumes, as ``peridyn check`` prints it), with its mean number
    of neighbors; then the warnings of :func:`plausibility.check_materials` (moduli, densities
    and wave speeds that look like a unit slip)."""
    vol = sim.fields["Volume"]
    counts = sim.bonds.counts()
    for blk in sim.blocks:
        lo, hi = blk.start, min(blk.stop, sim.num_owned)
        n = max(hi - lo, 0)
        with np.errstate(all="ignore"):
            h = float(np.sum(sim.horizon_local[lo:hi])) if n else 0.0
            s = float(np.sum(np.cbrt(vol[lo:hi]))) if n else 0.0
            nb = float(np.sum(counts[lo:hi])) if n else 0.0
        n, h, s, nb = (sim.comm.allreduce_sum(v) for v in (n, h, s, nb))
        if not n or not s > 0:
            continue
        ratio = h / s
        if ratio < MIN_HORIZON_PER_SPACING:
            slip = plausibility.horizon_slip(ratio, h / n)
            log.warning(
                "block %s: the horizon is %.3g point spacings (below %g): about %.1f neighbors per point, "
                "too few for the peridynamic sums to resolve the deformation; %s",
                blk.name, ratio, MIN_HORIZON_PER_SPACING, nb / n, slip or "give a horizon of about three spacings",
            )
    plausibility.check_materials(sim)
