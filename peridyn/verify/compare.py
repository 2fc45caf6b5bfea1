"""``peridyn verify --compare RESULTS.json``: each point's error against the same point of an
earlier run (same problem, method and resolution), within its problem's tolerance.

A point's error is deterministic physics (its wall time is not compared): an error that moves by
more than ``compare_rtol`` of the earlier value (5 % unless the problem says), a point that
failed now but ran then, or one whose error became undefined, is a move that fails the command."""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from ..core.errors import InputError

#: moves of an error smaller than this (the errors are dimensionless) are round-off, not counted:
#: the exact checks' errors of 1e-9 change with the order of a parallel sum
FLOOR = 1.0e-8


def load(path: str | Path) -> dict[str, Any]:
    """An earlier run's results.json; InputError when it cannot be read as one."""
    p = Path(path)
    try:
        state = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"--compare {str(p)!r}: cannot read it as a results.json: {exc}",
                         fix="give the results.json an earlier 'peridyn verify' wrote") from None
    if not isinstance(state, dict) or not isinstance(state.get("problems"), list):
        raise InputError(f"--compare {str(p)!r}: not a results.json of 'peridyn verify' (no problems list)",
                         fix="give the results.json an earlier 'peridyn verify' wrote")
    return state


def _points(state: dict[str, Any]) -> dict[tuple[str, str, float], dict[str, Any]]:
    return {(p["problem"], p["method"], float(p["resolution"])): p for e in state["problems"] for p in e.get("points", [])}


def compare(old: dict[str, Any], new: dict[str, Any], rtol: dict[str, float]) -> dict[str, Any]:
    """The points of ``new`` that moved from ``old``: ``rtol`` per problem name (default 0.05).
    Returns {"compared": n, "moved": [...], "only before": [...], "only now": [...]}."""
    before, now = _points(old), _points(new)
    moved = []
    compared = 0
    for key, p in now.items():
        q = before.get(key)
        if q is None:
            continue
        compared += 1
        tol = rtol.get(key[0], 0.05)
        a, b = q.get("error"), p.get("error")
        row = {"problem": key[0], "method": key[1], "resolution": key[2], "before": a, "now": b, "tolerance": tol}
        if "failure" in p and "failure" not in q:
            moved.append({**row, "why": f"the point failed now: {p['failure']}"})
        elif a is None or b is None:
            if (a is None) != (b is None):
                moved.append({**row, "why": "an error only in one of the runs"})
        elif not (math.isfinite(a) and math.isfinite(b)):
            if not (a == b):
                moved.append({**row, "why": "a non-finite error"})
        elif abs(b - a) > tol * abs(a) + FLOOR:
            moved.append({**row, "why": f"moved by {(b - a) / abs(a) if a else math.inf:+.3g} of the earlier error (tolerance {tol:g})"})
    return {"compared": compared, "moved": moved, "only before": sorted(map(list, before.keys() - now.keys())),
            "only now": sorted(map(list, now.keys() - before.keys()))}
