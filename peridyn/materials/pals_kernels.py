"""Kernels and loop laws of the ``Pals`` material (:mod:`peridyn.materials.pals`;
PERIDIGM_MODELS.md §4).

Shapes: x, y (n, 3) reference and current positions (L); volume (n,) (L^3); offsets (n+1,),
neighbors (nb,) int32 CSR bonds; zeta (nb,) reference bond lengths (L); lam, tau (n, 6) the
dilatation and deviatoric Lagrange multipliers of each point (L^-7); per-point arrays (n,);
bond_damage (nb,) or empty (no damage model). The bond influences, the weighted volume, the
dilatation and pressure, the force state and the energy are loop laws
(:mod:`peridyn.core.traversal`) that the run's backend compiles; the Lagrange multipliers (a
6x6 solve per point) and the finite-difference tangent are written by hand. Every loop writes
the rows [start, stop) only, and each point is handled by one thread (no scatter).

Notation of one bond of point i: xi = (a, b, c) = x_j - x_i, r = |xi| = sqrt((a a + b b) + c c),
eta = y_j - y_i, e = |eta| - r (the extension). The bases of the multipliers are

    dilatation  E_k   = (a a, b b, c c, 2 (a b), 2 (a c), 2 (b c))                     (L^2)
    deviatoric  eps_k = (a a / r - r/3, b b / r - r/3, c c / r - r/3, 2 (a b)/r, 2 (a c)/r, 2 (b c)/r)  (L)

and the composite influence functions are

    omega(xi) = omega_0(r, delta) + (((l0 a) a + (l1 b) b) + (l2 c) c) + 2 (((l3 a) b + (l4 a) c) + (l5 b) c)
    sigma(xi) = sigma_0(r, delta) + sum_k (t_k eps_k) eps_k

with omega_0, sigma_0 the named influence functions of :mod:`peridyn.core.influence` (One,
Parabolic Decay, Gaussian). The multipliers make sum_j omega E_k V_j = (1, 1, 1, 0, 0, 0) and
sum_j sigma eps_k^2 V_j = (2/3, 2/3, 2/3, 2, 2, 2) at every point: the dilatation and the
deviatoric energy are exact for every homogeneous deformation, surface points included.
Units: omega and sigma are per L^5 (theta = sum omega r e V is dimensionless), omega_0 and
sigma_0 are taken in those units, as Peridigm does (1 means 1 L^-5).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..core.influence import omega as omega_0
from ..core.assembly import local_scalar_state_force_kernel, scatter_local_kernel
from ..core.traversal import BondMap, PointSum

NUM_MULTIPLIERS = 6
NO_TABLE = np.zeros(0)  # omega_0 is always a named function (never a per-bond table)
#: kernel status codes
OK, SINGULAR = 0, 1


# ------------------------------------------------------------------------------------------------
# the bond functions
# ------------------------------------------------------------------------------------------------
@njit(cache=True, inline="always", error_model="numpy")
def dilatation_influence(kind, delta, r, a, b, c, lam, i):
    """omega(xi) of point i's bond (a, b, c) of length r (dimensionless)."""
    D = (((lam[i, 0] * a) * a + (lam[i, 1] * b) * b) + (lam[i, 2] * c) * c) + 2.0 * (
        ((lam[i, 3] * a) * b + (lam[i, 4] * a) * c) + (lam[i, 5] * b) * c
    )
    return 1.0 * (omega_0(kind, r, delta, NO_TABLE, 0) + D)


@njit(cache=True, inline="always", error_model="numpy")
def deviatoric_influence(kind, delta, r, a, b, c, tau, i):
    """sigma(xi) of point i's bond (a, b, c) of length r (dimensionless)."""
    avg = r / 3.0
    e0 = (a * a) / r - avg
    e1 = (b * b) / r - avg
    e2 = (c * c) / r - avg
    e3 = (2.0 * (a * b)) / r
    e4 = (2.0 * (a * c)) / r
    e5 = (2.0 * (b * c)) / r
    T = (tau[i, 0] * e0) * e0
    T = T + (tau[i, 1] * e1) * e1
    T = T + (tau[i, 2] * e2) * e2
    T = T + (tau[i, 3] * e3) * e3
    T = T + (tau[i, 4] * e4) * e4
    T = T + (tau[i, 5] * e5) * e5
    return 1.0 * (omega_0(kind, r, delta, NO_TABLE, 0) + T)


