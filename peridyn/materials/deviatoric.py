"""Shared kernels of the ordinary state-based materials with a deviatoric internal state:
``Elastic Plastic`` and ``Elastic Plastic Hardening`` (Mitchell's J2 plasticity on the
deviatoric extension state) and ``Viscoelastic`` (a standard linear solid on the deviatoric
extension state). PERIDIGM_MODELS.md §1-§3.

Common to all three (notation of :mod:`peridyn.materials.elastic`): for point i with weighted
volume m_i = sum_j omega zeta^2 V_j and dilatation theta_i = sum_j 3 omega (1-d) zeta e V_j / m_i
(both with the deck's influence function omega, e = |eta| - zeta), the scalar force state of the
bond i->j is

    t_ij = D (c_i zeta + D t^d_ij)      (plasticity; D = 1 - d)
    t_ij = D (c_i zeta + t^d_ij)        (viscoelasticity, where D is inside e^d)

with c_i = 3 K theta_i / m_i, alpha_i = 15 mu / m_i and the deviatoric extension
e^d = (|eta| - zeta) - theta_i zeta / 3. The deviatoric force state t^d uses omega = 1 whatever
the deck's influence function (Peridigm's kernels fix OMEGA = 1.0; trap 1 of §15).

Plasticity (state e^dp per bond and lambda per point, read from N, written to NP1 at every
evaluation): trial t^tr = alpha (e^d - e^dp_N); its norm ||t^tr||^2 = sum_j ((1-d) t^tr)^2 V_j
(damage once); yield if ||t^tr||^2 / 2 > Y (Y = 25 sigma_y^2 / (8 pi delta^5)); then
perfect plasticity scales t^d onto the yield surface, hardening solves Peridigm's cubic for
d lambda (:func:`update_delta_lambda`).

Loops: the force paths are loop laws (:mod:`peridyn.core.traversal`, compiled by the run's
backend): the dilatation is Elastic's ``DILATATION`` law (no thermal strain); plasticity first
runs ``PLASTIC_POINTS`` (a :class:`PointSum` of the trial norm whose ``finish`` does the return
map, writes lambda_NP1 and keeps each point's return-map data in a (n, 6) array), then either
``PLASTIC_FORCE_STATE`` (a :class:`BondMap`: the force states of a view's own bonds, which the
engine gathers at both ends) or ``PLASTIC_PAIR_FORCE`` (a :class:`PairForce`: both ends of every
bond of a closed block in one pass, the far end's state read through the reverse bond);
viscoelasticity has ``VISCO_FORCE_STATE`` and ``VISCO_PAIR_FORCE``. The per-point helpers with
their own bond loops (``point_theta``, ``plastic_point``, ``plastic_bonds``, ``visco_bonds``)
serve the tangents' probes (:mod:`peridyn.materials.deviatoric_tangents`), which run inside one
parallel iteration on a private copy of a family; they do the laws' arithmetic through the same
bond helpers (``trial_square``, ``return_map``, ``plastic_td``, ``visco_t``).

Kernels take flat arrays: x, y (n, 3) L; volume (n,) L^3; offsets (n+1,), neighbors (nb,);
bond arrays (nb,); point arrays (n,). An empty ``bond_damage`` means no damage model.
"""
from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numba import njit
from pydantic import Field, model_validator

from ..core.fields import FieldSpec, Relation, Temporal
from ..core.influence import omega
from ..core.interfaces import BlockView, ElasticModuli, Material
from ..core.params import UsedWhen
from ..core.traversal import BondMap, PairForce, PointSum
from ..kernels.lengths import compiled_with_lengths
from .elastic import DILATATION, WEIGHTED_VOLUME
from .moduli import IsotropicElasticParams, isotropic_moduli

EMPTY = np.zeros(0)
PERFECT, HARDENING, VISCO = 0, 1, 2  # model switch of the finite-difference tangent


