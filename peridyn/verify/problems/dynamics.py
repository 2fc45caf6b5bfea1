"""Problems on explicit time integration: velocity Verlet's order of convergence and its
energy account (``verlet-energy``) and the largest stable time step against the set-up
estimate (``stability``)."""
from __future__ import annotations

import contextlib
import logging
import math
from typing import Any

import numpy as np

from ...core.errors import InstabilityError
from ...solvers.stable_step import measured_stable_step
from ...solvers.verlet import Verlet, VerletSection
from ...testing import build_simulation, cube_deck
from .base import Check, Measurement, Problem, simulation

K = 1.0e9  # Pa


@contextlib.contextmanager
def quiet(*names: str):
    """Within the block, the named loggers pass errors only (a stability search runs above the
    estimate on purpose and would warn at every trial)."""
    loggers = [logging.getLogger(n) for n in names]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.ERROR)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


def _section(final_time: float, method: dict[str, Any]) -> VerletSection:
    return VerletSection.model_validate({"Initial Time": 0.0, "Final Time": final_time, "Verlet": method})


def energy_scale(e: dict[str, float]) -> float:
    """The energy scale of a run's account (J): the largest of the kinetic energies, the stored
    energy and the work done, as ``peridyn run`` reports it."""
    return max(abs(e["kinetic_initial"]), abs(e["kinetic"]), abs(e["stored_from_work"]),
               abs(e["external_work"]) + abs(e["constraint_work"]), 1e-300)


class VerletEnergy(Problem):
    name = "verlet-energy"
    title = "Velocity Verlet: order in time and energy balance"
    T_END = 2.0e-4  # s
    computes = (
        "A cube of n^3 points (spacing 1 m, horizon 3.015 m; n = 6 with --quick, 8 otherwise), K = 1 GPa, "
        "rho = 1000 kg/m^3 (`Elastic`: G = 0.6 GPa), started with the smooth shear velocity "
        "v_x = sin(pi y / n) m/s and run with velocity Verlet and a fixed step dt to t = 2e-4 s. "
        "Error: max |u - u_ref| / max |u_ref| over all points and components. The solver's energy account "
        "(kinetic + stored energy against the work done) gives the relative balance error at the end of "
        "each run. Wall time: the run (set-up excluded). With `--device gpu`, the curves marked (GPU) are the same runs on "
        "the GPU backend, against the same reference (the CPU's): their error must fall at the same rate and their "
        "wall time shows what a GPU does with a model this small (a few hundred points: each step is kernel launches)."
    )
    reference = (
        "u_ref: the same run with a step 16 times smaller than the finest point's (its own wall time is not "
        "in the table). Velocity Verlet is second order: the error falls as dt^2 (band 1.8 .. 2.2). The exact "
        "energy balance holds for the continuous motion; the discrete one closes to O(dt^2) as well, and its "
        "relative error at the finest step must stay below 1e-4."
    )
    resolution_name = "steps"
    size_name = "dt (s)"
    error_name = "relative displacement error"
    methods = ("Elastic", "Elastic Bond Based")
    gpu_methods = methods
    rate_band = {m: (1.8, 2.2) for m in methods}
    ENERGY_BAND = 1.0e-4

    def __init__(self) -> None:
        self._reference: dict[tuple[str, bool], np.ndarray] = {}

    def ladder(self, method: str, quick: bool) -> list[float]:
        return [16.0, 32.0, 64.0, 128.0] if quick else [16.0, 32.0, 64.0, 128.0, 256.0]

    def material(self, method: str) -> dict[str, Any]:
        mat = {"Material Model": method, "Density": 1000.0, "Bulk Modulus": K}
        if method == "Elastic":
            mat["Shear Modulus"] = 0.6 * K
        return mat

    def run(self, method: str, steps: int, quick: bool) -> tuple[np.ndarray, dict[str, Any]]:
        n = 6 if quick else 8
        tree = cube_deck(self.material(method), n=n)
        section = {"Initial Time": 0.0, "Final Time": self.T_END * (1 + 1e-12), "Verlet": {"Fixed dt": self.T_END / steps}}
        sim = simulation(dict(tree, Solver=section))  # the deck names its solver: the GPU's set-up checks it has a GPU path
        x = sim.fields["Model_Coordinates"]
        sim.fields["Velocity"][:, 0] = np.sin(np.pi * x[:, 1] / n)
        Verlet(VerletSection.model_validate(section)).run(sim)
        return sim.fields["Displacement"].copy(), sim.stats["solvers"][-1]

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        key = (method, quick)
        if key not in self._reference:
            finest = self.ladder(method, quick)[-1]
            self._reference[key] = self.run(method, int(16 * finest), quick)[0]
        ref = self._reference[key]
        u, stats = self.run(method, int(resolution), quick)
        wall = float(stats["wall"])  # the solver's own: set-up excluded
        e = stats["energy"]
        balance = abs(e["balance_error"]) / energy_scale(e)
        err = float(np.abs(u - ref).max() / np.abs(ref).max())
        return Measurement(err, size=self.T_END / resolution, steps=int(stats["steps"]),
                           values={"energy balance error": balance,
                                   "worst balance error": e["max_relative_error"], "wall (s)": wall})

    def extra_checks(self, method, points, quick):
        p = points[-1]
        return [Check(self.name, method, f"relative energy balance error at the finest dt ({int(p['resolution'])} steps)",
                      p["values"]["energy balance error"], high=self.ENERGY_BAND)]


