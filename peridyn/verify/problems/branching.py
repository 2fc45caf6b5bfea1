"""Validation against experiment: ``glass-branching``, dynamic crack branching in a pre-cracked
soda-lime glass plate under a sudden traction on its long edges (the experiments of Bowden,
Brunton, Field & Heyes 1967 and Döll 1975; the set-up of Ha & Bobaru 2010, Int. J. Fract. 162,
229): a crack runs from the pre-crack's tip at about half the Rayleigh speed and splits into two
symmetric branches.

Units: SI throughout (m, s, kg, Pa, J/m^2)."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from .base import Check, Measurement, Problem
from .experiments import CrackHistory, rayleigh_speed, recorded_run

GL_E = 72.0e9  #: Young's modulus (Pa) of soda-lime glass
GL_RHO = 2440.0  #: density (kg/m^3)
GL_G0 = 3.8  #: fracture energy (J/m^2)
GL_TRACTION = 2.0e6  #: the traction (Pa) on the top and bottom edges, applied at t = 0 and held
GL_LENGTH = 0.100  #: plate length along the pre-crack, x in [0, 100 mm] (m)
GL_HALF_HEIGHT = 0.020  #: half the 40 mm height, y in [-20, 20] mm (m)
GL_CRACK = 0.050  #: the pre-crack: y = 0, x <= 50 mm (m)
#: the Rayleigh speed (m/s) of the bond-based plane-stress glass (nu = 1/3)
GL_RAYLEIGH = rayleigh_speed(GL_E, 1.0 / 3.0, GL_RHO)


def glass_deck(dx: float, *, m: float = 3.0, g0: float = GL_G0, traction: float = GL_TRACTION) -> tuple[dict[str, Any], dict[str, float]]:
    """The glass plate (m): one layer of points of spacing ``dx`` (m; plane stress, thickness dx),
    x in [0, 100 mm], y in [-20, 20 mm]; the pre-crack is the plane y = 0 for x <= 50 mm, across
    which no bond exists. The traction ``traction`` (Pa) pulls the top row of points (+y) and the
    bottom row (-y) as a body force density traction / dx (N/m^3) on a row one spacing deep, from
    t = 0 on: the total force on each edge is exactly traction x length x thickness. Material:
    ``Elastic Bond Based`` plane stress, E = 72 GPa, rho = 2440 kg/m^3; damage ``Critical Energy``
    with G_0 = ``g0`` (J/m^2). Horizon delta = ``m`` dx (times 1.005)."""
    if abs(GL_HALF_HEIGHT / dx - round(GL_HALF_HEIGHT / dx)) > 1e-6 or abs(GL_LENGTH / dx - round(GL_LENGTH / dx)) > 1e-6:
        raise ValueError(f"the spacing {dx!r} must divide the plate's 20 mm and 100 mm")
    h = dx
    delta = m * dx * 1.005
    box = lambda lo, hi: {"Shape": "Box", "Block": "block_1", "Min": [lo[0], lo[1], 0.0], "Max": [hi[0], hi[1], h], "Spacing": dx}  # noqa: E731
    top, bottom = GL_HALF_HEIGHT, -GL_HALF_HEIGHT
    shapes = {
        "Plate": box((0.0, bottom + dx), (GL_LENGTH, top - dx)),
        "Top": box((0.0, top - dx), (GL_LENGTH, top)),
        "Bottom": box((0.0, bottom), (GL_LENGTH, bottom + dx)),
    }
    crack = {"Type": "Rectangular_Plane", "Normal_X": 0.0, "Normal_Y": 1.0, "Normal_Z": 0.0,
             "Lower_Left_Corner_X": -dx, "Lower_Left_Corner_Y": 0.0, "Lower_Left_Corner_Z": -h,
             "Bottom_Unit_Vector_X": 1.0, "Bottom_Unit_Vector_Y": 0.0, "Bottom_Unit_Vector_Z": 0.0,
             "Bottom_Length": GL_CRACK + dx, "Side_Length": 3 * h}
    b = repr(traction / dx)
    tree = {
        "Discretization": {"Type": "Shapes", "Shapes": shapes, "Bond Filters": {"Pre-crack": crack}},
        "Materials": {"Glass": {"Material Model": "Elastic Bond Based", "Density": GL_RHO, "Young's Modulus": GL_E,
                                "Plane Stress": True, "Height": h}},
        "Damage Models": {"D": {"Damage Model": "Critical Energy", "Critical Energy": g0}},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "Glass", "Damage Model": "D", "Horizon": delta}},
        "Boundary Conditions": {
            "Pull up": {"Type": "Body Force", "Node Set": "Top", "Coordinate": "y", "Value": b},
            "Pull down": {"Type": "Body Force", "Node Set": "Bottom", "Coordinate": "y", "Value": "-" + b},
            **{f"Z {k}": {"Type": "Prescribed Displacement", "Node Set": k, "Coordinate": "z", "Value": "0.0"} for k in shapes},
        },
    }
    return tree, {"dx": dx, "delta": delta, "h": h}


def crack_tip(x: np.ndarray, damage: np.ndarray, dx: float, threshold: float = 0.3) -> float:
    """The farthest x (m) reached by the damaged points (damage above ``threshold``) connected to
    the pre-crack's tip (by steps of at most 1.5 ``dx``); the pre-crack's end when none is."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    sel = np.flatnonzero(damage > threshold)
    if sel.size == 0:
        return GL_CRACK
    pairs = cKDTree(x[sel, :2]).query_pairs(1.5 * dx, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(sel.size, sel.size))
    _, label = connected_components(graph, directed=False)
    near = np.hypot(x[sel, 0] - GL_CRACK, x[sel, 1]) <= 2.0 * dx
    keep = np.isin(label, np.unique(label[near]))
    return float(max(GL_CRACK, x[sel[keep], 0].max())) if keep.any() else GL_CRACK


