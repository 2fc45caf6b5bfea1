"""``Multiphysics Elastic``: Peridigm's LPS solid coupled with a nonlocal fluid flow, the pressure
p being a fourth unknown per point (PERIDIGM_MODELS.md §7; ``nonlocal_diffusion.cxx``).

Force. The Elastic (LPS) force state with the owner's fluid pressure p_i (``Fluid_Pressure_Y``)
in the dilatational coefficient (Peridigm's evaluation order):

    alpha = (15 mu / m) s,   c1 = (omega theta_i) (3K/m - alpha/3) - ((3 omega)/m) p_i,
    t_ij  = (1-d) (c1 zeta + ((1-d) omega) alpha e),        e = |eta| - zeta - a_T dT_i zeta,

s the surface correction factor (1, or the Elastic Plastic Hardening factor *not* inverted with
``Apply Shear Correction Factor``). A positive pressure pushes the points of a family apart.

Flow. For every bond i->j, with eta = y_j - y_i,

    k_bar = k - 0.25 (3 k)                       (the diagonal of the nonlocal permeability)
    k_e   = eta . k_bar I . eta,  then  k_e <- k_e + (k_max - k_e) / (1 + exp(a_p (d - d_c)))
    q_ij  = ((rho_f / mu) (4 / (pi delta^2))) (k_e / |eta|^4) (p_j - p_i),
    mu    = mu_f exp(c_T dT_i) with a thermal expansion coefficient, else mu_f,

and Flux_Density_i = sum_j q_ij V_j - sum_{j: i in N_j} q_ji V_j (Peridigm adds q V_j to i and
subtracts q V_i from j). ``Fluid compressibility`` and ``Fluid linear thermal expansion`` are
read and unused, as in Peridigm. Only the coupled QuasiStatic solve advances the pressure.

Tangent (:mod:`peridyn.materials.multiphysics_kernels`): the exact Jacobian of (f V, flow V)
with respect to (y, p) in 4x4 blocks, in place of Peridigm's Sacado AD (equal up to round-off).
"""
from __future__ import annotations

import math

import numpy as np
from pydantic import Field, field_validator

from ..core.errors import InputError
from ..core.fields import FieldSpec, Relation
from ..core.influence import ONE, omega
from ..core.interfaces import SMALL_STRAIN, BlockView, ElasticModuli, Material
from ..core.traversal import BondMap, PointSum
from ..kernels.lengths import compiled_with_lengths
from .elastic import DILATATION, EMPTY, WEIGHTED_VOLUME, dilatation_finish
from .moduli import IsotropicElasticParams, isotropic_moduli

#: the pressure fields (node scalars): current trial value, accumulated value, rate; flow density
PRESSURE_FIELDS = ("Fluid_Pressure_Y", "Fluid_Pressure_U", "Fluid_Pressure_V", "Flux_Density")
#: per-bond flow q_ij (written by force_state, gathered by the coupled solver)
FLOW_BOND_FIELD = "Fluid_Flow_Bond"


class MultiphysicsElasticParams(IsotropicElasticParams):
    permeability: float = Field(alias="Permeability", description="isotropic permeability k (L^2)")
    fluid_density: float = Field(alias="Fluid density", description="fluid density rho_f (M/L^3)")
    fluid_compressibility: float = Field(alias="Fluid compressibility", description="read and unused, as in Peridigm (L T^2/M)")
    fluid_dynamic_viscosity: float = Field(alias="Fluid dynamic viscosity", gt=0, description="fluid dynamic viscosity mu_f (M/(L T))")
    fluid_linear_thermal_expansion: float = Field(alias="Fluid linear thermal expansion", description="read and unused, as in Peridigm (1/temperature)")
    reynolds_viscosity_temperature_effect: float = Field(
        alias="Fluid Reynolds viscosity temperature effect", description="c_T: mu = mu_f exp(c_T dT) with thermal strain (1/temperature)"
    )
    permeability_inflection_damage: float = Field(alias="Permeability curve inflection damage", description="d_c of the logistic permeability law")
    max_permeability: float = Field(alias="Max permeability", description="k_max of the logistic permeability law")
    permeability_alpha: float = Field(alias="Permeability alpha", description="a_p, the slope of the logistic permeability law")
    apply_ad_jacobian: bool = Field(
        True, alias="Apply Automatic Differentiation Jacobian", description="must be true: the material has only the exact tangent (as in Peridigm)"
    )
    apply_shear_correction_factor: bool = Field(
        False, alias="Apply Shear Correction Factor", description="scale alpha by the surface correction factor (Peridigm's, not inverted)"
    )
    thermal_expansion_coefficient: float | None = Field(
        None, alias="Thermal Expansion Coefficient", description="linear thermal expansion coefficient of the solid (1/temperature)"
    )
    multiphysics: int | None = Field(None, alias="Multiphysics", description="accepted (the top-level Multiphysics key decides)")

    @field_validator("apply_ad_jacobian")
    @classmethod
    def _ad_only(cls, v: bool) -> bool:
        if not v:
            raise ValueError("Multiphysics Elastic has only the exact (automatic differentiation) Jacobian; remove the key or set it to true")
        return v


