"""Numerical core of Peridigm's hypoelastic correspondence family (PERIDIGM_CORRESPONDENCE.md §8,
§5.2/§5.3/§5.6 at node and bond level), gather only.

Loops: the bond loops are loop laws (:mod:`peridyn.core.traversal`) run on the current positions
by the block's backend: ``MOMENT`` and ``GRADIENT`` (§8.3, two :class:`PointSum` passes with the
pseudo-inverse between them), ``DEFORMED_LENGTH`` (a :class:`BondMap`), ``BOND_STRESS`` (a
:class:`PointSum` of the non-homogeneity integral whose terms update each bond's state) and
``BOND_FORCE`` (a :class:`BondMap` of width 3); the node level (``node_kernel``) has no bond loop.
The per-point helpers with their own bond loops (:func:`precompute_point`,
:func:`bond_force_point`) serve the tangent's probes (:mod:`.fd_tangent_rate`), which run one
family inside a parallel iteration; they do the laws' arithmetic through the same bond helpers
(``moment_bond``, ``gradient_bond``, ``bond_stress``, ``bond_force``), inlined into both.

Eulerian formulation: every evaluation builds the gradient weights on the current configuration
(bond vector η = y_j - y_i, deformed length l = sqrt((ηx ηx + ηy ηy) + ηz ηz)), with volumes
V'_j = J_N,j V_j scaled by the Jacobian of step N, the influence function ω(l, δ) at the deformed
length and the point's Horizon field δ (= ``Actual Horizon``), and bond damage d of step N.

Shapes and units of the kernel arguments:

* ``offsets`` (n+1,) int64 and ``neighbors`` (nb,) int32: the CSR bond lists (list order);
* ``y`` (n, 3) current positions (NP1 Coordinates, L); ``v`` (n, 3) NP1 velocities (L/T);
  ``volume`` (n,) (L^3); ``horizon`` (n,) the Horizon field δ (L); ``J_N`` (n,) the
  Jacobian_Determinant of step N (-); ``bond_damage`` (nb,) the N-step Bond_Damage (any real
  dtype) or an empty array (no damage model: d = 0);
* ``omega_kind``/``omega_table`` as in :func:`peridyn.core.influence.omega`; for an expression
  influence function the table holds ω(l_b, δ) at the deformed lengths of the block's bonds,
  indexed b - b0 with b0 = offsets[start] (an empty table otherwise);
* per-point tensors (n, 9) flat row-major: Velocity_Gradient L (1/T), Left_Stretch_Tensor V (-),
  Rotation_Tensor R (-), Unrotated_Rate_Of_Deformation d (1/T), stresses (M/(L T^2));
* per-bond fields: ``phi`` (nb, 3) the gradient weights (1/L^4 per unit volume: Σ_j Δv φ V'_j
  is a velocity gradient), bond tensors (nb, 9), bond equivalent plastic strain (nb,);
* ``T`` (nb, 3): the vector force state of every bond (force per volume squared).

Every operation follows the spec's (and Peridigm's source) order: left-to-right sums from 0.0 in
bond-list order, no fused multiply-add.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ...core.influence import omega
from ...core.traversal import BondMap, PointSum
from ...kernels import default_backend
from .stress import (
    _deviator,
    _dot9,
    _eqps_update,
    _floor,
    _return_to,
    _strain_increment,
    _trial_stress,
)
from .svd import pseudo_inverse
from .tensor import ZERO, flanagan_taylor, load9, matmul, matmul_nt, matmul_tn, store9

SQRT_2_3 = math.sqrt(2.0 / 3.0)
SQRT_6 = math.sqrt(6.0)

#: stress models (§5.8): node and bond level use the same routine
ELASTIC, PERFECTLY_PLASTIC, POWER_LAW = 0, 1, 2


# ------------------------------------------------------------------------------------------------
# §8.3 precompute: weighted volumes, gradient weights, velocity gradient, Jacobian
# ------------------------------------------------------------------------------------------------
@njit(cache=True, inline="always")
def _damage(bond_damage, b):
    return float(bond_damage[b]) if bond_damage.shape[0] > 0 else 0.0


@njit(cache=True, inline="always")
def _bond(i, j, y):
    """(ηx, ηy, ηz, l) with l = sqrt((ηx ηx + ηy ηy) + ηz ηz)."""
    e0 = y[j, 0] - y[i, 0]
    e1 = y[j, 1] - y[i, 1]
    e2 = y[j, 2] - y[i, 2]
    return e0, e1, e2, math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)


# The precompute's bond physics, shared by the loop laws and the per-point helper of the tangent's
# probes (arrays as arguments: a law's function unpacks its args and calls them; inlined).
@njit(cache=True, inline="always", error_model="numpy")
def moment_bond(i, j, b, e0, e1, e2, length, volume, horizon, J_N, bond_damage, omega_kind, omega_table, b0):
    """Bond i→j's terms of the weighted volume, ((1 - d) ω) V'_j, and of the moment matrix,
    M_ab = (temp Q_a) Q_b with temp = (ω (1 - d)) V'_j, Q = η/δ_i, V'_j = J_N,j V_j: 10 numbers."""
    delta = horizon[i]
    vj = J_N[j] * volume[j]
    om = omega(omega_kind, length, delta, omega_table, b - b0)
    d = _damage(bond_damage, b)
    temp = (om * (1.0 - d)) * vj
    q0 = e0 / delta
    q1 = e1 / delta
    q2 = e2 / delta
    return (
        ((1.0 - d) * om) * vj,
        (temp * q0) * q0, (temp * q0) * q1, (temp * q0) * q2,
        (temp * q1) * q0, (temp * q1) * q1, (temp * q1) * q2,
        (temp * q2) * q0, (temp * q2) * q1, (temp * q2) * q2,
    )


@njit(cache=True, error_model="numpy")
def moment_point(i, acc, horizon, weighted_volume):
    """From point i's sums acc = (weighted volume, M row-major): Weighted_Volume[i] = acc[0] (when
    ``weighted_volume`` is non-empty); returns (1.0 if the SVD did not converge else 0.0, M⁺
    row-major) with the threshold ((1e-6 δ) δ) δ."""
    if weighted_volume.shape[0] > 0:
        weighted_volume[i] = acc[0]
    M = np.empty(9)
    for k in range(9):
        M[k] = acc[k + 1]
    delta = horizon[i]
    Mi = np.zeros(9)
    ok = pseudo_inverse(M, 3, ((1.0e-6 * delta) * delta) * delta, Mi)
    return (0.0 if ok else 1.0, Mi[0], Mi[1], Mi[2], Mi[3], Mi[4], Mi[5], Mi[6], Mi[7], Mi[8])


@njit(cache=True, inline="always", error_model="numpy")
def gradient_bond(i, j, b, e0, e1, e2, length, Mi, v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, b0, phi):
    """φ of bond i→j from the point's M⁺ (``Mi``, 9 numbers row-major), written to phi[b]
    (φ_r = Σ_c (((1.0 ω(1-d)) M⁺_rc) Q_c)/δ from 0.0), and the bond's terms of L_i, (Δv_a φ_c) V'_j,
    and of m0_i, ω V'_j: 10 numbers."""
    delta = horizon[i]
    om = omega(omega_kind, length, delta, omega_table, b - b0)
    temp = 1.0 * (om * (1.0 - _damage(bond_damage, b)))
    q0 = e0 / delta
    q1 = e1 / delta
    q2 = e2 / delta
    p0 = ((((0.0 + ((temp * Mi[0]) * q0) / delta) + ((temp * Mi[1]) * q1) / delta)) + ((temp * Mi[2]) * q2) / delta)
    p1 = ((((0.0 + ((temp * Mi[3]) * q0) / delta) + ((temp * Mi[4]) * q1) / delta)) + ((temp * Mi[5]) * q2) / delta)
    p2 = ((((0.0 + ((temp * Mi[6]) * q0) / delta) + ((temp * Mi[7]) * q1) / delta)) + ((temp * Mi[8]) * q2) / delta)
    phi[b, 0] = p0
    phi[b, 1] = p1
    phi[b, 2] = p2
    vj = J_N[j] * volume[j]
    u0 = v[j, 0] - v[i, 0]
    u1 = v[j, 1] - v[i, 1]
    u2 = v[j, 2] - v[i, 2]
    return (
        (u0 * p0) * vj, (u0 * p1) * vj, (u0 * p2) * vj,
        (u1 * p0) * vj, (u1 * p1) * vj, (u1 * p2) * vj,
        (u2 * p0) * vj, (u2 * p1) * vj, (u2 * p2) * vj,
        om * vj,
    )


