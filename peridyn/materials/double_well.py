"""``Nonlocal Double Well State``: the state-based fracture model of Lipton, Said & Jha (2018)
and Jha & Lipton (2019), NLMech's ``PDState``/``RNPState``: the regularized nonlinear bond
potential of :mod:`peridyn.materials.rnp` plus a double-well potential in the nonlocal
dilatation, which frees Poisson's ratio.

Dilatation (the regularized hydrostatic strain; NLMech's theta divided by delta):

    theta_i = sum_j J(r/delta) (|eta| - |xi|) V_j / (omega_d delta^(d+1))   (-> M tr(eps) = tr(eps))

Energy density W_i = sum_j J f(r s^2) V_j / (omega_d delta^(d+1)) + (1/delta) g(sqrt(delta) theta_i),
f(x) = C (1 - exp(-beta x)) the bond potential and g(y) = Cbar (1 - exp(-Betabar y^2)) the
dilatational one: convex near zero, concave past the critical dilatation
theta_c = (2 Betabar delta)^(-1/2), bounded by Cbar / delta, so that opening a crack costs a
finite energy in it too. The force is the gradient of sum_i W_i V_i: the bond pair force of
the RNP model plus, for the dilatation, the ordinary state

    t_ij = P_i J(r/delta) / (omega_d delta^(d+1)),   P_i = g'(sqrt(delta) theta_i) / sqrt(delta)
         = 2 Cbar Betabar theta_i exp(-Betabar delta theta_i^2).

Relations (3D; J normalised, M = 1; mu, lambda the Lame constants; planar in brackets with
lambda* = K - mu the in-plane one, K the in-plane bulk modulus):

    bond part:        lambda_b = mu_b = mu = 2 C beta / 5          [C beta / 2]
    dilatation part:  Cbar Betabar = (lambda - mu) / 2             [(lambda* - mu) / 2]
    fracture energy:  G_c = 3 C / 2 + 2 Cbar                       [4 C / pi + 2 Cbar]

(the dilatation of every point within delta of a cut grows without bound as the cut opens, so
each side's band of width delta holds Cbar / delta per volume: 2 Cbar per crack area). The
double well needs lambda >= mu (Poisson's ratio at least 1/4 in 3D and plane strain, 1/3 in
plane stress); at equality the model is the RNP bond model. One constant is free: Betabar,
by default equal to beta (the dilatation softens at the strain scale the bonds do), which gives
beta = (lambda + 11 mu / 4) / G_c [(lambda* - mu + 8 mu / pi) / G_c], C = 5 mu / (2 beta)
[2 mu / beta], Cbar = (lambda - mu) / (2 Betabar). A deck's Beta Bar sets it instead:
Cbar = (lambda - mu) / (2 Betabar), C = 2 (G_c - 2 Cbar) / 3 [pi (G_c - 2 Cbar) / 4] (G_c must
exceed 2 Cbar), beta = 5 mu / (2 C) [2 mu / C].

NLMech's dilatational energy is the quadratic (lambda - mu) theta^2 (Lipton's doubled elastic
energy, see peridyn.materials.rnp) and it stops counting bonds past their inflection stretch in
theta; here the dilatation's own double well bounds the energy of a crack, and every bond
counts. No irreversible option: the model is elastic (with a damage model's Bond_Damage, each
end's force, dilatation and energy are scaled by 1 - d).
"""
from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from ..core.fields import FieldSpec, Relation, Temporal
from ..core.interfaces import BlockView, ElasticModuli, Material
from ..core.params import ModelParams, UsedWhen
from ..core.traversal import BondMap, PairForce, PointSum
from ..kernels import compiled, empty, resident
from ..kernels.lengths import reference_lengths
from .moduli import bulk_and_shear
from .rnp import INFLUENCE_KINDS, horizon_factor, influence, influence_coefficient

EMPTY_INDEX = np.zeros(0, dtype=np.int32)


