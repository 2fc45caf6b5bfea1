"""Numerical core of Peridigm's bond-associated correspondence family
(PERIDIGM_CORRESPONDENCE.md §5.2, §5.3, §5.7, §8.2, §9), one point per ``prange`` iteration,
gather only (a point writes its own rows and its own bonds, never a neighbour's).

Shapes and units of the kernel arguments:

* ``offsets`` (n+1,) int64, ``neighbors`` (nb,) int32: the CSR bond lists (list order);
* ``x``, ``y``, ``u``, ``v`` (n, 3): reference positions, current (NP1) positions, NP1
  displacements (L) and NP1 velocities (L/T); ``volume`` (n,) (L^3); ``horizon`` (n,) the
  Horizon field δ_i (L); ``omega_kind``/``omega_table`` as in :func:`peridyn.core.influence.omega`;
* per bond: ``influence`` (nb,) the Influence_State ω_ij = ω(|ξ|, δ_i)(1 - d_ij) (-),
  ``phi`` (nb, 3) the Lagrangian gradient weights φ_ij (L^-3), bond tensors (nb, 9) flat
  row-major (left stretch V_b, rotation R_b, unrotated Cauchy stress σ̂_b in M/(L T^2)),
  ``beqps`` (nb,) the bond equivalent plastic strain, ``P`` (nb, 9) scratch for the bond first
  Piola-Kirchhoff stress, ``T`` (nb, 3) the vector force state (force per volume squared);
* per point: ``m`` (n,) Weighted_Volume m_i = Σ ω_ij V_j (L^3, fixed at initialize); the node
  deformation gradient F and its rate Ḟ as rows (Deformation_Gradient_X/Y/Z and
  Deformation_Gradient_Dot_X/Y/Z, (n, 3) each, Peridigm's storage); node tensors (n, 9).

Constitutive model codes: ELASTIC (§5.2 with the von Mises stress), PERFECT (§5.3 J2 perfectly
plastic, parameter p0 = σ_y), POWER_LAW and SATURATION (§5.7 Newton radial return; p0 = σ_y,
p1 = ε_c, p2 = n, or p0 = σ0, p1 = σ∞, p2 = β, p3 = h). Every expression keeps the spec's
operation order (left-to-right sums, no FMA).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ...core.influence import omega
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
from .tensor import (
    IDENTITY,
    ZERO,
    flanagan_taylor,
    inv3,
    load9,
    matmul,
    matmul_nt,
    matmul_nt_scaled,
    matmul_tn,
    store9,
)

ELASTIC, PERFECT, POWER_LAW, SATURATION = 0, 1, 2, 3
MAX_NEWTON = 100  #: more iterations in the radial return: Peridigm aborts the run
#: status codes of :func:`force_kernel`
SINGULAR_NODE_F, SINGULAR_BOND_F, NO_CONVERGENCE = 1, 2, 3


# ------------------------------------------------------------------------------------------------
# §8.2 gradient weights with the pseudo-inverse (order 1), §9.1 weighted volume
# ------------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def pseudo_inverse(M, tau):
    """Peridigm's ``invertAndCond``: with the SVD M = U diag(w) Vᵀ, M⁺_rc = Σ_k ((V_rk·1.0)/w_k)·U_ck
    over the k with w_k > τ (ascending k, from 0.0); directions with w_k <= τ are dropped, so it
    never fails (a zero or non-finite M gives M⁺ = 0). M: (q, q) float64."""
    q = M.shape[0]
    out = np.zeros((q, q))
    if not np.all(np.isfinite(M)):
        return out
    u, w, vh = np.linalg.svd(M)
    for r in range(q):
        for c in range(q):
            acc = 0.0
            for k in range(q):
                if w[k] > tau:
                    acc += ((vh[k, r] * 1.0) / w[k]) * u[c, k]
            out[r, c] = acc
    return out


@njit(cache=True, error_model="numpy")
def gradient_weights_point(i, offsets, neighbors, x, volume, horizon, omega_kind, omega_table, bond_damage, influence, phi):
    """§8.2 with b = ξ (order 1, Q = ξ/δ) for point i: writes ω_ij = ω(|ξ|, δ_i)(1.0 - d_ij) into
    ``influence`` and φ_ij into ``phi`` for i's bonds. ``bond_damage`` (nb,) NP1, empty for none.
    M_rc += ((ω V_j) Q_r) Q_c; τ = ((1.0e-6 δ) δ) δ; φ_r = Σ_c (((1.0 ω) M⁺_rc) Q_c)/δ."""
    delta = horizon[i]
    damaged = bond_damage.shape[0] > 0
    M = np.zeros((3, 3))
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        X0 = x[j, 0] - x[i, 0]
        X1 = x[j, 1] - x[i, 1]
        X2 = x[j, 2] - x[i, 2]
        Q0 = X0 / delta
        Q1 = X1 / delta
        Q2 = X2 / delta
        w = omega(omega_kind, math.sqrt(X0 * X0 + X1 * X1 + X2 * X2), delta, omega_table, b)
        w = w * (1.0 - bond_damage[b]) if damaged else w * 1.0
        influence[b] = w
        t = w * volume[j]
        M[0, 0] += (t * Q0) * Q0
        M[0, 1] += (t * Q0) * Q1
        M[0, 2] += (t * Q0) * Q2
        M[1, 0] += (t * Q1) * Q0
        M[1, 1] += (t * Q1) * Q1
        M[1, 2] += (t * Q1) * Q2
        M[2, 0] += (t * Q2) * Q0
        M[2, 1] += (t * Q2) * Q1
        M[2, 2] += (t * Q2) * Q2
    Mi = pseudo_inverse(M, ((1.0e-6 * delta) * delta) * delta)
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        Q0 = (x[j, 0] - x[i, 0]) / delta
        Q1 = (x[j, 1] - x[i, 1]) / delta
        Q2 = (x[j, 2] - x[i, 2]) / delta
        t = 1.0 * influence[b]
        for r in range(3):
            phi[b, r] = (((0.0 + ((t * Mi[r, 0]) * Q0) / delta) + ((t * Mi[r, 1]) * Q1) / delta) + ((t * Mi[r, 2]) * Q2) / delta)


@njit(cache=True, parallel=True, error_model="numpy")
def initialize_kernel(start, stop, offsets, neighbors, x, volume, horizon, omega_kind, omega_table, bond_damage, influence, phi, m):
    """§9.1 steps 1-3 for the points [start, stop): ω_ij and φ_ij (§8.2), then the weighted volume
    m_i = Σ_j ω_ij V_j (sequential from 0.0), which the family never updates."""
    for i in prange(start, stop):
        gradient_weights_point(i, offsets, neighbors, x, volume, horizon, omega_kind, omega_table, bond_damage, influence, phi)
        acc = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            acc += influence[b] * volume[neighbors[b]]
        m[i] = acc


@njit(cache=True, error_model="numpy")
def deformation_gradient_point(i, offsets, neighbors, volume, phi, u, v, FX, FY, FZ, FdX, FdY, FdZ):
    """§9.2 step 2: F = I + Σ_j (Δu ⊗ φ) V_j and Ḟ = Σ_j (Δv ⊗ φ) V_j, entry by entry
    F[a][c] += (Δu_a φ_c) V_j over all of i's bonds (no ω test), stored as rows."""
    F0 = F4 = F8 = 1.0
    F1 = F2 = F3 = F5 = F6 = F7 = 0.0
    D0 = D1 = D2 = D3 = D4 = D5 = D6 = D7 = D8 = 0.0
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        Vj = volume[j]
        h0 = phi[b, 0]
        h1 = phi[b, 1]
        h2 = phi[b, 2]
        u0 = u[j, 0] - u[i, 0]
        u1 = u[j, 1] - u[i, 1]
        u2 = u[j, 2] - u[i, 2]
        v0 = v[j, 0] - v[i, 0]
        v1 = v[j, 1] - v[i, 1]
        v2 = v[j, 2] - v[i, 2]
        F0 += (u0 * h0) * Vj
        F1 += (u0 * h1) * Vj
        F2 += (u0 * h2) * Vj
        F3 += (u1 * h0) * Vj
        F4 += (u1 * h1) * Vj
        F5 += (u1 * h2) * Vj
        F6 += (u2 * h0) * Vj
        F7 += (u2 * h1) * Vj
        F8 += (u2 * h2) * Vj
        D0 += (v0 * h0) * Vj
        D1 += (v0 * h1) * Vj
        D2 += (v0 * h2) * Vj
        D3 += (v1 * h0) * Vj
        D4 += (v1 * h1) * Vj
        D5 += (v1 * h2) * Vj
        D6 += (v2 * h0) * Vj
        D7 += (v2 * h1) * Vj
        D8 += (v2 * h2) * Vj
    FX[i, 0], FX[i, 1], FX[i, 2] = F0, F1, F2
    FY[i, 0], FY[i, 1], FY[i, 2] = F3, F4, F5
    FZ[i, 0], FZ[i, 1], FZ[i, 2] = F6, F7, F8
    FdX[i, 0], FdX[i, 1], FdX[i, 2] = D0, D1, D2
    FdY[i, 0], FdY[i, 1], FdY[i, 2] = D3, D4, D5
    FdZ[i, 0], FdZ[i, 1], FdZ[i, 2] = D6, D7, D8