# ------------------------------------------------------------------------------------------------
# per-point pieces
# ------------------------------------------------------------------------------------------------
# not a loop law: per-point helper of the tangents' probes (one family inside a parallel iteration); the loop law is Elastic's DILATATION
@njit(cache=True, inline="always", error_model="numpy")
def point_theta(i, offsets, neighbors, zeta, y, volume, m_i, omega_kind, delta, omega_table, bond_damage):
    """theta_i = sum_j 3 omega (1-d) zeta e V_j / m_i (Peridigm's computeDilatation, no thermal
    term; 0 for a point without weighted volume)."""
    if m_i == 0.0:
        return 0.0
    has_damage = bond_damage.shape[0] > 0
    acc = 0.0
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        z = zeta[b]
        ex = y[j, 0] - y[i, 0]
        ey = y[j, 1] - y[i, 1]
        ez = y[j, 2] - y[i, 2]
        e = math.sqrt(ex * ex + ey * ey + ez * ez) - z
        w = omega(omega_kind, z, delta, omega_table, b)
        keep = 1.0 - bond_damage[b] if has_damage else 1.0
        acc += ((((3.0 * w) * keep) * z) * e) * volume[j]
    return acc / m_i


@njit(cache=True, error_model="numpy")
def update_delta_lambda(n, lam_n, Yp, alpha, H):
    """Peridigm's ``updateDeltaLambda``: the plastic multiplier increment of Elastic Plastic
    Hardening, the smallest positive root of the cubic x^3 + a x^2 + b x + c = 0 that states
    (n / (1 + alpha x))^2 / 2 = Yp + H (lam_n + x), or 0 (PERIDIGM_MODELS.md §2)."""
    a = ((2.0 / alpha + lam_n) + Yp / H)
    b = ((H + ((2.0 * alpha) * H) * lam_n) + (2.0 * alpha) * Yp) / ((alpha * alpha) * H)
    c = (((2.0 * H) * lam_n + 2.0 * Yp) - n * n) / (((2.0 * alpha) * alpha) * H)
    Q = (a * a - 3.0 * b) / 9.0
    R = ((((2.0 * a) * a) * a - (9.0 * a) * b) + 27.0 * c) / 54.0
    if R * R < (Q * Q) * Q:
        phi = math.acos(R / math.sqrt((Q * Q) * Q))
        sq = -2.0 * math.sqrt(Q)
        best = np.inf
        for shift in (0.0, (2.0 * math.pi) / 3.0, -((2.0 * math.pi) / 3.0)):
            r = sq * math.cos(phi / 3.0 + shift) - a / 3.0
            if r > 0.0 and abs(r) < abs(best):
                best = r
        return 0.0 if best == np.inf else best
    sign = 1.0 if R > 0.0 else (-1.0 if R < 0.0 else 0.0)
    A = -sign * (abs(R) + math.sqrt(R * R - (Q * Q) * Q)) ** (1.0 / 3.0)
    B = Q / A
    val = (A + B) - a / 3.0
    return max(val, 0.0)


@njit(cache=True, inline="always", error_model="numpy")
def trial_square(L, z, theta, alpha, keep, edp_n):
    """((1-d) t^tr)^2 of one bond (M^2 L^-10 T^-4): deformed length L and reference length z
    (L), owner dilatation theta and alpha (M L^-6 T^-2), keep = 1 - d, e^dp_N (L); omega = 1."""
    ed = (L - z) - (theta * z) / 3.0
    tt = ((keep * alpha) * 1.0) * (ed - edp_n)
    return tt * tt


@njit(cache=True, error_model="numpy")
def return_map(norm2, alpha, s, Y, H, hardening, lam_n):
    """(n, d lambda, plastic) of a point from its trial norm squared norm2 = ||t^tr||^2: n =
    ||t^tr||, plastic iff n^2 / 2 > Y_p = s^2 Y; d lambda from Peridigm's cubic with modulus H
    (``hardening``) or perfect plasticity, 0 when elastic."""
    n = math.sqrt(norm2)
    Yp = (s * s) * Y
    f = (n * n) / 2.0 - Yp
    dlam = 0.0
    plastic = False
    if f > 0.0:
        if hardening:
            dlam = update_delta_lambda(n, lam_n, Yp, alpha, H)
            dlam = max(dlam, 0.0)
            plastic = dlam > 0.0
        else:
            dlam = (n / math.sqrt(2.0 * Yp) - 1.0) / alpha
            plastic = True
    return n, dlam, plastic


