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
from numba import njit, prange
from pydantic import Field, model_validator

from ..core.errors import InputError
from ..core.fields import FieldSpec, Relation, Temporal
from ..core.influence import TABLE, omega
from ..core.interfaces import BlockView, DamageModel
from ..core.params import ModelParams

EMPTY = np.zeros(0)
STRESS = "Bond_Unrotated_Cauchy_Stress"


# ------------------------------------------------------------------------------------------------
# kernels (offsets (n+1,), neighbors (nb,) int32; y, x (n, 3) L; volume (n,) L^3; per-bond (nb,))
# ------------------------------------------------------------------------------------------------
@njit(cache=True, parallel=True, error_model="numpy")
def bond_invariants_kernel(start, stop, offsets, S, vm, triax):
    """Von Mises stress vm = sqrt((3/2) s:s) and triaxiality ((S0 + S4) + S8)/(3 max(1e-20, vm))
    of the bond stresses S (nb, 9) of the points [start, stop) (triax skipped when empty)."""
    want_triax = triax.shape[0] > 0
    for i in prange(start, stop):
        for b in range(offsets[i], offsets[i + 1]):
            tr = (S[b, 0] + S[b, 4]) + S[b, 8]
            p = tr / 3.0
            acc = 0.0
            for k in range(9):
                sk = S[b, k] - p if k % 4 == 0 else S[b, k]
                acc += sk * sk
            v = math.sqrt((3.0 / 2.0) * acc)
            vm[b] = v
            if want_triax:
                triax[b] = tr / (3.0 * (max(1e-20, v)))


@njit(cache=True, parallel=True, error_model="numpy")
def reference_weighted_volume_kernel(start, stop, offsets, neighbors, x, volume, horizon, kind, m_u):
    """m_u,i = sum_j omega(|xi|, delta_i) V_j (L^3) for the points [start, stop)."""
    for i in prange(start, stop):
        acc = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            dx = x[j, 0] - x[i, 0]
            dy = x[j, 1] - x[i, 1]
            dz = x[j, 2] - x[i, 2]
            acc += omega(kind, math.sqrt(dx * dx + dy * dy + dz * dz), horizon[i], EMPTY, b) * volume[j]
        m_u[i] = acc


@njit(cache=True, parallel=True, error_model="numpy")
def von_mises_damage_kernel(start, stop, offsets, neighbors, y, volume, J, horizon, kind, m_u, vm, sigma_c, D_crit, D_th,
                            neglect, d_n, d_np1, bbva, flag):
    """Bond damage d_np1 = max(d_n, trial(vm / sigma_c)), Broken_Bond_Volume_Averaged bbva and
    Flying_Point_Flag flag of the points [start, stop). J (n,) or empty (J = 1)."""
    has_J = J.shape[0] > 0
    for i in prange(start, stop):
        acc = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            r = vm[b] / sigma_c
            if r >= D_crit:
                trial = 1.0
            elif r <= D_th:
                trial = 0.0
            else:
                trial = (r - D_th) / (D_crit - D_th)
            d = d_n[b]
            d = max(d, trial)
            d_np1[b] = d
            j = neighbors[b]
            Vj = J[j] * volume[j] if has_J else volume[j]
            ex = y[j, 0] - y[i, 0]
            ey = y[j, 1] - y[i, 1]
            ez = y[j, 2] - y[i, 2]
            w = omega(kind, math.sqrt(ex * ex + ey * ey + ez * ez), horizon[i], EMPTY, b)
            if m_u[i] > 0.0:  # 0 before the material's first precompute (Peridigm: 0/0)
                acc += ((d * w) / m_u[i]) * Vj
        bbva[i] = acc
        flag[i] = 1.0 if acc > neglect else -1.0


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
            reference_weighted_volume_kernel(lo, hi, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Volume"], s["Horizon"],
                                             block.influence.kind, self._m_u)

    def _inputs(self, block: BlockView) -> tuple[np.ndarray, np.ndarray]:
        """(J at N or empty, m_u) and the bond invariants of the stress the material wrote last
        (into Bond_Von_Mises_Stress, Bond_Stress_Triaxiality)."""
        s, nl = block.fields, block.bonds
        # the material writes its bond stress into the NP1 array of the evaluation; the last one it
        # wrote is the array that was NP1 at the previous update (N after a completed step)
        src = self._last_stress if self._last_stress is not None else s.np1(STRESS)
        bond_invariants_kernel(block.start, block.stop, nl.offsets, src, s["Bond_Von_Mises_Stress"],
                               s["Bond_Stress_Triaxiality"] if self.needs_triaxiality else EMPTY)
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
        von_mises_damage_kernel(
            block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], s["Volume"], J, s["Horizon"], block.influence.kind,
            m_u, s["Bond_Von_Mises_Stress"], float(p.critical_von_mises_stress), float(p.critical_damage), float(p.threshold_damage),
            float(p.critical_damage_to_neglect), s.n("Bond_Damage"), s["Bond_Damage"], s["Broken_Bond_Volume_Averaged"],
            s["Flying_Point_Flag"],
        )
        s["Damage"][block.start : block.stop] = s["Broken_Bond_Volume_Averaged"][block.start : block.stop]
