"""3x3 tensor helpers with Peridigm's exact operation order (PERIDIGM_CORRESPONDENCE.md §0.1, §4.2).

A tensor is a flat row-major sequence of 9 floats: index 0 = XX, 1 = XY, 2 = XZ, 3 = YX, ...,
8 = ZZ (``correspondence.cxx — MatrixMultiply``). The helpers take any 9-sequence numba can index
(a tuple or a 1-D array row such as ``F[i]``) and return 9-tuples, which live in registers inside
the callers' ``prange`` loops (no heap allocation per point). Every expression is written with the
evaluation order of the C++ source: left-to-right sums, no fused multiply-add (numba does not
contract ``a*b + c`` without ``fastmath``).

All helpers are ``inline="always"``: numba inlines them into the kernels that call them.
"""
from __future__ import annotations

import math

from numba import njit

IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
ZERO = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@njit(cache=True, inline="always")
def load9(a, i):
    """Row i of an (n, 9) array as a 9-tuple."""
    return (a[i, 0], a[i, 1], a[i, 2], a[i, 3], a[i, 4], a[i, 5], a[i, 6], a[i, 7], a[i, 8])


@njit(cache=True, inline="always")
def store9(a, i, t):
    """a[i, :] = t for an (n, 9) array a and a 9-tuple t."""
    a[i, 0] = t[0]
    a[i, 1] = t[1]
    a[i, 2] = t[2]
    a[i, 3] = t[3]
    a[i, 4] = t[4]
    a[i, 5] = t[5]
    a[i, 6] = t[6]
    a[i, 7] = t[7]
    a[i, 8] = t[8]


@njit(cache=True, inline="always")
def matmul(a, b):
    """A·B: C_rc = (A_r0 B_0c + A_r1 B_1c) + A_r2 B_2c."""
    return (
        (a[0] * b[0] + a[1] * b[3]) + a[2] * b[6],
        (a[0] * b[1] + a[1] * b[4]) + a[2] * b[7],
        (a[0] * b[2] + a[1] * b[5]) + a[2] * b[8],
        (a[3] * b[0] + a[4] * b[3]) + a[5] * b[6],
        (a[3] * b[1] + a[4] * b[4]) + a[5] * b[7],
        (a[3] * b[2] + a[4] * b[5]) + a[5] * b[8],
        (a[6] * b[0] + a[7] * b[3]) + a[8] * b[6],
        (a[6] * b[1] + a[7] * b[4]) + a[8] * b[7],
        (a[6] * b[2] + a[7] * b[5]) + a[8] * b[8],
    )


@njit(cache=True, inline="always")
def matmul_nt(a, b):
    """A·Bᵀ: C_rc = (A_r0 B_c0 + A_r1 B_c1) + A_r2 B_c2."""
    return (
        (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2],
        (a[0] * b[3] + a[1] * b[4]) + a[2] * b[5],
        (a[0] * b[6] + a[1] * b[7]) + a[2] * b[8],
        (a[3] * b[0] + a[4] * b[1]) + a[5] * b[2],
        (a[3] * b[3] + a[4] * b[4]) + a[5] * b[5],
        (a[3] * b[6] + a[4] * b[7]) + a[5] * b[8],
        (a[6] * b[0] + a[7] * b[1]) + a[8] * b[2],
        (a[6] * b[3] + a[7] * b[4]) + a[8] * b[5],
        (a[6] * b[6] + a[7] * b[7]) + a[8] * b[8],
    )


