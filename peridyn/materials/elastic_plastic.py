"""``Elastic Plastic``: Mitchell's ordinary state-based perfectly plastic J2 model, as Peridigm
computes it (PERIDIGM_MODELS.md §1).

Per evaluation, for point i (kernels in :mod:`peridyn.materials.deviatoric`): theta_i with the
deck's influence function and the NP1 bond damage d; alpha = 15 mu / m_i, c = 3 K theta_i / m_i;
the trial deviatoric force state t^tr = alpha (e^d - e^dp_N) with omega = 1, its norm
n = (sum_j ((1-d) t^tr)^2 V_j)^(1/2) (damage once); plastic iff n^2 / 2 > Y with the yield value
Y = 25 sigma_y^2 / (8 pi delta^5) (planar: 75 sigma_y^2 / (8 pi T delta^4)); then
d lambda = (n / sqrt(2Y) - 1) / alpha, t^d = sqrt(2Y) t^tr / n and e^dp_NP1 = e^dp_N + t^d d lambda;
else t^d = t^tr. The force state is t = (1-d)(c zeta + (1-d) t^d).

Outputs: ``Lambda`` (element, the accumulated plastic multiplier, in the units of 1/alpha: L^6 T^2 M^-1)
and ``Dilatation``. The bond state ``Deviatoric_Plastic_Extension`` (L) is kept but, being a bond
field, cannot be written. No stored energy (Peridigm defines none). ``Disable Plasticity`` makes
Y infinite, so the yield test is never true.

Tangent: the exact Jacobian of this force (return map differentiated as coded, like Peridigm's
default AD tangent), or with ``Apply Automatic Differentiation Jacobian: false`` Peridigm's
central finite differences (both compiled).
"""
from __future__ import annotations

import math

import numpy as np
from pydantic import Field, model_validator

from ..core.fields import FieldSpec, Relation, Temporal
from ..core.params import UsedWhen
from ..core.interfaces import BlockView
from ..kernels import compiled
from ..kernels.lengths import compiled_with_lengths
from .deviatoric import (
    EMPTY,
    PERFECT,
    PLASTIC_FORCE_STATE,
    PLASTIC_PAIR_FORCE,
    PLASTIC_POINTS,
    DeviatoricParams,
    DeviatoricStateMaterial,
    yield_value,
)


class PlasticParams(DeviatoricParams):
    """What both plastic models read."""

    yield_stress: float = Field(alias="Yield Stress", description="uniaxial yield stress sigma_y (M/(L T^2), Pa in SI); > 0 unless 'Disable Plasticity'")
    disable_plasticity: bool = Field(False, alias="Disable Plasticity", description="true: purely elastic (the yield value becomes infinite)")
    #: with plasticity disabled Peridigm sets sigma_y to DBL_MAX and never reads the deck's value
    used_when = {"yield_stress": UsedWhen(lambda p: not p.disable_plasticity, "plasticity is enabled ('Disable Plasticity' false)", gt=0)}

    def planar_thickness(self) -> float | None:
        """The plate thickness (L) of a planar problem's 2-D yield value; None in 3-D."""
        return None

    def hardening_slope(self) -> float:
        """H, the growth of the yield value per unit plastic multiplier; 1 (never read) for perfect plasticity."""
        return 1.0


class ElasticPlasticParams(PlasticParams):
    apply_ad_jacobian: bool = Field(
        True, alias="Apply Automatic Differentiation Jacobian", description="implicit solvers: exact tangent (true) or central finite differences (false)"
    )
    planar_problem: bool = Field(False, alias="Planar Problem", description="2-D yield value (needs 'Thickness'); m and theta keep their 3-D sums")
    thickness: float | None = Field(None, alias="Thickness", description="plate thickness T of a planar problem (L)")
    used_when = {"thickness": UsedWhen(lambda p: p.planar_problem, "'Planar Problem' is true", gt=0)}
    ignored_keys = frozenset({"Apply Shear Correction Factor"})  # Peridigm does not read it here
    rejected_keys = frozenset({"Thermal Expansion Coefficient"})
    model_name = "'Elastic Plastic'"

    @model_validator(mode="after")
    def _planar(self):
        if self.planar_problem and self.thickness is None:
            raise ValueError("'Planar Problem' needs 'Thickness' (the plate thickness)")
        return self

    def planar_thickness(self) -> float | None:
        return self.thickness if self.planar_problem else None

    def finite_difference_tangent(self) -> bool:
        return not self.apply_ad_jacobian


