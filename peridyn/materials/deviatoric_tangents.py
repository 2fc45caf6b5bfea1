"""Tangents d(f V)/dy of the plastic and viscoelastic materials (:mod:`peridyn.materials.deviatoric`),
compiled: Peridigm's central finite differences (all three models) and the exact derivative of
the plastic force (Peridigm's automatic-differentiation tangent up to round-off).

Both build, for every point i of a block (in Peridigm's evaluation order ``pts``), the dense local
block of point i's bond forces over S_i = [N_i..., i] and add it into the BSR matrix with
:func:`peridyn.core.assembly.scatter_local_kernel`. Points are processed in batches: the
local blocks of a batch are computed in parallel (``prange``, each point only reading shared
arrays; a finite-difference probe moves a private copy of its family's positions), then added
serially in ``pts`` order, so the matrix is the same for any thread count, and the same as a
one-point-at-a-time loop. Neither writes the material's state (probes write scratch arrays).

Shapes as in :mod:`peridyn.materials.deviatoric`; data (nnzb, 3, 3) force per length.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..core.influence import TABLE, omega
from .deviatoric import (
    HARDENING,
    VISCO,
    plastic_bonds,
    plastic_point,
    point_theta,
    visco_bonds,
)
from ..core.assembly import local_scalar_state_force_kernel, scatter_local_kernel


@njit(cache=True, error_model="numpy")
def _probe(model, i, offsets, neighbors, zeta, y, volume, m, omega_kind, delta, omega_table, bond_damage, K, mu, prm, scf, bond_n, bond_n2, point_n, t, w1, w2, out):
    """Point i's force on S_i at the positions y, its state written to scratch only (w1, w2)."""
    o = offsets[i]
    theta = point_theta(i, offsets, neighbors, zeta, y, volume, m[i], omega_kind, delta, omega_table, bond_damage)
    if model == VISCO:
        visco_bonds(i, o, offsets, neighbors, zeta, y, m[i], point_n[i], theta, K, mu, prm[0], prm[1], prm[2], bond_damage, bond_n, bond_n2, t, w1, w2)
    else:
        s = scf[i] if scf.shape[0] > 0 else 1.0
        hard = model == HARDENING
        alpha, c, n, dlam, plastic = plastic_point(i, offsets, neighbors, zeta, y, volume, m[i], theta, K, mu, s, prm[0], prm[1], hard, bond_damage, bond_n, point_n[i])
        plastic_bonds(i, o, offsets, neighbors, zeta, y, theta, alpha, c, n, dlam, plastic, (s * s) * prm[0], hard, bond_damage, bond_n, t, w1)
    local_scalar_state_force_kernel(i, offsets, neighbors, y, volume, t, out)


@njit(cache=True, error_model="numpy")
def _fd_block(model, i, offsets, neighbors, zeta, y, volume, m, omega_kind, delta, omega_table, bond_damage, K, mu, prm, scf, bond_n, bond_n2, point_n, eps, Kloc):
    """The central-difference block of point i into Kloc[:3 ns, :3 ns]. The family is copied
    into local arrays (neighbours 0..deg-1, i last), whose positions the probes move."""
    o = offsets[i]
    deg = offsets[i + 1] - o
    ns = deg + 1
    lo = np.zeros(ns + 1, np.int64)
    lo[ns] = deg  # row of the local point deg (= i): bonds 0..deg-1
    ln = np.arange(deg)
    yl = np.empty((ns, 3))
    vl = np.empty(ns)
    ml = np.zeros(ns)
    pl = np.zeros(ns)
    sl = np.zeros(ns if scf.shape[0] > 0 else 0)
    for k in range(ns):
        q = neighbors[o + k] if k < deg else i
        for c in range(3):
            yl[k, c] = y[q, c]
        vl[k] = volume[q]
    ml[deg] = m[i]
    pl[deg] = point_n[i]
    if scf.shape[0] > 0:
        sl[deg] = scf[i]
    zl = zeta[o : o + deg]
    dl = bond_damage[o : o + deg] if bond_damage.shape[0] > 0 else bond_damage
    tl = omega_table[o : o + deg] if omega_kind == TABLE else omega_table
    b1 = bond_n[o : o + deg]
    b2 = bond_n2[o : o + deg]
    t = np.empty(deg)
    w1 = np.empty(deg)
    w2 = np.empty(deg)
    Fp = np.empty(3 * ns)
    Fm = np.empty(3 * ns)
    for a in range(ns):
        for c in range(3):
            orig = yl[a, c]
            yl[a, c] = orig - eps
            _probe(model, deg, lo, ln, zl, yl, vl, ml, omega_kind, delta, tl, dl, K, mu, prm, sl, b1, b2, pl, t, w1, w2, Fm)
            yl[a, c] = orig + eps
            _probe(model, deg, lo, ln, zl, yl, vl, ml, omega_kind, delta, tl, dl, K, mu, prm, sl, b1, b2, pl, t, w1, w2, Fp)
            yl[a, c] = orig
            for r in range(ns):
                Vs = vl[r]
                for d in range(3):
                    Kloc[3 * r + d, 3 * a + c] = (((Fp[3 * r + d] - Fm[3 * r + d]) / eps) * 0.5) * Vs


