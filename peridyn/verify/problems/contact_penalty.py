"""``hertz-penalty``: the ``hertz`` indentation (a rigid sphere pressed into a bond-based block)
through PeriLab's ``Penalty Contact`` instead of Peridigm's ``Short Range Force``, against
Hertz's F = 4/3 E* sqrt(R) d^1.5.

The penalty law pushes two points of different bodies closer than R_c apart with (4.5 / pi)
(c_i delta_i^-5 + c_j delta_j^-5) (R_c - d) V_i V_j (N), c = p K of each point's block (``Penalty
Factor`` p, K from the material's ``elastic_moduli()``): PeriLab's 9 c / (pi delta^5) for a pair
of equal horizons. With p = 2 k / K it is the ``Short Range Force`` law of ``Spring Constant`` k,
so p = 200 gives the springs of ``hertz`` (k = 100 K) through the bulk modulus of the block.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .contact import K, Hertz

METHOD = "Penalty Contact"


class HertzPenalty(Hertz):
    name = "hertz-penalty"
    title = "Hertz contact through PeriLab's penalty contact: a rigid sphere pressed into a peridynamic block"
    PENALTY = 200.0  #: Penalty Factor: contact stiffness c = 200 K, the springs of ``hertz``'s Spring Constant 100 K
    methods = (METHOD,)
    every_band = {METHOD: 0.10}
    finest_band = {METHOD: 0.07}
    rate_band = {METHOD: (0.6, 1.6)}
    computes = (
        "The indentation of `hertz` (rigid sphere of radius R = 20 mm on an `Elastic Bond Based` block, K = 1 GPa, rho = "
        f"1000 kg/m^3, horizon {Hertz.M} h, R/h = n; the same mesh, motion, records and fits) with the contact between the "
        f"sphere and the block computed by PeriLab's `Penalty Contact` (Contact Radius R_c = h, Penalty Factor p = {PENALTY:g}: "
        "contact stiffness c = p K of each point's block, read through the material's elastic_moduli()). Columns as in "
        "`hertz`: C/C_H from F^(2/3) against the half-space approach d_hs, C_el/C_H with the springs' penetration removed, "
        "C_el (ring)/C_H from the descent against the surface at R/2, the exponent of F against d_hs, the penetration "
        "epsilon / d_max at the end, and the contact force on the top-centre point at the end against PeriLab's law "
        "recomputed from the positions (`law error`)."
    )
    reference = (
        "Hertz (Johnson, Contact Mechanics, §3.4, 4.2) as in `hertz`: F = 4/3 E* sqrt(R + R_c) d^(3/2), E* = 2.22 K of "
        "the block's lattice solid. PeriLab's penalty law (PeriLab.jl src/Models/Contact/Penalty_model.jl, 3D): each "
        "master-slave pair closer than R_c gets c (9 / (pi delta^5)) (R_c - d) V_partner along the line between the points; "
        "peridyn visits each pair from both points with half of it, so the force on a point is the sum over the points j "
        "of other bodies closer than R_c of (4.5 / pi)(c_i delta_i^-5 + c_j delta_j^-5)(R_c - d) V_i V_j. With c = 200 K "
        "that is the pair stiffness of `hertz`'s Short Range Force springs (18 k / (pi delta^5), k = 100 K), so the same "
        "bands hold: stiffness error at most 10 % at every point, 7 % at the finest, rate 0.6 .. 1.6 (3 points or more); "
        "C_el within 3 %, C_el (ring) within 4 %, exponent 1.45 .. 1.55, the finest error at most 0.9 of the coarsest, "
        "penetration rate 0.7 .. 1.5; the law error round-off (1e-9). A penalty stiffness taken from a wrong modulus, or "
        "springs a tenth as stiff (penetration 3.4 times larger), fails them. **This is the identity it looks like**: "
        "with p = 200 the pair forces are those of `hertz`'s springs, so the runs reproduce `hertz` to round-off (its "
        "figures and numbers match `hertz`'s by construction). What this problem adds is the penalty law itself (the law "
        "error against PeriLab's formula recomputed from the positions, and the penalty factor read through the "
        "material's bulk modulus), not a second, independent comparison with Hertz."
    )

    def deck(self, n: int, folder: Path, spring: float | None = None) -> tuple[dict[str, Any], dict[str, float]]:
        """``Hertz.deck`` with ``Penalty Contact`` (``spring``: the Penalty Factor, default PENALTY)."""
        tree, info = super().deck(n, folder)
        factor = self.PENALTY if spring is None else spring
        tree["Contact"]["Models"] = {
            "Springs": {"Contact Model": "Penalty Contact", "Contact Radius": info["rc"], "Penalty Factor": factor},
        }
        return tree, info

    def contact_law(self, sim: Any, i: int, tree: dict[str, Any], rc: float) -> np.ndarray:
        """PeriLab's penalty force (N) on point i recomputed from the positions, c = p K for both
        bodies (the sphere's material has the block's bulk modulus)."""
        c = float(tree["Contact"]["Models"]["Springs"]["Penalty Factor"]) * K
        return self.law_force(sim, i, 0.5 * c, rc)  # 4.5 c / pi = 9 k / pi: Short Range Force springs of k = c / 2
