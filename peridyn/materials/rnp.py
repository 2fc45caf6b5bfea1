"""``Regularized Nonlinear Bond``: NLMech's regularized nonlinear peridynamic (RNP) bond model.

The model of Lipton (J. Elast. 2014, 2016), Lipton, Said & Jha (2018) and Jha & Lipton (2019),
as NLMech (Jha & Diehl, JOSS 2021) implements it as ``PDBond``/``RNPBond``. A bond of
reference length r = |xi| and stretch s = (|eta| - |xi|)/|xi| stores, at each of its two ends,

    w(r, s) = J(r/delta) f(r s^2) / (omega_d delta^(d+1)),    f(x) = C (1 - exp(-beta x)),

omega_d delta^(d+1) the horizon's volume times delta (omega_3 = 4 pi / 3; omega_2 = pi, times the
thickness h of a planar model). The stored energy density is W_i = sum_j w(r_ij, s_ij) V_j and
the force on i the gradient of sum_i W_i V_i, a central pair force of magnitude

    (t_ij + t_ji) = 4 J C beta s exp(-beta r s^2) / (omega_d delta^(d+1))     (force / volume^2),

t_ij = t_ji its half. For small r s^2 it is the linear bond-based model with the micromodulus
c(r) = 4 J(r/delta) C beta / (omega_d delta^(d+1)). Past the inflection stretch
s_c(r) = rbar / sqrt(r), rbar = sqrt(1 / (2 beta)), where beta r s^2 = 1/2, the bond force
decreases: the bond softens instead of snapping, and separating a bond costs the finite energy
2 J C / (omega_d delta^(d+1)) V_i V_j (both ends), the depth of the potential well.

Influence function J(r) on [0, 1] (``Influence Function Type``, NLMech's three, each normalised
so that its moment M = int_0^1 J(r) r^d dr is 1): Constant J = d + 1; Linear J = (d+1)(d+2)(1-r);
Gaussian J = alpha exp(-r^2 / 0.2) with alpha set by M = 1.

Relations (M the moment above; derived from the energy whose gradient is the force):

    3D:     K = 2 C beta M / 3   (lambda = mu = 2 C beta M / 5, nu = 1/4)    G_c = 3 C M / 2
    planar: K = C beta M         (in-plane bulk modulus, mu = K / 2)          G_c = 4 C M / pi

so, from the deck's K (or E) and G_c (or K_Ic): C = 2 G_c / (3 M), beta = 9 K / (4 G_c) in 3D;
C = pi G_c / (4 M), beta = 4 K / (pi G_c) planar. G_c is the energy per crack area of the
integral int_{xi_n > 0} xi_n (2 J C / (omega_d delta^(d+1))) dxi over the bonds crossing a plane.
K_Ic gives G_c = K_Ic^2 / E' (E' = E / (1 - nu^2) in 3D and plane strain, E in plane stress).
Lipton states the limit energy as int 2 mu |E u|^2 + lambda (div u)^2, twice the usual elastic
energy, and writes lambda = mu = f'(0) M / 5 (3D), f'(0) M / 4 (2D); NLMech computes beta from
those, which with its own force law (the one above) gives a small-strain limit twice as stiff
as the stated E. peridyn keeps the usual energy: its beta is half of NLMech's, and the
small-strain limit is the ``Elastic Bond Based`` model of the stated K (checked by the tests).

Irreversibility (``Irreversible Bond Fracture``, NLMech's option, off by default): without it the
softening is elastic and a bond brought back heals, as in Lipton's analysis. With it a bond whose
|s| exceeds ``Check Sc Factor`` x s_c(r) (beta r s^2 > factor^2 / 2) is broken for good (a
two-step bond field ``Bond_Fracture``): it carries no force and keeps, in the stored energy, the
work that broke it, J C (1 - exp(-factor^2 / 2)) / (omega_d delta^(d+1)) per end (NLMech counts
the full depth C there). The energy to separate two halves is then G_c (1 - exp(-factor^2/2)):
0.39 G_c at the default factor 1 (breaking at the inflection), 0.99 G_c at factor 3.03.

Bond damage of a damage model, when the deck has one, scales each end's force and energy by
(1 - d) as in ``Elastic Bond Based``.
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

EMPTY_INDEX = np.zeros(0, dtype=np.int32)
GAUSSIAN_WIDTH = 0.2  #: NLMech's default width of the Gaussian influence function (of r/delta)
INFLUENCE_KINDS = {"Constant": 0, "Linear": 1, "Gaussian": 2}


def influence_coefficient(kind: str, dim: int) -> float:
    """The amplitude of the influence function ``kind`` that makes int_0^1 J(r) r^dim dr = 1."""
    if kind == "Constant":
        return float(dim + 1)
    if kind == "Linear":
        return float((dim + 1) * (dim + 2))
    b = GAUSSIAN_WIDTH
    if dim == 3:
        return (2.0 / b) / (b - (b + 1.0) * math.exp(-1.0 / b))
    return (4.0 / b) / (math.sqrt(math.pi * b) * math.erf(1.0 / math.sqrt(b)) - 2.0 * math.exp(-1.0 / b))


def horizon_factor(dim: int, delta: float, height: float = 1.0) -> float:
    """omega_d delta^(d+1) (L^4 in 3D; planar: pi h delta^3, h the thickness)."""
    if dim == 3:
        return (4.0 * math.pi / 3.0) * delta**4
    return math.pi * height * delta**3


def potential_constants(K: float, Gc: float, dim: int, moment: float = 1.0) -> tuple[float, float]:
    """(C, beta) of the potential f(x) = C (1 - exp(-beta x)) from the bulk modulus K (in-plane
    for dim 2, Pa) and G_c (J/m^2): C in J/m^2, beta in 1/m."""
    if dim == 3:
        C = 2.0 * Gc / (3.0 * moment)
        return C, 1.5 * K / (C * moment)
    C = math.pi * Gc / (4.0 * moment)
    return C, K / (C * moment)


def moduli_and_energy(C: float, beta: float, dim: int, moment: float = 1.0) -> tuple[float, float]:
    """(K, G_c) of the potential constants: the inverse of :func:`potential_constants`."""
    if dim == 3:
        return 2.0 * C * beta * moment / 3.0, 1.5 * C * moment
    return C * beta * moment, 4.0 * C * moment / math.pi


class RNPBondParams(ModelParams):
    density: float = Field(alias="Density", gt=0, description="mass density (M/L^3, kg/m^3 in SI)")
    bulk_modulus: float | None = Field(None, alias="Bulk Modulus", gt=0, description="bulk modulus K of the small-strain limit (Pa in SI); give this or Young's Modulus, or C and Beta")
    youngs_modulus: float | None = Field(None, alias="Young's Modulus", gt=0, description="Young's modulus E (Pa in SI); Poisson's ratio is fixed (1/4; 1/3 in plane stress)")
    gc: float | None = Field(None, alias="Gc", gt=0, description="critical energy release rate G_c (J/m^2 in SI): the energy to separate two halves per crack area; give this or KIc")
    kic: float | None = Field(None, alias="KIc", gt=0, description="mode I fracture toughness K_Ic (Pa m^0.5 in SI), G_c = K_Ic^2 / E'")
    c: float | None = Field(None, alias="C", gt=0, description="depth C of the potential f(x) = C (1 - exp(-beta x)) (J/m^2 in SI); with Beta, instead of moduli and Gc")
    beta: float | None = Field(None, alias="Beta", gt=0, description="beta of the potential f(x) = C (1 - exp(-beta x)) (1/m in SI); with C")
    influence: Literal["Constant", "Linear", "Gaussian"] = Field(
        "Constant", alias="Influence Function Type", description="J(r/delta), normalised to int_0^1 J(r) r^d dr = 1: Constant, Linear (1 - r) or Gaussian exp(-r^2/0.2)"
    )
    irreversible: bool = Field(False, alias="Irreversible Bond Fracture", description="a bond stretched past Check Sc Factor x its inflection stretch breaks for good")
    sc_factor: float = Field(1.0, alias="Check Sc Factor", description="breaking stretch / inflection stretch s_c(r) = sqrt(1/(2 beta r)) of an irreversible bond (dimensionless)")
    plane_strain: bool = Field(False, alias="Plane Strain", description="2D plane strain (needs Height)")
    plane_stress: bool = Field(False, alias="Plane Stress", description="2D plane stress (needs Height)")
    height: float | None = Field(None, alias="Height", description="thickness of a 2D model (L)")
    used_when = {
        "height": UsedWhen(lambda p: p.plane_strain or p.plane_stress, "the model is 2D ('Plane Strain' or 'Plane Stress')", gt=0),
        "sc_factor": UsedWhen(lambda p: p.irreversible, "'Irreversible Bond Fracture' is true", gt=0, le=1.0e3),
    }

    @model_validator(mode="after")
    def _check(self):
        direct = self.c is not None or self.beta is not None
        moduli = self.bulk_modulus is not None or self.youngs_modulus is not None
        energies = self.gc is not None or self.kic is not None
        if direct:
            if self.c is None or self.beta is None:
                raise ValueError("give both 'C' and 'Beta' (the potential's constants), or neither and moduli with 'Gc' or 'KIc'")
            if moduli or energies:
                raise ValueError("'C' and 'Beta' fix the moduli and G_c: give either them or a modulus with 'Gc'/'KIc', not both")
        else:
            if (self.bulk_modulus is None) == (self.youngs_modulus is None):
                raise ValueError("give exactly one of 'Bulk Modulus' and \"Young's Modulus\" (Poisson's ratio is fixed by the bond-based model), or 'C' and 'Beta'")
            if (self.gc is None) == (self.kic is None):
                raise ValueError("give exactly one of 'Gc' (critical energy release rate) and 'KIc' (fracture toughness), or 'C' and 'Beta'")
        if self.plane_strain and self.plane_stress:
            raise ValueError("'Plane Strain' and 'Plane Stress' cannot both be true")
        if (self.plane_strain or self.plane_stress) and self.height is None:
            raise ValueError("a 2D model ('Plane Strain' or 'Plane Stress') needs 'Height'")
        return self

    @property
    def dimension(self) -> int:
        return 2 if (self.plane_strain or self.plane_stress) else 3

    @property
    def poisson(self) -> float:
        return 1.0 / 3.0 if self.plane_stress else 0.25

    def bulk(self) -> float:
        """K of the stated modulus (in-plane for 2D), Pa; None-free only without C/Beta."""
        if self.bulk_modulus is not None:
            return self.bulk_modulus
        return bulk_and_shear(E=self.youngs_modulus, nu=self.poisson, plane_strain=self.plane_strain, plane_stress=self.plane_stress)[0]

    def fracture_energy(self, K: float) -> float:
        """G_c (J/m^2) as given, or from K_Ic with the E' of the model's E and nu."""
        if self.gc is not None:
            return self.gc
        nu = self.poisson
        if self.dimension == 3:
            E = 3.0 * K * (1.0 - 2.0 * nu)
        else:  # in-plane bulk modulus: E = 2 K (1 - nu) in plane stress, 2 K (1 + nu)(1 - 2 nu) in plane strain
            E = 2.0 * K * (1.0 - nu) if self.plane_stress else 2.0 * K * (1.0 + nu) * (1.0 - 2.0 * nu)
        e_prime = E if self.plane_stress else E / (1.0 - nu * nu)
        return self.kic**2 / e_prime

    def constants(self) -> tuple[float, float, float, float]:
        """(C, beta, K, G_c) with the normalised influence function (M = 1)."""
        dim = self.dimension
        if self.c is not None:
            K, Gc = moduli_and_energy(self.c, self.beta, dim)
            return self.c, self.beta, K, Gc
        K = self.bulk()
        Gc = self.fracture_energy(K)
        C, beta = potential_constants(K, Gc, dim)
        return C, beta, K, Gc


# Loop laws (peridyn.core.traversal); bond context (i, j, b, ex, ey, ez, L, z, p, args) with
# L = |eta|, z = |xi|. ``prm`` is a float array (coef_f, coef_w, beta, 1/delta, kind, a, x_break):
# coef_f = 4 C beta / (omega_d delta^(d+1)), coef_w = C / (omega_d delta^(d+1)), x_break =
# factor^2 / 2. ``frac_n``/``frac_np1``: Bond_Fracture at N and NP1, empty when reversible.
def influence(prm, z):
    """J(z / delta) (dimensionless)."""
    r = z * prm[3]
    kind = prm[4]
    if kind == 0.0:
        return prm[5]
    if kind == 1.0:
        return prm[5] * (1.0 - r)
    return prm[5] * math.exp(-r * r * (1.0 / GAUSSIAN_WIDTH))


def half_pair(b, L, z, prm, frac_n, frac_np1):
    """t_ij of bond b (force per volume^2), with the irreversible fracture test written to NP1."""
    s = (L - z) / z
    x = prm[2] * z * s * s
    if frac_n.shape[0] > 0:
        if frac_n[b] != 0 or x > prm[6]:
            frac_np1[b] = 1
            return 0.0
        frac_np1[b] = 0
    return (0.5 * prm[0]) * influence(prm, z) * s * math.exp(-x)


def force_state_bond(i, j, b, ex, ey, ez, L, z, p, args):
    """t_ij = (1 - d) x half the pair force; args (prm, d, frac_n, frac_np1)."""
    prm, bond_damage, frac_n, frac_np1 = args
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    return keep * half_pair(b, L, z, prm, frac_n, frac_np1)


def pair_force(i, j, b, ex, ey, ez, L, z, p, args):
    """(t_ij + t_ji) V_j; args (prm, d, reverse, frac_n, frac_np1, V); ``reverse`` as in
    ``Elastic Bond Based`` (read only with unequal damage at the two ends)."""
    prm, bond_damage, reverse, frac_n, frac_np1, volume = args
    half = half_pair(b, L, z, prm, frac_n, frac_np1)
    if bond_damage.shape[0] > 0:
        d_rev = bond_damage[reverse[b]] if reverse.shape[0] > 0 and reverse[b] >= 0 else bond_damage[b]
        t = (1.0 - bond_damage[b]) * half + (1.0 - d_rev) * half
    else:
        t = half + half
    return t * volume[j]


def stored_energy_term(i, j, b, ex, ey, ez, L, z, p, args):
    """(1 - d) w(r, s) V_j (energy per volume); args (prm, d, frac, V), frac at NP1."""
    prm, bond_damage, frac, volume = args
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    if frac.shape[0] > 0 and frac[b] != 0:
        x = prm[6]
    else:
        s = (L - z) / z
        x = prm[2] * z * s * s
    return keep * prm[1] * influence(prm, z) * (-math.expm1(-x)) * volume[j]


def softened_term(i, j, b, ex, ey, ez, L, z, p, args):
    """1 for a bond past its inflection stretch (beta r s^2 > 1/2) or broken; args (prm, frac,
    offsets)."""
    prm, frac, offsets = args
    if frac.shape[0] > 0 and frac[b] != 0:
        return 1.0
    s = (L - z) / z
    return 1.0 if prm[2] * z * s * s > 0.5 else 0.0


def fraction(i, acc, p, args):
    """acc / the number of i's bonds (dimensionless)."""
    count = args[2][i + 1] - args[2][i]
    return acc / count if count > 0 else 0.0


