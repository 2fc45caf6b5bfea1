"""``Elastic Bond Based``: the prototype microelastic brittle material (bond-based).

Pairwise force density c s along the deformed bond, s = (|eta| - |xi|)/|xi| the stretch and
c the micromodulus (PERIDIGM_SEMANTICS.md §4.3):

    3D:                        c = 18 K / (pi delta^4)        (nu = 1/4)
    Plane Strain/Plane Stress: c = 12 K / (pi h delta^3)      (h = Height; K from E with nu = 1/4
                                                               (strain) or 1/3 (stress))

Each end of a bond carries half: t_ij = c s (1 - d_ij) / 2, so an undamaged pair exerts c s.
Stored energy density (Peridigm outputs 0 here; peridyn defines it so energy balances can be
checked): W_i = sum_j (1 - d_ij) c s^2 |xi| V_j / 4, whose volume integral is the pair potential
sum_pairs c s^2 |xi| V_i V_j / 2.
"""
from __future__ import annotations

import math

import numpy as np
from pydantic import Field, model_validator

from ..core.fields import FieldSpec
from ..core.interfaces import SMALL_STRAIN, BlockView, ElasticModuli, Material
from ..core.params import ModelParams, UsedWhen
from ..core.traversal import BondMap, PairForce, PointSum
from ..kernels import compiled, empty
from ..kernels.lengths import reference_lengths
from .moduli import bulk_and_shear

EMPTY = np.zeros(0)
EMPTY_INDEX = np.zeros(0, dtype=np.int32)  # no reverse lookup: symmetric damage


class ElasticBondBasedParams(ModelParams):
    density: float = Field(alias="Density", gt=0, description="mass density (M/L^3, kg/m^3 in SI)")
    bulk_modulus: float | None = Field(None, alias="Bulk Modulus", gt=0, description="bulk modulus K (Pa in SI); give this or Young's Modulus")
    youngs_modulus: float | None = Field(None, alias="Young's Modulus", gt=0, description="Young's modulus E (Pa in SI); Poisson's ratio is fixed by the model")
    plane_strain: bool = Field(False, alias="Plane Strain", description="2D plane strain (needs Height)")
    plane_stress: bool = Field(False, alias="Plane Stress", description="2D plane stress (needs Height)")
    height: float | None = Field(None, alias="Height", description="thickness of a 2D model (L)")
    finite_difference_probe_length: float | None = Field(
        None, alias="Finite Difference Probe Length", description="accepted for compatibility (this model has an exact tangent; any finite value)"
    )
    ignored_keys = frozenset({"Apply Shear Correction Factor"})
    used_when = {"height": UsedWhen(lambda p: p.plane_strain or p.plane_stress, "the model is 2D ('Plane Strain' or 'Plane Stress')", gt=0)}

    @model_validator(mode="after")
    def _check(self):
        if (self.bulk_modulus is None) == (self.youngs_modulus is None):
            raise ValueError("give exactly one of 'Bulk Modulus' and \"Young's Modulus\" (Poisson's ratio is fixed by the bond-based model)")
        if self.plane_strain and self.plane_stress:
            raise ValueError("'Plane Strain' and 'Plane Stress' cannot both be true")
        if (self.plane_strain or self.plane_stress) and self.height is None:
            raise ValueError("a 2D model ('Plane Strain' or 'Plane Stress') needs 'Height'")
        return self

    @property
    def two_dimensional(self) -> bool:
        return self.plane_strain or self.plane_stress

    def bulk(self) -> float:
        if self.bulk_modulus is not None:
            return self.bulk_modulus
        nu = 1.0 / 3.0 if self.plane_stress else 0.25
        return bulk_and_shear(E=self.youngs_modulus, nu=nu, plane_strain=self.plane_strain, plane_stress=self.plane_stress)[0]


# Loop laws (peridyn.core.traversal); bond context (i, j, b, ex, ey, ez, L, z, p, args) with
# L = |eta|, z = |xi| (L); args (c, d, ...) with d empty without damage.
def force_state_bond(i, j, b, ex, ey, ez, L, z, p, args):
    """t_ij = (1-d) s c / 2 (force per volume^2); args (c, d)."""
    c, bond_damage = args
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    return ((0.5 * keep) * ((L - z) / z)) * c


