"""``Critical Stretch`` and ``Time Dependent Critical Stretch`` damage (PERIDIGM_SEMANTICS.md
§5.2, §5.3).

A bond breaks for good when its stretch s = (|eta| - |xi|)/|xi| (minus the thermal strain
a_T dT_i of the owner point, when the model has a thermal expansion coefficient) exceeds the
critical stretch, strictly, in tension only. Each end of a bond decides for itself (i's copy with
i's temperature change). ``Damage`` of a point is its broken-bond count over its neighbor count.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from pydantic import Field, field_validator

from ..core.bondmath import stretch_exceeds
from ..core.fields import FieldSpec, Relation
from ..core.interfaces import BlockView, DamageModel
from ..core.params import ModelParams

EMPTY = np.zeros(0)


@njit(cache=True, parallel=True, error_model="numpy")
def critical_stretch_kernel(start, stop, offsets, neighbors, zeta, y, s_c, d_n, d_np1, copy_previous, dT, alpha_T, damage):
    """Update bond damage d_np1 (from d_n when ``copy_previous``) and the point damage of
    points [start, stop). Shapes: zeta (nb,) reference bond lengths; y (n, 3); d_n, d_np1 (nb,);
    damage (n,); dT (n,) or empty."""
    thermal = dT.shape[0] > 0
    for i in prange(start, stop):
        acc = 0.0
        lo = offsets[i]
        hi = offsets[i + 1]
        for b in range(lo, hi):
            d = float(d_n[b]) if copy_previous else float(d_np1[b])
            if d >= 1.0:  # broken for good: nothing to compute
                d_np1[b] = d
                acc += d
                continue
            j = neighbors[b]
            L0 = zeta[b]
            c0 = y[i, 0] - y[j, 0]
            c1 = y[i, 1] - y[j, 1]
            c2 = y[i, 2] - y[j, 2]
            L2 = c0 * c0 + c1 * c1 + c2 * c2
            if thermal:
                L = math.sqrt(L2) - (alpha_T * dT[i]) * L0
                trial = 1.0 if (L - L0) / L0 > s_c else 0.0
            else:
                trial = 1.0 if stretch_exceeds(L2, L0, s_c) else 0.0
            d = trial if trial > d else d
            d_np1[b] = d
            acc += d
        damage[i] = acc / (hi - lo) if hi > lo else 0.0


class CriticalStretchParams(ModelParams):
    critical_stretch: float = Field(alias="Critical Stretch", gt=0, description="stretch (dimensionless) above which a bond breaks")
    thermal_expansion_coefficient: float | None = Field(
        None, alias="Thermal Expansion Coefficient", description="subtracts a_T dT from the stretch (1/temperature); independent of the material's"
    )


class CriticalStretch(DamageModel):
    name = "Critical Stretch"
    Params = CriticalStretchParams
    bond_damage_dtype = "uint8"  # bonds are whole or broken: one byte per bond
    row_local = True
    #: copy bond damage N into NP1 before each update (Peridigm's intent; see the time-dependent variant)
    copy_previous = True

    def __init__(self, params, *, options=None) -> None:
        super().__init__(params, options=options)
        self.s_c = float(getattr(params, "critical_stretch", 0.0))
        self.alpha_T = params.thermal_expansion_coefficient

    @property
    def symmetric(self) -> bool:
        # the stretch of i->j and j->i is computed from bitwise equal lengths; only the
        # owner's temperature change can differ
        return self.alpha_T is None

    def bond_rule(self):
        """("critical stretch", s_c, copy N into NP1): lets a material apply this model inside
        its own bond loop (one pass instead of two); None where it cannot (thermal strain)."""
        if self.alpha_T is not None:
            return None
        return ("critical stretch", self.s_c, self.copy_previous)

    def fields(self) -> list[FieldSpec]:
        specs = super().fields()
        if self.alpha_T is not None:
            specs += [FieldSpec("Temperature", Relation.NODE), FieldSpec("Temperature_Change", Relation.NODE, halo=True)]
        return specs

    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        lo, hi = nl.offsets[block.start], nl.offsets[block.stop]
        s["Bond_Damage"][lo:hi] = 0.0
        s["Damage"][block.start : block.stop] = 0.0

    def update(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        dT = s["Temperature_Change"] if self.alpha_T is not None else EMPTY
        critical_stretch_kernel(
            block.start, block.stop, nl.offsets, nl.neighbors, s["Bond_Length"], s["Coordinates"], self.s_c,
            s.n("Bond_Damage"), s["Bond_Damage"], self.copy_previous, dT, float(self.alpha_T or 0.0), s["Damage"],
        )


class TimeDependentCriticalStretchParams(ModelParams):
    time_dependent_critical_stretch: str | float = Field(
        alias="Time Dependent Critical Stretch", description="critical stretch as an expression of t (time)"
    )

    @field_validator("time_dependent_critical_stretch")
    @classmethod
    def _compiles(cls, v):
        from ..deck.expressions import compile_expression

        compile_expression(repr(v) if isinstance(v, float) else v, ("t",))  # ExpressionError is a ValueError
        return v
    thermal_expansion_coefficient: float | None = Field(None, alias="Thermal Expansion Coefficient", description="as for Critical Stretch")


class TimeDependentCriticalStretch(CriticalStretch):
    """Critical stretch s_c = f(t), re-evaluated at the start of every explicit step (Peridigm
    re-creates damage models there; implicit solvers keep f(0)).

    Peridigm's N -> NP1 copy is a no-op for this model (a defect: trial configurations of an
    implicit step leave broken bonds behind, and explicit damage alternates between two
    buffers). No reference result depends on it, so peridyn copies N into NP1 as for Critical
    Stretch (docs/peridigm-differences.md).
    """

    name = "Time Dependent Critical Stretch"
    Params = TimeDependentCriticalStretchParams

    def __init__(self, params, *, options=None) -> None:
        super().__init__(params, options=options)
        from ..deck.expressions import compile_expression

        value = params.time_dependent_critical_stretch
        self.expr = compile_expression(repr(value) if isinstance(value, float) else value, ("t",))
        self.s_c = float(self.expr(t=0.0))

    def begin_step(self, block: BlockView, time: float) -> None:
        self.s_c = float(self.expr(t=time))