# not a loop law: per-point helper of the tangents' probes (one family inside a parallel iteration); the loop law is PLASTIC_POINTS
@njit(cache=True, error_model="numpy")
def plastic_point(i, offsets, neighbors, zeta, y, volume, m_i, theta_i, K, mu, s, Y, H, hardening, bond_damage, edp_n, lam_n):
    """Trial norm and yield decision of point i: (alpha, c, n, d lambda, plastic) with
    alpha = (s 15 mu) / m_i, c = 3 K theta_i / m_i, n = ||t^tr|| (damage once) and d lambda
    the plastic increment (0 when elastic). ``hardening``: Peridigm's cubic with modulus H,
    else perfect plasticity; s is the shear correction factor (1 without)."""
    if m_i == 0.0:
        return 0.0, 0.0, 0.0, 0.0, False
    has_damage = bond_damage.shape[0] > 0
    alpha = ((s * 15.0) * mu) / m_i
    c = (((3.0 * K) * theta_i) * 1.0) / m_i
    norm2 = 0.0
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        z = zeta[b]
        ex = y[j, 0] - y[i, 0]
        ey = y[j, 1] - y[i, 1]
        ez = y[j, 2] - y[i, 2]
        L = math.sqrt(ex * ex + ey * ey + ez * ez)
        keep = 1.0 - bond_damage[b] if has_damage else 1.0
        norm2 += trial_square(L, z, theta_i, alpha, keep, edp_n[b]) * volume[j]
    n, dlam, plastic = return_map(norm2, alpha, s, Y, H, hardening, lam_n)
    return alpha, c, n, dlam, plastic


@njit(cache=True, inline="always", error_model="numpy")
def plastic_td(L, z, theta, alpha, n, dlam, plastic, root, hardening, edp_n):
    """(t^d, e^dp_NP1) of one bond of deformed length L and reference length z whose owner has
    dilatation theta and the return-map data (alpha, n, d lambda, plastic, root = sqrt(2 Y_p))."""
    ed = (L - z) - (theta * z) / 3.0
    tt = (alpha * 1.0) * (ed - edp_n)
    if not plastic:
        return tt, edp_n
    td = tt / (1.0 + alpha * dlam) if hardening else (root * tt) / n
    return td, edp_n + td * dlam


# not a loop law: per-point helper of the tangents' probes (one family inside a parallel iteration); the loop law is PLASTIC_FORCE_STATE
@njit(cache=True, error_model="numpy")
def plastic_bonds(i, shift, offsets, neighbors, zeta, y, theta_i, alpha, c, n, dlam, plastic, Yp, hardening, bond_damage, edp_n, t, edp_np1):
    """Second pass of point i: t[b - shift] (force state, M L^-5 T^-2) and edp_np1[b - shift]
    for its bonds b."""
    has_damage = bond_damage.shape[0] > 0
    root = math.sqrt(2.0 * Yp) if plastic and not hardening else 0.0
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        z = zeta[b]
        ex = y[j, 0] - y[i, 0]
        ey = y[j, 1] - y[i, 1]
        ez = y[j, 2] - y[i, 2]
        L = math.sqrt(ex * ex + ey * ey + ez * ez)
        td, edp_np1[b - shift] = plastic_td(L, z, theta_i, alpha, n, dlam, plastic, root, hardening, edp_n[b])
        keep = 1.0 - bond_damage[b] if has_damage else 1.0
        t[b - shift] = keep * (c * z + keep * td)


@njit(cache=True, inline="always", error_model="numpy")
def visco_t(keep, e, e_n, z, theta_n, theta, c, k1, k2, decay, beta, edb_n):
    """(t, e^b_NP1) of one bond: extension e = |eta| - zeta now and e_n at N, owner dilatations
    theta_n and theta, owner coefficients c = 3 K theta / m, k1 = (1 - lambda_i) alpha, k2 =
    lambda_i alpha."""
    ei_n = (theta_n * z) / 3.0
    ei_np1 = (theta * z) / 3.0
    ed_n = keep * e_n - ei_n
    ed_np1 = keep * e - ei_np1
    eb = (ed_n * (1.0 - decay) + edb_n * decay) + beta * (ed_np1 - ed_n)
    td = k1 * ed_np1 + k2 * (ed_np1 - eb)
    return keep * ((c * 1.0) * z + td), eb


