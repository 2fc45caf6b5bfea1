"""Unrotated stress updates, Cauchy stress and Piola stress (PERIDIGM_CORRESPONDENCE.md §5, §6)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from peridyn.materials.correspondence import stress as S

EMPTY = np.zeros(0)
E_MOD, NU = 200.0e9, 0.3
K = E_MOD / (3.0 * (1.0 - 2.0 * NU))
G = E_MOD / (2.0 * (1.0 + NU))
LAM = K - 2.0 * G / 3.0
SY = 250.0e6
NOFLAW = (False, np.zeros((1, 3)), 0.0, 0.0, 0.0, 1.0, 0.0)  # flaw, x, fx, fy, fz, size, magnitude


def sym(rng, scale=1.0):
    a = rng.normal(size=(3, 3)) * scale
    return 0.5 * (a + a.T)


# -- §5.2 -----------------------------------------------------------------------------------------
def test_elastic_uniaxial_strain_is_hookes_law():
    """d = diag(rate, 0, 0) over several steps: σ = λ tr(ε) I + 2G ε with λ = K - 2G/3."""
    rate, dt, nsteps = 0.2, 1e-3, 7
    d = np.zeros((1, 9))
    d[0, 0] = rate
    sig = np.zeros((1, 9))
    nxt = np.zeros((1, 9))
    for _ in range(nsteps):
        S.elastic_stress_kernel(0, 1, d, sig, dt, K, G, EMPTY, EMPTY, 0.0, nxt)
        sig, nxt = nxt, sig
    eps = rate * dt * nsteps
    want = np.diag([LAM * eps + 2.0 * G * eps, LAM * eps, LAM * eps])
    np.testing.assert_allclose(sig.reshape(3, 3), want, rtol=1e-13, atol=1e-13 * abs(want).max())


def test_elastic_general_increment_and_subrange():
    rng = np.random.default_rng(0)
    n = 6
    d = np.array([sym(rng).ravel() for _ in range(n)])
    sN = np.array([sym(rng, 1e8).ravel() for _ in range(n)])
    out = np.full((n, 9), 5.0)
    dt = 1e-4
    S.elastic_stress_kernel(1, 5, d, sN, dt, K, G, EMPTY, EMPTY, 0.0, out)
    assert np.all(out[0] == 5.0) and np.all(out[5] == 5.0)
    for i in range(1, 5):
        eps = d[i].reshape(3, 3) * dt
        want = sN[i].reshape(3, 3) + LAM * np.trace(eps) * np.eye(3) + 2.0 * G * eps
        np.testing.assert_allclose(out[i].reshape(3, 3), want, rtol=1e-12, atol=1e-9 * abs(want).max())


def test_thermal_strain_only_changes_the_volumetric_part(ref):
    """Free expansion d = α dT/dt I is stress-free; heating with d = 0 gives -3 K α ΔT I."""
    alpha, dT, dt = 1.2e-5, 40.0, 1e-3
    TN = np.array([10.0])
    TNP1 = TN + dT
    d = np.zeros((1, 9))
    d[0, [0, 4, 8]] = alpha * dT / dt
    out = np.zeros((1, 9))
    S.elastic_stress_kernel(0, 1, d, np.zeros((1, 9)), dt, K, G, TN, TNP1, alpha, out)
    assert np.abs(out).max() < 1e-9 * K * alpha * dT
    S.elastic_stress_kernel(0, 1, np.zeros((1, 9)), np.zeros((1, 9)), dt, K, G, TN, TNP1, alpha, out)
    np.testing.assert_allclose(out.reshape(3, 3), -3.0 * K * alpha * dT * np.eye(3), rtol=1e-14)
    rng = np.random.default_rng(1)
    d = sym(rng).ravel()[None]
    sN = sym(rng, 1e7).ravel()[None]
    S.elastic_stress_kernel(0, 1, d, sN, dt, K, G, TN, TNP1, alpha, out)
    assert list(out[0]) == ref.elastic(list(sN[0]), list(d[0]), dt, K, G, alpha, TN[0], TNP1[0])


# -- path drivers -------------------------------------------------------------------------------------
def run_shear(point, params, gamma_max, nsteps, rate=1.0):
    """Simple shear d_xy = d_yx = rate/2 (mean stress and lateral stresses stay zero); returns
    rows (γ, σ_xy, eqps, vm)."""
    dt = gamma_max / nsteps / rate
    d = np.zeros((1, 9))
    d[0, 1] = d[0, 3] = 0.5 * rate
    sig, e = np.zeros((1, 9)), np.zeros(1)
    out, e1, vm = np.zeros((1, 9)), np.zeros(1), np.zeros(1)
    rows = []
    for k in range(nsteps):
        point(0, d, sig, e, dt, K, G, *params, out, e1, vm)
        sig[:] = out
        e[:] = e1
        rows.append(((k + 1) * dt * rate, out[0, 1], e1[0], vm[0]))
    return np.array(rows).T


def run_uniaxial_stress(point, params, eps_max, nsteps):
    """d = diag(1, r, r) with r found each step so that σ_yy = σ_zz = 0 (brentq to round-off);
    returns rows (ε_xx, σ_xx, eqps, vm, max lateral |σ|)."""
    dt = eps_max / nsteps
    sig, e = np.zeros((1, 9)), np.zeros(1)
    out, e1, vm = np.zeros((1, 9)), np.zeros(1), np.zeros(1)
    d = np.zeros((1, 9))
    d[0, 0] = 1.0

    def lateral(r):
        d[0, 4] = d[0, 8] = r
        point(0, d, sig, e, dt, K, G, *params, out, e1, vm)
        return out[0, 4]

    rows = []
    for k in range(nsteps):
        lateral(brentq(lateral, -1.0, 0.0, xtol=1e-300, rtol=1e-15, maxiter=200))
        sig[:] = out
        e[:] = e1
        rows.append(((k + 1) * dt, out[0, 0], e1[0], vm[0], max(abs(out[0, 4]), abs(out[0, 8]))))
    return np.array(rows).T


# -- §5.3 -----------------------------------------------------------------------------------------
def test_j2_simple_shear_saturates_and_eqps_follows_the_closed_form():
    """τ = G γ up to τ_y = σ_y/√3, then τ = τ_y (vm = σ_y) and eqps = (γ - τ_y/G)/√3.

    (5.3a) projects the plastic strain on the average of the returned direction over the TRIAL
    magnitude and the step-N direction, so each plastic step under-counts by the relative amount
    G Δγ/(2 τ_y): the error is first order in the step, 2.5/N here (N steps to 5 γ_y)."""
    tau_y = SY / math.sqrt(3.0)
    gamma_y = tau_y / G
    errors = []
    for nsteps in (500, 1000):
        g, tau, eqps, vm = run_shear(S.elastic_plastic_point, (SY,), 5.0 * gamma_y, nsteps)
        assert np.all(vm <= SY * (1.0 + 1e-14))
        elastic = g < gamma_y * (1.0 - 1e-9)
        np.testing.assert_allclose(tau[elastic], G * g[elastic], rtol=1e-12)
        assert np.all(eqps[elastic] == 0.0)
        plastic = g > gamma_y * 1.01
        np.testing.assert_allclose(vm[plastic], SY, rtol=1e-14)
        np.testing.assert_allclose(tau[plastic], tau_y, rtol=1e-14)
        want = (g - gamma_y) / math.sqrt(3.0)
        err = np.abs(eqps[plastic] - want[plastic]).max() / want[-1]
        assert err < 1.05 * 2.5 / nsteps
        assert np.all(np.diff(eqps) >= 0.0)
        errors.append(err)
    assert errors[1] / errors[0] == pytest.approx(0.5, rel=0.05)


def test_j2_uniaxial_stress_saturates_at_the_yield_stress():
    """σ_xx = E ε up to ε_y = σ_y/E, then σ_xx = vm = σ_y and eqps = ε - σ_y/E (plastic flow
    is incompressible: ε_p = diag(e, -e/2, -e/2) has eqps e). First-order step bias as in shear."""
    nsteps = 500
    eps, sxx, eqps, vm, lat = run_uniaxial_stress(S.elastic_plastic_point, (SY,), 5.0 * SY / E_MOD, nsteps)
    assert lat.max() < 1e-8 * SY
    elastic = eps < SY / E_MOD * (1.0 - 1e-9)
    np.testing.assert_allclose(sxx[elastic], E_MOD * eps[elastic], rtol=1e-9)
    plastic = eps > SY / E_MOD * 1.01
    np.testing.assert_allclose(sxx[plastic], SY, rtol=1e-12)
    np.testing.assert_allclose(vm[plastic], SY, rtol=1e-14)
    want = eps - SY / E_MOD
    assert np.abs(eqps[plastic] - want[plastic]).max() < 3.0 / nsteps * want[-1]


# -- §5.4 -----------------------------------------------------------------------------------------
def test_isotropic_hardening_uniaxial_stress_follows_the_linear_hardening_curve():
    """σ = σ_y + H eqps beyond yield, and σ(ε) = σ_y + H (E ε - σ_y)/(E + H) (closed form).

    Peridigm's Δλ drops the H eqps_N term of the consistency condition (it uses σ_r, not
    σ_r + H eqps_N, §5.4 trap 3), so the trial stress may overshoot before the return: the stress
    runs above the curve by H/(3G) of the hardening part, σ = σ_y + H (1 + H/(3G)) eqps. Both
    bounds are checked, with H/(3G) = 0.9 % here."""
    H = 0.01 * E_MOD
    eps, sxx, eqps, vm, lat = run_uniaxial_stress(S.isotropic_hardening_point, (SY, H, *NOFLAW), 0.02, 2000)
    assert lat.max() < 1e-8 * SY
    np.testing.assert_allclose(vm, np.abs(sxx), rtol=1e-12)
    plastic = eps > 1.5 * SY / E_MOD
    hard = sxx[plastic] - SY
    assert np.all(hard >= H * eqps[plastic] * (1.0 - 1e-3))
    assert np.all(hard <= H * eqps[plastic] * (1.0 + 1.05 * H / (3.0 * G)))
    assert hard[-1] > 0.1 * SY  # a real hardening, far above round-off
    want = SY + H * (E_MOD * eps - SY) / (E_MOD + H)
    np.testing.assert_allclose(sxx[plastic], want[plastic], rtol=1e-3)


def test_isotropic_hardening_without_hardening_is_j2_bit_for_bit():
    rng = np.random.default_rng(2)
    n = 200
    d = np.array([sym(rng, 0.5).ravel() for _ in range(n)])
    sN = np.array([sym(rng, 0.8e8).ravel() for _ in range(n)])
    eN = rng.uniform(0.0, 0.01, n)
    a = [np.zeros((n, 9)), np.zeros(n), np.zeros(n)]
    b = [np.zeros((n, 9)), np.zeros(n), np.zeros(n)]
    S.elastic_plastic_stress_kernel(0, n, d, sN, eN, 1e-3, K, G, SY, *a)
    S.isotropic_hardening_stress_kernel(0, n, d, sN, eN, 1e-3, K, G, SY, 0.0, *NOFLAW, *b)
    assert 20 < np.count_nonzero(a[1] > eN) < n - 20  # both branches present
    for u, v in zip(a, b):
        np.testing.assert_array_equal(u, v)


def test_flaw_reduces_the_yield_stress_at_its_centre():
    """A trial stress between σ_y (1 - m) and σ_y yields at the flaw centre only."""
    m = 0.2
    x = np.array([[0.5, 0.5, 0.5], [3.0, 3.0, 3.0]])
    flaw = (True, x, 0.5, 0.5, 0.5, 0.1, m)
    tau = 0.9 * SY / math.sqrt(3.0)  # vm = 0.9 σ_y
    d = np.zeros((2, 9))
    d[:, 1] = d[:, 3] = 0.5 * (tau / G)
    out, e1, vm = np.zeros((2, 9)), np.zeros(2), np.zeros(2)
    S.isotropic_hardening_stress_kernel(0, 2, d, np.zeros((2, 9)), np.zeros(2), 1.0, K, G, SY, 1e9, *flaw, out, e1, vm)
    assert e1[0] > 0.0 and vm[0] < 0.9 * SY and vm[0] > SY * (1.0 - m)
    assert e1[1] == 0.0 and vm[1] == pytest.approx(0.9 * SY, rel=1e-12)


# -- §5.5 -----------------------------------------------------------------------------------------
NEEDLEMAN = {"n": 0.1, "rate0": 1.0, "eps0": 0.002, "eps1": 0.5}


def needleman_hard(e):
    return SY * (1.0 + e / NEEDLEMAN["eps0"]) ** NEEDLEMAN["n"] / (1.0 + (e / NEEDLEMAN["eps1"]) ** 2)


def needleman_params(m):
    p = NEEDLEMAN
    return (SY, p["n"], m, p["rate0"], p["eps0"], p["eps1"], *NOFLAW)


def test_needleman_rate_independent_limit_follows_the_hardening_curve():
    """m = 0 makes the rate factor 1: vm = σ_y (1 + e/ε0)^n / (1 + (e/ε1)^2) along the plastic
    path, converging as the step shrinks."""
    errors = []
    for nsteps in (1000, 2000):
        _, _, eqps, vm = run_shear(S.needleman_point, needleman_params(0.0), 0.2, nsteps)
        plastic = eqps > 0.0
        assert plastic.sum() > 0.9 * nsteps
        errors.append(np.abs(vm[plastic] - needleman_hard(eqps[plastic])).max() / SY)
    assert errors[1] < 1e-4 and errors[1] < errors[0]
    assert vm[-1] > 1.3 * SY  # hardened well beyond the initial yield stress


@pytest.mark.parametrize("rate", [1.0, 100.0])
def test_needleman_rate_factor(rate):
    """Steady plastic shear at γ̇: the plastic equivalent rate tends to γ̇/√3, so
    vm / hard(eqps) tends to ((γ̇/√3)/ε̇0)^m."""
    m = 0.02
    dt_steps = 2000
    _, _, eqps, vm = run_shear(S.needleman_point, needleman_params(m), 0.2, dt_steps, rate=rate)
    late = eqps > 0.05
    factor = vm[late] / needleman_hard(eqps[late])
    np.testing.assert_allclose(factor, (rate / math.sqrt(3.0) / NEEDLEMAN["rate0"]) ** m, rtol=1e-4)


@pytest.mark.parametrize("m", [0.0, 0.05])
def test_needleman_bisection_converges_to_the_root(m):
    """Where f(λ) changes sign in (0, 1) the bisection stops within a relative 1e-6 of the root
    (the stopping test bounds the half-interval that still holds it)."""
    p = NEEDLEMAN
    rng = np.random.default_rng(3)
    dt = 1e-4
    tested = 0
    for _ in range(40):
        eqps_n = float(rng.uniform(0.0, 0.1))
        mq = float(rng.uniform(0.9, 1.0)) * needleman_hard(eqps_n) * math.sqrt(2.0 / 3.0)
        ebar = float(rng.uniform(1e-5, 1e-3))

        def f(lam, eqps_n=eqps_n, ebar=ebar, mq=mq):
            g = needleman_hard(eqps_n + lam) * (math.sqrt(2.0 / 3.0) * lam / dt / p["rate0"]) ** m
            return (ebar - lam) - 0.5 / G * (math.sqrt(2.0 / 3.0) * g - mq)

        if not f(1e-300) > 0.0 > f(1.0):
            continue
        tested += 1
        lam, its, converged = S.needleman_plastic_multiplier(ebar, mq, eqps_n, SY, G, p["n"], m, p["rate0"], p["eps0"], p["eps1"], dt)
        assert converged and its < 100
        root = brentq(f, 1e-300, 1.0, xtol=1e-300, rtol=1e-15)
        assert abs(lam - root) <= 1.01e-6 * root
    assert tested >= 10


def test_needleman_bisection_without_a_root_runs_out_like_peridigm():
    """m = 0 and a trial state between σ_r and the hardened curve: f < 0 on (0, 1], the bisection
    halves towards 0 (relative change 1 per step) and stops after MAX_BISECTION iterations
    (Peridigm prints a message); the step then stays elastic (vm below g(λ, eqps_N) =
    hard(eqps_N)), which is no error."""
    p = NEEDLEMAN
    eqps_n = 0.05
    mq = 0.5 * needleman_hard(eqps_n) * math.sqrt(2.0 / 3.0)
    lam, its, converged = S.needleman_plastic_multiplier(1e-6, mq, eqps_n, SY, G, p["n"], 0.0, p["rate0"], p["eps0"], p["eps1"], 1e-4)
    assert not converged and its == S.MAX_BISECTION and lam == 0.0
    # through the kernel: vm_N = 1.1 σ_y, between σ_r = σ_y and hard(eqps_N) = 1.37 σ_y
    tau = 1.1 * SY / math.sqrt(3.0)
    assert needleman_hard(eqps_n) > 1.3 * SY
    sN = np.zeros((1, 9))
    sN[0, 1] = sN[0, 3] = tau
    d = np.zeros((1, 9))
    d[0, 1] = d[0, 3] = 0.5
    out, e1, vm = np.zeros((1, 9)), np.zeros(1), np.zeros(1)
    failed = S.needleman_stress_kernel(0, 1, d, sN, np.array([eqps_n]), 1e-9, K, G, SY, p["n"], 0.0, p["rate0"], p["eps0"], p["eps1"], *NOFLAW, out, e1, vm)
    assert failed == (-1, 0, 1) and e1[0] == eqps_n
    assert out[0, 1] == pytest.approx(tau + G * 1e-9, rel=1e-12)


# -- bit-for-bit against the spec transcription ---------------------------------------------------
def random_states(n, seed):
    rng = np.random.default_rng(seed)
    d = np.array([(sym(rng, 3.0) + 0.3 * rng.normal(size=(3, 3))).ravel() for _ in range(n)])
    sN = np.array([(sym(rng, 1.5e8)).ravel() for _ in range(n)])
    eN = rng.uniform(0.0, 0.05, n)
    eN[:5] = 0.0
    sN[:3] = 0.0  # |s_N| = 0: the 1e-20 floor of (5.3a)
    x = rng.uniform(0.0, 1.0, (n, 3))
    return d, sN, eN, x


def test_plastic_updates_follow_the_spec_bit_for_bit(ref):
    n = 300
    d, sN, eN, x = random_states(n, 4)
    dt = 1e-3
    flaw = (0.4, 0.6, 0.5, 0.3, 0.15)
    out = [np.zeros((n, 9)), np.zeros(n), np.zeros(n)]
    S.elastic_plastic_stress_kernel(0, n, d, sN, eN, dt, K, G, SY, *out)
    assert 30 < np.count_nonzero(out[1] > eN) < n - 30
    for i in range(n):
        sig, vm, e = ref.elastic_plastic(list(sN[i]), list(d[i]), eN[i], dt, K, G, SY)
        assert list(out[0][i]) == sig and out[1][i] == e and out[2][i] == vm
    H = 2.0e9
    S.isotropic_hardening_stress_kernel(0, n, d, sN, eN, dt, K, G, SY, H, True, x, *flaw, *out)
    assert 30 < np.count_nonzero(out[1] > eN) < n - 30
    for i in range(n):
        sig, vm, e = ref.hardening(list(sN[i]), list(d[i]), eN[i], dt, K, G, SY, H, flaw, x[i])
        assert list(out[0][i]) == sig and out[1][i] == e and out[2][i] == vm
    p = NEEDLEMAN
    assert S.needleman_stress_kernel(0, n, d, sN, eN, dt, K, G, SY, p["n"], 0.03, p["rate0"], p["eps0"], p["eps1"], True, x, *flaw, *out) == (-1, 0, 0)
    assert 30 < np.count_nonzero(out[1] > eN) < n - 30
    for i in range(n):
        sig, vm, e = ref.needleman(list(sN[i]), list(d[i]), eN[i], dt, K, G, SY, p["n"], 0.03, p["rate0"], p["eps0"], p["eps1"], flaw, x[i])
        assert list(out[0][i]) == sig and out[1][i] == e and out[2][i] == vm


# -- §2.2 step 5, §6 steps 1-3 ----------------------------------------------------------------------
def test_cauchy_and_piola_stress(ref):
    rng = np.random.default_rng(5)
    n = 50
    R = np.array([ref.random_rotation(rng).ravel() for _ in range(n)])
    sh = np.array([sym(rng, 1e8).ravel() for _ in range(n)])
    F = np.array([(np.eye(3) + 0.1 * rng.normal(size=(3, 3))).ravel() for _ in range(n)])
    Kinv = np.array([np.linalg.inv(sym(rng) + 4.0 * np.eye(3)).ravel() for _ in range(n)])
    F[0] = np.eye(3).ravel()  # J == 1.0: no scaling
    sig, A = np.zeros((n, 9)), np.zeros((n, 9))
    assert S.rotate_piola_kernel(0, n, R, sh, F, Kinv, sig, A) == -1
    for i in range(n):
        Ri, Fi = R[i].reshape(3, 3), F[i].reshape(3, 3)
        s = Ri @ sh[i].reshape(3, 3) @ Ri.T
        np.testing.assert_allclose(sig[i].reshape(3, 3), s, rtol=1e-12, atol=1e-6)
        P = np.linalg.det(Fi) * s @ np.linalg.inv(Fi).T
        np.testing.assert_allclose(A[i].reshape(3, 3), P @ Kinv[i].reshape(3, 3), rtol=1e-10, atol=1e-10 * np.abs(P).max())
        r_sig, r_A, ok = ref.rotate_piola(list(R[i]), list(sh[i]), list(F[i]), list(Kinv[i]))
        assert ok and list(sig[i]) == r_sig and list(A[i]) == r_A
    F[7] = 0.0
    F[9] = 0.0
    assert S.rotate_piola_kernel(2, n, R, sh, F, Kinv, sig, A) == 7
    assert np.all(A[7] == 0.0)