# ------------------------------------------------------------------------------------------------
# Loop laws (peridyn.core.traversal), compiled into each loop by the run's backend. Bond context
# (i, j, b, ex, ey, ez, L, z, p, args): eta = (ex, ey, ez) = y_j - y_i, L = |eta| (L), z = |xi|
# (L). Arrays: m, theta, scf, P (n,) weighted volume (L^5), dilatation, surface correction factor,
# fluid pressure; d (nb,) bond damage or empty; dT (n,) temperature change or empty (no thermal
# strain). The general dilatation and the weighted volume are Elastic's laws
# (peridyn.materials.elastic). Per-point switches (thermal strain) come with the point's value,
# and an optional array is read only inside the helpers below, never under a branch of a law
# function itself: a compiled law counts references to an array it holds across such a branch at
# every bond (several times slower).
# ------------------------------------------------------------------------------------------------
def influence(omega_kind, zeta, delta, table, b):
    """omega of bond b (:func:`peridyn.core.influence.omega`)."""
    return omega(omega_kind, zeta, delta, table, b)


def damage_of(bond_damage, b):
    """d of bond b, 0 without damage."""
    return bond_damage[b] if bond_damage.shape[0] > 0 else 0.0


def intact(bond_damage, b):
    """1 - d of bond b, 1 without damage."""
    return 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0


def thermal_shift(i, args):
    """(thermal strain on, a_T dT_i) of the owner point (0 without); args[10], args[11] = (dT,
    a_T) in the force-state and the energy args alike."""
    dT, alpha_T = args[10], args[11]
    thermal = dT.shape[0] > 0
    return thermal, alpha_T * dT[i] if thermal else 0.0


def coupled_point(i, args):
    """(m_i, alpha_i = (15 mu / m_i) s_i, thermal strain on, a_T dT_i, theta_i, 3K/m_i - alpha_i/3,
    P_i); alpha and 3K/m - alpha/3 are 0 for a point without weighted volume. args (m, theta, scf,
    P, K, mu, omega_kind, delta, table, d, dT, a_T)."""
    m, theta, scf, P, K, mu = args[0], args[1], args[2], args[3], args[4], args[5]
    mi = m[i]
    alpha = ((15.0 * mu) / mi) * scf[i] if mi != 0.0 else 0.0
    cK = (3.0 * K) / mi - alpha / 3.0 if mi != 0.0 else 0.0
    thermal, shift = thermal_shift(i, args)
    return mi, alpha, thermal, shift, theta[i], cK, P[i]


def coupled_force_state_bond(i, j, b, ex, ey, ez, L, z, q, args):
    """t_ij (M L^-5 T^-2) with the owner's pressure in c1 (Peridigm's
    computeInternalForceLinearElasticCoupled); 0 where m_i = 0. Reads only the arrays it needs
    (an array held across the early return would be reference-counted at every bond)."""
    omega_kind, delta, omega_table, bond_damage = args[6], args[7], args[8], args[9]
    mi, alpha, thermal, shift, th, cK, Pi = q
    if mi == 0.0:
        return 0.0
    e = L - z
    if thermal:
        e -= shift * z
    w = influence(omega_kind, z, delta, omega_table, b)
    keep = intact(bond_damage, b)
    c1 = (w * th) * cK - (((3.0 * w) / mi) * 1.0) * Pi
    return keep * (c1 * z + ((keep * w) * alpha) * e)


def coupled_plain_point(i, args):
    """(m_i, alpha_i, c1_i) for omega = 1: c1 = theta_i (3K/m_i - alpha_i/3) - (3/m_i) P_i (per
    point; the products of ``coupled_force_state_bond`` with w = 1)."""
    m, theta, scf, P, K, mu = args[0], args[1], args[2], args[3], args[4], args[5]
    mi = m[i]
    if mi == 0.0:
        return mi, 0.0, 0.0
    alpha = ((15.0 * mu) / mi) * scf[i]
    return mi, alpha, theta[i] * ((3.0 * K) / mi - alpha / 3.0) - ((3.0 / mi) * 1.0) * P[i]