@njit(cache=True, inline="always", error_model="numpy")
def visco_coefficients(m, theta, K, mu, lam_i):
    """(c, k1, k2) of a point (zeros without weighted volume)."""
    if m == 0.0:
        return 0.0, 0.0, 0.0
    alpha = (15.0 * mu) / m
    return ((3.0 * K) * theta) / m, ((1.0 - lam_i) * alpha) * 1.0, (lam_i * alpha) * 1.0


# not a loop law: per-point helper of the tangents' probes (one family inside a parallel iteration); the loop law is VISCO_FORCE_STATE
@njit(cache=True, error_model="numpy")
def visco_bonds(i, shift, offsets, neighbors, zeta, y, m_i, theta_n, theta_np1, K, mu, lam_i, decay, beta, bond_damage, ext_n, edb_n, t, ext_np1, edb_np1):
    """Standard linear solid on the deviatoric extension of point i's bonds b: t[b - shift],
    the back extension edb_np1[b - shift] and the bond extension ext_np1[b - shift] = |eta| -
    zeta (the N value of the next step). ext_n, edb_n: N values (L). No force without
    weighted volume."""
    has_damage = bond_damage.shape[0] > 0
    c, k1, k2 = visco_coefficients(m_i, theta_np1, K, mu, lam_i)
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        z = zeta[b]
        keep = 1.0 - bond_damage[b] if has_damage else 1.0
        ex = y[j, 0] - y[i, 0]
        ey = y[j, 1] - y[i, 1]
        ez = y[j, 2] - y[i, 2]
        e = math.sqrt(ex * ex + ey * ey + ez * ez) - z
        ext_np1[b - shift] = e
        t[b - shift], edb_np1[b - shift] = visco_t(keep, e, ext_n[b], z, theta_n, theta_np1, c, k1, k2, decay, beta, edb_n[b])


# ------------------------------------------------------------------------------------------------
# Loop laws (peridyn.core.traversal), compiled by the run's backend. Bond context (i, j, b, ex,
# ey, ez, L, z, p, args): eta = (ex, ey, ez) = y_j - y_i and L = |eta| (L), z = zeta[b] (L), p what
# the law's point function returned for i. Empty ``bond_damage`` (d) means no damage model.
# ------------------------------------------------------------------------------------------------
def trial_norm_point(i, args):
    """(s, alpha, c, theta_i) of point i: shear correction factor s (1 without), alpha = (s 15 mu)
    / m_i (M L^-6 T^-2), c = 3 K theta_i / m_i (M L^-6 T^-2), both 0 without weighted volume.
    args (V, m, theta, K, mu, scf, Y, H, hardening, d, edp_n, lam_n, pp): V (n,) L^3, m (n,) L^5,
    theta (n,), scf (n,) or empty, Y and H numbers, d and edp_n (nb,), lam_n (n,), pp (n, 6)."""
    m, theta, K, mu, scf = args[1], args[2], args[3], args[4], args[5]
    s = scf[i] if scf.shape[0] > 0 else 1.0
    m_i = m[i]
    if m_i == 0.0:
        return s, 0.0, 0.0, theta[i]
    alpha = ((s * 15.0) * mu) / m_i
    c = (((3.0 * K) * theta[i]) * 1.0) / m_i
    return s, alpha, c, theta[i]


def trial_norm_term(i, j, b, ex, ey, ez, L, z, p, args):
    """((1-d) t^tr)^2 V_j of bond i->j (M^2 L^-7 T^-4), damage once (omega = 1)."""
    volume, bond_damage, edp_n = args[0], args[9], args[10]
    s, alpha, c, theta_i = p
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    return trial_square(L, z, theta_i, alpha, keep, edp_n[b]) * volume[j]


def return_map_finish(i, norm2, p, args):
    """The return map of point i from its trial norm squared: writes pp[i] = (alpha, c, n,
    d lambda, plastic (1/0), sqrt(2 Y_p) of a perfectly plastic step) and returns lambda_NP1
    (lambda_N + d lambda when plastic); a point without weighted volume stays elastic (zeros)."""
    m, Y, H, hardening, lam_n, pp = args[1], args[6], args[7], args[8], args[11], args[12]
    s, alpha, c, theta_i = p
    n = 0.0
    dlam = 0.0
    plastic = False
    if m[i] != 0.0:
        n, dlam, plastic = return_map(norm2, alpha, s, Y, H, hardening, lam_n[i])
    pp[i, 0] = alpha
    pp[i, 1] = c
    pp[i, 2] = n
    pp[i, 3] = dlam
    pp[i, 4] = 1.0 if plastic else 0.0
    pp[i, 5] = math.sqrt(2.0 * ((s * s) * Y)) if plastic and not hardening else 0.0
    return lam_n[i] + dlam if plastic else lam_n[i]


