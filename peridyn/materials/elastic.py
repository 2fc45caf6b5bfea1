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
from dataclasses import replace

import numpy as np
from numba import njit, prange
from pydantic import Field

from ..core.bondmath import stretch_exceeds
from ..core.fields import FieldSpec, Relation, Temporal
from ..core.influence import omega
from ..core.interfaces import SMALL_STRAIN, BlockView, ElasticModuli, Material
from ..core.params import UsedWhen
from ..core.traversal import BondMap, PairForce, PointMap, PointSum
from ..kernels import compiled, empty, on_host, resident
from ..kernels.lengths import coded_lengths, reference_lengths
from ..kernels.packing import pack_points_kernel, reach_kernel
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
# Loop laws (peridyn.core.traversal): the bond functions below are compiled into each loop by the
# run's backend. Bond context (i, j, b, ex, ey, ez, L, z, p, args): eta = (ex, ey, ez) = y_j - y_i
# and L = |eta| (L), z = |xi| (L), p what the law's point function returned for i. Empty arrays in
# args mean "feature off" (no damage, no thermal strain, no influence table).
def weighted_volume_term(i, j, b, ex, ey, ez, L, z, p, args):
    """omega zeta^2 V_j (L^5) of bond i->j, on reference positions (y = x); args (V, omega_kind,
    delta, omega_table)."""
    volume, omega_kind, delta, omega_table = args
    z2 = ex * ex + ey * ey + ez * ez
    return (omega(omega_kind, L, delta, omega_table, b) * z2) * volume[j]


def thermal_shift(i, args):
    """a_T dT_i (thermal strain of the owner point), 0 without thermal strain; args[-2:] = (dT, a_T)."""
    dT = args[-2]
    return args[-1] * dT[i] if dT.shape[0] > 0 else 0.0


def dilatation_term(i, j, b, ex, ey, ez, L, z, shift, args):
    """3 omega (1-d) zeta e V_j; args (V, m, omega_kind, delta, omega_table, d, dT, a_T)."""
    volume, m, omega_kind, delta, omega_table, bond_damage, dT, alpha_T = args
    e = L - z
    if dT.shape[0] > 0:
        e -= shift * z
    w = omega(omega_kind, z, delta, omega_table, b)
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    return ((((3.0 * w) * keep) * z) * e) * volume[j]


def dilatation_finish(i, acc, p, args):
    """theta_i = acc / m_i, 0 for a point without weighted volume; args[1] = m."""
    m = args[1]
    return acc / m[i] if m[i] != 0.0 else 0.0


def dilatation_plain_term(i, j, b, ex, ey, ez, L, z, p, args):
    """``dilatation_term`` for omega = 1, no damage, no thermal strain (the same products), on
    packed records (args[0] = P, V in column 5)."""
    P = args[0]
    return ((3.0 * z) * (L - z)) * P[j, 5]


def stretch_damage_gate(i, b, p, args):
    """Critical-stretch damage inside the dilatation loop: a bond broken for good keeps d = 1
    (added to the point's damage sum) and is skipped. args (P, m, omega_kind, delta,
    omega_table, s_c, d_n, d_np1, copy_previous, damage, offsets, dsum); dsum (n,) the points'
    running sums of their bonds' new damage, zero between calls."""
    d_n, d_np1, copy_previous, dsum = args[6], args[7], args[8], args[11]
    d = float(d_n[b]) if copy_previous else float(d_np1[b])
    if d >= 1.0:
        d_np1[b] = d
        dsum[i] += d
        return False
    return True


