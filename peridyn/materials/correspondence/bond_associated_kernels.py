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

import numpy as np
from numba import njit, prange

from ...core.traversal import BondMap, PointSum
from ...kernels import default_backend
# the constitutive model codes the force kernels take, and their stress update (node and bond)
from .bond_associated_stress import ELASTIC, MAX_NEWTON, PERFECT, POWER_LAW, SATURATION, _stress_update, stress_update  # noqa: F401
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

#: status codes of :func:`force_kernel`
SINGULAR_NODE_F, SINGULAR_BOND_F, NO_CONVERGENCE = 1, 2, 3
EMPTY = np.zeros(0)


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