@njit(cache=True, error_model="numpy")
def gradient_point(i, Lt, w0, J_N, dt, L, J_NP1, m0):
    """L_i (9 numbers) into L[i], J_NP1,i = J_N,i (1.0 + ((L0 + L4) + L8) dt) and m0_i = w0."""
    store9(L, i, Lt)
    J_NP1[i] = J_N[i] * (1.0 + ((Lt[0] + Lt[4]) + Lt[8]) * dt)
    m0[i] = w0


# not a loop law: probe helper of fd_tangent_rate (one family inside a parallel iteration); the laws are MOMENT and GRADIENT
@njit(cache=True, error_model="numpy")
def precompute_point(i, offsets, neighbors, y, v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, b0, dt,
                     phi, L, J_NP1, m0, weighted_volume):
    """§8.3 for point i: Weighted_Volume (when ``weighted_volume`` is non-empty), the gradient
    weights φ of i's bonds (order 1: Q = η/δ, M = Σ (ω(1-d) V'_j) Q⊗Q, M⁺ with threshold
    ((1e-6 δ) δ) δ, φ_r = Σ_c (((1.0 ω(1-d)) M⁺_rc) Q_c)/δ), L_i = Σ (Δv ⊗ φ) V'_j, J_NP1 =
    J_N,i (1.0 + ((L0 + L4) + L8) dt) and the Undamaged_Weighted_Volume m0_i = Σ ω V'_j.
    Returns 1 when the SVD did not converge (Peridigm goes on), else 0. The arithmetic of
    ``MOMENT`` and ``GRADIENT`` (the same helpers)."""
    lo = offsets[i]
    hi = offsets[i + 1]
    W0 = W1 = W2 = W3 = W4 = W5 = W6 = W7 = W8 = W9 = 0.0
    for b in range(lo, hi):
        j = neighbors[b]
        e0, e1, e2, length = _bond(i, j, y)
        t = moment_bond(i, j, b, e0, e1, e2, length, volume, horizon, J_N, bond_damage, omega_kind, omega_table, b0)
        W0 += t[0]
        W1 += t[1]
        W2 += t[2]
        W3 += t[3]
        W4 += t[4]
        W5 += t[5]
        W6 += t[6]
        W7 += t[7]
        W8 += t[8]
        W9 += t[9]
    r = moment_point(i, (W0, W1, W2, W3, W4, W5, W6, W7, W8, W9), horizon, weighted_volume)
    Mi = (r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9])
    L0 = L1 = L2 = L3 = L4 = L5 = L6 = L7 = L8 = 0.0
    w0 = 0.0
    for b in range(lo, hi):
        j = neighbors[b]
        e0, e1, e2, length = _bond(i, j, y)
        t = gradient_bond(i, j, b, e0, e1, e2, length, Mi, v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, b0, phi)
        L0 += t[0]
        L1 += t[1]
        L2 += t[2]
        L3 += t[3]
        L4 += t[4]
        L5 += t[5]
        L6 += t[6]
        L7 += t[7]
        L8 += t[8]
        w0 += t[9]
    gradient_point(i, (L0, L1, L2, L3, L4, L5, L6, L7, L8), w0, J_N, dt, L, J_NP1, m0)
    return 0 if r[0] == 0.0 else 1


