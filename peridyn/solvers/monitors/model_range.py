"""Whether a run stays where its models' laws hold.

A linear peridynamic solid at 47 % strain, or a small-rotation correspondence model turned by 90
degrees, still runs, and its energy balance may still close; the answer is then the law's
extrapolation, not the material's. Materials declare their range (``Material.small_strain_limit``,
the largest bond strain of intact bonds at which their law is still theirs;
``Material.small_rotation_limit``, the largest rotation of a point's family, in radians, for
models whose strain is not rotation invariant). :class:`RangeWatch` measures, a few times per
solver section, the largest strain of each such block's families (the principal stretches of the
deformation gradient fitted to a family's intact bonds, for points with a bond beyond the limit
and damage at most 1/2) and the largest rotation
of its points' families (the polar decomposition of the family's deformation gradient), and
warns once per block and measure, naming the block, the value, the point and the limit. Blocks
whose materials declare no limit cost nothing.
"""
from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np
from numba import njit, prange, uint64

from ...computes.deformation_gradient import INTACT_DEFORMATION_GRADIENT
from ...core.influence import ONE
from ...kernels import mirror

log = logging.getLogger("peridyn.solver")

#: checks per solver section (and one at its end): the strain check is one pass over the bonds,
#: about a force evaluation's work, so at most one every MIN_STRIDE steps (under 1 % of a
#: section's work; a section shorter than that is checked at its end)
CHECKS_PER_SECTION = 10
MIN_STRIDE = 100


@njit(cache=True, inline="always")
def squared_stretch(x, y, i, j):
    """(|y_j - y_i| / |x_j - x_i|)^2, or -1 for two points at one place."""
    r0 = 0.0
    r = 0.0
    for c in range(3):
        d0 = x[j, c] - x[i, c]
        d = y[j, c] - y[i, c]
        r0 += d0 * d0
        r += d * d
    return r / r0 if r0 > 0.0 else -1.0


@njit(cache=True, parallel=True)
def bond_strain_kernel(start, stop, offsets, neighbors, x, y, damage, point_damage, out):
    """out[i - start] = largest |(|y_j - y_i| - |x_j - x_i|) / |x_j - x_i|| over point i's bonds
    with damage below 1 (damage empty: every bond), for start <= i < stop; 0 for a point whose
    ``point_damage`` is above 1/2 (a fragment's debris: its few bonds left are no continuum)."""
    has_d = damage.shape[0] > 0
    has_p = point_damage.shape[0] > 0
    for i in prange(start, stop):
        if has_p and point_damage[i] > 0.5:
            out[i - start] = 0.0
            continue
        longest = 1.0  # the extremes of (|y_j - y_i| / |x_j - x_i|)^2: one division a bond, two roots a point
        shortest = 1.0
        for b in range(uint64(offsets[i]), uint64(offsets[i + 1])):  # unsigned: no wraparound code (as the bond loops)
            if has_d and damage[b] >= 1:
                continue
            j = neighbors[b] & 0x7FFFFFFF
            q = squared_stretch(x, y, i, j)
            if q >= 0.0:
                if q > longest:
                    longest = q
                elif q < shortest:
                    shortest = q
        out[i - start] = max(math.sqrt(longest) - 1.0, 1.0 - math.sqrt(shortest))


