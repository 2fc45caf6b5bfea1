"""The exact tangent of ``Multiphysics Elastic`` (PERIDIGM_MODELS.md §7): 4x4 blocks
d(f V, flow V)/d(y, p), Peridigm's AD Jacobian derived by hand.

For point i with family S_i = [i, N_i...] (Peridigm's local order), its bonds b = i->j give
(eta = y_j - y_i, L = |eta|, n = eta / L, e = L - zeta (- a_T dT_i zeta)):

* dilatation: d theta_i / dy_j = g_b n, d theta_i / dy_i = -sum_b g_b n, g_b = 3 omega (1-d) zeta V_j / m;
* force state t = (1-d)(c1 zeta + (1-d) omega alpha e), c1 = omega theta (3K/m - alpha/3) - (3 omega/m) p_i:
  dt/dtheta = (1-d) omega (3K/m - alpha/3) zeta, dt/de = (1-d)^2 omega alpha, dt/dp_i = -(1-d)(3 omega/m) zeta;
* F = t n with dn/dy_j = (I - n n^T)/L = -dn/dy_i; F V_j adds to f_i, -F V_i to f_j;
* flow q = C k_e' L^-4 (p_j - p_i) with k_e' = (1-s) k_bar L^2 + s k_max, s the logistic factor
  (constant in y): dq/deta = C (p_j - p_i) ((1-s) 2 k_bar L^-4 - 4 k_e' L^-6) eta,
  dq/dp_j = C k_e' L^-4 = -dq/dp_i; q V_j adds to flow_i, -q V_i to flow_j.

Every row of the local matrix is multiplied by the volume of its point, and the local matrices
are added into the 4x4-block BSR matrix point by point in Peridigm's evaluation order.

These loops are written by hand, not as loop laws (:mod:`peridyn.core.traversal`): each point
fills a dense local matrix over its whole family (columns for every neighbor, rows for the
reactions) that is then scattered into the block-sparse matrix, which none of the three laws
(a sum per point, a value per bond, a pair force) expresses.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..core.influence import omega


@njit(cache=True)
def block_position(indptr, indices, row, col):
    """Position of block (row, col) in a BSR matrix with sorted column indices (-1: absent)."""
    lo = indptr[row]
    hi = indptr[row + 1]
    while lo < hi:
        mid = (lo + hi) // 2
        c = indices[mid]
        if c < col:
            lo = mid + 1
        elif c > col:
            hi = mid
        else:
            return mid
    return -1


# not a loop law: tangent assembly (a dense local 4 ns x 4 ns Jacobian per point over its family, then added into a 4x4-block BSR matrix)
@njit(cache=True, error_model="numpy")
def local_coupled_jacobian(i, offsets, neighbors, zeta, y, volume, m, theta, scf, p, K, mu, omega_kind, delta, omega_table,
                           bond_damage, dT, alpha_T, c_T, k, rho_f, mu_f, k_max, a_p, d_c, S, Kl):
    """Point i's local Jacobian Kl (4 ns, 4 ns) over S = [i, N_i...] (filled into S): rows
    d(f_s V_s)/d(y, p) (force) and d(flow_s V_s)/d(y, p) (flow) of i's bonds only."""
    o = offsets[i]
    nb = offsets[i + 1] - o
    ns = nb + 1
    S[0] = i
    for a in range(1, ns):
        S[a] = neighbors[o + a - 1]
    for r in range(4 * ns):
        for c in range(4 * ns):
            Kl[r, c] = 0.0
    has_damage = bond_damage.shape[0] > 0
    thermal = dT.shape[0] > 0
    Vi = volume[i]
    mi = m[i]
    # -- force: d theta_i / dy over S -----------------------------------------------------------
    if mi != 0.0:
        dth = np.zeros((ns, 3))
        for a in range(1, ns):
            b = o + a - 1
            j = S[a]
            e0 = y[j, 0] - y[i, 0]
            e1 = y[j, 1] - y[i, 1]
            e2 = y[j, 2] - y[i, 2]
            L = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
            if L == 0.0:
                continue
            w = omega(omega_kind, zeta[b], delta, omega_table, b)
            keep = 1.0 - bond_damage[b] if has_damage else 1.0
            g = ((3.0 * w) * keep * zeta[b] * volume[j]) / mi / L
            dth[a, 0] += g * e0
            dth[a, 1] += g * e1
            dth[a, 2] += g * e2
            dth[0, 0] -= g * e0
            dth[0, 1] -= g * e1
            dth[0, 2] -= g * e2
        alpha = ((15.0 * mu) / mi) * scf[i]
        cK = (3.0 * K) / mi - alpha / 3.0
        shift = alpha_T * dT[i] if thermal else 0.0
        n = np.zeros(3)
        M = np.zeros((3, 3))
        for a in range(1, ns):
            b = o + a - 1
            j = S[a]
            z = zeta[b]
            n[0] = y[j, 0] - y[i, 0]
            n[1] = y[j, 1] - y[i, 1]
            n[2] = y[j, 2] - y[i, 2]
            L = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
            if L == 0.0:
                continue
            n /= L
            e = L - z - shift * z
            w = omega(omega_kind, z, delta, omega_table, b)
            keep = 1.0 - bond_damage[b] if has_damage else 1.0
            c1 = (w * theta[i]) * cK - ((3.0 * w) / mi) * p[i]
            t = keep * (c1 * z + ((keep * w) * alpha) * e)
            dt_dth = keep * w * cK * z
            dt_de = keep * keep * w * alpha
            dt_dp = -keep * ((3.0 * w) / mi) * z
            Vj = volume[j]
            for kk in range(ns):
                sgn = 1.0 if kk == a else (-1.0 if kk == 0 else 0.0)
                for d in range(3):
                    for c in range(3):
                        dtdy = dt_dth * dth[kk, c] + dt_de * sgn * n[c]
                        proj = (1.0 if d == c else 0.0) - n[d] * n[c]
                        M[d, c] = n[d] * dtdy + t * sgn * proj / L
                for d in range(3):
                    for c in range(3):
                        Kl[d, 4 * kk + c] += Vj * M[d, c]
                        Kl[4 * a + d, 4 * kk + c] -= Vi * M[d, c]
            for d in range(3):
                Kl[d, 3] += Vj * n[d] * dt_dp
                Kl[4 * a + d, 3] -= Vi * n[d] * dt_dp
    # -- flow -------------------------------------------------------------------------------------
    mu_i = mu_f * math.exp(c_T * dT[i]) if thermal else mu_f
    kbar = k - 0.25 * (3.0 * k)
    C = (rho_f / mu_i) * (4.0 / ((math.pi * delta) * delta))
    for a in range(1, ns):
        b = o + a - 1
        j = S[a]
        e0 = y[j, 0] - y[i, 0]
        e1 = y[j, 1] - y[i, 1]
        e2 = y[j, 2] - y[i, 2]
        L2 = e0 * e0 + e1 * e1 + e2 * e2
        if L2 == 0.0:
            continue
        d = bond_damage[b] if has_damage else 0.0
        s = 1.0 / (1.0 + math.exp(a_p * (d - d_c)))
        ke = kbar * L2
        ke = ke + (k_max - ke) * s
        L4 = L2 * L2
        dq_dp = C * ke / L4
        dp = p[j] - p[i]
        h = C * dp * ((1.0 - s) * 2.0 * kbar / L4 - 4.0 * ke / (L4 * L2))
        Vj = volume[j]
        eta = (e0, e1, e2)
        for c in range(3):
            g = h * eta[c]
            Kl[3, 4 * a + c] += Vj * g
            Kl[3, c] -= Vj * g
            Kl[4 * a + 3, 4 * a + c] -= Vi * g
            Kl[4 * a + 3, c] += Vi * g
        Kl[3, 4 * a + 3] += Vj * dq_dp
        Kl[3, 3] -= Vj * dq_dp
        Kl[4 * a + 3, 4 * a + 3] -= Vi * dq_dp
        Kl[4 * a + 3, 3] += Vi * dq_dp
    for r in range(ns):
        Vr = volume[S[r]]
        for rr in range(4):
            for c in range(4 * ns):
                Kl[4 * r + rr, c] *= Vr
    return ns