@njit(cache=True, parallel=True, error_model="numpy")
def moment_inverse_kernel(start, stop, horizon, W, weighted_volume, Minv):
    """Between the two passes of §8.3, per point of [start, stop) (no bond loop): from the
    moment pass's sums W (n, 10) = (weighted volume, M row-major), Weighted_Volume (when
    ``weighted_volume`` is non-empty) and M⁺ into Minv (n, 9) (:func:`moment_point`). Returns
    the number of points whose SVD did not converge."""
    bad = np.zeros(max(stop - start, 0), dtype=np.int8)
    for i in prange(start, stop):
        r = moment_point(i, (W[i, 0], W[i, 1], W[i, 2], W[i, 3], W[i, 4], W[i, 5], W[i, 6], W[i, 7], W[i, 8], W[i, 9]), horizon,
                         weighted_volume)
        store9(Minv, i, (r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9]))
        bad[i - start] = 0 if r[0] == 0.0 else 1
    count = 0
    for k in range(bad.shape[0]):
        count += bad[k]
    return count


# Loop laws (peridyn.core.traversal), run on the current positions: the bond context's
# (ex, ey, ez) = η = y_j - y_i and L = l = |η| (L); |ξ| from the reference positions is not read.
# args, the same tuple for both passes: (v (n, 3) L/T, volume (n,) L^3, horizon (n,) L, J_N (n,),
# bond_damage (nb,) or empty, omega_kind, omega_table, b0, dt T, Minv (n, 9) M⁺ per point,
# phi (nb, 3), L (n, 9) 1/T, J_NP1 (n,), m0 (n,) L^3).
def moment_term(i, j, b, ex, ey, ez, L, z, p, args):
    """The bond's terms of the weighted volume and the moment matrix (10 numbers)."""
    v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, b0 = args[:8]
    return moment_bond(i, j, b, ex, ey, ez, L, volume, horizon, J_N, bond_damage, omega_kind, omega_table, b0)


