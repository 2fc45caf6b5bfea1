"""Small bond formulas shared by kernels of different plugins (inlined by numba)."""
from __future__ import annotations

import math

from numba import njit, types, uint64
from numba.extending import overload


@njit(cache=True, inline="always")
def stretch_exceeds(L2: float, L0: float, s_c: float) -> bool:
    """Whether (|eta| - |xi|)/|xi| > s_c, Peridigm's critical-stretch test, with |eta|^2 = L2 and
    |xi| = L0. Bonds far from the threshold are decided from squared lengths (a relative
    margin of 1e-10, far above round-off); the rest exactly as Peridigm computes it."""
    if s_c > -1.0:
        limit = L0 * (1.0 + s_c)
        limit2 = limit * limit
        if L2 < limit2 * (1.0 - 1e-10):
            return False
        if L2 > limit2 * (1.0 + 1e-10):
            return True
    L = math.sqrt(L2)
    return (L - L0) / L0 > s_c


def damage_sum(d, lo, hi):
    """sum_b d[b] for b in [lo, hi), in bond order (float). Integer bond damage (whole or broken
    bonds, uint8) is counted in an integer, which numba vectorizes (over an unsigned range: a
    signed index's wraparound check stops it; cube40's rows 3.2 -> 0.6 ms); the same value,
    exactly."""
    total = 0.0
    for b in range(lo, hi):
        total += d[b]
    return total


@overload(damage_sum, jit_options={"cache": True})
def _damage_sum(d, lo, hi):
    if isinstance(d.dtype, types.Integer):
        def count(d, lo, hi):
            n = 0
            for b in range(uint64(lo), uint64(hi)):
                n += d[b]
            return float(n)

        return count

    def add(d, lo, hi):
        total = 0.0
        for b in range(uint64(lo), uint64(hi)):
            total += d[b]
        return total

    return add