# not a loop law: tangent assembly (serial scatter of the local Jacobians into the 4x4-block BSR matrix, in evaluation order)
@njit(cache=True, error_model="numpy")
def coupled_tangent_kernel(start, stop, eval_rank, offsets, neighbors, zeta, y, volume, m, theta, scf, p, K, mu, omega_kind, delta,
                           omega_table, bond_damage, dT, alpha_T, c_T, k, rho_f, mu_f, k_max, a_p, d_c, row_of_local, indptr, indices, data):
    """Add the local Jacobians of the points [start, stop) (in evaluation order) into the 4x4-block
    BSR matrix (indptr, indices, data (nnzb, 4, 4)), rows and columns numbered by ``row_of_local``
    (serial: a scatter)."""
    if stop <= start:
        return
    order = np.argsort(eval_rank[start:stop])
    maxdeg = 0
    for i in range(start, stop):
        maxdeg = max(maxdeg, offsets[i + 1] - offsets[i])
    S = np.zeros(maxdeg + 1, dtype=np.int64)
    Kl = np.zeros((4 * (maxdeg + 1), 4 * (maxdeg + 1)))
    for q in range(order.shape[0]):
        i = start + order[q]
        ns = local_coupled_jacobian(i, offsets, neighbors, zeta, y, volume, m, theta, scf, p, K, mu, omega_kind, delta, omega_table,
                                    bond_damage, dT, alpha_T, c_T, k, rho_f, mu_f, k_max, a_p, d_c, S, Kl)
        for r in range(ns):
            row = row_of_local[S[r]]
            for c in range(ns):
                pos = block_position(indptr, indices, row, row_of_local[S[c]])
                if pos < 0:
                    continue
                for rr in range(4):
                    for cc in range(4):
                        data[pos, rr, cc] += Kl[4 * r + rr, 4 * c + cc]