@njit(cache=True, parallel=True, error_model="numpy")
def precompute_kernel(start, stop, offsets, neighbors, x, volume, horizon, omega_kind, omega_table, damage_N, damage_NP1, bond_damage,
                      influence, phi, u, v, FX, FY, FZ, FdX, FdY, FdZ):
    """§9.2 for the points [start, stop): where Damage_NP1 - Damage_N > 1.0e-15 (``damage_N``
    non-empty), new ω and φ from the current bond damage (m_i is kept); then F and Ḟ."""
    check = damage_N.shape[0] > 0
    for i in prange(start, stop):
        if check and damage_NP1[i] - damage_N[i] > 1.0e-15:
            gradient_weights_point(i, offsets, neighbors, x, volume, horizon, omega_kind, omega_table, bond_damage, influence, phi)
        deformation_gradient_point(i, offsets, neighbors, volume, phi, u, v, FX, FY, FZ, FdX, FdY, FdZ)


# ------------------------------------------------------------------------------------------------
# §5.2, §5.3, §5.7 stress updates as tuple functions (inlined)
# ------------------------------------------------------------------------------------------------
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


# ------------------------------------------------------------------------------------------------
# §9.3 computeForce
# ------------------------------------------------------------------------------------------------
@njit(cache=True, inline="always")
def _rows(X, Y, Z, i):
    """The tensor whose rows are X[i], Y[i], Z[i], as a 9-tuple."""
    return (X[i, 0], X[i, 1], X[i, 2], Y[i, 0], Y[i, 1], Y[i, 2], Z[i, 0], Z[i, 1], Z[i, 2])


