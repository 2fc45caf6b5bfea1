"""Contact problems: ``hertz`` (a rigid sphere pressed into a peridynamic block through
Peridigm's ``Short Range Force`` springs, against Hertz's F = 4/3 E* sqrt(R) d^1.5) and
``contact-stability`` (the largest stable Verlet step with stiff contact springs against the
set-up estimate that counts them, ``ContactManager.stable_time_step``).

What the short-range force model is: two points of bodies that were not bonded repel when
closer than the contact radius R_c, with the force (18 k / (pi delta^5)) (R_c - d) V_i V_j (N)
along the line between them (k the ``Spring Constant``, Pa; delta the horizon). It is a penalty
law on point distances: the contact "surface" of a lattice body lies R_c from its outer points
(not half a spacing, as its volume would say), and the bodies interpenetrate by the spring's
compression, more the softer k. Neither is Hertz's hard contact; both shrink with the spacing h
(R_c is of the order of h; where one point of the other body faces each point, the compression
at a pressure p is p h pi m^5 / (2 k), m = delta / h, with V = h^3 facing V = h^3 / 9 as in ``hertz``).
"""
from __future__ import annotations

import contextlib
import math
import re
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...core.errors import InstabilityError
from ...solvers.explicit.verlet import Verlet
from ...testing import build_simulation
from ...testing.tensile import lattice_family
from ..fit import fit_rate
from ...engine.run_services import RunServices
from ...engine.session import run_section
from .base import Check, Measurement, Problem
from .dynamics import Stability, _section, quiet
from .families import one_thread

#: bond-based ``Elastic Bond Based`` block: bulk modulus (Pa), density (kg/m^3)
K = 1.0e9
RHO = 1000.0


# ------------------------------------------------------------------------------------------------
# lattice elasticity and Hertz
# ------------------------------------------------------------------------------------------------
def lattice_moduli(m: float, bulk: float = K) -> tuple[float, float, float]:
    """(C11, C12, C44) (Pa) of ``Elastic Bond Based`` with bulk modulus ``bulk`` on a simple cubic
    lattice with horizon m spacings (full neighbour volumes, Peridigm's inclusive search):
    C_abcd = (c / 2) sum_j |xi_j| n_a n_b n_c n_d V_j, c = 18 K / (pi delta^4). The continuum
    ball gives C11 = 3 C12 = 1.8 K; the lattice does not (m = 1.515: C11 = 2.63 K, C12 = C44 =
    0.769 K, a bulk modulus 1.39 K): the model converges to the lattice's solid, not the stated one."""
    xi, length = lattice_family(m)
    n = xi / length[:, None]
    c = 18.0 * bulk / (math.pi * m**4)  # spacing 1: the constants do not depend on it
    w = 0.5 * c * length
    return float(np.sum(w * n[:, 0] ** 4)), float(np.sum(w * n[:, 0] ** 2 * n[:, 1] ** 2)), float(np.sum(w * n[:, 0] ** 2 * n[:, 1] ** 2))


def isotropic(c11: float, c12: float, c44: float) -> tuple[float, float, float]:
    """(E* (Pa), nu, G (Pa)) of the isotropic solid with the cubic constants' bulk modulus
    (C11 + 2 C12) / 3 and Voigt shear modulus (C11 - C12 + 3 C44) / 5; E* = E / (1 - nu^2) is
    Hertz's modulus of a rigid indenter on it. (At m = 1.515 the Voigt and Reuss shear moduli
    differ by 0.9 %, the anisotropy 2 C44 / (C11 - C12) is 0.83.)"""
    G = (c11 - c12 + 3.0 * c44) / 5.0
    lam = (c11 + 2.0 * c12) / 3.0 - 2.0 * G / 3.0
    nu = lam / (2.0 * (lam + G))
    return 2.0 * G / (1.0 - nu), nu, G


def hertz_axis_displacement(force: float, depth: float, e_star: float, nu: float, G: float, radius: float) -> float:
    """The downward displacement (m) of the half-space's point on the axis at ``depth`` (m) under
    Hertz's pressure p0 sqrt(1 - r^2/a^2) of a rigid sphere of ``radius`` (m) pressed with ``force``
    (N), relative to points far away: Boussinesq's u_z = P / (4 pi G) (z^2 / rho^3 + 2 (1 - nu) / rho)
    integrated over the contact circle (64-point Gauss-Legendre in r = a sin(theta)). At depth 0
    it is Hertz's approach d = a^2 / R."""
    if not force > 0.0:
        return 0.0
    a = (3.0 * force * radius / (4.0 * e_star)) ** (1.0 / 3.0)
    p0 = 3.0 * force / (2.0 * math.pi * a * a)
    x, w = np.polynomial.legendre.leggauss(64)
    theta = 0.25 * math.pi * (x + 1.0)
    r, cos = a * np.sin(theta), np.cos(theta)
    rho = np.sqrt(r * r + depth * depth)
    kernel = (depth * depth / rho**3 + 2.0 * (1.0 - nu) / rho) / (4.0 * math.pi * G)
    # p dA = p0 cos(theta) 2 pi r a cos(theta) d(theta)
    return float(np.sum(0.25 * math.pi * w * p0 * cos * 2.0 * math.pi * r * kernel * a * cos))