@njit(cache=True, error_model="numpy")
def _plastic_block(i, offsets, neighbors, zeta, y, volume, m, omega_kind, delta, omega_table, bond_damage, K, mu, scf, Y, H, hardening, edp_n, lam_n, Kloc):
    """The exact block of point i into Kloc[:3 ns, :3 ns] (zero without bonds or weighted volume).

    With u_k = M_k . d eta_k (M the deformed bond direction) the change of the bond extensions,
    d theta = sum_k beta_k u_k (beta_k = 3 omega_k D_k zeta_k V_k / m), x_k = e^d_k - e^dp_N,
    t^tr = alpha x and dn = sum_k gamma_k (u_k - zeta_k d theta / 3) (gamma_k = (D_k alpha)^2
    x_k V_k / n), the deviatoric force is t^d = g0 t^tr with d t^d_j = g0 d t^tr_j - g1 t^tr_j dn
    (elastic: g0 = 1, g1 = 0; perfect: g0 = sqrt(2Y)/n, g1 = sqrt(2Y)/n^2; hardening: g0 =
    1/(1 + alpha dl), g1 = alpha (d dl/dn)/(1 + alpha dl)^2, d dl/dn from the cubic), so

        dt_j = diag_j u_j + a_j (beta . u) + b_j (gamma . u),

    and the pair vector g_j = V_i V_j t_j M_j changes by V_i V_j [M_j dt_j + (t_j/L_j)(I - M_j
    M_j^T) d eta_j]; point i adds +g_j to itself and -g_j to j."""
    o = offsets[i]
    deg = offsets[i + 1] - o
    ns = deg + 1
    for r in range(3 * ns):
        for c in range(3 * ns):
            Kloc[r, c] = 0.0
    mi = m[i]
    if mi == 0.0 or deg == 0:
        return
    has_damage = bond_damage.shape[0] > 0
    s = scf[i] if scf.shape[0] > 0 else 1.0
    theta = point_theta(i, offsets, neighbors, zeta, y, volume, mi, omega_kind, delta, omega_table, bond_damage)
    alpha, c, n, dlam, plastic = plastic_point(i, offsets, neighbors, zeta, y, volume, mi, theta, K, mu, s, Y, H, hardening, bond_damage, edp_n, lam_n[i])
    Yp = (s * s) * Y
    g0 = 1.0
    g1 = 0.0
    if plastic:
        if hardening:
            q = 1.0 + alpha * dlam
            a3 = (2.0 / alpha + lam_n[i]) + Yp / H
            b3 = ((H + ((2.0 * alpha) * H) * lam_n[i]) + (2.0 * alpha) * Yp) / ((alpha * alpha) * H)
            dxdn = (n / ((alpha * alpha) * H)) / ((3.0 * dlam * dlam + (2.0 * a3) * dlam) + b3)
            g0 = 1.0 / q
            g1 = (alpha * dxdn) / (q * q)
        else:
            root = math.sqrt(2.0 * Yp)
            g0 = root / n
            g1 = root / (n * n)
    Mv = np.empty((deg, 3))
    Lb = np.empty(deg)
    tb = np.empty(deg)
    beta = np.empty(deg)
    gam = np.empty(deg)
    dg = np.empty(deg)
    ab = np.empty(deg)
    bb = np.empty(deg)
    Vi = volume[i]
    Gam = 0.0
    for k in range(deg):
        b = o + k
        j = neighbors[b]
        z = zeta[b]
        ex = y[j, 0] - y[i, 0]
        ey = y[j, 1] - y[i, 1]
        ez = y[j, 2] - y[i, 2]
        L = math.sqrt(ex * ex + ey * ey + ez * ez)
        Lb[k] = L
        inv = 1.0 / L if L > 0.0 else 0.0
        Mv[k, 0] = ex * inv
        Mv[k, 1] = ey * inv
        Mv[k, 2] = ez * inv
        keep = 1.0 - bond_damage[b] if has_damage else 1.0
        x = ((L - z) - (theta * z) / 3.0) - edp_n[b]
        tt = alpha * x
        tb[k] = keep * (c * z + keep * (g0 * tt))
        w = omega(omega_kind, z, delta, omega_table, b)
        beta[k] = (3.0 * w * keep * z * volume[j]) / mi
        gam[k] = ((keep * alpha) * (keep * alpha) * x * volume[j]) / n if plastic else 0.0
        Gam += gam[k] * z / 3.0
        dg[k] = keep * keep * g0 * alpha
        bb[k] = -keep * keep * g1 * tt
    for k in range(deg):
        b = o + k
        keep = 1.0 - bond_damage[b] if has_damage else 1.0
        ab[k] = keep * ((3.0 * K) / mi) * zeta[b] - (dg[k] * zeta[b]) / 3.0 - bb[k] * Gam
    # neighbour blocks: Kloc[j, k] = -d g_j / d y_k
    for jj in range(deg):
        if Lb[jj] == 0.0:
            continue
        VV = Vi * volume[neighbors[o + jj]]
        for kk in range(deg):
            coef = -VV * (ab[jj] * beta[kk] + bb[jj] * gam[kk])
            for d in range(3):
                for cc in range(3):
                    Kloc[3 * jj + d, 3 * kk + cc] += coef * Mv[jj, d] * Mv[kk, cc]
        geo = tb[jj] / Lb[jj]
        for d in range(3):
            for cc in range(3):
                mm = Mv[jj, d] * Mv[jj, cc]
                ident = 1.0 if d == cc else 0.0
                Kloc[3 * jj + d, 3 * jj + cc] -= VV * (dg[jj] * mm + geo * (ident - mm))
    # translation invariance (columns of i) and momentum balance (rows of i)
    for r in range(3 * deg):
        for cc in range(3):
            acc = 0.0
            for kk in range(deg):
                acc += Kloc[r, 3 * kk + cc]
            Kloc[r, 3 * deg + cc] = -acc
    for col in range(3 * ns):
        for d in range(3):
            acc = 0.0
            for jj in range(deg):
                acc += Kloc[3 * jj + d, col]
            Kloc[3 * deg + d, col] = -acc


