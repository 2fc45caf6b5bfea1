"""Influence functions omega(zeta, delta) as kernels see them (PERIDIGM_SEMANTICS.md §3).

Kernels call :func:`omega` with an integer kind; a user expression is evaluated once per bond
at set-up (it depends only on the reference bond length and the horizon) and passed to kernels
as a per-bond table, allocated only when the deck uses an expression
(:class:`peridyn.geometry.influence.InfluenceFunction` builds it).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

ONE, PARABOLIC_DECAY, GAUSSIAN, TABLE = 0, 1, 2, 3
NAMED = {"One": ONE, "Parabolic Decay": PARABOLIC_DECAY, "Gaussian": GAUSSIAN}


@njit(cache=True, inline="always")
def omega(kind: int, zeta: float, delta: float, table: np.ndarray, b: int) -> float:
    """omega for bond ``b`` of reference length ``zeta`` (L) and horizon ``delta`` (L)."""
    if kind == ONE:
        return 1.0
    if kind == PARABOLIC_DECAY:
        if zeta > delta:
            return 0.0
        s = zeta / delta
        if s < 0.5:
            return 1.0
        return (-4.0 * s) * s + 4.0 * s
    if kind == GAUSSIAN:
        h2 = ((delta * delta) * 0.4) * 0.4
        return math.exp(-(zeta * zeta) / h2)
    return table[b]