# ------------------------------------------------------------------------------------------------
# Lagrange multipliers (initialize)
# ------------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def lu_solve_6(K, rhs):
    """Solve K z = rhs in place (rhs becomes z) by LU with partial pivoting (LAPACK dgetf2 and
    dgetrs order: first largest pivot, reciprocal scaling, right-looking updates). K (6, 6) is
    overwritten. Returns False for an exactly zero pivot (LAPACK's INFO > 0)."""
    n = NUM_MULTIPLIERS
    piv = np.empty(n, dtype=np.int64)
    for j in range(n):
        p = j
        big = abs(K[j, j])
        for r in range(j + 1, n):
            if abs(K[r, j]) > big:
                big = abs(K[r, j])
                p = r
        piv[j] = p
        if K[p, j] == 0.0:
            return False
        if p != j:
            for c in range(n):
                tmp = K[j, c]
                K[j, c] = K[p, c]
                K[p, c] = tmp
        inv = 1.0 / K[j, j]
        for r in range(j + 1, n):
            K[r, j] *= inv
        for c in range(j + 1, n):
            f = K[j, c]
            if f != 0.0:
                for r in range(j + 1, n):
                    K[r, c] -= K[r, j] * f
    for j in range(n):  # row interchanges, then L (unit diagonal), then U
        p = piv[j]
        if p != j:
            tmp = rhs[j]
            rhs[j] = rhs[p]
            rhs[p] = tmp
    for c in range(n):
        v = rhs[c]
        if v != 0.0:
            for r in range(c + 1, n):
                rhs[r] -= v * K[r, c]
    for c in range(n - 1, -1, -1):
        if rhs[c] != 0.0:
            rhs[c] /= K[c, c]
            v = rhs[c]
            for r in range(c):
                rhs[r] -= v * K[r, c]
    return True


@njit(cache=True, error_model="numpy")
def lagrange_point(i, offsets, neighbors, x, volume, kind_w, kind_s, delta, lam, tau):
    """The multipliers lam[i], tau[i] of point i (PERIDIGM_MODELS.md §4, steps 1-5). Returns
    False when a matrix is singular."""
    n = NUM_MULTIPLIERS
    Kd = np.zeros((n, n))
    Ks = np.zeros((n, n))
    rd = np.zeros(n)
    rs = np.zeros(n)
    E = np.empty(n)
    S = np.empty(n)
    xi0 = x[i, 0]
    xi1 = x[i, 1]
    xi2 = x[i, 2]
    for bnd in range(offsets[i], offsets[i + 1]):
        j = neighbors[bnd]
        V = volume[j]
        a = x[j, 0] - xi0
        b = x[j, 1] - xi1
        c = x[j, 2] - xi2
        a2 = a * a
        b2 = b * b
        c2 = c * c
        ab = a * b
        ac = a * c
        bc = b * c
        E[0] = a2
        E[1] = b2
        E[2] = c2
        E[3] = 2.0 * ab
        E[4] = 2.0 * ac
        E[5] = 2.0 * bc
        for k in range(n):
            for m in range(n):
                Kd[k, m] += (E[k] * E[m]) * V
        r = math.sqrt((a2 + b2) + c2)
        avg = r / 3.0
        S[0] = a2 / r - avg
        S[1] = b2 / r - avg
        S[2] = c2 / r - avg
        S[3] = (2.0 * ab) / r
        S[4] = (2.0 * ac) / r
        S[5] = (2.0 * bc) / r
        for k in range(n):
            sk2 = S[k] * S[k]
            for m in range(n):
                Ks[k, m] += (sk2 * (S[m] * S[m])) * V
        w0 = omega_0(kind_w, r, delta, NO_TABLE, 0)
        s0 = omega_0(kind_s, r, delta, NO_TABLE, 0)
        for k in range(n):
            rd[k] += (w0 * E[k]) * V
            rs[k] += ((s0 * S[k]) * S[k]) * V
    c23 = 2.0 / 3.0
    for k in range(3):
        rd[k] = 1.0 - rd[k]
        rs[k] = c23 - rs[k]
    for k in range(3, n):
        rd[k] = 0.0 - rd[k]
        rs[k] = 2.0 - rs[k]
    trace = 0.0
    for k in range(n):
        trace += Kd[k, k]
    for k in range(n):  # planar (or linear) families: the missing directions are fixed at zero
        if Kd[k, k] / trace < 1.0e-15:
            for m in range(n):
                Kd[k, m] = 0.0
                Kd[m, k] = 0.0
                Ks[k, m] = 0.0
                Ks[m, k] = 0.0
            Kd[k, k] = 1.0
            Ks[k, k] = 1.0
            rd[k] = 0.0
            rs[k] = 0.0
    if not lu_solve_6(Kd, rd) or not lu_solve_6(Ks, rs):
        return False
    for k in range(n):
        lam[i, k] = rd[k]
        tau[i, k] = rs[k]
    return True