def double_well_constants(K: float, mu: float, Gc: float, dim: int, beta_bar: float | None = None) -> tuple[float, float, float, float]:
    """(C, beta, Cbar, Betabar) from the bulk modulus K (in-plane for dim 2), the shear modulus
    mu (Pa), G_c (J/m^2) and optionally Betabar (1/m); M = 1. Raises ValueError when lambda < mu
    or G_c <= 2 Cbar."""
    lam = K - 2.0 * mu / 3.0 if dim == 3 else K - mu
    if lam < mu * (1.0 - 1e-12):
        raise ValueError(f"the double well needs lambda >= mu (Poisson's ratio >= {'1/4' if dim == 3 else '1/4 in plane strain, 1/3 in plane stress'}); "
                         f"got lambda = {lam:.6g}, mu = {mu:.6g}: use 'Regularized Nonlinear Bond' or a larger Poisson's ratio")
    lam = max(lam, mu)
    bond_k = 2.5 if dim == 3 else 2.0  # C beta = bond_k mu
    bond_g = 1.5 if dim == 3 else 4.0 / math.pi  # G_c of the bonds = bond_g C
    if beta_bar is None:
        beta = (lam - mu + bond_g * bond_k * mu) / Gc
        return bond_k * mu / beta, beta, (lam - mu) / (2.0 * beta), beta
    c_bar = (lam - mu) / (2.0 * beta_bar)
    if not Gc > 2.0 * c_bar:
        raise ValueError(f"'Beta Bar' = {beta_bar:g} puts Cbar = (lambda - mu) / (2 Beta Bar) = {c_bar:.6g} J/m^2, and 2 Cbar exceeds Gc = {Gc:g}: "
                         "give a larger 'Beta Bar' or leave it out")
    C = (Gc - 2.0 * c_bar) / bond_g
    return C, bond_k * mu / C, c_bar, beta_bar


class DoubleWellParams(ModelParams):
    density: float = Field(alias="Density", gt=0, description="mass density (M/L^3, kg/m^3 in SI)")
    bulk_modulus: float | None = Field(None, alias="Bulk Modulus", gt=0, description="bulk modulus K (Pa in SI); two of Bulk, Shear, Young's Modulus and Poisson's Ratio")
    shear_modulus: float | None = Field(None, alias="Shear Modulus", gt=0, description="shear modulus mu (Pa in SI)")
    youngs_modulus: float | None = Field(None, alias="Young's Modulus", gt=0, description="Young's modulus E (Pa in SI)")
    poissons_ratio: float | None = Field(None, alias="Poisson's Ratio", description="Poisson's ratio nu (dimensionless; the double well needs nu >= 1/4, 1/3 in plane stress)")
    gc: float | None = Field(None, alias="Gc", gt=0, description="critical energy release rate G_c (J/m^2 in SI), bonds' and dilatation's together; give this or KIc")
    kic: float | None = Field(None, alias="KIc", gt=0, description="mode I fracture toughness K_Ic (Pa m^0.5 in SI), G_c = K_Ic^2 / E'")
    beta_bar: float | None = Field(None, alias="Beta Bar", gt=0, description="Betabar of the dilatation's potential g(y) = Cbar (1 - exp(-Betabar y^2)) (1/m in SI); default: the bonds' beta")
    influence: Literal["Constant", "Linear", "Gaussian"] = Field(
        "Constant", alias="Influence Function Type", description="J(r/delta), normalised to int_0^1 J(r) r^d dr = 1: Constant, Linear (1 - r) or Gaussian exp(-r^2/0.2)"
    )
    plane_strain: bool = Field(False, alias="Plane Strain", description="2D plane strain (needs Height)")
    plane_stress: bool = Field(False, alias="Plane Stress", description="2D plane stress (needs Height)")
    height: float | None = Field(None, alias="Height", description="thickness of a 2D model (L)")
    used_when = {"height": UsedWhen(lambda p: p.plane_strain or p.plane_stress, "the model is 2D ('Plane Strain' or 'Plane Stress')", gt=0)}

    @model_validator(mode="after")
    def _check(self):
        if (self.gc is None) == (self.kic is None):
            raise ValueError("give exactly one of 'Gc' (critical energy release rate) and 'KIc' (fracture toughness)")
        if self.plane_strain and self.plane_stress:
            raise ValueError("'Plane Strain' and 'Plane Stress' cannot both be true")
        if (self.plane_strain or self.plane_stress) and self.height is None:
            raise ValueError("a 2D model ('Plane Strain' or 'Plane Stress') needs 'Height'")
        K, mu = self.moduli()
        E, nu = self.youngs_and_poisson(K, mu)
        if not (-1.0 < nu < 0.5):
            raise ValueError(f"the moduli give Poisson's ratio {nu:.6g}, outside (-1, 1/2)")
        double_well_constants(K, mu, self.fracture_energy(), self.dimension, self.beta_bar)
        return self

    @property
    def dimension(self) -> int:
        return 2 if (self.plane_strain or self.plane_stress) else 3

    def moduli(self) -> tuple[float, float]:
        """(K, mu) in Pa, K in-plane for a 2D model."""
        return bulk_and_shear(K=self.bulk_modulus, G=self.shear_modulus, E=self.youngs_modulus, nu=self.poissons_ratio,
                              plane_strain=self.plane_strain, plane_stress=self.plane_stress)

    def youngs_and_poisson(self, K: float, mu: float) -> tuple[float, float]:
        planar = "plane stress" if self.plane_stress else "plane strain" if self.plane_strain else "3d"
        return ElasticModuli(K, mu, planar).youngs_and_poisson()

    def fracture_energy(self) -> float:
        """G_c (J/m^2) as given, or K_Ic^2 / E' (E' = E / (1 - nu^2) but in plane stress)."""
        if self.gc is not None:
            return self.gc
        E, nu = self.youngs_and_poisson(*self.moduli())
        return self.kic**2 / (E if self.plane_stress else E / (1.0 - nu * nu))


