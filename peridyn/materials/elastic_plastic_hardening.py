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
from numba import njit
from pydantic import Field

from ..core.fields import FieldSpec, Relation
from ..core.influence import omega
from ..core.params import UsedWhen
from ..core.interfaces import BlockView
from ..core.traversal import PointSum
from ..kernels import compiled, default_backend
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

    def hardening_slope(self) -> float:
        return self.hardening_modulus

    def finite_difference_tangent(self) -> bool:
        return not self.apply_ad_jacobian


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


# Loop laws (peridyn.core.traversal) of the shear correction factor, run on the reference
# positions (y = x, so (ex, ey, ez) = x_j - x_i and L = |xi| computed from x; z is not read).
# args (x, V, m, omega_kind, delta, omega_table, mode, theta, S_0, S_1, offsets): x (n, 3) L,
# V (n,) L^3, m (n,) L^5, mode 0 XY, 1 ZX, 2 YZ, theta (n,) the mode's dilatation, S_0 and S_1
# (n,) the norms of modes 0 and 1 (L^5), offsets (n+1,).
def shear_theta_term(i, j, b, ex, ey, ez, L, z, p, args):
    """3 omega zeta e V_j / m_i of bond i->j under the pure shear ``mode`` of size GAMMA centred
    on i (Peridigm divides each term by m)."""
    x, volume, m, omega_kind, delta, omega_table, mode = args[0], args[1], args[2], args[3], args[4], args[5], args[6]
    e = _sheared_length(mode, x, i, j, ex, ey, ez) - L
    w = omega(omega_kind, L, delta, omega_table, b)
    return (((((3.0 * w) * 1.0) * L) * e) * volume[j]) / m[i]


def shear_theta_point(i, args):
    """theta_i of the mode (args[7])."""
    return args[7][i]


def shear_norm_term(i, j, b, ex, ey, ez, L, z, theta, args):
    """omega e^d e^d V_j (L^5) of bond i->j under the shear ``mode``, e^d = e - theta zeta / 3."""
    x, volume, omega_kind, delta, omega_table, mode = args[0], args[1], args[3], args[4], args[5], args[6]
    ed = (_sheared_length(mode, x, i, j, ex, ey, ez) - L) - (theta * L) / 3.0
    w = omega(omega_kind, L, delta, omega_table, b)
    return ((ed * w) * ed) * volume[j]


def shear_correction_finish(i, S_2, theta, args):
    """1 / s'_i with S_max the largest norm of the three modes (the last one S_2 here); 1 for a
    point without bonds or weighted volume."""
    m, S_0, S_1, offsets = args[2], args[8], args[9], args[10]
    if offsets[i + 1] == offsets[i] or m[i] == 0.0:
        return 1.0
    smax = S_0[i]
    smax = max(smax, S_1[i])
    smax = max(smax, S_2)
    return 1.0 / (((((4.0 * GAMMA) * GAMMA) * m[i]) / smax) / 15.0)


#: theta (n,) of a mode
SHEAR_THETA = PointSum(shear_theta_term)
#: S (n,) of a mode
SHEAR_NORM = PointSum(shear_norm_term, point=shear_theta_point)
#: 1 / s' (n,), with the last mode's S
SHEAR_CORRECTION = PointSum(shear_norm_term, point=shear_theta_point, finish=shear_correction_finish)


def shear_correction(kernel, start, stop, offsets, neighbors, zeta, x, volume, m, omega_kind, delta, omega_table, out):
    """out[i] = 1 / s'_i for i in [start, stop) (dimensionless; see module docstring); 1 for a
    point without bonds. ``kernel(law)`` gives a law's loop (``lambda law: compiled(block, law)``);
    zeta (nb,) is the prelude's bond length, not read by the laws; x (n, 3) reference positions
    (L); volume (n,) L^3; m (n,) L^5. Six passes: for each mode its dilatation, then its norm."""
    n = x.shape[0]
    theta = np.zeros(n)
    S = (np.zeros(n), np.zeros(n))
    for mode in range(3):
        args = (x, volume, m, omega_kind, delta, omega_table, mode, theta, S[0], S[1], offsets)
        kernel(SHEAR_THETA)(start, stop, offsets, neighbors, zeta, x, args, theta)
        law, dest = (SHEAR_NORM, S[mode]) if mode < 2 else (SHEAR_CORRECTION, out)
        kernel(law)(start, stop, offsets, neighbors, zeta, x, args, dest)


def shear_correction_kernel(start, stop, offsets, neighbors, x, volume, m, omega_kind, delta, omega_table, out):
    """:func:`shear_correction` on the default backend, for callers without a view (the
    signature of the former hand-written kernel)."""
    shear_correction(default_backend().kernel, start, stop, offsets, neighbors, np.zeros(neighbors.shape[0]), x, volume, m, omega_kind, delta, omega_table, out)


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
        shear_correction(
            lambda law: compiled(block, law), block.start, block.stop, nl.offsets, nl.neighbors, s["Bond_Length"], s["Model_Coordinates"],
            s["Volume"], s["Weighted_Volume"], kind, delta, table, out,
        )

    def _scf(self, block: BlockView) -> np.ndarray:
        return block.fields["Surface_Correction_Factor"]