def stretch_damage_term(i, j, b, ex, ey, ez, L, z, p, args):
    """d = max(d, s > s_c) written to d_np1 and added to dsum[i], and the bond's dilatation
    term with it."""
    P, m, omega_kind, delta, omega_table, s_c, d_n, d_np1, copy_previous, damage, offsets, dsum = args
    d = float(d_n[b]) if copy_previous else float(d_np1[b])
    if stretch_exceeds(ex * ex + ey * ey + ez * ez, z, s_c):
        d = 1.0
    d_np1[b] = d
    dsum[i] += d
    if d < 1.0:
        w = omega(omega_kind, z, delta, omega_table, b)
        return ((((3.0 * w) * (1.0 - d)) * z) * (L - z)) * P[j, 5]
    return 0.0


def stretch_damage_finish(i, acc, p, args):
    """Point damage = broken bonds / bonds (written; the sum of the new bond damage, in bond
    order, as ``damage_sum`` gives it, taken from dsum, which is reset), theta_i returned."""
    m, damage, offsets, dsum = args[1], args[9], args[10], args[11]
    lo = offsets[i]
    hi = offsets[i + 1]
    damage[i] = dsum[i] / (hi - lo) if hi > lo else 0.0
    dsum[i] = 0.0
    return acc / m[i] if m[i] != 0.0 else 0.0


def coefficients_point(i, args):
    """(a_i, c_i, a_T dT_i); args[0:2] = (a, c), args[-2:] = (dT, a_T)."""
    return args[0][i], args[1][i], thermal_shift(i, args)


def force_state_bond(i, j, b, ex, ey, ez, L, z, p, args):
    """t_ij (M L^-5 T^-2); args (a, c, omega_kind, delta, omega_table, d, dT, a_T)."""
    a, c, omega_kind, delta, omega_table, bond_damage, dT, alpha_T = args
    ai, ci, shift = p
    e = L - z
    if dT.shape[0] > 0:
        e -= shift * z
    w = omega(omega_kind, z, delta, omega_table, b)
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    return keep * (w * (ci * z + keep * ai * e))


def pair_force(i, j, b, ex, ey, ez, L, z, p, args):
    """(t_ij + t_ji) V_j, both ends computed here (closed block, symmetric families: ``reverse``
    gives bond j->i; read only with damage, empty when both ends have equal damage); args (a, c,
    V, omega_kind, delta, omega_table, d, reverse, dT, a_T)."""
    a, c, volume, omega_kind, delta, omega_table, bond_damage, reverse, dT, alpha_T = args
    ai, ci, shift_i = p
    has_damage = bond_damage.shape[0] > 0
    thermal = dT.shape[0] > 0
    e = L - z
    w = omega(omega_kind, z, delta, omega_table, b)
    if has_damage or thermal:
        e_i = e - shift_i * z if thermal else e
        e_j = e - (alpha_T * dT[j]) * z if thermal else e
        k_i = 1.0 - bond_damage[b] if has_damage else 1.0
        k_j = (1.0 - bond_damage[reverse[b]] if reverse.shape[0] > 0 and reverse[b] >= 0 else k_i) if has_damage else 1.0
        t = w * (k_i * (ci * z + k_i * ai * e_i) + k_j * (c[j] * z + k_j * a[j] * e_j))
    else:
        t = w * plain_magnitude(ai, ci, a[j], c[j], z, e)
    return t * volume[j]


def packed_point(i, args):
    """(a_i, c_i) from the packed records args[0] (columns 3, 4)."""
    P = args[0]
    return P[i, 3], P[i, 4]


def plain_magnitude(ai, ci, aj, cj, z, e):
    """(t_ij + t_ji) / omega of an intact bond of stretch e = |eta| - |xi| (``pair_force``'s
    undamaged, unheated form; symmetric in its two ends, bit for bit)."""
    return (ci + cj) * z + (ai + aj) * e


def damaged_magnitude(k, ai, ci, aj, cj, z, e):
    """``plain_magnitude`` for a bond kept by k = 1 - d at both ends."""
    return k * (ci * z + k * ai * e) + k * (cj * z + k * aj * e)


