"""``peridyn.read``: a result file (Exodus ``.e``, history ``.h``) read back as numpy arrays."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError

_COMPONENTS = ("X", "Y", "Z")


class Results:
    """The frames of one output file, fields in mesh order (the file's node order, that of
    ``Model`` fields).

    ``times`` (m,) output times (T); ``ids`` (n,) 1-based global ids; ``x`` (n, 3) reference
    positions; ``field(name, frame)`` a point field at one frame ((n,) or (n, 3): a vector
    written as ``NameX``, ``NameY``, ``NameZ`` comes back as one (n, 3) array);
    ``results[name]`` all frames ((m, n) or (m, n, 3)); ``globals`` name -> (m,) global
    variables; ``node_sets`` name -> 0-based indices; ``raw`` what
    :func:`peridyn.io.exodus_reader.read_results` returns.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        from ..io.exodus_reader import read_results

        self.path = Path(path)
        if not self.path.is_file():
            raise InputError("the result file does not exist", file=str(self.path),
                             fix="give the .e (or history .h) file a run wrote; a run stopped by an error leaves NAME.partial.e")
        self.raw: dict[str, Any] = read_results(self.path)
        raw = self.raw
        self.times: np.ndarray = raw["times"]
        self.ids: np.ndarray = raw["node_num_map"]
        self.x: np.ndarray = raw["coords"]
        self.globals: dict[str, np.ndarray] = dict(raw["global"])
        self.node_sets: dict[str, np.ndarray] = dict(raw["node_sets"])
        self._fields: dict[str, np.ndarray] = {}
        scalars = {**raw["element"], **raw["nodal"]}
        taken: set[str] = set()
        for name in scalars:
            base = name[:-1]
            if name[-1:] == "X" and all(base + c in scalars for c in _COMPONENTS):
                self._fields[base] = np.stack([scalars[base + c] for c in _COMPONENTS], axis=-1)
                taken.update(base + c for c in _COMPONENTS)
        for name, values in scalars.items():
            if name not in taken:
                self._fields[name] = values

    @property
    def fields(self) -> list[str]:
        """Names of the point fields in the file (vectors under their base name)."""
        return sorted(self._fields)

    @property
    def num_frames(self) -> int:
        return int(self.times.size)

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self._fields[name]
        except KeyError:
            if name in self.globals:
                return self.globals[name]
            raise KeyError(f"no field {name!r} in {self.path.name}; fields: {', '.join(self.fields)}; "
                           f"global variables: {', '.join(sorted(self.globals)) or 'none'}") from None

    def field(self, name: str, frame: int = -1) -> np.ndarray:
        """A point field at output frame ``frame`` (default: the last), mesh order."""
        return self[name][frame]

    def frame_at(self, t: float) -> int:
        """The index of the frame whose time is closest to ``t``."""
        if not self.num_frames:
            raise IndexError(f"{self.path.name} holds no frame")
        return int(np.argmin(np.abs(self.times - t)))

    def __repr__(self) -> str:
        return f"Results({str(self.path)!r}: {self.num_frames} frames, {self.x.shape[0]} points, fields {self.fields}, globals {sorted(self.globals)})"


def read(path: str | os.PathLike) -> Results:
    """Read a result file a run wrote (``peridyn.read("quickstart.e")``)."""
    return Results(path)
