"""Unit slips: a horizon in millimetres next to coordinates in metres, moduli in GPa next to a
density in kg/m^3. Decks are unit-agnostic, so no single number is wrong in itself; what no
consistent unit system makes plausible is a dimensionless ratio of the model's own numbers:

* the horizon over the point spacing (2 to 6 in practice; the reference decks reach 13.6 on a
  27-point cube): above ``WARN_SPACINGS`` a warning, above ``REFUSE_SPACINGS`` a refusal; a
  horizon that reaches across a body of more than ``ALL_TO_ALL_REFUSE_POINTS`` points (every
  point bonded to every other) is refused too, and a mean family above ``WARN_FAMILY`` points
  warned about;
* moduli and densities between blocks (factors of 1e5 and more in the bulk modulus, 500 and
  more in the density: one block's numbers in another unit than the other's);
* the wave speed c = sqrt(K / density) against the run's own lengths and times, for an explicit
  solver: a 'Fixed dt' of more than ``FIXED_DT_CROSSINGS`` times the time a wave takes to cross
  one point spacing (the step is then far above the stable one), or a run in which the wave
  crosses the body more than ``BODY_CROSSINGS`` times.

The refusals go through :func:`peridyn.engine.limits.refuse` (``--no-limits`` runs the model
anyway, memory permitting). :func:`unit_slip_hint` states the likely slip for an error message
(a step count that cannot be made, an instability): empty when nothing looks like one.
"""
from __future__ import annotations

import logging
import math
import weakref
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import limits

log = logging.getLogger("peridyn.engine")

#: horizon / spacing above which a block gets a warning (a horizon that resolves nothing more
#: than one of a few spacings does, at a cost growing as its cube)
WARN_SPACINGS = 50.0
#: horizon / spacing above which a block is refused: a family of millions of points in 3D, or
#: a body inside one horizon; no peridynamic discretization is meant so
REFUSE_SPACINGS = 100.0
#: mean number of neighbors (estimated before the search) above which a warning is given
WARN_FAMILY = 2000.0
#: a horizon reaching across the whole body (every point bonded to every other) is warned
#: about above this many points and refused above the second (Peridigm's own decks bond all
#: of 2 to 27 points on purpose)
ALL_TO_ALL_WARN_POINTS = 100
ALL_TO_ALL_REFUSE_POINTS = 1000
#: bulk moduli (densities) of two blocks further apart than this factor: one in another unit
MODULUS_RATIO = 1.0e5
DENSITY_RATIO = 500.0
#: explicit runs: a 'Fixed dt' above this many times the time a wave needs to cross one point
#: spacing (the stable step is about 0.7 of it at three spacings' horizon)
FIXED_DT_CROSSINGS = 100.0
#: explicit runs: waves crossing the body more often than this in one run (the examples and
#: reference decks: 0.01 to 1,400)
BODY_CROSSINGS = 1.0e5
#: prescribed motion faster than this many wave speeds (strain of order one at every step), and
#: loads straining the loaded layer by more than this (|b| spacing / K): a modulus unit slip
SUPERSONIC = 1.0
LOAD_STRAIN = 1.0
#: horizon / spacing a horizon corrected by a unit factor should land in to be named as the slip
_PLAUSIBLE = (1.5, 8.0)
#: a horizon below this many spacings is named as a length slip (Peridigm's decks give half a
#: spacing to bond nothing on purpose, with contact only)
_TOO_SHORT = 0.1
#: (factor, smaller unit, larger unit) of the length slips named, the likeliest first
_LENGTH_SLIPS = ((1000.0, "millimetres", "metres"), (100.0, "centimetres", "metres"),
                 (25.4, "millimetres", "inches"), (10.0, "millimetres", "centimetres"))


def horizon_slip(ratio: float, horizon: float) -> str:
    """The length-unit slip that brings a horizon of ``ratio`` point spacings to a plausible
    2 to 6 spacings, as a question with the corrected horizon ("" when none does)."""
    if not (math.isfinite(ratio) and ratio > 0.0):
        return ""
    lo, hi = _PLAUSIBLE
    for factor, small, big in _LENGTH_SLIPS:
        if ratio > hi and lo <= ratio / factor <= hi:
            return f"a horizon in {small} with coordinates in {big}? give {horizon / factor:.6g}"
        if ratio < _TOO_SHORT and lo <= ratio * factor <= hi:
            return f"a horizon in {big} with coordinates in {small}? give {horizon * factor:.6g}"
    return ""


