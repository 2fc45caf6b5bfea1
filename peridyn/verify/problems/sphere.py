"""``lame-sphere``: a thick-walled hollow sphere under internal pressure against Lamé's closed
form, `Elastic Correspondence` near nu = 0.5 (0.49 and 0.499) beside the LPS solid `Elastic` at the
same Poisson ratios: the displacement the solve finds, the stress the correspondence model
computes from it, the LPS dilatation and stored energy density. One octant is solved (the
field's symmetry planes are carried by a collar of points across them). Units: SI (m, Pa)."""
from __future__ import annotations

import copy
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..fit import fit_rate
from .base import Check, Measurement, Problem
from .dynamics import quiet
from .elasticity import MATRIX_FREE, NEWTON, solve, solver_values, write_mesh
from .lame import poisson_ratio

G = 1.0e9  #: shear modulus (Pa)
H = 1.0e-3  #: lattice spacing (m)
RATIO = 2.015  #: horizon / spacing
OUTER = 3.0  #: b / a
#: internal pressure p (Pa): small, so that the strains (3e-7 at r = a) make the geometric
#: nonlinearity (strain^2, 1e-13) negligible beside the trace of the strain (1e-9 at nu = 0.499)
PRESSURE = 1.0e3
HOURGLASS = 0.02


def lame_bulk_modulus(nu: float) -> float:
    """K = 2 G (1 + nu) / (3 (1 - 2 nu)) (Pa) of Lamé's solid."""
    return 2.0 * G * (1.0 + nu) / (3.0 * (1.0 - 2.0 * nu))


def bulk_modulus(nu: float) -> float:
    """The bulk modulus (Pa) given to the models: Lamé's (a test patches it alone)."""
    return lame_bulk_modulus(nu)


def shear_modulus() -> float:
    """The shear modulus (Pa) given to the models: Lamé's G (a test patches it alone)."""
    return G


