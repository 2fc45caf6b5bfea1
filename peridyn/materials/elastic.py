"""``Elastic``: the linear peridynamic solid (LPS), Peridigm's ordinary state-based elastic model.

For point i with weighted volume m_i = sum_j omega zeta^2 V_j (reference configuration, never
updated) and dilatation theta_i = sum_j 3 omega (1-d) zeta e V_j / m_i, the scalar force state
of bond i->j is (PERIDIGM_SEMANTICS.md §4.2, damage factors exactly as Peridigm has them)

    a_i  = 15 mu / m_i,   c_i = theta_i (3 K / m_i - a_i / 3)
    t_ij = (1 - d) omega (c_i zeta + (1 - d) a_i e),      e = |eta| - zeta - a_T dT_i zeta

with zeta = |xi| the reference and |eta| the deformed bond length, d the bond damage, a_T the
thermal expansion coefficient and dT_i the owner point's temperature change. The force density
of point i is f_i = sum_j (t_ij + t_ji) (eta_ij/|eta_ij|) V_j.

Stored energy density: W_i = K theta_i^2 / 2 + (alpha / 2) sum_j (1-d) omega e_d^2 V_j with
e_d = e - theta_i zeta / 3.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from pydantic import Field

from ..core.bondmath import stretch_exceeds
from ..core.fields import FieldSpec, Relation, Temporal
from ..core.influence import omega
from ..core.interfaces import BlockView, ElasticModuli, Material
from ..core.params import UsedWhen
from .moduli import IsotropicElasticParams, isotropic_moduli

EMPTY = np.zeros(0)
EMPTY_INDEX = np.zeros(0, dtype=np.int32)  # no reverse lookup: symmetric damage


class ElasticParams(IsotropicElasticParams):
    thermal_expansion_coefficient: float | None = Field(
        None, alias="Thermal Expansion Coefficient", description="linear thermal expansion coefficient (1/temperature)"
    )
    apply_ad_jacobian: bool = Field(
        True, alias="Apply Automatic Differentiation Jacobian", description="implicit solvers: use the exact tangent (true) or finite differences (false)"
    )
    compute_partial_stress: bool = Field(False, alias="Compute Partial Stress", description="accepted for compatibility")
    finite_difference_probe_length: float | None = Field(
        None, alias="Finite Difference Probe Length", description="implicit solvers, finite-difference tangent: probe (L); default 1e-6 x the smallest element radius"
    )
    ignored_keys = frozenset({"Apply Shear Correction Factor", "Hourglass Coefficient"})
    used_when = {"finite_difference_probe_length": UsedWhen(lambda p: not p.apply_ad_jacobian, "the finite-difference tangent is used ('Apply Automatic Differentiation Jacobian' false)", gt=0)}


# ------------------------------------------------------------------------------------------------
# kernels (shapes: x, y (n, 3) L; volume (n,) L^3; offsets (n+1,), neighbors (nb,) int32;
# per-bond arrays (nb,); per-point arrays (n,); empty arrays mean "feature off")
# ------------------------------------------------------------------------------------------------
@njit(cache=True, parallel=True, error_model="numpy")
def weighted_volume_kernel(start, stop, offsets, neighbors, x, volume, omega_kind, delta, omega_table, m):
    """m_i = sum_j (omega zeta^2) V_j (L^5) for i in [start, stop)."""
    for i in prange(start, stop):
        acc = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            dx = x[j, 0] - x[i, 0]
            dy = x[j, 1] - x[i, 1]
            dz = x[j, 2] - x[i, 2]
            z2 = dx * dx + dy * dy + dz * dz
            w = omega(omega_kind, math.sqrt(z2), delta, omega_table, b)
            acc += (w * z2) * volume[j]
        m[i] = acc


@njit(cache=True, parallel=True, error_model="numpy")
def dilatation_kernel(start, stop, offsets, neighbors, zeta, y, volume, m, omega_kind, delta, omega_table, bond_damage, dT, alpha_T, theta):
    """theta_i = sum_j 3 omega (1-d) zeta e V_j / m_i (dimensionless) for i in [start, stop).
    zeta (nb,) reference bond lengths."""
    has_damage = bond_damage.shape[0] > 0
    thermal = dT.shape[0] > 0
    for i in prange(start, stop):
        if m[i] == 0.0:
            theta[i] = 0.0
            continue
        acc = 0.0
        shift = alpha_T * dT[i] if thermal else 0.0
        yi0 = y[i, 0]
        yi1 = y[i, 1]
        yi2 = y[i, 2]
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            z = zeta[b]
            ex = y[j, 0] - yi0
            ey = y[j, 1] - yi1
            ez = y[j, 2] - yi2
            e = math.sqrt(ex * ex + ey * ey + ez * ez) - z
            if thermal:
                e -= shift * z
            w = omega(omega_kind, z, delta, omega_table, b)
            keep = 1.0 - bond_damage[b] if has_damage else 1.0
            acc += ((((3.0 * w) * keep) * z) * e) * volume[j]
        theta[i] = acc / m[i]


@njit(cache=True, parallel=True, error_model="numpy")
def dilatation_stretch_damage_kernel(start, stop, offsets, neighbors, zeta, P, m, omega_kind, delta, omega_table, s_c, d_n, d_np1, copy_previous, damage, theta):
    """Critical-stretch damage and the dilatation in one bond loop (each deformed bond length
    computed once): d = max(d, s > s_c) from N (``copy_previous``) or NP1, point damage = broken
    bonds / bonds, then theta_i with the updated damage. Same results as the damage model's
    kernel followed by ``dilatation_kernel``. P: packed records (y in columns 0-2, V in 5)."""
    for i in prange(start, stop):
        acc = 0.0
        broken = 0.0
        lo = offsets[i]
        hi = offsets[i + 1]
        yi0 = P[i, 0]
        yi1 = P[i, 1]
        yi2 = P[i, 2]
        for b in range(lo, hi):
            d = float(d_n[b]) if copy_previous else float(d_np1[b])
            if d >= 1.0:  # broken for good: no force, nothing to compute
                d_np1[b] = d
                broken += d
                continue
            j = neighbors[b]
            z = zeta[b]
            ex = P[j, 0] - yi0
            ey = P[j, 1] - yi1
            ez = P[j, 2] - yi2
            L2 = ex * ex + ey * ey + ez * ez
            if stretch_exceeds(L2, z, s_c):
                d = 1.0
            d_np1[b] = d
            broken += d
            if d < 1.0:
                w = omega(omega_kind, z, delta, omega_table, b)
                acc += ((((3.0 * w) * (1.0 - d)) * z) * (math.sqrt(L2) - z)) * P[j, 5]
        damage[i] = broken / (hi - lo) if hi > lo else 0.0
        theta[i] = acc / m[i] if m[i] != 0.0 else 0.0


@njit(cache=True, inline="always", error_model="numpy")
def point_coefficients(m, theta, K, mu):
    """Force-state coefficients of one point: a = 15 mu / m, c = theta (3 K / m - a / 3), so
    that t_ij = (1-d) omega (c_i zeta + (1-d) a_i e). Zero for a point without neighbors."""
    if m == 0.0:
        return 0.0, 0.0
    a = (15.0 * mu) / m
    return a, theta * ((3.0 * K) / m - a / 3.0)


@njit(cache=True, parallel=True, error_model="numpy")
def coefficients_kernel(start, stop, m, theta, K, mu, a, c):
    """``point_coefficients`` of the points [start, stop) into a and c."""
    for i in prange(start, stop):
        a[i], c[i] = point_coefficients(m[i], theta[i], K, mu)


# Packed point records for the hot kernels: row i of P (n_local, 6) holds (y_x, y_y, y_z, a_i,
# c_i, V_i) in one 48-byte record, so a neighbor costs one or two cache lines instead of one per
# array (y, a, c, V). On cube40 (7.15 M bonds) that made a step 8 % faster on one core and much
# less slowed by a busy second core (median 2-thread step 31.8 against 37.4 ms). Only the rows a
# view's bonds reach are packed: two ranges, owned rows and ghost rows (``Elastic._reach``).
PACK_WIDTH = 6
PACK_MIN_ROWS = 64  # smaller views (the finite-difference tangent's single points) read the arrays


@njit(cache=True)
def reach_kernel(start, stop, n_owned, offsets, neighbors):
    """(lo1, hi1, lo2, hi2): the owned rows [lo1, hi1) (including [start, stop)) and the ghost
    rows [lo2, hi2) (empty: 0, 0) the bonds of rows [start, stop) reach."""
    lo1, hi1 = start, stop
    lo2, hi2 = -1, -1
    for b in range(offsets[start], offsets[stop]):
        j = neighbors[b]
        if j < n_owned:
            lo1 = min(lo1, j)
            hi1 = max(hi1, j + 1)
        elif lo2 < 0:
            lo2, hi2 = j, j + 1
        else:
            lo2 = min(lo2, j)
            hi2 = max(hi2, j + 1)
    if lo2 < 0:
        lo2, hi2 = 0, 0
    return lo1, hi1, lo2, hi2


@njit(cache=True, parallel=True)
def pack_points_kernel(lo1, hi1, lo2, hi2, y, volume, P):
    """P[i, 0:3] = y_i and P[i, 5] = V_i for the rows [lo1, hi1) and [lo2, hi2)."""
    n1 = hi1 - lo1
    for k in prange(n1 + (hi2 - lo2)):
        i = lo1 + k if k < n1 else lo2 + (k - n1)
        P[i, 0] = y[i, 0]
        P[i, 1] = y[i, 1]
        P[i, 2] = y[i, 2]
        P[i, 5] = volume[i]


@njit(cache=True, parallel=True, error_model="numpy")
def pack_force_points_kernel(lo1, hi1, lo2, hi2, y, volume, m, theta, K, mu, P):
    """The whole record (y, a, c from ``point_coefficients``, V) of the rows [lo1, hi1) and
    [lo2, hi2)."""
    n1 = hi1 - lo1
    for k in prange(n1 + (hi2 - lo2)):
        i = lo1 + k if k < n1 else lo2 + (k - n1)
        P[i, 0] = y[i, 0]
        P[i, 1] = y[i, 1]
        P[i, 2] = y[i, 2]
        P[i, 3], P[i, 4] = point_coefficients(m[i], theta[i], K, mu)
        P[i, 5] = volume[i]


@njit(cache=True, parallel=True, error_model="numpy")
def dilatation_plain_kernel(start, stop, offsets, neighbors, zeta, P, m, theta):
    """``dilatation_kernel`` for omega = 1, no damage, no thermal strain (same arithmetic), on
    packed records P (y in columns 0-2, V in column 5)."""
    for i in prange(start, stop):
        if m[i] == 0.0:
            theta[i] = 0.0
            continue
        acc = 0.0
        yi0 = P[i, 0]
        yi1 = P[i, 1]
        yi2 = P[i, 2]
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            z = zeta[b]
            ex = P[j, 0] - yi0
            ey = P[j, 1] - yi1
            ez = P[j, 2] - yi2
            e = math.sqrt(ex * ex + ey * ey + ez * ez) - z
            acc += ((3.0 * z) * e) * P[j, 5]  # omega = 1, no damage: the same products
        theta[i] = acc / m[i]


@njit(cache=True, parallel=True, error_model="numpy")
def force_state_kernel(start, stop, offsets, neighbors, zeta, y, a, c, omega_kind, delta, omega_table, bond_damage, dT, alpha_T, t):
    """Scalar force state t[b] (M L^-5 T^-2) of every bond of points [start, stop)."""
    has_damage = bond_damage.shape[0] > 0
    thermal = dT.shape[0] > 0
    for i in prange(start, stop):
        shift = alpha_T * dT[i] if thermal else 0.0
        ai = a[i]
        ci = c[i]
        yi0 = y[i, 0]
        yi1 = y[i, 1]
        yi2 = y[i, 2]
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            z = zeta[b]
            ex = y[j, 0] - yi0
            ey = y[j, 1] - yi1
            ez = y[j, 2] - yi2
            e = math.sqrt(ex * ex + ey * ey + ez * ez) - z
            if thermal:
                e -= shift * z
            w = omega(omega_kind, z, delta, omega_table, b)
            keep = 1.0 - bond_damage[b] if has_damage else 1.0
            t[b] = keep * (w * (ci * z + keep * ai * e))


@njit(cache=True, parallel=True, error_model="numpy")
def fused_force_kernel(start, stop, offsets, neighbors, reverse, zeta, y, volume, a, c, omega_kind, delta, omega_table, bond_damage, dT, alpha_T, f):
    """f_i = sum_j (t_ij + t_ji) e_ij V_j for i in [start, stop), both bond ends computed here
    (closed block, symmetric families: ``reverse`` gives bond j->i; it is read only with damage,
    and is empty when the damage model gives both ends equal damage)."""
    has_damage = bond_damage.shape[0] > 0
    thermal = dT.shape[0] > 0
    for i in prange(start, stop):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        ai = a[i]
        ci = c[i]
        shift_i = alpha_T * dT[i] if thermal else 0.0
        yi0 = y[i, 0]
        yi1 = y[i, 1]
        yi2 = y[i, 2]
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            z = zeta[b]
            ex = y[j, 0] - yi0
            ey = y[j, 1] - yi1
            ez = y[j, 2] - yi2
            L = math.sqrt(ex * ex + ey * ey + ez * ez)
            e = L - z
            w = omega(omega_kind, z, delta, omega_table, b)
            if has_damage or thermal:
                e_i = e - shift_i * z if thermal else e
                e_j = e - (alpha_T * dT[j]) * z if thermal else e
                k_i = 1.0 - bond_damage[b] if has_damage else 1.0
                k_j = (1.0 - bond_damage[reverse[b]] if reverse.shape[0] > 0 and reverse[b] >= 0 else k_i) if has_damage else 1.0
                t = w * (k_i * (ci * z + k_i * ai * e_i) + k_j * (c[j] * z + k_j * a[j] * e_j))
            else:
                t = w * ((ci + c[j]) * z + (ai + a[j]) * e)
            if L > 0.0:
                s = (t * volume[j]) / L
                fx += s * ex
                fy += s * ey
                fz += s * ez
        f[i, 0] = fx
        f[i, 1] = fy
        f[i, 2] = fz


@njit(cache=True, parallel=True, error_model="numpy")
def fused_force_plain_kernel(start, stop, offsets, neighbors, zeta, P, f):
    """``fused_force_kernel`` for the common case (omega = 1, no damage, no thermal strain) on
    packed records P (y, a, c, V): the inner loop has no branches (about 10 % faster)."""
    for i in prange(start, stop):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        ai = P[i, 3]
        ci = P[i, 4]
        yi0 = P[i, 0]
        yi1 = P[i, 1]
        yi2 = P[i, 2]
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            z = zeta[b]
            ex = P[j, 0] - yi0
            ey = P[j, 1] - yi1
            ez = P[j, 2] - yi2
            L = math.sqrt(ex * ex + ey * ey + ez * ez)
            t = (ci + P[j, 4]) * z + (ai + P[j, 3]) * (L - z)
            s = (t * P[j, 5]) / L if L > 0.0 else 0.0
            fx += s * ex
            fy += s * ey
            fz += s * ez
        f[i, 0] = fx
        f[i, 1] = fy
        f[i, 2] = fz


@njit(cache=True, parallel=True, error_model="numpy")
def fused_force_damage_plain_kernel(start, stop, offsets, neighbors, zeta, P, bond_damage, f):
    """``fused_force_kernel`` for omega = 1, no thermal strain and damage equal at both ends of
    a bond (same arithmetic) on packed records P (y, a, c, V): broken bonds are skipped, and the
    inner loop has no other branch."""
    for i in prange(start, stop):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        ai = P[i, 3]
        ci = P[i, 4]
        yi0 = P[i, 0]
        yi1 = P[i, 1]
        yi2 = P[i, 2]
        for b in range(offsets[i], offsets[i + 1]):
            k = 1.0 - bond_damage[b]
            if k == 0.0:
                continue
            j = neighbors[b]
            z = zeta[b]
            ex = P[j, 0] - yi0
            ey = P[j, 1] - yi1
            ez = P[j, 2] - yi2
            L = math.sqrt(ex * ex + ey * ey + ez * ez)
            e = L - z
            t = k * (ci * z + k * ai * e) + k * (P[j, 4] * z + k * P[j, 3] * e)
            if L > 0.0:
                s = (t * P[j, 5]) / L
                fx += s * ex
                fy += s * ey
                fz += s * ez
        f[i, 0] = fx
        f[i, 1] = fy
        f[i, 2] = fz


@njit(cache=True, parallel=True, error_model="numpy")
def stored_energy_kernel(start, stop, offsets, neighbors, x, y, volume, m, theta, K, mu, omega_kind, delta, omega_table, bond_damage, dT, alpha_T, W):
    """W_i = K theta^2 / 2 + (15 mu / m_i / 2) sum_j (1-d) omega e_d^2 V_j (energy per volume)."""
    has_damage = bond_damage.shape[0] > 0
    thermal = dT.shape[0] > 0
    for i in prange(start, stop):
        if m[i] == 0.0:
            W[i] = 0.0
            continue
        alpha = (15.0 * mu) / m[i]
        th = theta[i]
        acc = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            dx = x[i, 0] - x[j, 0]
            dy = x[i, 1] - x[j, 1]
            dz = x[i, 2] - x[j, 2]
            L0 = math.sqrt(dx * dx + dy * dy + dz * dz)
            ex = y[i, 0] - y[j, 0]
            ey = y[i, 1] - y[j, 1]
            ez = y[i, 2] - y[j, 2]
            L = math.sqrt(ex * ex + ey * ey + ez * ez)
            if thermal:
                L -= (alpha_T * dT[i]) * L0
            ed = (L - L0) - (th * L0) / 3.0
            keep = 1.0 - bond_damage[b] if has_damage else 1.0
            acc += (((keep * omega(omega_kind, L0, delta, omega_table, b)) * ed) * ed) * volume[j]
        W[i] = ((0.5 * K) * th) * th + (0.5 * alpha) * acc


# ------------------------------------------------------------------------------------------------
class Elastic(Material):
    """Linear peridynamic solid (Peridigm's ``Elastic``)."""

    name = "Elastic"
    Params = ElasticParams
    precompute_fields = ("Dilatation",)
    row_local = True
    bond_energy = "lps"

    def __init__(self, params: ElasticParams, *, horizon: float | None, options=None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        self.K, self.mu = params.moduli()
        self.alpha_T = params.thermal_expansion_coefficient
        self.omega_table = EMPTY
        self._a: np.ndarray | None = None
        self._c: np.ndarray | None = None
        self._P: np.ndarray | None = None  # packed records, allocated by the first view that uses them
        self._reaches: dict[tuple[int, int], tuple[int, int, int, int]] = {}
        self._damage_model = None  # a damage model whose rule precompute applies itself

    @property
    def density(self) -> float:
        return self.params.density

    @property
    def bulk_modulus(self) -> float:
        return self.K

    def elastic_moduli(self) -> ElasticModuli:
        return isotropic_moduli(self.params, self.K, self.mu, hookean=True)

    @property
    def thermal(self) -> bool:
        return self.alpha_T is not None

    def fields(self) -> list[FieldSpec]:
        specs = [
            FieldSpec("Weighted_Volume", Relation.ELEMENT, 1, Temporal.CONSTANT, halo=True, units="L^5"),
            FieldSpec("Dilatation", Relation.ELEMENT, 1, Temporal.CONSTANT, halo=True),
        ]
        if self.thermal:
            specs += [FieldSpec("Temperature", Relation.NODE), FieldSpec("Temperature_Change", Relation.NODE, halo=True)]
        return specs

    def _common(self, block: BlockView):
        kind = block.influence.kind
        return kind, block.horizon, self.omega_table

    def _damage(self, block: BlockView) -> np.ndarray:
        return block.fields["Bond_Damage"] if "Bond_Damage" in block.fields else EMPTY

    def _dT(self, block: BlockView) -> tuple[np.ndarray, float]:
        if self.thermal:
            return block.fields["Temperature_Change"], float(self.alpha_T)
        return EMPTY, 0.0

    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        if block.influence.needs_table:
            self.omega_table = block.influence.table_for(nl.offsets, nl.neighbors, s["Model_Coordinates"], np.arange(block.start, block.stop), block.horizon)
        kind, delta, table = self._common(block)
        weighted_volume_kernel(block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Volume"], kind, delta, table, s["Weighted_Volume"])

    def adopt_damage(self, damage) -> bool:
        rule = damage.bond_rule()
        if rule is None or rule[0] != "critical stretch" or self.thermal:
            return False
        self._damage_model = damage
        return True

    def precompute_with_damage(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        _, s_c, copy_previous = self._damage_model.bond_rule()
        dilatation_stretch_damage_kernel(
            block.start, block.stop, nl.offsets, nl.neighbors, s["Bond_Length"], self._packed(block, False), s["Weighted_Volume"],
            kind, delta, table, s_c, s.n("Bond_Damage"), s["Bond_Damage"], copy_previous, s["Damage"], s["Dilatation"],
        )

    def precompute(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        dT, aT = self._dT(block)
        damage = self._damage(block)
        if kind == 0 and not damage.shape[0] and not dT.shape[0] and block.stop - block.start >= PACK_MIN_ROWS:
            dilatation_plain_kernel(
                block.start, block.stop, nl.offsets, nl.neighbors, s["Bond_Length"], self._packed(block, False), s["Weighted_Volume"], s["Dilatation"]
            )
            return
        dilatation_kernel(
            block.start, block.stop, nl.offsets, nl.neighbors, s["Bond_Length"], s["Coordinates"], s["Volume"],
            s["Weighted_Volume"], kind, delta, table, damage, dT, aT, s["Dilatation"],
        )

    def _reach(self, block: BlockView) -> tuple[int, int, int, int]:
        """The rows the bonds of ``block`` reach, with its own: [lo1, hi1) owned, [lo2, hi2) ghosts."""
        key = (block.start, block.stop)
        r = self._reaches.get(key)
        if r is None:
            nl = block.bonds
            r = self._reaches[key] = tuple(int(v) for v in reach_kernel(block.start, block.stop, block.num_owned, nl.offsets, nl.neighbors))
        return r

    def _packed(self, block: BlockView, coefficients: bool) -> np.ndarray:
        """The packed records of the rows ``block`` reaches: y and V, and a, c when ``coefficients``
        (from the current Weighted_Volume and Dilatation, ghosts' included)."""
        s = block.fields
        n = s.num_points
        if self._P is None or self._P.shape[0] != n:
            self._P = np.zeros((n, PACK_WIDTH))
        lo1, hi1, lo2, hi2 = self._reach(block)
        if coefficients:
            pack_force_points_kernel(lo1, hi1, lo2, hi2, s["Coordinates"], s["Volume"], s["Weighted_Volume"], s["Dilatation"], self.K, self.mu, self._P)
        else:
            pack_points_kernel(lo1, hi1, lo2, hi2, s["Coordinates"], s["Volume"], self._P)
        return self._P

    def _coefficients(self, block: BlockView, reach: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """a and c of the view's rows and the ghosts, or (``reach``: what a fused kernel reads,
        both ends of every bond) of every row the view's bonds reach."""
        s = block.fields
        n = s.num_points
        if self._a is None or self._a.shape[0] != n:
            self._a = np.zeros(n)
            self._c = np.zeros(n)
        lo1, hi1, lo2, hi2 = self._reach(block) if reach else (block.start, block.stop, block.num_owned, n)
        m, theta = s["Weighted_Volume"], s["Dilatation"]
        coefficients_kernel(lo1, hi1, m, theta, self.K, self.mu, self._a, self._c)
        if hi2 > lo2:  # ghosts (MPI): their dilatation and weighted volume are exchanged
            coefficients_kernel(lo2, hi2, m, theta, self.K, self.mu, self._a, self._c)
        return self._a, self._c

    def force_state(self, block: BlockView, t: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        dT, aT = self._dT(block)
        a, c = self._coefficients(block)
        force_state_kernel(
            block.start, block.stop, nl.offsets, nl.neighbors, s["Bond_Length"], s["Coordinates"], a, c,
            kind, delta, table, self._damage(block), dT, aT, t,
        )

    def force_fused(self, block: BlockView, force_density: np.ndarray) -> bool:
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        dT, aT = self._dT(block)
        damage = self._damage(block)
        if kind == 0 and not damage.shape[0] and not dT.shape[0]:
            fused_force_plain_kernel(block.start, block.stop, nl.offsets, nl.neighbors, s["Bond_Length"], self._packed(block, True), force_density)
            return True
        reverse = nl.reverse() if damage.shape[0] and not block.damage_symmetric else EMPTY_INDEX
        if kind == 0 and damage.shape[0] and not dT.shape[0] and not reverse.shape[0]:
            fused_force_damage_plain_kernel(
                block.start, block.stop, nl.offsets, nl.neighbors, s["Bond_Length"], self._packed(block, True), damage, force_density
            )
            return True
        a, c = self._coefficients(block, reach=True)
        fused_force_kernel(
            block.start, block.stop, nl.offsets, nl.neighbors, reverse, s["Bond_Length"], s["Coordinates"], s["Volume"],
            a, c, kind, delta, table, damage, dT, aT, force_density,
        )
        return True

    def tangent(self, block: BlockView, target) -> bool:
        """Analytic d(f V)/dy (peridyn.materials.tangents), unless the deck asks for Peridigm's
        finite differences (``Apply Automatic Differentiation Jacobian: false``)."""
        if not self.params.apply_ad_jacobian:
            return False
        from .tangents import lps_tangent_kernel

        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        dT, aT = self._dT(block)
        T = target
        lps_tangent_kernel(
            block.start, block.stop, T.nrows, T.nchunks, nl.offsets, nl.neighbors, T.in_offsets, T.in_bonds, T.sources,
            T.eval_rank, s["Bond_Length"], s["Coordinates"], s["Volume"], s["Weighted_Volume"], s["Dilatation"], self.K, self.mu,
            kind, delta, table, self._damage(block), dT, aT, T.row_of_local, T.local_of_row, T.indptr, T.indices, T.data,
            T.max_degree, T.max_in,
        )
        return True

    def stored_energy_density(self, block: BlockView, out: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        dT, aT = self._dT(block)
        stored_energy_kernel(
            block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Coordinates"], s["Volume"],
            s["Weighted_Volume"], s["Dilatation"], self.K, self.mu, kind, delta, table, self._damage(block), dT, aT, out,
        )