def coupled_force_state_plain_bond(i, j, b, ex, ey, ez, L, z, q, args):
    """``coupled_force_state_bond`` for omega = 1, no damage, no thermal strain (the same
    products): no branch on an optional array."""
    mi, alpha, c1 = q
    if mi == 0.0:
        return 0.0
    return c1 * z + alpha * (L - z)


def dilatation_plain_term(i, j, b, ex, ey, ez, L, z, p, args):
    """Elastic's dilatation term for omega = 1, no damage, no thermal strain (the same
    products); args (V, m) as Elastic's."""
    return ((3.0 * z) * (L - z)) * args[0][j]


def flow_coefficients(k, rho_f, mu, delta):
    """(k_bar, C): the diagonal of the nonlocal permeability and (rho_f/mu) (4/(pi delta^2))."""
    kbar = k - 0.25 * (3.0 * k)
    return kbar, (rho_f / mu) * (4.0 / ((math.pi * delta) * delta))


def flow_point(i, args):
    """(k_bar, C) of the owner point (its viscosity mu_f exp(c_T dT_i) with thermal strain).
    args (P, d, dT, c_T, k, rho_f, mu_f, k_max, a_p, d_c, delta)."""
    P, bond_damage, dT, c_T, k, rho_f, mu_f, k_max, a_p, d_c, delta = args
    mu = mu_f * math.exp(c_T * dT[i]) if dT.shape[0] > 0 else mu_f
    return flow_coefficients(k, rho_f, mu, delta)


def flow_bond(i, j, b, ex, ey, ez, L, z, q, args):
    """q_ij = C (k_e / |eta|^4) (P_j - P_i) (pressure per time per volume; Peridigm's
    computeInternalFluidFlow)."""
    P, bond_damage, dT, c_T, k, rho_f, mu_f, k_max, a_p, d_c, delta = args
    kbar, C = q
    # the sequential sum over row, col of (eta_row K_bar[row, col]) eta_col (zeros included)
    ke = 0.0
    ke += (ex * kbar) * ex
    ke += (ex * 0.0) * ey
    ke += (ex * 0.0) * ez
    ke += (ey * 0.0) * ex
    ke += (ey * kbar) * ey
    ke += (ey * 0.0) * ez
    ke += (ez * 0.0) * ex
    ke += (ez * 0.0) * ey
    ke += (ez * kbar) * ez
    d = damage_of(bond_damage, b)
    ke = ke + (k_max - ke) * (1.0 / (1.0 + math.exp(a_p * (d - d_c))))
    return (C * (ke / math.pow(L, 4.0))) * (P[j] - P[i])


def coupled_energy_point(i, args):
    """(theta_i, thermal strain on, a_T dT_i); args (x, V, m, K, theta, mu, omega_kind, delta,
    table, d, dT, a_T, scf), Elastic's stored-energy args and the surface correction factors."""
    thermal, shift = thermal_shift(i, args)
    return args[4][i], thermal, shift


def coupled_energy_term(i, j, b, ex, ey, ez, L, z, p, args):
    """(1-d) omega e_d^2 V_j with e_d = e - theta_i |xi| / 3, |xi| from the reference positions x
    (Elastic's arithmetic; the pressure does not enter)."""
    x, volume, m, K, theta, mu, omega_kind, delta, omega_table, bond_damage, dT, alpha_T, scf = args
    th, thermal, shift = p
    dx = x[i, 0] - x[j, 0]
    dy = x[i, 1] - x[j, 1]
    dz = x[i, 2] - x[j, 2]
    L0 = math.sqrt(dx * dx + dy * dy + dz * dz)
    if thermal:
        L -= shift * L0
    ed = (L - L0) - (th * L0) / 3.0
    keep = intact(bond_damage, b)
    return (((keep * influence(omega_kind, L0, delta, omega_table, b)) * ed) * ed) * volume[j]


def coupled_energy_finish(i, acc, p, args):
    """W_i = K theta^2 / 2 + (alpha / 2) acc, alpha = (15 mu / m_i) s_i (energy per volume;
    Peridigm's computeStoredElasticEnergyDensity); 0 without weighted volume."""
    m, K, mu, scf = args[2], args[3], args[5], args[12]
    th = p[0]
    if m[i] == 0.0:
        return 0.0
    alpha = ((15.0 * mu) / m[i]) * scf[i]
    return ((0.5 * K) * th) * th + (0.5 * alpha) * acc


