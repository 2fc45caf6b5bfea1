"""The keys of a solver section outside its method sublist: what every solver (explicit or
implicit) and the engine read of a section, whatever its method."""
from __future__ import annotations

from pydantic import Field, field_validator, model_validator

from .params import ModelParams


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
