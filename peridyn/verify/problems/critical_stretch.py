"""``critical-stretch``: the bonds the ``Critical Stretch`` damage model breaks under a homogeneous
stretch, against the exact set of bonds whose stretch exceeds s_c.

Under the deformation y = F x, F = diag(1 + s, 1, 1), a bond xi with direction cosine c = xi_x /
|xi| has the stretch lambda(s) = sqrt(1 + (2 s + s^2) c^2) - 1, which passes s_c at

    s*(c) = sqrt(1 + ((1 + s_c)^2 - 1) / c^2) - 1.

So at s = s*(c) (1 -+ EPS) every bond of that direction class must be intact / broken, and every
bond of the other classes as its own threshold says: the set of broken bonds is known exactly,
bond by bond, with a relative margin EPS = 1e-6 that is far above round-off and far below any
error worth seeing (a critical stretch 10 % off moves every threshold by 10 %)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ...testing import build_simulation, cube_deck
from .base import Check, Measurement, Problem

#: critical stretch of the deck and the relative margin either side of each threshold
S_C = 1.0e-3
EPS = 1.0e-6


def threshold(c2: np.ndarray, s_c: float = S_C) -> np.ndarray:
    """s*(c) (dimensionless): the uniaxial stretch s of F = diag(1 + s, 1, 1) at which a bond with
    squared direction cosine ``c2`` = (xi_x / |xi|)^2 > 0 reaches the stretch ``s_c``."""
    return np.sqrt(1.0 + ((1.0 + s_c) ** 2 - 1.0) / c2) - 1.0


class CriticalStretch(Problem):
    name = "critical-stretch"
    title = "Critical Stretch: the bonds broken under a homogeneous stretch, bond by bond"
    kind = "table"
    plotted = False  # a count of misclassified bonds, zero when right
    computes = (
        f"A cube of 6^3 points (spacing 1 m, horizon = delta/h spacings; 8^3 and more ratios without --quick) with the "
        f"`Critical Stretch` damage model, s_c = {S_C:g}, its positions set to y = F x, F = diag(1 + s, 1, 1) (no solver: "
        "one force evaluation per s, which updates the damage first), for s = s*(c) (1 - 1e-6) and s*(c) (1 + 1e-6) at "
        "every direction class c = xi_x / |xi| > 0 of the lattice's bonds, from the smallest threshold up, each "
        "evaluation from the undamaged state. Error: the number of bonds whose `Bond_Damage` (0 or 1) differs from the "
        "exact set, over all evaluations; columns: the bonds checked, the classes, the point damage's largest "
        "difference from broken bonds / bonds."
    )
    reference = (
        "A bond breaks when its stretch |eta| / |xi| - 1 exceeds s_c; under y = F x the stretch of a bond with direction "
        "cosine c is sqrt(1 + (2 s + s^2) c^2) - 1, which passes s_c at s*(c) = sqrt(1 + ((1 + s_c)^2 - 1) / c^2) - 1. "
        "At s*(c) (1 -+ 1e-6) the bonds of class c are intact / broken (their stretch is s_c (1 -+ ~1e-6), a margin "
        "10^10 times round-off), every other bond as its own threshold says, and bonds with c = 0 never break. Band: "
        "no misclassified bond (error 0) at every point, and the point damage equal to the broken fraction of each "
        "point's bonds to 1e-12. A critical stretch 10 % off misclassifies every bond class at one of its two s values."
    )
    resolution_name = "delta/h"
    size_name = "-"
    error_name = "misclassified bonds"
    methods = ("Elastic Bond Based", "Elastic")
    MATERIALS: dict[str, dict[str, Any]] = {
        "Elastic Bond Based": {"Material Model": "Elastic Bond Based", "Density": 1000.0, "Bulk Modulus": 1.0e9},
        "Elastic": {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1.0e9, "Shear Modulus": 0.45e9},
    }
    #: largest |point damage - broken / bonds|
    DAMAGE_BAND = 1.0e-12

    def ladder(self, method: str, quick: bool) -> list[float]:
        return [3.015] if quick else [2.015, 3.015, 4.015]

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        n = 6 if quick else 8
        sim = build_simulation(cube_deck(self.MATERIALS[method], n=n, horizon_factor=resolution,
                                         damage={"Damage Model": "Critical Stretch", "Critical Stretch": S_C}))
        x = np.array(sim.fields["Model_Coordinates"])
        offsets, neighbors = np.asarray(sim.bonds.offsets), np.asarray(sim.bonds.neighbors)
        owners = np.repeat(np.arange(len(offsets) - 1), np.diff(offsets))
        xi = x[neighbors] - x[owners]
        c2 = np.round(xi[:, 0] ** 2 / np.einsum("ij,ij->i", xi, xi), 12)
        classes = np.unique(c2[c2 > 0.0])
        stars = threshold(classes)
        wrong = checked = 0
        damage_error = 0.0
        for s in np.concatenate([stars * (1.0 - EPS), stars * (1.0 + EPS)]):
            self._reset(sim)
            sim.fields["Coordinates"][:] = x
            sim.fields["Coordinates"][:, 0] = x[:, 0] * (1.0 + s)
            sim.evaluate_forces()
            broken = np.asarray(sim.fields["Bond_Damage"]) >= 1.0
            expected = (c2 > 0.0) & (threshold(np.where(c2 > 0.0, c2, 1.0)) < s)
            wrong += int(np.count_nonzero(broken != expected))
            checked += len(broken)
            fraction = np.add.reduceat(broken.astype(float), offsets[:-1]) / np.maximum(np.diff(offsets), 1)
            damage_error = max(damage_error, float(np.abs(np.asarray(sim.fields["Damage"]) - fraction).max()))
        sim.fields["Coordinates"][:] = x
        return Measurement(float(wrong), steps=2 * len(classes), values={
            "bond checks": checked, "direction classes": len(classes), "smallest threshold s*": float(stars.min()),
            "largest threshold s*": float(stars.max()), "point damage error": damage_error, "bonds": len(c2)})

    @staticmethod
    def _reset(sim: Any) -> None:
        """Clear the damage of both states (the model reads the previous step's Bond_Damage)."""
        for name in ("Bond_Damage", "Damage"):
            if name in sim.fields:
                sim.fields[name][:] = 0.0
                try:
                    sim.fields.n(name)[:] = 0.0
                except (KeyError, AttributeError):
                    pass

    def checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        out = []
        for p in points:
            out.append(Check(self.name, method, f"misclassified bonds at delta/h = {p['resolution']:g} "
                             f"({p['values']['bond checks']} bond checks)", p["error"], high=0.0))
            out.append(Check(self.name, method, f"largest |point damage - broken / bonds| at delta/h = {p['resolution']:g}",
                             p["values"]["point damage error"], high=self.DAMAGE_BAND))
        return out