def gradient_load(i, args):
    """Point i's M⁺ (9 numbers) from Minv (args[9])."""
    return load9(args[9], i)


def gradient_term(i, j, b, ex, ey, ez, L, z, p, args):
    """φ of the bond into phi[b]; its terms of L_i and m0_i (10 numbers)."""
    v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, b0 = args[:8]
    return gradient_bond(i, j, b, ex, ey, ez, L, p, v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, b0, args[10])


def gradient_finish(i, acc, p, args):
    """L_i, J_NP1,i and m0_i written (:func:`gradient_point`); returns acc."""
    gradient_point(i, (acc[0], acc[1], acc[2], acc[3], acc[4], acc[5], acc[6], acc[7], acc[8]), acc[9], args[3], args[8], args[11],
                   args[12], args[13])
    return acc


def deformed_length(i, j, b, ex, ey, ez, L, z, p, args):
    """l_b = sqrt((ηx ηx + ηy ηy) + ηz ηz) (L)."""
    return L


#: first pass of §8.3: out (n, 10) = (weighted volume, M row-major) per point
MOMENT = PointSum(moment_term, width=10, z_from_positions=True)
#: second pass: φ (nb, 3) of the points' bonds, L (n, 9), J_NP1 and m0 written; out (n, 10) scratch
GRADIENT = PointSum(gradient_term, point=gradient_load, finish=gradient_finish, width=10, z_from_positions=True)
#: deformed bond lengths (nb,) on current positions, for expression influence functions
DEFORMED_LENGTH = BondMap(deformed_length, z_from_positions=True)


def precompute_kernel(start, stop, offsets, neighbors, y, v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, dt,
                      phi, L, J_NP1, m0, weighted_volume, *, backend=None, x=None):
    """§8.3 for the points [start, stop) (see :func:`precompute_point`): ``MOMENT``, the
    pseudo-inverses (:func:`moment_inverse_kernel`), then ``GRADIENT``, the laws on ``backend``
    (None: the default) over the current positions y. Writes φ (nb, 3) of their bonds, L (n, 9),
    J_NP1 (n,), m0 (n,) and, when non-empty, weighted_volume (n,). ``omega_table`` is indexed
    b - offsets[start]; ``x`` (n, 3) any positions for the laws' unread |ξ| (the reference
    positions; None: y). Returns the number of points whose SVD did not converge in 30 sweeps
    per value."""
    bk = backend or default_backend()
    x = y if x is None else x
    b0 = int(offsets[start]) if stop > start else 0
    n = y.shape[0]
    W = np.empty((n, 10))
    Minv = np.empty((n, 9))
    args = (v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, b0, float(dt), Minv, phi, L, J_NP1, m0)
    bk.kernel(MOMENT)(start, stop, offsets, neighbors, x, y, args, W)
    bad = moment_inverse_kernel(start, stop, horizon, W, weighted_volume, Minv)
    bk.kernel(GRADIENT)(start, stop, offsets, neighbors, x, y, args, W)
    return int(bad)


# ------------------------------------------------------------------------------------------------
# §5.2/§5.3/§5.6: the stress updates with von Mises stress and triaxiality
# ------------------------------------------------------------------------------------------------
@njit(cache=True, inline="always")
def _powerlaw_slope(e, sy, ec, n):
    """H(e) = ((σ_y n)/ε_c) pow(1.0 + e/ε_c, n - 1.0)."""
    return ((sy * n) / ec) * math.pow(1.0 + e / ec, n - 1.0)