def hertz_surface_displacement(force: float, r: float, e_star: float, radius: float) -> float:
    """The downward displacement (m) of the half-space's surface at distance ``r`` (m) from the axis
    when a rigid sphere of ``radius`` (m) presses it with ``force`` (N), relative to points far
    away (Hertz; Johnson, Contact Mechanics, eq. 3.42): d - r^2 / (2R) inside the contact circle
    (a^3 = 3 F R / (4 E*), d = a^2 / R), (a^2 / (pi R)) ((2 - s^2) asin(1/s) + sqrt(s^2 - 1)),
    s = r / a, outside it: d/2 at its edge, F / (pi E* r) far from it."""
    if not force > 0.0:
        return 0.0
    a = (3.0 * force * radius / (4.0 * e_star)) ** (1.0 / 3.0)
    s = r / a
    if s <= 1.0:
        return a * a / radius - r * r / (2.0 * radius)
    return a * a / (math.pi * radius) * ((2.0 - s * s) * math.asin(1.0 / s) + math.sqrt(s * s - 1.0))


# ------------------------------------------------------------------------------------------------
# the indentation run
# ------------------------------------------------------------------------------------------------
@dataclass
class Indentation:
    """What one indentation run recorded, one entry per Verlet step (the quantities in m and N;
    downward displacements positive)."""

    spacing: float
    approach: np.ndarray  #: d: the sphere's descent since it stood R_c above the block's top layer (first touch)
    force: np.ndarray  #: F: the contact force on the block (sum of V_i Contact_Force_Density_z)
    deep: np.ndarray  #: the descent of the block's point on the axis at depth z0 = R/4
    ring: np.ndarray  #: the mean descent of the block's 4 top-layer points at r1 = R/2 on the x and y axes
    top: np.ndarray  #: the descent of the block's top-centre point
    depth: float  #: z0 (m)
    ring_radius: float  #: r1 (m)
    law_error: float  #: at the end: |f_model - f_law| / |f_law| at the top-centre point (see Hertz.law_force)
    steps: int
    points: int
    bonds: int
    balance: float  #: the solver's largest relative energy balance error


@contextlib.contextmanager
def _folder() -> Iterator[Path]:
    with tempfile.TemporaryDirectory(prefix="peridyn-verify-contact-") as tmp:
        yield Path(tmp)


