"""Shared helpers for the correspondence-kernel tests, exposed through the ``ref`` fixture.

``ref`` holds an independent pure-Python transcription of PERIDIGM_CORRESPONDENCE.md §0.1, §3-§7
(scalar loops over lists, Python floats: IEEE doubles, left to right, no FMA), written from the
spec's notation rather than from the kernels, plus small point clouds and bond lists. The kernels
must match it bit for bit where the spec fixes the operation order.
"""
from __future__ import annotations

import math
import types

import numpy as np
import pytest

SQ23 = math.sqrt(2.0 / 3.0)


# -- §0.1 -----------------------------------------------------------------------------------------
def mm(a, b, ta=False, tb=False, alpha=1.0):
    """MatMul with optional transposes; alpha applied after the sums unless 1.0."""
    def ea(r, k):
        return a[3 * k + r] if ta else a[3 * r + k]

    def eb(k, c):
        return b[3 * c + k] if tb else b[3 * k + c]

    out = [(ea(r, 0) * eb(0, c) + ea(r, 1) * eb(1, c)) + ea(r, 2) * eb(2, c) for r in range(3) for c in range(3)]
    if alpha != 1.0:
        out = [v * alpha for v in out]
    return out


def inv3(M):
    m = [
        M[4] * M[8] - M[5] * M[7], M[3] * M[8] - M[5] * M[6], M[3] * M[7] - M[4] * M[6],
        M[1] * M[8] - M[2] * M[7], M[0] * M[8] - M[6] * M[2], M[0] * M[7] - M[1] * M[6],
        M[1] * M[5] - M[2] * M[4], M[0] * M[5] - M[2] * M[3], M[0] * M[4] - M[1] * M[3],
    ]
    det = (M[0] * m[0] - M[1] * m[1]) + M[2] * m[2]
    if det == 0.0:
        return [0.0] * 9, det, False
    sign = [1, -1, 1, -1, 1, -1, 1, -1, 1]
    src = [0, 3, 6, 1, 4, 7, 2, 5, 8]  # adjugate: transpose of the cofactors
    inv = [(m[src[k]] / det) if sign[k] > 0 else ((-1.0 * m[src[k]]) / det) for k in range(9)]
    return inv, det, True


# -- influence (PERIDIGM_SEMANTICS.md §3) ---------------------------------------------------------
def omega(kind, zeta, delta, table, b):
    if kind == 0:
        return 1.0
    if kind == 1:
        if zeta > delta:
            return 0.0
        s = zeta / delta
        return 1.0 if s < 0.5 else (-4.0 * s) * s + 4.0 * s
    if kind == 2:
        return math.exp(-(zeta * zeta) / (((delta * delta) * 0.4) * 0.4))
    return float(table[b])


def norm3(a):
    return math.sqrt((a[0] * a[0] + a[1] * a[1]) + a[2] * a[2])


# -- §4.2 -----------------------------------------------------------------------------------------
def ft(L, V, R, dt):
    D = [0.0] * 9
    W = [0.0] * 9
    for k in (0, 4, 8):
        D[k] = L[k]
    for p, q in ((1, 3), (2, 6), (5, 7)):
        D[p] = D[q] = 0.5 * (L[p] + L[q])
        W[p] = 0.5 * (L[p] - L[q])
        W[q] = -1.0 * W[p]
    zX = (((((-V[2]) * D[3] - V[5] * D[4]) - V[8] * D[5]) + V[1] * D[6]) + V[4] * D[7]) + V[7] * D[8]
    zY = ((((V[2] * D[0] + V[5] * D[1]) + V[8] * D[2]) - V[0] * D[6]) - V[3] * D[7]) - V[6] * D[8]
    zZ = (((((-V[1]) * D[0] - V[4] * D[1]) - V[7] * D[2]) + V[0] * D[3]) + V[3] * D[4]) + V[6] * D[5]
    w = [0.5 * (W[7] - W[5]), 0.5 * (W[2] - W[6]), 0.5 * (W[3] - W[1])]
    trV = (V[0] + V[4]) + V[8]
    T = [(trV - V[k]) if k in (0, 4, 8) else -V[k] for k in range(9)]
    Ti, _, _ = inv3(T)
    z = [zX, zY, zZ]
    o = [((w[r] + Ti[3 * r] * z[0]) + Ti[3 * r + 1] * z[1]) + Ti[3 * r + 2] * z[2] for r in range(3)]
    Om = [0.0, -o[2], o[1], o[2], 0.0, -o[0], -o[1], o[0], 0.0]
    Om2 = (o[0] * o[0] + o[1] * o[1]) + o[2] * o[2]
    if Om2 > 1.0e-30:
        mag = math.sqrt(Om2)
        s1 = math.sin(dt * mag) / mag
        s2 = -(1.0 - math.cos(dt * mag)) / Om2
        OO = mm(Om, Om)
        Q = [((1.0 + s1 * Om[k]) + s2 * OO[k]) if k in (0, 4, 8) else (s1 * Om[k] + s2 * OO[k]) for k in range(9)]
    else:
        Q = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    R1 = mm(Q, R)
    A = mm(L, V)
    B = mm(V, Om)
    V1 = [V[k] + dt * (A[k] - B[k]) for k in range(9)]
    d = mm(R1, mm(D, R1), ta=True)
    return V1, R1, d