@njit(cache=True)
def _scatter(i, offsets, neighbors, Kloc, row_of_local, nrows, indptr, indices, data):
    """Add point i's block Kloc[:3 ns, :3 ns] over S_i = [N_i..., i], dropping points beyond nrows."""
    o = offsets[i]
    deg = offsets[i + 1] - o
    ns = deg + 1
    nk = 0
    for a in range(ns):
        q = neighbors[o + a] if a < deg else i
        if q < nrows:
            nk += 1
    keep = np.empty(nk, np.int64)
    rows = np.empty(nk, np.int64)
    k = 0
    for a in range(ns):
        q = neighbors[o + a] if a < deg else i
        if q < nrows:
            keep[k] = a
            rows[k] = row_of_local[q]
            k += 1
    sub = np.empty((3 * nk, 3 * nk))
    for p in range(nk):
        for q in range(nk):
            for d in range(3):
                for c in range(3):
                    sub[3 * p + d, 3 * q + c] = Kloc[3 * keep[p] + d, 3 * keep[q] + c]
    scatter_local_kernel(rows, sub, indptr, indices, data)


@njit(cache=True, parallel=True, error_model="numpy")
def fd_tangent_kernel(
    model, pts, offsets, neighbors, zeta, y, volume, m, omega_kind, delta, omega_table, bond_damage, K, mu, prm, scf,
    bond_n, bond_n2, point_n, eps, row_of_local, nrows, indptr, indices, data, max_degree, batch,
):
    """Peridigm's central finite-difference tangent (PERIDIGM_SEMANTICS.md §11.1) of the points
    ``pts``: for each point i and each degree of freedom (q, c) of S_i = [N_i..., i], y_qc -/+ eps,
    point i re-evaluated from the N state (theta_i included), column (((F+ - F-)/eps) 0.5) V_s.
    ``model``: PERFECT, HARDENING (prm = [Y, H]) or VISCO (prm = [lambda_i, decay, beta]);
    bond_n / bond_n2 / point_n: e^dp_N, (unused), lambda_N (plasticity) or extension_N, e^b_N,
    theta_N (viscoelasticity). ``batch`` local blocks are computed in parallel at a time."""
    size = 3 * (max_degree + 1)
    buf = np.empty((batch, size, size))
    for first in range(0, pts.shape[0], batch):
        count = min(batch, pts.shape[0] - first)
        for k in prange(count):
            _fd_block(model, pts[first + k], offsets, neighbors, zeta, y, volume, m, omega_kind, delta, omega_table, bond_damage,
                      K, mu, prm, scf, bond_n, bond_n2, point_n, eps, buf[k])
        for k in range(count):
            _scatter(pts[first + k], offsets, neighbors, buf[k], row_of_local, nrows, indptr, indices, data)