@njit(cache=True, error_model="numpy")
def stress_update(model, sN, di, eqps_n, dt, K, G, sy, ec, nexp, bond):
    """One unrotated stress update: (σ̂_NP1, eqps_NP1, vm, triaxiality, triaxiality_written).

    model ELASTIC: §5.2 (trial stress, vm of the trial deviator); PERFECTLY_PLASTIC: §5.3 with
    the strict test vm > σ_y and (5.3a), triaxiality ((σ0 + σ4) + σ8)/(3.0 max(1e-20, vm))
    always; POWER_LAW: §5.6, σ_y (1 + eqps/ε_c)^n with the averaged-slope Δλ; elastic when
    vm < f0 (strict, triaxiality not written at node level). Peridigm's bond-level routine
    (``bond`` True) returns to f without the node level's second test vm > f. sN: σ̂_N 9-tuple,
    di: d 9-tuple (1/T), eqps_n (-), dt (T), K, G, σ_y (M/(L T^2)), ε_c, n (-)."""
    de, dth = _strain_increment(di, dt)
    sig = _trial_stress(sN, de, dth, K, G)
    s, p = _deviator(sig)
    t = _dot9(s, s)
    vm = math.sqrt((3.0 / 2.0) * t)
    e = eqps_n
    if model == ELASTIC:
        return sig, e, vm, 0.0, False
    if model == PERFECTLY_PLASTIC:
        if vm > sy:
            mag_tr = _floor(math.sqrt(t))
            sig, r, vm = _return_to(s, p, mag_tr, sy)
            e = _eqps_update(de, r, mag_tr, sN, G, eqps_n)
        return sig, e, vm, ((sig[0] + sig[4]) + sig[8]) / (3.0 * _floor(vm)), True
    # POWER_LAW
    mag_tr = _floor(math.sqrt(t))
    f0 = sy * math.pow(1.0 + eqps_n / ec, nexp)
    if vm < f0:
        return sig, e, vm, 0.0, bond
    ebar = _dot9(s, de) / mag_tr
    q, _ = _deviator(sN)
    mq = math.sqrt(_dot9(q, q))  # no 1e-20 floor here
    hN = _powerlaw_slope(eqps_n, sy, ec, nexp)
    dlam = ((((6.0 * ebar) * G) - SQRT_6 * f0) + 3.0 * mq) / (2.0 * (hN + 3.0 * G))
    e1 = eqps_n + SQRT_2_3 * dlam
    H = 0.5 * (hN + _powerlaw_slope(e1, sy, ec, nexp))
    dlam = ((((6.0 * ebar) * G) - SQRT_6 * f0) + 3.0 * mq) / (2.0 * (H + 3.0 * G))
    e1 = eqps_n + SQRT_2_3 * dlam
    f = sy * math.pow(1.0 + e1 / ec, nexp)
    if bond or vm > f:
        sig, r, vm = _return_to(s, p, mag_tr, f)
        e = _eqps_update(de, r, mag_tr, sN, G, eqps_n)
    return sig, e, vm, ((sig[0] + sig[4]) + sig[8]) / (3.0 * _floor(vm)), True


# ------------------------------------------------------------------------------------------------
# §8.4 computeForce: bond kinematics, bond stresses, non-homogeneity integral, force states
# ------------------------------------------------------------------------------------------------
@njit(cache=True, inline="always")
def _bond_velocity_gradient(Li, Lj, e0, e1, e2, lsq, u0, u1, u2):
    """L_b = L̄ + ((Δv - L̄ η) ⊗ η)/|η|², L̄ = 0.5 (L_i + L_j), |η|² = l·l."""
    m0 = 0.5 * (Li[0] + Lj[0])
    m1 = 0.5 * (Li[1] + Lj[1])
    m2 = 0.5 * (Li[2] + Lj[2])
    m3 = 0.5 * (Li[3] + Lj[3])
    m4 = 0.5 * (Li[4] + Lj[4])
    m5 = 0.5 * (Li[5] + Lj[5])
    m6 = 0.5 * (Li[6] + Lj[6])
    m7 = 0.5 * (Li[7] + Lj[7])
    m8 = 0.5 * (Li[8] + Lj[8])
    a0 = u0 - ((m0 * e0 + m1 * e1) + m2 * e2)
    a1 = u1 - ((m3 * e0 + m4 * e1) + m5 * e2)
    a2 = u2 - ((m6 * e0 + m7 * e1) + m8 * e2)
    return (
        m0 + (a0 * e0) / lsq, m1 + (a0 * e1) / lsq, m2 + (a0 * e2) / lsq,
        m3 + (a1 * e0) / lsq, m4 + (a1 * e1) / lsq, m5 + (a1 * e2) / lsq,
        m6 + (a2 * e0) / lsq, m7 + (a2 * e1) / lsq, m8 + (a2 * e2) / lsq,
    )


@njit(cache=True, inline="always")
def _projector(e0, e1, e2, lsq):
    """P⊥ = I - η⊗η/|η|² with |η|² the sum of squares, entered as Peridigm does."""
    p0 = 1.0 - (e0 * e0) / lsq
    p1 = ((-e0) * e1) / lsq
    p2 = ((-e0) * e2) / lsq
    p4 = 1.0 - (e1 * e1) / lsq
    p5 = ((-e1) * e2) / lsq
    p8 = 1.0 - (e2 * e2) / lsq
    return (p0, p1, p2, p1, p4, p5, p2, p5, p8)


