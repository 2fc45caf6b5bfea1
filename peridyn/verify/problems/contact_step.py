"""``contact-step``: the set-up's stable-step estimate with contact springs
(``ContactManager.stable_time_step``) against the exact stability limit of the same model
linearised in contact.

Velocity Verlet on M u'' = -K u is stable exactly when dt < 2 / omega_max, omega_max^2 the largest
eigenvalue of K / rho. K here is the model's own: -d f / d u of the bond forces plus the
`Short Range Force` contact forces, by central differences at a configuration where every facing
pair of points is compressed. So the reference is the stability limit of the very system the
estimate is for, not a run near the limit (``contact-stability`` bisects runs: 3 halvings leave a
10 % error in the estimate inside one interval)."""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...testing import build_simulation
from .base import Check, Measurement, Problem
from .contact import ContactStability
from .dynamics import quiet
from .families import one_thread


def contact_stiffness(sim: Any, step: float) -> np.ndarray:
    """(3n, 3n) -d f / d u of ``sim``'s bond and contact force density (n, 3) at its current
    positions, by central differences of one component at a time (step ``step``, m); the pair
    list is the one built at the current positions, the positions are restored."""
    y = sim.fields["Coordinates"]
    y0 = np.array(y)
    n = len(y0)

    def force() -> np.ndarray:
        f = np.array(sim.evaluate_forces())
        sim.contact.add_force(f, 0.0, 0)
        return f.reshape(-1)

    force()  # the pair list at the base positions
    out = np.empty((3 * n, 3 * n))
    for k in range(3 * n):
        i, c = divmod(k, 3)
        y[:] = y0
        y[i, c] += step
        plus = force()
        y[:] = y0
        y[i, c] -= step
        out[:, k] = -(plus - force()) / (2.0 * step)
    y[:] = y0
    return out


class ContactStep(Problem):
    name = "contact-step"
    title = "Stable-step estimate with contact springs against the exact limit of the linearised model"
    kind = "table"
    plotted = False  # a ratio to the exact limit, held near its measured value, not an error
    CUBE = 4  #: points per side of each cube
    GAP = 0.8  #: distance of the facing points, in contact radii (= spacings): every facing pair compressed by 0.2 R_c
    STEP = 1.0e-9  #: m, the finite-difference step (the springs' compression is 2e-4 m)
    RATIOS = ContactStability.RATIOS
    #: (k/K, horizon/spacing) -> the measured exact limit / estimate (deterministic: the finite
    #: differences reproduce it to 1e-8); the band is +- TOLERANCE around it
    MEASURED: dict[tuple[str, float], float] = {
        ("k/K = 1", 1.515): 2.0253, ("k/K = 10", 1.515): 2.4231, ("k/K = 100", 1.515): 2.2970, ("k/K = 1000", 1.515): 2.2764,
        ("k/K = 1", 3.015): 1.3260, ("k/K = 10", 3.015): 1.5692, ("k/K = 100", 3.015): 2.1741, ("k/K = 1000", 3.015): 2.2646,
    }
    TOLERANCE = 0.01
    methods = tuple(RATIOS)
    resolution_name = "horizon/spacing"
    size_name = "-"
    error_name = "exact limit / estimate"
    computes = (
        "`contact-stability`'s steel (K = 130 GPa, G = 78 GPa, rho = 7800 kg/m^3, LPS `Elastic`) as two cubes of 4^3 points "
        "(spacing h = 1 mm, no bonds between them) whose facing points stand 0.8 h apart, inside the `Short Range Force` "
        "contact radius R_c = h (Spring Constant k = 1, 10, 100, 1000 K), at rest. K = -d f / d u of the bond and contact "
        "force densities by central differences (step 1e-9 m, 768 force evaluations); omega_max^2 the largest eigenvalue of "
        "K / rho; dt_exact = 2 / omega_max, the step at which velocity Verlet on the linearised model becomes unstable. "
        "Columns: the estimate `ContactManager.stable_time_step` against the bond-only estimate, dt_exact against the "
        "estimate, the asymmetry of K / rho (a conservative model's is symmetric) and the contact pairs."
    )
    reference = (
        "dt_exact is exact for the linearised model (its modes), so the checks are: the estimate does not exceed it "
        "(dt_exact / estimate >= 1: the step `peridyn run` suggests is stable in contact), and dt_exact / estimate is the "
        f"measured ratio of each k/K and horizon within +- {100 * TOLERANCE:g} % (a band around the measurement of this "
        "deterministic ratio, reproduced to 1e-8: the estimate is a heuristic, dt_i = sqrt(2 rho / (sum_bonds V_j c / "
        "|xi| + k_c P_i / 0.81)), not a closed form of this scene). A contact pair stiffness 10 % off in the estimate moves "
        "the ratio by 4.5 % at k/K = 1000, a contact force law 10 % off moves dt_exact by as much; both fail."
    )

    def ladder(self, method: str, quick: bool) -> list[float]:
        return [1.515, 3.015]

    def tree(self, ratio: float, hf: float) -> dict[str, Any]:
        """``contact-stability``'s deck with cubes of CUBE^3 points, the right one moved left by
        (1 - GAP) h, at rest."""
        h, n = ContactStability.H, self.CUBE
        tree = ContactStability().tree(ratio, hf)
        shapes = tree["Discretization"]["Shapes"]
        shift = (1.0 - self.GAP) * h
        shapes["Left"]["Max"] = [n * h, n * h, n * h]
        shapes["Right"]["Min"] = [n * h - shift, 0.0, 0.0]
        shapes["Right"]["Max"] = [2 * n * h - shift, n * h, n * h]
        tree["Boundary Conditions"] = {}
        return tree

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        with quiet("peridyn.engine", "peridyn.geometry", "peridyn.contact"), one_thread():
            sim = build_simulation(self.tree(self.RATIOS[method], resolution))
            estimate, bond = sim.contact.stable_time_step(), sim.critical_time_step()
            K = contact_stiffness(sim, self.STEP)
            pairs = int(sim.contact.stats["pairs"])
        rho = float(ContactStability.MATERIAL["Density"])
        a = K / rho
        asymmetry = float(np.abs(a - a.T).max() / np.abs(a).max())
        omega = math.sqrt(float(np.linalg.eigvalsh(0.5 * (a + a.T)).max()))
        exact = 2.0 / omega
        values = {"estimate / bond-only estimate": estimate / bond, "exact limit (s)": exact, "exact limit / estimate": exact / estimate,
                  "asymmetry of K / rho": asymmetry, "contact pairs": pairs}
        return Measurement(exact / estimate, steps=2 * K.shape[0], values=values)

    def checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        out = []
        for p in points:
            r, at = float(p["error"]), f"at horizon/spacing {p['resolution']:g}"
            out.append(Check(self.name, method, f"exact Verlet limit of the linearised model / the estimate {at} (the estimate is stable)", r, low=1.0))
            ref = self.MEASURED.get((method, float(p["resolution"])))
            if ref is not None:
                out.append(Check(self.name, method, f"exact Verlet limit / the estimate {at}, against its measured {ref:g}", r,
                                 ref * (1.0 - self.TOLERANCE), ref * (1.0 + self.TOLERANCE)))
            out.append(Check(self.name, method, f"asymmetry of K / rho {at}", float(p["values"]["asymmetry of K / rho"]), high=1e-6))
        return out
