"""``peridyn plot RESULT.e``: pictures of a result file with matplotlib (the ``plot`` extra).

* the histories: energies and momenta the run wrote as global outputs, each labelled by what it
  is (Peridigm's ``Global_Linear_Momentum`` is the sum over blocks of each block's momentum
  magnitude, the magnitude of the total only for one block); where the file holds the per-point
  ``Linear_Momentum`` or ``Angular_Momentum``, the components and magnitude of their total too;
  a global vector as its components and magnitude; the damage (share of points with any damage,
  mean damage over points) of every frame that holds a ``Damage`` field;
* frames: the points at their deformed positions (reference coordinates plus ``Displacement``
  when written), coloured by a field (``Damage``, a vector's magnitude, one component),
  projected on a coordinate plane, the nearest points drawn last.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError
from .exodus_reader import component_groups

INSTALL = 'pip install "peridyn[plot]"'
VIEWS = {"xy": (0, 1, 2), "xz": (0, 2, 1), "yz": (1, 2, 0)}


def pyplot():
    """matplotlib.pyplot with the Agg backend (files, no window), or None when matplotlib is not
    installed."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    return plt


def read(path: str | Path) -> dict[str, Any]:
    """The result file as :func:`peridyn.io.exodus_reader.read_results` gives it; InputError for
    a missing or unreadable file or one without frames."""
    from .exodus_reader import read_results

    path = Path(path)
    if not path.is_file():
        raise InputError(f"no such result file: {str(path)!r}", file=path, fix="give the Exodus file a run wrote (NAME.e)")
    try:
        r = read_results(path)
    except InputError:
        raise
    except Exception as exc:  # noqa: BLE001 - any unreadable file is bad input here
        raise InputError(f"cannot read {str(path)!r} as an Exodus result: {type(exc).__name__}: {exc}", file=path,
                         fix="give the Exodus file a run wrote (NAME.e)") from None
    if np.asarray(r["times"]).size == 0:
        raise InputError(f"{path.name} holds no output frame", file=path, fix="let the run write at least one output step")
    return r


def _vectors(table: dict[str, np.ndarray]) -> dict[str, list[str]]:
    """base -> component names of the vectors of ``table`` (tensor components are not vectors:
    ``StressXX``, ``StressXY``, ``StressXZ`` is no vector ``StressX``)."""
    return {base: names for base, (kind, names) in component_groups(list(table)).items() if kind == "vector"}


def field_names(r: dict[str, Any]) -> list[str]:
    """What a frame can be coloured by: nodal and element fields (tensors by their components),
    and each vector (``Velocity`` for VelocityX, Y, Z) as its magnitude."""
    names = list(r["nodal"]) + list(r["element"])
    vectors = [v for table in (r["nodal"], r["element"]) for v in _vectors(table)]
    return vectors + names


def field_values(r: dict[str, Any], name: str, frame: int) -> np.ndarray:
    """(num_points,) values of ``name`` (a field, or a vector's magnitude) at ``frame``."""
    for table in (r["nodal"], r["element"]):
        if name in table:
            return np.asarray(table[name][frame], dtype=float)
        vectors = _vectors(table)
        if name in vectors:
            return np.linalg.norm(np.stack([np.asarray(table[c][frame], float) for c in vectors[name]], axis=1), axis=1)
    raise KeyError(name)


def positions(r: dict[str, Any], frame: int) -> np.ndarray:
    """(num_points, 3) deformed positions when Displacement was written, else reference ones."""
    x = np.asarray(r["coords"], dtype=float)
    if all(f"Displacement{c}" in r["nodal"] for c in "XYZ"):
        return x + np.stack([np.asarray(r["nodal"][f"Displacement{c}"][frame], float) for c in "XYZ"], axis=1)
    return x


#: Peridigm's global momenta: the sum over blocks of |the block's summed vector| (computes/kinematics.py)
BLOCK_MAGNITUDES = {"Global_Linear_Momentum": ("linear momentum", "p", "Linear_Momentum"),
                    "Global_Angular_Momentum": ("angular momentum", "L", "Angular_Momentum")}


def _panel(name: str) -> str:
    if "Energy" in name:
        return "energy"
    if "Angular_Momentum" in name:
        return "angular momentum"
    if "Momentum" in name:
        return "linear momentum"
    return "other global outputs"


