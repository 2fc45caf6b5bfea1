"""The ``Restart`` section: when a run writes checkpoints, and where (docs/restart.md).

Peridigm's decks carry ``Restart: {Restart: true}``; Peridigm reads only the section's presence
(``isParameter("Restart")``) and then writes its state at the end of every solver section. The
same section here does the same; peridyn's own keys add checkpoints every N steps, the folder and
how many checkpoints are kept.
"""
from __future__ import annotations

from pydantic import Field, field_validator

from ..core.params import ModelParams

#: the top-level section name
SECTION = "Restart"


class RestartParams(ModelParams):
    restart: bool = Field(True, alias="Restart",
                          description="Peridigm's key: the section's presence turns checkpoints on, whatever this value (as Peridigm reads it)")
    restart_frequency: int = Field(0, alias="Restart Frequency", ge=0, le=2**31 - 1,
                                   description="explicit (Verlet) sections also write a checkpoint every this many steps (0: only at the "
                                               "end of each solver section and on SIGTERM/SIGINT)")
    folder: str = Field("restart", alias="Folder", min_length=1,
                        description="folder of the checkpoints, relative to the output folder (--output-dir)")
    keep: int = Field(2, alias="Keep", ge=1, le=10_000, description="how many of this deck's latest checkpoints are kept (older ones are removed)")

    @field_validator("folder")
    @classmethod
    def _plain_folder(cls, v: str) -> str:
        if v.strip() != v or "\x00" in v:
            raise ValueError(f"Folder {v!r} has leading or trailing spaces or a NUL character")
        return v