def lame_sphere(r: np.ndarray, a: float, b: float, nu: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
    """Lamé's hollow sphere a < r < b (m) under the internal pressure PRESSURE, the outer face
    free, at the radii ``r`` (any shape, m): u_r (m), du_r/dr, sigma_rr and sigma_tt (Pa), and the
    mean stress A (Pa, uniform). u_r = p a^3 / (E (b^3 - a^3)) ((1 - 2 nu) r + (1 + nu) b^3 / (2 r^2)),
    sigma_rr = A (1 - b^3 / r^3), sigma_tt = A (1 + b^3 / (2 r^3)), A = p a^3 / (b^3 - a^3)."""
    c = PRESSURE * a**3 / (2.0 * G * (1.0 + nu) * (b**3 - a**3))  # E = 2 G (1 + nu)
    A = PRESSURE * a**3 / (b**3 - a**3)
    q = b**3 / r**3
    ur = c * ((1.0 - 2.0 * nu) * r + (1.0 + nu) * b**3 / (2.0 * r * r))
    dudr = c * ((1.0 - 2.0 * nu) - (1.0 + nu) * b**3 / r**3)
    return ur, dudr, A * (1.0 - q), A * (1.0 + 0.5 * q), A


def lame_expressions(a: float, b: float, nu: float) -> tuple[str, str, str]:
    """Deck expressions (x, y, z, t; m) of Lamé's u_x, u_y, u_z times t: u_r / r = C + D / r^3."""
    c = PRESSURE * a**3 / (2.0 * G * (1.0 + nu) * (b**3 - a**3))  # E = 2 G (1 + nu)
    r = "sqrt(x*x+y*y+z*z)"
    per_r = f"({c * (1.0 - 2.0 * nu)!r} + {c * (1.0 + nu) * b**3 / 2.0!r}/({r}*{r}*{r}))"
    return tuple(f"{per_r}*{v}*t" for v in "xyz")  # type: ignore[return-value]


def lps_energy(x: np.ndarray, u: np.ndarray, at: np.ndarray, bulk: float) -> np.ndarray:
    """The LPS stored energy density (J/m^3) at the points ``at`` (bool, (n,)) of the lattice
    ``x`` (n, 3; m, every volume H^3, influence 1) displaced by ``u`` (n, 3; m), written here from
    the bond sums (not read from the code): W = K/2 theta^2 + 15 G / (2 m) sum (e - theta |xi| / 3)^2 V,
    theta = 3 / m sum |xi| e V, m = sum |xi|^2 V, e = |xi + eta| - |xi|, over |xi| <= delta.
    Every point of ``at`` needs its whole family in ``x``."""
    from scipy.spatial import cKDTree

    V = H**3
    idx = np.nonzero(at)[0]
    families = cKDTree(x).query_ball_point(x[idx], RATIO * H * (1.0 + 1e-9))
    out = np.empty(len(idx))
    for k, (i, family) in enumerate(zip(idx, families)):
        j = np.array([q for q in family if q != i])
        xi = x[j] - x[i]
        d = np.linalg.norm(xi, axis=1)
        e = np.linalg.norm(xi + u[j] - u[i], axis=1) - d
        m = float(np.sum(d * d)) * V
        theta = 3.0 / m * float(np.sum(d * e)) * V
        out[k] = 0.5 * bulk * theta**2 + 7.5 * G / m * float(np.sum((e - theta * d / 3.0) ** 2)) * V
    return out


def octant(a_over_h: float) -> tuple[np.ndarray, float, float]:
    """The points (n, 3; m) of the shell a < r < b on the lattice of spacing H (points at half
    spacings) that lie in the octant x, y, z > 0 or within two horizons of it (the collar across
    the symmetry planes), and the radii a, b (m)."""
    a, b = a_over_h * H, OUTER * a_over_h * H
    depth = 2.0 * RATIO * H
    n, k = int(math.ceil(b / H)), int(math.ceil(depth / H))
    g = (np.arange(-k, n) + 0.5) * H
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    r = np.linalg.norm(x, axis=1)
    across = np.linalg.norm(np.minimum(x, 0.0), axis=1)  # distance from the octant
    return x[(r > a) & (r < b) & (across < depth)], a, b


def free_points(x: np.ndarray, a: float, b: float) -> np.ndarray:
    """(n,) bool: the points (n, 3; m) more than two horizons from both faces, inside the octant."""
    depth = 2.0 * RATIO * H
    r = np.linalg.norm(x, axis=1)
    return (r > a + depth) & (r < b - depth) & np.all(x > 0.0, axis=1)


class LameSphere(Problem):
    name = "lame-sphere"
    title = "Correspondence near nu = 0.5 beside LPS: a pressurised thick-walled sphere against Lamé"
    computes = (
        f"A hollow sphere a < r < b = {OUTER:g} a (a = (a/h) h, h = 1 mm), lattice points at half spacings, horizon {RATIO} h, "
        f"G = 1 GPa and K from nu (K/G = 50 at nu = 0.49, 500 at 0.499): `Elastic Correspondence` (hourglass coefficient "
        f"{HOURGLASS:g}, Newton on the assembled tangent) and the LPS solid `Elastic` (influence 1, matrix-free Newton-Krylov). "
        "One octant x, y, z > 0 is modelled, with the points within two horizons of it across its symmetry planes. The points "
        "within two horizons of either face or outside the octant (a collar) carry Lamé's displacement for an internal "
        f"pressure p = {PRESSURE:g} Pa and a free outer face; the points of the octant from r = a + 2 delta to b - 2 delta are "
        "free. One quasi-static load step. At the free points: the displacement against Lamé's (error: max |u - u_Lame| / "
        "max u_r). Correspondence: the amplitude of its `Cauchy_Stress` deviator sigma_tt - sigma_rr against Lamé's "
        "(3/2) A b^3 / r^3 (least squares) and the mean stress tr(sigma) / 3 against Lamé's A. LPS: the mean of its "
        "`Dilatation` against Lamé's tr(eps) = A / K, and its stored energy density against the LPS energy of Lamé's "
        "displacement at the same points (least squares)."
    )
    reference = (
        "Lamé (internal pressure p at r = a, the face r = b free): u_r = p a^3 / (E (b^3 - a^3)) ((1 - 2 nu) r + (1 + nu) "
        "b^3 / (2 r^2)), sigma_rr = A (1 - b^3/r^3), sigma_tt = sigma_pp = A (1 + b^3 / (2 r^3)), A = p a^3 / (b^3 - a^3), "
        "the mean stress A uniform. The radial field u = C r + D / r^2 is in equilibrium for any isotropic moduli, so the "
        "collar alone fixes the displacement: it tests the solve at K/G = 50 and 500 and the model's isotropy, not the "
        "moduli (measured max error: correspondence 1.93 %, 1.30 %, 0.73 % of u_max at a/h = 6, 8, 10 for nu = 0.49, "
        "rate 1.9 in h/a, band 1.4 .. 2.6, and 2.56 %, 1.69 %, 0.97 % for 0.499; LPS 0.64 %, 0.59 % at a/h = 6, 8 "
        "(0.73 % at 10: its lattice's anisotropy, which does not shrink at a fixed delta/h; no rate fitted), 1.55 % at "
        "0.499; band 3 % at every point). The stresses test the moduli. The correspondence deviator is 2 G times Lamé's: "
        "its amplitude sees G one for one (measured 1 - 7e-4, 1 - 3e-4, 1 - 1.5e-4 at both nu; band 1 %). The mean stress "
        "is K tr(eps): it sees K one for one, and it is the trace of an almost isochoric strain (tr(eps) is 1.6 % of the "
        "largest strain at nu = 0.49, 0.16 % at 0.499), so the O((delta/r)^2) error of the family's least-squares gradient "
        "is amplified: at nu = 0.49 the mean stress is -11.5 %, -6.3 %, -3.6 % off Lamé's A at a/h = 6, 8, 10, its error "
        "falling at the fitted rate 2.3 in h/a (band 1.4 .. 3, both nu). Its bands at nu = 0.49 are that measured "
        "discretisation error +- 2.5 % at each a/h (regression bands: a K 5 % off moves the mean stress 5 % and fails at "
        "every a/h, and the rate band holds the error to its convergence towards Lamé); at nu = 0.499 it is -123 %, -68 %, "
        "-38 % (the same rate, ten times the constant): a known miss against Lamé's A +- 2.5 % (see the check's reason). "
        "LPS: theta against tr(eps) = A / K sees the dilatation kernel (a factor 3 -> 2.9 moves it -3.3 %); measured "
        "-2.9 %, -1.0 %, +0.2 % at a/h = 6, 8, 10 (scatter 41 %, 37 %, 36 %), band 3.5 % at every point; at nu = 0.499 "
        "-108 %, -58 % (scatter 150 %, 81 %), the same known miss. Its stored energy density against the LPS energy of Lamé's exact "
        "displacement at the same points, W = K/2 theta^2 + 15 G / (2 m) sum (e - theta |xi| / 3)^2 V written here from the "
        "bond sums (so that the family's averaging of a curved field, +4 % at a/h = 6 against the continuum's energy, is "
        "not counted as an error): almost all deviatoric, it sees G one for one; measured 1 - 1.2e-3, 1 - 3.1e-3, "
        "1 - 4.0e-3 (0.49), 1 - 4.9e-3 (0.499, a/h = 6), band 2.5 %. With --quick a/h = 6 alone (3 .. 5 s a point)."
    )
    #: a table (no warm-up run of each method: one point per method with --quick) with its figure
    kind = "table"
    resolution_name = "a/h"
    size_name = "h/a"
    error_name = "max |u - u_Lame| / max u_r"
    methods = ("Elastic Correspondence, nu = 0.49", "Elastic Correspondence, nu = 0.499", "Elastic, nu = 0.49", "Elastic, nu = 0.499")
    every_band = {m: 0.03 for m in methods}
    rate_band = {"Elastic Correspondence, nu = 0.49": (1.4, 2.6)}
    DEVIATOR_BAND = 0.01
    #: the correspondence mean stress / Lamé's A at nu = 0.49 as measured at each a/h (its discretisation error)
    MEAN_MEASURED = {6.0: 0.8851, 8.0: 0.9372, 10.0: 0.9639}
    MEAN_BAND = 0.025  #: +- around MEAN_MEASURED, and of the extrapolated mean stress around 1
    MEAN_RATE_BAND = (1.4, 3.0)
    THETA_BAND = 0.035
    ENERGY_BAND = 0.025
    DILATATION_MISS = (
        "the model's pressure is K times each point's own dilatation (correspondence: the trace of the family's least-squares "
        "gradient; LPS: theta = 3/m sum omega |xi| e V), and at nu = 0.499 the field's trace is 0.16 % of its strain, so the "
        "O((delta/r)^2) truncation and lattice error of that trace is amplified ten times more than at nu = 0.49: the "
        "correspondence mean stress is off by -123 %, -68 %, -38 % at a/h = 6, 8, 10 (it converges, at the same rate 2.3, "
        "scatter 84 .. 20 %), LPS's dilatation by -108 %, -58 % at a/h = 6, 8 (scatter 150 %, 81 %). Within 2.5 % would take a/h of about 33 "
        "(some 10^6 points in the octant), or a pressure that is not K times each point's own trace: a mixed "
        "(displacement-pressure) formulation or a dilatation averaged over the family (B-bar-like)")

    nu = staticmethod(poisson_ratio)

    def ladder(self, method: str, quick: bool) -> list[float]:
        if quick:
            return [6.0]
        return [6.0, 8.0, 10.0] if method.startswith("Elastic Correspondence") else [6.0, 8.0]

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        t0 = time.perf_counter()
        nu = self.nu(method)
        model = self.material_of(method)
        correspondence = model == "Elastic Correspondence"
        pts, a, b = octant(resolution)
        delta = RATIO * H
        collar = ~free_points(pts, a, b)
        mat: dict[str, Any] = {"Material Model": model, "Density": 1000.0, "Bulk Modulus": bulk_modulus(nu), "Shear Modulus": shear_modulus()}
        if correspondence:
            mat["Hourglass Coefficient"] = HOURGLASS
        conditions: dict[str, Any] = {"Collar Node Set": "collar.txt"}
        for c, value in zip("xyz", lame_expressions(a, b, nu)):
            conditions[f"Lame {c.upper()}"] = {"Type": "Prescribed Displacement", "Node Set": "Collar Node Set", "Coordinate": c, "Value": value}
        tree: dict[str, Any] = {
            "Discretization": {"Type": "Text File", "Input Mesh File": "points.txt"},
            "Materials": {"M": mat},
            "Blocks": {"Sphere": {"Block Names": "block_1", "Material": "M", "Horizon": delta}},
            "Boundary Conditions": conditions,
            "Solver": copy.deepcopy(NEWTON if correspondence else MATRIX_FREE),
        }
        if correspondence:
            tree["Output"] = {"Output File Type": "ExodusII", "Output Filename": "sphere", "Output Frequency": 1,
                              "Output Variables": {"Cauchy_Stress": True}}
        with tempfile.TemporaryDirectory(prefix="peridyn-verify-sphere-") as d, quiet("peridyn.engine", "peridyn.geometry", "peridyn.solvers"):
            write_mesh(Path(d), pts, H**3, {"collar": collar})
            sim, st = solve(tree, Path(d))
            x = np.array(sim.fields["Model_Coordinates"])
            u = np.array(sim.fields["Displacement"])
            if correspondence:
                sigma = np.array(sim.fields.n("Cauchy_Stress")).reshape(-1, 3, 3)  # the converged step's (swapped into N)
            else:
                theta = np.array(sim.fields["Dilatation"])
                W = np.zeros(len(x))
                for blk in sim.blocks:
                    blk.material.stored_energy_density(blk.view, W)
        wall = time.perf_counter() - t0
        free = free_points(x, a, b)
        r = np.linalg.norm(x, axis=1)
        er = x / r[:, None]
        ur, _, srr, stt, A = lame_sphere(r, a, b, nu)
        err = float(np.abs(u[free] - ur[free, None] * er[free]).max() / ur.max())
        values: dict[str, Any] = {"K / G": lame_bulk_modulus(nu) / G}
        if correspondence:
            mrr = np.einsum("ni,nij,nj->n", er, sigma, er)[free]
            mean = np.trace(sigma, axis1=1, axis2=2)[free] / 3.0
            dev = (stt - srr)[free]
            values.update({"deviator / Lame": float(np.dot(1.5 * (mean - mrr), dev) / np.dot(dev, dev)),
                           "mean stress / Lame": float(mean.mean() / A), "mean stress scatter / Lame": float(mean.std() / A)})
        else:
            trace = A / lame_bulk_modulus(nu)
            w_ref = lps_energy(x, ur[:, None] * er, free, lame_bulk_modulus(nu))
            values.update({"dilatation / Lame": float(theta[free].mean() / trace), "dilatation scatter / Lame": float(theta[free].std() / trace),
                           "energy density / bond-sum Lame": float(np.dot(W[free], w_ref) / np.dot(w_ref, w_ref))})
        values.update({"points": int(len(x)), "free points": int(free.sum()), **solver_values(st), "wall (s)": wall})
        return Measurement(err, size=1.0 / resolution, steps=int(st.get("force_evaluations") or 1), values=values)

    def extra_checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        out = []
        known = self.DILATATION_MISS if self.nu(method) > 0.495 else None
        for p in points:
            at = f"at a/h = {p['resolution']:g}"
            v = p["values"]
            if "deviator / Lame" in v:
                out.append(Check(self.name, method, f"deviator amplitude / Lame's (3/2) A b^3 / r^3 {at}", v["deviator / Lame"],
                                 1.0 - self.DEVIATOR_BAND, 1.0 + self.DEVIATOR_BAND))
                centre = self.MEAN_MEASURED.get(p["resolution"]) if known is None else 1.0
                if centre is not None:
                    band = (f"its measured discretisation error {centre - 1.0:+.1%} +- {self.MEAN_BAND:.1%}" if known is None
                            else f"Lame's A +- {self.MEAN_BAND:.1%}")
                    out.append(Check(self.name, method, f"mean stress / Lame's A {at} (band: {band})", v["mean stress / Lame"],
                                     centre - self.MEAN_BAND, centre + self.MEAN_BAND, known=known))
            else:
                out.append(Check(self.name, method, f"mean dilatation / Lame's tr(eps) {at}", v["dilatation / Lame"],
                                 1.0 - self.THETA_BAND, 1.0 + self.THETA_BAND, known=known))
                out.append(Check(self.name, method, f"stored energy density / the bond-sum LPS energy of Lame's displacement {at}",
                                 v["energy density / bond-sum Lame"], 1.0 - self.ENERGY_BAND, 1.0 + self.ENERGY_BAND))
        if len(points) >= 3 and "deviator / Lame" in points[0]["values"]:
            q = fit_rate([p["size"] for p in points], [abs(p["values"]["mean stress / Lame"] - 1.0) for p in points])
            out.append(Check(self.name, method, "fitted rate of |mean stress / Lame's A - 1| in h/a (its error tends to 0)", q,
                             *self.MEAN_RATE_BAND))
        return out