def pair_force_plain(i, j, b, ex, ey, ez, L, z, p, args):
    """``pair_force`` for omega = 1, no damage, no thermal strain, on packed records (y, a, c, V):
    no branch in the bond loop."""
    P = args[0]
    ai, ci = p
    return plain_magnitude(ai, ci, P[j, 3], P[j, 4], z, L - z) * P[j, 5]


def pair_force_plain_both(i, j, b, rb, ex, ey, ez, L, z, p, pj, args):
    """``pair_force_plain`` from both ends: one force magnitude, each end's neighbor volume."""
    P = args[0]
    ai, ci = p
    aj, cj = pj
    t = plain_magnitude(ai, ci, aj, cj, z, L - z)
    return t * P[j, 5], t * P[i, 5]


def intact_gate(i, b, p, args):
    """Skips a bond broken for good (args[1] = d)."""
    return 1.0 - args[1][b] != 0.0


def pair_force_damage_plain(i, j, b, ex, ey, ez, L, z, p, args):
    """``pair_force`` for omega = 1, no thermal strain, damage equal at both ends (same
    arithmetic), on packed records; args (P, d)."""
    P, bond_damage = args
    ai, ci = p
    return damaged_magnitude(1.0 - bond_damage[b], ai, ci, P[j, 3], P[j, 4], z, L - z) * P[j, 5]


def pair_force_damage_plain_both(i, j, b, rb, ex, ey, ez, L, z, p, pj, args):
    """``pair_force_damage_plain`` from both ends; one force magnitude when the two ends' bond
    damage is equal (always, for the damage models this law is used with)."""
    P, bond_damage = args
    if bond_damage[rb] != bond_damage[b]:
        return (pair_force_damage_plain(i, j, b, ex, ey, ez, L, z, p, args),
                pair_force_damage_plain(j, i, rb, -ex, -ey, -ez, L, z, pj, args))
    ai, ci = p
    aj, cj = pj
    t = damaged_magnitude(1.0 - bond_damage[b], ai, ci, aj, cj, z, L - z)
    return t * P[j, 5], t * P[i, 5]


def energy_point(i, args):
    """theta_i; args[4] = theta."""
    return args[4][i]


def stored_energy_term(i, j, b, ex, ey, ez, L, z, th, args):
    """(1-d) omega e_d^2 V_j with e_d = e - theta_i |xi| / 3, |xi| from the reference positions;
    args (x, V, m, K, theta, mu, omega_kind, delta, omega_table, d, dT, a_T)."""
    x, volume, m, K, theta, mu, omega_kind, delta, omega_table, bond_damage, dT, alpha_T = args
    dx = x[i, 0] - x[j, 0]
    dy = x[i, 1] - x[j, 1]
    dz = x[i, 2] - x[j, 2]
    L0 = math.sqrt(dx * dx + dy * dy + dz * dz)
    if dT.shape[0] > 0:
        L -= (alpha_T * dT[i]) * L0
    ed = (L - L0) - (th * L0) / 3.0
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    return (((keep * omega(omega_kind, L0, delta, omega_table, b)) * ed) * ed) * volume[j]


def stored_energy_finish(i, acc, th, args):
    """W_i = K theta^2 / 2 + (15 mu / m_i / 2) acc (energy per volume); 0 without weighted volume."""
    m, K, mu = args[2], args[3], args[5]
    if m[i] == 0.0:
        return 0.0
    alpha = (15.0 * mu) / m[i]
    return ((0.5 * K) * th) * th + (0.5 * alpha) * acc