# not a loop law: a 6x6 moment matrix pair per point, accumulated over the family and solved by LU (lagrange_point)
@njit(cache=True, parallel=True, error_model="numpy")
def multipliers_kernel(start, stop, offsets, neighbors, x, volume, kind_w, kind_s, delta, lam, tau):
    """Multipliers lam, tau of the points [start, stop). Returns the first point whose matrices
    are singular, or -1."""
    bad = np.full(stop - start, -1, dtype=np.int64)
    for i in prange(start, stop):
        if not lagrange_point(i, offsets, neighbors, x, volume, kind_w, kind_s, delta, lam, tau):
            bad[i - start] = i
    for k in range(stop - start):
        if bad[k] >= 0:
            return bad[k]
    return -1


# ------------------------------------------------------------------------------------------------
# bond influences, weighted volume, dilatation and pressure, force state, energy: loop laws
# (peridyn.core.traversal) compiled into each loop by the run's backend. Bond context (i, j, b,
# ex, ey, ez, L, z, p, args): (ex, ey, ez) = y_j - y_i of the kernel's y, L its length (L), and
# z = r = |xi| (L). The influences and the weighted volume are sums over reference bonds (the
# kernel's y is x, so (ex, ey, ez) = xi); the others over the current ones.
# W, Sg (nb,): omega and sigma of every bond; d (nb,) bond damage or empty.
# ------------------------------------------------------------------------------------------------
def dilatation_influence_bond(i, j, b, ex, ey, ez, L, z, p, args):
    """omega of bond b (per L^5); args (lam, tau, kind_w, kind_s, delta); y = x."""
    lam, tau, kind_w, kind_s, delta = args
    return dilatation_influence(kind_w, delta, z, ex, ey, ez, lam, i)


def deviatoric_influence_bond(i, j, b, ex, ey, ez, L, z, p, args):
    """sigma of bond b (per L^5); args (lam, tau, kind_w, kind_s, delta); y = x."""
    lam, tau, kind_w, kind_s, delta = args
    return deviatoric_influence(kind_s, delta, z, ex, ey, ez, tau, i)


def weighted_volume_term(i, j, b, ex, ey, ez, L, z, p, args):
    """(sigma |xi|^2) V_j, the sum m_i is dimensionless; args (V, tau, kind_s, delta); y = x."""
    volume, tau, kind_s, delta = args
    z2 = (ex * ex + ey * ey) + ez * ez
    s = deviatoric_influence(kind_s, delta, L, ex, ey, ez, tau, i)
    return (s * z2) * volume[j]


@njit(cache=True, inline="always", error_model="numpy")
def theta_p_bond(bnd, r, e, V, W, Sg, two_mu, bond_damage):
    """(1-d) ((omega r) e) V and (1-d) (-((2 mu)(sigma r))/3) e V of bond bnd: its shares of
    theta_i and of the pressure's bond sum."""
    if bond_damage.shape[0] > 0:
        keep = 1.0 - float(bond_damage[bnd])
        return keep * (((W[bnd] * r) * e) * V), keep * ((-((two_mu * (Sg[bnd] * r)) / 3.0) * e) * V)
    return ((W[bnd] * r) * e) * V, (-((two_mu * (Sg[bnd] * r)) / 3.0) * e) * V


@njit(cache=True, inline="always", error_model="numpy")
def force_state_value(bnd, r, e, W, Sg, theta_i, p_i, two_mu, bond_damage):
    """t = (1-d) ((p_i omega) r + ((2 mu) sigma) e_d), e_d = e - (theta_i r)/3 (M L^-5 T^-2)."""
    ed = e - (theta_i * r) / 3.0
    tb = (p_i * W[bnd]) * r + (two_mu * Sg[bnd]) * ed
    if bond_damage.shape[0] > 0:
        tb = (1.0 - float(bond_damage[bnd])) * tb
    return tb


def theta_point(i, args):
    """Clears the pressure's bond sum P[i] (written by ``theta_term``); args (V, W, Sg, m, K,
    two_mu, d, P)."""
    args[7][i] = 0.0
    return 0.0


def theta_term(i, j, b, ex, ey, ez, L, z, p, args):
    """The bond's share of theta_i (returned) and of p_i (added to P[i])."""
    volume, W, Sg, m, K, two_mu, bond_damage, P = args
    th, pp = theta_p_bond(b, z, L - z, volume[j], W, Sg, two_mu, bond_damage)
    P[i] += pp
    return th