class Stability(Problem):
    name = "stability"
    title = "Largest stable Verlet time step against the set-up estimate"
    kind = "table"
    computes = (
        "An impact on a cube of 10^3 points (spacing 1 mm; 8^3 with --quick): the x = max face starts at "
        "-1 m/s, which excites the highest modes. For each material and horizon/spacing ratio, the largest "
        "`Safety Factor` (time step / Peridigm's estimate) whose run stays stable for 2000 steps (1000 with "
        "--quick) is found by bisection (7 halvings; 4 with --quick) between 1 and 3: a run is unstable "
        "when the solver's energy monitor stops it (InstabilityError) or a velocity is not finite. Verlet's "
        "own check before the first step (power iteration on the forces) is switched off for the trials, "
        "so that the runs decide; its bound is reported beside them."
    )
    reference = (
        "The set-up estimate dt_crit = min_i sqrt(2 rho / sum_j V_j c / |xi_ij|) (Peridigm's; "
        "`Simulation.critical_time_step`). It must be safe: the ratio of the largest stable step to it must "
        "be at least 1 (a FAIL otherwise). The ratio is the interval [largest stable, smallest unstable]; "
        "the power-iteration bound (`solvers/stable_step.py`) is an upper bound of the true limit."
    )
    resolution_name = "horizon/spacing"
    size_name = "-"
    error_name = "stable ratio"
    MATERIALS: dict[str, dict[str, Any]] = {
        "Elastic Bond Based": {"Material Model": "Elastic Bond Based", "Density": 7800.0, "Bulk Modulus": 130.0e9},
        "Elastic": {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 130.0e9, "Shear Modulus": 78.0e9},
        "Elastic, K/G = 1000": {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1.0e12, "Shear Modulus": 1.0e9},
        "Elastic Correspondence": {"Material Model": "Elastic Correspondence", "Density": 7800.0, "Bulk Modulus": 130.0e9,
                                   "Shear Modulus": 78.0e9, "Hourglass Coefficient": 0.02},
    }
    methods = tuple(MATERIALS)
    LOW, HIGH = 1.0, 3.0

    def ladder(self, method: str, quick: bool) -> list[float]:
        return [3.015] if quick else [1.515, 3.015, 5.015]

    def _stable(self, method: str, factor: float, ratio: float, quick: bool) -> tuple[bool, int]:
        sim = build_simulation(cube_deck(self.MATERIALS[method], n=8 if quick else 10, spacing=1e-3, horizon_factor=ratio))
        x = sim.fields["Model_Coordinates"]
        sim.fields["Velocity"][x[:, 0] > x[:, 0].max() - 5e-4, 0] = -1.0
        steps = 1000 if quick else 2000
        dt = sim.critical_time_step() * factor
        solver = Verlet(_section(steps * dt * (1 + 1e-9), {"Safety Factor": factor}))
        solver.MEASURE_ABOVE = math.inf  # the runs decide, not the set-up check
        try:
            solver.run(sim)
        except InstabilityError:
            return False, int(sim.stats["solvers"][-1]["steps"]) if sim.stats.get("solvers") else 0
        return bool(np.all(np.isfinite(sim.fields["Velocity"]))), steps

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        with quiet("peridyn.solver", "peridyn.engine", "peridyn.solvers"):
            sim = build_simulation(cube_deck(self.MATERIALS[method], n=8 if quick else 10, spacing=1e-3, horizon_factor=resolution))
            estimate = sim.critical_time_step()
            bound = measured_stable_step(sim, estimate)[0] / estimate
            total = 0
            ok, n = self._stable(method, self.LOW, resolution, quick)
            total += n
            if not ok:  # the estimate is unsafe: how far below it does the limit lie
                lo, hi = 0.0, self.LOW
            else:
                lo, hi = self.LOW, self.HIGH
                ok, n = self._stable(method, hi, resolution, quick)
                total += n
                if ok:
                    lo = hi
            if lo < hi:
                for _ in range(4 if quick else 7):
                    mid = 0.5 * (lo + hi)
                    ok, n = self._stable(method, mid, resolution, quick)
                    total += n
                    lo, hi = (mid, hi) if ok else (lo, mid)
        return Measurement(None, steps=total, values={"estimate (s)": estimate, "largest stable ratio": lo,
                                                       "smallest unstable ratio": hi if hi > lo else None,
                                                       "power-iteration bound": bound})

    def checks(self, method, points, quick):
        return [Check(self.name, method, f"largest stable step / estimate at horizon/spacing {p['resolution']:g}",
                      p["values"]["largest stable ratio"], low=1.0) for p in points]