@njit(cache=True, inline="always")
def _bond_row(Fi, Fj, k, e, X0, X1, X2, L2):
    """Row a (k = 3a) of the bond tensor (§9.3 step 2): F̄ = 0.5 (F_i + F_j) entrywise,
    t = (F̄_a0 ξx + F̄_a1 ξy) + F̄_a2 ξz, F_b[a][c] = F̄[a][c] + ((e - t) ξ_c)/|ξ|², with e = η_a
    (deformation gradient) or Δv_a (its rate)."""
    f0 = 0.5 * (Fi[k] + Fj[k])
    f1 = 0.5 * (Fi[k + 1] + Fj[k + 1])
    f2 = 0.5 * (Fi[k + 2] + Fj[k + 2])
    t = (f0 * X0 + f1 * X1) + f2 * X2
    return f0 + ((e - t) * X0) / L2, f1 + ((e - t) * X1) / L2, f2 + ((e - t) * X2) / L2


@njit(cache=True, error_model="numpy")
def node_point(i, FX, FY, FZ, FdX, FdY, FdZ, V_N, R_N, V_NP1, R_NP1, d, sig_N, sig_NP1, cauchy, vm, triax, eqps_N, eqps_NP1,
               E_N, E_NP1, model, K, G, p0, p1, p2, p3, dt):
    """§9.3 steps 1, 3, 4 at node level (output quantities): Green_Lagrange_Strain when ``E_N`` is
    non-empty, L = Ḟ·Inv3(F), FT(L, V_N, R_N, dt), the stress update and σ = R·(σ̂·Rᵀ).
    Returns SINGULAR_NODE_F, NO_CONVERGENCE or 0."""
    F = _rows(FX, FY, FZ, i)
    Fd = _rows(FdX, FdY, FdZ, i)
    if E_N.shape[0] > 0:
        X = matmul_tn(Fd, F)
        for a in range(3):
            for c in range(3):
                E_NP1[i, 3 * a + c] = E_N[i, 3 * a + c] + (0.5 * (X[3 * a + c] + X[3 * c + a])) * dt
    Finv, _, ok = inv3(F)
    V1, R1, di = flanagan_taylor(matmul(Fd, Finv), load9(V_N, i), load9(R_N, i), dt)
    store9(V_NP1, i, V1)
    store9(R_NP1, i, R1)
    store9(d, i, di)
    plastic = model != ELASTIC
    sig, v, e, tri, failed = _stress_update(model, load9(sig_N, i), di, eqps_N[i] if plastic else 0.0, dt, K, G, p0, p1, p2, p3)
    store9(sig_NP1, i, sig)
    vm[i] = v
    if plastic:
        eqps_NP1[i] = e
        triax[i] = tri
    store9(cauchy, i, matmul(R1, matmul_nt(sig, R1)))
    if not ok:
        return SINGULAR_NODE_F
    return NO_CONVERGENCE if failed else 0


