"""AztecOO's GMRES (``az_gmres.c``) with its safeguards, as NOX's ``LinearSystemAztecOO`` runs it.

Beyond plain restarted GMRES (right preconditioning, classical Gram-Schmidt twice or modified
Gram-Schmidt, Givens rotations, ``AZ_r0`` convergence on the recursive residual), AztecOO

* estimates the condition number of the triangular factor of the Hessenberg matrix at every
  iteration with LAPACK's incremental condition estimator (DLAIC1) and stops, keeping the
  solution of the previous iteration, when it exceeds ``AZ_ill_cond_thresh`` (1e11; NOX's
  ``Ill-Conditioning Threshold``) or when the new diagonal entry is below DBL_EPSILON
  ("the matrix may be singular; GMRES may have a least-squares solution"). On a singular
  tangent (a body free to translate or rotate) this is what keeps the null-space part of the
  solution at round-off size instead of letting hundreds of iterations inflate it;
* when the recursive residual says converged, computes the true residual ||b - A x|| / ||r0||;
  if that is not below the tolerance either, it quits ("loss of precision") when the two differ
  by more than the tolerance, else tightens the tolerance by 1.5 x the difference, takes back
  the cycle's update and iterates on;
* at a restart, forms the new residual as r - A dx from the cycle's residual.

Returns a :class:`~peridyn.solvers.linalg.linear.SolveResult` (``converged`` false for every early stop).
"""
from __future__ import annotations

import math

import numpy as np

from .linear import SolveResult, gdot, gsum

DBL_EPSILON = float(np.finfo(float).eps)
#: LAPACK's dlamch('E') (relative machine precision, rounding mode)
LAPACK_EPS = DBL_EPSILON * 0.5


