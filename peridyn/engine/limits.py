"""A run's size, estimated before anything large is allocated or computed, and the limits that
refuse what cannot fit in this machine's memory or cannot finish.

Estimates, in order of the set-up:

* points: from a generator's parameters (``DiscretizationReader.estimate_points``) before
  the points are made;
* bonds: sum over points of min(n - 1, (4/3) pi delta_i^3 / V_i), the points of a ball of the
  horizon at the point's own density, before the neighbor search;
* memory: ``BYTES_PER_POINT`` per point plus ``BYTES_PER_BOND`` per bond, against the memory
  the operating system reports available;
* steps and wall time: each solver's ``planned_steps`` times the bonds and points, at
  ``BOND_RATE`` bond evaluations per second, before the first step; for a solver that solves
  with a tangent (``Solver.implicit``), ``ITERATIONS_PER_STEP`` Newton iterations per step, each
  costing ``TANGENT_ENTRY_SECONDS`` per stored tangent entry (assembly and solve) plus
  ``EVALUATIONS_PER_ITERATION`` force evaluations; the tangent's entries are counted from the
  neighbor lists (:func:`estimate_tangent_entries`). benchmarks/estimates.py measures how these
  estimates compare with the examples' and reference decks' wall times.

A model over the memory limit or a run over ``MAX_STEPS`` steps or ``MAX_SECONDS`` of estimated
wall time is an input error (exit 2) that states the estimate and the limit; a run estimated to
take more than ``WARN_SECONDS`` gets a warning. The ratios that betray a unit slip (a horizon of
thousands of point spacings, say) are refused the same way, by :mod:`peridyn.engine.plausibility`.
``PERIDYN_NO_LIMITS=1`` (or ``peridyn run --no-limits``) turns the refusals into warnings for
those who mean it.
"""
from __future__ import annotations

import logging
import math

import numpy as np

from ..core.resources import NO_LIMITS_ENV as ENV, available_memory, human_bytes as _human_bytes, limits_off
from ..core.errors import InputError

log = logging.getLogger("peridyn.engine")

#: fields, ids and orderings of one point, with headroom (cube40: about 600 bytes measured)
BYTES_PER_POINT = 1024
#: int32 neighbor, float64 bond length and damage, reverse and transposed indices, and the
#: temporaries of the search, the sort and a grid generator's candidate lists
BYTES_PER_BOND = 64
#: bond evaluations per second per run, a low figure for the LPS kernels on one core
BOND_RATE = 5.0e7
#: seconds per stored tangent entry of one Newton iteration on one core (assembly, AMG set-up
#: and solve), measured 2026-11-28 on this project's 2-core Intel machine: an analytic tangent
#: (LPS Elastic, a 4,000-point bar, 17 M entries: 3.6e-8) and one by finite differences (Elastic
#: Correspondence, Peridigm's tensile test, 30 M entries: 1.6e-7)
TANGENT_ENTRY_SECONDS = {"analytic": 4.0e-8, "finite differences": 1.6e-7}
#: Newton iterations per load or time step in the estimate (the examples and reference decks: 2 to 4)
ITERATIONS_PER_STEP = 3.0
#: force evaluations per Newton iteration in the estimate (residual and line search)
EVALUATIONS_PER_ITERATION = 3.0
#: seconds of a Newton iteration that do not grow with the model (Python, the linear solver's
#: set-up), and of an implicit section (its first compiled calls): what the reference decks of a
#: dozen points take (benchmarks/estimates.py)
ITERATION_OVERHEAD_SECONDS = 0.01
SECTION_OVERHEAD_SECONDS = 0.1
#: points whose two-horizon neighbourhood is counted to estimate the tangent's entries
TANGENT_SAMPLE = 256
MAX_STEPS = 1.0e9
MAX_SECONDS = 30 * 24 * 3600.0
WARN_SECONDS = 3600.0


def human_seconds(s: float) -> str:
    if not math.isfinite(s):
        return "forever"
    if s < 120:
        return f"{s:.3g} s"
    if s < 7200:
        return f"{s / 60:.3g} min"
    if s < 3 * 86400:
        return f"{s / 3600:.3g} h"
    if s < 3 * 365 * 86400:
        return f"{s / 86400:.3g} days"
    return f"{s / (365 * 86400):.3g} years"


def refuse(message: str, *, file: str | None, path: tuple[str, ...], fix: str) -> None:
    """An InputError for a judgment of size (memory, steps, absurd ratios: see
    :mod:`peridyn.engine.plausibility`), a warning instead under ``PERIDYN_NO_LIMITS``."""
    if limits_off():
        log.warning("%s (%s is set: running anyway)", message, ENV)
        return
    raise InputError(message, file=file, path=path, fix=f"{fix}, or set {ENV}=1 (peridyn run --no-limits) if you mean it")


