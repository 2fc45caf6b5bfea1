"""Peridigm's central finite-difference tangent of the hypoelastic and bond-associated
correspondence materials (PERIDIGM_CORRESPONDENCE.md §12.3), in compiled code.

The probes are those of the solver's Python finite-difference path
(:meth:`peridyn.solvers.linalg.tangent.TangentMatrix._finite_difference`), with the same arithmetic in
the same order, so the matrix is the same bit for bit: for every point i (``pts`` order) and every
degree of freedom (q, c) of S_i = [N_i..., i], y_qc and v_qc are moved by -eps, -dv and then
+eps, +dv (dv = eps/dt, 0 when dt == 0); point i alone is re-evaluated, its node-level data
first (hypoelastic: gradient weights, velocity gradient L_i, weighted volume m0_i; bond-associated:
F_i and Ḟ_i) and then the vector force states of its bonds, from the N state. The neighbours'
node-level data stay as the last full evaluation left them (Peridigm calls no precompute in
its probes: §12.3). The contributions of i's bonds on S_i give the column
(((F+ - F-)/eps)·0.5)·V_s.

Each worker perturbs its own copies of y and v and keeps its own copies of the node-level
arrays the bond forces read at the neighbours (L and m0; F and Ḟ), restored after each point;
the per-bond arrays a point writes (gradient weights, NP1 bond state, force states) belong to
that point alone. Blocks of a batch of points are computed in parallel, then scattered with
:func:`.fd_tangent.scatter_rows` (worker w adds the matrix rows r with r % W == w, the blocks in
``pts`` order): every matrix entry receives its additions in Peridigm's order.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ...core.assembly import local_vector_force_kernel
from . import bond_associated_kernels as BK
from . import bond_associated_gradients as BKG
from . import hypoelastic_kernels as HK
from .fd_tangent import scatter_rows

# not a loop law: one column of a point's local block from its finite-difference quotients
@njit(cache=True, error_model="numpy")
def _column(Kloc, m, col, ns, o, neighbors, volume, i, Fp, Fm, eps):
    """Kloc[r, col] = (((F+_r - F-_r)/eps)·0.5)·V_s(r) (row-major m x m)."""
    r = 0
    for bb in range(ns):
        s = neighbors[o + bb] if bb < ns - 1 else i
        Vs = volume[s]
        for _ in range(3):
            Kloc[r * m + col] = (((Fp[r] - Fm[r]) / eps) * 0.5) * Vs
            r += 1


# not a loop law: one point's block of the finite-difference tangent (every probe of its family, inside a parallel iteration)
@njit(cache=True, error_model="numpy")
def hypo_point_block(i, offsets, neighbors, y, v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, dt, eps, dv,
                     L, m0, phi, Jw, Vb_N, Rb_N, Sb_N, eb_N, model, K, G, sy, ec, nexp, Vb_NP1, Rb_NP1, Sb_NP1, eb_NP1, T,
                     Fp, Fm, Kloc):
    """The local block of point i (hypoelastic family) into Kloc; y, v, L, m0, Jw: this worker's
    copies (y and v restored exactly; L[i], m0[i] left perturbed: the caller restores them)."""
    o = offsets[i]
    ns = offsets[i + 1] - o + 1
    m = 3 * ns
    no_wv = np.zeros(0)  # optional outputs off (module-level arrays would be read-only here)
    no_integral = np.zeros((0, 9))
    for a in range(ns):
        q = neighbors[o + a] if a < ns - 1 else i
        for cc in range(3):
            orig = y[q, cc]
            vorig = v[q, cc]
            for side in range(2):
                y[q, cc] = orig - eps if side == 0 else orig + eps
                v[q, cc] = vorig - dv if side == 0 else vorig + dv
                HK.precompute_point(i, offsets, neighbors, y, v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, o, dt,
                                    phi, L, Jw, m0, no_wv)
                HK.bond_force_point(i, offsets, neighbors, y, v, volume, horizon, J_N, bond_damage, omega_kind, omega_table, o, dt, L,
                                    m0, phi, Vb_N, Rb_N, Sb_N, eb_N, model, K, G, sy, ec, nexp, Vb_NP1, Rb_NP1, Sb_NP1, eb_NP1,
                                    no_integral, T)
                local_vector_force_kernel(i, offsets, neighbors, volume, T, Fm if side == 0 else Fp)
            y[q, cc] = orig
            v[q, cc] = vorig
            _column(Kloc, m, 3 * a + cc, ns, o, neighbors, volume, i, Fp, Fm, eps)


# not a loop law: parallel over a batch of points, each assembling its dense local block
@njit(cache=True, parallel=True, error_model="numpy")
def hypo_blocks(pts, k0, k1, offsets, neighbors, ys, vs, volume, horizon, J_N, bond_damage, omega_kind, omega_table, dt, eps, dv,
                L, m0, Ls, m0s, phi, phi0, Js, Vb_N, Rb_N, Sb_N, eb_N, model, K, G, sy, ec, nexp, Vb_NP1, Rb_NP1, Sb_NP1, eb_NP1, T,
                Fps, Fms, Kbuf):
    """Local blocks of pts[k0:k1] into Kbuf[k - k0] (worker w: k = k0 + w, k0 + w + W, ...).
    L, m0, phi0: the unperturbed node data and gradient weights; Ls, m0s, Js, ys, vs: per-worker
    copies; phi: written for the point being probed, restored from phi0 after it."""
    W = ys.shape[0]
    for w in prange(W):
        for k in range(k0 + w, k1, W):
            i = pts[k]
            hypo_point_block(i, offsets, neighbors, ys[w], vs[w], volume, horizon, J_N, bond_damage, omega_kind, omega_table, dt, eps, dv,
                             Ls[w], m0s[w], phi, Js[w], Vb_N, Rb_N, Sb_N, eb_N, model, K, G, sy, ec, nexp, Vb_NP1, Rb_NP1, Sb_NP1,
                             eb_NP1, T, Fps[w], Fms[w], Kbuf[k - k0])
            for c in range(9):
                Ls[w, i, c] = L[i, c]
            m0s[w, i] = m0[i]
            for b in range(offsets[i], offsets[i + 1]):
                phi[b, 0] = phi0[b, 0]
                phi[b, 1] = phi0[b, 1]
                phi[b, 2] = phi0[b, 2]


# not a loop law: one point's block of the finite-difference tangent (every probe of its family, inside a parallel iteration)
@njit(cache=True, error_model="numpy")
def ba_point_block(i, offsets, neighbors, x, y, v, u, volume, horizon, omega_kind, omega_table, check, damage_N, damage_NP1,
                   bond_damage, influence, phi, m, FX, FY, FZ, FdX, FdY, FdZ, bV_N, bR_N, bV_NP1, bR_NP1, bsig_N, bsig_NP1,
                   beqps_N, beqps_NP1, model, K, G, p0, p1, p2, p3, dt, eps, dv, P, T, Fp, Fm, Kloc):
    """The local block of point i (bond-associated family) into Kloc; y, v and F..FdZ: this
    worker's copies (y, v restored exactly; row i of F..FdZ left perturbed: the caller restores
    it). Returns 0 or the failure code of :func:`.bond_associated_kernels.bond_point`."""
    o = offsets[i]
    ns = offsets[i + 1] - o + 1
    m3 = 3 * ns
    for a in range(ns):
        q = neighbors[o + a] if a < ns - 1 else i
        for cc in range(3):
            orig = y[q, cc]
            vorig = v[q, cc]
            for side in range(2):
                y[q, cc] = orig - eps if side == 0 else orig + eps
                v[q, cc] = vorig - dv if side == 0 else vorig + dv
                if check and damage_NP1[i] - damage_N[i] > 1.0e-15:
                    BKG.gradient_weights_point(i, offsets, neighbors, x, volume, horizon, omega_kind, omega_table, bond_damage, influence,
                                              phi)
                BKG.deformation_gradient_point(i, offsets, neighbors, volume, phi, u, v, FX, FY, FZ, FdX, FdY, FdZ)
                st = BK.bond_point(i, offsets, neighbors, x, y, v, volume, m, influence, phi, FX, FY, FZ, FdX, FdY, FdZ, bV_N, bR_N,
                                   bV_NP1, bR_NP1, bsig_N, bsig_NP1, beqps_N, beqps_NP1, model, K, G, p0, p1, p2, p3, dt, P, T)
                if st != 0:
                    y[q, cc] = orig
                    v[q, cc] = vorig
                    return st
                local_vector_force_kernel(i, offsets, neighbors, volume, T, Fm if side == 0 else Fp)
            y[q, cc] = orig
            v[q, cc] = vorig
            _column(Kloc, m3, 3 * a + cc, ns, o, neighbors, volume, i, Fp, Fm, eps)
    return 0


# not a loop law: parallel over a batch of points, each assembling its dense local block
@njit(cache=True, parallel=True, error_model="numpy")
def ba_blocks(pts, k0, k1, offsets, neighbors, x, ys, vs, u, volume, horizon, omega_kind, omega_table, check, damage_N, damage_NP1,
              bond_damage, influence, phi, m, F6, F6s, bV_N, bR_N, bV_NP1, bR_NP1, bsig_N, bsig_NP1, beqps_N, beqps_NP1,
              model, K, G, p0, p1, p2, p3, dt, eps, dv, P, T, Fps, Fms, Kbuf, status):
    """Local blocks of pts[k0:k1] into Kbuf[k - k0] and their status into status[k - k0]. F6
    (6, n, 3): the unperturbed F rows and Ḟ rows; F6s (W, 6, n, 3) per-worker copies."""
    W = ys.shape[0]
    for w in prange(W):
        Fw = F6s[w]
        for k in range(k0 + w, k1, W):
            i = pts[k]
            status[k - k0] = ba_point_block(
                i, offsets, neighbors, x, ys[w], vs[w], u, volume, horizon, omega_kind, omega_table, check, damage_N, damage_NP1,
                bond_damage, influence, phi, m, Fw[0], Fw[1], Fw[2], Fw[3], Fw[4], Fw[5], bV_N, bR_N, bV_NP1, bR_NP1, bsig_N,
                bsig_NP1, beqps_N, beqps_NP1, model, K, G, p0, p1, p2, p3, dt, eps, dv, P, T, Fps[w], Fms[w], Kbuf[k - k0],
            )
            for r in range(6):
                for c in range(3):
                    Fw[r, i, c] = F6[r, i, c]


# not a loop law: scatters dense local blocks into the block-sparse matrix (row maps, not bond sums)
@njit(cache=True, parallel=True, error_model="numpy")
def scatter_batch(pts, k0, k1, W, offsets, neighbors, nrows, row_of_local, Kbuf, indptr, indices, data):
    """Add the blocks of pts[k0:k1] (Kbuf[k - k0]) into the matrix, worker w the rows r % W == w,
    the blocks in ``pts`` order."""
    for w in prange(W):
        for k in range(k0, k1):
            scatter_rows(w, W, pts[k], offsets, neighbors, nrows, row_of_local, Kbuf[k - k0], indptr, indices, data)


def batching(num_points: int, max_degree: int, threads: int) -> tuple[int, int, int]:
    """(workers, batch, local block size M) for :func:`hypo_blocks` / :func:`ba_blocks`: the
    blocks of a batch use at most 64 MiB."""
    workers = max(1, min(int(threads), num_points))
    M = 3 * (int(max_degree) + 1)
    batch = max(workers, min(16 * workers, (64 << 20) // max(1, 8 * M * M)))
    return workers, batch, M