def dlaic1(job: int, x: np.ndarray, sest: float, w: np.ndarray, gamma: float) -> tuple[float, float, float]:
    """LAPACK DLAIC1, real case: one step of incremental condition estimation. For a lower
    triangular L with the estimate ``sest`` of its largest (job 1) or smallest (job 2) singular
    value and the approximate singular vector x, returns (sestpr, s, c) for the extended matrix
    [[L, 0], [w^T, gamma]] with the new vector [s x, c]."""
    eps = LAPACK_EPS
    alpha = float(np.dot(x, w))
    absalp = abs(alpha)
    absgam = abs(gamma)
    absest = abs(sest)
    if job == 1:
        if sest == 0.0:
            s1 = max(absgam, absalp)
            if s1 == 0.0:
                return 0.0, 0.0, 1.0
            s = alpha / s1
            c = gamma / s1
            tmp = math.sqrt(s * s + c * c)
            return s1 * tmp, s / tmp, c / tmp
        if absgam <= eps * absest:
            tmp = max(absest, absalp)
            s1 = absest / tmp
            s2 = absalp / tmp
            return tmp * math.sqrt(s1 * s1 + s2 * s2), 1.0, 0.0
        if absalp <= eps * absest:
            s1, s2 = absgam, absest
            return (s2, 1.0, 0.0) if s1 <= s2 else (s1, 0.0, 1.0)
        if absest <= eps * absalp or absest <= eps * absgam:
            s1, s2 = absgam, absalp
            if s1 <= s2:
                tmp = s1 / s2
                s = math.sqrt(1.0 + tmp * tmp)
                sestpr = s2 * s
                c = (gamma / s2) / s
                s = math.copysign(1.0, alpha) / s
                return sestpr, s, c
            tmp = s2 / s1
            c = math.sqrt(1.0 + tmp * tmp)
            sestpr = s1 * c
            s = (alpha / s1) / c
            c = math.copysign(1.0, gamma) / c
            return sestpr, s, c
        zeta1 = alpha / absest
        zeta2 = gamma / absest
        b = (1.0 - zeta1 * zeta1 - zeta2 * zeta2) * 0.5
        c = zeta1 * zeta1
        if b > 0.0:
            t = c / (b + math.sqrt(b * b + c))
        else:
            t = math.sqrt(b * b + c) - b
        sine = -zeta1 / t
        cosine = -zeta2 / (1.0 + t)
        tmp = math.sqrt(sine * sine + cosine * cosine)
        return math.sqrt(t + 1.0) * absest, sine / tmp, cosine / tmp
    # job 2: smallest singular value
    if sest == 0.0:
        if max(absgam, absalp) == 0.0:
            sine, cosine = 1.0, 0.0
        else:
            sine, cosine = -gamma, alpha
        s1 = max(abs(sine), abs(cosine))
        s = sine / s1
        c = cosine / s1
        tmp = math.sqrt(s * s + c * c)
        return 0.0, s / tmp, c / tmp
    if absgam <= eps * absest:
        return absgam, 0.0, 1.0
    if absalp <= eps * absest:
        s1, s2 = absgam, absest
        return (s1, 0.0, 1.0) if s1 <= s2 else (s2, 1.0, 0.0)
    if absest <= eps * absalp or absest <= eps * absgam:
        s1, s2 = absgam, absalp
        if s1 <= s2:
            tmp = s1 / s2
            c = math.sqrt(1.0 + tmp * tmp)
            sestpr = absest * (tmp / c)
            s = -(gamma / s2) / c
            c = math.copysign(1.0, alpha) / c
            return sestpr, s, c
        tmp = s2 / s1
        s = math.sqrt(1.0 + tmp * tmp)
        sestpr = absest / s
        c = (alpha / s1) / s
        s = -math.copysign(1.0, gamma) / s
        return sestpr, s, c
    zeta1 = alpha / absest
    zeta2 = gamma / absest
    norma = max(1.0 + zeta1 * zeta1 + abs(zeta1 * zeta2), abs(zeta1 * zeta2) + zeta2 * zeta2)
    test = 1.0 + 2.0 * (zeta1 - zeta2) * (zeta1 + zeta2)
    if test >= 0.0:
        b = (zeta1 * zeta1 + zeta2 * zeta2 + 1.0) * 0.5
        c = zeta2 * zeta2
        t = c / (b + math.sqrt(abs(b * b - c)))
        sine = zeta1 / (1.0 - t)
        cosine = -zeta2 / t
        sestpr = math.sqrt(t + 4.0 * eps * eps * norma) * absest
    else:
        b = (zeta2 * zeta2 + zeta1 * zeta1 - 1.0) * 0.5
        c = zeta1 * zeta1
        if b >= 0.0:
            t = -c / (b + math.sqrt(b * b + c))
        else:
            t = b - math.sqrt(b * b + c)
        sine = -zeta1 / t
        cosine = -zeta2 / (1.0 + t)
        sestpr = math.sqrt(1.0 + t + 4.0 * eps * eps * norma) * absest
    tmp = math.sqrt(sine * sine + cosine * cosine)
    return sestpr, sine / tmp, cosine / tmp


def _increment(H: np.ndarray, g: np.ndarray, V: np.ndarray, i: int, precond) -> np.ndarray:
    """M^-1 V_i y with y solving the i x i upper triangular H y = g (AZ_get_x_incr)."""
    y = np.zeros(i)
    for k in range(i - 1, -1, -1):
        y[k] = (g[k] - np.dot(H[k, k + 1 : i], y[k + 1 : i])) / H[k, k]
    dx = y @ V[:i] if i else np.zeros(V.shape[1])
    return precond(dx) if precond is not None else dx