class Hertz(Problem):
    name = "hertz"
    title = "Hertz contact: a rigid sphere pressed into a peridynamic block through contact springs"
    M = 1.515  #: horizon / spacing of the block (its lattice is nearly isotropic, see ``isotropic``)
    R = 0.02  #: sphere radius (m)
    WIDTH = 1.0  #: block half-width / R
    DEPTH = 1.0  #: block depth / R
    D_MAX = 1.0 / 32.0  #: largest approach / R (Hertz's contact radius a = 0.18 R there)
    FIT_FROM = 0.3  #: the fits use the approaches from this fraction of the largest on
    Z0 = 0.25  #: depth of the reference point on the axis / R (a lattice point for R/h a multiple of 4)
    RING = 0.5  #: distance of the reference points on the surface from the axis / R
    SPRING = 100.0  #: Spring Constant / K
    CAP_SPACING = 1.0 / 3.0  #: spacing of the sphere's points / h
    TRANSITS = 8.0  #: the descent lasts this many P-wave transits of the block's depth
    SAFETY = 0.6  #: Fixed dt / the block's bond-only estimate
    resolution_name = "R/h"
    size_name = "h/R"
    error_name = "stiffness error"
    methods = ("Elastic Bond Based",)
    every_band = {"Elastic Bond Based": 0.10}
    finest_band = {"Elastic Bond Based": 0.07}
    rate_band = {"Elastic Bond Based": (0.6, 1.6)}
    ELASTIC_BAND = 0.03  #: |C_el / C_H - 1| at every point
    RING_BAND = 0.04  #: |C_el (ring) / C_H - 1| at every point
    EXPONENT_BAND = (1.45, 1.55)
    PENETRATION_RATE_BAND = (0.7, 1.5)
    LAW_BAND = 1.0e-9
    FALL_BAND = 0.9  #: the finest point's stiffness error / the coarsest's
    computes = (
        "A rigid sphere (radius R = 20 mm) pressed into an `Elastic Bond Based` block (K = 1 GPa, rho = 1000 kg/m^3, "
        f"horizon {M} h) through `Short Range Force` contact springs (Contact Radius R_c = h, Spring Constant k = 100 K), "
        "run by `Verlet` (one numba thread). The block: a lattice of spacing h = R/n, 2R wide and R deep, its bottom two "
        "layers held, top layer at z = 0. The sphere: points on the sphere of radius R over a cap 1.6 times Hertz's largest "
        "contact radius, at spacing h/3 (a square grid projected on it, volume (h/3)^2 h / cos(theta) each: a shell one "
        "spacing thick), moved as a rigid body by prescribed displacement from R_c above the top layer (the first touch) "
        "down d(t) = d_max (10 s^3 - 15 s^4 + 6 s^5), s = t/T, d_max = R/32, in T = 8 P-wave transits of the block's depth "
        "(Fixed dt 0.6 x the bond-only estimate). Every step records the contact force F on the block, the sphere's descent "
        "d, and the descents of the block's top-centre point (u_top), of its point on the axis at depth z0 = R/4 (u_deep) "
        "and of its 4 top-layer points at r1 = R/2 on the x and y axes (u_ring, their mean). A block held 1 R below is "
        "stiffer than Hertz's half-space, whose points move to infinity (column `raw C/C_H`: F against d itself), so the "
        "approach is measured from the point at depth z0, and the half-space's own descent there, u_H(z0, F) (Boussinesq "
        "integrated over Hertz's pressure), is added: d_hs = d - u_deep + u_H(z0); the block's own d_el = u_top - u_deep + "
        "u_H(z0) = d_hs - epsilon, epsilon = d - u_top the springs' penetration at the centre; and d_ring = u_top - "
        "u_ring + u_H(r1) (Hertz's surface descent at r1). Over d >= 0.3 d_max, F^(2/3) = C^(2/3) (d_hs - d0) is fitted by "
        "least squares: C the stiffness, d0 the offset of the first touch (column in h); C_el and C_el (ring) likewise from "
        "d_el and d_ring. Error: |C / C_H - 1|. Also: the exponent of F against d_hs (log-log, no offset), epsilon / d_max "
        "at the end, and the contact force on the top-centre point at the end against the law recomputed from the "
        "positions (`law error`). Wall time: set-up and run."
    )
    reference = (
        "Hertz (Johnson, Contact Mechanics, §3.4, 4.2): F = 4/3 E* sqrt(R_eff) d^(3/2) for a rigid sphere on an elastic "
        "half-space, a << R; outside the contact circle the surface descends (a^2 / (pi R))((2 - s^2) asin(1/s) + sqrt(s^2 "
        "- 1)), s = r/a. R_eff = R + R_c: the springs hold the block's points R_c from the sphere's points, so that is the "
        "surface they see. E* = 2 G / (1 - nu) of the block's lattice solid: bond-based peridynamics with the micromodulus "
        "18 K / (pi delta^4) on a cubic lattice at 1.515 spacings has C11 = 2.63 K, C12 = C44 = 0.769 K (`lattice_moduli`), "
        "nearly isotropic (Voigt and Reuss shear moduli 0.9 % apart): E* = 2.22 K, not the stated solid's 1.6 K (nu = "
        "1/4); at a fixed horizon/spacing the model converges to the lattice's solid. What a penalty contact cannot "
        "reproduce is hard contact: the springs let the bodies interpenetrate, by epsilon = p h pi m^5 / (2 k) here (one "
        "sphere point above each block point, pressure p, m = 1.515), O(h) against d. That penetration (8 % of d_max at "
        "R/h = 12, 3 % at 32) is most of the stiffness error, which falls with it (rate band 0.6 .. 1.6 with 3 points or "
        "more; the penetration's rate 0.7 .. 1.5; the finest error at most 0.9 of the coarsest; bands 10 % at every point, "
        "7 % at the finest). Removing it (C_el) leaves the elastic response, within 3 % of Hertz at every point (measured "
        "-1.8 % at R/h = 12, -0.6 % at 32). The reference point at z0 moves with the contact, so C and C_el do not see "
        "the run's dynamics much (8 to 24 transits: under 1 %) nor, much, the block's modulus, which scales its descent "
        "too (10 % stiffer: +3 %). C_el (ring) does (10 % stiffer: +7.6 %): within 4 % of Hertz at every point (measured "
        "-0.4 .. +1.4 %; at 8 transits it is about 2.5 % below its quasi-static value, and the penetration, largest at the centre, "
        "flattens the contact by about +epsilon/2d). The exponent must lie in 1.45 .. 1.55 (springs so soft that they carry "
        "the load make a Winkler foundation, F ~ d^2), and the law error must be round-off (1e-9): the force on a point is "
        "the sum over the points j of other bodies closer than R_c of (9 k / pi)(delta_i^-5 + delta_j^-5)(R_c - d_ij) V_i "
        "V_j along the line between them (PERIDIGM_CONTACT.md §4). Not reachable here: Hertz to 1 % in C needs a "
        "penetration under 1 % (R/h near 100, about 4e6 points, or springs 10 times stiffer and a step 2.4 times shorter), "
        "and d_max/R -> 0 (a = 0.18 R here; at d_max = R/16 C_el is 2.5 % lower)."
    )

    def ladder(self, method: str, quick: bool) -> list[float]:
        return [12.0, 16.0, 20.0] if quick else [12.0, 16.0, 20.0, 24.0, 32.0]

    # -- the model ---------------------------------------------------------------------------
    def elastic(self) -> tuple[float, float, float]:
        """(E* (Pa), nu, G (Pa)) of the block's lattice solid."""
        return isotropic(*lattice_moduli(self.M, K))

    def deck(self, n: int, folder: Path, spring: float | None = None) -> tuple[dict[str, Any], dict[str, float]]:
        """The deck tree at R/h = n, its ``Text File`` mesh written into ``folder`` (block 1: the
        block, block 2: the sphere), and the sizes the run needs (m, s)."""
        R = self.R
        h = R / n
        nw, nd = int(round(self.WIDTH * n)), int(round(self.DEPTH * n))
        g = np.arange(-nw, nw + 1) * h
        X, Y, Z = np.meshgrid(g, g, -np.arange(nd + 1) * h, indexing="ij")
        xb = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
        rc, d_max, s = h, self.D_MAX * R, self.CAP_SPACING * h
        cap = 1.6 * math.sqrt(R * d_max)
        k = int(math.ceil(cap / s))
        CX, CY = np.meshgrid(np.arange(-k, k + 1) * s, np.arange(-k, k + 1) * s, indexing="ij")
        cx, cy = CX.ravel(), CY.ravel()
        on = cx * cx + cy * cy <= cap * cap
        cx, cy = cx[on], cy[on]
        root = np.sqrt(R * R - cx * cx - cy * cy)
        lines = [f"{a!r} {b!r} {c!r} 1 {h**3!r}" for a, b, c in xb.tolist()]
        cz, vc = R + rc - root, s * s * h * R / root  # volume (h/3)^2 h / cos(theta)
        lines += [f"{a!r} {b!r} {c!r} 2 {v!r}" for a, b, c, v in zip(cx.tolist(), cy.tolist(), cz.tolist(), vc.tolist())]
        (folder / "points.txt").write_text("# x y z block volume\n" + "\n".join(lines) + "\n")
        nb = len(xb)
        held = np.flatnonzero(xb[:, 2] < -(nd - 1.5) * h)
        duration = self.TRANSITS * nd * h / math.sqrt(lattice_moduli(self.M, K)[0] / RHO)
        material = {"Material Model": "Elastic Bond Based", "Density": RHO, "Bulk Modulus": K}
        bcs: dict[str, Any] = {"Held Node Set": " ".join(str(i + 1) for i in held),
                               "Sphere Node Set": " ".join(str(i) for i in range(nb + 1, nb + len(cx) + 1))}
        for c in "xyz":
            bcs[f"Hold {c}"] = {"Type": "Prescribed Displacement", "Node Set": "Held Node Set", "Coordinate": c, "Value": "0.0"}
        for c in "xy":
            bcs[f"Sphere {c}"] = {"Type": "Prescribed Displacement", "Node Set": "Sphere Node Set", "Coordinate": c, "Value": "0.0"}
        t = f"(t/{duration!r})"
        bcs["Sphere z"] = {"Type": "Prescribed Displacement", "Node Set": "Sphere Node Set", "Coordinate": "z",
                           "Value": f"-{d_max!r}*(10*{t}^3-15*{t}^4+6*{t}^5)"}
        tree = {
            "Discretization": {"Type": "Text File", "Input Mesh File": "points.txt", "Omit Bonds Between Blocks": "All"},
            # the sphere moves as one rigid body: its density only keeps its points out of the step estimate
            "Materials": {"Block": material, "Sphere": dict(material, Density=1.0e6 * RHO)},
            "Blocks": {"Block": {"Block Names": "block_1", "Material": "Block", "Horizon": self.M * h},
                       "Sphere": {"Block Names": "block_2", "Material": "Sphere", "Horizon": self.M * h}},
            "Contact": {"Search Radius": 2.0 * rc, "Search Frequency": 100,
                        "Models": {"Springs": {"Contact Model": "Short Range Force", "Contact Radius": rc,
                                               "Spring Constant": (self.SPRING if spring is None else spring) * K}}},
            "Boundary Conditions": bcs,
        }
        return tree, {"h": h, "rc": rc, "d_max": d_max, "duration": duration, "ring": self.RING * R, "depth": self.Z0 * R}

    def indent(self, n: int, spring: float | None = None) -> Indentation:
        """Run the descent at R/h = n (``spring``: Spring Constant / K, default SPRING)."""
        with _folder() as folder, one_thread():
            tree, info = self.deck(n, folder, spring)
            sim = build_simulation(tree, directory=folder)
            dt = self.SAFETY * sim.critical_time_step()
            f, n_own = sim.fields, sim.num_owned
            x = f["Model_Coordinates"][:n_own]
            index = {b.name: k for k, b in enumerate(sim.blocks)}  # by mesh block name
            block = np.flatnonzero(sim.block_index[:n_own] == index["block_1"])
            cap = int(np.flatnonzero(sim.block_index[:n_own] == index["block_2"])[0])
            top = int(block[np.argmin(np.einsum("ij,ij->i", x[block], x[block]))])
            r1 = info["ring"]
            ring = [int(block[np.argmin(np.einsum("ij,ij->i", x[block] - q, x[block] - q))])
                    for q in np.array([[r1, 0.0, 0.0], [-r1, 0.0, 0.0], [0.0, r1, 0.0], [0.0, -r1, 0.0], [0.0, 0.0, -info["depth"]]])]
            ring, deep = ring[:4], ring[4]
            vol = f["Volume"][block]
            rows: list[tuple[float, float, float, float, float]] = []

            def record(t: float) -> None:
                u = f["Displacement"]
                force = -float(np.dot(f["Contact_Force_Density"][block, 2], vol))
                rows.append((-float(u[cap, 2]), force, -float(u[deep, 2]), -float(np.mean(u[ring, 2])), -float(u[top, 2])))

            # the harness reads every step, as an output would
            run_section(sim, Verlet(_section(info["duration"], {"Fixed dt": dt})), run=RunServices.reading(record))
            st = sim.stats["solvers"][-1]
            law = self.contact_law(sim, top, tree, info["rc"])
            model = f["Contact_Force_Density"][top] * f["Volume"][top]
            a = np.array(rows)
            return Indentation(info["h"], a[:, 0], a[:, 1], a[:, 2], a[:, 3], a[:, 4], float(-x[deep, 2]),
                               float(np.mean(np.linalg.norm(x[ring, :2], axis=1))),
                               float(np.linalg.norm(model - law) / max(float(np.linalg.norm(law)), 1e-300)), int(st["steps"]),
                               int(n_own), int(sim.bonds.num_bonds), float(st["energy"]["max_relative_error"]))

    def contact_law(self, sim: Any, i: int, tree: dict[str, Any], rc: float) -> np.ndarray:
        """The contact force (N) on point i that the deck's contact model must give (``law_force``)."""
        return self.law_force(sim, i, float(tree["Contact"]["Models"]["Springs"]["Spring Constant"]), rc)

    @staticmethod
    def law_force(sim: Any, i: int, spring: float, rc: float) -> np.ndarray:
        """The short-range force (N) on point i recomputed from the positions: the sum over the
        points j of other blocks closer than R_c of (9 k / pi)(delta_i^-5 + delta_j^-5)(R_c - d) V_i V_j
        along (y_i - y_j) / d (a pair is visited from both points, each visit with its point's horizon)."""
        n = sim.num_owned
        y, vol = sim.fields["Coordinates"][:n], sim.fields["Volume"][:n]
        horizon = np.array([float(b.horizon) for b in sim.blocks])[sim.block_index[:n]]
        e = y[i] - y
        d = np.linalg.norm(e, axis=1)
        near = (sim.block_index[:n] != sim.block_index[i]) & (d < rc)
        c = (9.0 * spring / math.pi) * (horizon[i] ** -5 + horizon[near] ** -5) * (rc - d[near]) * vol[i] * vol[near]
        return np.sum((c / d[near])[:, None] * e[near], axis=0)

    # -- the measurement ---------------------------------------------------------------------
    @staticmethod
    def stiffness(d: np.ndarray, F: np.ndarray) -> tuple[float, float]:
        """(C, d0) of the least-squares line F^(2/3) = C^(2/3) (d - d0) (N m^-3/2, m)."""
        slope, intercept = np.polyfit(d, F ** (2.0 / 3.0), 1)
        return float(slope) ** 1.5, -float(intercept) / float(slope)

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        n = int(resolution)
        run = self.indent(n)
        e_star, nu, G = self.elastic()
        h, d_max = run.spacing, self.D_MAX * self.R
        r_eff = self.R + h  # R_c = h
        c_h = 4.0 / 3.0 * e_star * math.sqrt(r_eff)
        sel = (run.approach >= self.FIT_FROM * d_max) & (run.force > 0.0)
        F = run.force[sel]
        u_deep = np.array([hertz_axis_displacement(float(q), run.depth, e_star, nu, G, r_eff) for q in F])
        d_hs = run.approach[sel] - run.deep[sel] + u_deep
        d_el = run.top[sel] - run.deep[sel] + u_deep
        u_ring = np.array([hertz_surface_displacement(float(q), run.ring_radius, e_star, r_eff) for q in F])
        C_ring, _ = self.stiffness(run.top[sel] - run.ring[sel] + u_ring, F)
        C, d0 = self.stiffness(d_hs, F)
        C_el, _ = self.stiffness(d_el, F)
        C_raw, _ = self.stiffness(run.approach[sel], F)
        a_max = (3.0 * float(run.force[-1]) * r_eff / (4.0 * e_star)) ** (1.0 / 3.0)
        values = {
            "C/C_H": C / c_h, "C_el/C_H": C_el / c_h, "C_el (ring)/C_H": C_ring / c_h, "raw C/C_H": C_raw / c_h,
            "exponent": float(np.polyfit(np.log(d_hs), np.log(F), 1)[0]),
            "exponent (block)": float(np.polyfit(np.log(d_el), np.log(F), 1)[0]),
            "offset d0/h": d0 / h, "penetration/d_max": float(run.approach[-1] - run.top[-1]) / d_max,
            "a/h at d_max": a_max / h, "a/delta": a_max / (self.M * h), "F (N) at d_max": float(run.force[-1]),
            "law error": run.law_error, "energy balance error": run.balance, "points": run.points, "bonds": run.bonds,
        }
        return Measurement(abs(C / c_h - 1.0), size=1.0 / n, steps=run.steps, values=values)

    def extra_checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        out = []
        for p in points:
            v, at = p["values"], f"at R/h = {p['resolution']:g}"
            out.append(Check(self.name, method, f"|C_el/C_H - 1| (the block's own descent, penetration removed) {at}",
                             abs(v["C_el/C_H"] - 1.0), high=self.ELASTIC_BAND))
            out.append(Check(self.name, method, f"|C_el (ring)/C_H - 1| (the modulus: the descent against the surface at R/2) {at}",
                             abs(v["C_el (ring)/C_H"] - 1.0), high=self.RING_BAND))
            out.append(Check(self.name, method, f"exponent of F against d {at}", v["exponent"], *self.EXPONENT_BAND))
            out.append(Check(self.name, method, f"contact force on the top-centre point against the law {at}", v["law error"],
                             high=self.LAW_BAND))
        if len(points) >= 2:
            out.append(Check(self.name, method, f"stiffness error at R/h = {points[-1]['resolution']:g} / at R/h = {points[0]['resolution']:g}",
                             points[-1]["error"] / points[0]["error"], high=self.FALL_BAND))
            rate = fit_rate([p["size"] for p in points], [p["values"]["penetration/d_max"] for p in points])
            out.append(Check(self.name, method, "fitted rate of the penetration/d_max in h/R", rate, *self.PENETRATION_RATE_BAND))
        return out


