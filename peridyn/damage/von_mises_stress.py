"""``Von Mises Stress`` damage (PERIDIGM_MODELS.md §8.3; Peridigm's
``Peridigm_VonMisesStressDamageModel.cpp``), and what it shares with ``Johnson Cook``
(:mod:`peridyn.damage.johnson_cook`): both are meant for the correspondence materials that keep
a stress per bond (the bond-associated and hypoelastic families).

Per bond, with r = sigma_vm,b / sigma_c (the bond's von Mises stress over ``Critical Von Mises
Stress``), the trial damage is 1 when r >= D_crit (``Critical Damage``), 0 when r <= D_th
(``Threshold Damage``) and (r - D_th)/(D_crit - D_th) between; bond damage = max(N value,
trial): it never decreases. Per point,

    Broken_Bond_Volume_Averaged_i = sum_j ((d_ij omega(|eta|, delta_i)) / m_u,i) (J_j V_j)
    Flying_Point_Flag_i = 1 if that exceeds ``Critical Damage To Neglect Material Point``, else -1

with omega the discretization's influence function of the *deformed* bond length and the
point's horizon, m_u the material's ``Undamaged_Weighted_Volume`` and J its
``Jacobian_Determinant`` at step N (hypoelastic family). Where the material has no such fields
(the bond-associated family, which is Lagrangian) J = 1 and m_u = sum_j omega(|xi|, delta_i) V_j
in the reference configuration.

Inputs: the bond von Mises stress and stress triaxiality are those of the stress the material
last wrote per bond (``Bond_Unrotated_Cauchy_Stress``; rotation does not change them), as
Peridigm's materials publish them in ``Bond_Von_Mises_Stress`` and ``Bond_Stress_Triaxiality``;
this module computes them into those bond fields before each update.

Difference from Peridigm: Peridigm's model registers no ``Damage``; here ``Damage`` is
Broken_Bond_Volume_Averaged, so that the material sees the point damage grow (the
bond-associated family re-derives its weights where it does).
"""
from __future__ import annotations

import math

import numpy as np
from pydantic import Field, model_validator

from ..core.errors import InputError
from ..core.fields import FieldSpec, Relation, Temporal
from ..core.influence import TABLE, omega
from ..core.interfaces import BlockView, DamageModel
from ..core.params import ModelParams
from ..core.traversal import BondMap, PointSum
from ..kernels import default_backend
from ..kernels.lengths import compiled_with_lengths

EMPTY = np.zeros(0)
STRESS = "Bond_Unrotated_Cauchy_Stress"


# ------------------------------------------------------------------------------------------------
# loop laws (peridyn.core.traversal). Bond context (i, j, b, ex, ey, ez, L, z, p, args):
# (ex, ey, ez) = y_j - y_i and L = |y_j - y_i| (L) of the positions the kernel is given, z the
# bond's reference length (L). Shapes: y, x (n, 3) L; volume (n,) L^3; per-bond arrays (nb,);
# per-point arrays (n,); J (n,) or empty (J = 1).
# ------------------------------------------------------------------------------------------------
def bond_invariants_bond(i, j, b, ex, ey, ez, L, z, p, args):
    """Von Mises stress sqrt((3/2) s:s) of the bond stress S[b] (M L^-1 T^-2; returned) and its
    triaxiality ((S0 + S4) + S8)/(3 max(1e-20, vm)) written to triax[b] (skipped when triax is
    empty); args (S (nb, 9), triax (nb,) or empty). No geometry is read."""
    S, triax = args
    tr = (S[b, 0] + S[b, 4]) + S[b, 8]
    mean = tr / 3.0
    acc = 0.0
    for k in range(9):
        sk = S[b, k] - mean if k % 4 == 0 else S[b, k]
        acc += sk * sk
    v = math.sqrt((3.0 / 2.0) * acc)
    if triax.shape[0] > 0:
        triax[b] = tr / (3.0 * (max(1e-20, v)))
    return v


def reference_weighted_volume_term(i, j, b, ex, ey, ez, L, z, p, args):
    """omega(|xi|, delta_i) V_j (L^3), on reference positions (y = x); args (V, horizon, kind)."""
    volume, horizon, kind = args
    return omega(kind, L, horizon[i], EMPTY, b) * volume[j]


def trial_damage(r, D_crit, D_th):
    """Trial bond damage of the stress ratio r: 1 at and above D_crit, 0 at and below D_th,
    linear between."""
    if r >= D_crit:
        return 1.0
    elif r <= D_th:
        return 0.0
    return (r - D_th) / (D_crit - D_th)