def plastic_state_point(i, args):
    """(theta_i, alpha, c, n, d lambda, plastic, sqrt(2 Y_p)) of point i from pp (args[1])."""
    theta, pp = args[0], args[1]
    return theta[i], pp[i, 0], pp[i, 1], pp[i, 2], pp[i, 3], pp[i, 4] != 0.0, pp[i, 5]


def plastic_force_state_bond(i, j, b, ex, ey, ez, L, z, p, args):
    """t_ij = (1-d)(c zeta + (1-d) t^d) (M L^-5 T^-2), and e^dp_NP1 (L) written at b. args
    (theta, pp, hardening, d, edp_n, edp_np1)."""
    theta, pp, hardening, bond_damage, edp_n, edp_np1 = args
    theta_i, alpha, c, n, dlam, plastic, root = p
    td, edp_np1[b] = plastic_td(L, z, theta_i, alpha, n, dlam, plastic, root, hardening, edp_n[b])
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    return keep * (c * z + keep * td)


def plastic_pair_force(i, j, b, ex, ey, ez, L, z, p, args):
    """(t_ij + t_ji) V_j, both ends computed here (closed block: ``reverse`` gives the bond j->i,
    whose damage, zeta and e^dp_N the far end uses), and e^dp_NP1 of bond b written. args
    (theta, pp, hardening, d, edp_n, edp_np1, zeta, V, reverse)."""
    theta, pp, hardening, bond_damage, edp_n, edp_np1, zeta, volume, reverse = args
    theta_i, alpha, c, n, dlam, plastic, root = p
    rb = reverse[b]
    td_i, edp_np1[b] = plastic_td(L, z, theta_i, alpha, n, dlam, plastic, root, hardening, edp_n[b])
    td_j, _ = plastic_td(L, zeta[rb], theta[j], pp[j, 0], pp[j, 2], pp[j, 3], pp[j, 4] != 0.0, pp[j, 5], hardening, edp_n[rb])
    has_damage = bond_damage.shape[0] > 0
    k_i = 1.0 - bond_damage[b] if has_damage else 1.0
    k_j = 1.0 - bond_damage[rb] if has_damage else 1.0
    t = k_i * (c * z + k_i * td_i) + k_j * (pp[j, 1] * zeta[rb] + k_j * td_j)
    return t * volume[j]


def visco_point(i, args):
    """(c, k1, k2, theta_N, theta) of point i (:func:`visco_coefficients`). args (m, theta_n,
    theta, K, mu, lam_i, decay, beta, d, ext_n, edb_n, ext_np1, edb_np1, ...): m (n,) L^5, theta_n
    and theta (n,), bond arrays (nb,) (L)."""
    m, theta_n, theta, K, mu, lam_i = args[0], args[1], args[2], args[3], args[4], args[5]
    c, k1, k2 = visco_coefficients(m[i], theta[i], K, mu, lam_i)
    return c, k1, k2, theta_n[i], theta[i]


def visco_force_state_bond(i, j, b, ex, ey, ez, L, z, p, args):
    """t_ij (M L^-5 T^-2); e^b_NP1 and the extension |eta| - zeta (the next step's N) written at b."""
    m, theta_n, theta, K, mu, lam_i, decay, beta, bond_damage, ext_n, edb_n, ext_np1, edb_np1 = args
    c, k1, k2, th_n, th = p
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    e = L - z
    ext_np1[b] = e
    t, edb_np1[b] = visco_t(keep, e, ext_n[b], z, th_n, th, c, k1, k2, decay, beta, edb_n[b])
    return t


