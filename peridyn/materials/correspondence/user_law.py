"""``Stress Law Correspondence``: the classic correspondence material with the stress given by a
user's numba function, the Python counterpart of the Abaqus UMAT that PeriLab accepts. The plugin
author writes only the law:

    @numba.njit
    def law(F_old, F_new, state, dt, params):  # (3, 3), (3, 3), (9,), float, (p,)
        ...
        return sigma, new_state                 # Cauchy stress (3, 3) at F_new, (9,)

``F_old`` is the deformation gradient at the end of the last step, ``F_new`` the current one,
``state`` the law's own variables at the end of the last step (9 numbers, zero at the start),
``dt`` the step (T) and ``params`` the deck's ``Law Parameters``. The deck names the law as
``module:function`` (``Stress Law``); :mod:`peridyn.materials.correspondence.laws` has a
compressible Neo-Hookean one. The engine keeps F and the state as two-step fields (an implicit
solver's iterations see the last converged step's), rotates the returned Cauchy stress into the
family's unrotated frame (R^-1 sigma R^-T, R the family's rotation tensor, so that the forces use the law's
stress exactly) and builds the forces as the
other classic correspondence materials do (hourglass control included). The deck's two elastic
constants are the law's small-strain ones: they set the time step estimate and the hourglass
force.
"""
from __future__ import annotations

from typing import Any, Callable, ClassVar

import numpy as np
from numba import njit, prange
from pydantic import Field, field_validator, model_validator

from ...core.fields import FieldSpec, Length, Relation, Temporal
from .classic import ClassicCorrespondence
from .law_check import STATE_SIZE, LawError, check_law, load_law
from . import params as P

__all__ = ["STATE_SIZE", "LawError", "StressLawCorrespondence", "StressLawParams", "check_law", "law_kernel", "load_law"]

class StressLawParams(P.ClassicParams):
    stress_law: str = Field(alias="Stress Law", description="the law as module:function, a numba function "
                            "(F_old, F_new, state, dt, params) -> (Cauchy stress (3, 3), state (9,))")
    law_parameters: list[float] = Field(default_factory=list, alias="Law Parameters",
                                        description="the numbers the law reads as params, in its own units")

    @field_validator("stress_law")
    @classmethod
    def _loadable(cls, value: str) -> str:
        load_law(value)
        return value

    @field_validator("law_parameters")
    @classmethod
    def _finite(cls, value: list[float]) -> list[float]:
        bad = [v for v in value if not np.isfinite(v)]
        if bad:
            raise ValueError(f"Law Parameters must be finite numbers, got {bad[0]!r}")
        return value

    @model_validator(mode="after")
    def _callable(self) -> "StressLawParams":
        """The law called at F = I and a small strain: a (3, 3) stress and at most 9 state
        variables (the point loop writes them into the 9 columns of Stress_Law_State), finite."""
        try:
            check_law(self.stress_law, self.law_parameters)
        except LawError as exc:
            raise LawError(exc.message, exc.fix, key="Stress Law") from None
        return self


_KERNELS: dict[Any, Callable[..., Any]] = {}


def law_kernel(law: Callable[..., Any]) -> Callable[..., Any]:
    """The point loop calling ``law`` (compiled once per law and process): for each point, the
    unrotated stress R^-1 sigma R^-T of the law's Cauchy stress sigma (R^T sigma R when R is a
    rotation; the family's rate-integrated R drifts from one over large rotations in few steps,
    and the inverse makes the family's R sigma_hat R^T give back exactly the law's sigma), and
    the law's new state."""
    kernel = _KERNELS.get(law)
    if kernel is not None:
        return kernel

    @njit(parallel=True)
    def kernel(lo, hi, F_N, F_NP1, R, state_N, state_NP1, dt, params, sigma_hat):
        for i in prange(lo, hi):
            sig, st = law(F_N[i].reshape(3, 3), F_NP1[i].reshape(3, 3), state_N[i], dt, params)
            ri = np.linalg.inv(R[i].reshape(3, 3))
            out = ri @ sig @ ri.T
            for a in range(3):
                for b in range(3):
                    sigma_hat[i, 3 * a + b] = out[a, b]
            for k in range(st.shape[0]):
                state_NP1[i, k] = st[k]

    _KERNELS[law] = kernel
    return kernel


class StressLawCorrespondence(ClassicCorrespondence):
    name = "Stress Law Correspondence"
    Params: ClassVar[type] = StressLawParams

    def __init__(self, params, *, horizon: float | None, options: dict[str, Any] | None = None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        self.law = load_law(params.stress_law)
        self.law_params = np.asarray(params.law_parameters, dtype=np.float64)

    def fields(self) -> list[FieldSpec]:
        return super().fields() + [
            FieldSpec("Stress_Law_Deformation_Gradient", Relation.ELEMENT, Length.TENSOR, Temporal.TWO_STEP),
            FieldSpec("Stress_Law_State", Relation.ELEMENT, Length.TENSOR, Temporal.TWO_STEP),
        ]

    def initialize(self, block) -> None:
        super().initialize(block)
        s, lo, hi = block.fields, block.start, block.stop
        s.n("Stress_Law_Deformation_Gradient")[lo:hi] = np.eye(3).ravel()
        s.np1("Stress_Law_Deformation_Gradient")[lo:hi] = np.eye(3).ravel()
        s.n("Stress_Law_State")[lo:hi] = 0.0
        s.np1("Stress_Law_State")[lo:hi] = 0.0

    def _update_stress(self, block, d: np.ndarray) -> None:
        s, lo, hi = block.fields, block.start, block.stop
        F = s.np1("Stress_Law_Deformation_Gradient")
        F[lo:hi] = s["Deformation_Gradient"][lo:hi]
        law_kernel(self.law)(lo, hi, s.n("Stress_Law_Deformation_Gradient"), F, s.np1("Rotation_Tensor"), s.n("Stress_Law_State"),
                             s.np1("Stress_Law_State"), float(block.time_step), self.law_params, s.np1("Unrotated_Cauchy_Stress"))

    def tangent(self, block, target) -> bool:
        return False  # the solvers' own finite-difference tangent (the compiled one knows Peridigm's laws only)