WEIGHTED_VOLUME = PointSum(weighted_volume_term)
WEIGHTED_VOLUME_FROM_X = PointSum(weighted_volume_term, z_from_positions=True)  # zeta: x (no Bond_Length)
DILATATION = PointSum(dilatation_term, point=thermal_shift, finish=dilatation_finish)
DILATATION_PLAIN = PointSum(dilatation_plain_term, finish=dilatation_finish)
# not mirrored: its two per-bond damage arrays, read and written at the far end's bond too, cost
# more than the shared square root saves (cube40 with damage, one core: 18.8 ms gathered against
# 21.7 mirrored with a shared stretch test)
DILATATION_STRETCH_DAMAGE = PointSum(stretch_damage_term, gate=stretch_damage_gate, finish=stretch_damage_finish, mirror=False)
FORCE_STATE = BondMap(force_state_bond, point=coefficients_point)
PAIR_FORCE = PairForce(pair_force, point=coefficients_point)
PAIR_FORCE_PLAIN = PairForce(pair_force_plain, point=packed_point, both=pair_force_plain_both)
PAIR_FORCE_DAMAGE_PLAIN = PairForce(pair_force_damage_plain, point=packed_point, gate=intact_gate, both=pair_force_damage_plain_both)
# The same laws taking |xi| from the records' reference positions (columns 6-8): a square root
# more per bond, no Bond_Length to hold (8 bytes a bond) or stream. Measured on one core: 45 %
# slower at 1.1 M bonds (the lengths stream from cache), even at 2.9 M, 0-8 % faster at 7.15 M
# (cube40: peak memory 312 -> 259 MiB); chosen from POSITIONS_MIN_BONDS local bonds up. Not with
# damage: there the stretch test needs no square root for most bonds and the damage model
# reads Bond_Length anyway.
POSITIONS_MIN_BONDS = 2_500_000
LENGTHS_FROM_X = {law: replace(law, z_from_positions=True) for law in (DILATATION_PLAIN, PAIR_FORCE_PLAIN, PAIR_FORCE_DAMAGE_PLAIN)}
# Every law reads coded lengths instead where the mesh has few distinct ones (a lattice;
# peridyn.kernels.lengths): no square root and one or two bytes a bond, the same bits.
STORED_ENERGY = PointSum(stored_energy_term, point=energy_point, finish=stored_energy_finish, z_from_positions=True)  # zeta: x


@njit(cache=True, inline="always", error_model="numpy")
def point_coefficients(m, theta, K, mu):
    """Force-state coefficients of one point: a = 15 mu / m, c = theta (3 K / m - a / 3), so
    that t_ij = (1-d) omega (c_i zeta + (1-d) a_i e). Zero for a point without neighbors."""
    if m == 0.0:
        return 0.0, 0.0
    a = (15.0 * mu) / m
    return a, theta * ((3.0 * K) / m - a / 3.0)


def coefficients_of_point(i, args):
    """(a_i, c_i) of ``point_coefficients``; args (m, theta, K, mu)."""
    m, theta, K, mu = args
    return point_coefficients(m[i], theta[i], K, mu)


COEFFICIENTS = PointMap(coefficients_of_point, width=2)


# Packed point records for the hot kernels: row i of P (n_local, 9) holds (y_x, y_y, y_z, a_i,
# c_i, V_i, x_x, x_y, x_z) in one 72-byte record (the first six, 48 bytes, when the bond lengths
# are coded: x is then never read), so a neighbor costs one or two cache lines
# instead of one per array (y, a, c, V, x). On cube40 (7.15 M bonds) packing y, a, c, V made a step
# 8 % faster on one core and much less slowed by a busy second core; taking |xi| from the
# record's x instead of reading Bond_Length (8 bytes a bond, never allocated then) made the force
# kernel 16 % faster again, bit for bit. Only the rows a view's bonds reach are repacked: two
# ranges, owned rows and ghost rows (``Elastic._reach``); x is written once.
PACK_WIDTH = 9
X_COLUMNS = slice(6, 9)
PACK_WIDTH_CODED = 6  # with coded bond lengths x is never read: 48-byte records (cube40: 6-12 % faster loops)
PACK_MIN_ROWS = 64  # smaller views (the finite-difference tangent's single points) read the arrays


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