def neighbor_volume(j, volume, J):
    """J_j V_j (L^3), V_j without the Jacobian (J empty)."""
    return J[j] * volume[j] if J.shape[0] > 0 else volume[j]


def von_mises_damage_term(i, j, b, ex, ey, ez, L, z, p, args):
    """Bond damage d = max(d_n, trial(vm / sigma_c)) written to d_np1[b]; returns the bond's
    share ((d omega(|eta|, delta_i)) / m_u,i) J_j V_j of Broken_Bond_Volume_Averaged (0 while
    m_u,i = 0, before the material's first precompute; Peridigm: 0/0). args (V, J, horizon,
    kind, m_u, vm, sigma_c, D_crit, D_th, neglect, d_n, d_np1, flag)."""
    volume, J, horizon, kind, m_u, vm, sigma_c, D_crit, D_th, neglect, d_n, d_np1, flag = args
    d = d_n[b]
    d = max(d, trial_damage(vm[b] / sigma_c, D_crit, D_th))
    d_np1[b] = d
    Vj = neighbor_volume(j, volume, J)
    w = omega(kind, L, horizon[i], EMPTY, b)
    if m_u[i] > 0.0:
        return ((d * w) / m_u[i]) * Vj
    return 0.0


def flying_point_finish(i, acc, p, args):
    """Broken_Bond_Volume_Averaged = acc (returned); Flying_Point_Flag = 1 above ``neglect``,
    else -1 (written to flag[i], the last of args; neglect args[-4])."""
    args[-1][i] = 1.0 if acc > args[-4] else -1.0
    return acc


BOND_INVARIANTS = BondMap(bond_invariants_bond)
REFERENCE_WEIGHTED_VOLUME = PointSum(reference_weighted_volume_term)
VON_MISES_DAMAGE = PointSum(von_mises_damage_term, finish=flying_point_finish)


# the laws' kernels with the arguments of the hand-written kernels they replaced (callers without a
# BlockView: tests, tools); the models call compiled(block, LAW) themselves
def bond_invariants_kernel(start, stop, offsets, S, vm, triax):
    """vm[b] (and triax[b], unless triax is empty) of the bond stresses S (nb, 9) of the points
    [start, stop) (the law BOND_INVARIANTS; reads no geometry)."""
    nb = S.shape[0]
    default_backend().kernel(BOND_INVARIANTS)(start, stop, offsets, np.zeros(nb, np.int32), np.zeros(nb), np.zeros((max(stop, 1), 3)),
                                              (S, triax), vm)


def von_mises_damage_kernel(start, stop, offsets, neighbors, y, volume, J, horizon, kind, m_u, vm, sigma_c, D_crit, D_th,
                            neglect, d_n, d_np1, bbva, flag):
    """Bond damage d_np1, Broken_Bond_Volume_Averaged bbva and Flying_Point_Flag flag of the
    points [start, stop) (the law VON_MISES_DAMAGE). y (n, 3) current positions (L)."""
    args = (volume, J, horizon, kind, m_u, vm, sigma_c, D_crit, D_th, neglect, d_n, d_np1, flag)
    default_backend().kernel(VON_MISES_DAMAGE)(start, stop, offsets, neighbors, np.zeros(neighbors.shape[0]), y, args, bbva)


