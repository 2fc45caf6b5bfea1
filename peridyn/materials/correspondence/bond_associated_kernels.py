"""Numerical core of Peridigm's bond-associated correspondence family
(PERIDIGM_CORRESPONDENCE.md §5.2, §5.3, §5.7, §8.2, §9), gather only (a point writes its own rows
and its own bonds, never a neighbour's).

Loops: the bond loops are loop laws (:mod:`peridyn.core.traversal`) run on the reference
positions by the block's backend: ``WEIGHTS_MOMENT`` and ``WEIGHTS_PHI`` (§8.2, a gated
:class:`PointSum` whose finish takes the pseudo-inverse, then a :class:`BondMap` of φ),
``WEIGHTED_VOLUME`` (§9.1), ``GRADIENTS`` (§9.2, F and Ḟ as one sum of 18 components),
``BOND_STRESS`` (a :class:`PointSum` of the stress integral whose terms update each bond's state)
and ``BOND_FORCE`` (a :class:`BondMap` of width 3); the node level (:func:`node_kernel`) has no
bond loop. The drivers :func:`initialize_kernel`, :func:`precompute_kernel` and
:func:`force_kernel` run them. The per-point helpers with their own bond loops
(:func:`gradient_weights_point`, :func:`deformation_gradient_point`, :func:`bond_point`) serve the
tangent's probes (:mod:`.fd_tangent_rate`), which run one family inside a parallel iteration; they
do the laws' arithmetic through the same bond helpers (``weights_bond``, ``phi_bond``,
``gradient_terms``, ``bond_stress``, ``bond_force``), inlined into both.

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
from ...core.traversal import BondMap, PointSum
from ...kernels import default_backend
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


# The force's bond physics, shared by the loop laws and the per-point helper of the tangent's
# probes (arrays as arguments: a law's function unpacks its args and calls them; inlined).
@njit(cache=True, inline="always", error_model="numpy")
def bond_stress(i, j, b, X0, X1, X2, y, v, volume, m, influence, F6, bV_N, bR_N, bV_NP1, bR_NP1, bsig_N, bsig_NP1, beqps_N, beqps_NP1,
                prm, dt, P):
    """§9.3 steps 2-5 for bond b = i→j with ξ = (X0, X1, X2): F_b, Ḟ_b, FT (ω > 0; else V, R
    copied, d = 0), the stress update (NP1 V, R, σ̂, eqps written at [b]), P_b = (σ_b·F_b⁻ᵀ)·J_b
    into P[b] (ω > 0). Returns (status, term): status SINGULAR_BOND_F or NO_CONVERGENCE (the bond
    state is then incomplete) or 0, term the bond's part of 𝒮_i, c (P_b (I - ξ⊗ξ/|ξ|²)) with
    c = (ω (0.5/m_i + 0.5/m_j)) V_j (9 numbers, zeros where ω <= 0). ``F6`` = (FX, FY, FZ, FdX,
    FdY, FdZ) the node F and Ḟ rows, ``prm`` = (model, K, G, p0, p1, p2, p3) of the stress update."""
    FX, FY, FZ, FdX, FdY, FdZ = F6
    model, K, G, p0, p1, p2, p3 = prm
    plastic = model != ELASTIC
    w = influence[b]
    L2 = X0 * X0 + X1 * X1 + X2 * X2
    if w > 0.0:
        Fi = _rows(FX, FY, FZ, i)
        Fdi = _rows(FdX, FdY, FdZ, i)
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
            return SINGULAR_BOND_F, ZERO
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
        return NO_CONVERGENCE, ZERO
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
        c = (w * (0.5 / m[i] + 0.5 / m[j])) * volume[j]
        return 0, (c * Y[0], c * Y[1], c * Y[2], c * Y[3], c * Y[4], c * Y[5], c * Y[6], c * Y[7], c * Y[8])
    return 0, ZERO


@njit(cache=True, inline="always", error_model="numpy")
def bond_force(i, b, X0, X1, X2, Si, m, influence, phi, P):
    """§9.3 step 6: T(i→j) = (ω/m_i) P_b ξ/|ξ|² + 𝒮_i φ_ij (force per volume squared; zero
    where ω <= 0), 𝒮_i = ``Si`` (9 numbers)."""
    w = influence[b]
    if w > 0.0:
        mi = m[i]
        L2 = X0 * X0 + X1 * X1 + X2 * X2
        h0 = phi[b, 0]
        h1 = phi[b, 1]
        h2 = phi[b, 2]
        return (
            ((w / mi) * ((P[b, 0] * X0 + P[b, 1] * X1) + P[b, 2] * X2)) / L2 + ((Si[0] * h0 + Si[1] * h1) + Si[2] * h2),
            ((w / mi) * ((P[b, 3] * X0 + P[b, 4] * X1) + P[b, 5] * X2)) / L2 + ((Si[3] * h0 + Si[4] * h1) + Si[5] * h2),
            ((w / mi) * ((P[b, 6] * X0 + P[b, 7] * X1) + P[b, 8] * X2)) / L2 + ((Si[6] * h0 + Si[7] * h1) + Si[8] * h2),
        )
    return 0.0, 0.0, 0.0


# not a loop law: probe helper of fd_tangent_rate (one family inside a parallel iteration); the laws are BOND_STRESS and BOND_FORCE
@njit(cache=True, error_model="numpy")
def bond_point(i, offsets, neighbors, x, y, v, volume, m, influence, phi, FX, FY, FZ, FdX, FdY, FdZ,
               bV_N, bR_N, bV_NP1, bR_NP1, bsig_N, bsig_NP1, beqps_N, beqps_NP1, model, K, G, p0, p1, p2, p3, dt, P, T):
    """§9.3 steps 2-6 for i's bonds: F_b, Ḟ_b, FT per bond (ω > 0; else V, R copied, d = 0), the
    stress update of every bond, P_b = (σ_b·F_b⁻ᵀ)·J_b, the stress integral 𝒮_i and the force
    state T of each bond (zero where ω <= 0). Returns SINGULAR_BOND_F, NO_CONVERGENCE or 0 (at
    the first failing bond). The arithmetic of ``BOND_STRESS`` and ``BOND_FORCE`` (the same
    helpers)."""
    F6 = (FX, FY, FZ, FdX, FdY, FdZ)
    prm = (model, K, G, p0, p1, p2, p3)
    S0 = S1 = S2 = S3 = S4 = S5 = S6 = S7 = S8 = 0.0
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        code, t = bond_stress(i, j, b, x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2], y, v, volume, m, influence, F6,
                              bV_N, bR_N, bV_NP1, bR_NP1, bsig_N, bsig_NP1, beqps_N, beqps_NP1, prm, dt, P)
        if code != 0:
            return code
        S0 += t[0]
        S1 += t[1]
        S2 += t[2]
        S3 += t[3]
        S4 += t[4]
        S5 += t[5]
        S6 += t[6]
        S7 += t[7]
        S8 += t[8]
    Si = (S0, S1, S2, S3, S4, S5, S6, S7, S8)
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        T[b, 0], T[b, 1], T[b, 2] = bond_force(i, b, x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2], Si, m, influence, phi, P)
    return 0


@njit(cache=True, inline="always", error_model="numpy")
def bond_stress_status(i, j, b, X0, X1, X2, y, v, volume, m, influence, F6, bV_N, bR_N, bV_NP1, bR_NP1, bsig_N, bsig_NP1, beqps_N,
                       beqps_NP1, prm, dt, P, status):
    """:func:`bond_stress`, its failure code into status[i] unless the point has one already (the
    node's, or an earlier bond's); returns the bond's term of 𝒮_i."""
    code, t = bond_stress(i, j, b, X0, X1, X2, y, v, volume, m, influence, F6, bV_N, bR_N, bV_NP1, bR_NP1, bsig_N, bsig_NP1, beqps_N,
                          beqps_NP1, prm, dt, P)
    if code != 0 and status[i] == 0:
        status[i] = code
    return t


