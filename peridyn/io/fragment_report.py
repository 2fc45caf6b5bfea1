"""``peridyn fragments RESULT.e``: the fragment-mass distribution of a result file written with
the ``Fragment_Id`` and ``Fragment_Mass`` outputs (:mod:`peridyn.computes.fragments`)."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError

NEEDED = ("Fragment_Id", "Fragment_Mass")


def fragment_table(path: str | Path, frame: int = -1) -> dict[str, Any]:
    """The fragments of output frame ``frame`` (default the last) of the Exodus file ``path``:
    time (T), and per fragment, largest first, its number, mass (M), points and, when written,
    centre-of-mass speed (L/T). InputError for a file that cannot be read or lacks the outputs."""
    from .exodus_reader import read_results

    path = Path(path)
    if not path.is_file():
        raise InputError(f"no such result file: {str(path)!r}", file=path, fix="give the Exodus file a run wrote (NAME.e)")
    try:
        r = read_results(path)
    except Exception as exc:  # noqa: BLE001 - any unreadable file is bad input here
        raise InputError(f"cannot read {str(path)!r} as an Exodus result: {type(exc).__name__}: {exc}", file=path,
                         fix="give the Exodus file a run wrote (NAME.e)") from None
    missing = [n for n in NEEDED if n not in r["element"]]
    if missing:
        raise InputError(f"{path.name} has no {' or '.join(missing)} output", file=path,
                         fix="add Fragment_Id: true and Fragment_Mass: true to the deck's Output Variables and run it again")
    times = np.asarray(r["times"])
    if times.size == 0:
        raise InputError(f"{path.name} holds no output frame", file=path, fix="let the run write at least one output step")
    if not -times.size <= frame < times.size:
        raise InputError(f"--frame {frame}: the file has frames 0 .. {times.size - 1}", file=path, path=("--frame",),
                         fix=f"give a frame from 0 to {times.size - 1}, or -1 for the last")
    ids = np.asarray(r["element"]["Fragment_Id"][frame])
    mass = np.asarray(r["element"]["Fragment_Mass"][frame])
    keep = np.isfinite(ids)
    ids, mass = ids[keep].astype(np.int64), mass[keep]
    numbers, first, points = np.unique(ids, return_index=True, return_counts=True)
    speed = None
    if all(f"Fragment_Velocity{c}" in r["nodal"] for c in "XYZ"):
        v = np.stack([np.asarray(r["nodal"][f"Fragment_Velocity{c}"][frame])[keep] for c in "XYZ"], axis=1)
        speed = np.linalg.norm(v[first], axis=1)
    order = np.argsort(-mass[first], kind="stable")
    return {"time": float(times[frame]), "frame": int(frame % times.size), "number": numbers[order], "mass": mass[first][order],
            "points": points[order], "speed": None if speed is None else speed[order]}


def format_table(t: dict[str, Any], top: int = 10) -> str:
    """The distribution as text: count, total mass, the ``top`` largest fragments, and how many
    fragments fall in each decade of mass fraction."""
    total = float(t["mass"].sum())
    n = len(t["mass"])
    lines = [f"frame {t['frame']} (t = {t['time']:.6g}): {n} fragment(s), total mass {total:.6g}"]
    head = f"  {'fragment':>8s} {'mass':>12s} {'fraction':>9s} {'points':>7s}" + (f" {'speed':>11s}" if t["speed"] is not None else "")
    lines.append(head)
    for k in range(min(top, n)):
        row = f"  {int(t['number'][k]):8d} {t['mass'][k]:12.5g} {t['mass'][k] / total:9.4f} {int(t['points'][k]):7d}"
        if t["speed"] is not None:
            row += f" {t['speed'][k]:11.5g}"
        lines.append(row)
    if n > top:
        lines.append(f"  ... {n - top} more")
    frac = t["mass"] / total if total > 0 else np.ones(n)
    lines.append("  mass fraction   fragments")
    decades = int(math.ceil(-math.log10(float(frac.min())))) if n and frac.min() > 0 else 1
    for k in range(max(decades, 1)):
        hi, lo = 10.0 ** -k, 10.0 ** -(k + 1)
        lines.append(f"  ({lo:.0e}, {hi:.0e}]  {int(((frac <= hi) & (frac > lo)).sum()):9d}")
    return "\n".join(lines)


def plot_distribution(t: dict[str, Any], png: str | Path) -> bool:
    """The cumulative distribution: the number of fragments of at least a mass, against the mass
    (log-log); False without matplotlib."""
    from .plot import pyplot

    plt = pyplot()
    if plt is None:
        return False
    m = np.sort(t["mass"])[::-1]
    fig, ax = plt.subplots(figsize=(5.5, 4.0))
    ax.loglog(m, np.arange(1, len(m) + 1), "o-", markersize=3)
    ax.set_xlabel("fragment mass")
    ax.set_ylabel("fragments of at least this mass")
    ax.set_title(f"{len(m)} fragments at t = {t['time']:.4g}", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)
    return True
