"""Peridigm's step count over a solver section's interval; the section's keys outside its method
sublist are :class:`peridyn.core.solver_section.SolverSection` (re-exported here)."""
from __future__ import annotations

import math
from collections.abc import Callable

from ..core.errors import InputError
from ..core.solver_section import SolverSection

__all__ = ["SolverSection", "count_steps"]


def count_steps(t0: float, t1: float, dt: float, *, source: str, file: str | None, path: tuple[str, ...],
                hint: Callable[[], str] | None = None) -> int:
    """floor((t1 - t0) / dt), Peridigm's step count; InputError when it cannot be counted or is
    0 (a run that would end "done" without a step). ``source`` says where dt came from;
    ``hint`` gives the model's likely unit slip for that message (collective under MPI: every
    rank reaches the error alike)."""
    steps = (t1 - t0) / dt
    if not math.isfinite(steps):
        raise InputError(f"the time step {dt!r} is too small for the time span to be counted in steps", file=file, path=path,
                         fix="check Fixed dt and Final Time")
    if steps < 1.0:
        slip = hint() if hint is not None else ""
        raise InputError(
            f"the time step {dt:.6g} ({source}) is longer than the solver's interval {t1 - t0:.6g}: not one step would be run"
            if slip else f"the time step {dt:.6g} ({source}) is longer than the solver's interval {t1 - t0:.6g} (Initial Time "
            f"{t0:.6g} to Final Time {t1:.6g}): not one step would be run",
            file=file, path=path,
            fix=(slip if slip else
                 "give a later 'Final Time' or a smaller time step; a step from the estimate may mean moduli in GPa, not Pa"),
        )
    return int(math.floor(steps))