@njit(cache=True, parallel=True, error_model="numpy")
def plastic_tangent_kernel(
    pts, offsets, neighbors, zeta, y, volume, m, omega_kind, delta, omega_table, bond_damage, K, mu, scf, Y, H, hardening,
    edp_n, lam_n, row_of_local, nrows, indptr, indices, data, max_degree, batch,
):
    """The exact tangent of the plastic force (:func:`_plastic_block`) of the points ``pts``,
    ``batch`` local blocks computed in parallel at a time, added in ``pts`` order."""
    size = 3 * (max_degree + 1)
    buf = np.empty((batch, size, size))
    for first in range(0, pts.shape[0], batch):
        count = min(batch, pts.shape[0] - first)
        for k in prange(count):
            _plastic_block(pts[first + k], offsets, neighbors, zeta, y, volume, m, omega_kind, delta, omega_table, bond_damage,
                           K, mu, scf, Y, H, hardening, edp_n, lam_n, buf[k])
        for k in range(count):
            _scatter(pts[first + k], offsets, neighbors, buf[k], row_of_local, nrows, indptr, indices, data)


def fd_tangent(self, block, target, model: int, prm: np.ndarray, scf: np.ndarray, bond_n, bond_n2, point_n) -> bool:
    """Peridigm's central finite differences of a deviatoric-state material ``self`` (compiled,
    :func:`fd_tangent_kernel`)."""
    s, nl = block.fields, block.bonds
    kind, delta, table = self._common(block)
    eps = target.probe_length
    if eps is None:
        raise ValueError(f"{self.name}: the finite-difference tangent needs a probe length")
    T = target
    fd_tangent_kernel(
        model, self._points(block, target), nl.offsets, nl.neighbors, s["Bond_Length"], s["Coordinates"], s["Volume"], s["Weighted_Volume"],
        kind, delta, table, self._damage(block), self.K, self.mu, prm, scf, bond_n, bond_n2, point_n, float(eps),
        T.row_of_local, T.nrows, T.indptr, T.indices, T.data, max(self._max_degree(block), 1), self._batch(block),
    )
    return True
