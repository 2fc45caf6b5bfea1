"""``Critical Stretch`` and ``Time Dependent Critical Stretch`` damage (PERIDIGM_SEMANTICS.md
§5.2, §5.3).

A bond breaks for good when its stretch s = (|eta| - |xi|)/|xi| (minus the thermal strain
a_T dT_i of the owner point, when the model has a thermal expansion coefficient) exceeds the
critical stretch, strictly, in tension only. Each end of a bond decides for itself (i's copy with
i's temperature change). ``Damage`` of a point is its broken-bond count over its neighbor count.
"""
from __future__ import annotations


import numpy as np
from pydantic import Field, field_validator

from ..core.bondmath import damage_sum, stretch_exceeds
from ..core.fields import FieldSpec, Relation
from ..core.interfaces import BlockView, DamageModel
from ..core.params import ModelParams
from ..core.traversal import PointSum
from ..kernels import empty
from ..kernels.lengths import compiled_with_lengths

EMPTY = np.zeros(0)


# Loop law (peridyn.core.traversal); args (s_c, d_n, d_np1, copy_previous, dT, a_T, damage, offsets):
# d_n, d_np1 (nb,) bond damage; dT (n,) or empty; damage (n,) written.
def previous_damage(args, b):
    """The bond's damage before this update: N when copying N into NP1, else NP1."""
    return float(args[1][b]) if args[3] else float(args[2][b])


def broken_gate(i, b, p, args):
    """A bond broken for good keeps d = 1 and is skipped."""
    d = previous_damage(args, b)
    if d >= 1.0:
        args[2][b] = d
        return False
    return True


def stretch_damage_term(i, j, b, ex, ey, ez, L, z, p, args):
    """d_np1 = max(d, s > s_c) (written and returned), s the stretch less the owner's thermal
    strain a_T dT_i."""
    s_c, d_n, d_np1, copy_previous, dT, alpha_T, damage, offsets = args
    d = previous_damage(args, b)
    if dT.shape[0] > 0:
        trial = 1.0 if ((L - (alpha_T * dT[i]) * z) - z) / z > s_c else 0.0
    else:
        trial = 1.0 if stretch_exceeds(ex * ex + ey * ey + ez * ez, z, s_c) else 0.0
    d = trial if trial > d else d
    d_np1[b] = d
    return d


def point_damage(i, acc, p, args):
    """Damage of a point: broken bonds / bonds (counted from d_np1 in bond order, skipped bonds
    included)."""
    d_np1, offsets = args[2], args[7]
    lo = offsets[i]
    hi = offsets[i + 1]
    return damage_sum(d_np1, lo, hi) / (hi - lo) if hi > lo else 0.0

CRITICAL_STRETCH = PointSum(stretch_damage_term, gate=broken_gate, finish=point_damage)


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
    devices = frozenset({"cpu", "gpu"})
    #: copy bond damage N into NP1 before each update (Peridigm's intent; see the time-dependent variant)
    copy_previous = True

    def __init__(self, params, *, options=None) -> None:
        super().__init__(params, options=options)
        self.s_c = self.critical_stretch_at(0.0)
        self.alpha_T = params.thermal_expansion_coefficient

    def critical_stretch_at(self, time: float) -> float:
        """The critical stretch (dimensionless) at time ``time`` (T)."""
        return float(self.params.critical_stretch)

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
        dT = s["Temperature_Change"] if self.alpha_T is not None else empty(block)
        args = (self.s_c, s.n("Bond_Damage"), s["Bond_Damage"], self.copy_previous, dT, float(self.alpha_T or 0.0), s["Damage"], nl.offsets)
        compiled_with_lengths(block, CRITICAL_STRETCH)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], args, s["Damage"])


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
        from ..deck.expressions import compile_expression

        value = params.time_dependent_critical_stretch
        self.expr = compile_expression(repr(value) if isinstance(value, float) else value, ("t",))
        super().__init__(params, options=options)

    def critical_stretch_at(self, time: float) -> float:
        return float(self.expr(t=time))

    def begin_step(self, block: BlockView, time: float) -> None:
        self.s_c = self.critical_stretch_at(time)