def visco_pair_force(i, j, b, ex, ey, ez, L, z, p, args):
    """(t_ij + t_ji) V_j, both ends computed here (``reverse`` gives the bond j->i, whose damage
    and N state the far end uses), and the new state of bond b written. args as
    :func:`visco_point`'s, then (zeta, V, reverse)."""
    m, theta_n, theta, K, mu, lam_i, decay, beta, bond_damage, ext_n, edb_n, ext_np1, edb_np1, zeta, volume, reverse = args
    c_i, k1_i, k2_i, th_n, th = p
    rb = reverse[b]
    has_damage = bond_damage.shape[0] > 0
    k_i = 1.0 - bond_damage[b] if has_damage else 1.0
    k_j = 1.0 - bond_damage[rb] if has_damage else 1.0
    e = L - z
    ext_np1[b] = e
    t_i, edb_np1[b] = visco_t(k_i, e, ext_n[b], z, th_n, th, c_i, k1_i, k2_i, decay, beta, edb_n[b])
    c_j, k1_j, k2_j = visco_coefficients(m[j], theta[j], K, mu, lam_i)
    t_j, _ = visco_t(k_j, L - zeta[rb], ext_n[rb], zeta[rb], theta_n[j], theta[j], c_j, k1_j, k2_j, decay, beta, edb_n[rb])
    return (t_i + t_j) * volume[j]


#: lambda_NP1 (n,) out; pp (n, 6) written
PLASTIC_POINTS = PointSum(trial_norm_term, point=trial_norm_point, finish=return_map_finish)
#: t (nb,) out (M L^-5 T^-2); e^dp_NP1 written
PLASTIC_FORCE_STATE = BondMap(plastic_force_state_bond, point=plastic_state_point)
#: force density (n, 3) out; e^dp_NP1 written
PLASTIC_PAIR_FORCE = PairForce(plastic_pair_force, point=plastic_state_point)
#: t (nb,) out; e^b_NP1 and the extension written
VISCO_FORCE_STATE = BondMap(visco_force_state_bond, point=visco_point)
#: force density (n, 3) out; e^b_NP1 and the extension written
VISCO_PAIR_FORCE = PairForce(visco_pair_force, point=visco_point)


def relaxation_constants(tau: float, dt: float) -> tuple[float, float]:
    """(decay, beta) of the back-extension update over a step dt (T) for relaxation time tau:
    decay = exp(-dt / tau), beta = 1 - (tau / dt)(1 - decay), exact for extensions linear in
    time over the step. dt <= 0 (an evaluation outside a time step) gives the limit (1, 0): no
    time passes, so the back extension does not move."""
    if not dt > 0.0:
        return 1.0, 0.0
    c1 = tau / dt
    decay = math.exp(-1.0 / c1)
    return decay, 1.0 - c1 * (1.0 - decay)


# ------------------------------------------------------------------------------------------------
# parameters and the shared wiring
# ------------------------------------------------------------------------------------------------
BATCH_PER_THREAD = 4  # local tangent blocks per thread and batch (each up to (3 (max_degree + 1))^2 doubles)


class DeviatoricParams(IsotropicElasticParams):
    """Density and two elastic constants, plus the keys every model of this family shares.
    ``rejected_keys``: deck keys Peridigm's class refuses for this model (an error even when
    false or zero)."""

    finite_difference_probe_length: float | None = Field(
        None, alias="Finite Difference Probe Length", description="finite-difference tangent: probe (L); default 1e-6 x the smallest element radius"
    )
    rejected_keys: ClassVar[frozenset[str]] = frozenset()
    #: the probe is read only by the finite-difference tangent (a model without the AD switch has only that one)
    used_when = {"finite_difference_probe_length": UsedWhen(
        lambda p: p.finite_difference_tangent(),
        "the finite-difference tangent is used ('Apply Automatic Differentiation Jacobian' false)", gt=0)}
    model_name: ClassVar[str] = "this material"

    def finite_difference_tangent(self) -> bool:
        """Whether the implicit solvers' tangent of the model is by finite differences (True
        unless an exact tangent is asked for: 'Apply Automatic Differentiation Jacobian')."""
        return True

    @model_validator(mode="before")
    @classmethod
    def _refuse(cls, data: Any) -> Any:
        if isinstance(data, dict):
            bad = sorted(k for k in cls.rejected_keys if k in data)
            if bad:
                names = ", ".join(repr(k) for k in bad)
                raise ValueError(f"{names} cannot be given for {cls.model_name} (Peridigm refuses it, whatever its value): remove it")
        return data


