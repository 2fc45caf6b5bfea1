"""Numba kernels of the ``Pals`` material (:mod:`peridyn.materials.pals`; PERIDIGM_MODELS.md §4).

Shapes: x, y (n, 3) reference and current positions (L); volume (n,) (L^3); offsets (n+1,),
neighbors (nb,) int32 CSR bonds; zeta (nb,) reference bond lengths (L); lam, tau (n, 6) the
dilatation and deviatoric Lagrange multipliers of each point (L^-7); per-point arrays (n,); bond_damage (nb,) or empty (no damage model). Kernels write rows
[start, stop) only, and each point is handled by one thread (``prange`` over points, no scatter).

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


@njit(cache=True, parallel=True, error_model="numpy")
def initialize_kernel(start, stop, offsets, neighbors, x, volume, kind_w, kind_s, delta, lam, tau, m):
    """Multipliers lam, tau and weighted volume m_i = sum_j (sigma |xi|^2) V_j (dimensionless) of the points
    [start, stop). Returns the first point whose matrices are singular, or -1."""
    bad = np.full(stop - start, -1, dtype=np.int64)
    for i in prange(start, stop):
        if not lagrange_point(i, offsets, neighbors, x, volume, kind_w, kind_s, delta, lam, tau):
            bad[i - start] = i
            m[i] = 0.0
            continue
        acc = 0.0
        for bnd in range(offsets[i], offsets[i + 1]):
            j = neighbors[bnd]
            a = x[j, 0] - x[i, 0]
            b = x[j, 1] - x[i, 1]
            c = x[j, 2] - x[i, 2]
            z2 = (a * a + b * b) + c * c
            s = deviatoric_influence(kind_s, delta, math.sqrt(z2), a, b, c, tau, i)
            acc += (s * z2) * volume[j]
        m[i] = acc
    for k in range(stop - start):
        if bad[k] >= 0:
            return bad[k]
    return -1


# ------------------------------------------------------------------------------------------------
# dilatation and pressure (precompute), force state, energy
# ------------------------------------------------------------------------------------------------
@njit(cache=True, parallel=True, error_model="numpy")
def bond_influence_kernel(start, stop, offsets, neighbors, x, zeta, lam, tau, kind_w, kind_s, delta, W, Sg):
    """omega (W) and sigma (Sg) of every bond of the points [start, stop) (per L^5): they depend
    on the reference bond and the point's multipliers only, so they are computed once."""
    for i in prange(start, stop):
        for bnd in range(offsets[i], offsets[i + 1]):
            j = neighbors[bnd]
            a = x[j, 0] - x[i, 0]
            b = x[j, 1] - x[i, 1]
            c = x[j, 2] - x[i, 2]
            r = zeta[bnd]
            W[bnd] = dilatation_influence(kind_w, delta, r, a, b, c, lam, i)
            Sg[bnd] = deviatoric_influence(kind_s, delta, r, a, b, c, tau, i)


@njit(cache=True, inline="always", error_model="numpy")
def point_theta_p(i, offsets, neighbors, zeta, y, volume, W, Sg, m_i, K, two_mu, bond_damage):
    """(theta_i, p_i) of point i (see :func:`precompute_kernel`)."""
    has_damage = bond_damage.shape[0] > 0
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
        V = volume[j]
        if has_damage:
            keep = 1.0 - float(bond_damage[bnd])
            th += keep * (((W[bnd] * r) * e) * V)
            pp += keep * ((-((two_mu * (Sg[bnd] * r)) / 3.0) * e) * V)
        else:
            th += ((W[bnd] * r) * e) * V
            pp += (-((two_mu * (Sg[bnd] * r)) / 3.0) * e) * V
    return th, pp + (K + (two_mu * m_i) / 9.0) * th


@njit(cache=True, inline="always", error_model="numpy")
def point_force_state(i, offsets, neighbors, zeta, y, W, Sg, theta_i, p_i, two_mu, bond_damage, t, t0):
    """t[t0 + k] = force state of point i's k-th bond (see :func:`force_state_kernel`)."""
    has_damage = bond_damage.shape[0] > 0
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
        ed = e - (theta_i * r) / 3.0
        tb = (p_i * W[bnd]) * r + (two_mu * Sg[bnd]) * ed
        if has_damage:
            tb = (1.0 - float(bond_damage[bnd])) * tb
        t[t0 + bnd - o] = tb


@njit(cache=True, parallel=True, error_model="numpy")
def precompute_kernel(start, stop, offsets, neighbors, zeta, y, volume, W, Sg, m, K, mu, bond_damage, theta, p):
    """theta_i = sum_j (1-d) ((omega r) e) V_j (dimensionless; no 3/m factor: the multipliers
    normalise omega) and the Pals pressure p_i = sum_j (1-d) (-((2 mu)(sigma r))/3) e V_j
    + (K + (2 mu) m_i / 9) theta_i (stress, M L^-1 T^-2) of the points [start, stop).
    W, Sg (nb,): omega and sigma of every bond (:func:`bond_influence_kernel`)."""
    for i in prange(start, stop):
        theta[i], p[i] = point_theta_p(i, offsets, neighbors, zeta, y, volume, W, Sg, m[i], K, 2.0 * mu, bond_damage)


@njit(cache=True, parallel=True, error_model="numpy")
def force_state_kernel(start, stop, offsets, neighbors, zeta, y, W, Sg, theta, p, mu, bond_damage, t):
    """Scalar force state t[b] = (1-d) ((p_i omega) r + ((2 mu) sigma) e_d), e_d = e - (theta_i r)/3
    (M L^-5 T^-2), of every bond of the points [start, stop)."""
    for i in prange(start, stop):
        point_force_state(i, offsets, neighbors, zeta, y, W, Sg, theta[i], p[i], 2.0 * mu, bond_damage, t, offsets[i])


@njit(cache=True, parallel=True, error_model="numpy")
def stored_energy_kernel(start, stop, offsets, neighbors, zeta, y, volume, Sg, theta, K, mu, bond_damage, W):
    """W_i = ((K/2) theta) theta + mu sum_j (1-d) ((sigma e_d) e_d) V_j (energy per volume; no 1/2
    on the deviatoric term, as in Peridigm: the force above is its derivative)."""
    has_damage = bond_damage.shape[0] > 0
    for i in prange(start, stop):
        th = theta[i]
        acc = 0.0
        for bnd in range(offsets[i], offsets[i + 1]):
            j = neighbors[bnd]
            r = zeta[bnd]
            ex = y[j, 0] - y[i, 0]
            ey = y[j, 1] - y[i, 1]
            ez = y[j, 2] - y[i, 2]
            e = math.sqrt((ex * ex + ey * ey) + ez * ez) - r
            ed = e - (r * th) / 3.0
            term = ((Sg[bnd] * ed) * ed) * volume[j]
            if has_damage:
                term = (1.0 - float(bond_damage[bnd])) * term
            acc += term
        W[i] = ((0.5 * K) * th) * th + mu * acc


# ------------------------------------------------------------------------------------------------
# the implicit tangent: Peridigm's central finite differences (Pals has no other), compiled
# ------------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def _probe(i, offsets, neighbors, zeta, y, volume, W, Sg, m, K, two_mu, bond_damage, t, F):
    """Force density of point i's bonds on S_i = [N_i..., i] (F (3 |S_i|,), the solvers'
    ``local_force_kernel`` arithmetic) with theta_i, p_i re-evaluated at the current y."""
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