@njit(cache=True, parallel=True, error_model="numpy")
def node_kernel(start, stop, FX, FY, FZ, FdX, FdY, FdZ, V_N, R_N, V_NP1, R_NP1, d, sig_N, sig_NP1, cauchy, vm, triax, eqps_N, eqps_NP1,
                E_N, E_NP1, model, K, G, p0, p1, p2, p3, dt, status):
    """:func:`node_point` of the points [start, stop) (no bond loop); its code into status[i]."""
    for i in prange(start, stop):
        status[i] = node_point(i, FX, FY, FZ, FdX, FdY, FdZ, V_N, R_N, V_NP1, R_NP1, d, sig_N, sig_NP1, cauchy, vm, triax, eqps_N, eqps_NP1,
                               E_N, E_NP1, model, K, G, p0, p1, p2, p3, dt)


# Loop laws (peridyn.core.traversal) of §9.3, run on reference positions: the bond context's
# (ex, ey, ez) = ξ = x_j - x_i (L). args (y (n, 3) L, v (n, 3) L/T, volume (n,) L^3, m (n,) L^3,
# influence (nb,), phi (nb, 3) L^-3, FX, FY, FZ, FdX, FdY, FdZ (n, 3) each, bV_N, bR_N, bV_NP1,
# bR_NP1, bsig_N, bsig_NP1 (nb, 9), beqps_N, beqps_NP1 (nb,) or empty, model, K, G, p0, p1, p2,
# p3, dt T, P (nb, 9) the bond Piola stresses, S (n, 9) the first pass's output, the stress
# integrals, status (n,) int8); flat (a tuple of numbers inside args is no parallel kernel
# argument).
def bond_stress_term(i, j, b, ex, ey, ez, L, z, p, args):
    """The bond's NP1 state and P_b written, its term of 𝒮_i (9 numbers); a failure's code into
    status[i] (:func:`bond_stress_status`)."""
    (y, v, volume, m, influence, phi, FX, FY, FZ, FdX, FdY, FdZ, bV_N, bR_N, bV_NP1, bR_NP1, bsig_N, bsig_NP1, beqps_N, beqps_NP1,
     model, K, G, p0, p1, p2, p3, dt, P, S, status) = args
    return bond_stress_status(i, j, b, ex, ey, ez, y, v, volume, m, influence, (FX, FY, FZ, FdX, FdY, FdZ), bV_N, bR_N, bV_NP1, bR_NP1,
                              bsig_N, bsig_NP1, beqps_N, beqps_NP1, (model, K, G, p0, p1, p2, p3), dt, P, status)