# Loop laws; prm (float array): coef_f, coef_w, beta, 1/delta, kind, a (as rnp), then
# 1/(omega_d delta^(d+1)) [6], 2 Cbar Betabar [7], Betabar delta [8], Cbar / delta [9].
def dilatation_term(i, j, b, ex, ey, ez, L, z, p, args):
    """(1 - d) J (|eta| - |xi|) V_j; args (prm, d, V)."""
    prm, bond_damage, volume = args
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    return keep * influence(prm, z) * (L - z) * volume[j]


def dilatation_finish(i, acc, p, args):
    return acc * args[0][6]


def pressure(prm, theta):
    """P = 2 Cbar Betabar theta exp(-Betabar delta theta^2) (M L^-1 T^-2)."""
    return prm[7] * theta * math.exp(-prm[8] * theta * theta)


def point_pressure(i, args):
    return pressure(args[0], args[2][i])


def force_state_bond(i, j, b, ex, ey, ez, L, z, p, args):
    """t_ij = (1 - d) J (f'-part / 2 + P_i / F) (force per volume^2); args (prm, d, theta)."""
    prm, bond_damage, theta = args
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    s = (L - z) / z
    J = influence(prm, z)
    return keep * J * ((0.5 * prm[0]) * s * math.exp(-prm[2] * z * s * s) + p * prm[6])


def pair_force(i, j, b, ex, ey, ez, L, z, p, args):
    """(t_ij + t_ji) V_j; args (prm, d, theta, reverse, V)."""
    prm, bond_damage, theta, reverse, volume = args
    s = (L - z) / z
    J = influence(prm, z)
    half = (0.5 * prm[0]) * s * math.exp(-prm[2] * z * s * s)
    ti = J * (half + p * prm[6])
    tj = J * (half + pressure(prm, theta[j]) * prm[6])
    if bond_damage.shape[0] > 0:
        d_rev = bond_damage[reverse[b]] if reverse.shape[0] > 0 and reverse[b] >= 0 else bond_damage[b]
        return ((1.0 - bond_damage[b]) * ti + (1.0 - d_rev) * tj) * volume[j]
    return (ti + tj) * volume[j]


