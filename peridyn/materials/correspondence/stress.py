"""Stress updates of Peridigm's classic correspondence family in the unrotated configuration, the
rotation back to the Cauchy stress and the first Piola-Kirchhoff stress times K⁻¹
(PERIDIGM_CORRESPONDENCE.md §5.1-§5.5, §2.2 step 5, §6 steps 1-3), one point per ``prange``
iteration.

Shapes and units: tensors (n, 9) flat row-major; unrotated Cauchy stress σ̂ (Unrotated_Cauchy_
Stress) and Cauchy stress σ in M/(L T^2); d (Unrotated_Rate_Of_Deformation) in 1/T; dt in T;
bulk and shear moduli K, G and yield stresses in M/(L T^2); equivalent plastic strain eqps (n,)
dimensionless; Von_Mises_Stress (n,) M/(L T^2); reference coordinates x (n, 3) in L.

Every formula follows the spec's operation order: Δε_k = d_k dt, Δθ = (Δε0 + Δε4) + Δε8,
Δe_k = Δε_k - Δθ/3.0 on the diagonal, trial σ_k = σ̂_N,k + (Δe_k 2.0) G then + K Δθ on the
diagonal, deviator s with p = ((σ0 + σ4) + σ8)/3.0, t = Σ_k s_k s_k from 0.0 in k order,
vm = sqrt((3.0/2.0) t). std::max(a, b) is written as ``b if a < b else a`` (its NaN behaviour).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .tensor import inv3, load9, matmul, matmul_nt, matmul_nt_scaled, store9

SQRT_2_3 = math.sqrt(2.0 / 3.0)
SQRT_6 = math.sqrt(6.0)
#: bisection steps of §5.5 before it counts as not converged. Peridigm allows 100000; on [0, 1] in
#: doubles the bisection has either stopped after about 1100 steps (the interval halves each step,
#: collapses below 2^-1074, and a collapsed interval meets the stopping test at once) or is stuck
#: at λ = 0 for good (|λ - λ_old|/|λ| is NaN there), so 2000 gives Peridigm's λ, flag and stress,
#: 50 times sooner (tests/unit/materials/correspondence/test_local_caps.py)
MAX_BISECTION = 2000
#: status of :func:`needleman_point`: converged (or elastic), no root but elastic (Peridigm prints
#: a message and goes on), no root and a plastic return to a λ that solves nothing, non-finite
#: stress or plastic strain
NEEDLEMAN_OK, NEEDLEMAN_NO_ROOT_ELASTIC, NEEDLEMAN_NO_ROOT, NEEDLEMAN_NON_FINITE = 0, 1, 2, 3


# ------------------------------------------------------------------------------------------------
# §5.1 building blocks (inlined)
# ------------------------------------------------------------------------------------------------
@njit(cache=True, inline="always")
def _strain_increment(di, dt):
    """(Δe, Δθ): deviatoric strain increment (9-tuple) and volumetric increment of one point."""
    e0 = di[0] * dt
    e1 = di[1] * dt
    e2 = di[2] * dt
    e3 = di[3] * dt
    e4 = di[4] * dt
    e5 = di[5] * dt
    e6 = di[6] * dt
    e7 = di[7] * dt
    e8 = di[8] * dt
    dth = (e0 + e4) + e8
    return (e0 - dth / 3.0, e1, e2, e3, e4 - dth / 3.0, e5, e6, e7, e8 - dth / 3.0), dth


@njit(cache=True, inline="always")
def _trial_stress(sN, de, dth, K, G):
    """σ_k = σ̂_N,k + (Δe_k 2.0) G, then σ_k += K Δθ for k = 0, 4, 8."""
    return (
        sN[0] + (de[0] * 2.0) * G + K * dth, sN[1] + (de[1] * 2.0) * G, sN[2] + (de[2] * 2.0) * G,
        sN[3] + (de[3] * 2.0) * G, sN[4] + (de[4] * 2.0) * G + K * dth, sN[5] + (de[5] * 2.0) * G,
        sN[6] + (de[6] * 2.0) * G, sN[7] + (de[7] * 2.0) * G, sN[8] + (de[8] * 2.0) * G + K * dth,
    )


@njit(cache=True, inline="always")
def _deviator(sig):
    """(s, p): deviator and mean stress, p = ((σ0 + σ4) + σ8)/3.0."""
    p = ((sig[0] + sig[4]) + sig[8]) / 3.0
    return (sig[0] - p, sig[1], sig[2], sig[3], sig[4] - p, sig[5], sig[6], sig[7], sig[8] - p), p


@njit(cache=True, inline="always")
def _dot9(a, b):
    """Σ_k a_k b_k, sequential from 0.0 in k order."""
    return ((((((((0.0 + a[0] * b[0]) + a[1] * b[1]) + a[2] * b[2]) + a[3] * b[3]) + a[4] * b[4]) + a[5] * b[5]) + a[6] * b[6]) + a[7] * b[7]) + a[8] * b[8]


@njit(cache=True, inline="always")
def _floor(x):
    """std::max(1.0e-20, x)."""
    return x if 1.0e-20 < x else 1.0e-20  # noqa: FURB136 (std::max's NaN behaviour, not max())


@njit(cache=True, inline="always")
def _return_to(s, p, mag_tr, f):
    """Radial return of the trial deviator s to the yield stress f: (σ, s_returned, vm)."""
    c = (SQRT_2_3 * f) / mag_tr
    r = (s[0] * c, s[1] * c, s[2] * c, s[3] * c, s[4] * c, s[5] * c, s[6] * c, s[7] * c, s[8] * c)
    sig = (r[0] + p, r[1], r[2], r[3], r[4] + p, r[5], r[6], r[7], r[8] + p)
    return sig, r, math.sqrt((3.0 / 2.0) * _dot9(r, r))


@njit(cache=True, inline="always")
def _eqps_update(de, r, mag_tr, sN, G, eqps_N):
    """(5.3a): eqps_N + max(0.0, sqrt(2/3) Σ a_k b_k), a_k = Δe_k - ((r_k - s_N,k)/2.0)/G,
    b_k = (r_k/|s_tr| + s_N,k/|s_N|)/2.0 with r the returned deviator, |s_tr| the trial magnitude
    and |s_N| = max(1e-20, |dev σ̂_N|)."""
    q, _ = _deviator(sN)
    mq = _floor(math.sqrt(_dot9(q, q)))
    a = (
        de[0] - ((r[0] - q[0]) / 2.0) / G, de[1] - ((r[1] - q[1]) / 2.0) / G, de[2] - ((r[2] - q[2]) / 2.0) / G,
        de[3] - ((r[3] - q[3]) / 2.0) / G, de[4] - ((r[4] - q[4]) / 2.0) / G, de[5] - ((r[5] - q[5]) / 2.0) / G,
        de[6] - ((r[6] - q[6]) / 2.0) / G, de[7] - ((r[7] - q[7]) / 2.0) / G, de[8] - ((r[8] - q[8]) / 2.0) / G,
    )
    b = (
        (r[0] / mag_tr + q[0] / mq) / 2.0, (r[1] / mag_tr + q[1] / mq) / 2.0, (r[2] / mag_tr + q[2] / mq) / 2.0,
        (r[3] / mag_tr + q[3] / mq) / 2.0, (r[4] / mag_tr + q[4] / mq) / 2.0, (r[5] / mag_tr + q[5] / mq) / 2.0,
        (r[6] / mag_tr + q[6] / mq) / 2.0, (r[7] / mag_tr + q[7] / mq) / 2.0, (r[8] / mag_tr + q[8] / mq) / 2.0,
    )
    inc = SQRT_2_3 * _dot9(a, b)
    return eqps_N + (inc if 0.0 < inc else 0.0)  # noqa: FURB136 (std::max's NaN behaviour)


@njit(cache=True, inline="always")
def _reduced_yield(sigma_y, flaw, x, i, fx, fy, fz, size, magnitude):
    """σ_r = σ_y (1.0 - m exp(((((-dX) dX) - dY dY) - dZ dZ)/s/s)) with the flaw, σ_y without."""
    if not flaw:
        return sigma_y
    dX = x[i, 0] - fx
    dY = x[i, 1] - fy
    dZ = x[i, 2] - fz
    return sigma_y * (1.0 - magnitude * math.exp(((((-dX) * dX) - dY * dY) - dZ * dZ) / size / size))


# ------------------------------------------------------------------------------------------------
# per-point updates (not inlined: the prange bodies only call them)
# ------------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def elastic_point(i, d, sigma_N, dt, K, G, dT_N, dT_NP1, alpha, sigma_NP1):
    """§5.2 for point i; thermal when dT_N is non-empty: Δθ -= 3.0 (α ΔT_NP1 - α ΔT_N) after Δe."""
    de, dth = _strain_increment(load9(d, i), dt)
    if dT_N.shape[0] > 0:
        dth = dth - 3.0 * (alpha * dT_NP1[i] - alpha * dT_N[i])
    store9(sigma_NP1, i, _trial_stress(load9(sigma_N, i), de, dth, K, G))


@njit(cache=True, error_model="numpy")
def elastic_plastic_point(i, d, sigma_N, eqps_N, dt, K, G, sigma_y, sigma_NP1, eqps_NP1, vm):
    """§5.3 for point i."""
    de, dth = _strain_increment(load9(d, i), dt)
    sN = load9(sigma_N, i)
    sig = _trial_stress(sN, de, dth, K, G)
    s, p = _deviator(sig)
    t = _dot9(s, s)
    v = math.sqrt((3.0 / 2.0) * t)
    e = eqps_N[i]
    if v > sigma_y:
        mag_tr = _floor(math.sqrt(t))
        sig, r, v = _return_to(s, p, mag_tr, sigma_y)
        e = _eqps_update(de, r, mag_tr, sN, G, e)
    store9(sigma_NP1, i, sig)
    eqps_NP1[i] = e
    vm[i] = v


@njit(cache=True, error_model="numpy")
def isotropic_hardening_point(i, d, sigma_N, eqps_N, dt, K, G, sigma_y, H, flaw, x, fx, fy, fz, size, magnitude, sigma_NP1, eqps_NP1, vm):
    """§5.4 for point i (linear hardening modulus H, optional flaw)."""
    de, dth = _strain_increment(load9(d, i), dt)
    sN = load9(sigma_N, i)
    sig = _trial_stress(sN, de, dth, K, G)
    s, p = _deviator(sig)
    t = _dot9(s, s)
    mag_tr = _floor(math.sqrt(t))
    v = math.sqrt((3.0 / 2.0) * t)
    e = eqps_N[i]
    sr = _reduced_yield(sigma_y, flaw, x, i, fx, fy, fz, size, magnitude)
    if not v < sr:
        ebar = _dot9(s, de) / mag_tr
        q, _ = _deviator(sN)
        mq = math.sqrt(_dot9(q, q))  # no 1e-20 floor here
        dlam = ((((6.0 * ebar) * G) + 3.0 * mq) - SQRT_6 * sr) / (2.0 * (H + 3.0 * G))
        f = sr + H * (e + SQRT_2_3 * dlam)
        if v > f:
            sig, r, v = _return_to(s, p, mag_tr, f)
            e = _eqps_update(de, r, mag_tr, sN, G, e)
    store9(sigma_NP1, i, sig)
    eqps_NP1[i] = e
    vm[i] = v


@njit(cache=True, inline="always", error_model="numpy")
def _needleman_g(lam, e, sr, n, m, rate0, eps0, eps1, dt):
    """g(λ, e) = hard·rate, hard = (σ_r pow(1.0 + e/ε0, n))/(1.0 + pow(e/ε1, 2.0)),
    rate = pow(((sqrt(2/3) λ)/dt)/ε̇0, m). pow(q, 2.0) is written q·q: GCC and LLVM both fold
    it so (exact rounding of the square)."""
    q = e / eps1
    hard = (sr * math.pow(1.0 + e / eps0, n)) / (1.0 + q * q)
    return hard * math.pow(((SQRT_2_3 * lam) / dt) / rate0, m)


@njit(cache=True, error_model="numpy")
def needleman_plastic_multiplier(ebar, mq, eqps_n, sr, G, n, m, rate0, eps0, eps1, dt):
    """(λ, iterations, converged) of §5.5 step 2: bisection on [0, 1] for
    f(λ) = (ē - λ) - ((1.0/2.0)/G) (sqrt(2/3) g(λ, eqps_N + λ) - |s_N|) (eqps argument without
    sqrt(2/3)), evaluating f at b and at the midpoint c, b <- c when f(b), f(c) share a strict
    sign, else a <- c; stops when |λ - λ_old|/|λ| < 1e-6 on successive midpoints, or after
    MAX_BISECTION iterations (not converged: Peridigm prints a message and keeps the last λ, 0).
    ebar: ē (-); mq: |s_N| (M/(L T^2)); eqps_n: eqps_N; sr: σ_r; G; n, m, rate0, eps0, eps1 and
    dt as in :func:`needleman_stress_kernel`."""
    a = 0.0
    b = 1.0
    c = (a + b) / 2.0
    lam = 1.0
    its = 0
    converged = False
    for k in range(MAX_BISECTION):
        gb = _needleman_g(b, eqps_n + b, sr, n, m, rate0, eps0, eps1, dt)
        gc = _needleman_g(c, eqps_n + c, sr, n, m, rate0, eps0, eps1, dt)
        fb = (ebar - b) - ((1.0 / 2.0) / G) * (SQRT_2_3 * gb - mq)
        fc = (ebar - c) - ((1.0 / 2.0) / G) * (SQRT_2_3 * gc - mq)
        if (fb > 0.0 and fc > 0.0) or (fb < 0.0 and fc < 0.0):
            b = c
        else:
            a = c
        old = c
        c = (a + b) / 2.0
        lam = c
        its = k + 1
        if abs(lam - old) / abs(lam) < 1.0e-6:
            converged = True
            break
    return lam, its, converged


@njit(cache=True, error_model="numpy")
def needleman_point(i, d, sigma_N, eqps_N, dt, K, G, sigma_y, n, m, rate0, eps0, eps1, flaw, x, fx, fy, fz, size, magnitude, sigma_NP1, eqps_NP1, vm):
    """§5.5 for point i. Returns NEEDLEMAN_OK; NEEDLEMAN_NO_ROOT_ELASTIC when the bisection did
    not converge but the step stays elastic (as in Peridigm); NEEDLEMAN_NO_ROOT when it did not
    converge and the stress was returned to the yield value of a λ that is no root;
    NEEDLEMAN_NON_FINITE for a non-finite stress or plastic strain. The state is written all the
    same."""
    de, dth = _strain_increment(load9(d, i), dt)
    sN = load9(sigma_N, i)
    sig = _trial_stress(sN, de, dth, K, G)
    s, p = _deviator(sig)
    t = _dot9(s, s)
    mag_tr = _floor(math.sqrt(t))
    v = math.sqrt((3.0 / 2.0) * t)
    e = eqps_N[i]
    sr = _reduced_yield(sigma_y, flaw, x, i, fx, fy, fz, size, magnitude)
    status = NEEDLEMAN_OK
    if not v < sr:
        ebar = _dot9(s, de) / mag_tr
        q, _ = _deviator(sN)
        mq = math.sqrt(_dot9(q, q))  # no 1e-20 floor here
        lam, _, converged = needleman_plastic_multiplier(ebar, mq, e, sr, G, n, m, rate0, eps0, eps1, dt)
        f = _needleman_g(lam, e + SQRT_2_3 * lam, sr, n, m, rate0, eps0, eps1, dt)
        if not converged:
            status = NEEDLEMAN_NO_ROOT_ELASTIC if v <= f else NEEDLEMAN_NO_ROOT
        if v > f:
            sig, r, v = _return_to(s, p, mag_tr, f)
            e = _eqps_update(de, r, mag_tr, sN, G, e)
    store9(sigma_NP1, i, sig)
    eqps_NP1[i] = e
    vm[i] = v
    if not (math.isfinite(e) and math.isfinite(_dot9(sig, sig))):
        status = NEEDLEMAN_NON_FINITE
    return status


@njit(cache=True, error_model="numpy")
def rotate_piola_point(i, R_NP1, sigma_hat_NP1, F, Kinv, sigma_NP1, A):
    """σ = R·(σ̂·Rᵀ); P = (σ·F⁻ᵀ)·J (J skipped when 1.0); A_i = P·K⁻¹. Returns 1 if F is singular."""
    R = load9(R_NP1, i)
    sig = matmul(R, matmul_nt(load9(sigma_hat_NP1, i), R))
    store9(sigma_NP1, i, sig)
    Finv, J, ok = inv3(load9(F, i))
    store9(A, i, matmul(matmul_nt_scaled(sig, Finv, J), load9(Kinv, i)))
    return 0 if ok else 1


# ------------------------------------------------------------------------------------------------
# kernels over [start, stop)
# ------------------------------------------------------------------------------------------------
@njit(cache=True, parallel=True, error_model="numpy")
def elastic_stress_kernel(start, stop, d, sigma_N, dt, K, G, dT_N, dT_NP1, alpha, sigma_NP1):
    """§5.2: σ̂_NP1 = trial stress. Thermal strain (Elastic Correspondence with a Thermal Expansion
    Coefficient α, 1/temperature) when ``dT_N``/``dT_NP1`` (n,) (Temperature_Change at N and NP1,
    the owner point's) are non-empty; pass empty arrays otherwise."""
    for i in prange(start, stop):
        elastic_point(i, d, sigma_N, dt, K, G, dT_N, dT_NP1, alpha, sigma_NP1)


@njit(cache=True, parallel=True, error_model="numpy")
def elastic_plastic_stress_kernel(start, stop, d, sigma_N, eqps_N, dt, K, G, sigma_y, sigma_NP1, eqps_NP1, vm):
    """§5.3 J2 perfectly plastic: strict test vm > σ_y, radial return to σ_y, eqps by (5.3a).
    Writes σ̂_NP1 (n, 9), eqps_NP1 (n,) and the Von_Mises_Stress vm (n,) (returned value when
    plastic, trial value otherwise)."""
    for i in prange(start, stop):
        elastic_plastic_point(i, d, sigma_N, eqps_N, dt, K, G, sigma_y, sigma_NP1, eqps_NP1, vm)


@njit(cache=True, parallel=True, error_model="numpy")
def isotropic_hardening_stress_kernel(
    start, stop, d, sigma_N, eqps_N, dt, K, G, sigma_y, H, flaw, x, flaw_x, flaw_y, flaw_z, flaw_size, flaw_magnitude,
    sigma_NP1, eqps_NP1, vm,
):
    """§5.4 linear isotropic hardening (hardening modulus H, M/(L T^2)). ``flaw`` (bool) enables
    the reduced yield stress σ_r at reference coordinates x (n, 3) around (flaw_x, flaw_y,
    flaw_z) (L), of size flaw_size (L) and magnitude flaw_magnitude (-); x is not read without
    the flaw. Elastic when vm < σ_r (strict); else Δλ, f = σ_r + H (eqps_N + sqrt(2/3) Δλ), and
    the return to f when vm > f with eqps by (5.3a)."""
    for i in prange(start, stop):
        isotropic_hardening_point(
            i, d, sigma_N, eqps_N, dt, K, G, sigma_y, H, flaw, x, flaw_x, flaw_y, flaw_z, flaw_size, flaw_magnitude,
            sigma_NP1, eqps_NP1, vm,
        )


@njit(cache=True, parallel=True, error_model="numpy")
def needleman_stress_kernel(
    start, stop, d, sigma_N, eqps_N, dt, K, G, sigma_y, n, m, rate0, eps0, eps1, flaw, x, flaw_x, flaw_y, flaw_z,
    flaw_size, flaw_magnitude, sigma_NP1, eqps_NP1, vm,
):
    """§5.5 viscoplastic Needleman: strain hardening exponent n, rate hardening exponent m,
    reference strain rate rate0 (1/T), reference strains eps0, eps1; flaw as in
    :func:`isotropic_hardening_stress_kernel`. Returns (point, status, elastic_no_root): the
    first point with status NEEDLEMAN_NO_ROOT or NEEDLEMAN_NON_FINITE and that status, or
    (-1, 0), and the number of points whose bisection found no root but stayed elastic (Peridigm
    prints a message for each and goes on). The caller stops the run for the former."""
    status = np.zeros(max(stop - start, 0), dtype=np.int8)
    for i in prange(start, stop):
        status[i - start] = needleman_point(
            i, d, sigma_N, eqps_N, dt, K, G, sigma_y, n, m, rate0, eps0, eps1, flaw, x, flaw_x, flaw_y, flaw_z,
            flaw_size, flaw_magnitude, sigma_NP1, eqps_NP1, vm,
        )
    elastic = 0
    for k in range(status.shape[0]):
        if status[k] == NEEDLEMAN_NO_ROOT_ELASTIC:
            elastic += 1
        elif status[k] != NEEDLEMAN_OK:
            return start + k, int(status[k]), elastic
    return -1, 0, elastic


@njit(cache=True, parallel=True, error_model="numpy")
def rotate_piola_kernel(start, stop, R_NP1, sigma_hat_NP1, F, Kinv, sigma_NP1, A):
    """§2.2 step 5 and §6 steps 1-3 for the points [start, stop): the Cauchy stress
    σ_NP1 = R·(σ̂·Rᵀ) (MatMul(σ̂, Rᵀ) then MatMul(R, ·)) into ``sigma_NP1`` (n, 9), then
    J = det F and F⁻¹ from Inv3(F), P = MatMul(σ, F⁻ᵀ) times J afterwards (skipped when J == 1.0),
    and A_i = MatMul(P, K⁻¹) into ``A`` (n, 9) (M L^-6 T^-2 with K⁻¹ in L^-5, see
    :mod:`.forces`). Returns the first point with a singular F (its A is zero), or -1: Peridigm
    terminates the run."""
    status = np.zeros(max(stop - start, 0), dtype=np.int8)
    for i in prange(start, stop):
        status[i - start] = rotate_piola_point(i, R_NP1, sigma_hat_NP1, F, Kinv, sigma_NP1, A)
    for k in range(status.shape[0]):
        if status[k] != 0:
            return start + k
    return -1