def aztecoo_gmres(
    matvec, b: np.ndarray, x0: np.ndarray | None, tol: float, kspace: int, maxiter: int, precond=None, *,
    classical: bool = True, comm=None, ill_cond_thresh: float = 1.0e11,
) -> SolveResult:
    """Solve A x = b as AztecOO's ``AZ_gmres`` with ``AZ_conv = AZ_r0`` (see module docstring).
    ``matvec(x, out)``; ``precond(v)`` returns M^-1 v; vectors distributed over ``comm``."""
    n = b.shape[0]
    x = np.zeros(n) if x0 is None else x0.astype(float, copy=True)
    tmp = np.empty(n)
    matvec(x, tmp)
    r = b - tmp
    r0 = math.sqrt(float(gdot(comm, r, r)))
    if r0 == 0.0:
        return SolveResult(x, True, 0)
    epsilon = tol
    rnorm = r0
    it = 0
    converged = False

    def stop(message: str) -> SolveResult:
        matvec(x, tmp)
        res = b - tmp
        actual = math.sqrt(float(gdot(comm, res, res))) / r0
        return SolveResult(x, actual < tol, it, f"{message} after {it} iterations (relative residual {actual:.3g})")

    while not converged and it < maxiter:
        beta = rnorm
        V = np.zeros((kspace + 1, n))
        V[0] = r * (1.0 / beta)
        H = np.zeros((kspace + 1, kspace))
        cs = np.zeros(kspace)
        sn = np.zeros(kspace)
        g = np.zeros(kspace + 1)
        g[0] = beta
        svbig = np.zeros(kspace + 1)
        svsml = np.zeros(kspace + 1)
        big = small = 0.0
        dx = np.zeros(n)
        i = 0
        while i < kspace and not converged and it < maxiter:
            it += 1
            z = precond(V[i]) if precond is not None else V[i]
            matvec(z, tmp)
            w = tmp.copy()
            if classical:
                for _ in range(2):
                    dots = gsum(comm, V[: i + 1] @ w)
                    H[: i + 1, i] += dots
                    w -= dots @ V[: i + 1]
            else:
                for k in range(i + 1):
                    d = float(gdot(comm, V[k], w))
                    H[k, i] += d
                    w -= d * V[k]
            hn = math.sqrt(float(gdot(comm, w, w)))
            H[i + 1, i] = hn
            V[i + 1] = w * (1.0 / hn) if hn > 100.0 * np.finfo(float).tiny else 0.0
            for k in range(i):
                t = H[k, i]
                H[k, i] = cs[k] * t + sn[k] * H[k + 1, i]
                H[k + 1, i] = -sn[k] * t + cs[k] * H[k + 1, i]
            d = math.sqrt(H[i, i] * H[i, i] + H[i + 1, i] * H[i + 1, i])
            if i == 0:
                big = small = d
                svbig[0] = svsml[0] = 1.0
            else:
                col = H[:i, i]
                big, s, c = dlaic1(1, svbig[:i], big, col, d)
                svbig[:i] *= s
                svbig[i] = c
                small, s, c = dlaic1(2, svsml[:i], small, col, d)
                svsml[:i] *= s
                svsml[i] = c
            if small == 0.0 or d < DBL_EPSILON or big / small > ill_cond_thresh:
                # take the solution of the previous iteration and get out
                x += _increment(H, g, V, i, precond)
                return stop("GMRES breakdown" if d < DBL_EPSILON else f"ill-conditioned GMRES Hessenberg matrix (condition estimate {big / small if small else math.inf:.3g})")
            cs[i] = H[i, i] / d
            sn[i] = H[i + 1, i] / d
            g[i + 1] = -sn[i] * g[i]
            g[i] = cs[i] * g[i]
            H[i, i] = cs[i] * H[i, i] + sn[i] * H[i + 1, i]
            rnorm = abs(g[i + 1])
            if not math.isfinite(rnorm):
                return SolveResult(x, False, it, "GMRES breakdown (non-finite residual)")
            i += 1
            converged = rnorm / r0 < epsilon
            if i == kspace or converged or it == maxiter:
                dx = _increment(H, g, V, i, precond)
                x += dx
            if converged:
                matvec(x, tmp)
                res = b - tmp
                actual = math.sqrt(float(gdot(comm, res, res))) / r0
                converged = actual < epsilon
                if not converged:
                    difference = abs(actual - rnorm / r0)
                    if difference > epsilon:
                        return SolveResult(x, False, it, f"GMRES loss of precision (recursive {rnorm / r0:.3g}, actual {actual:.3g})")
                    epsilon = epsilon - 1.5 * difference
                    while epsilon < 0.0:
                        epsilon += 0.1 * difference
                    if i != kspace:
                        x -= dx
            if i == kspace and not converged:
                matvec(dx, tmp)
                r = beta * V[0] - tmp
    if converged:
        return SolveResult(x, True, it)
    return stop(f"GMRES reached {maxiter} iterations")
