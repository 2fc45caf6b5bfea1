"""``Viscoelastic``: a standard linear solid on the deviatoric extension state, as Peridigm
computes it (PERIDIGM_MODELS.md §3).

A fraction lambda_i of the shear response relaxes with time constant tau_b through a back
extension state e^b (bond, two-step); the dilatational response is elastic. Per evaluation over a
step dt (Verlet dt, the load-step increment in QuasiStatic), with decay = exp(-dt / tau_b) and
beta = 1 - (tau_b / dt)(1 - decay), for the bond i->j (omega = 1 in the force; m and theta use
the deck's influence function; D = 1 - d with the NP1 bond damage for both time levels):

    e^d_N   = D (|eta_N| - zeta) - theta_N zeta / 3,   e^d_NP1 = D (|eta| - zeta) - theta zeta / 3
    e^b_NP1 = (e^d_N (1 - decay) + e^b_N decay) + beta (e^d_NP1 - e^d_N)
    t^d     = (1 - lambda_i) alpha e^d_NP1 + lambda_i alpha (e^d_NP1 - e^b_NP1)
    t       = D (c zeta + t^d),        alpha = 15 mu / m, c = 3 K theta / m.

The e^b update integrates de^b/dt = (e^d - e^b)/tau_b exactly for e^d linear in time over the
step. |eta_N| - zeta (Peridigm reads it from Coordinates N) is kept per bond in the two-step
field ``Viscoelastic_Bond_Extension`` (written at every evaluation, so after the end-of-step swap
its N value is the extension at the previous step's positions; zero at start-up, as Peridigm's
Coordinates N = x). theta_N is the Dilatation N buffer. An evaluation outside a time step
(dt = 0) uses the limit decay = 1, beta = 0 (no time passes). Tangent: Peridigm's central
finite differences only (compiled).
"""
from __future__ import annotations

import numpy as np
from pydantic import Field

from ..core.fields import FieldSpec, Relation, Temporal
from ..core.interfaces import SMALL_STRAIN, BlockView
from ..kernels import compiled
from ..kernels.lengths import compiled_with_lengths
from .deviatoric import (
    VISCO,
    VISCO_FORCE_STATE,
    VISCO_PAIR_FORCE,
    DeviatoricParams,
    DeviatoricStateMaterial,
    relaxation_constants,
)


class ViscoelasticParams(DeviatoricParams):
    lambda_i: float = Field(alias="lambda_i", ge=0.0, le=1.0, description="fraction of the shear modulus that relaxes (dimensionless, 0 to 1)")
    tau_b: float = Field(alias="tau b", gt=0, description="relaxation time tau_b of the back extension (T)")
    rejected_keys = frozenset({"Apply Automatic Differentiation Jacobian", "Apply Shear Correction Factor", "Thermal Expansion Coefficient"})
    model_name = "'Viscoelastic'"


class Viscoelastic(DeviatoricStateMaterial):
    """Peridigm's ``Viscoelastic`` (standard linear solid on the deviatoric extension)."""
    small_strain_limit = SMALL_STRAIN  # a linear law

    name = "Viscoelastic"
    Params = ViscoelasticParams
    needs_horizon = False

    def fields(self) -> list[FieldSpec]:
        return super().fields() + [
            FieldSpec("Deviatoric_Back_Extension", Relation.BOND, 1, Temporal.TWO_STEP, units="L"),
            FieldSpec("Viscoelastic_Bond_Extension", Relation.BOND, 1, Temporal.TWO_STEP, units="L"),
        ]

    def _constants(self, block: BlockView) -> tuple[float, float]:
        return relaxation_constants(float(self.params.tau_b), float(block.time_step))

    def _args(self, block: BlockView) -> tuple:
        """The laws' args (m, theta_N, theta, K, mu, lambda_i, decay, beta, d, extension_N,
        e^b_N, extension_NP1, e^b_NP1)."""
        s = block.fields
        decay, beta = self._constants(block)
        return (
            s["Weighted_Volume"], s.n("Dilatation"), s["Dilatation"], self.K, self.mu, float(self.params.lambda_i), decay, beta, self._damage(block),
            s.n("Viscoelastic_Bond_Extension"), s.n("Deviatoric_Back_Extension"), s["Viscoelastic_Bond_Extension"], s["Deviatoric_Back_Extension"],
        )

    def force_state(self, block: BlockView, t: np.ndarray) -> None:
        """t (nb,) of the view's bonds (M L^-5 T^-2), their new back extension and extension."""
        s, nl = block.fields, block.bonds
        compiled_with_lengths(block, VISCO_FORCE_STATE)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], self._args(block), t)

    def force_fused(self, block: BlockView, force_density: np.ndarray) -> bool:
        """Both ends of every bond in one pass (no force-state array, no gather)."""
        reverse = self._reverse(block)
        if reverse is None:
            return False
        s, nl = block.fields, block.bonds
        zeta = s["Bond_Length"]
        args = self._args(block) + (zeta, s["Volume"], reverse)
        compiled(block, VISCO_PAIR_FORCE)(block.start, block.stop, nl.offsets, nl.neighbors, zeta, s["Coordinates"], args, force_density)
        return True

    def tangent(self, block: BlockView, target) -> bool:
        """Peridigm's central finite differences (compiled; the state is not written)."""
        s = block.fields
        decay, beta = self._constants(block)
        prm = np.array([float(self.params.lambda_i), decay, beta])
        from .deviatoric_tangents import fd_tangent as _fd_tangent

        return _fd_tangent(
            self, block, target, VISCO, prm, np.zeros(0), s.n("Viscoelastic_Bond_Extension"), s.n("Deviatoric_Back_Extension"), s.n("Dilatation")
        )
