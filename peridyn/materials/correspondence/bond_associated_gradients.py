"""The bond-associated correspondence model's gradient weights and deformation gradients
(PERIDIGM_CORRESPONDENCE.md §8.2 with the pseudo-inverse, order 1; §9.1 weighted volume, §9.2
the node and bond deformation gradients), as loop laws and per-point helpers; the force
(§9.3) is :mod:`.bond_associated_kernels`'."""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ...core.influence import omega
from ...core.traversal import BondMap, PointSum
from ...kernels import default_backend
from .tensor import load9, store9

EMPTY = np.zeros(0)


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


# The gradient weights' and the deformation gradient's bond physics, shared by the loop laws and
# the per-point helpers of the tangent's probes (arrays as arguments: a law's function unpacks its
# args and calls them; inlined).
@njit(cache=True, inline="always", error_model="numpy")
def weights_bond(i, j, b, X0, X1, X2, zeta, volume, horizon, omega_kind, omega_table, bond_damage, influence):
    """ω_ij = ω(ζ, δ_i)(1.0 - d_ij) (``w * 1.0`` without damage) of bond b = i→j with ξ = (X0, X1,
    X2), ζ = |ξ|, written to influence[b]; returns the bond's terms of the moment matrix,
    M_rc = ((ω V_j) Q_r) Q_c with Q = ξ/δ_i: 9 numbers, row-major."""
    delta = horizon[i]
    Q0 = X0 / delta
    Q1 = X1 / delta
    Q2 = X2 / delta
    w = omega(omega_kind, zeta, delta, omega_table, b)
    w = w * (1.0 - bond_damage[b]) if bond_damage.shape[0] > 0 else w * 1.0
    influence[b] = w
    t = w * volume[j]
    return (
        (t * Q0) * Q0, (t * Q0) * Q1, (t * Q0) * Q2,
        (t * Q1) * Q0, (t * Q1) * Q1, (t * Q1) * Q2,
        (t * Q2) * Q0, (t * Q2) * Q1, (t * Q2) * Q2,
    )


@njit(cache=True, error_model="numpy")
def weights_inverse(i, acc, horizon):
    """M⁺ of point i's moment matrix (``acc``, 9 numbers row-major) with τ = ((1.0e-6 δ) δ) δ, as 9
    numbers row-major."""
    M = np.empty((3, 3))
    for r in range(3):
        for c in range(3):
            M[r, c] = acc[3 * r + c]
    delta = horizon[i]
    Mi = pseudo_inverse(M, ((1.0e-6 * delta) * delta) * delta)
    return (Mi[0, 0], Mi[0, 1], Mi[0, 2], Mi[1, 0], Mi[1, 1], Mi[1, 2], Mi[2, 0], Mi[2, 1], Mi[2, 2])


@njit(cache=True, inline="always", error_model="numpy")
def phi_bond(i, b, X0, X1, X2, Mi, horizon, influence):
    """φ_ij (3 numbers, L^-3): φ_r = Σ_c (((1.0 ω_ij) M⁺_rc) Q_c)/δ from 0.0, Q = ξ/δ, M⁺ = ``Mi``
    (9 numbers, row-major)."""
    delta = horizon[i]
    Q0 = X0 / delta
    Q1 = X1 / delta
    Q2 = X2 / delta
    t = 1.0 * influence[b]
    return (
        (((0.0 + ((t * Mi[0]) * Q0) / delta) + ((t * Mi[1]) * Q1) / delta) + ((t * Mi[2]) * Q2) / delta),
        (((0.0 + ((t * Mi[3]) * Q0) / delta) + ((t * Mi[4]) * Q1) / delta) + ((t * Mi[5]) * Q2) / delta),
        (((0.0 + ((t * Mi[6]) * Q0) / delta) + ((t * Mi[7]) * Q1) / delta) + ((t * Mi[8]) * Q2) / delta),
    )