# The bond level's physics, shared by the loop laws and the per-point helper of the tangent's
# probes (arrays as arguments: a law's function unpacks its args and calls them; inlined).
@njit(cache=True, inline="always", error_model="numpy")
def bond_stress(i, j, b, e0, e1, e2, length, own, v, volume, J_N, bond_damage, omega_kind, omega_table, b0, dt, L, m0,
                Vb_N, Rb_N, Sb_N, eb_N, prm, Vb_NP1, Rb_NP1, Sb_NP1, eb_NP1):
    """§8.4 steps 2, 4-7 for bond b = i→j (η = (e0, e1, e2), l = |η|): bond velocity gradient,
    bond Flanagan-Taylor update, bond stress update (V, R, σ̂ and eqps of NP1 written at [b]);
    returns the bond's term of the non-homogeneity integral, sc (σ_b P⊥) with
    σ_b = R_b (σ̂_b R_bᵀ), P⊥ = I - η⊗η/|η|², sc = (ω (0.5/m0_i + 0.5/m0_j)) (J_N,j V_j),
    ω = (1 - d) ω(l, δ_i), as 9 numbers (zeros where ω <= 0). ``own`` = (L_i, m0_i, δ_i) of point
    i (:func:`stress_own`), ``prm`` = (model, K, G, σ_y, ε_c, n) of :func:`stress_update`."""
    Li, m0i, delta = own
    model, K, G, sy, ec, nexp = prm
    plastic = eb_N.shape[0] > 0
    Lb = _bond_velocity_gradient(Li, load9(L, j), e0, e1, e2, length * length, v[j, 0] - v[i, 0], v[j, 1] - v[i, 1], v[j, 2] - v[i, 2])
    V1, R1, db = flanagan_taylor(Lb, load9(Vb_N, b), load9(Rb_N, b), dt)
    store9(Vb_NP1, b, V1)
    store9(Rb_NP1, b, R1)
    sh, e, _, _, _ = stress_update(model, load9(Sb_N, b), db, eb_N[b] if plastic else 0.0, dt, K, G, sy, ec, nexp, True)
    store9(Sb_NP1, b, sh)
    if plastic:
        eb_NP1[b] = e
    om = (1.0 - _damage(bond_damage, b)) * omega(omega_kind, length, delta, omega_table, b - b0)
    if om > 0.0:
        sig = matmul(R1, matmul_nt(sh, R1))
        Y = matmul(sig, _projector(e0, e1, e2, (e0 * e0 + e1 * e1) + e2 * e2))
        sc = (om * (0.5 / m0i + 0.5 / m0[j])) * (J_N[j] * volume[j])
        return (sc * Y[0], sc * Y[1], sc * Y[2], sc * Y[3], sc * Y[4], sc * Y[5], sc * Y[6], sc * Y[7], sc * Y[8])
    return ZERO


@njit(cache=True, inline="always", error_model="numpy")
def bond_force(i, j, b, e0, e1, e2, length, own, J_N, bond_damage, omega_kind, omega_table, b0, phi, Rb_NP1, Sb_NP1):
    """§8.4 step 8: T_b = (J_N,i T) J_N,j with T_a = ((ω/m0_i) (σ_b η)_a)/|η|² + (𝒩_i φ_b)_a
    (force per volume squared; zero where ω <= 0), σ_b from the NP1 bond state; ``own`` =
    (𝒩_i, m0_i, J_N,i, δ_i) of point i (:func:`force_own`)."""
    Ni, m0i, Ji, delta = own
    om = (1.0 - _damage(bond_damage, b)) * omega(omega_kind, length, delta, omega_table, b - b0)
    if om > 0.0:
        R1 = load9(Rb_NP1, b)
        sig = matmul(R1, matmul_nt(load9(Sb_NP1, b), R1))  # the same σ_b as in bond_stress, bit for bit
        lsq = (e0 * e0 + e1 * e1) + e2 * e2
        c = om / m0i
        px = phi[b, 0]
        py = phi[b, 1]
        pz = phi[b, 2]
        tx = ((c * ((sig[0] * e0 + sig[1] * e1) + sig[2] * e2)) / lsq) + ((Ni[0] * px + Ni[1] * py) + Ni[2] * pz)
        ty = ((c * ((sig[3] * e0 + sig[4] * e1) + sig[5] * e2)) / lsq) + ((Ni[3] * px + Ni[4] * py) + Ni[5] * pz)
        tz = ((c * ((sig[6] * e0 + sig[7] * e1) + sig[8] * e2)) / lsq) + ((Ni[6] * px + Ni[7] * py) + Ni[8] * pz)
        Jj = J_N[j]
        return (Ji * tx) * Jj, (Ji * ty) * Jj, (Ji * tz) * Jj
    return 0.0, 0.0, 0.0