FORCE_STATE = BondMap(force_state_bond)
SOFTENED = PointSum(softened_term, finish=fraction)
PAIR_FORCE = PairForce(pair_force)
STORED_ENERGY = PointSum(stored_energy_term)


class RNPBond(Material):
    """NLMech's regularized nonlinear bond-based peridynamic material."""

    name = "Regularized Nonlinear Bond"
    Params = RNPBondParams
    row_local = True
    tangent_coupling = "pairs"
    devices = frozenset({"cpu", "gpu"})

    def __init__(self, params: RNPBondParams, *, horizon: float | None, options=None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        if horizon is None:
            raise ValueError(f"{self.name} needs a constant horizon (its constants depend on it); give Horizon as a number")
        dim = params.dimension
        self.C, self.beta, self.K, self.Gc = params.constants()
        vol = horizon_factor(dim, horizon, params.height if dim == 2 else 1.0)
        self.amplitude = influence_coefficient(params.influence, dim)
        x_break = 0.5 * params.sc_factor**2
        self.prm = np.array(
            [4.0 * self.C * self.beta / vol, self.C / vol, self.beta, 1.0 / horizon, float(INFLUENCE_KINDS[params.influence]), self.amplitude, x_break]
        )

    @property
    def density(self) -> float:
        return self.params.density

    @property
    def bulk_modulus(self) -> float:
        return self.K

    def inflection_stretch(self, r: float | np.ndarray) -> float | np.ndarray:
        """s_c(r) = sqrt(1 / (2 beta r)): past it the bond force decreases (r in L)."""
        return np.sqrt(0.5 / (self.beta * np.asarray(r, dtype=float)))

    def elastic_moduli(self) -> ElasticModuli:
        """K and the shear modulus of the fixed Poisson's ratio (small-strain limit); the
        micromodulus c = 4 J C beta / (omega_d delta^(d+1)) for the constant influence function."""
        p = self.params
        c = self.prm[0] * self.amplitude if p.influence == "Constant" else None
        if p.dimension == 2:
            planar = "plane stress" if p.plane_stress else "plane strain"
            return ElasticModuli(self.K, 0.5 * self.K, planar, thickness=p.height, micromodulus=c)
        return ElasticModuli(self.K, 0.6 * self.K, "3d", micromodulus=c)

    def fields(self) -> list[FieldSpec]:
        if self.params.irreversible:
            return [FieldSpec("Bond_Fracture", Relation.BOND, 1, Temporal.TWO_STEP, dtype="uint8")]
        return []

    def output_fields(self) -> list[FieldSpec]:
        """``Softened_Bond_Fraction``: the fraction of a point's bonds stretched past their
        inflection stretch (or broken, with Irreversible Bond Fracture): where the crack runs."""
        return [FieldSpec("Softened_Bond_Fraction", Relation.ELEMENT)]

    def _softened(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        if "Softened_Bond_Fraction" in s:
            args = (self._prm(block), self._fracture(block)[1], nl.offsets)
            law, zeta = reference_lengths(block, SOFTENED)
            compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, s["Softened_Bond_Fraction"])

    def _damage(self, block: BlockView) -> np.ndarray:
        return block.fields["Bond_Damage"] if "Bond_Damage" in block.fields else empty(block)

    def _fracture(self, block: BlockView) -> tuple[np.ndarray, np.ndarray]:
        s = block.fields
        if self.params.irreversible:
            return s.n("Bond_Fracture"), s["Bond_Fracture"]
        none = empty(block, np.uint8)
        return none, none

    def _prm(self, block: BlockView) -> np.ndarray:
        return resident(block, self.prm)

    def force_state(self, block: BlockView, t: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        args = (self._prm(block), self._damage(block), *self._fracture(block))
        law, zeta = reference_lengths(block, FORCE_STATE)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, t)
        self._softened(block)

    def force_fused(self, block: BlockView, force_density: np.ndarray) -> bool:
        s, nl = block.fields, block.bonds
        damage = self._damage(block)
        reverse = nl.reverse() if damage.shape[0] and not block.damage_symmetric else empty(block, EMPTY_INDEX.dtype)
        args = (self._prm(block), damage, reverse, *self._fracture(block), s["Volume"])
        law, zeta = reference_lengths(block, PAIR_FORCE)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, force_density)
        self._softened(block)
        return True

    def stored_energy_density(self, block: BlockView, out: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        args = (self._prm(block), self._damage(block), self._fracture(block)[1], s["Volume"])
        law, zeta = reference_lengths(block, STORED_ENERGY)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, out)