def integral_load(i, args):
    """𝒮_i (9 numbers) from the first pass's output S (args[29])."""
    return load9(args[29], i)


def bond_force_term(i, j, b, ex, ey, ez, L, z, p, args):
    """T(i→j) (3 numbers, :func:`bond_force`) with 𝒮_i = p."""
    return bond_force(i, b, ex, ey, ez, p, args[3], args[4], args[5], args[28])


#: §9.3 steps 2-5: the NP1 bond states and P written; out (n, 9) = 𝒮_i
BOND_STRESS = PointSum(bond_stress_term, width=9, z_from_positions=True)
#: §9.3 step 6: out (nb, 3) = T of the points' bonds, from 𝒮 (args[29]) of the first pass
BOND_FORCE = BondMap(bond_force_term, point=integral_load, width=3, z_from_positions=True)


def force_kernel(start, stop, offsets, neighbors, x, y, v, volume, m, influence, phi, FX, FY, FZ, FdX, FdY, FdZ,
                 V_N, R_N, V_NP1, R_NP1, d, sig_N, sig_NP1, cauchy, vm, triax, eqps_N, eqps_NP1, E_N, E_NP1,
                 bV_N, bR_N, bV_NP1, bR_NP1, bsig_N, bsig_NP1, beqps_N, beqps_NP1, model, K, G, p0, p1, p2, p3, dt, P, T,
                 *, backend=None, S=None):
    """§9.3 for the points [start, stop): :func:`node_point` per point (:func:`node_kernel`),
    then the laws ``BOND_STRESS`` and ``BOND_FORCE`` on ``backend`` (None: the default) over the
    reference positions x. Node arrays (n, 9) / (n,), bond arrays (nb, 9) / (nb,); eqps, triax
    arrays may be empty for ELASTIC, ``E_N``/``E_NP1`` empty when Green_Lagrange_Strain is not
    wanted; ``S`` (n, 9) scratch for the stress integrals, else one is made. Returns (first point with a problem
    or -1, its status code: the node's, else its first failing bond's)."""
    bk = backend or default_backend()
    n = x.shape[0]
    if S is None:
        S = np.empty((n, 9))
    status = np.zeros(n, dtype=np.int8)
    node_kernel(start, stop, FX, FY, FZ, FdX, FdY, FdZ, V_N, R_N, V_NP1, R_NP1, d, sig_N, sig_NP1, cauchy, vm, triax, eqps_N, eqps_NP1,
                E_N, E_NP1, model, K, G, p0, p1, p2, p3, dt, status)
    bond = (y, v, volume, m, influence, phi, FX, FY, FZ, FdX, FdY, FdZ, bV_N, bR_N, bV_NP1, bR_NP1, bsig_N, bsig_NP1, beqps_N, beqps_NP1,
            model, K, G, p0, p1, p2, p3, dt, P, S, status)
    bk.kernel(BOND_STRESS)(start, stop, offsets, neighbors, x, x, bond, S)
    bk.kernel(BOND_FORCE)(start, stop, offsets, neighbors, x, x, bond, T)
    hits = np.flatnonzero(status[start:stop])
    if hits.size:
        k = start + int(hits[0])
        return k, int(status[k])
    return -1, 0
