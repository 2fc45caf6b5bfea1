"""``Linear LPS Partial Volume``: the linearised (small-displacement) peridynamic solid, with
optional partial volumes (PERIDIGM_MODELS.md §5.1; Peridigm's ``LinearLPSPVMaterial``,
``elastic_pv.cxx``), and ``Elastic Partial Volume`` (§5.2) without them.

Per bond i->j with reference bond xi = x_j - x_i, displacement difference du = u_j - u_i and
neighbour weight W_j (the bond's ``Neighbor_Volume`` with partial volumes, else V_j):

    m_i     = sum_j (omega zeta^2) W_j                   (or the deck's analytic value)
    theta_i = (3 / m_i) sum_j ((omega (1 - d)) (xi . du)) W_j      (only where i has bonds)
    T1_i    = (((9K - 15 mu) omega) theta_i) / (3 m_i),   T2_i = ((15 mu) omega) / (m_i |xi|^2)
    M_a     = ((xi_a xi_0) du_0 + (xi_a xi_1) du_1) + (xi_a xi_2) du_2
    T_i<xi> = (1 - d) (T1_i xi + T2_i M)      (a vector force state along the *reference* bond)

and f_i = sum_j (T_i<xi_ij> - T_j<xi_ji>) W_j. With partial volumes Peridigm weights the reaction
of bond j->i on i by that bond's ``Self_Volume``: the part of the bond owner's cell (j) inside
the other end's (i's) horizon, |cell_j ∩ B(x_i, delta_i)|, which is i's ``Neighbor_Volume`` of
bond i->j. So peridyn weights both terms with i's own ``Neighbor_Volume`` (one bond field, no
reverse lookup). The small-strain model is invariant under translations and infinitesimal
rotations only (a finite rotation strains it).

Differences from Peridigm: implicit solvers build this material's tangent by peridyn's finite
differences, which call ``precompute`` at every probe (Peridigm's freeze theta, so its tangent
lacks d theta / d y); ``Use Improved Quadrature`` is not available (an external library in
Peridigm too); with partial volumes the block must be computed by the fused kernel (a block
whose bonds stay inside it, symmetric families).

The stored energy density W_i = K theta_i^2 / 2 + (15 mu / (2 m_i)) sum_j (1-d) omega
(e - theta_i zeta / 3)^2 W_j with e = (xi . du) / zeta is the linearised LPS energy (Peridigm's
class defines none).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from pydantic import Field, model_validator

from ..core.errors import InputError
from ..core.fields import FieldSpec, Relation, Temporal
from ..core.influence import omega
from ..core.interfaces import BlockView, ElasticModuli, Material
from ..core.params import UsedWhen
from .elastic import Elastic, ElasticParams
from .moduli import IsotropicElasticParams, isotropic_moduli

EMPTY = np.zeros(0)
EMPTY_INDEX = np.zeros(0, dtype=np.int32)


class LinearLPSPVParams(IsotropicElasticParams):
    verbose: bool = Field(False, alias="Verbose", description="accepted for compatibility")
    use_partial_volume: bool = Field(
        False, alias="Use Partial Volume",
        description="weight neighbours by the part of their cell inside the horizon (needs Discretization > "
        "Compute Element-Horizon Intersections: true, an Exodus HEX8 mesh)",
    )
    use_improved_quadrature: bool = Field(False, alias="Use Improved Quadrature", description="not available (Peridigm: an external library)")
    use_analytic_weighted_volume: bool = Field(False, alias="Use Analytic Weighted Volume", description="use 'Analytic Weighted Volume' for every m_i")
    analytic_weighted_volume: float | None = Field(None, alias="Analytic Weighted Volume", description="m (L^5), required with 'Use Analytic Weighted Volume'")
    used_when = {"analytic_weighted_volume": UsedWhen(lambda p: p.use_analytic_weighted_volume, "'Use Analytic Weighted Volume' is true", gt=0)}

    @model_validator(mode="after")
    def _options(self):
        if self.use_improved_quadrature:
            raise ValueError("'Use Improved Quadrature' is not available (Peridigm needs an external quadrature library for it)")
        if self.use_analytic_weighted_volume and self.analytic_weighted_volume is None:
            raise ValueError("'Use Analytic Weighted Volume' is true: give 'Analytic Weighted Volume' (L^5)")
        return self


# ------------------------------------------------------------------------------------------------
# kernels (x, y (n, 3) L; volume (n,) L^3; offsets (n+1,), neighbors (nb,); W (nb,) neighbour
# weights or empty (then V_j); bond_damage (nb,) or empty; omega_kind / delta / table as in
# peridyn.core.influence)
# ------------------------------------------------------------------------------------------------
@njit(cache=True, parallel=True, error_model="numpy")
def weighted_volume_kernel(start, stop, offsets, neighbors, x, volume, W, omega_kind, delta, table, m):
    """m_i = sum_j (omega zeta^2) W_j (L^5), zeta from self - neighbour."""
    pv = W.shape[0] > 0
    for i in prange(start, stop):
        acc = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            dx = x[i, 0] - x[j, 0]
            dy = x[i, 1] - x[j, 1]
            dz = x[i, 2] - x[j, 2]
            z2 = (dx * dx + dy * dy) + dz * dz
            w = omega(omega_kind, math.sqrt(z2), delta, table, b)
            acc += (w * z2) * (W[b] if pv else volume[j])
        m[i] = acc


@njit(cache=True, parallel=True, error_model="numpy")
def dilatation_kernel(start, stop, offsets, neighbors, x, y, volume, W, m, omega_kind, delta, table, bond_damage, theta):
    """theta_i = (3 / m_i) sum_j ((omega (1-d)) (xi . du)) W_j; 0 for a point without bonds."""
    pv = W.shape[0] > 0
    has_damage = bond_damage.shape[0] > 0
    for i in prange(start, stop):
        u0 = y[i, 0] - x[i, 0]
        u1 = y[i, 1] - x[i, 1]
        u2 = y[i, 2] - x[i, 2]
        acc = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            xi0 = x[j, 0] - x[i, 0]
            xi1 = x[j, 1] - x[i, 1]
            xi2 = x[j, 2] - x[i, 2]
            s = (xi0 * ((y[j, 0] - x[j, 0]) - u0) + xi1 * ((y[j, 1] - x[j, 1]) - u1)) + xi2 * ((y[j, 2] - x[j, 2]) - u2)
            w = omega(omega_kind, math.sqrt((xi0 * xi0 + xi1 * xi1) + xi2 * xi2), delta, table, b)
            keep = 1.0 - bond_damage[b] if has_damage else 1.0
            acc += ((w * keep) * s) * (W[b] if pv else volume[j])
        theta[i] = acc * (3.0 / m[i]) if offsets[i + 1] > offsets[i] else acc


@njit(cache=True, inline="always", error_model="numpy")
def _bond(x, y, i, j):
    """xi = x_j - x_i, du = u_j - u_i, |xi|^2 and the dyad product M = xi (xi . du) of a bond."""
    xi0 = x[j, 0] - x[i, 0]
    xi1 = x[j, 1] - x[i, 1]
    xi2 = x[j, 2] - x[i, 2]
    d0 = (y[j, 0] - x[j, 0]) - (y[i, 0] - x[i, 0])
    d1 = (y[j, 1] - x[j, 1]) - (y[i, 1] - x[i, 1])
    d2 = (y[j, 2] - x[j, 2]) - (y[i, 2] - x[i, 2])
    M0 = ((xi0 * xi0) * d0 + (xi0 * xi1) * d1) + (xi0 * xi2) * d2
    M1 = ((xi1 * xi0) * d0 + (xi1 * xi1) * d1) + (xi1 * xi2) * d2
    M2 = ((xi2 * xi0) * d0 + (xi2 * xi1) * d1) + (xi2 * xi2) * d2
    return xi0, xi1, xi2, (xi0 * xi0 + xi1 * xi1) + xi2 * xi2, M0, M1, M2


@njit(cache=True, parallel=True, error_model="numpy")
def force_state_kernel(start, stop, offsets, neighbors, x, y, m, theta, K, mu, omega_kind, delta, table, bond_damage, T):
    """T[b] (nb, 3) = (1-d) (T1_i xi + T2_i M) for the bonds of points [start, stop) (force per
    volume squared)."""
    has_damage = bond_damage.shape[0] > 0
    for i in prange(start, stop):
        for b in range(offsets[i], offsets[i + 1]):
            xi0, xi1, xi2, z2, M0, M1, M2 = _bond(x, y, i, neighbors[b])
            w = omega(omega_kind, math.sqrt(z2), delta, table, b)
            T1 = (((9.0 * K - 15.0 * mu) * w) * theta[i]) / (3.0 * m[i])
            T2 = ((15.0 * mu) * w) / (m[i] * z2)
            keep = 1.0 - bond_damage[b] if has_damage else 1.0
            T[b, 0] = keep * (T1 * xi0 + T2 * M0)
            T[b, 1] = keep * (T1 * xi1 + T2 * M1)
            T[b, 2] = keep * (T1 * xi2 + T2 * M2)


@njit(cache=True, parallel=True, error_model="numpy")
def fused_force_kernel(start, stop, offsets, neighbors, reverse, x, y, W, m, theta, K, mu, omega_kind, delta, table, bond_damage, f):
    """f_i = sum_j (T_i<xi_ij> - T_j<xi_ji>) W_ij for i in [start, stop), both ends from point
    quantities: xi and M change sign with the bond's direction, so T_j<xi_ji> = -(1-d_ji) (T1_j xi
    + T2_j M); ``reverse`` gives d_ji (empty: d_ji = d_ij). W (nb,) the bonds' weights."""
    has_damage = bond_damage.shape[0] > 0
    for i in prange(start, stop):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            xi0, xi1, xi2, z2, M0, M1, M2 = _bond(x, y, i, j)
            w = omega(omega_kind, math.sqrt(z2), delta, table, b)
            c1 = (9.0 * K - 15.0 * mu) * w
            c2 = (15.0 * mu) * w
            T1i = (c1 * theta[i]) / (3.0 * m[i])
            T2i = c2 / (m[i] * z2)
            T1j = (c1 * theta[j]) / (3.0 * m[j])
            T2j = c2 / (m[j] * z2)
            ki = 1.0 - bond_damage[b] if has_damage else 1.0
            kj = ki
            if has_damage and reverse.shape[0] > 0 and reverse[b] >= 0:
                kj = 1.0 - bond_damage[reverse[b]]
            fx += (ki * (T1i * xi0 + T2i * M0) + kj * (T1j * xi0 + T2j * M0)) * W[b]
            fy += (ki * (T1i * xi1 + T2i * M1) + kj * (T1j * xi1 + T2j * M1)) * W[b]
            fz += (ki * (T1i * xi2 + T2i * M2) + kj * (T1j * xi2 + T2j * M2)) * W[b]
        f[i, 0] = fx
        f[i, 1] = fy
        f[i, 2] = fz