def theta_finish(i, th, p, args):
    """theta_i; P[i] = its bond sum + (K + (2 mu) m_i / 9) theta_i."""
    m, K, two_mu, P = args[3], args[4], args[5], args[7]
    P[i] = P[i] + (K + (two_mu * m[i]) / 9.0) * th
    return th


def force_state_point(i, args):
    """(theta_i, p_i); args (W, Sg, theta, P, two_mu, d)."""
    return args[2][i], args[3][i]


def force_state_bond(i, j, b, ex, ey, ez, L, z, p, args):
    """t_ij (M L^-5 T^-2)."""
    W, Sg, theta, P, two_mu, bond_damage = args
    theta_i, p_i = p
    return force_state_value(b, z, L - z, W, Sg, theta_i, p_i, two_mu, bond_damage)


def energy_point(i, args):
    """theta_i; args (V, Sg, theta, K, mu, d)."""
    return args[2][i]


def stored_energy_term(i, j, b, ex, ey, ez, L, z, th, args):
    """(1-d) ((sigma e_d) e_d) V_j, e_d = e - (r theta_i)/3."""
    volume, Sg, theta, K, mu, bond_damage = args
    ed = (L - z) - (z * th) / 3.0
    term = ((Sg[b] * ed) * ed) * volume[j]
    if bond_damage.shape[0] > 0:
        term = (1.0 - float(bond_damage[b])) * term
    return term


def stored_energy_finish(i, acc, th, args):
    """W_i = ((K/2) theta) theta + mu acc (energy per volume; no 1/2 on the deviatoric term, as in
    Peridigm: the force above is its derivative)."""
    K, mu = args[3], args[4]
    return ((0.5 * K) * th) * th + mu * acc


DILATATION_INFLUENCE = BondMap(dilatation_influence_bond)
DEVIATORIC_INFLUENCE = BondMap(deviatoric_influence_bond)
WEIGHTED_VOLUME = PointSum(weighted_volume_term)
#: theta_i = sum_j (1-d) ((omega r) e) V_j (dimensionless; no 3/m factor: the multipliers
#: normalise omega) into out, and the Pals pressure p_i = sum_j (1-d) (-((2 mu)(sigma r))/3) e V_j
#: + (K + (2 mu) m_i / 9) theta_i (stress, M L^-1 T^-2) into args' P
THETA_PRESSURE = PointSum(theta_term, point=theta_point, finish=theta_finish, mirror=False)  # point writes
FORCE_STATE = BondMap(force_state_bond, point=force_state_point)
STORED_ENERGY = PointSum(stored_energy_term, point=energy_point, finish=stored_energy_finish)


# ------------------------------------------------------------------------------------------------
# one point's theta, p and force state, re-evaluated by the finite-difference tangent below
# (the laws' arithmetic, through the same bond helpers)
# ------------------------------------------------------------------------------------------------
# not a loop law: per-point helper of the tangent's probes (one family, re-evaluated at each probe); the loop law is THETA_PRESSURE
@njit(cache=True, inline="always", error_model="numpy")
def point_theta_p(i, offsets, neighbors, zeta, y, volume, W, Sg, m_i, K, two_mu, bond_damage):
    """(theta_i, p_i) of point i (see ``THETA_PRESSURE``)."""
    th = 0.0
    pp = 0.0
    yi0 = y[i, 0]
    yi1 = y[i, 1]
    yi2 = y[i, 2]
    for bnd in range(offsets[i], offsets[i + 1]):
        j = neighbors[bnd]
        r = zeta[bnd]
        ex = y[j, 0] - yi0
        ey = y[j, 1] - yi1
        ez = y[j, 2] - yi2
        e = math.sqrt((ex * ex + ey * ey) + ez * ez) - r
        dth, dpp = theta_p_bond(bnd, r, e, volume[j], W, Sg, two_mu, bond_damage)
        th += dth
        pp += dpp
    return th, pp + (K + (two_mu * m_i) / 9.0) * th