# not a loop law: probe helper of fd_tangent_rate (one family inside a parallel iteration); the laws are WEIGHTS_MOMENT and WEIGHTS_PHI
@njit(cache=True, error_model="numpy")
def gradient_weights_point(i, offsets, neighbors, x, volume, horizon, omega_kind, omega_table, bond_damage, influence, phi):
    """§8.2 with b = ξ (order 1, Q = ξ/δ) for point i: writes ω_ij = ω(|ξ|, δ_i)(1.0 - d_ij) into
    ``influence`` and φ_ij into ``phi`` for i's bonds. ``bond_damage`` (nb,) NP1, empty for none.
    M_rc += ((ω V_j) Q_r) Q_c; τ = ((1.0e-6 δ) δ) δ; φ_r = Σ_c (((1.0 ω) M⁺_rc) Q_c)/δ. The
    arithmetic of ``WEIGHTS_MOMENT`` and ``WEIGHTS_PHI`` (the same helpers)."""
    M0 = M1 = M2 = M3 = M4 = M5 = M6 = M7 = M8 = 0.0
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        X0 = x[j, 0] - x[i, 0]
        X1 = x[j, 1] - x[i, 1]
        X2 = x[j, 2] - x[i, 2]
        t = weights_bond(i, j, b, X0, X1, X2, math.sqrt(X0 * X0 + X1 * X1 + X2 * X2), volume, horizon, omega_kind, omega_table,
                         bond_damage, influence)
        M0 += t[0]
        M1 += t[1]
        M2 += t[2]
        M3 += t[3]
        M4 += t[4]
        M5 += t[5]
        M6 += t[6]
        M7 += t[7]
        M8 += t[8]
    Mi = weights_inverse(i, (M0, M1, M2, M3, M4, M5, M6, M7, M8), horizon)
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        phi[b, 0], phi[b, 1], phi[b, 2] = phi_bond(i, b, x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2], Mi, horizon, influence)


@njit(cache=True, inline="always", error_model="numpy")
def gradient_terms(i, j, b, volume, phi, u, v):
    """Bond i→j's terms of F and Ḟ, (Δu_a φ_c) V_j and (Δv_a φ_c) V_j: 18 numbers (F, then Ḟ,
    row-major)."""
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
    return (
        (u0 * h0) * Vj, (u0 * h1) * Vj, (u0 * h2) * Vj,
        (u1 * h0) * Vj, (u1 * h1) * Vj, (u1 * h2) * Vj,
        (u2 * h0) * Vj, (u2 * h1) * Vj, (u2 * h2) * Vj,
        (v0 * h0) * Vj, (v0 * h1) * Vj, (v0 * h2) * Vj,
        (v1 * h0) * Vj, (v1 * h1) * Vj, (v1 * h2) * Vj,
        (v2 * h0) * Vj, (v2 * h1) * Vj, (v2 * h2) * Vj,
    )


@njit(cache=True, inline="always", error_model="numpy")
def store_gradients(i, t, FX, FY, FZ, FdX, FdY, FdZ):
    """F and Ḟ (18 numbers) of point i into the rows FX[i] ... FdZ[i]."""
    FX[i, 0], FX[i, 1], FX[i, 2] = t[0], t[1], t[2]
    FY[i, 0], FY[i, 1], FY[i, 2] = t[3], t[4], t[5]
    FZ[i, 0], FZ[i, 1], FZ[i, 2] = t[6], t[7], t[8]
    FdX[i, 0], FdX[i, 1], FdX[i, 2] = t[9], t[10], t[11]
    FdY[i, 0], FdY[i, 1], FdY[i, 2] = t[12], t[13], t[14]
    FdZ[i, 0], FdZ[i, 1], FdZ[i, 2] = t[15], t[16], t[17]


# not a loop law: probe helper of fd_tangent_rate (one family inside a parallel iteration); the law is GRADIENTS
@njit(cache=True, error_model="numpy")
def deformation_gradient_point(i, offsets, neighbors, volume, phi, u, v, FX, FY, FZ, FdX, FdY, FdZ):
    """§9.2 step 2: F = I + Σ_j (Δu ⊗ φ) V_j and Ḟ = Σ_j (Δv ⊗ φ) V_j, entry by entry
    F[a][c] += (Δu_a φ_c) V_j over all of i's bonds (no ω test), stored as rows."""
    F0 = F4 = F8 = 1.0
    F1 = F2 = F3 = F5 = F6 = F7 = 0.0
    D0 = D1 = D2 = D3 = D4 = D5 = D6 = D7 = D8 = 0.0
    for b in range(offsets[i], offsets[i + 1]):
        t = gradient_terms(i, neighbors[b], b, volume, phi, u, v)
        F0 += t[0]
        F1 += t[1]
        F2 += t[2]
        F3 += t[3]
        F4 += t[4]
        F5 += t[5]
        F6 += t[6]
        F7 += t[7]
        F8 += t[8]
        D0 += t[9]
        D1 += t[10]
        D2 += t[11]
        D3 += t[12]
        D4 += t[13]
        D5 += t[14]
        D6 += t[15]
        D7 += t[16]
        D8 += t[17]
    store_gradients(i, (F0, F1, F2, F3, F4, F5, F6, F7, F8, D0, D1, D2, D3, D4, D5, D6, D7, D8), FX, FY, FZ, FdX, FdY, FdZ)


