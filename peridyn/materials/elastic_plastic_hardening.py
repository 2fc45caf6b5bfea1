"""``Elastic Plastic Hardening``: Mitchell's ordinary state-based J2 plasticity with isotropic
hardening, as Peridigm computes it (PERIDIGM_MODELS.md §2).

As ``Elastic Plastic`` (:mod:`peridyn.materials.elastic_plastic`) with a per-point shear
correction factor s (``Surface_Correction_Factor``, 1 without ``Apply Shear Correction Factor``):
alpha = (s 15 mu) / m_i, yield value Y_p = s^2 Y. A step is plastic iff n^2 / 2 > Y_p (the test
ignores hardening); then d lambda is the smallest positive root of Peridigm's cubic
(:func:`peridyn.materials.deviatoric.update_delta_lambda`), i.e. the backward-Euler solution of

    (n / (1 + alpha d lambda))^2 / 2 = Y_p + H (lambda_N + d lambda),

and t^d = t^tr / (1 + alpha d lambda), e^dp_NP1 = e^dp_N + t^d d lambda, lambda_NP1 = lambda_N +
d lambda. H (``Hardening Modulus``) has the units of Y per unit lambda (M^3 L^-13 T^-6).

Shear correction factor (Peridigm's computeShearCorrectionFactor, once at initialize): for each
point, three pure shears of size gamma = 1e-6 (XY, ZX, YZ) centred on it give
S = sum_j omega e^d e^d V_j (global omega, theta' of the mode with per-term division by m); with
S_max the largest, s' = 4 gamma^2 m / S_max / 15 and Peridigm stores **1/s'** (its trap).

Tangent: Peridigm's central finite differences by default (compiled); the exact tangent with
``Apply Automatic Differentiation Jacobian: true``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from pydantic import Field

from ..core.fields import FieldSpec, Relation
from ..core.influence import omega
from ..core.params import UsedWhen
from ..core.interfaces import BlockView
from .deviatoric import HARDENING
from .elastic_plastic import ElasticPlastic, PlasticParams

GAMMA = 1.0e-6  # size of Peridigm's probing shears


class ElasticPlasticHardeningParams(PlasticParams):
    hardening_modulus: float = Field(
        alias="Hardening Modulus", description="H: growth of the yield value per unit plastic multiplier (units of Y / lambda, M^3 L^-13 T^-6)"
    )
    apply_shear_correction_factor: bool = Field(
        True, alias="Apply Shear Correction Factor", description="scale alpha and the yield value by Peridigm's per-point shear correction factor"
    )
    apply_ad_jacobian: bool = Field(
        False, alias="Apply Automatic Differentiation Jacobian", description="implicit solvers: exact tangent (true) or central finite differences (false)"
    )
    rejected_keys = frozenset({"Thermal Expansion Coefficient"})
    model_name = "'Elastic Plastic Hardening'"
    used_when = {"hardening_modulus": UsedWhen(lambda p: not p.disable_plasticity, "plasticity is enabled ('Disable Plasticity' false)", gt=0)}


@njit(cache=True, error_model="numpy")
def _shear_norm(i, mode, offsets, neighbors, x, volume, m_i, omega_kind, delta, omega_table):
    """S = sum_j omega e^d e^d V_j of point i under Peridigm's pure shear ``mode`` (0 XY, 1 ZX,
    2 YZ) of size GAMMA centred on i (y_i = x_i)."""
    theta = 0.0
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        d0 = x[j, 0] - x[i, 0]
        d1 = x[j, 1] - x[i, 1]
        d2 = x[j, 2] - x[i, 2]
        z = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        e = _sheared_length(mode, x, i, j, d0, d1, d2) - z
        w = omega(omega_kind, z, delta, omega_table, b)
        theta += (((((3.0 * w) * 1.0) * z) * e) * volume[j]) / m_i
    acc = 0.0
    for b in range(offsets[i], offsets[i + 1]):
        j = neighbors[b]
        d0 = x[j, 0] - x[i, 0]
        d1 = x[j, 1] - x[i, 1]
        d2 = x[j, 2] - x[i, 2]
        z = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        ed = (_sheared_length(mode, x, i, j, d0, d1, d2) - z) - (theta * z) / 3.0
        w = omega(omega_kind, z, delta, omega_table, b)
        acc += ((ed * w) * ed) * volume[j]
    return acc


@njit(cache=True, inline="always", error_model="numpy")
def _sheared_length(mode, x, i, j, d0, d1, d2):
    """|y_j - x_i| with y_j the sheared position of neighbour j."""
    if mode == 0:
        y0 = (x[j, 0] + GAMMA * d1) + 0.0
        y1 = (x[j, 1] + GAMMA * d0) + 0.0
        y2 = (x[j, 2] + 0.0) + 0.0
    elif mode == 1:
        y0 = (x[j, 0] + GAMMA * d2) + 0.0
        y1 = (x[j, 1] + 0.0) + 0.0
        y2 = (x[j, 2] + GAMMA * d0) + 0.0
    else:
        y0 = (x[j, 0] + 0.0) + 0.0
        y1 = (x[j, 1] + GAMMA * d2) + 0.0
        y2 = (x[j, 2] + GAMMA * d1) + 0.0
    e0 = y0 - x[i, 0]
    e1 = y1 - x[i, 1]
    e2 = y2 - x[i, 2]
    return math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)


@njit(cache=True, parallel=True, error_model="numpy")
def shear_correction_kernel(start, stop, offsets, neighbors, x, volume, m, omega_kind, delta, omega_table, out):
    """out[i] = 1 / s'_i for i in [start, stop) (dimensionless; see module docstring); 1 for a
    point without bonds."""
    for i in prange(start, stop):
        if offsets[i + 1] == offsets[i] or m[i] == 0.0:
            out[i] = 1.0
            continue
        smax = _shear_norm(i, 0, offsets, neighbors, x, volume, m[i], omega_kind, delta, omega_table)
        for mode in (1, 2):
            S = _shear_norm(i, mode, offsets, neighbors, x, volume, m[i], omega_kind, delta, omega_table)
            smax = max(smax, S)
        out[i] = 1.0 / (((((4.0 * GAMMA) * GAMMA) * m[i]) / smax) / 15.0)


class ElasticPlasticHardening(ElasticPlastic):
    """Peridigm's ``Elastic Plastic Hardening`` (ordinary state-based J2, isotropic hardening)."""

    name = "Elastic Plastic Hardening"
    Params = ElasticPlasticHardeningParams
    hardening = True
    _fd_model = HARDENING

    def fields(self) -> list[FieldSpec]:
        return super().fields() + [FieldSpec("Surface_Correction_Factor", Relation.ELEMENT)]

    def initialize(self, block: BlockView) -> None:
        super().initialize(block)
        s, nl = block.fields, block.bonds
        out = s["Surface_Correction_Factor"]
        if not self.params.apply_shear_correction_factor:
            out[block.start : block.stop] = 1.0
            return
        kind, delta, table = self._common(block)
        shear_correction_kernel(
            block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Volume"], s["Weighted_Volume"], kind, delta, table, out
        )

    def _scf(self, block: BlockView) -> np.ndarray:
        return block.fields["Surface_Correction_Factor"]