COUPLED_FORCE_STATE = BondMap(coupled_force_state_bond, point=coupled_point)
#: omega = 1, no damage, no thermal strain: laws without the optional arrays
COUPLED_FORCE_STATE_PLAIN = BondMap(coupled_force_state_plain_bond, point=coupled_plain_point)
DILATATION_PLAIN = PointSum(dilatation_plain_term, finish=dilatation_finish)
FLOW = BondMap(flow_bond, point=flow_point)
COUPLED_STORED_ENERGY = PointSum(coupled_energy_term, point=coupled_energy_point, finish=coupled_energy_finish)


# ------------------------------------------------------------------------------------------------
class MultiphysicsElastic(Material):
    """Peridigm's ``Multiphysics Elastic`` (LPS solid + nonlocal Darcy-like flow)."""
    small_strain_limit = SMALL_STRAIN  # a linear law

    name = "Multiphysics Elastic"
    Params = MultiphysicsElasticParams
    precompute_fields = ("Dilatation",)
    ghost_inputs = ("Fluid_Pressure_Y",)
    multiphysics = True
    flow_bond_field = FLOW_BOND_FIELD

    def __init__(self, params: MultiphysicsElasticParams, *, horizon: float | None, options=None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        self._ones: np.ndarray | None = None
        if horizon is None:
            raise InputError(
                "the Multiphysics Elastic material needs a constant horizon (its flow law uses the block's horizon)",
                path=tuple((options or {}).get("path", ())),
                fix="give the block's Horizon as a number",
            )
        self.K, self.mu = params.moduli()
        self.alpha_T = params.thermal_expansion_coefficient
        self.omega_table = EMPTY

    @property
    def density(self) -> float:
        return self.params.density

    @property
    def bulk_modulus(self) -> float:
        return self.K

    def elastic_moduli(self) -> ElasticModuli:
        """The solid's constants (not Hookean: the fluid pressure enters the stress)."""
        return isotropic_moduli(self.params, self.K, self.mu, hookean=False)

    @property
    def thermal(self) -> bool:
        return self.alpha_T is not None

    def fields(self) -> list[FieldSpec]:
        specs = [
            FieldSpec("Weighted_Volume", Relation.ELEMENT, 1, halo=True, units="L^5"),
            FieldSpec("Dilatation", Relation.ELEMENT, 1, halo=True),
            FieldSpec("Fluid_Pressure_Y", Relation.NODE, halo=True, units="pressure"),
            FieldSpec("Fluid_Pressure_U", Relation.NODE, units="pressure"),
            FieldSpec("Fluid_Pressure_V", Relation.NODE, units="pressure/T"),
            FieldSpec("Flux_Density", Relation.NODE, units="pressure/T"),
            FieldSpec(FLOW_BOND_FIELD, Relation.BOND, units="pressure/(T L^3)"),
        ]
        if self.params.apply_shear_correction_factor:
            specs.append(FieldSpec("Surface_Correction_Factor", Relation.ELEMENT, halo=True))
        if self.thermal:
            specs += [FieldSpec("Temperature", Relation.NODE), FieldSpec("Temperature_Change", Relation.NODE, halo=True)]
        return specs

    # -- helpers ---------------------------------------------------------------------------------
    def _common(self, block: BlockView):
        return block.influence.kind, float(self.horizon), self.omega_table

    @staticmethod
    def _damage(block: BlockView) -> np.ndarray:
        return block.fields.get("Bond_Damage", EMPTY)

    def _dT(self, block: BlockView) -> tuple[np.ndarray, float]:
        if self.thermal:
            return block.fields["Temperature_Change"], float(self.alpha_T)
        return EMPTY, 0.0

    def scf(self, block: BlockView) -> np.ndarray:
        """Surface correction factors (n_local,), ones without ``Apply Shear Correction Factor``."""
        if self.params.apply_shear_correction_factor:
            return block.fields["Surface_Correction_Factor"]
        n = block.fields.num_points
        if self._ones is None or self._ones.shape[0] != n:
            self._ones = np.ones(n)
        return self._ones

    def flow_parameters(self) -> tuple[float, float, float, float, float, float, float]:
        """(c_T, k, rho_f, mu_f, k_max, a_p, d_c) in the kernels' order."""
        p = self.params
        return (float(p.reynolds_viscosity_temperature_effect), float(p.permeability), float(p.fluid_density), float(p.fluid_dynamic_viscosity),
                float(p.max_permeability), float(p.permeability_alpha), float(p.permeability_inflection_damage))

    # -- material interface ----------------------------------------------------------------------
    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        if block.influence.needs_table:
            self.omega_table = block.influence.table_for(nl.offsets, nl.neighbors, s["Model_Coordinates"], np.arange(block.start, block.stop), float(self.horizon))
        kind, delta, table = self._common(block)
        compiled_with_lengths(block, WEIGHTED_VOLUME)(
            block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], (s["Volume"], kind, delta, table), s["Weighted_Volume"]
        )
        if self.params.apply_shear_correction_factor:
            from .elastic_plastic_hardening import shear_correction_kernel

            out = s["Surface_Correction_Factor"]
            shear_correction_kernel(block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Volume"], s["Weighted_Volume"], kind, delta, table, out)
            out[block.start : block.stop] = 1.0 / out[block.start : block.stop]  # Peridigm's factor, not inverted

    def _plain(self, block: BlockView) -> bool:
        """omega = 1, no damage, no thermal strain: the branch-free laws apply."""
        return block.influence.kind == ONE and not self._damage(block).shape[0] and not self.thermal

    def precompute(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        dT, aT = self._dT(block)
        args = (s["Volume"], s["Weighted_Volume"], kind, delta, table, self._damage(block), dT, aT)
        law = DILATATION_PLAIN if self._plain(block) else DILATATION
        compiled_with_lengths(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], args, s["Dilatation"])

    def force_state(self, block: BlockView, t: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        dT, aT = self._dT(block)
        args = (s["Weighted_Volume"], s["Dilatation"], self.scf(block), s["Fluid_Pressure_Y"], self.K, self.mu, kind, delta, table,
                self._damage(block), dT, aT)
        law = COUPLED_FORCE_STATE_PLAIN if self._plain(block) else COUPLED_FORCE_STATE
        compiled_with_lengths(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], args, t)
        self.flow_state(block)

    def stored_energy_density(self, block: BlockView, out: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        dT, aT = self._dT(block)
        args = (s["Model_Coordinates"], s["Volume"], s["Weighted_Volume"], self.K, s["Dilatation"], self.mu, kind, delta, table,
                self._damage(block), dT, aT, self.scf(block))
        compiled_with_lengths(block, COUPLED_STORED_ENERGY)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], args, out)

    def flow_state(self, block: BlockView) -> None:
        """The per-bond flow q (field ``Fluid_Flow_Bond``) of the block's points' bonds."""
        s, nl = block.fields, block.bonds
        dT, _ = self._dT(block)
        c_T, k, rho_f, mu_f, k_max, a_p, d_c = self.flow_parameters()
        q = s[FLOW_BOND_FIELD]
        args = (s["Fluid_Pressure_Y"], self._damage(block), dT, c_T, k, rho_f, mu_f, k_max, a_p, d_c, float(self.horizon))
        compiled_with_lengths(block, FLOW)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], args, q)
        if not np.isfinite(q[nl.offsets[block.start] : nl.offsets[block.stop]]).all():
            from ..core.errors import InstabilityError

            raise InstabilityError(
                f"the fluid flow of block {block.name!r} is not finite (coincident deformed points, or a non-finite pressure)", collective=False
            )

    def coupled_tangent(self, block: BlockView, target) -> None:
        """Add d(f V, flow V)/d(y, p) of the block's points' bonds to the 4x4-block matrix
        ``target`` (:class:`peridyn.solvers.linalg.coupled_tangent.CoupledTangentTarget`)."""
        from .multiphysics_kernels import coupled_tangent_kernel

        s, nl = block.fields, block.bonds
        kind, delta, table = self._common(block)
        dT, aT = self._dT(block)
        c_T, k, rho_f, mu_f, k_max, a_p, d_c = self.flow_parameters()
        T = target
        coupled_tangent_kernel(
            block.start, block.stop, T.eval_rank, nl.offsets, nl.neighbors, s["Bond_Length"], s["Coordinates"], s["Volume"],
            s["Weighted_Volume"], s["Dilatation"], self.scf(block), s["Fluid_Pressure_Y"], self.K, self.mu, kind, delta, table,
            self._damage(block), dT, aT, c_T, k, rho_f, mu_f, k_max, a_p, d_c, T.row_of_local, T.indptr, T.indices, T.data,
        )

    def tangent(self, block: BlockView, target) -> bool:
        raise InputError(
            "the Multiphysics Elastic material needs the coupled (displacement and pressure) QuasiStatic solve",
            path=tuple(self.options.get("path", ())),
            fix="use a QuasiStatic solver with 'Solve For Displacement' and 'Solve For Pressure' true",
        )
