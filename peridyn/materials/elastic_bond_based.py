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
from numba import njit, prange
from pydantic import Field, model_validator

from ..core.fields import FieldSpec
from ..core.interfaces import BlockView, ElasticModuli, Material
from ..core.params import ModelParams, UsedWhen
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


@njit(cache=True, parallel=True, error_model="numpy")
def force_state_kernel(start, stop, offsets, neighbors, zeta, y, c, bond_damage, t):
    """t[b] = 0.5 (1-d) s c for the bonds of points [start, stop) (force per volume^2)."""
    has_damage = bond_damage.shape[0] > 0
    for i in prange(start, stop):
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            L0 = zeta[b]
            ex = y[j, 0] - y[i, 0]
            ey = y[j, 1] - y[i, 1]
            ez = y[j, 2] - y[i, 2]
            L = math.sqrt(ex * ex + ey * ey + ez * ez)
            keep = 1.0 - bond_damage[b] if has_damage else 1.0
            t[b] = ((0.5 * keep) * ((L - L0) / L0)) * c


@njit(cache=True, parallel=True, error_model="numpy")
def fused_force_kernel(start, stop, offsets, neighbors, reverse, zeta, y, volume, c, bond_damage, f):
    """f_i = sum_j (t_ij + t_ji) eta/|eta| V_j for points [start, stop) of a closed block."""
    has_damage = bond_damage.shape[0] > 0
    for i in prange(start, stop):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            L0 = zeta[b]
            ex = y[j, 0] - y[i, 0]
            ey = y[j, 1] - y[i, 1]
            ez = y[j, 2] - y[i, 2]
            L = math.sqrt(ex * ex + ey * ey + ez * ez)
            half = (0.5 * ((L - L0) / L0)) * c
            if has_damage:
                d_rev = bond_damage[reverse[b]] if reverse.shape[0] > 0 and reverse[b] >= 0 else bond_damage[b]
                t = (1.0 - bond_damage[b]) * half + (1.0 - d_rev) * half
            else:
                t = half + half
            if L > 0.0:
                s = (t * volume[j]) / L
                fx += s * ex
                fy += s * ey
                fz += s * ez
        f[i, 0] = fx
        f[i, 1] = fy
        f[i, 2] = fz


@njit(cache=True, parallel=True, error_model="numpy")
def stored_energy_kernel(start, stop, offsets, neighbors, zeta, y, volume, c, bond_damage, W):
    """W_i = sum_j (1-d) c s^2 |xi| V_j / 4 (energy per volume)."""
    has_damage = bond_damage.shape[0] > 0
    for i in prange(start, stop):
        acc = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            L0 = zeta[b]
            ex = y[j, 0] - y[i, 0]
            ey = y[j, 1] - y[i, 1]
            ez = y[j, 2] - y[i, 2]
            s = (math.sqrt(ex * ex + ey * ey + ez * ez) - L0) / L0
            keep = 1.0 - bond_damage[b] if has_damage else 1.0
            acc += keep * c * s * s * L0 * volume[j]
        W[i] = 0.25 * acc


class ElasticBondBased(Material):
    """Prototype microelastic brittle (bond-based) material."""

    name = "Elastic Bond Based"
    Params = ElasticBondBasedParams
    row_local = True
    bond_energy = "pair"

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
        return block.fields["Bond_Damage"] if "Bond_Damage" in block.fields else EMPTY

    def force_state(self, block: BlockView, t: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        force_state_kernel(block.start, block.stop, nl.offsets, nl.neighbors, s["Bond_Length"], s["Coordinates"], self.c, self._damage(block), t)

    def force_fused(self, block: BlockView, force_density: np.ndarray) -> bool:
        s, nl = block.fields, block.bonds
        damage = self._damage(block)
        reverse = nl.reverse() if damage.shape[0] and not block.damage_symmetric else EMPTY_INDEX
        fused_force_kernel(
            block.start, block.stop, nl.offsets, nl.neighbors, reverse, s["Bond_Length"], s["Coordinates"], s["Volume"], self.c, damage, force_density
        )
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
        stored_energy_kernel(block.start, block.stop, nl.offsets, nl.neighbors, s["Bond_Length"], s["Coordinates"], s["Volume"], self.c, self._damage(block), out)