def histories(r: dict[str, Any]) -> dict[str, dict[str, np.ndarray]]:
    """Panel title -> {curve label -> (nt,) values}: energies, momenta, damage, each labelled by
    what it is. ``Global_Linear_Momentum`` (and the angular one) is Peridigm's sum over blocks of
    each block's momentum magnitude: labelled so (as |total p| for one block); when the file
    holds the per-point ``Linear_Momentum`` (``Angular_Momentum``) vectors, their total's
    components and magnitude are drawn beside it. A global vector (``NameX``, ``NameY``,
    ``NameZ``) is drawn as its components and its magnitude."""
    panels: dict[str, dict[str, np.ndarray]] = {}
    glob = r["global"]
    groups = component_groups(list(glob))
    grouped = {c for _, names in groups.values() for c in names}
    num_blocks = len(r.get("blocks", ())) or 1
    for name, values in glob.items():
        if name in grouped:
            continue
        label = name
        if name in BLOCK_MAGNITUDES:
            _, sym, _ = BLOCK_MAGNITUDES[name]
            label = (f"{name}: |total {sym}| (one block)" if num_blocks == 1 else
                     f"{name}: sum over the {num_blocks} blocks of |{sym}_block| (not |total {sym}|)")
        panels.setdefault(_panel(name), {})[label] = np.asarray(values, float)
    for base, (kind, names) in groups.items():
        curves = panels.setdefault(_panel(base), {})
        parts = [np.asarray(glob[c], float) for c in names]
        for c, values in zip(names, parts):
            curves[c] = values
        if kind == "vector":
            curves[f"|{base}| (magnitude of the vector)"] = np.linalg.norm(np.stack(parts, axis=1), axis=1)
    for what, sym, field in BLOCK_MAGNITUDES.values():
        for table in (r["nodal"], r["element"]):
            comps = _vectors(table).get(field)
            if comps is None:
                continue
            with np.errstate(invalid="ignore"):
                total = np.stack([np.nansum(np.asarray(table[c], float), axis=1) for c in comps], axis=1)
            curves = panels.setdefault(what, {})
            for k, axis in enumerate("xyz"):
                curves[f"total {sym}_{axis} (sum of {field} over points)"] = total[:, k]
            curves[f"|total {sym}| (magnitude of the sum)"] = np.linalg.norm(total, axis=1)
            break
    damage = r["element"].get("Damage", r["nodal"].get("Damage"))
    if damage is not None:
        d = np.asarray(damage, float)
        with np.errstate(invalid="ignore"):
            panels["damage"] = {"points with damage (share)": np.nanmean(np.where(np.isnan(d), np.nan, d > 0.0), axis=1),
                                "mean damage over points (not volume-weighted)": np.nanmean(d, axis=1)}
    return panels


def history_figure(r: dict[str, Any], png: str | Path, plt) -> bool:
    """One panel per kind of history against time; False when the file has none."""
    panels = histories(r)
    if not panels:
        return False
    t = np.asarray(r["times"], float)
    fig, axes = plt.subplots(len(panels), 1, figsize=(6.4, 2.6 * len(panels)), sharex=True, squeeze=False)
    for ax, (title, curves) in zip(axes[:, 0], panels.items()):
        for label, values in curves.items():
            ax.plot(t, values, ".-", label=label, markersize=3)
        ax.set_ylabel(title)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    axes[-1, 0].set_xlabel("time")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)
    return True


def frame_figure(r: dict[str, Any], frame: int, field: str, view: str, png: str | Path, plt) -> None:
    """The points of ``frame`` coloured by ``field`` seen along the axis ``view`` leaves out."""
    a, b, depth = VIEWS[view]
    y = positions(r, frame)
    c = field_values(r, field, frame)
    order = np.argsort(y[:, depth], kind="stable")  # the nearest (largest depth) drawn last
    span = np.ptp(y[:, (a, b)], axis=0) if len(y) else np.ones(2)
    fig, ax = plt.subplots(figsize=(6.4, max(2.5, min(8.0, 6.4 * (span[1] / span[0] if span[0] > 0 else 1.0)))))
    size = max(0.5, min(30.0, 2.0e4 / max(len(y), 1)))
    finite = np.isfinite(c)
    sc = ax.scatter(y[order, a], y[order, b], c=np.where(finite, c, np.nan)[order], s=size, cmap="viridis", linewidths=0)
    fig.colorbar(sc, ax=ax, label=field)
    ax.set_aspect("equal")
    ax.set_xlabel("xyz"[a])
    ax.set_ylabel("xyz"[b])
    ax.set_title(f"{field} at t = {float(r['times'][frame]):.4g} (frame {frame})", fontsize=9)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def default_view(r: dict[str, Any]) -> str:
    """The coordinate plane of the body's two largest extents."""
    extent = np.ptp(np.asarray(r["coords"], float), axis=0) if len(r["coords"]) else np.ones(3)
    left_out = int(np.argmin(extent))
    return {2: "xy", 1: "xz", 0: "yz"}[left_out]


def plot(path: str | Path, *, frames: list[int] | None = None, field: str | None = None, view: str | None = None,
         prefix: str | Path | None = None) -> list[Path]:
    """Write PREFIX_history.png and PREFIX_frame<K>_<field>.png for each frame (default: the
    last); PREFIX defaults to the result file's name without '.e'. Returns the files written.
    InputError for a bad file, frame, field or view, or without matplotlib."""
    plt = pyplot()
    if plt is None:
        raise InputError("peridyn plot needs matplotlib", file=str(path), fix=INSTALL)
    r = read(path)
    nt = len(r["times"])
    frames = [-1] if not frames else frames
    for k in frames:
        if not -nt <= k < nt:
            raise InputError(f"--frames {k}: the file has frames 0 .. {nt - 1}", file=str(path), path=("--frames",),
                             fix=f"give frames from 0 to {nt - 1}, or -1 for the last")
    names = field_names(r)
    if field is None:
        field = "Damage" if "Damage" in names else "Displacement" if "Displacement" in names else (names[0] if names else None)
    if field is not None and field not in names:
        raise InputError(f"--field {field!r}: the file has no such output", file=str(path), path=("--field",),
                         fix=f"choose one of: {', '.join(names)}")
    if view is not None and view not in VIEWS:
        raise InputError(f"--view {view!r} is not a coordinate plane", path=("--view",), fix="use xy, xz or yz")
    view = view or default_view(r)
    stem = Path(prefix) if prefix is not None else Path(path).with_suffix("")
    written = []
    history = Path(f"{stem}_history.png")
    if history_figure(r, history, plt):
        written.append(history)
    if field is not None:
        for k in frames:
            png = Path(f"{stem}_frame{k % nt}_{field}.png")
            frame_figure(r, k % nt, field, view, png, plt)
            written.append(png)
    return written
