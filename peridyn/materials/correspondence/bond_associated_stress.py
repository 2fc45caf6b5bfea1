"""The bond-associated correspondence model's stress updates (PERIDIGM_CORRESPONDENCE.md §5.2
elastic, §5.3 perfectly plastic, §5.7 isotropic hardening by power law or saturation), as tuple
functions the force kernels inline, at the node and at the bond alike."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .stress import (
    SQRT_6,
    _deviator,
    _dot9,
    _eqps_update,
    _floor,
    _return_to,
    _strain_increment,
    _trial_stress,
)
from .tensor import load9

ELASTIC, PERFECT, POWER_LAW, SATURATION = 0, 1, 2, 3
MAX_NEWTON = 100  #: more iterations in the radial return: Peridigm aborts the run


@njit(cache=True, inline="always", error_model="numpy")
def _hardened(model, e, p0, p1, p2, p3):
    """σ_h(e): σ_y pow(1.0 + e/ε_c, n), or (σ0 + (σ∞ - σ0)(1.0 - exp((-β) e))) + h e."""
    if model == POWER_LAW:
        return p0 * math.pow(1.0 + e / p1, p2)
    return (p0 + (p1 - p0) * (1.0 - math.exp((-p2) * e))) + p3 * e


@njit(cache=True, inline="always", error_model="numpy")
def _slope(model, e, p0, p1, p2, p3):
    """H(e): ((σ_y n)/ε_c) pow(1.0 + e/ε_c, n - 1.0), or ((β (σ∞ - σ0)) exp((-β) e)) + h."""
    if model == POWER_LAW:
        return ((p0 * p2) / p1) * math.pow(1.0 + e / p1, p2 - 1.0)
    return ((p2 * (p1 - p0)) * math.exp((-p2) * e)) + p3


@njit(cache=True, inline="always", error_model="numpy")
def _radial_return(model, sN, di, eN, dt, K, G, p0, p1, p2, p3):
    """§5.7 (``radialReturnPowerlaw``/``radialReturnSaturationExponential``):
    (σ_NP1, vm, eqps_NP1, iterations); iterations = MAX_NEWTON + 1 when Newton did not converge
    (or its residual is NaN)."""
    de, dth = _strain_increment(di, dt)
    sig = _trial_stress(sN, de, dth, K, G)
    s, _ = _deviator(sig)
    t = _dot9(s, s)
    mag = _floor(math.sqrt(t))
    vm_tr = math.sqrt((3.0 / 2.0) * t)
    f = vm_tr - _hardened(model, eN, p0, p1, p2, p3)
    if f < 0.0:
        return sig, vm_tr, eN, 0
    n = (s[0] / mag, s[1] / mag, s[2] / mag, s[3] / mag, s[4] / mag, s[5] / mag, s[6] / mag, s[7] / mag, s[8] / mag)
    tol = 1.0e-16 * K
    gam = 0.0
    e = eN
    its = 0
    while not abs(f) <= tol:  # a NaN residual iterates to the cap as well: reported, never taken as converged
        its += 1
        if its > MAX_NEWTON:
            return sig, vm_tr - (3.0 * G) * gam, e, its
        dl = f / (3.0 * G + _slope(model, e, p0, p1, p2, p3))
        gam += dl
        e += dl
        c = (SQRT_6 * G) * dl
        sig = (sig[0] - c * n[0], sig[1] - c * n[1], sig[2] - c * n[2], sig[3] - c * n[3], sig[4] - c * n[4],
               sig[5] - c * n[5], sig[6] - c * n[6], sig[7] - c * n[7], sig[8] - c * n[8])
        f = (vm_tr - (3.0 * G) * gam) - _hardened(model, e, p0, p1, p2, p3)
    return sig, vm_tr - (3.0 * G) * gam, e, its


@njit(cache=True, inline="always", error_model="numpy")
def _stress_update(model, sN, di, eN, dt, K, G, p0, p1, p2, p3):
    """(σ̂_NP1, von Mises stress, eqps_NP1, stress triaxiality, failed) of one point or bond.
    ELASTIC: §5.2 plus vm of §5.1 (triaxiality 0.0, eqps_N passed through); PERFECT: §5.3 with
    eqps by (5.3a); POWER_LAW/SATURATION: §5.7. Triaxiality ((σ0 + σ4) + σ8)/(3.0 max(1e-20, vm))."""
    if model == ELASTIC:
        de, dth = _strain_increment(di, dt)
        sig = _trial_stress(sN, de, dth, K, G)
        s, _ = _deviator(sig)
        return sig, math.sqrt((3.0 / 2.0) * _dot9(s, s)), eN, 0.0, False
    if model == PERFECT:
        de, dth = _strain_increment(di, dt)
        sig = _trial_stress(sN, de, dth, K, G)
        s, p = _deviator(sig)
        t = _dot9(s, s)
        vm = math.sqrt((3.0 / 2.0) * t)
        e = eN
        if vm > p0:
            mag_tr = _floor(math.sqrt(t))
            sig, r, vm = _return_to(s, p, mag_tr, p0)
            e = _eqps_update(de, r, mag_tr, sN, G, eN)
        return sig, vm, e, ((sig[0] + sig[4]) + sig[8]) / (3.0 * _floor(vm)), False
    sig, vm, e, its = _radial_return(model, sN, di, eN, dt, K, G, p0, p1, p2, p3)
    return sig, vm, e, ((sig[0] + sig[4]) + sig[8]) / (3.0 * _floor(vm)), its > MAX_NEWTON


@njit(cache=True, error_model="numpy")
def stress_update(model, sN, d, eqps_N, dt, K, G, p0, p1, p2, p3):
    """:func:`_stress_update` on arrays, for tests: sN, d (9,) -> (σ̂_NP1 (9,), vm, eqps, triax,
    Newton iterations (0 unless §5.7 went plastic))."""
    s9 = load9(sN.reshape(1, 9), 0)
    d9 = load9(d.reshape(1, 9), 0)
    out = np.zeros(9)
    its = 0
    if model == POWER_LAW or model == SATURATION:
        sig, vm, e, its = _radial_return(model, s9, d9, eqps_N, dt, K, G, p0, p1, p2, p3)
        tri = ((sig[0] + sig[4]) + sig[8]) / (3.0 * _floor(vm))
    else:
        sig, vm, e, tri, _ = _stress_update(model, s9, d9, eqps_N, dt, K, G, p0, p1, p2, p3)
    for k in range(9):
        out[k] = sig[k]
    return out, vm, e, tri, its