@njit(cache=True)
def mirrored_bond_strain_kernel(n, offsets, neighbors, x, y, damage, point_damage, upper, cursor, longest, shortest, out):
    """bond_strain_kernel's ``out`` for the points 0..n, each bond visited once (one thread): row i
    visits its upper bonds (``kernels.mirror``'s plan ``upper``, ``cursor``), whose bond back from j
    is j's next lower bond; each end keeps the bond when its own damage is below 1. The same
    extremes as the gather, so the same bits."""
    has_d = damage.shape[0] > 0
    has_p = point_damage.shape[0] > 0
    for i in range(n):
        cursor[i] = 0
        longest[i] = 1.0
        shortest[i] = 1.0
    for i in range(n):
        for b in range(uint64(upper[i]), uint64(offsets[i + 1])):
            j = neighbors[b] & 0x7FFFFFFF
            rb = offsets[j] + cursor[j]
            cursor[j] += 1
            q = squared_stretch(x, y, i, j)
            if q >= 0.0:
                if not has_d or damage[b] < 1:
                    longest[i] = max(longest[i], q)
                    shortest[i] = min(shortest[i], q)
                if not has_d or damage[rb] < 1:
                    longest[j] = max(longest[j], q)
                    shortest[j] = min(shortest[j], q)
    for i in range(n):
        if has_p and point_damage[i] > 0.5:
            out[i] = 0.0
        else:
            out[i] = max(math.sqrt(longest[i]) - 1.0, 1.0 - math.sqrt(shortest[i]))