def ep_yield_value(params: PlasticParams, horizon: float) -> float:
    """Y of the deck (inf with ``Disable Plasticity``)."""
    if params.disable_plasticity:
        return math.inf
    return yield_value(params.yield_stress, horizon, params.planar_thickness())


class ElasticPlastic(DeviatoricStateMaterial):
    """Peridigm's ``Elastic Plastic`` (ordinary state-based perfect plasticity)."""

    name = "Elastic Plastic"
    analytic_tangent = True
    Params = ElasticPlasticParams
    hardening = False

    def __init__(self, params: PlasticParams, *, horizon: float | None, options=None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        self.Y = ep_yield_value(params, float(horizon))
        self._pp: np.ndarray | None = None  # return-map data of the force paths, (n_local, 6)
        self.H = float(params.hardening_slope())

    def fields(self) -> list[FieldSpec]:
        return super().fields() + [
            FieldSpec("Deviatoric_Plastic_Extension", Relation.BOND, 1, Temporal.TWO_STEP, units="L"),
            FieldSpec("Lambda", Relation.ELEMENT, 1, Temporal.TWO_STEP),
        ]

    def _scf(self, block: BlockView) -> np.ndarray:
        return EMPTY

    def _return_map(self, block: BlockView) -> np.ndarray:
        """First pass (``PLASTIC_POINTS``): lambda_NP1 of the view's points written, and their
        return-map data pp (n, 6) (alpha, c, n, d lambda, plastic, sqrt(2 Y_p)) returned."""
        s, nl = block.fields, block.bonds
        if self._pp is None or self._pp.shape[0] != s.num_points:
            self._pp = np.zeros((s.num_points, 6))
        args = (
            s["Volume"], s["Weighted_Volume"], s["Dilatation"], self.K, self.mu, self._scf(block), self.Y, self.H, self.hardening,
            self._damage(block), s.n("Deviatoric_Plastic_Extension"), s.n("Lambda"), self._pp,
        )
        compiled_with_lengths(block, PLASTIC_POINTS)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], args, s["Lambda"])
        return self._pp

    def force_state(self, block: BlockView, t: np.ndarray) -> None:
        """t (nb,) of the view's bonds (M L^-5 T^-2) and their e^dp_NP1, after the return map."""
        s, nl = block.fields, block.bonds
        pp = self._return_map(block)
        args = (s["Dilatation"], pp, self.hardening, self._damage(block), s.n("Deviatoric_Plastic_Extension"), s["Deviatoric_Plastic_Extension"])
        compiled_with_lengths(block, PLASTIC_FORCE_STATE)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], args, t)

    def force_fused(self, block: BlockView, force_density: np.ndarray) -> bool:
        """Both ends of every bond in one pass (no force-state array, no gather), after the pass
        that gives every point its return-map data."""
        reverse = self._reverse(block)
        if reverse is None:
            return False
        s, nl = block.fields, block.bonds
        pp = self._return_map(block)
        zeta = s["Bond_Length"]
        args = (
            s["Dilatation"], pp, self.hardening, self._damage(block), s.n("Deviatoric_Plastic_Extension"), s["Deviatoric_Plastic_Extension"],
            zeta, s["Volume"], reverse,
        )
        compiled(block, PLASTIC_PAIR_FORCE)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, force_density)
        return True

    def tangent(self, block: BlockView, target) -> bool:
        """Exact tangent by default, finite differences with ``Apply Automatic Differentiation
        Jacobian: false``; neither writes the plastic state."""
        s, nl = block.fields, block.bonds
        edp_n, lam_n = s.n("Deviatoric_Plastic_Extension"), s.n("Lambda")
        if not self.params.apply_ad_jacobian:
            prm = np.array([self.Y, self.H])
            from .deviatoric_tangents import fd_tangent as _fd_tangent

            return _fd_tangent(self, block, target, self._fd_model, prm, self._scf(block), edp_n, edp_n, lam_n)
        from .deviatoric_tangents import plastic_tangent_kernel

        kind, delta, table = self._common(block)
        T = target
        plastic_tangent_kernel(
            self._points(block, target), nl.offsets, nl.neighbors, s["Bond_Length"], s["Coordinates"], s["Volume"], s["Weighted_Volume"],
            kind, delta, table, self._damage(block), self.K, self.mu, self._scf(block), self.Y, self.H, self.hardening, edp_n, lam_n,
            T.row_of_local, T.nrows, T.indptr, T.indices, T.data, max(self._max_degree(block), 1), self._batch(block),
        )
        return True

    _fd_model = PERFECT
