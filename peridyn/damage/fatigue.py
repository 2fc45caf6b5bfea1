"""``Fatigue``: the Silling-Askari cyclic-loading bond fatigue law (Silling & Askari, "Peridynamic
model for fatigue cracking", SAND2014-18590, 2014), used with the ``QuasiStatic`` solver.

The deck's loads are the **peak** loads of a constant-amplitude cycle with load ratio
R = P_min / P_max (proportional loading). Each solver load step, the equilibrium at the peak load
is solved, and the step stands for Delta N = f Delta t cycles (f the ``Frequency``): the solver's
time is t = N / f. Each bond has a remaining life lambda (``Remaining_Life``, 1 at the start);
with s+ the bond's stretch at the peak load, its cyclic strain range is

    eps = |s+ - s-| = |1 - R| |s+|

and, per load step k of Delta N_k cycles, with eps at the peak equilibrium of that step,

    phase I  (nucleation; neither end point damaged):   lambda_k = lambda_k-1 - Delta N_k A1 max(eps - eps_inf, 0)^m1
    phase II (growth; an end point has a broken bond):  lambda_k = lambda_k-1 - Delta N_k A2 eps^m2

(eps_inf the ``Fatigue Limit``). As in Silling & Askari's algorithm (solve at the peak load, take
the lives, break the bonds whose life ran out, solve again), a bond whose life runs out in step k
is broken, for good, in the equilibrium of step k + 1: the bonds of a step's solve do not depend
on the solver's trial configurations, only on the lives at the end of the previous step. A bond
is in phase II when ``Damage`` of either end point in the previous step's solve is positive: the
crack has reached the bond's family. With ``Critical Stretch`` a bond also breaks at once when s+
exceeds it (static failure at the peak load). ``Damage`` of a point is its broken-bond count over
its neighbor count, as for Critical Stretch.
"""
from __future__ import annotations

from pydantic import Field

from ..core.bondmath import damage_sum
from ..core.errors import InputError
from ..core.fields import FieldSpec, Relation, Temporal
from ..core.interfaces import BlockView, DamageModel
from ..core.params import ModelParams
from ..core.traversal import PointSum
from ..kernels.lengths import compiled_with_lengths

LIFE = "Remaining_Life"


# Loop law (peridyn.core.traversal); args (|1 - R|, A1, m1, A2, m2, eps_inf, s_c, dN, life_n,
# life_np1, d_n, d_np1, damage_n, offsets): s_c 0 for no static failure; dN the cycles of this
# step; life_n, life_np1 (nb,) remaining life; d_n, d_np1 (nb,) bond damage; damage_n (n,) point
# damage at the end of the previous step.
def broken_gate(i, b, p, args):
    """A bond broken for good stays broken (d = 1, its life kept) and is skipped."""
    life_n, life_np1, d_n, d_np1 = args[8], args[9], args[10], args[11]
    if d_n[b] >= 1:
        d_np1[b] = 1
        life_np1[b] = life_n[b]
        return False
    return True


def life_rate(eps, phase2, args):
    """-d lambda / dN (per cycle) of a bond with cyclic strain range eps in phase I or II."""
    if phase2:
        return args[3] * eps ** args[4] if eps > 0.0 else 0.0
    e = eps - args[5]
    return args[1] * e ** args[2] if e > 0.0 else 0.0


def fatigue_term(i, j, b, ex, ey, ez, L, z, p, args):
    """The bond is broken in this step's solve when its life ran out by the end of the previous
    step (lambda_n <= 0) or s+ > s_c; lambda_np1 = lambda_n - dN rate(eps) at this configuration.
    Writes both and returns the bond damage (0 or 1)."""
    s_c, dN, life_n, life_np1, d_np1, damage_n = args[6], args[7], args[8], args[9], args[11], args[12]
    s = (L - z) / z
    phase2 = damage_n[i] > 0.0 or damage_n[j] > 0.0
    life = life_n[b]
    life_np1[b] = life - dN * life_rate(args[0] * abs(s), phase2, args)
    broken = life <= 0.0 or (s_c > 0.0 and s > s_c)
    d_np1[b] = 1 if broken else 0
    return 1.0 if broken else 0.0


