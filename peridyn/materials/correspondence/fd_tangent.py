"""Peridigm's central finite-difference tangent of the classic correspondence materials
(PERIDIGM_CORRESPONDENCE.md §12.3), in compiled code.

For every point i of a block (in Peridigm's evaluation order, ``pts``) and every degree of
freedom (q, c) of S_i = [N_i..., i] (neighbors in list order, then i): y_qc is moved by -eps and
+eps and v_qc by -dv and +dv (dv = eps/dt, 0 when dt == 0: the rate form reads velocities), only
point i is re-evaluated from the N state (V_N, R_N, σ̂_N, eqps_N): kinematics, stress update,
rotation and A = P K⁻¹, then the vector force states T(i→j) of i's bonds (hourglass term
included) and their contributions on S_i, f_i += T V_j, f_j -= T V_i
(:func:`peridyn.core.assembly.local_vector_force_kernel`); the column is
(((F+ - F-)/eps)·0.5)·V_s. The local 3|S_i| x 3|S_i| block is added into the matrix with
:func:`peridyn.core.assembly.scatter_local_kernel` (rows ``row_of_local``; degrees of freedom
of points beyond ``nrows`` dropped), points in ``pts`` order: the same arithmetic, in the same
order, as the solver's Python finite-difference path, hence the same matrix bit for bit.

What does not depend on y and v is computed once per point (:func:`prepare_point`): K⁻¹ (the
arithmetic of the ``KINEMATICS`` law of :mod:`.kinematics`), the reference bonds, their influence
weights, the unperturbed η, Δv, 1/|η| and the running N and A sums. A probe of q re-adds the N
and A sums from the first bond to q only (the terms before it, and their partial sums, are the
unperturbed ones), and reads the unperturbed bond data of every bond not touching q; every
floating-point operation of the original per-point functions (:mod:`.kinematics`,
:mod:`.stress`, :mod:`.forces`) is kept, in the same order. The per-point results are written
into per-worker scratch arrays (the material's NP1 fields are not touched), and each worker
perturbs its own copy of y and v. Points are processed in batches: round t computes the local
blocks of batch t in parallel (``prange`` over workers) and, in the same parallel region,
scatters the blocks of batch t - 1, split by matrix rows (worker w adds the rows r with
r % W == w, every block in ``pts`` order), so every matrix entry receives its additions in
Peridigm's order.

Stress models (``model``, parameters ``prm``):

* 0 Elastic: [K, G, α] (thermal when dT_N/dT_NP1 are non-empty);
* 1 Elastic Plastic: [K, G, σ_y];
* 2 Isotropic Hardening: [K, G, σ_y, H, flaw, flaw_x, flaw_y, flaw_z, flaw_size, flaw_magnitude];
* 3 Viscoplastic Needleman: [K, G, σ_y, n, m, ε̇0, ε0, ε1, flaw, flaw_x, flaw_y, flaw_z,
  flaw_size, flaw_magnitude] (flaw != 0.0 switches the flaw on).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ...core.influence import omega
from .stress import (
    elastic_plastic_point,
    elastic_point,
    isotropic_hardening_point,
    needleman_point,
    rotate_piola_point,
)
from .tensor import flanagan_taylor, inv3, load9, matmul, store9

ELASTIC = 0
ELASTIC_PLASTIC = 1
ISOTROPIC_HARDENING = 2
NEEDLEMAN = 3


# Rows of the per-point bond cache ``bc`` (NC, max_degree): for i's bond k (list order) the
# reference bond ξ, ζ = |ξ|, the shape weight ω V_j, the force-state weight ω, V_j, and the
# unperturbed η = y_j - y_i, 1.0/|η|, Δv = v_j - v_i and y_j (reused by the probes that do not
# move y_j, y_i: the same numbers the probe would compute); rows _T0.._T2: a probe's T(i→j).
_X0, _X1, _X2, _ZETA, _WV, _W, _VJ, _E0, _E1, _E2, _ILEN, _U0, _U1, _U2, _Y0, _Y1, _Y2, _T0, _T1, _T2 = range(20)
NC = 20


# not a loop law: per-point set-up of the finite-difference tangent, run for one family inside its parallel iteration
@njit(cache=True, error_model="numpy")
def prepare_point(i, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table, bc, pre, Kinv):
    """The probe-independent part of point i's kinematics: the bond cache ``bc`` (see above),
    K⁻¹ into row i of ``Kinv`` (the arithmetic of :mod:`.kinematics`' ``KINEMATICS``: K does
    not depend on y or v), and the running sums of N and A of the unperturbed state,
    ``pre[k] = (N_0..N_8, A_0..A_8)`` after the first k bonds (list order, from 0.0): a probe
    that moves neither i nor any of the first k neighbours accumulates the same prefix. Returns
    1 if K is singular, else 0."""
    o = offsets[i]
    e = offsets[i + 1]
    delta = horizon[i]
    xi0 = x[i, 0]
    xi1 = x[i, 1]
    xi2 = x[i, 2]
    yi0 = y[i, 0]
    yi1 = y[i, 1]
    yi2 = y[i, 2]
    vi0 = v[i, 0]
    vi1 = v[i, 1]
    vi2 = v[i, 2]
    K0 = K1 = K2 = K3 = K4 = K5 = K6 = K7 = K8 = 0.0
    N0 = N1 = N2 = N3 = N4 = N5 = N6 = N7 = N8 = 0.0
    A0 = A1 = A2 = A3 = A4 = A5 = A6 = A7 = A8 = 0.0
    for k in range(18):
        pre[0, k] = 0.0
    for b in range(o, e):
        k = b - o
        j = neighbors[b]
        X0 = x[j, 0] - xi0
        X1 = x[j, 1] - xi1
        X2 = x[j, 2] - xi2
        zeta = math.sqrt(X0 * X0 + X1 * X1 + X2 * X2)
        om = omega(omega_kind, zeta, delta, omega_table, b)
        w = om * volume[j]
        E0 = y[j, 0] - yi0
        E1 = y[j, 1] - yi1
        E2 = y[j, 2] - yi2
        U0 = v[j, 0] - vi0
        U1 = v[j, 1] - vi1
        U2 = v[j, 2] - vi2
        bc[_X0, k] = X0
        bc[_X1, k] = X1
        bc[_X2, k] = X2
        bc[_ZETA, k] = zeta
        bc[_WV, k] = w
        bc[_W, k] = om
        bc[_VJ, k] = volume[j]
        bc[_E0, k] = E0
        bc[_E1, k] = E1
        bc[_E2, k] = E2
        bc[_ILEN, k] = 1.0 / math.sqrt(E0 * E0 + E1 * E1 + E2 * E2)
        bc[_U0, k] = U0
        bc[_U1, k] = U1
        bc[_U2, k] = U2
        bc[_Y0, k] = y[j, 0]
        bc[_Y1, k] = y[j, 1]
        bc[_Y2, k] = y[j, 2]
        K0 += (w * X0) * X0
        K1 += (w * X0) * X1
        K2 += (w * X0) * X2
        K3 += (w * X1) * X0
        K4 += (w * X1) * X1
        K5 += (w * X1) * X2
        K6 += (w * X2) * X0
        K7 += (w * X2) * X1
        K8 += (w * X2) * X2
        N0 += (w * E0) * X0
        N1 += (w * E0) * X1
        N2 += (w * E0) * X2
        N3 += (w * E1) * X0
        N4 += (w * E1) * X1
        N5 += (w * E1) * X2
        N6 += (w * E2) * X0
        N7 += (w * E2) * X1
        N8 += (w * E2) * X2
        A0 += (w * U0) * X0
        A1 += (w * U0) * X1
        A2 += (w * U0) * X2
        A3 += (w * U1) * X0
        A4 += (w * U1) * X1
        A5 += (w * U1) * X2
        A6 += (w * U2) * X0
        A7 += (w * U2) * X1
        A8 += (w * U2) * X2
        r = pre[k + 1]
        r[0] = N0
        r[1] = N1
        r[2] = N2
        r[3] = N3
        r[4] = N4
        r[5] = N5
        r[6] = N6
        r[7] = N7
        r[8] = N8
        r[9] = A0
        r[10] = A1
        r[11] = A2
        r[12] = A3
        r[13] = A4
        r[14] = A5
        r[15] = A6
        r[16] = A7
        r[17] = A8
    Ki, _, okK = inv3((K0, K1, K2, K3, K4, K5, K6, K7, K8))
    store9(Kinv, i, Ki)
    return 0 if okK else 1


# not a loop law: one probe of the finite-difference tangent on a private copy of one family, inside a parallel iteration
@njit(cache=True, error_model="numpy")
def probe_point(
    i, q, start, offsets, neighbors, x, y, v, volume, V_N, R_N, sigma_N, eqps_N, dt, model, prm, dT_N, dT_NP1, c1, c,
    bc, pre, Kinv, F, V1, R1, d, sig1, eqps1, vm, sigma, A, out,
):
    """Point i's bond contributions on S_i = [N_i..., i] into out (3 |S_i|,) (force density, as
    ``local_vector_force_kernel``) with y_q, v_q perturbed (y, v: the perturbed copies), from
    the cache of :func:`prepare_point`: the N and A sums resume from ``pre[start]`` (``start``:
    the first bond to q, 0 when q == i), the bonds to points other than q (and i) read their
    unperturbed η, Δv and 1/|η| from ``bc``; every sum runs in the order of
    :mod:`.kinematics`' ``KINEMATICS`` and :func:`.forces.force_state_bond` /
    :func:`.forces.hourglass_bond` (c = c1/(((δ_i δ_i) δ_i) δ_i)). Scratch outputs F ... A are
    (n, 9) (eqps1, vm (n,)), row i written. Returns 0 or 2 (singular deformation gradient)."""
    o = offsets[i]
    e = offsets[i + 1]
    nb = e - o
    allc = q == i
    yi0 = y[i, 0]
    yi1 = y[i, 1]
    yi2 = y[i, 2]
    vi0 = v[i, 0]
    vi1 = v[i, 1]
    vi2 = v[i, 2]
    r = pre[start]
    N0 = r[0]
    N1 = r[1]
    N2 = r[2]
    N3 = r[3]
    N4 = r[4]
    N5 = r[5]
    N6 = r[6]
    N7 = r[7]
    N8 = r[8]
    A0 = r[9]
    A1 = r[10]
    A2 = r[11]
    A3 = r[12]
    A4 = r[13]
    A5 = r[14]
    A6 = r[15]
    A7 = r[16]
    A8 = r[17]
    for k in range(start, nb):
        j = neighbors[o + k]
        X0 = bc[_X0, k]
        X1 = bc[_X1, k]
        X2 = bc[_X2, k]
        w = bc[_WV, k]
        if allc or j == q:
            E0 = y[j, 0] - yi0
            E1 = y[j, 1] - yi1
            E2 = y[j, 2] - yi2
            U0 = v[j, 0] - vi0
            U1 = v[j, 1] - vi1
            U2 = v[j, 2] - vi2
        else:
            E0 = bc[_E0, k]
            E1 = bc[_E1, k]
            E2 = bc[_E2, k]
            U0 = bc[_U0, k]
            U1 = bc[_U1, k]
            U2 = bc[_U2, k]
        N0 += (w * E0) * X0
        N1 += (w * E0) * X1
        N2 += (w * E0) * X2
        N3 += (w * E1) * X0
        N4 += (w * E1) * X1
        N5 += (w * E1) * X2
        N6 += (w * E2) * X0
        N7 += (w * E2) * X1
        N8 += (w * E2) * X2
        A0 += (w * U0) * X0
        A1 += (w * U0) * X1
        A2 += (w * U0) * X2
        A3 += (w * U1) * X0
        A4 += (w * U1) * X1
        A5 += (w * U1) * X2
        A6 += (w * U2) * X0
        A7 += (w * U2) * X1
        A8 += (w * U2) * X2
    Ki = load9(Kinv, i)
    Fi = matmul((N0, N1, N2, N3, N4, N5, N6, N7, N8), Ki)
    Fdot = matmul((A0, A1, A2, A3, A4, A5, A6, A7, A8), Ki)
    Finv, _, okF = inv3(Fi)
    Li = matmul(Fdot, Finv)
    Vn, Rn, di = flanagan_taylor(Li, load9(V_N, i), load9(R_N, i), dt)
    store9(F, i, Fi)
    store9(V1, i, Vn)
    store9(R1, i, Rn)
    store9(d, i, di)
    if not okF:
        return 2
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
    a0 = A[i, 0]
    a1 = A[i, 1]
    a2 = A[i, 2]
    a3 = A[i, 3]
    a4 = A[i, 4]
    a5 = A[i, 5]
    a6 = A[i, 6]
    a7 = A[i, 7]
    a8 = A[i, 8]
    f0, f1, f2, f3, f4, f5, f6, f7, f8 = Fi
    # T(i→j) of every bond from the unperturbed bond data (no branch: vectorizable), then the
    # bonds to q (all bonds when q == i) again from the perturbed y
    if c1 != 0.0:
        for k in range(nb):
            X0 = bc[_X0, k]
            X1 = bc[_X1, k]
            X2 = bc[_X2, k]
            w = bc[_W, k]
            E0 = bc[_E0, k]
            E1 = bc[_E1, k]
            E2 = bc[_E2, k]
            h0 = (((yi0 + f0 * X0) + f1 * X1) + f2 * X2) - bc[_Y0, k]
            h1 = (((yi1 + f3 * X0) + f4 * X1) + f5 * X2) - bc[_Y1, k]
            h2 = (((yi2 + f6 * X0) + f7 * X1) + f8 * X2) - bc[_Y2, k]
            dot = (h0 * E0 + h1 * E1) + h2 * E2
            dot = dot * -1.0
            M = (c * (dot / bc[_ZETA, k])) * bc[_ILEN, k]
            bc[_T0, k] = w * ((a0 * X0 + a1 * X1) + a2 * X2) + M * E0
            bc[_T1, k] = w * ((a3 * X0 + a4 * X1) + a5 * X2) + M * E1
            bc[_T2, k] = w * ((a6 * X0 + a7 * X1) + a8 * X2) + M * E2
        for k in range(start, nb):
            j = neighbors[o + k]
            if allc or j == q:
                X0 = bc[_X0, k]
                X1 = bc[_X1, k]
                X2 = bc[_X2, k]
                w = bc[_W, k]
                E0 = y[j, 0] - yi0
                E1 = y[j, 1] - yi1
                E2 = y[j, 2] - yi2
                il = 1.0 / math.sqrt(E0 * E0 + E1 * E1 + E2 * E2)
                h0 = (((yi0 + f0 * X0) + f1 * X1) + f2 * X2) - y[j, 0]
                h1 = (((yi1 + f3 * X0) + f4 * X1) + f5 * X2) - y[j, 1]
                h2 = (((yi2 + f6 * X0) + f7 * X1) + f8 * X2) - y[j, 2]
                dot = (h0 * E0 + h1 * E1) + h2 * E2
                dot = dot * -1.0
                M = (c * (dot / bc[_ZETA, k])) * il
                bc[_T0, k] = w * ((a0 * X0 + a1 * X1) + a2 * X2) + M * E0
                bc[_T1, k] = w * ((a3 * X0 + a4 * X1) + a5 * X2) + M * E1
                bc[_T2, k] = w * ((a6 * X0 + a7 * X1) + a8 * X2) + M * E2
    else:
        for k in range(nb):
            X0 = bc[_X0, k]
            X1 = bc[_X1, k]
            X2 = bc[_X2, k]
            w = bc[_W, k]
            bc[_T0, k] = w * ((a0 * X0 + a1 * X1) + a2 * X2)
            bc[_T1, k] = w * ((a3 * X0 + a4 * X1) + a5 * X2)
            bc[_T2, k] = w * ((a6 * X0 + a7 * X1) + a8 * X2)
    Vi = volume[i]
    fx = 0.0
    fy = 0.0
    fz = 0.0
    for k in range(nb):
        tx = bc[_T0, k]
        ty = bc[_T1, k]
        tz = bc[_T2, k]
        kk = 3 * k
        out[kk] = -tx * Vi
        out[kk + 1] = -ty * Vi
        out[kk + 2] = -tz * Vi
        Vj = bc[_VJ, k]
        fx += tx * Vj
        fy += ty * Vj
        fz += tz * Vj
    kk = 3 * nb
    out[kk] = fx
    out[kk + 1] = fy
    out[kk + 2] = fz
    return 0


# not a loop law: assembles one point's dense block of the finite-difference tangent (every probe of its family)
@njit(cache=True, error_model="numpy")
def point_block(
    i, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table, V_N, R_N, sigma_N, eqps_N, dt,
    model, prm, dT_N, dT_NP1, c1, eps, dv, Kinv, F, V1, R1, d, sig1, eqps1, vm, sigma, A, Fp, Fm, Kloc, bc, pre,
):
    """The local block of point i into Kloc[:(3 ns)^2] (row-major 3 ns x 3 ns, ns = |S_i|);
    y and v (this worker's copies) are perturbed and restored; bc, pre: the scratch of
    :func:`prepare_point`. Returns 0 when all probes succeeded, 1 for a singular shape tensor,
    2 for a singular deformation gradient in a probe."""
    st = prepare_point(i, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table, bc, pre, Kinv)
    if st != 0:
        return st
    delta = horizon[i]
    c = c1 / (((delta * delta) * delta) * delta)
    o = offsets[i]
    ns = offsets[i + 1] - o + 1
    m = 3 * ns
    for a in range(ns):
        q = neighbors[o + a] if a < ns - 1 else i
        start = 0
        if q != i:  # the first bond to q (its list position unless q is listed twice)
            start = a
            for k in range(a):
                if neighbors[o + k] == q:
                    start = k
                    break
        for cc in range(3):
            orig = y[q, cc]
            vorig = v[q, cc]
            y[q, cc] = orig - eps
            v[q, cc] = vorig - dv
            st = probe_point(i, q, start, offsets, neighbors, x, y, v, volume, V_N, R_N, sigma_N, eqps_N, dt, model, prm, dT_N,
                             dT_NP1, c1, c, bc, pre, Kinv, F, V1, R1, d, sig1, eqps1, vm, sigma, A, Fm)
            if st == 0:
                y[q, cc] = orig + eps
                v[q, cc] = vorig + dv
                st = probe_point(i, q, start, offsets, neighbors, x, y, v, volume, V_N, R_N, sigma_N, eqps_N, dt, model, prm, dT_N,
                                 dT_NP1, c1, c, bc, pre, Kinv, F, V1, R1, d, sig1, eqps1, vm, sigma, A, Fp)
            y[q, cc] = orig
            v[q, cc] = vorig
            if st != 0:
                return st
            col = 3 * a + cc
            r = 0
            for bb in range(ns):
                Vs = bc[_VJ, bb] if bb < ns - 1 else volume[i]  # V_s, s = [N_i..., i][bb]
                for _ in range(3):
                    Kloc[r * m + col] = (((Fp[r] - Fm[r]) / eps) * 0.5) * Vs
                    r += 1
    return 0


# not a loop law: scatters a point's block into the block-sparse matrix (row maps, not bond sums)
@njit(cache=True, error_model="numpy")
def scatter_rows(w, W, i, offsets, neighbors, nrows, row_of_local, Kloc, indptr, indices, data):
    """data += the rows r (r % W == w) of point i's local block Kloc (row-major 3 ns x 3 ns,
    S_i = [N_i..., i]); degrees of freedom of points beyond ``nrows`` dropped, entries outside
    the pattern dropped: the additions of :func:`peridyn.core.assembly.scatter_local_kernel`
    that fall into those rows (each matrix entry receives the same value)."""
    o = offsets[i]
    ns = offsets[i + 1] - o + 1
    m = 3 * ns
    for a in range(ns):
        sa = neighbors[o + a] if a < ns - 1 else i
        if sa >= nrows:
            continue
        r = row_of_local[sa]
        if r % W != w:
            continue
        lo = indptr[r]
        hi = indptr[r + 1]
        for b in range(ns):
            sb = neighbors[o + b] if b < ns - 1 else i
            if sb >= nrows:
                continue
            col = row_of_local[sb]
            left = lo
            right = hi
            while left < right:
                mid = (left + right) // 2
                if indices[mid] < col:
                    left = mid + 1
                else:
                    right = mid
            if left < hi and indices[left] == col:
                for dd in range(3):
                    base = (3 * a + dd) * m + 3 * b
                    for c in range(3):
                        data[left, dd, c] += Kloc[base + c]


# not a loop law: parallel over points, each assembling and scattering its block-sparse rows
@njit(cache=True, parallel=True, error_model="numpy")
def fd_tangent_kernel(
    pts, offsets, neighbors, x, y, v, volume, horizon, omega_kind, omega_table, V_N, R_N, sigma_N, eqps_N, dt,
    model, prm, dT_N, dT_NP1, c1, eps, dv, nrows, row_of_local, indptr, indices, data, max_degree, workers, batch,
):
    """Add the finite-difference tangent of the points ``pts`` (in this order) into the BSR
    matrix (indptr, indices, data) (see the module docstring). ``workers`` scratch sets (one
    per thread), ``batch`` points per parallel round (>= workers). y, v are read only (copied
    per worker). Returns (point, status): (-1, 0), or the first point whose probe met a
    singular shape tensor (1) or deformation gradient (2); nothing of that point is added.

    Round t computes the blocks of batch t (worker w: its points k = w, w + W, ...) and, in the
    same parallel region, scatters the blocks of batch t - 1 (two buffers), worker w adding the
    matrix rows r with r % W == w: every matrix entry still receives its additions in ``pts``
    order."""
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
    Kbuf = np.empty((2, batch, M * M))
    status = np.zeros((2, batch), dtype=np.int64)
    bcs = np.empty((W, NC, max(max_degree, 1)))
    pres = np.empty((W, max_degree + 1, 18))
    npts = pts.shape[0]
    nbat = (npts + batch - 1) // batch
    for t in range(nbat + 1):
        cur = t % 2
        prev = 1 - cur
        b0 = t * batch
        nb = min(batch, npts - b0) if t < nbat else 0
        p0 = (t - 1) * batch
        npv = min(batch, npts - p0) if t > 0 else 0
        nsc = npv  # batch t - 1 is scattered up to its first failed point
        for k in range(npv):
            if status[prev, k] != 0:
                nsc = k
                break
        for w in prange(W):
            yw = ys[w]
            vw = vs[w]
            sw = t9[w]
            for k in range(w, nb, W):
                status[cur, k] = point_block(
                    pts[b0 + k], offsets, neighbors, x, yw, vw, volume, horizon, omega_kind, omega_table, V_N, R_N, sigma_N,
                    eqps_N, dt, model, prm, dT_N, dT_NP1, c1, eps, dv, sw[0], sw[1], sw[2], sw[3], sw[4], sw[5], t1[w, 0],
                    t1[w, 1], sw[6], sw[7], Fp[w], Fm[w], Kbuf[cur, k], bcs[w], pres[w],
                )
            for k in range(nsc):
                scatter_rows(w, W, pts[p0 + k], offsets, neighbors, nrows, row_of_local, Kbuf[prev, k], indptr, indices, data)
        if nsc < npv:
            return pts[p0 + nsc], status[prev, nsc]
    return -1, 0
