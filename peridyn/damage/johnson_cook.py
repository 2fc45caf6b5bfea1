"""``Johnson Cook`` damage (PERIDIGM_MODELS.md §8.2; Peridigm's
``Peridigm_JohnsonCookDamageModel.cpp``) for the plastic correspondence materials that keep a
stress and an equivalent plastic strain per bond.

Per bond, a damage parameter D (``Bond_Damage_Parameter``, two-step) accumulates the bond's
equivalent plastic strain over the strain to failure of its stress triaxiality eta:

    D_NP1 = min(1, D_N + max(0, (eqps_N - eqps_NP1) / eps_f)),   eps_f = d1 + d2 exp(-d3 eta)

(``Damage Parameter 1/2/3``). The damage model runs before the material in an evaluation, so
that after a completed step (buffers swapped) eqps_N - eqps_NP1 is the increment of the
previous step, as in Peridigm. The bond damage is (D - D_th)/(1 - D_th) above ``Threshold
Damage`` D_th, else 0. Per point,

    Damage_i                      = sum_j ((D_ij omega(|eta|, delta_i)) / m_u,i) (J_j V_j)
    Broken_Bond_Volume_Averaged_i = sum_j ((d_ij omega(|eta|, delta_i)) / m_u,i) (J_j V_j)
    Flying_Point_Flag_i           = 1 if Broken_Bond_Volume_Averaged_i > ``Critical Damage To
                                    Neglect Material Point``, else -1

(omega, m_u, J and the inputs as for ``Von Mises Stress``: :mod:`peridyn.damage.von_mises_stress`).
``Critical Damage`` is validated (< 1, > Threshold Damage) but otherwise unused, as in Peridigm.
"""
from __future__ import annotations

import math

import numpy as np
from pydantic import Field, model_validator

from ..core.fields import FieldSpec, Relation, Temporal
from ..core.influence import omega
from ..core.interfaces import BlockView
from ..core.params import ModelParams
from ..core.traversal import PointSum
from ..kernels import default_backend
from ..kernels.lengths import compiled_with_lengths
from .von_mises_stress import EMPTY, BondStressDamage, neighbor_volume


# Loop law (peridyn.core.traversal). Bond context (i, j, b, ex, ey, ez, L, z, p, args):
# (ex, ey, ez) = y_j - y_i, L = |y_j - y_i| (L) in the current configuration. args (V, J, horizon,
# kind, m_u, eqps_n, eqps_np1, triax, d1, d2, d3, D_th, neglect, P_n, P_np1, d_np1, damage, flag):
# V, horizon, m_u, damage, flag (n,); J (n,) or empty (J = 1); eqps_n, eqps_np1, triax, P_n, P_np1,
# d_np1 (nb,) bond equivalent plastic strains, stress triaxiality, damage parameter, bond damage.
def damage_sum_point(i, args):
    """Starts Damage_i (args[16]), which the bonds add to one at a time."""
    args[16][i] = 0.0
    return 0.0


def johnson_cook_term(i, j, b, ex, ey, ez, L, z, p, args):
    """Damage parameter D = min(1, D_n + max(0, deqps / eps_f)) written to P_np1[b], bond damage
    d = (D - D_th)/(1 - D_th) above D_th (else 0) written to d_np1[b]; adds the bond's share
    ((D omega) / m_u,i) J_j V_j to Damage_i and returns ((d omega) / m_u,i) J_j V_j (the share of
    Broken_Bond_Volume_Averaged); omega = omega(|eta|, delta_i). No share while m_u,i = 0
    (before the material's first precompute; Peridigm: 0/0)."""
    (volume, J, horizon, kind, m_u, eqps_n, eqps_np1, triax, d1, d2, d3, D_th, neglect, P_n, P_np1, d_np1, damage,
     flag) = args
    D = P_n[b]
    deqps = eqps_n[b] - eqps_np1[b]
    eps_f = d1 + d2 * math.exp(-d3 * triax[b])
    inc = deqps / eps_f
    if inc > 0.0:
        D += inc
    D = min(1.0, D)
    P_np1[b] = D
    d = (D - D_th) / (1.0 - D_th) if D > D_th else 0.0
    d_np1[b] = d
    Vj = neighbor_volume(j, volume, J)
    w = omega(kind, L, horizon[i], EMPTY, b)
    if m_u[i] > 0.0:
        damage[i] += ((D * w) / m_u[i]) * Vj
        return ((d * w) / m_u[i]) * Vj
    return 0.0


def johnson_cook_finish(i, acc, p, args):
    """Broken_Bond_Volume_Averaged = acc (returned); Flying_Point_Flag = 1 above ``neglect``
    (args[12]), else -1 (written to flag[i], args[17])."""
    args[17][i] = 1.0 if acc > args[12] else -1.0
    return acc