# -- §3, §4.1 -------------------------------------------------------------------------------------
def kinematics_point(i, offsets, neighbors, x, y, v, vol, horizon, kind, table, VN, RN, dt):
    K = [0.0] * 9
    N = [0.0] * 9
    A = [0.0] * 9
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        xi = [float(x[j, a] - x[i, a]) for a in range(3)]
        eta = [float(y[j, a] - y[i, a]) for a in range(3)]
        dv = [float(v[j, a] - v[i, a]) for a in range(3)]
        w = ((1.0 - 0.0) * omega(kind, norm3(xi), float(horizon[i]), table, b)) * float(vol[j])
        for a in range(3):
            for c in range(3):
                K[3 * a + c] += (w * xi[a]) * xi[c]
                N[3 * a + c] += (w * eta[a]) * xi[c]
                A[3 * a + c] += (w * dv[a]) * xi[c]
    Ki, _, okK = inv3(K)
    F = mm(N, Ki)
    Fdot = mm(A, Ki)
    Finv, _, okF = inv3(F)
    L = mm(Fdot, Finv)
    V1, R1, d = ft(L, list(map(float, VN)), list(map(float, RN)), dt)
    return {"Kinv": Ki, "F": F, "L": L, "V": V1, "R": R1, "d": d, "okK": okK, "okF": okF}


# -- §5 -------------------------------------------------------------------------------------------
def trial(sN, d, dt, K, G, thermal_shift=None):
    eps = [d[k] * dt for k in range(9)]
    dth = (eps[0] + eps[4]) + eps[8]
    de = list(eps)
    for k in (0, 4, 8):
        de[k] -= dth / 3.0
    if thermal_shift is not None:
        dth -= thermal_shift
    sig = [sN[k] + (de[k] * 2.0) * G for k in range(9)]
    for k in (0, 4, 8):
        sig[k] += K * dth
    return sig, de


def dev(sig):
    p = ((sig[0] + sig[4]) + sig[8]) / 3.0
    s = list(sig)
    for k in (0, 4, 8):
        s[k] -= p
    return s, p


def ssum(a, b):
    t = 0.0
    for k in range(9):
        t += a[k] * b[k]
    return t


def ret_and_eqps(s, p, mag_tr, f, de, sN, G, eqps_n):
    c = SQ23 * f / mag_tr
    r = [sk * c for sk in s]
    sig = list(r)
    for k in (0, 4, 8):
        sig[k] += p
    vm = math.sqrt(3.0 / 2.0 * ssum(r, r))
    q, _ = dev(sN)
    mq = max(1.0e-20, math.sqrt(ssum(q, q)))
    a = [de[k] - (r[k] - q[k]) / 2.0 / G for k in range(9)]
    b = [(r[k] / mag_tr + q[k] / mq) / 2.0 for k in range(9)]
    return sig, vm, eqps_n + max(0.0, SQ23 * ssum(a, b))


def elastic(sN, d, dt, K, G, alpha=None, dTN=0.0, dTNP1=0.0):
    shift = 3.0 * (alpha * dTNP1 - alpha * dTN) if alpha is not None else None
    return trial(sN, d, dt, K, G, shift)[0]