@njit(cache=True, error_model="numpy")
def recompute(i, damage_N, damage_NP1):
    """Whether point i's ω and φ are (re)computed: always without ``damage_N`` (initialize), else
    where Damage_NP1 - Damage_N > 1.0e-15."""
    return damage_N.shape[0] == 0 or damage_NP1[i] - damage_N[i] > 1.0e-15


@njit(cache=True, inline="always", error_model="numpy")
def phi_or_kept(i, b, X0, X1, X2, again, Mi, horizon, influence, phi):
    """φ_ij (:func:`phi_bond`) where ``again``, else the bond's φ as it is."""
    if again:
        return phi_bond(i, b, X0, X1, X2, Mi, horizon, influence)
    return phi[b, 0], phi[b, 1], phi[b, 2]


@njit(cache=True, inline="always", error_model="numpy")
def gradients_with_identity(i, j, b, first, volume, phi, u, v):
    """:func:`gradient_terms` of the bond, with the 1.0 of F's diagonal added to the point's first
    bond (``first``): summed from 0.0, 0.0 + (1.0 + t_1) is 1.0 + t_1 exactly, so F is the
    hand-written sum from I (1.0 + t_1, then + t_2, ...) bit for bit."""
    t = gradient_terms(i, j, b, volume, phi, u, v)
    if first:
        return (1.0 + t[0], t[1], t[2], t[3], 1.0 + t[4]) + t[5:8] + (1.0 + t[8],) + t[9:18]
    return t


@njit(cache=True, error_model="numpy")
def gradients_finish_rows(i, acc, has_bonds, FX, FY, FZ, FdX, FdY, FdZ):
    """F and Ḟ (``acc``, 18 numbers) into the rows of point i, F = I for a point without bonds;
    returns what was stored."""
    if not has_bonds:
        acc = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0) + acc[9:18]
    store_gradients(i, acc, FX, FY, FZ, FdX, FdY, FdZ)
    return acc


# Loop laws (peridyn.core.traversal) of §9.1-§9.2, run on reference positions: the bond context's
# (ex, ey, ez) = ξ = x_j - x_i and L = |ξ| (L). The weights' laws take (volume (n,) L^3, horizon
# (n,) L, omega_kind, omega_table, bond_damage (nb,) NP1 or empty, damage_N (n,) or empty,
# damage_NP1 (n,), influence (nb,), phi (nb, 3) L^-3, Minv (n, 9) the moment pass's M⁺ per point)
# as args.
def weights_point(i, args):
    """Whether point i's ω and φ are (re)computed (:func:`recompute`)."""
    return recompute(i, args[5], args[6])


def weights_gate(i, b, p, args):
    """Only the bonds of the points that recompute."""
    return p


def weights_term(i, j, b, ex, ey, ez, L, z, p, args):
    """ω_ij into influence[b]; the bond's terms of the moment matrix (9 numbers)."""
    volume, horizon, omega_kind, omega_table, bond_damage, damage_N, damage_NP1, influence, phi, Minv = args
    return weights_bond(i, j, b, ex, ey, ez, L, volume, horizon, omega_kind, omega_table, bond_damage, influence)


def phi_point(i, args):
    """(recompute, M⁺ of point i from Minv (args[9]))."""
    return recompute(i, args[5], args[6]), load9(args[9], i)


def phi_term(i, j, b, ex, ey, ez, L, z, p, args):
    """φ_ij where point i recomputes its weights, else the bond's φ unchanged."""
    volume, horizon, omega_kind, omega_table, bond_damage, damage_N, damage_NP1, influence, phi, Minv = args
    return phi_or_kept(i, b, ex, ey, ez, p[0], p[1], horizon, influence, phi)


def weighted_volume_term(i, j, b, ex, ey, ez, L, z, p, args):
    """ω_ij V_j (L^3)."""
    return args[7][b] * args[0][j]


# GRADIENTS takes (offsets, volume (n,) L^3, phi (nb, 3), u (n, 3) L, v (n, 3) L/T, FX, FY, FZ,
# FdX, FdY, FdZ (n, 3) each) as args; F starts from I (see :func:`gradients_with_identity`).
def gradients_point(i, args):
    """Position of point i's first bond."""
    return args[0][i]


def gradients_term(i, j, b, ex, ey, ez, L, z, p, args):
    """The bond's terms of F (from I) and Ḟ: 18 numbers."""
    offsets, volume, phi, u, v, FX, FY, FZ, FdX, FdY, FdZ = args
    return gradients_with_identity(i, j, b, b == p, volume, phi, u, v)