JOHNSON_COOK = PointSum(johnson_cook_term, point=damage_sum_point, finish=johnson_cook_finish, mirror=False)  # point writes


def johnson_cook_kernel(start, stop, offsets, neighbors, y, volume, J, horizon, kind, m_u, eqps_n, eqps_np1, triax, d1, d2, d3,
                        D_th, neglect, P_n, P_np1, d_np1, damage, bbva, flag):
    """Damage parameter P_np1, bond damage d_np1 (nb,), Damage, Broken_Bond_Volume_Averaged bbva
    and Flying_Point_Flag flag (n,) of the points [start, stop): the law JOHNSON_COOK with the
    arguments of the hand-written kernel it replaced (callers without a BlockView). y (n, 3)
    current positions (L)."""
    args = (volume, J, horizon, kind, m_u, eqps_n, eqps_np1, triax, d1, d2, d3, D_th, neglect, P_n, P_np1, d_np1, damage, flag)
    default_backend().kernel(JOHNSON_COOK)(start, stop, offsets, neighbors, np.zeros(neighbors.shape[0]), y, args, bbva)


class JohnsonCookParams(ModelParams):
    damage_parameter_1: float = Field(alias="Damage Parameter 1", description="d1 of the strain to failure eps_f = d1 + d2 exp(-d3 eta) (dimensionless)")
    damage_parameter_2: float = Field(alias="Damage Parameter 2", description="d2 of eps_f (dimensionless)")
    damage_parameter_3: float = Field(alias="Damage Parameter 3", description="d3 of eps_f (dimensionless; eta is the stress triaxiality)")
    critical_damage: float = Field(alias="Critical Damage", description="validated (< 1 and > Threshold Damage) but unused, as in Peridigm")
    threshold_damage: float = Field(alias="Threshold Damage", description="damage parameter below which a bond takes no damage (< Critical Damage)")
    critical_damage_to_neglect: float = Field(
        0.95, alias="Critical Damage To Neglect Material Point", description="Broken_Bond_Volume_Averaged above which Flying_Point_Flag is set"
    )

    @model_validator(mode="after")
    def _order(self):
        if self.critical_damage >= 1.0:
            raise ValueError(f"'Critical Damage' ({self.critical_damage:g}) should be less than 1.0")
        if self.threshold_damage >= self.critical_damage:
            raise ValueError(f"'Threshold Damage' ({self.threshold_damage:g}) should be less than 'Critical Damage' ({self.critical_damage:g})")
        if not self.damage_parameter_1 + self.damage_parameter_2 > 0.0:
            raise ValueError("the strain to failure d1 + d2 exp(-d3 eta) must be positive: 'Damage Parameter 1' + "
                             "'Damage Parameter 2' (its value at zero triaxiality) is not")
        return self


class JohnsonCook(BondStressDamage):
    """Peridigm's ``Johnson Cook`` damage model (see the module docstring)."""

    name = "Johnson Cook"
    Params = JohnsonCookParams
    needs_triaxiality = True

    def fields(self) -> list[FieldSpec]:
        return super().fields() + [FieldSpec("Bond_Damage_Parameter", Relation.BOND, 1, Temporal.TWO_STEP)]

    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        if "Bond_Equivalent_Plastic_Strain" not in s:
            raise self._error("the block's material has no equivalent plastic strain per bond (Bond_Equivalent_Plastic_Strain)",
                              "use a plastic bond-associated or hypoelastic correspondence material")
        super().initialize(block)
        b0, b1 = nl.offsets[block.start], nl.offsets[block.stop]
        s.n("Bond_Damage_Parameter")[b0:b1] = 0.0
        s.np1("Bond_Damage_Parameter")[b0:b1] = 0.0

    def update(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        J, m_u = self._inputs(block)
        p = self.params
        args = (s["Volume"], J, s["Horizon"], block.influence.kind, m_u, s.n("Bond_Equivalent_Plastic_Strain"),
                s.np1("Bond_Equivalent_Plastic_Strain"), s["Bond_Stress_Triaxiality"], float(p.damage_parameter_1),
                float(p.damage_parameter_2), float(p.damage_parameter_3), float(p.threshold_damage), float(p.critical_damage_to_neglect),
                s.n("Bond_Damage_Parameter"), s["Bond_Damage_Parameter"], s["Bond_Damage"], s["Damage"], s["Flying_Point_Flag"])
        compiled_with_lengths(block, JOHNSON_COOK)(block.start, block.stop, nl.offsets, nl.neighbors, s["Coordinates"], args,
                                      s["Broken_Bond_Volume_Averaged"])