@njit(cache=True, parallel=True, error_model="numpy")
def stored_energy_kernel(start, stop, offsets, neighbors, x, y, volume, W, m, theta, K, mu, omega_kind, delta, table, bond_damage, out):
    """W_i = K theta^2 / 2 + (15 mu / (2 m_i)) sum_j (1-d) omega (e - theta zeta / 3)^2 W_j,
    e = (xi . du) / zeta (energy per volume)."""
    pv = W.shape[0] > 0
    has_damage = bond_damage.shape[0] > 0
    for i in prange(start, stop):
        th = theta[i]
        acc = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            xi0, xi1, xi2, z2, M0, M1, M2 = _bond(x, y, i, j)
            z = math.sqrt(z2)
            s = (M0 * xi0 + M1 * xi1 + M2 * xi2) / z2  # xi . du
            ed = s / z - th * z / 3.0
            keep = 1.0 - bond_damage[b] if has_damage else 1.0
            acc += (keep * omega(omega_kind, z, delta, table, b)) * ed * ed * (W[b] if pv else volume[j])
        out[i] = 0.5 * K * th * th + (0.5 * (15.0 * mu) / m[i]) * acc if offsets[i + 1] > offsets[i] else 0.5 * K * th * th


# ------------------------------------------------------------------------------------------------
class LinearLPSPartialVolume(Material):
    """Linearised LPS with optional partial volumes (Peridigm's ``Linear LPS Partial Volume``)."""

    name = "Linear LPS Partial Volume"
    Params = LinearLPSPVParams
    force_state_kind = "vector"
    precompute_fields = ("Dilatation",)

    def __init__(self, params: LinearLPSPVParams, *, horizon: float | None, options=None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        self.K, self.mu = params.moduli()
        self.omega_table = EMPTY

    @property
    def density(self) -> float:
        return self.params.density

    @property
    def bulk_modulus(self) -> float:
        return self.K

    def elastic_moduli(self) -> ElasticModuli:
        return isotropic_moduli(self.params, self.K, self.mu, hookean=True)

    @property
    def partial(self) -> bool:
        return bool(self.params.use_partial_volume)

    def _common(self, block: BlockView):
        return block.influence.kind, block.horizon, self.omega_table

    def _damage(self, block: BlockView) -> np.ndarray:
        return block.fields.get("Bond_Damage", EMPTY)

    def fields(self) -> list[FieldSpec]:
        specs = [
            FieldSpec("Weighted_Volume", Relation.ELEMENT, 1, Temporal.CONSTANT, halo=True, units="L^5"),
            FieldSpec("Dilatation", Relation.ELEMENT, 1, Temporal.CONSTANT, halo=True),
        ]
        if self.partial:
            specs.append(FieldSpec("Neighbor_Volume", Relation.BOND, 1, Temporal.CONSTANT, units="L^3"))
        return specs

    def _weights(self, block: BlockView) -> np.ndarray:
        return block.fields["Neighbor_Volume"] if self.partial else EMPTY

    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        if block.influence.needs_table:
            self.omega_table = block.influence.table_for(nl.offsets, nl.neighbors, s["Model_Coordinates"], np.arange(block.start, block.stop), block.horizon)
        W = self._weights(block)
        lo, hi = int(nl.offsets[block.start]), int(nl.offsets[block.stop])
        if self.partial and hi > lo and not np.any(W[lo:hi] > 0.0):
            raise InputError(
                "'Use Partial Volume' is true but the discretization computes no partial volumes",
                path=tuple(self.options.get("path", ())) + ("Use Partial Volume",),
                fix="set Discretization > 'Compute Element-Horizon Intersections: true' (an Exodus HEX8 mesh)",
            )
        m = s["Weighted_Volume"]
        if self.params.use_analytic_weighted_volume:
            m[block.start : block.stop] = float(self.params.analytic_weighted_volume)
            return
        kind, delta, table = self._common(block)
        weighted_volume_kernel(block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Volume"], W, kind, delta, table, m)

    def precompute(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        dilatation_kernel(block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Coordinates"], s["Volume"],
                          self._weights(block), s["Weighted_Volume"], kind, delta, table, self._damage(block), s["Dilatation"])

    def force_state(self, block: BlockView, T: np.ndarray) -> None:
        if self.partial:
            raise InputError(
                f"block {block.name!r}: 'Use Partial Volume' needs the block's bonds to stay inside the block (one material, "
                "no implicit finite-difference tangent)",
                path=tuple(self.options.get("path", ())) + ("Use Partial Volume",),
            )
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        force_state_kernel(block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Coordinates"],
                           s["Weighted_Volume"], s["Dilatation"], self.K, self.mu, kind, delta, table, self._damage(block), T)

    def force_fused(self, block: BlockView, force_density: np.ndarray) -> bool:
        if not self.partial:
            return False  # the engine's gather of the vector force states
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        damage = self._damage(block)
        reverse = nl.reverse() if damage.shape[0] and not block.damage_symmetric else EMPTY_INDEX
        fused_force_kernel(block.start, block.stop, nl.offsets, nl.neighbors, reverse, s["Model_Coordinates"], s["Coordinates"],
                           self._weights(block), s["Weighted_Volume"], s["Dilatation"], self.K, self.mu, kind, delta, table, damage, force_density)
        return True

    def tangent(self, block: BlockView, target) -> bool:
        return False  # finite differences (Peridigm: the base class's)

    def stored_energy_density(self, block: BlockView, out: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        stored_energy_kernel(block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Coordinates"], s["Volume"],
                             self._weights(block), s["Weighted_Volume"], s["Dilatation"], self.K, self.mu, kind, delta, table,
                             self._damage(block), out)


class ElasticPVParams(ElasticParams):
    """Peridigm's ``Elastic Partial Volume`` parameters as far as its kernels show them."""


class ElasticPartialVolume(Elastic):
    """``Elastic Partial Volume`` (PERIDIGM_MODELS.md §5.2). Peridigm's class is not public; its
    kernels are the Elastic LPS with W_j = Neighbor_Volume when partial volumes exist, else
    exactly ``Elastic``. peridyn runs it as ``Elastic`` (partial volumes are not applied)."""

    name = "Elastic Partial Volume"
    Params = ElasticPVParams