def material_slip(bulk: float, density: float) -> str:
    """The unit slip a bulk modulus and a density of one material suggest, by the size of their
    numbers in the unit systems a deck's other numbers could use ("" when they look alike).
    Used only once a dimensionless ratio already says something is off."""
    if not (bulk > 0.0 and density > 0.0 and math.isfinite(bulk) and math.isfinite(density)):
        return ""
    kg_m3 = 100.0 <= density <= 3.0e4  # a solid's density in kg/m^3
    pascal = 1.0e7 <= bulk <= 1.0e12  # a solid's bulk modulus in Pa
    if kg_m3 and bulk < 2.0e3:
        return f"moduli in GPa with the density in kg/m^3 (bulk modulus {bulk:.3g}, density {density:.3g})? give the moduli in Pa, 1e9 times larger"
    if kg_m3 and bulk < 1.0e7:
        return f"moduli in MPa with the density in kg/m^3 (bulk modulus {bulk:.3g}, density {density:.3g})? give the moduli in Pa, 1e6 times larger"
    if kg_m3 and bulk > 1.0e14:
        return f"a bulk modulus of {bulk:.3g} with the density in kg/m^3 ({density:.3g}): above any solid's in Pa; moduli 1e9 times too large?"
    if pascal and 0.1 <= density < 100.0:
        return f"a density in g/cm^3 with moduli in Pa (density {density:.3g}, bulk modulus {bulk:.3g})? give the density in kg/m^3, 1e3 times larger"
    if pascal and density > 3.0e4:
        return f"a density of {density:.3g} with moduli in Pa (bulk modulus {bulk:.3g}): denser than any solid in kg/m^3; 1e3 times too large?"
    return ""


# ---------------------------------------------------------------------------------------------
# geometry, before the neighbor search (the whole discretization is on every rank)


def check_geometry(sim: Any, disc: Any, horizon: np.ndarray) -> None:
    """Refuse a block whose horizon is hundreds of point spacings or spans a body of many
    points; warn about one of tens of spacings or of thousands of neighbors. Spacing: the cube
    root of the points' volumes; body size: the diagonal of the bounding box."""
    n = int(disc.num_points)
    if n < 2 or not horizon.size:
        return
    with np.errstate(all="ignore"):
        span = np.ptp(disc.x, axis=0)
        size = float(np.sqrt(np.sum(span * span)))
        family = np.minimum((4.0 / 3.0 * math.pi) * horizon**3 / disc.volume, n - 1.0)
    for k, (name, _bid, entry) in enumerate(sim.block_specs):
        mask = sim.block_index_mothership == k
        count = int(np.count_nonzero(mask))
        if not count:
            continue
        with np.errstate(all="ignore"):
            spacing = float(np.cbrt(np.median(disc.volume[mask])))
            h = float(np.median(horizon[mask]))
            ratio = h / spacing
            mean_family = float(np.mean(family[mask]))
        if not (math.isfinite(ratio) and spacing > 0.0):
            continue
        all_to_all = bool(np.min(horizon[mask]) >= size) and n > 2
        hint = horizon_slip(ratio, h)
        question, _, corrected = hint.partition(" give ")
        fix = f"give {corrected}" if corrected else f"give a horizon of about three point spacings ({3.015 * spacing:.4g})"
        reach = f", beyond the body (size {size:.3g}): all {n} points bonded to each other" if all_to_all else ""
        what = f"horizon {h:.6g} in block {name!r} is {ratio:.4g} point spacings (spacing {spacing:.3g}){reach}"
        if ratio > REFUSE_SPACINGS or (all_to_all and n > ALL_TO_ALL_REFUSE_POINTS):
            limits.refuse(f"{what}{'; ' + question if question else ''}", file=sim.deck.file, path=entry.path + ("Horizon",), fix=fix)
        elif ratio > WARN_SPACINGS or mean_family > WARN_FAMILY or (all_to_all and n > ALL_TO_ALL_WARN_POINTS):
            log.warning("Blocks > %s > Horizon: %s, about %.0f neighbors per point; %s", name, what, mean_family,
                        hint or "a peridynamic horizon is usually 2 to 6 point spacings")


def no_neighbor_hint(sim: Any) -> str:
    """For a model without bonds: the length slip of the first block whose horizon, corrected,
    is a plausible number of spacings ("" when none). Collective under MPI."""
    for b in block_scales(sim):
        hint = horizon_slip(b.horizon / b.spacing, b.horizon) if b.spacing > 0.0 else ""
        if hint:
            return f"block {b.name}: {hint}"
    return ""


# ---------------------------------------------------------------------------------------------
# materials and times, after set-up (reduced over ranks: every rank decides alike)


@dataclass(frozen=True)
class BlockScales:
    """One block's numbers, the same on every rank."""

    name: str
    points: int
    spacing: float  #: mean cube root of the point volumes (L)
    horizon: float  #: mean horizon (L)
    bulk: float  #: bulk modulus (M L^-1 T^-2), nan where the material has none
    density: float  #: (M L^-3)

    @property
    def wave_speed(self) -> float:
        """sqrt(K / density) (L/T), nan without a modulus."""
        with np.errstate(all="ignore"):
            return math.sqrt(self.bulk / self.density) if self.bulk > 0.0 and self.density > 0.0 else math.nan

    @property
    def crossing(self) -> float:
        """Time a wave needs to cross one point spacing (T)."""
        c = self.wave_speed
        return self.spacing / c if c > 0.0 else math.nan


