"""The keys of a solver section outside its method sublist, and Peridigm's step count over a
section's interval: what every solver (explicit or implicit) reads of its section."""
from __future__ import annotations

import math
from collections.abc import Callable

from pydantic import Field, field_validator, model_validator

from ..core.errors import InputError
from ..core.params import ModelParams


class SolverSection(ModelParams):
    """Keys of a solver section outside its method sublist."""

    verbose: bool = Field(False, alias="Verbose", description="accepted; use --verbose for more output")
    initial_time: float = Field(0.0, alias="Initial Time", description="start time of this solver (T)")
    final_time: float = Field(1.0, alias="Final Time", description="end time of this solver (T)")
    device: str | None = Field(None, alias="Device", description='"CPU" or "GPU": where an explicit solver runs (the command line\'s --device wins; GPU needs peridyn[gpu])')
    disable_heuristics: bool = Field(False, alias="Disable Heuristics", description="implicit solvers: no predictor, damping or line search heuristics")
    initialize_predictor: bool = Field(
        False, alias="Initialize Predictor From Previous Solver", description="implicit solvers: start from the previous solver's velocity"
    )

    @field_validator("device")
    @classmethod
    def _device_name(cls, v):
        if v is not None and v.lower() not in ("cpu", "gpu"):
            raise ValueError(f"Device {v!r} is not a device: give \"CPU\" or \"GPU\"")
        return v

    @model_validator(mode="after")
    def _time_order(self):
        if (self.given("final_time") or self.given("initial_time")) and not self.final_time > self.initial_time:
            raise ValueError(
                f"'Final Time' ({self.final_time:g}) must be later than 'Initial Time' ({self.initial_time:g}); "
                "nothing would be run" + ("" if self.given("final_time") else " ('Final Time' defaults to 1.0, as in Peridigm)")
            )
        return self


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
