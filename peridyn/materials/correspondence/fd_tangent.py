"""Peridigm's central finite-difference tangent of the classic correspondence materials
(PERIDIGM_CORRESPONDENCE.md §12.3), in compiled code.

For every point i of a block (in Peridigm's evaluation order, ``pts``) and every degree of
freedom (q, c) of S_i = [N_i..., i] (neighbors in list order, then i): y_qc is moved by -eps and
+eps and v_qc by -dv and +dv (dv = eps/dt, 0 when dt == 0: the rate form reads velocities), only
point i is re-evaluated from the N state (V_N, R_N, σ̂_N, eqps_N): kinematics, stress update,
rotation and A = P K⁻¹, then the vector force states T(i→j) of i's bonds (hourglass term
included) and their contributions on S_i, f_i += T V_j, f_j -= T V_i
(:func:`peridyn.solvers.tangent.local_vector_force_kernel`); the column is
(((F+ - F-)/eps)·0.5)·V_s. The local 3|S_i| x 3|S_i| block is added into the matrix with
:func:`peridyn.materials.tangents.scatter_local_kernel` (rows ``row_of_local``; degrees of freedom
of points beyond ``nrows`` dropped), points in ``pts`` order: the same arithmetic, in the same
order, as the solver's Python finite-difference path, hence the same matrix bit for bit.

The per-point functions of :mod:`.kinematics`, :mod:`.stress` and :mod:`.forces` write their
results into per-worker scratch arrays (the material's NP1 fields are not touched), and each
worker perturbs its own copy of y and v. Points are processed in batches: the workers compute
the local blocks of a batch in parallel (``prange`` over workers), then the blocks are scattered
serially in ``pts`` order.

Stress models (``model``, parameters ``prm``):

* 0 Elastic: [K, G, α] (thermal when dT_N/dT_NP1 are non-empty);
* 1 Elastic Plastic: [K, G, σ_y];
* 2 Isotropic Hardening: [K, G, σ_y, H, flaw, flaw_x, flaw_y, flaw_z, flaw_size, flaw_magnitude];
* 3 Viscoplastic Needleman: [K, G, σ_y, n, m, ε̇0, ε0, ε1, flaw, flaw_x, flaw_y, flaw_z,
  flaw_size, flaw_magnitude] (flaw != 0.0 switches the flaw on).
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..tangents import scatter_local_kernel
from .forces import _force_state, _hourglass_bond
from .kinematics import kinematics_point
from .stress import (
    elastic_plastic_point,
    elastic_point,
    isotropic_hardening_point,
    needleman_point,
    rotate_piola_point,
)

ELASTIC = 0
ELASTIC_PLASTIC = 1
ISOTROPIC_HARDENING = 2
NEEDLEMAN = 3


@njit(cache=True, error_model="numpy")
def point_force_contributions(
    i, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table, V_N, R_N, sigma_N, eqps_N, dt,
    model, prm, dT_N, dT_NP1, c1, Kinv, F, V1, R1, d, sig1, eqps1, vm, sigma, A, out,
):
    """Point i's bond contributions on S_i = [N_i..., i] into out (3 |S_i|,) (force density, as
    ``local_vector_force_kernel``), from positions y and velocities v, the N state and the
    stress model (``model``, ``prm``); scratch outputs Kinv ... A are (n, 9) (eqps1, vm (n,)),
    row i written. Returns 0, 1 (singular shape tensor) or 2 (singular deformation gradient)."""
    st = kinematics_point(i, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table, V_N, R_N, dt, Kinv, F, V1, R1, d)
    if st != 0:
        return st
    K = prm[0]
    G = prm[1]
    if model == ELASTIC:
        elastic_point(i, d, sigma_N, dt, K, G, dT_N, dT_NP1, prm[2], sig1)
    elif model == ELASTIC_PLASTIC:
        elastic_plastic_point(i, d, sigma_N, eqps_N, dt, K, G, prm[2], sig1, eqps1, vm)
    elif model == ISOTROPIC_HARDENING:
        isotropic_hardening_point(i, d, sigma_N, eqps_N, dt, K, G, prm[2], prm[3], prm[4] != 0.0, x, prm[5], prm[6], prm[7],
                                  prm[8], prm[9], sig1, eqps1, vm)
    else:
        needleman_point(i, d, sigma_N, eqps_N, dt, K, G, prm[2], prm[3], prm[4], prm[5], prm[6], prm[7], prm[8] != 0.0, x,
                        prm[9], prm[10], prm[11], prm[12], prm[13], sig1, eqps1, vm)
    if rotate_piola_point(i, R1, sig1, F, Kinv, sigma, A) != 0:
        return 2
    o = offsets[i]
    e = offsets[i + 1]
    Vi = volume[i]
    delta = horizon[i]
    fx = 0.0
    fy = 0.0
    fz = 0.0
    for b in range(o, e):
        j = neighbors[b]
        tx, ty, tz, _, _, _ = _force_state(A, i, x, j, delta, omega_kind, omega_table, b)
        if c1 != 0.0:
            hx, hy, hz = _hourglass_bond(i, j, x, y, F, c1, delta)
            tx += hx
            ty += hy
            tz += hz
        k = 3 * (b - o)
        out[k] = -tx * Vi
        out[k + 1] = -ty * Vi
        out[k + 2] = -tz * Vi
        fx += tx * volume[j]
        fy += ty * volume[j]
        fz += tz * volume[j]
    k = 3 * (e - o)
    out[k] = fx
    out[k + 1] = fy
    out[k + 2] = fz
    return 0


@njit(cache=True, error_model="numpy")
def point_block(
    i, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table, V_N, R_N, sigma_N, eqps_N, dt,
    model, prm, dT_N, dT_NP1, c1, eps, dv, Kinv, F, V1, R1, d, sig1, eqps1, vm, sigma, A, Fp, Fm, Kloc,
):
    """The local block of point i into Kloc[:(3 ns)^2] (row-major 3 ns x 3 ns, ns = |S_i|);
    y and v (this worker's copies) are perturbed and restored. Returns the status of
    :func:`point_force_contributions` (0 when all probes succeeded)."""
    o = offsets[i]
    ns = offsets[i + 1] - o + 1
    m = 3 * ns
    for a in range(ns):
        q = neighbors[o + a] if a < ns - 1 else i
        for c in range(3):
            orig = y[q, c]
            vorig = v[q, c]
            y[q, c] = orig - eps
            v[q, c] = vorig - dv
            st = point_force_contributions(i, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table, V_N, R_N,
                                           sigma_N, eqps_N, dt, model, prm, dT_N, dT_NP1, c1, Kinv, F, V1, R1, d, sig1, eqps1,
                                           vm, sigma, A, Fm)
            if st == 0:
                y[q, c] = orig + eps
                v[q, c] = vorig + dv
                st = point_force_contributions(i, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table, V_N, R_N,
                                               sigma_N, eqps_N, dt, model, prm, dT_N, dT_NP1, c1, Kinv, F, V1, R1, d, sig1, eqps1,
                                               vm, sigma, A, Fp)
            y[q, c] = orig
            v[q, c] = vorig
            if st != 0:
                return st
            col = 3 * a + c
            for r in range(m):
                s = neighbors[o + r // 3] if r < m - 3 else i
                Kloc[r * m + col] = (((Fp[r] - Fm[r]) / eps) * 0.5) * volume[s]
    return 0


@njit(cache=True, parallel=True, error_model="numpy")
def fd_tangent_kernel(
    pts, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table, V_N, R_N, sigma_N, eqps_N, dt,
    model, prm, dT_N, dT_NP1, c1, eps, dv, nrows, row_of_local, indptr, indices, data, max_degree, workers, batch,
):
    """Add the finite-difference tangent of the points ``pts`` (in this order) into the BSR
    matrix (indptr, indices, data) (see the module docstring). ``workers`` scratch sets (one
    per thread), ``batch`` points per parallel round (>= workers). y, v are read only (copied
    per worker). Returns (point, status): (-1, 0), or the first point whose probe met a
    singular shape tensor (1) or deformation gradient (2); nothing of that point is added."""
    n = y.shape[0]
    W = workers
    ys = np.empty((W, n, 3))
    vs = np.empty((W, n, 3))
    for w in range(W):
        ys[w] = y
        vs[w] = v
    t9 = np.zeros((W, 8, n, 9))
    t1 = np.zeros((W, 2, n))
    M = 3 * (max_degree + 1)
    Fp = np.empty((W, M))
    Fm = np.empty((W, M))
    Kbuf = np.empty((batch, M * M))
    status = np.zeros(batch, dtype=np.int64)
    rows = np.empty(max_degree + 1, dtype=np.int64)
    keep = np.empty(M, dtype=np.int64)
    npts = pts.shape[0]
    for b0 in range(0, npts, batch):
        nb = min(batch, npts - b0)
        for w in prange(W):
            yw = ys[w]
            vw = vs[w]
            sw = t9[w]
            for k in range(w, nb, W):
                status[k] = point_block(
                    pts[b0 + k], offsets, neighbors, x, yw, vw, volume, horizon, omega_kind, omega_table, V_N, R_N, sigma_N,
                    eqps_N, dt, model, prm, dT_N, dT_NP1, c1, eps, dv, sw[0], sw[1], sw[2], sw[3], sw[4], sw[5], t1[w, 0],
                    t1[w, 1], sw[6], sw[7], Fp[w], Fm[w], Kbuf[k],
                )
        for k in range(nb):
            i = pts[b0 + k]
            if status[k] != 0:
                return i, status[k]
            o = offsets[i]
            ns = offsets[i + 1] - o + 1
            m = 3 * ns
            nk = 0
            for a in range(ns):
                s = neighbors[o + a] if a < ns - 1 else i
                if s < nrows:
                    rows[nk] = row_of_local[s]
                    for c in range(3):
                        keep[3 * nk + c] = 3 * a + c
                    nk += 1
            Kloc = Kbuf[k]
            if nk < ns:  # under MPI: drop the columns and rows of points beyond this rank's rows
                mk = 3 * nk
                for r in range(mk):
                    for cc in range(mk):
                        Kloc[r * mk + cc] = Kloc[keep[r] * m + keep[cc]]
                m = mk
            scatter_local_kernel(rows[:nk], Kloc[: m * m].reshape((m, m)), indptr, indices, data)
    return -1, 0