def block_scales(sim: Any) -> list[BlockScales]:
    """Every block's points, spacing, horizon, bulk modulus and density, summed over ranks."""
    vol = sim.fields["Volume"]
    out = []
    for blk in sim.blocks:
        lo, hi = blk.start, min(blk.stop, sim.num_owned)
        n = max(hi - lo, 0)
        with np.errstate(all="ignore"):
            h = float(np.sum(sim.horizon_local[lo:hi])) if n else 0.0
            s = float(np.sum(np.cbrt(vol[lo:hi]))) if n else 0.0
        n, h, s = (sim.comm.allreduce_sum(v) for v in (float(n), h, s))
        try:
            bulk = float(blk.material.bulk_modulus)
        except Exception:  # noqa: BLE001 - a material without a bulk modulus (diffusion)
            bulk = math.nan
        try:
            density = float(blk.material.density)
        except Exception:  # noqa: BLE001
            density = math.nan
        if n:
            out.append(BlockScales(blk.name, int(n), s / n, h / n, bulk, density))
    return out


def _body_size(sim: Any) -> float:
    x = sim.discretization.x
    if not x.size:
        return 0.0
    span = np.ptp(x, axis=0)
    return float(np.sqrt(np.sum(span * span)))


def _explicit_sections(sim: Any) -> list[tuple[Any, float, float | None, float | None]]:
    """(entry, interval, Fixed dt times the Safety Factor or None, Safety Factor) of each
    explicit (Verlet) solver section."""
    out = []
    for entry in sim.deck.solvers:
        step = entry.cls.explicit_step(entry.params)
        if step is not None:
            out.append((entry, float(entry.params.final_time) - float(entry.params.initial_time), *step))
    return out


def material_findings(scales: list[BlockScales]) -> list[str]:
    """Moduli and densities of blocks too far apart for one unit system."""
    found = []
    known = [b for b in scales if b.bulk > 0.0 and math.isfinite(b.bulk)]
    if len(known) > 1:
        soft, stiff = min(known, key=lambda b: b.bulk), max(known, key=lambda b: b.bulk)
        if stiff.bulk > MODULUS_RATIO * soft.bulk:
            factor = stiff.bulk / soft.bulk
            unit = min((1e3, "GPa and MPa"), (1e6, "MPa and Pa (or GPa and kPa)"), (1e9, "GPa and Pa"),
                       key=lambda u: abs(math.log10(factor / u[0])))[1]
            found.append(f"block {stiff.name}'s bulk modulus ({stiff.bulk:.3g}) is {factor:.3g} times block {soft.name}'s "
                         f"({soft.bulk:.3g}): moduli in {unit} in one deck?")
    dense = [b for b in scales if b.density > 0.0 and math.isfinite(b.density)]
    if len(dense) > 1:
        light, heavy = min(dense, key=lambda b: b.density), max(dense, key=lambda b: b.density)
        if heavy.density > DENSITY_RATIO * light.density:
            found.append(f"block {heavy.name}'s density ({heavy.density:.3g}) is {heavy.density / light.density:.3g} times block "
                         f"{light.name}'s ({light.density:.3g}): one in kg/m^3 and one in g/cm^3?")
    return found


def time_findings(sim: Any, scales: list[BlockScales]) -> list[str]:
    """Explicit sections whose 'Fixed dt' or interval no plausible wave speed fits."""
    found = []
    timed = [b for b in scales if b.crossing > 0.0 and math.isfinite(b.crossing)]
    if not timed:
        return found
    fastest = min(timed, key=lambda b: b.crossing)
    size = _body_size(sim)
    for entry, interval, fixed_dt, _sf in _explicit_sections(sim):
        if fixed_dt is not None and fixed_dt > FIXED_DT_CROSSINGS * fastest.crossing:
            found.append(f"{entry.section}: 'Fixed dt' {fixed_dt:.4g} is {fixed_dt / fastest.crossing:.3g} times the time a wave "
                         f"(sqrt(bulk modulus/density) = {fastest.wave_speed:.4g}) needs to cross one point spacing in block "
                         f"{fastest.name} ({fastest.crossing:.3g}){_named(fastest, ' ')}")
        crossings = interval * fastest.wave_speed / size if size > 0.0 else 0.0
        if crossings > BODY_CROSSINGS:
            found.append(f"{entry.section}: a wave (sqrt(bulk modulus/density) = {fastest.wave_speed:.4g}) would cross the body "
                         f"(size {size:.3g}) {crossings:.3g} times before Final Time{_named(fastest, ' ')}")
    return found