@njit(cache=True, error_model="numpy")
def bond_point(i, offsets, neighbors, x, y, v, volume, m, influence, phi, FX, FY, FZ, FdX, FdY, FdZ,
               bV_N, bR_N, bV_NP1, bR_NP1, bsig_N, bsig_NP1, beqps_N, beqps_NP1, model, K, G, p0, p1, p2, p3, dt, P, T):
    """§9.3 steps 2-6 for i's bonds: F_b, Ḟ_b, FT per bond (ω > 0; else V, R copied, d = 0), the
    stress update of every bond, P_b = (σ_b·F_b⁻ᵀ)·J_b, the stress integral 𝒮_i and the force
    state T of each bond (zero where ω <= 0). Returns SINGULAR_BOND_F, NO_CONVERGENCE or 0."""
    Fi = _rows(FX, FY, FZ, i)
    Fdi = _rows(FdX, FdY, FdZ, i)
    plastic = model != ELASTIC
    mi = m[i]
    S0 = S1 = S2 = S3 = S4 = S5 = S6 = S7 = S8 = 0.0
    for b in range(offsets[i], offsets[i + 1]):
        w = influence[b]
        j = neighbors[b]
        X0 = x[j, 0] - x[i, 0]
        X1 = x[j, 1] - x[i, 1]
        X2 = x[j, 2] - x[i, 2]
        L2 = X0 * X0 + X1 * X1 + X2 * X2
        if w > 0.0:
            Fj = _rows(FX, FY, FZ, j)
            Fdj = _rows(FdX, FdY, FdZ, j)
            a0, a1, a2 = _bond_row(Fi, Fj, 0, y[j, 0] - y[i, 0], X0, X1, X2, L2)
            a3, a4, a5 = _bond_row(Fi, Fj, 3, y[j, 1] - y[i, 1], X0, X1, X2, L2)
            a6, a7, a8 = _bond_row(Fi, Fj, 6, y[j, 2] - y[i, 2], X0, X1, X2, L2)
            Fb = (a0, a1, a2, a3, a4, a5, a6, a7, a8)
            a0, a1, a2 = _bond_row(Fdi, Fdj, 0, v[j, 0] - v[i, 0], X0, X1, X2, L2)
            a3, a4, a5 = _bond_row(Fdi, Fdj, 3, v[j, 1] - v[i, 1], X0, X1, X2, L2)
            a6, a7, a8 = _bond_row(Fdi, Fdj, 6, v[j, 2] - v[i, 2], X0, X1, X2, L2)
            Fbd = (a0, a1, a2, a3, a4, a5, a6, a7, a8)
            Finv, J, ok = inv3(Fb)
            if not ok:
                return SINGULAR_BOND_F
            V1, R1, db = flanagan_taylor(matmul(Fbd, Finv), load9(bV_N, b), load9(bR_N, b), dt)
        else:
            V1 = load9(bV_N, b)
            R1 = load9(bR_N, b)
            db = ZERO
            Finv = IDENTITY
            J = 1.0
        store9(bV_NP1, b, V1)
        store9(bR_NP1, b, R1)
        sig, _, e, _, failed = _stress_update(model, load9(bsig_N, b), db, beqps_N[b] if plastic else 0.0, dt, K, G, p0, p1, p2, p3)
        if failed:
            return NO_CONVERGENCE
        store9(bsig_NP1, b, sig)
        if plastic:
            beqps_NP1[b] = e
        if w > 0.0:
            Pb = matmul_nt_scaled(matmul(R1, matmul_nt(sig, R1)), Finv, J)
            store9(P, b, Pb)
            q1 = ((-X0) * X1) / L2
            q2 = ((-X0) * X2) / L2
            q5 = ((-X1) * X2) / L2
            Y = matmul(Pb, (1.0 - (X0 * X0) / L2, q1, q2, q1, 1.0 - (X1 * X1) / L2, q5, q2, q5, 1.0 - (X2 * X2) / L2))
            c = (w * (0.5 / mi + 0.5 / m[j])) * volume[j]
            S0 += c * Y[0]
            S1 += c * Y[1]
            S2 += c * Y[2]
            S3 += c * Y[3]
            S4 += c * Y[4]
            S5 += c * Y[5]
            S6 += c * Y[6]
            S7 += c * Y[7]
            S8 += c * Y[8]
    for b in range(offsets[i], offsets[i + 1]):
        w = influence[b]
        if w > 0.0:
            j = neighbors[b]
            X0 = x[j, 0] - x[i, 0]
            X1 = x[j, 1] - x[i, 1]
            X2 = x[j, 2] - x[i, 2]
            L2 = X0 * X0 + X1 * X1 + X2 * X2
            h0 = phi[b, 0]
            h1 = phi[b, 1]
            h2 = phi[b, 2]
            T[b, 0] = ((w / mi) * ((P[b, 0] * X0 + P[b, 1] * X1) + P[b, 2] * X2)) / L2 + ((S0 * h0 + S1 * h1) + S2 * h2)
            T[b, 1] = ((w / mi) * ((P[b, 3] * X0 + P[b, 4] * X1) + P[b, 5] * X2)) / L2 + ((S3 * h0 + S4 * h1) + S5 * h2)
            T[b, 2] = ((w / mi) * ((P[b, 6] * X0 + P[b, 7] * X1) + P[b, 8] * X2)) / L2 + ((S6 * h0 + S7 * h1) + S8 * h2)
        else:
            T[b, 0] = 0.0
            T[b, 1] = 0.0
            T[b, 2] = 0.0
    return 0


