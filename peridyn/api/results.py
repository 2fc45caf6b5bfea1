"""``peridyn.read``: a result file (Exodus ``.e``, history ``.h``) read back as numpy arrays."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError



class Results:
    """The frames of one output file, fields in mesh order (the file's node order, that of
    ``Model`` fields).

    ``times`` (m,) output times (T); ``ids`` (n,) 1-based global ids; ``x`` (n, 3) reference
    positions; ``field(name, frame)`` a point field at one frame: (n,) for a scalar, (n, 3) for a
    vector written as ``NameX``, ``NameY``, ``NameZ``, (n, 3, 3) for a tensor written as
    ``NameXX``, ``NameXY``, ... ``NameZZ`` (or a symmetric one's six components);
    ``results[name]`` all frames ((m, n), (m, n, 3) or (m, n, 3, 3)), a global variable
    ((m,), (m, 3), (m, 3, 3)), or one component by its own name (``"Cauchy_StressXY"``:
    (m, n)); ``globals`` name -> global variable (the components and the combined arrays);
    ``node_sets`` name -> 0-based indices; ``raw`` what
    :func:`peridyn.io.exodus_reader.read_results` returns.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        from ..io.exodus_reader import combine_components, component_groups, read_results

        if not isinstance(path, (str, os.PathLike)):
            from .checks import ArgumentTypeError

            raise ArgumentTypeError(f"path must be a file name (str or os.PathLike), not {type(path).__name__} {path!r}",
                                    path=("peridyn.read", "path"), fix="give the .e (or history .h) file a run wrote")
        self.path = Path(path)
        if not self.path.is_file():
            raise InputError("the result file does not exist", file=str(self.path),
                             fix="give the .e (or history .h) file a run wrote; a run stopped by an error leaves NAME.partial.e")
        self.raw: dict[str, Any] = read_results(self.path)
        raw = self.raw
        self.times: np.ndarray = raw["times"]
        self.ids: np.ndarray = raw["node_num_map"]
        self.x: np.ndarray = raw["coords"]
        self.node_sets: dict[str, np.ndarray] = dict(raw["node_sets"])
        self.globals: dict[str, np.ndarray] = dict(raw["global"])
        for base, (kind, names) in component_groups(list(raw["global"])).items():
            self.globals.setdefault(base, combine_components(raw["global"], kind, names))
        self._fields: dict[str, np.ndarray] = {}
        self._components: dict[str, np.ndarray] = {}
        for table in (raw["element"], raw["nodal"]):  # a nodal variable wins over an element one of its name
            taken: set[str] = set()
            for base, (kind, names) in component_groups(list(table)).items():
                self._fields[base] = combine_components(table, kind, names)
                taken.update(names)
            for name, values in table.items():
                if name in taken:
                    self._components[name] = values
                else:
                    self._fields[name] = values

    @property
    def fields(self) -> list[str]:
        """Names of the point fields in the file (vectors and tensors under their base name)."""
        return sorted(self._fields)

    @property
    def num_frames(self) -> int:
        return int(self.times.size)

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self._fields[name]
        except KeyError:
            if name in self._components:
                return self._components[name]
            if name in self.globals:
                return self.globals[name]
            raise KeyError(f"no field {name!r} in {self.path.name}; fields: {', '.join(self.fields)}; "
                           f"global variables: {', '.join(sorted(self.globals)) or 'none'}") from None

    def field(self, name: str, frame: int = -1) -> np.ndarray:
        """A point field at output frame ``frame`` (default: the last; -m..m-1), mesh order."""
        from .checks import ArgumentError, whole_number

        values = self[name]
        k = whole_number("Results.field", "frame", frame, -self.num_frames)
        if k >= self.num_frames:
            raise ArgumentError(f"frame {k}: {self.path.name} holds frames 0..{self.num_frames - 1}", path=("Results.field", "frame"),
                                fix=f"give 0..{self.num_frames - 1}, or -1 for the last")
        return values[k]

    def frame_at(self, t: float) -> int:
        """The index of the frame whose time is closest to ``t``."""
        from .checks import ArgumentError, finite_number

        t = finite_number("Results.frame_at", "t", t)
        if not self.num_frames:
            raise ArgumentError(f"{self.path.name} holds no frame", path=("Results.frame_at",), fix="read a file the run wrote frames to")
        return int(np.argmin(np.abs(self.times - t)))

    def __repr__(self) -> str:
        return f"Results({str(self.path)!r}: {self.num_frames} frames, {self.x.shape[0]} points, fields {self.fields}, globals {sorted(self.globals)})"


def read(path: str | os.PathLike) -> Results:
    """Read a result file a run wrote (``peridyn.read("quickstart.e")``)."""
    return Results(path)