def _named(block: BlockScales, sep: str) -> str:
    slip = material_slip(block.bulk, block.density)
    return f":{sep}{slip}" if slip else ": check the units of the moduli and the density"


def check_materials(sim: Any) -> None:
    """One warning per finding of :func:`material_findings` and :func:`time_findings`."""
    scales = block_scales(sim)
    for text in material_findings(scales) + time_findings(sim, scales):
        log.warning("%s", text)


# ---------------------------------------------------------------------------------------------
# the hint an error message appends

_STATIC: "weakref.WeakKeyDictionary[Any, list[str]]" = weakref.WeakKeyDictionary()


def _static_findings(sim: Any) -> list[str]:
    """What the model's numbers say before any step, once per simulation."""
    if sim in _STATIC:
        return _STATIC[sim]
    scales = block_scales(sim)
    found = []
    for b in scales:
        ratio = b.horizon / b.spacing if b.spacing > 0.0 else math.nan
        if not (_PLAUSIBLE[0] <= ratio <= WARN_SPACINGS):
            slip = horizon_slip(ratio, b.horizon)
            if slip:
                found.append(f"block {b.name}'s horizon is {ratio:.4g} point spacings: {slip}")
    found += material_findings(scales)
    found += time_findings(sim, scales)
    timed = [b for b in scales if b.crossing > 0.0 and math.isfinite(b.crossing)]
    if timed and not any("horizon" in f for f in found):
        slow = max(timed, key=lambda b: b.crossing)
        for entry, interval, fixed_dt, _sf in _explicit_sections(sim):
            if fixed_dt is None and interval < slow.crossing:  # the estimate-based step is longer than the run
                slip = material_slip(slow.bulk, slow.density)  # short: it ends a message that says the rest
                found.append(slip or f"{entry.section}: a wave (sqrt(bulk modulus/density) = {slow.wave_speed:.4g}) needs "
                             f"{slow.crossing:.3g} to cross one point spacing of block {slow.name}, longer than the whole interval "
                             f"{interval:.4g}{_named(slow, ' ')}")
                break
    _STATIC[sim] = found
    return found


def _motion_findings(sim: Any, scales: list[BlockScales]) -> list[str]:
    """Prescribed motion faster than sound, loads straining the loaded points by more than
    100 %: what a modulus far too small gives (read from the fields now, reduced over ranks)."""
    found = []
    n = sim.num_owned
    speeds = [b for b in scales if b.wave_speed > 0.0]
    if not speeds:
        return found
    slowest = min(speeds, key=lambda b: b.wave_speed)
    stiff = max(b.bulk for b in speeds)
    fast = 0.0
    dofs = sim.prescribed_dofs
    if "Velocity" in sim.fields and n:
        v = np.abs(sim.fields["Velocity"][:n])[dofs[:n]]
        v = v[np.isfinite(v)]
        fast = float(v.max()) if v.size else 0.0
    fast = sim.comm.allreduce_max(fast)
    if fast > SUPERSONIC * slowest.wave_speed:
        found.append(f"the prescribed motion ({fast:.3g}) is {fast / slowest.wave_speed:.3g} times the wave speed "
                     f"sqrt(bulk modulus/density) = {slowest.wave_speed:.3g} of block {slowest.name}{_named(slowest, ' ')}")
    load = 0.0
    if "External_Force_Density" in sim.fields and n:
        b = sim.fields["External_Force_Density"][:n]
        with np.errstate(all="ignore"):
            mag = np.sqrt(np.einsum("ij,ij->i", b, b)) * np.cbrt(sim.fields["Volume"][:n])
        mag = mag[np.isfinite(mag)]
        load = float(mag.max()) if mag.size else 0.0
    load = sim.comm.allreduce_max(load)
    if stiff > 0.0 and load > LOAD_STRAIN * stiff:
        found.append(f"the loads strain the loaded points by about {load / stiff:.3g} (|body force density| x spacing / bulk "
                     f"modulus){_named(max(speeds, key=lambda b: b.bulk), ' ')}")
    return found


def unit_slip_hint(sim: Any) -> str:
    """The likely unit slip of the model, one clause for an error message ("" when nothing
    looks like one): horizon against spacing, moduli and densities between blocks, wave speed
    against the explicit sections' 'Fixed dt' and intervals (computed once and kept), and the
    prescribed motion and loads against the wave speed and moduli (read now). Collective under
    MPI (every rank calls it; every rank gets the same text)."""
    try:
        found = list(_static_findings(sim))
        if not found:
            found = _motion_findings(sim, block_scales(sim))
    except (AttributeError, KeyError, TypeError, ValueError, ArithmeticError):  # a partial model: no hint rather than a second error
        return ""
    if not found:
        return ""
    return "likely a unit slip: " + found[0]