# not a loop law: probe helper of fd_tangent_rate (one family inside a parallel iteration); the laws are BOND_STRESS and BOND_FORCE
@njit(cache=True, error_model="numpy")
def bond_force_point(i, offsets, neighbors, y, v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, b0, dt, L, m0, phi,
                     Vb_N, Rb_N, Sb_N, eb_N, model, K, G, sy, ec, nexp, Vb_NP1, Rb_NP1, Sb_NP1, eb_NP1, integral, T):
    """§8.4 steps 2, 4-8 for the bonds of point i: bond velocity gradient, bond Flanagan-Taylor
    update, bond stress update, σ_b = R_b (σ̂_b R_bᵀ), the non-homogeneity integral 𝒩_i (into row
    i of ``integral`` when non-empty) and the force states T_b = (J_N,i T) J_N,j with
    T_a = ((ω/m0_i) (σ_b η)_a)/|η|² + (𝒩 φ_b)_a, ω = (1 - d) ω(l, δ) > 0 (T_b = 0 otherwise).
    ``eb_N``/``eb_NP1`` are empty for the elastic model. The arithmetic of ``BOND_STRESS`` and
    ``BOND_FORCE`` (the same helpers)."""
    lo = offsets[i]
    hi = offsets[i + 1]
    prm = (model, K, G, sy, ec, nexp)
    own = (load9(L, i), m0[i], horizon[i])
    N0 = N1 = N2 = N3 = N4 = N5 = N6 = N7 = N8 = 0.0
    for b in range(lo, hi):
        j = neighbors[b]
        e0, e1, e2, length = _bond(i, j, y)
        t = bond_stress(i, j, b, e0, e1, e2, length, own, v, volume, J_N, bond_damage, omega_kind, omega_table, b0, dt, L, m0,
                        Vb_N, Rb_N, Sb_N, eb_N, prm, Vb_NP1, Rb_NP1, Sb_NP1, eb_NP1)
        N0 += t[0]
        N1 += t[1]
        N2 += t[2]
        N3 += t[3]
        N4 += t[4]
        N5 += t[5]
        N6 += t[6]
        N7 += t[7]
        N8 += t[8]
    Ni = (N0, N1, N2, N3, N4, N5, N6, N7, N8)
    if integral.shape[0] > 0:
        store9(integral, i, Ni)
    own = (Ni, m0[i], J_N[i], horizon[i])
    for b in range(lo, hi):
        j = neighbors[b]
        e0, e1, e2, length = _bond(i, j, y)
        T[b, 0], T[b, 1], T[b, 2] = bond_force(i, j, b, e0, e1, e2, length, own, J_N, bond_damage, omega_kind, omega_table, b0, phi,
                                               Rb_NP1, Sb_NP1)


# Loop laws (peridyn.core.traversal), run on the current positions: the bond context's
# (ex, ey, ez) = η = y_j - y_i and L = l = |η| (L); |ξ| from the reference positions is not read.
# args, the same tuple for both passes: (v (n, 3) L/T, volume (n,) L^3, horizon (n,) L, J_N (n,),
# bond_damage (nb,) or empty, omega_kind, omega_table, b0, dt T, L (n, 9) 1/T, m0 (n,) L^3, phi (nb, 3), Vb_N, Rb_N, Sb_N
# (nb, 9), eb_N (nb,) or empty, model, K, G, sy, ec, nexp, Vb_NP1, Rb_NP1, Sb_NP1 (nb, 9), eb_NP1
# (nb,) or empty, N (n, 9) the first pass's output, the non-homogeneity integrals); flat (a tuple of
# numbers inside args is no parallel kernel argument).
def stress_own(i, args):
    """(L_i, m0_i, δ_i) of point i."""
    return load9(args[9], i), args[10][i], args[2][i]


def bond_stress_term(i, j, b, ex, ey, ez, L, z, p, args):
    """The bond's NP1 state written; its term of 𝒩_i (9 numbers, :func:`bond_stress`), p = (L_i, m0_i, δ_i)."""
    (v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, b0, dt, Lg, m0, phi, Vb_N, Rb_N, Sb_N, eb_N,
     model, K, G, sy, ec, nexp, Vb_NP1, Rb_NP1, Sb_NP1, eb_NP1, N) = args
    return bond_stress(i, j, b, ex, ey, ez, L, p, v, volume, J_N, bond_damage, omega_kind, omega_table, b0, dt, Lg, m0,
                       Vb_N, Rb_N, Sb_N, eb_N, (model, K, G, sy, ec, nexp), Vb_NP1, Rb_NP1, Sb_NP1, eb_NP1)


def force_own(i, args):
    """(𝒩_i from the first pass's output args[26], m0_i, J_N,i, δ_i) of point i."""
    return load9(args[26], i), args[10][i], args[3][i], args[2][i]


