"""``lame-cylinder``: `Elastic Correspondence` near nu = 0.5, a thick-walled cylinder under
internal pressure in plane strain, against Lamé's closed form: the displacement the solve
finds, and the deviatoric and mean stress the model computes from it."""
from __future__ import annotations

import copy
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from .base import Check, Measurement, Problem
from .dynamics import quiet
from .elasticity import NEWTON, solve, solver_values, write_mesh

G = 1.0e9  #: shear modulus (Pa)
H = 1.0e-3  #: lattice spacing (m)
RATIO = 2.015  #: horizon / spacing
LAYERS = 3  #: lattice layers along z (u_z = 0 at every point: plane strain)
OUTER = 3.0  #: b / a
PRESSURE = 1.0e6  #: internal pressure p (Pa)
HOURGLASS = 0.02


def bulk_modulus(nu: float) -> float:
    """K = 2 G (1 + nu) / (3 (1 - 2 nu)) (Pa)."""
    return 2.0 * G * (1.0 + nu) / (3.0 * (1.0 - 2.0 * nu))


def lame(r: np.ndarray, a: float, b: float, nu: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Lamé's plane strain cylinder a < r < b (m) under the internal pressure PRESSURE, the
    outer face free: (u_r (m), sigma_rr, sigma_tt (Pa)) at r, and sigma_zz (Pa, uniform).
    sigma_rr = A (1 - b^2/r^2), sigma_tt = A (1 + b^2/r^2), A = p a^2 / (b^2 - a^2),
    u_r = ((1 - 2 nu) A r + A b^2 / r) / (2 G), sigma_zz = 2 nu A."""
    A = PRESSURE * a * a / (b * b - a * a)
    q = b * b / (r * r)
    return ((1.0 - 2.0 * nu) * A * r + A * b * b / r) / (2.0 * G), A * (1.0 - q), A * (1.0 + q), 2.0 * nu * A


def lame_expressions(a: float, b: float, nu: float) -> tuple[str, str]:
    """Deck expressions (x, y, t; m) of Lamé's u_x and u_y times t."""
    A = PRESSURE * a * a / (b * b - a * a)
    r = "sqrt(x*x+y*y)"
    ur = f"(({(1.0 - 2.0 * nu) * A / (2.0 * G)!r})*{r} + ({A * b * b / (2.0 * G)!r})/{r})"
    return f"{ur}*x/{r}*t", f"{ur}*y/{r}*t"


def poisson_ratio(method: str) -> float:
    """The Poisson's ratio a method's name states (``"Elastic, nu = 0.49"`` -> 0.49)."""
    return float(method.split("= ")[1])


class LameCylinder(Problem):
    name = "lame-cylinder"
    title = "Correspondence near nu = 0.5: a pressurised thick-walled cylinder against Lamé"
    computes = (
        f"A thick-walled cylinder a < r < b = {OUTER:g} a (a = (a/h) h, h = 1 mm) in plane strain: {LAYERS} lattice layers "
        f"along z with u_z = 0 prescribed at every point, `Elastic Correspondence` (G = 1 GPa, K from nu, hourglass "
        f"coefficient {HOURGLASS:g}, horizon {RATIO} h), lattice points at half spacings, those outside the annulus removed. "
        "The points within two horizons of either face (a collar) carry Lamé's displacement for an internal pressure "
        f"p = {PRESSURE / 1e6:g} MPa and a free outer face; the points between (r from a + 2 delta to b - 2 delta) are free "
        "in x and y. One quasi-static load step (Newton on the assembled tangent). At the free points: the displacement "
        "against Lamé's (error: max |u - u_Lame| / max u_r), the amplitude of the model's `Cauchy_Stress` deviator "
        "sigma_tt - sigma_rr against Lamé's 2 A b^2 / r^2 (least squares) and the mean of (sigma_rr + sigma_tt) / 2 "
        "against Lamé's A (the in-plane pressure part; sigma_zz in the table)."
    )
    reference = (
        "Lamé (plane strain, internal pressure p at r = a, the face r = b free): sigma_rr = A (1 - b^2/r^2), "
        "sigma_tt = A (1 + b^2/r^2), sigma_zz = 2 nu A, u_r = ((1 - 2 nu) A r + A b^2 / r) / (2 G), A = p a^2 / (b^2 - a^2). "
        "Near nu = 0.5 the field is almost isochoric: the divergence 2 (1 - 2 nu) A / (2 G) is 2 % (nu = 0.49) or 0.2 % "
        "(nu = 0.499) of the strain, and the mean stress K tr(eps) amplifies any error of the computed trace by K / G = 50 "
        "or 500. The radial field's displacement is fixed by the collar alone (u = C r + D / r for any moduli): it tests "
        "the solve at K / G = 50 and 500 (measured max error 0.84 %, 0.43 %, 0.27 % of u_max at a/h = 6, 8, 10 for "
        "nu = 0.49, falling as h^2, and 1.5 %, 0.67 %, 0.52 % for nu = 0.499; band 2 % at every point). The stresses "
        "test the moduli: the deviator is 2 G times Lamé's, so its amplitude sees G one for one (measured 1 - 7e-4 .. "
        "1 + 7e-4, band 1 %); the in-plane mean is K tr(eps) + ... , a 5 % error of K moves it 3.5 .. 6 % (nu = 0.49, "
        "measured). Its band, 2.5 %, is the smallest that holds the discretisation's measured error at nu = 0.49 (-1.4 %, "
        "-1.4 %, -1.8 % at a/h = 6, 8, 10; -2.2 % at 12): that error does not shrink with a/h at a fixed delta/h. At nu = "
        "0.499 it is -13 %, -18 %, -20 % at a/h = 6, 8, 10, with pointwise scatter of the pressure of 100 % and 44 % (a "
        "checkerboard): a known miss, reported as such (see the check's reason)."
    )
    #: a table (no warm-up run of each method: one point per method with --quick) with its figure
    kind = "table"
    resolution_name = "a/h"
    size_name = "h/a"
    error_name = "max |u - u_Lame| / max u_r"
    methods = ("Elastic Correspondence, nu = 0.49", "Elastic Correspondence, nu = 0.499")
    every_band = {m: 0.02 for m in methods}
    DEVIATOR_BAND = 0.01
    MEAN_BAND = 0.025
    PRESSURE_MISS = (
        "the correspondence stress is K tr(F) - ... with F the family's least-squares gradient; on an almost isochoric field "
        "its trace error, O((delta/r)^2) of the strain and a lattice checkerboard, is amplified by K/G = 500, so the pressure "
        "is 13 .. 20 % low with 40 .. 100 % scatter and does not converge at a fixed delta/h. A fix needs a pressure that is "
        "not K times each point's own trace: a mixed (displacement-pressure) or B-bar-like averaged dilatation over the "
        "family, in peridyn/materials/correspondence")

    nu = staticmethod(poisson_ratio)

    def ladder(self, method: str, quick: bool) -> list[float]:
        return [6.0] if quick else [6.0, 8.0, 10.0]

    @staticmethod
    def annulus(a_over_h: float) -> tuple[np.ndarray, float, float]:
        """The cylinder's points (n, 3; m) and its radii a, b (m)."""
        a, b = a_over_h * H, OUTER * a_over_h * H
        n = int(math.ceil(b / H))
        g = (np.arange(-n, n) + 0.5) * H
        z = (np.arange(LAYERS) - 0.5 * (LAYERS - 1)) * H
        x = np.stack(np.meshgrid(g, g, z, indexing="ij"), axis=-1).reshape(-1, 3)
        r = np.hypot(x[:, 0], x[:, 1])
        return x[(r > a) & (r < b)], a, b

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        t0 = time.perf_counter()
        nu = self.nu(method)
        pts, a, b = self.annulus(resolution)
        delta = RATIO * H
        r0 = np.hypot(pts[:, 0], pts[:, 1])
        collar = (r0 < a + 2.0 * delta) | (r0 > b - 2.0 * delta)
        ux, uy = lame_expressions(a, b, nu)
        mat = {"Material Model": "Elastic Correspondence", "Density": 1000.0, "Bulk Modulus": bulk_modulus(nu), "Shear Modulus": G,
               "Hourglass Coefficient": HOURGLASS}
        with tempfile.TemporaryDirectory(prefix="peridyn-verify-lame-") as d, quiet("peridyn.engine", "peridyn.geometry", "peridyn.solvers"):
            write_mesh(Path(d), pts, H**3, {"collar": collar, "all": np.ones(len(pts), dtype=bool)})
            tree = {
                "Discretization": {"Type": "Text File", "Input Mesh File": "points.txt"},
                "Materials": {"M": mat},
                "Blocks": {"Cylinder": {"Block Names": "block_1", "Material": "M", "Horizon": delta}},
                "Boundary Conditions": {
                    "Collar Node Set": "collar.txt", "All Node Set": "all.txt",
                    "Lame X": {"Type": "Prescribed Displacement", "Node Set": "Collar Node Set", "Coordinate": "x", "Value": ux},
                    "Lame Y": {"Type": "Prescribed Displacement", "Node Set": "Collar Node Set", "Coordinate": "y", "Value": uy},
                    "Plane Strain": {"Type": "Prescribed Displacement", "Node Set": "All Node Set", "Coordinate": "z", "Value": "0.0"},
                },
                "Solver": copy.deepcopy(NEWTON),
                "Output": {"Output File Type": "ExodusII", "Output Filename": "cylinder", "Output Frequency": 1,
                           "Output Variables": {"Cauchy_Stress": True}},
            }
            sim, st = solve(tree, Path(d))
            x = np.array(sim.fields["Model_Coordinates"])
            u = np.array(sim.fields["Displacement"])
            sigma = np.array(sim.fields.n("Cauchy_Stress")).reshape(-1, 3, 3)  # the converged step's (swapped into N)
        wall = time.perf_counter() - t0
        r = np.hypot(x[:, 0], x[:, 1])
        free = (r > a + 2.0 * delta) & (r < b - 2.0 * delta)
        er = np.stack([x[:, 0] / r, x[:, 1] / r, np.zeros_like(r)], axis=1)
        et = np.stack([-x[:, 1] / r, x[:, 0] / r, np.zeros_like(r)], axis=1)
        ur, srr, stt, szz = lame(r, a, b, nu)
        err = float(np.abs(u[free] - ur[free, None] * er[free]).max() / ur.max())
        mrr = np.einsum("ni,nij,nj->n", er, sigma, er)[free]
        mtt = np.einsum("ni,nij,nj->n", et, sigma, et)[free]
        dev = (stt - srr)[free]
        A = 0.5 * float(stt[0] + srr[0])
        mean = 0.5 * (mrr + mtt)
        values = {
            "K / G": bulk_modulus(nu) / G, "deviator / Lame": float(np.dot(mtt - mrr, dev) / np.dot(dev, dev)),
            "mean stress / Lame": float(mean.mean() / A), "mean stress scatter / Lame": float(mean.std() / A),
            "sigma_zz / Lame": float(sigma[free, 2, 2].mean() / szz), "points": int(len(x)), "free points": int(free.sum()),
            **solver_values(st), "wall (s)": wall,
        }
        return Measurement(err, size=1.0 / resolution, steps=int(st.get("force_evaluations") or 1), values=values)

    def extra_checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        out = []
        for p in points:
            at = f"at a/h = {p['resolution']:g}"
            v = p["values"]["deviator / Lame"]
            out.append(Check(self.name, method, f"deviator amplitude / Lame's 2 A b^2 / r^2 {at}", v, 1.0 - self.DEVIATOR_BAND, 1.0 + self.DEVIATOR_BAND))
            v = p["values"]["mean stress / Lame"]
            known = self.PRESSURE_MISS if self.nu(method) > 0.495 else None
            out.append(Check(self.name, method, f"mean in-plane stress / Lame's A {at}", v, 1.0 - self.MEAN_BAND, 1.0 + self.MEAN_BAND, known=known))
        return out