# ------------------------------------------------------------------------------------------------
# stability with stiff contact springs
# ------------------------------------------------------------------------------------------------
@dataclass
class Trial:
    """One run of :class:`ContactStability`. ``outcome``: ``stable`` (finished, finite, energy balance
    error at most SUSPECT_BALANCE = 3 %), ``inaccurate`` (finished, balance error above 3 %),
    ``stopped`` (InstabilityError; ``message`` its text, ``steps`` the step it names) or ``silent``
    (finished with a non-finite state, or with a balance error above 10 % at or below the estimate,
    where the set-up gave no warning, or above 100 % anywhere: the wrong answer this problem must
    never see). ``balance``:
    the larger of the solver's largest relative balance error and the problem's own account of
    the final state."""

    factor: float
    outcome: str
    steps: int
    balance: float = math.nan
    message: str = ""

    @property
    def stable(self) -> bool:
        return self.outcome == "stable"


class ContactStability(Stability):
    name = "contact-stability"
    title = "Largest stable Verlet step with stiff contact springs against the set-up estimate"
    kind = "table"
    plotted = False  # a stable ratio inside a band, not an error
    H = 1.0e-3  #: point spacing (m)
    CUBE = 6  #: points per side of each cube
    SPEED = 0.2  #: approach speed of each cube (m/s)
    BODY_FORCE = 1.6e10  #: N/m^3 pressing each cube towards the other
    #: physical time of every trial, in steps of the bond-only estimate
    LENGTH = {True: 300, False: 1000}
    HALVINGS = {True: 3, False: 6}
    SUSPECT_BALANCE = 0.03  #: the solver's SUSPECT_BALANCE_ERROR: above it a trial is not counted stable
    SILENT_BALANCE = 0.10  #: a trial at or below the estimate that finishes above this gave a wrong answer unwarned
    BLOWUP_BALANCE = 1.0  #: and one above the estimate (warned at set-up) that finishes above this
    RATIOS = {"k/K = 1": 1.0, "k/K = 10": 10.0, "k/K = 100": 100.0, "k/K = 1000": 1000.0}
    MATERIAL = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 130.0e9, "Shear Modulus": 78.0e9}
    methods = tuple(RATIOS)
    resolution_name = "horizon/spacing"
    size_name = "-"
    error_name = "stable ratio"
    computes = (
        "benchmarks/contact_stability.py's scene in-process: two `Elastic` steel cubes (K = 130 GPa, G = 78 GPa, rho = 7800 "
        "kg/m^3) of 6^3 points (Shapes, spacing 1 mm), not bonded, face to face with the facing points R_c = 1 mm apart, "
        "approaching at 0.2 m/s each and pressed together by a body force of 1.6e10 N/m^3, so that the `Short Range Force` "
        "springs (Spring Constant k = 1, 10, 100, 1000 times K: the contact micromodulus 18 k / (pi delta^4) against the "
        "bonds' 18 K / (pi delta^4)) act through the run. For each k/K and horizon/spacing, `Verlet` with a Fixed dt of "
        "ratio x the set-up estimate with the contact springs (`ContactManager.stable_time_step`, the step `peridyn run` "
        "suggests) runs for a physical time of 300 bond-only estimates (1000 without --quick; the runs near the limit grow "
        "slowly, so the limit found depends somewhat on it). A trial is stable when it finishes with finite values and an "
        "energy balance error of at most 3 % (the solver's own line for a trusted run), the larger of the solver's largest "
        "error over the run and this problem's own account of the final state: kinetic + stored energy (the contact "
        "springs' included) - the body force's work, against the initial kinetic energy. (The two differ near the limit: "
        "the solver integrates the stored energy from the forces' work, which Verlet's shadow energy keeps balanced.) The "
        "ratio is bisected (3 halvings; 6 without --quick) between 1 and 3 when the estimate is stable, else between 0 and "
        "1. Verlet's check before the first step is off, so that the runs decide. Columns: the estimate against the "
        "bond-only one, the largest stable and smallest unstable ratio, how the trial at the estimate and the smallest "
        "unstable one ended, and how many trials stopped (InstabilityError), stopped naming the contact springs, ended "
        "inaccurate (balance error above 3 %) or silently."
    )
    reference = (
        "The estimate: dt_i = sqrt(2 rho / (sum_bonds V_j c / |xi| + 18 k P_i / (0.81 pi delta^5))), P_i the partner volume "
        "of a deep contact (docs/contact.md, *The time step*). It is an estimate, not a bound: benchmarks/contact_stability.md "
        "measured 0.75 to 2.3 times it. So the check is that each k/K either runs stable at the estimate (largest stable "
        "ratio >= 1), or the run at the estimate stops with an InstabilityError whose message names the contact springs "
        "(ContactManager.diagnosis: a smaller Safety Factor or softer springs); and that no trial ends silently: finished "
        "with a non-finite value, or at or below the estimate (where the set-up does not warn) with a balance error above "
        "10 %, or above it with one above 100 % (a blow-up let finish); and that every stopped trial names the contact "
        "springs. Above the estimate the set-up warns that the step "
        "is too long for the springs, so a trial there that finishes inaccurate is warned, not silent (k/K = 100 at 3.015 "
        "spacings: 1.625 x the estimate finishes with its energy 13 % off while the solver's own balance reads 0.5 %). A "
        "monitor that let an unstable run finish, or a diagnosis that did not say what to change, fails these checks."
    )

    def ladder(self, method: str, quick: bool) -> list[float]:
        return [1.515] if quick else [1.515, 3.015]

    def tree(self, ratio: float, hf: float) -> dict[str, Any]:
        """The deck tree: k = ``ratio`` K, horizon ``hf`` spacings, no solver."""
        h, n = self.H, self.CUBE
        shapes = {"Left": {"Shape": "Box", "Block": "block_1", "Min": [0.0, 0.0, 0.0], "Max": [n * h, n * h, n * h], "Spacing": h},
                  "Right": {"Shape": "Box", "Block": "block_2", "Min": [n * h, 0.0, 0.0], "Max": [2 * n * h, n * h, n * h], "Spacing": h}}
        bcs: dict[str, Any] = {}
        for side, sign in (("Left", 1), ("Right", -1)):
            bcs[f"Approach {side}"] = {"Type": "Initial Velocity", "Node Set": side, "Coordinate": "x", "Value": str(sign * self.SPEED)}
            bcs[f"Push {side}"] = {"Type": "Body Force", "Node Set": side, "Coordinate": "x", "Value": str(sign * self.BODY_FORCE)}
        return {
            "Discretization": {"Type": "Shapes", "Omit Bonds Between Blocks": "All", "Shapes": shapes},
            "Materials": {"Steel": dict(self.MATERIAL)},
            "Blocks": {"Cubes": {"Block Names": "block_1 block_2", "Material": "Steel", "Horizon": hf * h}},
            "Contact": {"Search Radius": (hf + 1.0) * h, "Search Frequency": 100,
                        "Models": {"Springs": {"Contact Model": "Short Range Force", "Contact Radius": h,
                                               "Spring Constant": ratio * float(self.MATERIAL["Bulk Modulus"])}}},
            "Boundary Conditions": bcs,
        }

    def trial(self, ratio: float, hf: float, factor: float, quick: bool) -> Trial:
        """One run at ``factor`` times the estimate with the contact springs."""
        sim = build_simulation(self.tree(ratio, hf))
        dt = factor * sim.contact.stable_time_step()
        steps = int(self.LENGTH[quick] * sim.critical_time_step() / dt)
        solver = Verlet(_section(steps * dt * (1.0 + 1e-9), {"Fixed dt": dt}))
        solver.MEASURE_ABOVE = math.inf  # the runs decide, not the set-up check
        kinetic0 = sim.kinetic_energy()  # the initial velocities are set at set-up
        try:
            run_section(sim, solver)
        except InstabilityError as exc:
            at = re.search(r"at step (\d+)", str(exc))
            return Trial(factor, "stopped", int(at.group(1)) if at else steps, message=str(exc))
        # the solver's largest balance error, and this problem's own account of the final state (not the
        # solver's): kinetic + stored (contact springs included) - the body force's work, against the start
        f = sim.fields
        with np.errstate(all="ignore"):
            work = float(np.sum(f["Volume"][:, None] * f["External_Force_Density"] * f["Displacement"]))
            kinetic, stored = sim.kinetic_energy(), sim.stored_energy()
            scale = max(kinetic0, abs(kinetic), abs(stored), abs(work))
            end = abs(kinetic + stored - work - kinetic0) / scale
        balance = max(float(sim.stats["solvers"][-1]["energy"]["max_relative_error"]), end)
        if not math.isfinite(end):
            return Trial(factor, "silent", steps, balance)
        if balance <= self.SUSPECT_BALANCE:
            return Trial(factor, "stable", steps, balance)
        # above the estimate the set-up has warned that the step is too long for the contact springs; an error
        # larger than all the energy present is a blow-up that finished, warned or not
        silent = balance > (self.SILENT_BALANCE if factor <= 1.0 else self.BLOWUP_BALANCE)
        return Trial(factor, "silent" if silent else "inaccurate", steps, balance)

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        ratio = self.RATIOS[method]
        trials: list[Trial] = []

        def stable(factor: float) -> bool:
            trials.append(self.trial(ratio, resolution, factor, quick))
            return trials[-1].stable

        with quiet("peridyn.solver", "peridyn.engine", "peridyn.solvers", "peridyn.contact"), one_thread():
            sim = build_simulation(self.tree(ratio, resolution))
            bond, estimate = sim.critical_time_step(), sim.contact.stable_time_step()
            lo, hi = (self.LOW, self.HIGH) if stable(self.LOW) else (0.0, self.LOW)
            if lo == self.LOW and stable(hi):
                lo = hi
            if lo < hi:
                for _ in range(self.HALVINGS[quick]):
                    mid = 0.5 * (lo + hi)
                    lo, hi = (mid, hi) if stable(mid) else (lo, mid)
        first, bad = trials[0], [t for t in trials if not t.stable]
        lowest = min(bad, key=lambda t: t.factor) if bad else None

        def ended(t: Trial) -> str:
            return f"stopped at step {t.steps}" if t.outcome == "stopped" else f"{t.outcome} (balance {t.balance:.2g})"

        values = {
            "estimate / bond-only estimate": estimate / bond, "largest stable ratio": lo, "smallest unstable ratio": hi if hi > lo else None,
            "at the estimate": ended(first), "smallest unstable ended": ended(lowest) if lowest else None,
            "trials": len(trials), "stopped": sum(t.outcome == "stopped" for t in trials),
            "stopped naming the contact springs": sum(t.outcome == "stopped" and "contact springs" in t.message for t in trials),
            "inaccurate": sum(t.outcome == "inaccurate" for t in trials), "silent": sum(t.outcome == "silent" for t in trials),
            "worst balance of a stable trial": max((t.balance for t in trials if t.stable), default=None),
            "diagnosis at the estimate": _diagnosis(first.message),
        }
        return Measurement(None, steps=sum(t.steps for t in trials), values=values)

    def checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        out = []
        for p in points:
            v, at = p["values"], f"at horizon/spacing {p['resolution']:g}"
            ratio = float(v["largest stable ratio"])
            named = v["at the estimate"].startswith("stopped") and v["diagnosis at the estimate"] == "names the contact springs"
            ok = ratio >= 1.0 or named
            diagnosis = v["diagnosis at the estimate"]
            shown = (f"stable at the estimate (largest stable ratio {ratio:.3g})" if ratio >= 1.0 else
                     f"unstable at the estimate (largest stable ratio {ratio:.3g}); {v['at the estimate']}, "
                     + ("naming the contact springs" if named else f"diagnosis: {diagnosis}" if diagnosis else "no diagnosis"))
            out.append(Check(self.name, method, f"the run at the estimate {at}", 1.0 if ok else 0.0, low=1.0, shown=shown,
                             expect="stable, or stopped naming the contact springs"))
            unclear = int(v["silent"]) + int(v["stopped"]) - int(v["stopped naming the contact springs"])
            what = ("trials ended silently (non-finite; balance error > 10 % at or below the estimate, > 100 % above it) "
                    f"or stopped without naming the contact springs {at}")
            out.append(Check(self.name, method, what, float(unclear), high=0.0))
        return out


def _diagnosis(message: str) -> str:
    """How an InstabilityError's message ends for this problem ('' for none)."""
    if not message:
        return ""
    return "names the contact springs" if "contact springs" in message else message[-200:]