def bond_force_term(i, j, b, ex, ey, ez, L, z, p, args):
    """T_b (3 numbers, :func:`bond_force`), p = (𝒩_i, m0_i, J_N,i, δ_i)."""
    (v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, b0, dt, Lg, m0, phi, Vb_N, Rb_N, Sb_N, eb_N,
     model, K, G, sy, ec, nexp, Vb_NP1, Rb_NP1, Sb_NP1, eb_NP1, N) = args
    return bond_force(i, j, b, ex, ey, ez, L, p, J_N, bond_damage, omega_kind, omega_table, b0, phi, Rb_NP1, Sb_NP1)


#: §8.4 steps 2, 4-7: the NP1 bond states written, out (n, 9) = 𝒩_i (Nonhomogeneous_Integral)
BOND_STRESS = PointSum(bond_stress_term, point=stress_own, width=9, z_from_positions=True)
#: §8.4 step 8: out (nb, 3) = T of the points' bonds, from 𝒩 (args[26]) of the first pass
BOND_FORCE = BondMap(bond_force_term, point=force_own, width=3, z_from_positions=True)


# ------------------------------------------------------------------------------------------------
# §8.4 node level (outputs only): F, Green-Lagrange strain, V, R, d, σ̂, σ, vm, eqps, triaxiality
# ------------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def node_point(i, L, dt, F_N, F_NP1, E, V_N, R_N, V_NP1, R_NP1, d, S_N, S_NP1, sigma, e_N, e_NP1, vm, triax,
               model, K, G, sy, ec, nexp):
    """Node-level quantities of point i (§8.4 steps 3, 5, 6): F_NP1 = F_N + (L F_N) dt,
    E = 0.5 Fᵀ F - 0.5 I (when ``E`` is non-empty), FT(L, V_N, R_N, dt), the node stress update
    (eqps, triaxiality when their arrays are non-empty) and σ = R (σ̂ Rᵀ) (when ``sigma`` is
    non-empty)."""
    Li = load9(L, i)
    FN = load9(F_N, i)
    Fd = matmul(Li, FN)
    F1 = (
        FN[0] + Fd[0] * dt, FN[1] + Fd[1] * dt, FN[2] + Fd[2] * dt,
        FN[3] + Fd[3] * dt, FN[4] + Fd[4] * dt, FN[5] + Fd[5] * dt,
        FN[6] + Fd[6] * dt, FN[7] + Fd[7] * dt, FN[8] + Fd[8] * dt,
    )
    store9(F_NP1, i, F1)
    if E.shape[0] > 0:
        C = matmul_tn(F1, F1)
        store9(E, i, (
            0.5 * C[0] - 0.5, 0.5 * C[1], 0.5 * C[2],
            0.5 * C[3], 0.5 * C[4] - 0.5, 0.5 * C[5],
            0.5 * C[6], 0.5 * C[7], 0.5 * C[8] - 0.5,
        ))
    V1, R1, di = flanagan_taylor(Li, load9(V_N, i), load9(R_N, i), dt)
    store9(V_NP1, i, V1)
    store9(R_NP1, i, R1)
    store9(d, i, di)
    plastic = e_N.shape[0] > 0
    sh, e, v, tr, wrote = stress_update(model, load9(S_N, i), di, e_N[i] if plastic else 0.0, dt, K, G, sy, ec, nexp, False)
    store9(S_NP1, i, sh)
    if plastic:
        e_NP1[i] = e
    if vm.shape[0] > 0:
        vm[i] = v
    if wrote and triax.shape[0] > 0:
        triax[i] = tr
    if sigma.shape[0] > 0:
        store9(sigma, i, matmul(R1, matmul_nt(sh, R1)))


@njit(cache=True, parallel=True, error_model="numpy")
def node_kernel(start, stop, L, dt, F_N, F_NP1, E, V_N, R_N, V_NP1, R_NP1, d, S_N, S_NP1, sigma, e_N, e_NP1, vm, triax,
                model, K, G, sy, ec, nexp):
    """:func:`node_point` for the points [start, stop). Empty arrays switch the optional parts
    off: E (Green_Lagrange_Strain), sigma (Cauchy_Stress), e_N/e_NP1 (elastic
    model), vm (Von_Mises_Stress), triax (Stress_Triaxiality)."""
    for i in prange(start, stop):
        node_point(i, L, dt, F_N, F_NP1, E, V_N, R_N, V_NP1, R_NP1, d, S_N, S_NP1, sigma, e_N, e_NP1, vm, triax, model, K, G, sy, ec, nexp)