def estimate_bonds(volume: np.ndarray, horizon: np.ndarray) -> float:
    """Expected number of bonds: sum_i min(n - 1, 4/3 pi delta_i^3 / V_i). volume, horizon: (n,)."""
    n = volume.shape[0]
    if n < 2:
        return 0.0
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        per_point = (4.0 / 3.0 * math.pi) * horizon**3 / volume
    per_point = np.where(np.isnan(per_point), n - 1.0, np.minimum(per_point, n - 1.0))
    return float(per_point.sum())


def check_memory(points: float, bonds: float, *, file: str | None, path: tuple[str, ...], what: str) -> None:
    """Refuse a model whose estimated memory exceeds what is available."""
    need = points * BYTES_PER_POINT + bonds * BYTES_PER_BOND
    have = available_memory()
    if need > 0.9 * have:
        bonds_text = f" and about {bonds:.3g} bonds" if bonds else ""
        refuse(
            f"{what}: {points:.3g} points{bonds_text} need about {_human_bytes(need)}, more than the "
            f"{_human_bytes(have)} of memory available",
            file=file,
            path=path,
            fix="use fewer points or a smaller horizon",
        )


def estimate_seconds(steps: float, points: float, bonds: float, *, tangent_entries: float = 0.0, finite_differences: bool = False) -> float:
    """Wall time (s) of ``steps`` steps on one core: explicit, one force evaluation a step; with
    ``tangent_entries`` (a solver that solves with a tangent of that many stored 3x3-block
    entries, scalars), Newton iterations of a tangent and force evaluations."""
    evaluation = (bonds + points) / BOND_RATE
    if tangent_entries <= 0.0:
        return steps * evaluation
    per_entry = TANGENT_ENTRY_SECONDS["finite differences" if finite_differences else "analytic"]
    per_iteration = ITERATION_OVERHEAD_SECONDS + tangent_entries * per_entry + EVALUATIONS_PER_ITERATION * evaluation
    return SECTION_OVERHEAD_SECONDS + steps * ITERATIONS_PER_STEP * per_iteration


def estimate_tangent_entries(offsets: np.ndarray, neighbors: np.ndarray, num_owned: int, coupling: str, comm=None) -> float:
    """Stored scalar entries of the implicit tangent of the owned points (all ranks, with
    ``comm``): 9 per coupled pair of points. ``coupling`` "pairs": a point and its bonded
    neighbors; "family": every point within two horizons (the neighbors' neighbors), counted
    exactly on up to ``TANGENT_SAMPLE`` evenly spaced points and scaled to all."""
    counts = np.diff(offsets[: num_owned + 1]).astype(np.float64)
    if coupling == "pairs" or num_owned == 0:
        local_sum, local_n = float((counts + 1.0).sum()), float(num_owned)
    else:
        sample = np.unique(np.linspace(0, num_owned - 1, min(num_owned, TANGENT_SAMPLE)).astype(np.int64))
        reach = []
        for i in sample:
            first = neighbors[offsets[i] : offsets[i + 1]]
            ring = [first] + [neighbors[offsets[j] : offsets[j + 1]] for j in first if j < len(offsets) - 1]
            reach.append(np.unique(np.concatenate(ring + [np.array([i], dtype=neighbors.dtype)])).size)
        local_sum, local_n = float(np.mean(reach)) * num_owned, float(num_owned)
    if comm is not None:
        local_sum, local_n = comm.allreduce_sum(local_sum), comm.allreduce_sum(local_n)
    return 9.0 * local_sum if local_n else 0.0


def check_steps(steps: int, points: float, bonds: float, *, file: str | None, path: tuple[str, ...], section: str,
                tangent_entries: float = 0.0, finite_differences: bool = False) -> float:
    """Refuse absurd step counts and run times; warn about runs of hours. Returns the estimate (s)."""
    seconds = estimate_seconds(float(steps), points, bonds, tangent_entries=tangent_entries, finite_differences=finite_differences)
    if steps > MAX_STEPS or seconds > MAX_SECONDS:
        refuse(
            f"{steps:.3g} steps, estimated {human_seconds(seconds)} "
            f"(limits: {MAX_STEPS:.0e} steps, {human_seconds(MAX_SECONDS)})",
            file=file,
            path=path,
            fix="check Final Time, Fixed dt and the number of load steps",
        )
    elif seconds > WARN_SECONDS:
        log.warning("%s: %d steps, estimated wall time %s on one core", section, steps, human_seconds(seconds))
    return seconds
