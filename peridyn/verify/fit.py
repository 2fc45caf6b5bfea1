"""Convergence rates fitted to measured points."""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


def fit_rate(sizes: Sequence[float], errors: Sequence[float]) -> float:
    """The least-squares slope p of log(error) = p log(size) + b (dimensionless): the order of
    convergence when ``sizes`` are step sizes (h, dt; any unit, only ratios matter) and
    ``errors`` the errors they give. NaN with fewer than two usable points (a size or an error
    that is not positive and finite is left out: an error of exactly 0 has no logarithm)."""
    pairs = [(float(s), float(e)) for s, e in zip(sizes, errors) if _positive(s) and _positive(e)]
    if len({s for s, _ in pairs}) < 2:
        return math.nan
    s, e = np.log(np.array(pairs)).T
    return float(np.polyfit(s, e, 1)[0])


def _positive(value: float) -> bool:
    return isinstance(value, (int, float)) and math.isfinite(value) and value > 0.0