def branches(x: np.ndarray, damage: np.ndarray, dx: float, at: float, threshold: float = 0.3) -> int:
    """How many separate cracks cross the line x = ``at`` (m): runs of consecutive rows (gaps of
    at most one spacing) among the points within dx/2 of the line whose damage is above
    ``threshold``."""
    col = np.abs(x[:, 0] - at) <= 0.5 * dx + 1e-12
    ys = np.sort(x[col & (damage > threshold), 1])
    if ys.size == 0:
        return 0
    return int(1 + np.count_nonzero(np.diff(ys) > 2.5 * dx))


def asymmetry(x: np.ndarray, damage: np.ndarray, dx: float, threshold: float = 0.3) -> float:
    """The fraction of damaged points (damage above ``threshold``) whose mirror image in y = 0 is
    not damaged: 0 for a crack pattern symmetric about the pre-crack's plane."""
    from scipy.spatial import cKDTree

    hit = damage > threshold
    if not hit.any():
        return 0.0
    mirror = x[:, :2] * np.array([1.0, -1.0])
    dist, j = cKDTree(x[:, :2]).query(mirror[hit])
    paired = (dist < 0.25 * dx) & hit[j]
    return float(1.0 - paired.mean())


@dataclass
class BranchingRun:
    """One run of :func:`glass_deck`: the crack tip's history, the crack pattern at the end, and
    run statistics."""

    history: CrackHistory
    tip: float  #: the crack's farthest x at the end (m)
    branch_x: float  #: the first x (m) from which two cracks cross every line x up to the tip less 2 delta; NaN if none
    branches_end: int  #: cracks crossing the line 2 delta behind the tip at the end
    asymmetry: float
    points: int
    steps: int
    dt: float
    wall: float
    delta: float