def pair_force(i, j, b, ex, ey, ez, L, z, p, args):
    """(t_ij + t_ji) V_j; args (c, d, reverse, V): ``reverse`` gives bond j->i (read only with
    damage; empty when both ends have equal damage)."""
    c, bond_damage, reverse, volume = args
    half = (0.5 * ((L - z) / z)) * c
    if bond_damage.shape[0] > 0:
        d_rev = bond_damage[reverse[b]] if reverse.shape[0] > 0 and reverse[b] >= 0 else bond_damage[b]
        t = (1.0 - bond_damage[b]) * half + (1.0 - d_rev) * half
    else:
        t = half + half
    return t * volume[j]


def stored_energy_term(i, j, b, ex, ey, ez, L, z, p, args):
    """(1-d) c s^2 |xi| V_j; args (c, d, V)."""
    c, bond_damage, volume = args
    s = (L - z) / z
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    return keep * c * s * s * z * volume[j]


def quarter(i, acc, p, args):
    """W_i = acc / 4 (energy per volume)."""
    return 0.25 * acc


FORCE_STATE = BondMap(force_state_bond)
PAIR_FORCE = PairForce(pair_force)
STORED_ENERGY = PointSum(stored_energy_term, finish=quarter)


class ElasticBondBased(Material):
    """Prototype microelastic brittle (bond-based) material."""
    small_strain_limit = SMALL_STRAIN  # a linear law

    name = "Elastic Bond Based"
    analytic_tangent = True
    Params = ElasticBondBasedParams
    row_local = True
    bond_energy = "pair"
    devices = frozenset({"cpu", "gpu"})

    def __init__(self, params: ElasticBondBasedParams, *, horizon: float | None, options=None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        self.K = params.bulk()
        if horizon is None:
            raise ValueError("Elastic Bond Based needs a constant horizon (its micromodulus depends on it); give Horizon as a number")
        delta = horizon
        if params.two_dimensional:
            self.c = (12.0 * self.K) / ((((math.pi * params.height) * delta) * delta) * delta)
        else:
            self.c = (18.0 * self.K) / ((((math.pi * delta) * delta) * delta) * delta)

    def finite_difference_probe_length(self) -> float | None:
        return self.params.finite_difference_probe_length

    @property
    def density(self) -> float:
        return self.params.density

    @property
    def bulk_modulus(self) -> float:
        return self.K

    def elastic_moduli(self) -> ElasticModuli:
        """K, the shear modulus of the fixed Poisson's ratio (nu = 1/4 in 3D and plane strain,
        1/3 in plane stress: mu = 3/5 K in 3D, K/2 in 2D), the micromodulus c and the Height."""
        p = self.params
        if p.two_dimensional:
            planar = "plane stress" if p.plane_stress else "plane strain"
            return ElasticModuli(self.K, 0.5 * self.K, planar, thickness=p.height, micromodulus=self.c)
        return ElasticModuli(self.K, 0.6 * self.K, "3d", micromodulus=self.c)

    def fields(self) -> list[FieldSpec]:
        return []

    def _damage(self, block: BlockView) -> np.ndarray:
        return block.fields["Bond_Damage"] if "Bond_Damage" in block.fields else empty(block)

    def force_state(self, block: BlockView, t: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        law, zeta = reference_lengths(block, FORCE_STATE)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], (self.c, self._damage(block)), t)

    def force_fused(self, block: BlockView, force_density: np.ndarray) -> bool:
        s, nl = block.fields, block.bonds
        damage = self._damage(block)
        reverse = nl.reverse() if damage.shape[0] and not block.damage_symmetric else empty(block, EMPTY_INDEX.dtype)
        args = (self.c, damage, reverse, s["Volume"])
        law, zeta = reference_lengths(block, PAIR_FORCE)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, force_density)
        return True

    tangent_coupling = "pairs"

    def tangent(self, block: BlockView, target) -> bool:
        """Analytic d(f V)/dy of the pair forces (peridyn.materials.tangents)."""
        from .tangents import bond_based_tangent_kernel

        s, nl = block.fields, block.bonds
        T = target
        bond_based_tangent_kernel(
            block.start, block.stop, T.nrows, T.nchunks, nl.offsets, nl.neighbors, T.in_offsets, T.in_bonds, T.sources,
            T.eval_rank, s["Bond_Length"], s["Coordinates"], s["Volume"], self.c, self._damage(block), T.row_of_local,
            T.local_of_row, T.indptr, T.indices, T.data, T.max_in,
        )
        return True

    def stored_energy_density(self, block: BlockView, out: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        args = (self.c, self._damage(block), s["Volume"])
        law, zeta = reference_lengths(block, STORED_ENERGY)
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, out)
