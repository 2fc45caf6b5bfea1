"""``Text File`` discretization: one point per line, ``x y z blockId volume``.

Follows Peridigm's ``TextFileDiscretization::getDecomp`` (PERIDIGM_SEMANTICS.md §2.4):

* each line is trimmed; lines that are empty or start with ``#``, ``/`` or ``*`` are skipped;
* every other line holds exactly five numbers ``x y z blockId volume``; the block id is
  truncated to an integer (``1.9`` -> 1);
* the 0-based global id of a point is its data-line index, and the point order is file order;
* block ``<id>`` is named ``block_<id>``; the file defines no node sets (use node-set files);
* neighbors: a Euclidean search within each point's horizon, inclusive (§2.5).

Stricter than Peridigm: a token that is not a number is an error (Peridigm stops reading the
line there), and a volume that is not positive and finite is an error.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
from pydantic import Field

from ..core.discretization import Discretization
from ..core.discretization import DiscretizationReader
from ..core.params import ModelParams
from ..core.errors import InputError, missing_file
from .nodesets import find_input_file

__all__ = ["TextFile", "TextFileParams", "read_text_mesh", "min_element_radius"]

_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\Z")
_COMMENT_STARTS = ("#", "/", "*")


def min_element_radius(volume: np.ndarray) -> float:
    """Peridigm's ``minElementRadius``: min over points of pow(0.238732414637843 V, 1/3).

    ``volume``: (n,) cell volumes (L^3). Returns a length (L); 1e50 when there are no points.
    """
    if volume.size == 0:
        return 1.0e50
    # pow is monotonic, so the radius of the smallest volume is the smallest radius; math.pow is
    # the C library's pow, as in Peridigm (numpy's SIMD pow may differ in the last bit).
    radius = math.pow(0.238732414637843 * float(np.min(volume)), 0.33333333333333333)
    return min(1.0e50, radius)


class TextFileParams(ModelParams):
    """``Discretization`` section of a ``Text File`` mesh."""

    input_mesh_file: str = Field(
        alias="Input Mesh File",
        description="Text file with one point per line: x y z blockId volume (lengths L, volume L^3); "
        "relative to the deck's folder.",
    )


def read_text_mesh(path: Path | str) -> Discretization:
    """Read a Peridigm text mesh.

    Returns a :class:`Discretization` with x (n, 3) and volume (n,) as written in the file,
    block_id (n,), gid = 0..n-1, blocks ``block_<id>`` and no node sets.

    Raises
    ------
    InputError: the file is missing, a data line does not hold exactly five numbers (the message
        gives the line number), a volume is not positive, or the file holds no points.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except (FileNotFoundError, IsADirectoryError):
        raise InputError(
            missing_file(path, "text mesh file"),
            path=("Discretization", "Input Mesh File"),
            fix="check the file name; relative names are relative to the deck's folder",
        ) from None
    except OSError as exc:
        raise InputError(f"cannot read text mesh file: {exc.strerror or exc}", file=str(path)) from None

    rows: list[tuple[float, float, float, float, float]] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith(_COMMENT_STARTS):
            continue
        tokens = line.split()
        bad = [t for t in tokens if _NUMBER.match(t) is None]
        if bad:
            raise InputError(
                f"{bad[0]!r} is not a number",
                file=str(path),
                line=number,
                fix="each data line must be 'x y z blockId volume'; comment lines start with #, / or *",
            )
        if len(tokens) != 5:
            raise InputError(
                f"expected 5 numbers (x y z blockId volume), found {len(tokens)}",
                file=str(path),
                line=number,
                fix="each data line must be 'x y z blockId volume'; comment lines start with #, / or *",
            )
        values = tuple(float(t) for t in tokens)
        volume = values[4]
        if not (math.isfinite(volume) and volume > 0.0):
            raise InputError(f"volume {tokens[4]} is not positive", file=str(path), line=number)
        if not all(math.isfinite(v) for v in values[:4]):
            raise InputError("coordinates and block id must be finite numbers", file=str(path), line=number)
        rows.append(values)  # type: ignore[arg-type]

    if not rows:
        raise InputError(
            "text mesh file holds no points",
            file=str(path),
            fix="add lines 'x y z blockId volume'",
        )
    data = np.array(rows, dtype=np.float64)
    x = np.ascontiguousarray(data[:, :3])
    block_id = np.trunc(data[:, 3]).astype(np.int64)  # C++ static_cast<int>: toward zero
    volume = np.ascontiguousarray(data[:, 4])
    n = data.shape[0]
    block_names = {int(b): f"block_{int(b)}" for b in np.unique(block_id)}
    return Discretization(
        x=x,
        volume=volume,
        block_id=block_id,
        gid=np.arange(n, dtype=np.int64),
        block_names=block_names,
        node_sets={},
        min_element_radius=min_element_radius(volume),
        neighbor_rule=None,
        source=str(path),
    )


class TextFile(DiscretizationReader):
    """Points read from a text file (``Type: Text File``)."""

    name = "Text File"
    Params = TextFileParams
    supports_bond_filters = True

    def read(self) -> Discretization:
        params: TextFileParams = self.params  # type: ignore[assignment]
        return read_text_mesh(find_input_file(params.input_mesh_file, self.deck_dir))