def energy_term(i, j, b, ex, ey, ez, L, z, p, args):
    """(1 - d) J f(r s^2) V_j / F; args (prm, d, V, theta)."""
    prm, bond_damage, volume, theta = args
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    s = (L - z) / z
    return keep * prm[1] * influence(prm, z) * (-math.expm1(-prm[2] * z * s * s)) * volume[j]


def energy_finish(i, acc, p, args):
    """Bonds' energy + (Cbar / delta) (1 - exp(-Betabar delta theta_i^2))."""
    prm, theta = args[0], args[3]
    return acc + prm[9] * (-math.expm1(-prm[8] * theta[i] * theta[i]))


DILATATION = PointSum(dilatation_term, finish=dilatation_finish)
FORCE_STATE = BondMap(force_state_bond, point=point_pressure)
PAIR_FORCE = PairForce(pair_force, point=point_pressure)
STORED_ENERGY = PointSum(energy_term, finish=energy_finish)


class DoubleWellState(Material):
    """Bond-based RNP potential plus a double well in the nonlocal dilatation."""

    name = "Nonlocal Double Well State"
    Params = DoubleWellParams
    row_local = True
    precompute_fields = ("Dilatation",)
    devices = frozenset({"cpu", "gpu"})

    def __init__(self, params: DoubleWellParams, *, horizon: float | None, options=None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        if horizon is None:
            raise ValueError(f"{self.name} needs a constant horizon (its constants depend on it); give Horizon as a number")
        dim = params.dimension
        self.K, self.mu = params.moduli()
        self.Gc = params.fracture_energy()
        self.C, self.beta, self.c_bar, self.beta_bar = double_well_constants(self.K, self.mu, self.Gc, dim, params.beta_bar)
        F = horizon_factor(dim, horizon, params.height if dim == 2 else 1.0)
        self.prm = np.array([
            4.0 * self.C * self.beta / F, self.C / F, self.beta, 1.0 / horizon, float(INFLUENCE_KINDS[params.influence]),
            influence_coefficient(params.influence, dim), 1.0 / F, 2.0 * self.c_bar * self.beta_bar, self.beta_bar * horizon,
            self.c_bar / horizon,
        ])

    @property
    def density(self) -> float:
        return self.params.density

    @property
    def bulk_modulus(self) -> float:
        return self.K

    def critical_dilatation(self) -> float:
        """theta_c = (2 Betabar delta)^(-1/2): past it the dilatation's pressure decreases."""
        return 1.0 / math.sqrt(2.0 * self.beta_bar * float(self.horizon))

    def elastic_moduli(self) -> ElasticModuli:
        p = self.params
        if p.dimension == 2:
            return ElasticModuli(self.K, self.mu, "plane stress" if p.plane_stress else "plane strain", thickness=p.height)
        return ElasticModuli(self.K, self.mu, "3d")

    def fields(self) -> list[FieldSpec]:
        return [FieldSpec("Dilatation", Relation.ELEMENT, 1, Temporal.CONSTANT, halo=True)]

    def _damage(self, block: BlockView) -> np.ndarray:
        return block.fields["Bond_Damage"] if "Bond_Damage" in block.fields else empty(block)

    def precompute(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        args = (resident(block, self.prm), self._damage(block), s["Volume"])
        law, zeta = reference_lengths(block, DILATATION)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, s["Dilatation"])

    def force_state(self, block: BlockView, t: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        args = (resident(block, self.prm), self._damage(block), s["Dilatation"])
        law, zeta = reference_lengths(block, FORCE_STATE)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, t)

    def force_fused(self, block: BlockView, force_density: np.ndarray) -> bool:
        s, nl = block.fields, block.bonds
        damage = self._damage(block)
        reverse = nl.reverse() if damage.shape[0] and not block.damage_symmetric else empty(block, EMPTY_INDEX.dtype)
        args = (resident(block, self.prm), damage, s["Dilatation"], reverse, s["Volume"])
        law, zeta = reference_lengths(block, PAIR_FORCE)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, force_density)
        return True

    def stored_energy_density(self, block: BlockView, out: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        args = (resident(block, self.prm), self._damage(block), s["Volume"], s["Dilatation"])
        law, zeta = reference_lengths(block, STORED_ENERGY)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, out)