# ------------------------------------------------------------------------------------------------
class Elastic(Material):
    """Linear peridynamic solid (Peridigm's ``Elastic``)."""
    small_strain_limit = SMALL_STRAIN  # a linear law

    name = "Elastic"
    analytic_tangent = True
    Params = ElasticParams
    precompute_fields = ("Dilatation",)
    row_local = True
    bond_energy = "lps"
    devices = frozenset({"cpu", "gpu"})

    def __init__(self, params: ElasticParams, *, horizon: float | None, options=None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        self.K, self.mu = params.moduli()
        self.alpha_T = params.thermal_expansion_coefficient
        self.omega_table = EMPTY
        self._ac_backend = None
        self._ac = None  # (n, 2) a and c of every local point (the general kernels)
        self._dsum: np.ndarray | None = None  # (n,) damage sums of DILATATION_STRETCH_DAMAGE, zero between calls
        self._P: np.ndarray | None = None  # packed records, allocated by the first view that uses them
        self._reaches: dict[tuple[int, int], tuple[int, int, int, int]] = {}
        self._damage_model = None  # a damage model whose rule precompute applies itself

    def finite_difference_probe_length(self) -> float | None:
        return self.params.finite_difference_probe_length

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
        return kind, block.horizon, resident(block, self.omega_table)

    def _damage(self, block: BlockView) -> np.ndarray:
        return block.fields["Bond_Damage"] if "Bond_Damage" in block.fields else empty(block)

    def _dT(self, block: BlockView) -> tuple[np.ndarray, float]:
        if self.thermal:
            return block.fields["Temperature_Change"], float(self.alpha_T)
        return empty(block), 0.0

    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        if block.influence.needs_table:
            self.omega_table = block.influence.table_for(nl.offsets, nl.neighbors, s["Model_Coordinates"], np.arange(block.start, block.stop), block.horizon)
        kind, delta, table = self._common(block)
        x = s["Model_Coordinates"]
        compiled(block, WEIGHTED_VOLUME_FROM_X)(block.start, block.stop, nl.offsets, nl.neighbors, x, x, (s["Volume"], kind, delta, table), s["Weighted_Volume"])

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
        P = self._packed(block, False)
        if self._dsum is None or self._dsum.shape[0] != s.num_points:
            self._dsum = np.zeros(s.num_points)
        args = (P, s["Weighted_Volume"], kind, delta, table, s_c, s.n("Bond_Damage"), s["Bond_Damage"], copy_previous, s["Damage"], nl.offsets, self._dsum)
        law, zeta = self._lengths(block, DILATATION_STRETCH_DAMAGE, P)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, P, args, s["Dilatation"])

    def precompute(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        dT, aT = self._dT(block)
        damage = self._damage(block)
        if kind == 0 and not damage.shape[0] and not dT.shape[0] and block.stop - block.start >= PACK_MIN_ROWS and on_host(block):
            P = self._packed(block, False)
            law, zeta = self._lengths(block, DILATATION_PLAIN, P)
            compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, P, (P, s["Weighted_Volume"]), s["Dilatation"])
            return
        args = (s["Volume"], s["Weighted_Volume"], kind, delta, table, damage, dT, aT)
        law, zeta = reference_lengths(block, DILATATION)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, s["Dilatation"])

    def _lengths(self, block: BlockView, law, P: np.ndarray):
        """The packed-record law and its ``zeta`` (the same bits every way): the coded lengths
        of a mesh with few distinct ones (while no other code has made Bond_Length); else
        Bond_Length, or from POSITIONS_MIN_BONDS local bonds up (and while no other code has made
        Bond_Length) the records' x."""
        if (not block.fields.allocated("Bond_Length") and block.bonds.num_bonds >= POSITIONS_MIN_BONDS
                and law in LENGTHS_FROM_X and coded_lengths(block) is None):
            return LENGTHS_FROM_X[law], P[:, X_COLUMNS]
        return reference_lengths(block, law)

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
            if coded_lengths(block) is None:
                self._P = np.zeros((n, PACK_WIDTH))
                self._P[:, X_COLUMNS] = s["Model_Coordinates"]
            else:
                self._P = np.zeros((n, PACK_WIDTH_CODED))
        lo1, hi1, lo2, hi2 = self._reach(block)
        if coefficients:
            pack_force_points_kernel(lo1, hi1, lo2, hi2, s["Coordinates"], s["Volume"], s["Weighted_Volume"], s["Dilatation"], self.K, self.mu, self._P)
        else:
            pack_points_kernel(lo1, hi1, lo2, hi2, s["Coordinates"], s["Volume"], 5, self._P)
        return self._P

    def _coefficients(self, block: BlockView, reach: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """a and c of the view's rows and the ghosts, or (``reach``: what a fused kernel reads,
        both ends of every bond) of every row the view's bonds reach."""
        s = block.fields
        n = s.num_points
        backend = block.backend
        if self._ac is None or self._ac.shape[0] != n or (backend is not None and self._ac_backend is not backend):
            self._ac = backend.zeros((n, 2)) if backend is not None else np.zeros((n, 2))
            self._ac_backend = backend
            # the column views, made once: numba-cuda slices a device array's column in Python, one
            # element at a time (seconds per slice at a million points, every step when made there)
            self._ac_columns = (self._ac[:, 0], self._ac[:, 1])
        if not on_host(block):  # one device: no ghosts; every row (those of a closed block's bonds among them)
            lo1, hi1, lo2, hi2 = 0, n, n, n
        else:
            lo1, hi1, lo2, hi2 = self._reach(block) if reach else (block.start, block.stop, block.num_owned, n)
        args = (s["Weighted_Volume"], s["Dilatation"], self.K, self.mu)
        kernel = compiled(block, COEFFICIENTS)
        nl = block.bonds
        kernel(lo1, hi1, nl.offsets, nl.neighbors, s["Weighted_Volume"], s["Coordinates"], args, self._ac)
        if hi2 > lo2:  # ghosts (MPI): their dilatation and weighted volume are exchanged
            kernel(lo2, hi2, nl.offsets, nl.neighbors, s["Weighted_Volume"], s["Coordinates"], args, self._ac)
        return self._ac_columns

    def force_state(self, block: BlockView, t: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        dT, aT = self._dT(block)
        a, c = self._coefficients(block)
        args = (a, c, kind, delta, table, self._damage(block), dT, aT)
        law, zeta = reference_lengths(block, FORCE_STATE)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, t)

    def force_fused(self, block: BlockView, force_density: np.ndarray) -> bool:
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        dT, aT = self._dT(block)
        damage = self._damage(block)
        host = on_host(block)
        if kind == 0 and not damage.shape[0] and not dT.shape[0] and host:
            P = self._packed(block, True)
            law, zeta = self._lengths(block, PAIR_FORCE_PLAIN, P)
            compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, P, (P,), force_density)
            return True
        reverse = nl.reverse() if damage.shape[0] and not block.damage_symmetric else empty(block, EMPTY_INDEX.dtype)
        if kind == 0 and damage.shape[0] and not dT.shape[0] and not reverse.shape[0] and host:
            P = self._packed(block, True)
            law, zeta = self._lengths(block, PAIR_FORCE_DAMAGE_PLAIN, P)
            compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, P, (P, damage), force_density)
            return True
        a, c = self._coefficients(block, reach=True)
        args = (a, c, s["Volume"], kind, delta, table, damage, reverse, dT, aT)
        law, zeta = reference_lengths(block, PAIR_FORCE)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, force_density)
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
        args = (s["Model_Coordinates"], s["Volume"], s["Weighted_Volume"], self.K, s["Dilatation"], self.mu, kind, delta, table, self._damage(block), dT, aT)
        compiled(block, STORED_ENERGY)(block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Coordinates"], args, out)