def point_damage(i, acc, p, args):
    """Damage of a point: broken bonds / bonds (from d_np1 in bond order, skipped bonds included)."""
    d_np1, offsets = args[11], args[13]
    lo = offsets[i]
    hi = offsets[i + 1]
    return damage_sum(d_np1, lo, hi) / (hi - lo) if hi > lo else 0.0


FATIGUE = PointSum(fatigue_term, gate=broken_gate, finish=point_damage)


class FatigueParams(ModelParams):
    load_ratio: float = Field(alias="Load Ratio", lt=1.0, description="R = P_min / P_max of the load cycle (dimensionless, < 1; negative: tension-compression)")
    frequency: float = Field(alias="Frequency", gt=0, description="load cycles per unit time (1/T, Hz in SI): a load step of dt stands for frequency * dt cycles")
    a1: float = Field(alias="A1", gt=0, description="phase I (nucleation) life coefficient: d lambda/dN = -A1 (eps - eps_inf)^m1 (1/cycle)")
    m1: float = Field(alias="m1", gt=0, le=100, description="phase I exponent (dimensionless): the slope -m1 of the S-N line in log-log")
    a2: float = Field(alias="A2", gt=0, description="phase II (growth) life coefficient: d lambda/dN = -A2 eps^m2 (1/cycle)")
    m2: float = Field(alias="m2", gt=0, le=100, description="phase II exponent (dimensionless): the Paris exponent of the crack growth rate")
    fatigue_limit: float = Field(0.0, alias="Fatigue Limit", ge=0, lt=1, description="eps_inf: cyclic bond strain range below which phase I takes no life (dimensionless)")
    critical_stretch: float | None = Field(None, alias="Critical Stretch", gt=0, description="optional: a bond whose peak stretch exceeds it breaks at once (static failure, dimensionless)")


class Fatigue(DamageModel):
    """The Silling-Askari fatigue law (module docstring). Fields: ``Bond_Damage`` (one byte per
    bond), ``Damage``, and ``Remaining_Life`` (bond, two-step, dimensionless), the last only in
    runs that use this model."""

    name = "Fatigue"
    Params = FatigueParams
    bond_damage_dtype = "uint8"

    def __init__(self, params, *, options=None) -> None:
        super().__init__(params, options=options)
        p = params
        s_c = float(p.critical_stretch) if p.critical_stretch is not None else 0.0
        self.law = (abs(1.0 - p.load_ratio), p.a1, p.m1, p.a2, p.m2, p.fatigue_limit, s_c)
        self.frequency = float(p.frequency)

    @property
    def symmetric(self) -> bool:
        # both ends compute the stretch from bitwise equal lengths and read both ends' Damage N
        return True

    def fields(self) -> list[FieldSpec]:
        return super().fields() + [FieldSpec(LIFE, Relation.BOND, 1, Temporal.TWO_STEP)]

    def cycles(self, block: BlockView) -> float:
        """Delta N, the load cycles of the current load step: frequency x the solver's step (T)."""
        return self.frequency * float(block.time_step)

    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        lo, hi = nl.offsets[block.start], nl.offsets[block.stop]
        if hi > lo and int(nl.neighbors[lo:hi].max()) >= block.num_owned:
            # phase II reads the neighbours' Damage, which the engine does not exchange to ghosts
            raise InputError(
                "the Fatigue damage model runs on one MPI rank only: its phase II test reads the Damage of bonded points",
                path=self.options.get("path", ()), fix="run the deck without mpiexec",
            )
        for life in (s[LIFE], s.n(LIFE)):
            life[lo:hi] = 1.0
        s["Bond_Damage"][lo:hi] = 0
        for damage in (s["Damage"], s.n("Damage")):
            damage[block.start : block.stop] = 0.0

    def begin_step(self, block: BlockView, time: float) -> None:
        """Called by the explicit solvers only, whose steps are not load cycles: refused."""
        raise InputError(
            "the Fatigue damage model needs a load-stepping static solver (each load step holds the peak load for Frequency x step cycles); "
            "an explicit dynamic step is not a load cycle",
            path=self.options.get("path", ()), fix="solve with QuasiStatic (or NOXQuasiStatic), the loads at their peak values",
        )

    def update(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        args = (*self.law, self.cycles(block), s.n(LIFE), s[LIFE], s.n("Bond_Damage"), s["Bond_Damage"], s.n("Damage"), nl.offsets)
        compiled_with_lengths(block, FATIGUE)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], args, s["Damage"])