def gradients_finish(i, acc, p, args):
    """F and Ḟ into the rows of point i (F = I without bonds); returns them."""
    offsets, volume, phi, u, v, FX, FY, FZ, FdX, FdY, FdZ = args
    return gradients_finish_rows(i, acc, offsets[i + 1] > p, FX, FY, FZ, FdX, FdY, FdZ)


#: §8.2 first pass: ω_ij written, out (n, 9) = the moment matrices of the points that recompute (gated)
WEIGHTS_MOMENT = PointSum(weights_term, point=weights_point, gate=weights_gate, width=9, z_from_positions=True)
#: §8.2 second pass: out (nb, 3) = φ (kept where a point does not recompute)
WEIGHTS_PHI = BondMap(phi_term, point=phi_point, width=3, z_from_positions=True)
#: §9.1 step 3: out (n,) = m_i = Σ_j ω_ij V_j
WEIGHTED_VOLUME = PointSum(weighted_volume_term, z_from_positions=True)
#: §9.2 step 2: F and Ḟ written as rows; out (n, 18) = (F, Ḟ)
GRADIENTS = PointSum(gradients_term, point=gradients_point, finish=gradients_finish, width=18, z_from_positions=True)


@njit(cache=True, parallel=True, error_model="numpy")
def weights_inverse_kernel(start, stop, horizon, damage_N, damage_NP1, Msum, Minv):
    """Between the two passes of §8.2, per point of [start, stop) that recomputes its weights (no
    bond loop): M⁺ of its moment matrix Msum[i] into Minv[i] (:func:`weights_inverse`)."""
    for i in prange(start, stop):
        if recompute(i, damage_N, damage_NP1):
            store9(Minv, i, weights_inverse(i, load9(Msum, i), horizon))


def _weights(bk, start, stop, offsets, neighbors, x, gw):
    """ω and φ (§8.2) of the points of [start, stop) that recompute them."""
    Msum = np.empty((x.shape[0], 9))
    bk.kernel(WEIGHTS_MOMENT)(start, stop, offsets, neighbors, x, x, gw, Msum)
    weights_inverse_kernel(start, stop, gw[1], gw[5], gw[6], Msum, gw[9])
    bk.kernel(WEIGHTS_PHI)(start, stop, offsets, neighbors, x, x, gw, gw[8])


def initialize_kernel(start, stop, offsets, neighbors, x, volume, horizon, omega_kind, omega_table, bond_damage, influence, phi, m,
                      *, backend=None):
    """§9.1 steps 1-3 for the points [start, stop): ω_ij and φ_ij (§8.2), then the weighted volume
    m_i = Σ_j ω_ij V_j (sequential from 0.0), which the family never updates. The laws
    ``WEIGHTS_MOMENT``, ``WEIGHTS_PHI`` (with the pseudo-inverses of
    :func:`weights_inverse_kernel` between them) and ``WEIGHTED_VOLUME`` on ``backend`` (None:
    the default) over the reference positions x."""
    bk = backend or default_backend()
    gw = (volume, horizon, omega_kind, omega_table, bond_damage, EMPTY, EMPTY, influence, phi, np.empty((x.shape[0], 9)))
    _weights(bk, start, stop, offsets, neighbors, x, gw)
    bk.kernel(WEIGHTED_VOLUME)(start, stop, offsets, neighbors, x, x, gw, m)


def precompute_kernel(start, stop, offsets, neighbors, x, volume, horizon, omega_kind, omega_table, damage_N, damage_NP1, bond_damage,
                      influence, phi, u, v, FX, FY, FZ, FdX, FdY, FdZ, *, backend=None):
    """§9.2 for the points [start, stop): where Damage_NP1 - Damage_N > 1.0e-15 (``damage_N``
    non-empty), new ω and φ from the current bond damage (m_i is kept); then F and Ḟ. The laws
    ``WEIGHTS_MOMENT`` and ``WEIGHTS_PHI`` (only when some point of the range recomputes), then
    ``GRADIENTS``, on ``backend`` (None: the default) over the reference positions x."""
    bk = backend or default_backend()
    if damage_N.shape[0] > 0 and stop > start and np.any(damage_NP1[start:stop] - damage_N[start:stop] > 1.0e-15):
        gw = (volume, horizon, omega_kind, omega_table, bond_damage, damage_N, damage_NP1, influence, phi, np.empty((x.shape[0], 9)))
        _weights(bk, start, stop, offsets, neighbors, x, gw)
    args = (offsets, volume, phi, u, v, FX, FY, FZ, FdX, FdY, FdZ)
    bk.kernel(GRADIENTS)(start, stop, offsets, neighbors, x, x, args, np.empty((x.shape[0], 18)))