# not a loop law: per-point helper of the tangent's probes (one family, re-evaluated at each probe); the loop law is FORCE_STATE
@njit(cache=True, inline="always", error_model="numpy")
def point_force_state(i, offsets, neighbors, zeta, y, W, Sg, theta_i, p_i, two_mu, bond_damage, t, t0):
    """t[t0 + k] = force state of point i's k-th bond (see ``FORCE_STATE``)."""
    o = offsets[i]
    yi0 = y[i, 0]
    yi1 = y[i, 1]
    yi2 = y[i, 2]
    for bnd in range(o, offsets[i + 1]):
        j = neighbors[bnd]
        r = zeta[bnd]
        ex = y[j, 0] - yi0
        ey = y[j, 1] - yi1
        ez = y[j, 2] - yi2
        e = math.sqrt((ex * ex + ey * ey) + ez * ez) - r
        t[t0 + bnd - o] = force_state_value(bnd, r, e, W, Sg, theta_i, p_i, two_mu, bond_damage)


# ------------------------------------------------------------------------------------------------
# the implicit tangent: Peridigm's central finite differences (Pals has no other), compiled
# ------------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def _probe(i, offsets, neighbors, zeta, y, volume, W, Sg, m, K, two_mu, bond_damage, t, F):
    """Force density of point i's bonds on S_i = [N_i..., i] (F (3 |S_i|,), the solvers'
    ``local_scalar_state_force_kernel`` arithmetic) with theta_i, p_i re-evaluated at the current y."""
    th, pp = point_theta_p(i, offsets, neighbors, zeta, y, volume, W, Sg, m[i], K, two_mu, bond_damage)
    point_force_state(i, offsets, neighbors, zeta, y, W, Sg, th, pp, two_mu, bond_damage, t, 0)
    local_scalar_state_force_kernel(i, offsets, neighbors, y, volume, t, F)


@njit(cache=True)
def _scatter(S, Kloc, row_of_local, nrows, indptr, indices, data):
    """Add Kloc (3 |S|, 3 |S|) over the local points S to the matrix, without the points
    beyond nrows (not in the matrix)."""
    keep = np.flatnonzero(S < nrows)
    rows = np.empty(keep.shape[0], np.int64)
    for p in range(keep.shape[0]):
        rows[p] = row_of_local[S[keep[p]]]
    if keep.shape[0] == S.shape[0]:
        scatter_local_kernel(rows, Kloc, indptr, indices, data)
        return
    nk = keep.shape[0]
    sub = np.empty((3 * nk, 3 * nk))
    for p in range(nk):
        for q in range(nk):
            for d in range(3):
                for c in range(3):
                    sub[3 * p + d, 3 * q + c] = Kloc[3 * keep[p] + d, 3 * keep[q] + c]
    scatter_local_kernel(rows, sub, indptr, indices, data)


# not a loop law: tangent assembly (central differences of one point's force over its family, scattered into the 3x3-block matrix)
@njit(cache=True, error_model="numpy")
def fd_tangent_kernel(pts, offsets, neighbors, zeta, y, volume, W, Sg, m, K, mu, bond_damage, eps,
                      row_of_local, nrows, indptr, indices, data, max_degree):
    """Peridigm's central finite-difference tangent (PERIDIGM_SEMANTICS.md §11.1) of the points
    ``pts`` (in evaluation order), the solvers' Python path compiled: for each point i and each
    degree of freedom (q, c) of S_i = [N_i..., i], y_qc -/+ eps (L), point i's theta, p and force
    state re-evaluated (nothing is written to the fields), column (((F+ - F-)/eps) 0.5) V_s
    (force per length). y is restored bit for bit. Serial."""
    two_mu = 2.0 * mu
    t = np.empty(max(max_degree, 1))
    for i in pts:
        o = offsets[i]
        deg = offsets[i + 1] - o
        ns = deg + 1
        S = np.empty(ns, np.int64)
        for k in range(deg):
            S[k] = neighbors[o + k]
        S[deg] = i
        Fp = np.empty(3 * ns)
        Fm = np.empty(3 * ns)
        Kloc = np.empty((3 * ns, 3 * ns))
        for a in range(ns):
            q = S[a]
            for c in range(3):
                orig = y[q, c]
                y[q, c] = orig - eps
                _probe(i, offsets, neighbors, zeta, y, volume, W, Sg, m, K, two_mu, bond_damage, t, Fm)
                y[q, c] = orig + eps
                _probe(i, offsets, neighbors, zeta, y, volume, W, Sg, m, K, two_mu, bond_damage, t, Fp)
                y[q, c] = orig
                for r in range(ns):
                    Vs = volume[S[r]]
                    for d in range(3):
                        Kloc[3 * r + d, 3 * a + c] = (((Fp[3 * r + d] - Fm[3 * r + d]) / eps) * 0.5) * Vs
        _scatter(S, Kloc, row_of_local, nrows, indptr, indices, data)