def yield_value(yield_stress: float, horizon: float, thickness: float | None = None) -> float:
    """Peridigm's yield value Y (M^2 L^-7 T^-4, the bound of ||t^d||^2 / 2): 3-D
    25 sigma_y^2 / (8 pi delta^5), planar (thickness T) 75 sigma_y^2 / (8 pi T delta^4), in
    Peridigm's operation order."""
    if thickness is None:
        return ((((25.0 * yield_stress) * yield_stress) / 8) / math.pi) / math.pow(horizon, 5)
    return ((((((225.0 / 3.0) * yield_stress) * yield_stress) / 8) / math.pi) / thickness) / math.pow(horizon, 4)


class DeviatoricStateMaterial(Material):
    """Wiring shared by the three models: weighted volume (deck influence function), the
    two-step dilatation, and the compiled tangents. Subclasses write ``force_state``."""

    precompute_fields = ()  # the force state of i's bonds reads only i's own theta and m
    needs_horizon: ClassVar[bool] = True

    def __init__(self, params, *, horizon: float | None, options=None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        if self.needs_horizon and horizon is None:
            raise ValueError(f"{self.name!r} needs a constant block horizon (a number): its yield value depends on it")
        self.K, self.mu = params.moduli()
        self.omega_table = EMPTY

    def finite_difference_probe_length(self) -> float | None:
        return self.params.finite_difference_probe_length

    @property
    def density(self) -> float:
        return float(self.params.density)

    @property
    def bulk_modulus(self) -> float:
        return float(self.K)

    def elastic_moduli(self) -> ElasticModuli:
        """The elastic part (not Hookean: plastic or viscous deviatoric response)."""
        return isotropic_moduli(self.params, self.K, self.mu, hookean=False)

    def fields(self) -> list[FieldSpec]:
        return [
            FieldSpec("Weighted_Volume", Relation.ELEMENT, 1, Temporal.CONSTANT, units="L^5"),
            FieldSpec("Dilatation", Relation.ELEMENT, 1, Temporal.TWO_STEP),
        ]

    def _common(self, block: BlockView):
        return block.influence.kind, block.horizon, self.omega_table

    @staticmethod
    def _damage(block: BlockView) -> np.ndarray:
        return block.fields.get("Bond_Damage", EMPTY)

    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        if block.influence.needs_table:
            self.omega_table = block.influence.table_for(nl.offsets, nl.neighbors, s["Model_Coordinates"], np.arange(block.start, block.stop), block.horizon)
        kind, delta, table = self._common(block)
        compiled_with_lengths(block, WEIGHTED_VOLUME)(
            block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], (s["Volume"], kind, delta, table), s["Weighted_Volume"]
        )

    def precompute(self, block: BlockView) -> None:
        """theta (Elastic's DILATATION law without thermal strain)."""
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        args = (s["Volume"], s["Weighted_Volume"], kind, delta, table, self._damage(block), EMPTY, 0.0)
        compiled_with_lengths(block, DILATATION)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], args, s["Dilatation"])

    def _reverse(self, block: BlockView) -> np.ndarray | None:
        """The reverse-bond index when the fused kernel can compute both ends of the view's
        bonds here: every neighbour owned locally (the far end's bond state lives on its
        owner's rank) and every family symmetric; else None (the engine's gather is used)."""
        key = (block.start, block.stop)
        cache = self.__dict__.setdefault("_reverse_cache", {})
        if key not in cache:
            nl = block.bonds
            lo, hi = int(nl.offsets[block.start]), int(nl.offsets[block.stop])
            ok = block.closed and (hi == lo or int(nl.neighbors[lo:hi].max()) < block.num_owned)
            rev = nl.reverse() if ok else None
            cache[key] = rev if rev is not None and (hi == lo or int(rev[lo:hi].min()) >= 0) else None
        return cache[key]

    @staticmethod
    def _points(block: BlockView, target) -> np.ndarray:
        """The block's points in Peridigm's evaluation order."""
        pts = np.arange(block.start, block.stop)
        return pts[np.argsort(target.eval_rank[pts], kind="stable")]

    @staticmethod
    def _max_degree(block: BlockView) -> int:
        deg = np.diff(block.bonds.offsets[block.start : block.stop + 1])
        return int(deg.max()) if deg.size else 0

    @staticmethod
    def _batch(block: BlockView) -> int:
        """Local tangent blocks computed in parallel at a time."""
        import numba

        return max(1, min(block.stop - block.start, BATCH_PER_THREAD * numba.get_num_threads()))