class GlassBranching(Problem):
    name = "glass-branching"
    title = "Dynamic crack branching in soda-lime glass: crack speed and branching against experiment"
    kind = "table"
    T_END = 46.0e-6  #: s (Ha & Bobaru's run)
    M = 3.0  #: horizon / spacing
    SAFETY = 0.8  #: time step / the set-up estimate
    #: the measured crack speed (m/s) before branching: Bowden et al. (1967) 1580 m/s, the value Ha & Bobaru
    #: (2010) compare with; the band is +-5 % about it, which holds the ~1500 m/s of Döll (1975) and Schardin's
    #: terminal speed in soda-lime glass (no error bars are quoted: this is the spread of the measurements)
    MEASURED_SPEED = 1580.0
    SPEED_BAND = (1500.0, 1660.0)
    SPEED_MISS = (
        "the bond-based plane-stress model runs 14 % (dx = 0.5 mm) and 20 % (0.25 mm) slower than the experiment and "
        "moves away from it as dx falls: the horizon is held at 3.015 dx, so delta shrinks with dx and the process zone "
        "with it. What it would take is not known yet: a delta held fixed while dx falls (m-convergence), glass's own "
        "nu = 0.22 (the bond-based plane-stress solid has 1/3; an LPS or correspondence plate), and a fracture energy "
        "with the measured rate dependence are the candidates, none tried here")
    #: the branch point must lie ahead of the pre-crack's tip by at least this (m) and the cracks reach this far
    BRANCH_AFTER = 0.005
    ASYMMETRY_BAND = 0.05
    computes = (
        "The plate of Ha & Bobaru (2010): 100 mm x 40 mm, a pre-crack 50 mm long on the centre line from the left edge "
        "(a plane across which no bond exists), one layer of `Elastic Bond Based` plane-stress points of spacing dx "
        "(E = 72 GPa, rho = 2440 kg/m^3, the bond-based plane-stress nu = 1/3), horizon delta = 3.015 dx, `Critical "
        "Energy` damage with G_0 = 3.8 J/m^2. A traction of 2 MPa pulls the top and bottom edges apart from t = 0 on "
        "(a body force density traction / dx on the edge rows: the total force is exact). Velocity Verlet (0.8 times the "
        "set-up step) to 46 us. Recorded every 10 steps: the crack tip, the farthest x of the damaged points (damage "
        "> 0.3) connected to the pre-crack's tip. Crack speed: mean over the tip's advance from 5 to 20 mm. Branching: "
        "the first x from which two separate cracks cross every vertical line up to 2 delta behind the final tip; "
        "symmetry: the fraction of damaged points whose mirror image in the centre line is not damaged. Rows: points "
        "across the plate's 40 mm height (40 mm / dx)."
    )
    reference = (
        "Experiment (Bowden et al. 1967; Döll 1975, as Ha & Bobaru 2010 compare with): the crack runs at about 1580 m/s, "
        "near half the Rayleigh speed, and branches into two cracks symmetric about the pre-crack's line. The Rayleigh "
        f"speed here is that of the model's own solid (bond-based plane stress, nu = 1/3): {GL_RAYLEIGH:.0f} m/s. Ha & "
        "Bobaru's bond-based runs give about 1700 m/s before branching and one symmetric branch, with more branches at "
        "higher tractions. Measured here: 1364 m/s (0.45 c_R) and a branch point at x = 69 mm at dx = 0.5 mm, 1257 m/s "
        "(0.41 c_R) and 65 mm at dx = 0.25 mm, two cracks symmetric to the last point in both. Bands, every point: mean speed "
        "1500 .. 1660 m/s (the measurements' spread about 1580 m/s; a **known miss**, reported and not counted: the model is "
        "14 .. 20 % slow and slower with refinement); two cracks at the end, the branch point at "
        "least 5 mm ahead of the pre-crack's tip; at most 5 % of the damaged points without a damaged mirror image. "
        "A traction 4 times smaller grows no crack in 46 us (no branch: FAIL)."
    )
    resolution_name = "40 mm / dx"
    size_name = "dx/40 mm"
    error_name = "|speed / 1580 m/s - 1|"
    methods = ("bond-based, plane stress",)
    method_materials = {"bond-based, plane stress": "Elastic Bond Based"}

    def __init__(self, traction: float = GL_TRACTION) -> None:
        self.traction = traction

    def ladder(self, method: str, quick: bool) -> list[float]:
        return [80.0] if quick else [80.0, 160.0]

    def run(self, across: float, *, every: int = 10) -> BranchingRun:
        """Run the plate with ``across`` points across its 40 mm height (dx = 40 mm / across),
        recording the crack tip every ``every`` steps."""
        dx = 2.0 * GL_HALF_HEIGHT / across
        tree, g = glass_deck(dx, m=self.M, traction=self.traction)
        history = CrackHistory()

        def record(sim, t: float) -> None:
            n = sim.num_owned
            history.times.append(t)
            history.lengths.append(crack_tip(sim.fields["Model_Coordinates"][:n], sim.fields["Damage"][:n], dx) - GL_CRACK)

        t0 = time.perf_counter()
        sim, dt = recorded_run(tree, self.SAFETY, self.T_END, every, record)
        wall = time.perf_counter() - t0
        n = sim.num_owned
        x = sim.fields["Model_Coordinates"][:n]
        st = sim.stats["solvers"][-1]
        damage = sim.fields["Damage"][:n]
        tip = crack_tip(x, damage, dx)
        delta = g["delta"]
        end = tip - 2.0 * delta
        lines = np.arange(GL_CRACK + dx, end + 0.5 * dx, dx)
        counts = np.array([branches(x, damage, dx, a) for a in lines], dtype=int)
        two = np.flatnonzero(counts < 2)  # the last line with fewer than two cracks
        branch_x = math.nan
        if counts.size and counts[-1] >= 2:
            branch_x = float(lines[two[-1] + 1]) if two.size else float(lines[0])
        return BranchingRun(history, tip, branch_x, int(counts[-1]) if counts.size else 0, asymmetry(x, damage, dx), n,
                            int(st["steps"]), dt, wall, delta)

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        r = self.run(resolution)
        speed = r.history.speed(0.005, 0.020)
        ratio = speed / GL_RAYLEIGH
        return Measurement(abs(speed / self.MEASURED_SPEED - 1.0), size=1.0 / resolution, steps=r.steps, values={
            "points": r.points, "dx (mm)": 1e3 * 2 * GL_HALF_HEIGHT / resolution, "dt (s)": r.dt,
            "crack speed (m/s)": speed, "crack speed / c_R": ratio, "tip at the end (mm)": 1e3 * r.tip,
            "branch point (mm)": 1e3 * r.branch_x, "cracks behind the tip": r.branches_end,
            "asymmetry": r.asymmetry, "wall (s)": r.wall})

    def checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        out: list[Check] = []
        num = lambda v: math.nan if v is None else float(v)  # noqa: E731 - JSON's null is NaN
        for p in points:
            v, at = p["values"], f"{self.resolution_name} = {p['resolution']:g}"
            out.append(Check(self.name, method, f"mean crack speed (m/s) against the measured ~{self.MEASURED_SPEED:g} at {at}",
                             num(v["crack speed (m/s)"]), *self.SPEED_BAND, known=self.SPEED_MISS))
            out.append(Check(self.name, method, f"cracks 2 delta behind the final tip at {at}", num(v["cracks behind the tip"]),
                             2.0, 2.0, expect="2"))
            out.append(Check(self.name, method, f"branch point ahead of the pre-crack's tip (mm) at {at}",
                             num(v["branch point (mm)"]) - 1e3 * GL_CRACK, low=1e3 * self.BRANCH_AFTER))
            out.append(Check(self.name, method, f"damaged points without a damaged mirror image at {at}", num(v["asymmetry"]),
                             high=self.ASYMMETRY_BAND))
        return out