@njit(cache=True, inline="always")
def matmul_tn(a, b):
    """Aᵀ·B: C_rc = (A_0r B_0c + A_1r B_1c) + A_2r B_2c."""
    return (
        (a[0] * b[0] + a[3] * b[3]) + a[6] * b[6],
        (a[0] * b[1] + a[3] * b[4]) + a[6] * b[7],
        (a[0] * b[2] + a[3] * b[5]) + a[6] * b[8],
        (a[1] * b[0] + a[4] * b[3]) + a[7] * b[6],
        (a[1] * b[1] + a[4] * b[4]) + a[7] * b[7],
        (a[1] * b[2] + a[4] * b[5]) + a[7] * b[8],
        (a[2] * b[0] + a[5] * b[3]) + a[8] * b[6],
        (a[2] * b[1] + a[5] * b[4]) + a[8] * b[7],
        (a[2] * b[2] + a[5] * b[5]) + a[8] * b[8],
    )


@njit(cache=True, inline="always")
def scale_unless_one(t, alpha):
    """MatrixMultiply's ``alpha != 1.0`` branch: every entry times alpha, after the sums; t itself
    when alpha == 1.0."""
    if alpha != 1.0:
        return (
            t[0] * alpha, t[1] * alpha, t[2] * alpha,
            t[3] * alpha, t[4] * alpha, t[5] * alpha,
            t[6] * alpha, t[7] * alpha, t[8] * alpha,
        )
    return (t[0], t[1], t[2], t[3], t[4], t[5], t[6], t[7], t[8])


@njit(cache=True, inline="always")
def matmul_scaled(a, b, alpha):
    """alpha·(A·B), alpha applied after the sums (skipped when alpha == 1.0)."""
    return scale_unless_one(matmul(a, b), alpha)


@njit(cache=True, inline="always")
def matmul_nt_scaled(a, b, alpha):
    """alpha·(A·Bᵀ), alpha applied after the sums (skipped when alpha == 1.0)."""
    return scale_unless_one(matmul_nt(a, b), alpha)


@njit(cache=True, inline="always")
def matmul_tn_scaled(a, b, alpha):
    """alpha·(Aᵀ·B), alpha applied after the sums (skipped when alpha == 1.0)."""
    return scale_unless_one(matmul_tn(a, b), alpha)


@njit(cache=True, inline="always", error_model="numpy")
def inv3(m):
    """(M⁻¹, det M, ok) by ``Invert3by3Matrix``: minors, det = (M0 m0 - M1 m1) + M2 m2, entries
    m/det with the negative ones as (-1.0 m)/det. det == 0.0 exactly: (zeros, 0.0, False)."""
    m0 = m[4] * m[8] - m[5] * m[7]
    m1 = m[3] * m[8] - m[5] * m[6]
    m2 = m[3] * m[7] - m[4] * m[6]
    m3 = m[1] * m[8] - m[2] * m[7]
    m4 = m[0] * m[8] - m[6] * m[2]
    m5 = m[0] * m[7] - m[1] * m[6]
    m6 = m[1] * m[5] - m[2] * m[4]
    m7 = m[0] * m[5] - m[2] * m[3]
    m8 = m[0] * m[4] - m[1] * m[3]
    det = (m[0] * m0 - m[1] * m1) + m[2] * m2
    if det == 0.0:
        return ZERO, det, False
    inv = (
        m0 / det, (-1.0 * m3) / det, m6 / det,
        (-1.0 * m1) / det, m4 / det, (-1.0 * m7) / det,
        m2 / det, (-1.0 * m5) / det, m8 / det,
    )
    return inv, det, True