def family_gradients(sim: Any, lo: int, hi: int, damage: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F (hi - lo, 3, 3), singular (hi - lo,) bool) of the points lo..hi: the deformation gradient
    fitted, unweighted, to each family's intact bonds (computes.deformation_gradient's
    INTACT_DEFORMATION_GRADIENT, run by the model's backend); singular where the family does
    not span three dimensions (F is 0 there)."""
    s = sim.fields
    n = sim.num_local
    F, Kinv, singular = np.zeros((n, 9)), np.zeros((n, 9)), np.zeros(n, dtype=np.int8)
    args = (s["Coordinates"], s["Volume"], sim.horizon_local, ONE, np.zeros(0), F, Kinv, singular, damage)
    sim.backend.kernel(INTACT_DEFORMATION_GRADIENT)(lo, hi, sim.bonds.offsets, sim.bonds.neighbors, s["Bond_Length"],
                                                    s["Model_Coordinates"], args, np.zeros(n))
    return F[lo:hi].reshape(-1, 3, 3), singular[lo:hi].astype(bool)


def family_strains(F: np.ndarray) -> np.ndarray:
    """(n,) largest |lambda - 1| over the principal stretches lambda of each F (n, 3, 3)."""
    if not len(F):
        return np.zeros(0)
    return np.abs(np.linalg.svd(F, compute_uv=False) - 1.0).max(axis=1)


def rotation_angles(F: np.ndarray) -> np.ndarray:
    """(n,) angle (radians, 0 to pi) of the rotation R of the polar decomposition F = R U of
    each (3, 3) F of ``F`` (n, 3, 3)."""
    if not len(F):
        return np.zeros(0)
    u, _, vt = np.linalg.svd(F)
    R = u @ vt
    flip = np.linalg.det(R) < 0.0
    if np.any(flip):  # an inverted family: the nearest proper rotation
        u[flip, :, 2] *= -1.0
        R = u @ vt
    cos = 0.5 * (np.trace(R, axis1=1, axis2=2) - 1.0)
    return np.arccos(np.clip(cos, -1.0, 1.0))


class RangeWatch:
    """Measures a run's deformation against its materials' declared ranges (see module doc)."""

    def __init__(self, sim: Any, steps: int, where: Any = None) -> None:
        self.sim = sim
        #: the step's placement, whose positions and damage are brought to the host to be measured
        self.where = where
        self.stride = max(MIN_STRIDE, steps // CHECKS_PER_SECTION)
        self.steps = steps
        self.blocks = [blk for blk in sim.blocks
                       if blk.material.small_strain_limit is not None or blk.material.small_rotation_limit is not None]
        #: (block name, "strain" | "rotation") already warned about, in this run
        self.warned: set[tuple[str, str]] = sim.stats.setdefault("range_warned", set())
        #: largest measure per block and kind over the run, for the summary
        self.largest: dict[str, dict[str, float]] = sim.stats.setdefault("range", {})

    def after_step(self, step: int) -> None:
        """Measure after ``step`` when one is due (every ``stride`` steps and at the last)."""
        if self.blocks and (step % self.stride == 0 or step == self.steps):
            if self.where is not None:
                self.where.to_host(["Coordinates", "Bond_Damage", "Damage"])
            self.measure()

    def measure(self) -> None:
        sim = self.sim
        f = sim.fields
        nl = sim.bonds
        n = sim.num_owned
        x, y = f["Model_Coordinates"], f["Coordinates"]
        damage = f["Bond_Damage"] if "Bond_Damage" in f else np.zeros(0, dtype=np.uint8)
        point_damage = f["Damage"] if "Damage" in f else np.zeros(0)
        every = self._mirrored_strains(x, y, damage, point_damage)
        for blk in self.blocks:
            lo, hi = blk.start, min(blk.stop, n)
            mat = blk.material
            for kind, limit in (("strain", mat.small_strain_limit), ("rotation", mat.small_rotation_limit)):
                if limit is None:
                    continue
                values = np.zeros(max(hi - lo, 0))
                if hi > lo:
                    if kind == "strain":  # a bond beyond the limit, then its family's strain (not one bond at a crack)
                        if every is not None:
                            values[:] = every[lo:hi]
                        else:
                            bond_strain_kernel(lo, hi, nl.offsets, nl.neighbors, x, y, damage, point_damage, values)
                        over = np.flatnonzero(values > limit)
                        if over.size:
                            F, singular = family_gradients(sim, lo, hi, damage)
                            values[over] = np.where(singular[over], 0.0, family_strains(F[over]))
                    else:
                        F, singular = family_gradients(sim, lo, hi, damage)
                        values = np.where(singular, 0.0, rotation_angles(F))
                k = int(np.argmax(values)) if values.size else -1
                local = (float(values[k]), int(sim.gid[lo + k]) + 1, tuple(float(c) for c in x[lo + k])) if k >= 0 else (0.0, 0, ())
                worst = max(sim.comm.allgather(local), key=lambda v: v[0]) if sim.comm.size > 1 else local
                seen = self.largest.setdefault(blk.name, {})
                seen[kind] = max(seen.get(kind, 0.0), worst[0])
                if worst[0] > limit and (blk.name, kind) not in self.warned:
                    self.warned.add((blk.name, kind))
                    self._warn(blk, kind, limit, worst)

    def _mirrored_strains(self, x: np.ndarray, y: np.ndarray, damage: np.ndarray,
                          point_damage: np.ndarray) -> np.ndarray | None:
        """(num_owned,) every point's bond_strain_kernel value from one visit per bond, on a run of
        one rank and one thread whose rows mirror (``kernels.mirror``) and whose blocks measure
        strain; None otherwise (the blocks' gathers run)."""
        sim = self.sim
        nl = sim.bonds
        if (sim.comm.size > 1 or not sim.backend.one_thread() or not mirror.enabled()
                or nl.num_points != sim.num_owned or not any(b.material.small_strain_limit is not None for b in self.blocks)):
            return None
        plan = mirror.mirror_plan(nl, 0, nl.num_points)
        if plan is None:
            return None
        n = nl.num_points
        out = np.empty(n)
        mirrored_bond_strain_kernel(n, nl.offsets, nl.neighbors, x, y, damage, point_damage, *plan,
                                    np.empty(n), np.empty(n), out)
        return out

    def _warn(self, blk: Any, kind: str, limit: float, worst: tuple) -> None:
        value, gid, where = worst
        at = f"point {gid} (x = {', '.join(f'{c:.4g}' for c in where)})"
        name = blk.material.name
        if kind == "strain":
            log.warning(
                "block %s: its families reach a strain of %.3g at %s, beyond %g, where the small-strain law of %r holds; "
                "the answer from here is the linear law's extrapolation (use a model for large strains, or smaller loads)",
                blk.name, value, at, limit, name,
            )
        else:
            log.warning(
                "block %s: its families have turned by %.3g degrees at %s, beyond the %.3g degrees within which %r "
                "(whose strain is not rotation invariant) holds; the stresses from here follow the rotation, not the "
                "material (use a rotation-invariant model such as Elastic, or a hypoelastic correspondence model)",
                blk.name, math.degrees(value), at, math.degrees(limit), name,
            )
