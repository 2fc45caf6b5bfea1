"""Analytic tangents of the central-force materials: K = d(f V)/dy, the derivative of the internal
force (force density f times volume V, in force units) with respect to the current positions y,
as Peridigm's implicit solvers use it (PERIDIGM_SEMANTICS.md §11.1).

Derivation
----------
Notation as in :mod:`peridyn.materials.elastic`: for a bond b = i->j of point i, xi = x_j - x_i,
zeta = |xi|, eta = y_j - y_i, L = |eta|, M = eta / L the deformed bond direction, d the bond
damage (keep = 1 - d), omega the influence function, V the volumes. Point i's bonds contribute
the pair vector

    g_ij = V_i V_j t_ij M_ij          to F_i (+g_ij) and to F_j (-g_ij),

where t_ij is i's scalar force state. Point i's contribution therefore couples the degrees of
freedom of S_i = {i} U N_i only, and K is the sum over points i of these family blocks (the
sparsity pattern Peridigm allocates). With dM/deta = (I - M M^T)/L and dL/deta = M^T:

    dg_ij = V_i V_j [ M (dt_ij) + (t_ij / L)(I - M M^T) deta ].

*Elastic (LPS).* With m_i the weighted volume, a_i = 15 mu / m_i, kappa_i = 3K/m_i - a_i/3,
e_ij = L - zeta - alpha_T dT_i zeta and

    theta_i = sum_k 3 omega_ik keep_ik zeta_ik e_ik V_k / m_i,
    t_ij    = keep_ij omega_ij (theta_i kappa_i zeta_ij + keep_ij a_i e_ij),

the force state depends on y through e_ij (de_ij = M_ij^T deta_ij) and through theta_i:

    d theta_i / d y_k = D_ik^T,   D_ik = (3 omega_ik keep_ik zeta_ik V_k / m_i) M_ik   (k in N_i),
    d theta_i / d y_i = -sum_k D_ik^T.

Hence, with the direct (pair) block

    A_ij = V_i V_j [ keep_ij^2 omega_ij a_i M M^T + (t_ij / L)(I - M M^T) ]     (= dg_ij/dy_j = -dg_ij/dy_i)

and the dilatation vectors w_ij = V_i V_j keep_ij omega_ij zeta_ij kappa_i M_ij (so that
dg_ij/dtheta_i = w_ij), point i adds

    K_ij += A_ij,   K_ii -= A_ij,   K_jj -= A_ij,   K_ji += A_ij            (every j in N_i)
    K_ik += W_i D_ik^T,   K_jk -= w_ij D_ik^T                              (k in N_i, W_i = sum_j w_ij)
    K_ii -= W_i (sum_k D_ik)^T,   K_ji += w_ij (sum_k D_ik)^T.

The second line is the dense family-by-family coupling of the dilatation; the damage factors
enter exactly as in Peridigm's force (keep once in theta and in the dilatational term, squared
in the extension term). The thermal strain shifts e only and does not change the derivative.

*Elastic Bond Based.* t_ij = (keep_ij / 2) c s_ij with s = (L - zeta)/zeta, so dt = keep c /(2 zeta) dL
and point i adds only the pair blocks

    A_ij = V_i V_j [ (keep_ij c / (2 zeta)) M M^T + (t_ij / L)(I - M M^T) ]

at (i,j) and (j,i) with + and at (i,i) and (j,j) with -.

Symmetry: in both models point i's force state depends on y only through the bond extensions
e_ik of its own family (and L through M), and V_j dt_ij/de_ik is symmetric in j and k (LPS:
3 kappa_i omega_j omega_k keep_j keep_k zeta_j zeta_k V_j V_k / m_i plus the diagonal keep^2 omega a_i V_j,
for any damage values). K is the sum over points of B_i^T H_i B_i (B_i the derivative of the
extensions, H_i that symmetric matrix) plus the symmetric geometric blocks V_i V_j (t/L)(I - M M^T)
of the pairs, so K is symmetric: with damage, thermal strain, one-sided families and several
blocks alike. (Peridigm's mixed damage factors still make the LPS force differ from the gradient
of its stored-energy density once bonds are broken, because m_i keeps broken bonds.)

Assembly
--------
The kernels *gather*: every matrix row point s (a local point) is processed by exactly one
thread, which sums the contributions of every point i with s in S_i (i = s and the sources of
s's incoming bonds) in Peridigm's evaluation order (block, then global id), so the result does
not depend on the thread count. A contribution to a column missing from the row's pattern is
dropped (that is how a block-diagonal pattern, used by NOX preconditioners, is filled).

Matrix layout (see :class:`peridyn.solvers.linalg.tangent.TangentMatrix`): block-sparse rows (BSR, 3x3
blocks) in global-id order: ``indptr`` (nrows+1,), ``indices`` (nnzb,) int32 block columns in
row numbering, ``data`` (nnzb, 3, 3) with ``data[p, d, c] = dF_(s,d) / dy_(k,c)``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..core.influence import omega


@njit(cache=True, inline="always")
def _add_outer(data, p, a, ax, ay, az, bx, by, bz):
    """data[p] += a * (u v^T) with u = (ax, ay, az), v = (bx, by, bz)."""
    data[p, 0, 0] += a * ax * bx
    data[p, 0, 1] += a * ax * by
    data[p, 0, 2] += a * ax * bz
    data[p, 1, 0] += a * ay * bx
    data[p, 1, 1] += a * ay * by
    data[p, 1, 2] += a * ay * bz
    data[p, 2, 0] += a * az * bx
    data[p, 2, 1] += a * az * by
    data[p, 2, 2] += a * az * bz


@njit(cache=True, inline="always")
def _add_pair(data, p, sign, VV, alpha, beta, mx, my, mz):
    """data[p] += sign V_i V_j [alpha M M^T + beta (I - M M^T)] = sign VV [(alpha - beta) M M^T + beta I]."""
    g = sign * VV * (alpha - beta)
    h = sign * VV * beta
    data[p, 0, 0] += g * mx * mx + h
    data[p, 0, 1] += g * mx * my
    data[p, 0, 2] += g * mx * mz
    data[p, 1, 0] += g * my * mx
    data[p, 1, 1] += g * my * my + h
    data[p, 1, 2] += g * my * mz
    data[p, 2, 0] += g * mz * mx
    data[p, 2, 1] += g * mz * my
    data[p, 2, 2] += g * mz * mz + h


@njit(cache=True, inline="always")
def _gather_candidates(s, start, stop, in_offsets, in_bonds, sources, eval_rank, cand, candb):
    """Points i in [start, stop) whose family contains s (s itself first if in range), sorted by
    evaluation rank; candb[k] = the bond i->s (-1 for i = s). Returns the count."""
    nc = 0
    if s >= start and s < stop:
        cand[0] = s
        candb[0] = -1
        nc = 1
    if s < in_offsets.shape[0] - 1:
        for kk in range(in_offsets[s], in_offsets[s + 1]):
            b = in_bonds[kk]
            i = sources[b]
            if i >= start and i < stop:
                cand[nc] = i
                candb[nc] = b
                nc += 1
    # insertion sort by evaluation rank (a few hundred entries at most)
    for a in range(1, nc):
        ci = cand[a]
        cb = candb[a]
        key = eval_rank[ci]
        k = a - 1
        while k >= 0 and eval_rank[cand[k]] > key:
            cand[k + 1] = cand[k]
            candb[k + 1] = candb[k]
            k -= 1
        cand[k + 1] = ci
        candb[k + 1] = cb
    return nc


@njit(cache=True, parallel=True, error_model="numpy")
def lps_tangent_kernel(
    start, stop, nrows, nchunks, offsets, neighbors, in_offsets, in_bonds, sources, eval_rank,
    zeta, y, volume, m, theta, K, mu, omega_kind, delta, omega_table, bond_damage, dT, alpha_T,
    row_of_local, local_of_row, indptr, indices, data, max_degree, max_in,
):
    """Add the LPS tangent contributions of the points [start, stop) (one block) to the rows of
    all local points [0, nrows) that they reach (see module docstring). Shapes: y (n, 3) L;
    volume, m, theta, eval_rank, row_of_local (n,); zeta, bond_damage (nb,) (bond_damage empty:
    no damage); dT (n,) or empty; data (nnzb, 3, 3) in force per length (M T^-2)."""
    has_damage = bond_damage.shape[0] > 0
    thermal = dT.shape[0] > 0
    for ch in prange(nchunks):
        lo = (ch * nrows) // nchunks
        hi = ((ch + 1) * nrows) // nchunks
        pos = np.full(y.shape[0], -1, np.int64)
        D = np.empty((max_degree + 1, 3))
        cand = np.empty(max_in + 1, np.int64)
        candb = np.empty(max_in + 1, np.int64)
        for s in range(lo, hi):
            r = row_of_local[s]
            for p in range(indptr[r], indptr[r + 1]):
                pos[local_of_row[indices[p]]] = p
            nc = _gather_candidates(s, start, stop, in_offsets, in_bonds, sources, eval_rank, cand, candb)
            for q in range(nc):
                i = cand[q]
                bs = candb[q]
                mi = m[i]
                if mi == 0.0:
                    continue
                ai = (15.0 * mu) / mi
                kap = (3.0 * K) / mi - ai / 3.0
                ci = theta[i] * kap
                Vi = volume[i]
                shift = alpha_T * dT[i] if thermal else 0.0
                yi0 = y[i, 0]
                yi1 = y[i, 1]
                yi2 = y[i, 2]
                o = offsets[i]
                sx = 0.0
                sy = 0.0
                sz = 0.0
                for b in range(o, offsets[i + 1]):
                    k = neighbors[b]
                    ex = y[k, 0] - yi0
                    ey = y[k, 1] - yi1
                    ez = y[k, 2] - yi2
                    L = math.sqrt(ex * ex + ey * ey + ez * ez)
                    keep = 1.0 - bond_damage[b] if has_damage else 1.0
                    if L > 0.0:
                        w = omega(omega_kind, zeta[b], delta, omega_table, b)
                        cf = (3.0 * w * keep * zeta[b] * volume[k]) / (mi * L)
                    else:
                        cf = 0.0
                    D[b - o, 0] = cf * ex
                    D[b - o, 1] = cf * ey
                    D[b - o, 2] = cf * ez
                    sx += cf * ex
                    sy += cf * ey
                    sz += cf * ez
                pi = pos[i]
                if bs < 0:
                    # row s = i: its own bonds
                    Wx = 0.0
                    Wy = 0.0
                    Wz = 0.0
                    for b in range(o, offsets[i + 1]):
                        j = neighbors[b]
                        ex = y[j, 0] - yi0
                        ey = y[j, 1] - yi1
                        ez = y[j, 2] - yi2
                        L = math.sqrt(ex * ex + ey * ey + ez * ez)
                        if L == 0.0:
                            continue
                        mx = ex / L
                        my = ey / L
                        mz = ez / L
                        z = zeta[b]
                        e = L - z
                        if thermal:
                            e -= shift * z
                        w = omega(omega_kind, z, delta, omega_table, b)
                        keep = 1.0 - bond_damage[b] if has_damage else 1.0
                        t = keep * (w * (ci * z + keep * ai * e))
                        VV = Vi * volume[j]
                        alpha = keep * keep * w * ai
                        beta = t / L
                        pj = pos[j]
                        if pj >= 0:
                            _add_pair(data, pj, 1.0, VV, alpha, beta, mx, my, mz)
                        if pi >= 0:
                            _add_pair(data, pi, -1.0, VV, alpha, beta, mx, my, mz)
                        ww = VV * keep * w * z * kap
                        Wx += ww * mx
                        Wy += ww * my
                        Wz += ww * mz
                    for b in range(o, offsets[i + 1]):
                        pk = pos[neighbors[b]]
                        if pk >= 0:
                            _add_outer(data, pk, 1.0, Wx, Wy, Wz, D[b - o, 0], D[b - o, 1], D[b - o, 2])
                    if pi >= 0:
                        _add_outer(data, pi, -1.0, Wx, Wy, Wz, sx, sy, sz)
                else:
                    # row s = j, a neighbor of i through bond bs = i->s
                    ex = y[s, 0] - yi0
                    ey = y[s, 1] - yi1
                    ez = y[s, 2] - yi2
                    L = math.sqrt(ex * ex + ey * ey + ez * ez)
                    if L == 0.0:
                        continue
                    mx = ex / L
                    my = ey / L
                    mz = ez / L
                    z = zeta[bs]
                    e = L - z
                    if thermal:
                        e -= shift * z
                    w = omega(omega_kind, z, delta, omega_table, bs)
                    keep = 1.0 - bond_damage[bs] if has_damage else 1.0
                    t = keep * (w * (ci * z + keep * ai * e))
                    VV = Vi * volume[s]
                    alpha = keep * keep * w * ai
                    beta = t / L
                    ps = pos[s]
                    if ps >= 0:
                        _add_pair(data, ps, -1.0, VV, alpha, beta, mx, my, mz)
                    if pi >= 0:
                        _add_pair(data, pi, 1.0, VV, alpha, beta, mx, my, mz)
                    ww = VV * keep * w * z * kap
                    wx = ww * mx
                    wy = ww * my
                    wz = ww * mz
                    for b in range(o, offsets[i + 1]):
                        pk = pos[neighbors[b]]
                        if pk >= 0:
                            _add_outer(data, pk, -1.0, wx, wy, wz, D[b - o, 0], D[b - o, 1], D[b - o, 2])
                    if pi >= 0:
                        _add_outer(data, pi, 1.0, wx, wy, wz, sx, sy, sz)
            for p in range(indptr[r], indptr[r + 1]):
                pos[local_of_row[indices[p]]] = -1


@njit(cache=True, parallel=True, error_model="numpy")
def bond_based_tangent_kernel(
    start, stop, nrows, nchunks, offsets, neighbors, in_offsets, in_bonds, sources, eval_rank,
    zeta, y, volume, c, bond_damage, row_of_local, local_of_row, indptr, indices, data, max_in,
):
    """Add the bond-based tangent contributions of the points [start, stop) to the rows of all
    local points [0, nrows) (see module docstring). Shapes as in :func:`lps_tangent_kernel`."""
    has_damage = bond_damage.shape[0] > 0
    for ch in prange(nchunks):
        lo = (ch * nrows) // nchunks
        hi = ((ch + 1) * nrows) // nchunks
        pos = np.full(y.shape[0], -1, np.int64)
        cand = np.empty(max_in + 1, np.int64)
        candb = np.empty(max_in + 1, np.int64)
        for s in range(lo, hi):
            r = row_of_local[s]
            for p in range(indptr[r], indptr[r + 1]):
                pos[local_of_row[indices[p]]] = p
            nc = _gather_candidates(s, start, stop, in_offsets, in_bonds, sources, eval_rank, cand, candb)
            for q in range(nc):
                i = cand[q]
                bs = candb[q]
                Vi = volume[i]
                pi = pos[i]
                if bs < 0:
                    b0 = offsets[i]
                    b1 = offsets[i + 1]
                else:
                    b0 = bs
                    b1 = bs + 1
                for b in range(b0, b1):
                    j = neighbors[b]
                    ex = y[j, 0] - y[i, 0]
                    ey = y[j, 1] - y[i, 1]
                    ez = y[j, 2] - y[i, 2]
                    L = math.sqrt(ex * ex + ey * ey + ez * ez)
                    if L == 0.0:
                        continue
                    z = zeta[b]
                    keep = 1.0 - bond_damage[b] if has_damage else 1.0
                    t = ((0.5 * keep) * ((L - z) / z)) * c
                    alpha = (0.5 * keep * c) / z
                    beta = t / L
                    VV = Vi * volume[j]
                    mx = ex / L
                    my = ey / L
                    mz = ez / L
                    if bs < 0:
                        pj = pos[j]
                        if pj >= 0:
                            _add_pair(data, pj, 1.0, VV, alpha, beta, mx, my, mz)
                        if pi >= 0:
                            _add_pair(data, pi, -1.0, VV, alpha, beta, mx, my, mz)
                    else:
                        ps = pos[s]
                        if ps >= 0:
                            _add_pair(data, ps, -1.0, VV, alpha, beta, mx, my, mz)
                        if pi >= 0:
                            _add_pair(data, pi, 1.0, VV, alpha, beta, mx, my, mz)
            for p in range(indptr[r], indptr[r + 1]):
                pos[local_of_row[indices[p]]] = -1