def elastic_plastic(sN, d, eqps_n, dt, K, G, sy):
    sig, de = trial(sN, d, dt, K, G)
    s, p = dev(sig)
    t = ssum(s, s)
    vm = math.sqrt(3.0 / 2.0 * t)
    if vm > sy:
        return ret_and_eqps(s, p, max(1.0e-20, math.sqrt(t)), sy, de, sN, G, eqps_n)
    return sig, vm, eqps_n


def reduced_yield(sy, flaw, xi):
    if flaw is None:
        return sy
    fx, fy, fz, size, mag = flaw
    dX, dY, dZ = xi[0] - fx, xi[1] - fy, xi[2] - fz
    return sy * (1.0 - mag * math.exp(((-dX) * dX - dY * dY - dZ * dZ) / size / size))


def hardening(sN, d, eqps_n, dt, K, G, sy, H, flaw=None, xi=None):
    sig, de = trial(sN, d, dt, K, G)
    s, p = dev(sig)
    t = ssum(s, s)
    mag = max(1.0e-20, math.sqrt(t))
    vm = math.sqrt(3.0 / 2.0 * t)
    sr = reduced_yield(sy, flaw, xi)
    if vm < sr:
        return sig, vm, eqps_n
    ebar = ssum(s, de) / mag
    q, _ = dev(sN)
    mq = math.sqrt(ssum(q, q))
    dlam = (6.0 * ebar * G + 3.0 * mq - math.sqrt(6.0) * sr) / (2.0 * (H + 3.0 * G))
    f = sr + H * (eqps_n + SQ23 * dlam)
    if vm > f:
        return ret_and_eqps(s, p, mag, f, de, sN, G, eqps_n)
    return sig, vm, eqps_n


def needleman_g(lam, e, sr, n, m, rate0, e0, e1, dt):
    q = e / e1
    return (sr * math.pow(1.0 + e / e0, n) / (1.0 + q * q)) * math.pow(SQ23 * lam / dt / rate0, m)


def needleman_lambda(ebar, mq, eqps_n, sr, G, n, m, rate0, e0, e1, dt):
    a, b = 0.0, 1.0
    c = (a + b) / 2.0
    lam = 1.0
    for it in range(100000):
        gb = needleman_g(b, eqps_n + b, sr, n, m, rate0, e0, e1, dt)
        gc = needleman_g(c, eqps_n + c, sr, n, m, rate0, e0, e1, dt)
        fb = ebar - b - 1.0 / 2.0 / G * (SQ23 * gb - mq)
        fc = ebar - c - 1.0 / 2.0 / G * (SQ23 * gc - mq)
        if (fb > 0.0 and fc > 0.0) or (fb < 0.0 and fc < 0.0):
            b = c
        else:
            a = c
        old = c
        c = (a + b) / 2.0
        lam = c
        if abs(lam - old) / abs(lam) < 1.0e-6:
            return lam, it + 1
    return lam, 100000


def needleman(sN, d, eqps_n, dt, K, G, sy, n, m, rate0, e0, e1, flaw=None, xi=None):
    sig, de = trial(sN, d, dt, K, G)
    s, p = dev(sig)
    t = ssum(s, s)
    mag = max(1.0e-20, math.sqrt(t))
    vm = math.sqrt(3.0 / 2.0 * t)
    sr = reduced_yield(sy, flaw, xi)
    if vm < sr:
        return sig, vm, eqps_n
    ebar = ssum(s, de) / mag
    q, _ = dev(sN)
    mq = math.sqrt(ssum(q, q))
    lam, _ = needleman_lambda(ebar, mq, eqps_n, sr, G, n, m, rate0, e0, e1, dt)
    f = needleman_g(lam, eqps_n + SQ23 * lam, sr, n, m, rate0, e0, e1, dt)
    if vm > f:
        return ret_and_eqps(s, p, mag, f, de, sN, G, eqps_n)
    return sig, vm, eqps_n


def rotate_piola(R, sh, F, Kinv):
    sig = mm(R, mm(sh, R, tb=True))
    Finv, J, ok = inv3(F)
    P = mm(sig, Finv, tb=True, alpha=J)
    return sig, mm(P, Kinv), ok