@njit(cache=True, inline="always", error_model="numpy")
def flanagan_taylor(L, V, R, dt):
    """Flanagan-Taylor kernel FT(L, V_N, R_N, dt) -> (V_NP1, R_NP1, d), §4.2 step by step.

    L: velocity gradient (1/T); V: left stretch at N; R: rotation at N; dt (T). Returns the left
    stretch and rotation at NP1 (forward Euler for V, exponential map for R) and the unrotated
    rate of deformation d = R_NP1ᵀ·(D·R_NP1) (1/T). A singular (tr V)·I - V is ignored (its
    inverse is taken as zero, no error), as in Peridigm.
    """
    # 1-2: D keeps L's diagonal verbatim; W the skew part
    D0 = L[0]
    D4 = L[4]
    D8 = L[8]
    D1 = 0.5 * (L[1] + L[3])
    D2 = 0.5 * (L[2] + L[6])
    D5 = 0.5 * (L[5] + L[7])
    D = (D0, D1, D2, D1, D4, D5, D2, D5, D8)
    W1 = 0.5 * (L[1] - L[3])
    W2 = 0.5 * (L[2] - L[6])
    W5 = 0.5 * (L[5] - L[7])
    W3 = -1.0 * W1
    W6 = -1.0 * W2
    W7 = -1.0 * W5
    # 3: z_i = eps_ikj D_jm V_mk, the source's term order
    zX = (((((-V[2]) * D1 - V[5] * D4) - V[8] * D5) + V[1] * D2) + V[4] * D5) + V[7] * D8
    zY = ((((V[2] * D0 + V[5] * D1) + V[8] * D2) - V[0] * D2) - V[3] * D5) - V[6] * D8
    zZ = (((((-V[1]) * D0 - V[4] * D1) - V[7] * D2) + V[0] * D1) + V[3] * D4) + V[6] * D5
    # 4: w = -1/2 eps W
    wX = 0.5 * (W7 - W5)
    wY = 0.5 * (W2 - W6)
    wZ = 0.5 * (W3 - W1)
    # 5: (tr V I - V)^-1, singular -> zeros, ignored
    trV = (V[0] + V[4]) + V[8]
    T = (trV - V[0], -V[1], -V[2], -V[3], trV - V[4], -V[5], -V[6], -V[7], trV - V[8])
    Ti, _, _ = inv3(T)
    # 6-7: omega = w + T^-1 z, Omega = skew(omega)
    oX = ((wX + Ti[0] * zX) + Ti[1] * zY) + Ti[2] * zZ
    oY = ((wY + Ti[3] * zX) + Ti[4] * zY) + Ti[5] * zZ
    oZ = ((wZ + Ti[6] * zX) + Ti[7] * zY) + Ti[8] * zZ
    Om = (0.0, -oZ, oY, oZ, 0.0, -oX, -oY, oX, 0.0)
    Om2 = (oX * oX + oY * oY) + oZ * oZ
    Omag = math.sqrt(Om2)
    # 8: Q = exp(dt Omega) (Rodrigues), identity for tiny spin
    if Om2 > 1.0e-30:
        s1 = math.sin(dt * Omag) / Omag
        s2 = (-(1.0 - math.cos(dt * Omag))) / Om2
        OO = matmul(Om, Om)
        Q = (
            (1.0 + s1 * Om[0]) + s2 * OO[0], s1 * Om[1] + s2 * OO[1], s1 * Om[2] + s2 * OO[2],
            s1 * Om[3] + s2 * OO[3], (1.0 + s1 * Om[4]) + s2 * OO[4], s1 * Om[5] + s2 * OO[5],
            s1 * Om[6] + s2 * OO[6], s1 * Om[7] + s2 * OO[7], (1.0 + s1 * Om[8]) + s2 * OO[8],
        )
    else:
        Q = IDENTITY
    # 9: R_NP1 = Q R_N
    R1 = matmul(Q, R)
    # 10: V_NP1 = V_N + dt (L V - V Omega)
    A = matmul(L, V)
    B = matmul(V, Om)
    V1 = (
        V[0] + dt * (A[0] - B[0]), V[1] + dt * (A[1] - B[1]), V[2] + dt * (A[2] - B[2]),
        V[3] + dt * (A[3] - B[3]), V[4] + dt * (A[4] - B[4]), V[5] + dt * (A[5] - B[5]),
        V[6] + dt * (A[6] - B[6]), V[7] + dt * (A[7] - B[7]), V[8] + dt * (A[8] - B[8]),
    )
    # 11: d = R_NP1^T (D R_NP1)
    d = matmul_tn(R1, matmul(D, R1))
    return V1, R1, d