@njit(cache=True, parallel=True, error_model="numpy")
def force_kernel(start, stop, offsets, neighbors, x, y, v, volume, m, influence, phi, FX, FY, FZ, FdX, FdY, FdZ,
                 V_N, R_N, V_NP1, R_NP1, d, sig_N, sig_NP1, cauchy, vm, triax, eqps_N, eqps_NP1, E_N, E_NP1,
                 bV_N, bR_N, bV_NP1, bR_NP1, bsig_N, bsig_NP1, beqps_N, beqps_NP1, model, K, G, p0, p1, p2, p3, dt, P, T):
    """§9.3 for the points [start, stop): :func:`node_point` then :func:`bond_point` per point.
    Node arrays (n, 9) / (n,), bond arrays (nb, 9) / (nb,); eqps, triax arrays may be empty for
    ELASTIC, ``E_N``/``E_NP1`` empty when Green_Lagrange_Strain is not wanted. Returns
    (first point with a problem or -1, its status code)."""
    status = np.zeros(max(stop - start, 0), dtype=np.int8)
    for i in prange(start, stop):
        a = node_point(i, FX, FY, FZ, FdX, FdY, FdZ, V_N, R_N, V_NP1, R_NP1, d, sig_N, sig_NP1, cauchy, vm, triax, eqps_N, eqps_NP1,
                       E_N, E_NP1, model, K, G, p0, p1, p2, p3, dt)
        c = bond_point(i, offsets, neighbors, x, y, v, volume, m, influence, phi, FX, FY, FZ, FdX, FdY, FdZ,
                       bV_N, bR_N, bV_NP1, bR_NP1, bsig_N, bsig_NP1, beqps_N, beqps_NP1, model, K, G, p0, p1, p2, p3, dt, P, T)
        status[i - start] = a if a != 0 else c
    for k in range(status.shape[0]):
        if status[k] != 0:
            return start + k, int(status[k])
    return -1, 0
