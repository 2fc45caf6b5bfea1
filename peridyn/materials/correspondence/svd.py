"""Numerical Recipes' singular value decomposition (``dsvd`` of Peridigm's correspondence.cxx,
PERIDIGM_CORRESPONDENCE.md §8.2 step 3) and the pseudo-inverse of the hypoelastic correspondence
model's shape tensor built on it, operation for operation as Peridigm computes them."""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _sign(a, b):
    """SIGN(a, b) = |a| if b >= 0.0 else -|a|."""
    return abs(a) if b >= 0.0 else -abs(a)


@njit(cache=True, inline="always")
def _pythag(a, b):
    """sqrt(a² + b²) without destructive underflow or overflow (``PYTHAG``)."""
    at = abs(a)
    bt = abs(b)
    if at > bt:
        ct = bt / at
        return at * math.sqrt(1.0 + ct * ct)
    if bt > 0.0:
        ct = at / bt
        return bt * math.sqrt(1.0 + ct * ct)
    return 0.0


@njit(cache=True, error_model="numpy")
def dsvd(a, m, n, w, v, rv1):
    """Golub-Reinsch SVD A = U diag(w) Vᵀ of the m x n row-major ``a`` (m >= n), in place: U
    overwrites ``a``, w (n,) the singular values (unsorted, >= 0), V (n x n row-major) into ``v``;
    ``rv1`` (n,) is scratch. A line-by-line port of Peridigm's ``dsvd`` (Householder
    bidiagonalisation, then implicit-shift QR sweeps, at most 30 per value), including its
    deviations from the printed Numerical Recipes routine (no rv1[i] = c rv1[i] and no break in
    the cancellation loop). Returns False when a value did not converge in 30 sweeps (Peridigm
    goes on silently with what it has), else True."""
    anorm = 0.0
    g = 0.0
    scale = 0.0
    s = 0.0
    f = 0.0
    h = 0.0
    c = 0.0
    x = 0.0
    y = 0.0
    z = 0.0
    l = 0
    nm = 0
    # Householder reduction to bidiagonal form
    for i in range(n):
        l = i + 1
        rv1[i] = scale * g
        g = 0.0
        s = 0.0
        scale = 0.0
        if i < m:
            for k in range(i, m):
                scale += abs(a[k * n + i])
            if scale != 0.0:
                for k in range(i, m):
                    a[k * n + i] = a[k * n + i] / scale
                    s += a[k * n + i] * a[k * n + i]
                f = a[i * n + i]
                g = -_sign(math.sqrt(s), f)
                h = f * g - s
                a[i * n + i] = f - g
                if i != n - 1:
                    for j in range(l, n):
                        s = 0.0
                        for k in range(i, m):
                            s += a[k * n + i] * a[k * n + j]
                        f = s / h
                        for k in range(i, m):
                            a[k * n + j] += f * a[k * n + i]
                for k in range(i, m):
                    a[k * n + i] = a[k * n + i] * scale
        w[i] = scale * g
        g = 0.0
        s = 0.0
        scale = 0.0
        if i < m and i != n - 1:
            for k in range(l, n):
                scale += abs(a[i * n + k])
            if scale != 0.0:
                for k in range(l, n):
                    a[i * n + k] = a[i * n + k] / scale
                    s += a[i * n + k] * a[i * n + k]
                f = a[i * n + l]
                g = -_sign(math.sqrt(s), f)
                h = f * g - s
                a[i * n + l] = f - g
                for k in range(l, n):
                    rv1[k] = a[i * n + k] / h
                if i != m - 1:
                    for j in range(l, m):
                        s = 0.0
                        for k in range(l, n):
                            s += a[j * n + k] * a[i * n + k]
                        for k in range(l, n):
                            a[j * n + k] += s * rv1[k]
                for k in range(l, n):
                    a[i * n + k] = a[i * n + k] * scale
        t = abs(w[i]) + abs(rv1[i])
        anorm = max(anorm, t)  # fmax
    # accumulate the right-hand transformation
    for i in range(n - 1, -1, -1):
        if i < n - 1:
            if g != 0.0:
                for j in range(l, n):
                    v[j * n + i] = (a[i * n + j] / a[i * n + l]) / g  # double division against underflow
                for j in range(l, n):
                    s = 0.0
                    for k in range(l, n):
                        s += a[i * n + k] * v[k * n + j]
                    for k in range(l, n):
                        v[k * n + j] += s * v[k * n + i]
            for j in range(l, n):
                v[i * n + j] = 0.0
                v[j * n + i] = 0.0
        v[i * n + i] = 1.0
        g = rv1[i]
        l = i
    # accumulate the left-hand transformation
    for i in range(n - 1, -1, -1):
        l = i + 1
        g = w[i]
        if i < n - 1:
            for j in range(l, n):
                a[i * n + j] = 0.0
        if g != 0.0:
            g = 1.0 / g
            if i != n - 1:
                for j in range(l, n):
                    s = 0.0
                    for k in range(l, m):
                        s += a[k * n + i] * a[k * n + j]
                    f = (s / a[i * n + i]) * g
                    for k in range(i, m):
                        a[k * n + j] += f * a[k * n + i]
            for j in range(i, m):
                a[j * n + i] = a[j * n + i] * g
        else:
            for j in range(i, m):
                a[j * n + i] = 0.0
        a[i * n + i] += 1.0
    # diagonalise the bidiagonal form
    converged = True
    for k in range(n - 1, -1, -1):
        done = False
        for _its in range(30):
            flag = True
            l = k
            while l >= 0:  # test for splitting (rv1[0] == 0 always stops it)
                nm = l - 1
                if abs(rv1[l]) + anorm == anorm:
                    flag = False
                    break
                if abs(w[nm]) + anorm == anorm:
                    break
                l -= 1
            if flag:  # cancellation of rv1[l]
                s = 1.0
                for i in range(l, k + 1):
                    f = s * rv1[i]
                    if abs(f) + anorm != anorm:
                        g = w[i]
                        h = _pythag(f, g)
                        w[i] = h
                        h = 1.0 / h
                        c = g * h
                        s = -f * h
                        for j in range(m):
                            y = a[j * n + nm]
                            z = a[j * n + i]
                            a[j * n + nm] = y * c + z * s
                            a[j * n + i] = z * c - y * s
            z = w[k]
            if l == k:  # convergence: make the singular value non-negative
                if z < 0.0:
                    w[k] = -z
                    for j in range(n):
                        v[j * n + k] = -v[j * n + k]
                done = True
                break
            # shift from the bottom 2 x 2 minor
            x = w[l]
            nm = k - 1
            y = w[nm]
            g = rv1[nm]
            h = rv1[k]
            f = ((y - z) * (y + z) + (g - h) * (g + h)) / (2.0 * h * y)
            g = _pythag(f, 1.0)
            f = ((x - z) * (x + z) + h * ((y / (f + _sign(g, f))) - h)) / x
            # next QR transformation
            c = 1.0
            s = 1.0
            for j in range(l, nm + 1):
                i = j + 1
                g = rv1[i]
                y = w[i]
                h = s * g
                g = c * g
                z = _pythag(f, h)
                rv1[j] = z
                c = f / z
                s = h / z
                f = x * c + g * s
                g = g * c - x * s
                h = y * s
                y = y * c
                for jj in range(n):
                    x = v[jj * n + j]
                    z = v[jj * n + i]
                    v[jj * n + j] = x * c + z * s
                    v[jj * n + i] = z * c - x * s
                z = _pythag(f, h)
                w[j] = z
                if z != 0.0:
                    z = 1.0 / z
                    c = f * z
                    s = h * z
                f = (c * g) + (s * y)
                x = (c * y) - (s * g)
                for jj in range(m):
                    y = a[jj * n + j]
                    z = a[jj * n + i]
                    a[jj * n + j] = y * c + z * s
                    a[jj * n + i] = z * c - y * s
            rv1[l] = 0.0
            rv1[k] = f
            w[k] = x
        if not done:
            converged = False
    return converged


@njit(cache=True, error_model="numpy")
def pseudo_inverse(M, n, threshold, out):
    """``invertAndCond``: M⁺ (n x n row-major, into ``out``) of the n x n row-major M by
    :func:`dsvd`, M⁺_rc = Σ_{k: w_k > threshold} ((V_rk 1.0)/w_k) U_ck, k ascending from 0.0.
    Never fails: directions with w_k <= threshold are dropped. Returns the SVD's convergence flag."""
    u = M.copy()
    w = np.zeros(n)
    v = np.zeros(n * n)
    rv1 = np.zeros(n)
    ok = dsvd(u, n, n, w, v, rv1)
    for r in range(n):
        for c in range(n):
            acc = 0.0
            for k in range(n):
                if w[k] > threshold:
                    acc += ((v[r * n + k] * 1.0) / w[k]) * u[c * n + k]
            out[r * n + c] = acc
    return ok