# -- §6, §7: Peridigm's serial scatter --------------------------------------------------------------
def scatter_forces(offsets, neighbors, x, vol, horizon, kind, table, A):
    n = len(offsets) - 1
    f = [[0.0, 0.0, 0.0] for _ in range(n)]
    S = [[0.0] * 9 for _ in range(n)]
    for i in range(n):
        Ai = [float(a) for a in A[i]]
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            xi = [float(x[j, a] - x[i, a]) for a in range(3)]
            w = omega(kind, norm3(xi), float(horizon[i]), table, b)
            T = [w * ((Ai[3 * a] * xi[0] + Ai[3 * a + 1] * xi[1]) + Ai[3 * a + 2] * xi[2]) for a in range(3)]
            for c in range(3):
                f[i][c] += T[c] * float(vol[j])
                f[j][c] -= T[c] * float(vol[i])
            for a in range(3):
                for c in range(3):
                    S[i][3 * a + c] += T[a] * xi[c] * float(vol[j])
    return np.array(f), np.array(S)


def scatter_hourglass(offsets, neighbors, x, y, vol, horizon, F, K, C):
    n = len(offsets) - 1
    hg = [[0.0, 0.0, 0.0] for _ in range(n)]
    c1 = 18.0 * C * K / math.pi
    for i in range(n):
        di = float(horizon[i])
        ci = c1 / (di * di * di * di)
        Fi = [float(a) for a in F[i]]
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            xi = [float(x[j, a] - x[i, a]) for a in range(3)]
            eta = [float(y[j, a] - y[i, a]) for a in range(3)]
            e = [float(y[i, a]) + Fi[3 * a] * xi[0] + Fi[3 * a + 1] * xi[1] + Fi[3 * a + 2] * xi[2] for a in range(3)]
            h = [e[a] - float(y[j, a]) for a in range(3)]
            dot = h[0] * eta[0] + h[1] * eta[1] + h[2] * eta[2]
            dot *= -1.0
            M = (1.0 - 0.0) * ci * (dot / norm3(xi)) * (1.0 / norm3(eta))
            for c in range(3):
                hg[i][c] += M * eta[c] * float(vol[j])
                hg[j][c] -= M * eta[c] * float(vol[i])
    return np.array(hg)


# -- point clouds ---------------------------------------------------------------------------------
def lattice(m, spacing=1.0, jitter=0.0, seed=0):
    """m^3 points of a cubic lattice, each moved by up to ``jitter`` spacings per coordinate."""
    g = np.arange(m, dtype=float) * spacing
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    if jitter:
        x = x + np.random.default_rng(seed).uniform(-jitter, jitter, x.shape) * spacing
    return x


def brute_bonds(x, horizon, shuffle_seed=None):
    """CSR (offsets int64, neighbors int32): j in i's family iff 0 < |x_j - x_i| <= horizon[i]
    (one-sided where horizons differ); rows in ascending order, or shuffled with the seed."""
    dist = np.linalg.norm(x[None, :, :] - x[:, None, :], axis=-1)
    rows = []
    rng = np.random.default_rng(shuffle_seed) if shuffle_seed is not None else None
    for i in range(len(x)):
        r = np.flatnonzero((dist[i] <= horizon[i]) & (np.arange(len(x)) != i))
        if rng is not None:
            r = rng.permutation(r)
        rows.append(r)
    offsets = np.zeros(len(x) + 1, dtype=np.int64)
    offsets[1:] = np.cumsum([len(r) for r in rows])
    neighbors = np.concatenate(rows).astype(np.int32) if rows else np.zeros(0, np.int32)
    return offsets, neighbors


def omega_np(kind, zeta, delta):
    """The influence function on arrays (kinds 0-2)."""
    if kind == 0:
        return np.ones_like(zeta)
    if kind == 1:
        s = zeta / delta
        return np.where(zeta > delta, 0.0, np.where(s < 0.5, 1.0, (-4.0 * s) * s + 4.0 * s))
    return np.exp(-(zeta * zeta) / (((delta * delta) * 0.4) * 0.4))


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def rodrigues(axis, angle):
    """Rotation matrix by ``angle`` about the unit vector ``axis`` (closed form)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    W = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * W + (1.0 - math.cos(angle)) * (W @ W)


def as_rows(mats):
    """(n, 3, 3) -> (n, 9) contiguous."""
    return np.ascontiguousarray(np.asarray(mats, dtype=float).reshape(-1, 9))


@pytest.fixture(scope="session")
def ref():
    return types.SimpleNamespace(**{k: v for k, v in globals().items() if not k.startswith("_") and k not in {"pytest", "types", "ref"}})
