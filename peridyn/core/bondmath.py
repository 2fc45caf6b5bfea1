"""Small bond formulas shared by kernels of different plugins (inlined by numba)."""
from __future__ import annotations

import math

from numba import njit


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