# ------------------------------------------------------------------------------------------------
# what the two models share
# ------------------------------------------------------------------------------------------------
class BondStressDamage(DamageModel):
    """Damage from the bond stresses of a correspondence material: the inputs (bond von Mises
    stress, triaxiality, J, m_u, horizon) and the point outputs of PERIDIGM_MODELS.md §8.2/§8.3."""

    #: also compute Bond_Stress_Triaxiality
    needs_triaxiality = False

    def __init__(self, params, *, options=None) -> None:
        super().__init__(params, options=options)
        self._m_u: np.ndarray | None = None  # own reference m_u when the material has none
        self._last_stress: np.ndarray | None = None  # the bond-stress array the material wrote last

    def fields(self) -> list[FieldSpec]:
        specs = super().fields()
        specs += [
            FieldSpec("Horizon", Relation.ELEMENT),
            FieldSpec("Flying_Point_Flag", Relation.ELEMENT, 1, Temporal.TWO_STEP),
            FieldSpec("Broken_Bond_Volume_Averaged", Relation.ELEMENT, 1, Temporal.TWO_STEP),
            FieldSpec("Bond_Von_Mises_Stress", Relation.BOND),
        ]
        if self.needs_triaxiality:
            specs.append(FieldSpec("Bond_Stress_Triaxiality", Relation.BOND))
        return specs

    def _error(self, message: str, fix: str) -> InputError:
        return InputError(f"{self.name}: {message}", path=self.options.get("path", ()), fix=fix)

    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        if STRESS not in s:
            raise self._error("the block's material keeps no stress per bond (Bond_Unrotated_Cauchy_Stress)",
                              "use a bond-associated or hypoelastic correspondence material")
        if block.influence.kind == TABLE:
            raise self._error("needs a named influence function of the deformed bond length, not an expression",
                              "set the Discretization's 'Influence Function' to One, Parabolic Decay or Gaussian")
        lo, hi = block.start, block.stop
        b0, b1 = nl.offsets[lo], nl.offsets[hi]
        for name in ("Broken_Bond_Volume_Averaged", "Damage"):
            s.n(name)[lo:hi] = 0.0
            s.np1(name)[lo:hi] = 0.0
        for name in ("Flying_Point_Flag",):
            s.n(name)[lo:hi] = -1.0
            s.np1(name)[lo:hi] = -1.0
        s.n("Bond_Damage")[b0:b1] = 0.0
        s.np1("Bond_Damage")[b0:b1] = 0.0
        if "Undamaged_Weighted_Volume" not in s:
            if self._m_u is None or self._m_u.shape[0] != s.num_points:
                self._m_u = np.zeros(s.num_points)
            compiled_with_lengths(block, REFERENCE_WEIGHTED_VOLUME)(lo, hi, nl.offsets, nl.neighbors, s["Model_Coordinates"],
                                                       (s["Volume"], s["Horizon"], block.influence.kind), self._m_u)

    def _inputs(self, block: BlockView) -> tuple[np.ndarray, np.ndarray]:
        """(J at N or empty, m_u) and the bond invariants of the stress the material wrote last
        (into Bond_Von_Mises_Stress, Bond_Stress_Triaxiality)."""
        s, nl = block.fields, block.bonds
        # the material writes its bond stress into the NP1 array of the evaluation; the last one it
        # wrote is the array that was NP1 at the previous update (N after a completed step)
        src = self._last_stress if self._last_stress is not None else s.np1(STRESS)
        triax = s["Bond_Stress_Triaxiality"] if self.needs_triaxiality else EMPTY
        compiled_with_lengths(block, BOND_INVARIANTS)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], (src, triax),
                                         s["Bond_Von_Mises_Stress"])
        self._last_stress = s.np1(STRESS)
        J = s.n("Jacobian_Determinant") if "Jacobian_Determinant" in s else EMPTY
        m_u = s.get("Undamaged_Weighted_Volume", self._m_u)
        return J, m_u


class VonMisesStressParams(ModelParams):
    critical_von_mises_stress: float = Field(alias="Critical Von Mises Stress", gt=0, description="sigma_c: bond von Mises stress of full damage when Critical Damage = 1 (M L^-1 T^-2, Pa in SI)")
    critical_damage: float = Field(1.0, alias="Critical Damage", gt=0, description="D_crit: stress ratio sigma_vm/sigma_c at and above which a bond is fully broken")
    threshold_damage: float = Field(0.99, alias="Threshold Damage", ge=0, description="D_th: stress ratio at and below which a bond takes no damage (<= Critical Damage)")
    critical_damage_to_neglect: float = Field(
        0.95, alias="Critical Damage To Neglect Material Point", description="Broken_Bond_Volume_Averaged above which Flying_Point_Flag is set"
    )

    @model_validator(mode="after")
    def _order(self):
        if self.critical_damage < self.threshold_damage:
            raise ValueError(f"'Threshold Damage' ({self.threshold_damage:g}) cannot be greater than 'Critical Damage' ({self.critical_damage:g})")
        return self


class VonMisesStress(BondStressDamage):
    """Peridigm's ``Von Mises Stress`` damage model (see the module docstring)."""

    name = "Von Mises Stress"
    Params = VonMisesStressParams

    def update(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        J, m_u = self._inputs(block)
        p = self.params
        args = (s["Volume"], J, s["Horizon"], block.influence.kind, m_u, s["Bond_Von_Mises_Stress"], float(p.critical_von_mises_stress),
                float(p.critical_damage), float(p.threshold_damage), float(p.critical_damage_to_neglect), s.n("Bond_Damage"),
                s["Bond_Damage"], s["Flying_Point_Flag"])
        compiled_with_lengths(block, VON_MISES_DAMAGE)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], args,
                                          s["Broken_Bond_Volume_Averaged"])
        s["Damage"][block.start : block.stop] = s["Broken_Bond_Volume_Averaged"][block.start : block.stop]
