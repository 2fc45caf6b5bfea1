"""Implicit time integration (``newmark-energy``): the order in time and the energy balance of
Peridigm's ``Implicit`` solver (Newmark-beta, average acceleration) on a smooth problem (the cube of
``verlet-energy`` at 1 m/s for 2e-4 s), with velocity Verlet at the same steps beside it."""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ...solvers.implicit.newmark import Implicit, ImplicitSection
from ...testing import build_simulation, cube_deck
from ...engine.session import run_section
from .base import Check, Measurement, Problem
from .dynamics import VerletEnergy

if TYPE_CHECKING:
    from ...engine.simulation import Simulation


class NewmarkEnergy(Problem):
    name = "newmark-energy"
    title = "Implicit Newmark (average acceleration): order in time and energy balance"
    #: final time (s) and initial velocity amplitude (m/s): ``verlet-energy``'s problem as it was
    #: before that problem moved to a longer run at a small amplitude for its exact modal reference
    T_END = 2.0e-4
    V0 = 1.0
    #: Newmark's parameters: the average acceleration (trapezoidal) rule, Peridigm's defaults
    BETA = 0.25
    GAMMA = 0.5
    #: Newton stops when the residual beta dt^2 (rho a - f) is below beta dt^2 rho times this
    #: acceleration (m/s^2) per unknown (root mean square): ~1e-6 of the largest acceleration of the run (70 m/s^2)
    ACCELERATION_TOLERANCE = 1.0e-4
    #: the reference runs velocity Verlet with this many times the finest point's steps
    REFERENCE_FACTOR = 16
    computes = (
        "The problem `verlet-energy` ran before it moved to its modal reference (a cube of n^3 points, spacing 1 m, "
        "horizon 3.015 m, n = 6 with --quick and 8 otherwise, K = 1 GPa, rho = 1000 kg/m^3, `Elastic` with G = 0.6 GPa, started with v_x = sin(pi y / n) "
        "m/s) run to t = 2e-4 s with the `Implicit` solver (Newmark beta = 1/4, gamma = 1/2, Peridigm's "
        "defaults; Belos CG; Newton to a residual of beta dt^2 rho 1e-4 m/s^2 per unknown) in 4 to 32 steps "
        "(--quick) or 4 to 128. Point volumes are 1 m^3, so Peridigm's Jacobian (which mixes force and force "
        "density) is exact. Error: max |u - u_ref| / max |u_ref| over all points and components, as in "
        "`verlet-energy`. Energy balance: |kinetic + stored energy at the end - kinetic energy at the start| / "
        "the largest of them (no work is done). Wall time: the solver's run, set-up excluded; the same for the "
        "velocity Verlet run at the same dt beside each point (Verlet error, Verlet wall), so that the two "
        "integrators can be put on the same axes of error against wall time."
    )
    reference = (
        "u_ref: velocity Verlet with a step 16 times smaller than the finest point's (its error is about 1/500 "
        "of the finest Newmark error; it is not in the table). Newmark's average acceleration rule is second "
        "order: the error falls as dt^2 (band 1.8 .. 2.2; gamma > 1/2 makes it first order). For a mode "
        "x'' = -omega^2 x started from x = 0 with velocity v0, its error is -(omega dt)^2 v0 t cos(omega t) / 12 (a "
        "pure phase error: the amplitude is exact), velocity Verlet's (omega dt)^2 v0 (sin(omega t) / (8 omega) + "
        "t cos(omega t) / 24): over this short run (omega t <= 0.3 for every mode of the model, by power iteration) Newmark's error "
        "is about -1/2 times Verlet's, mode by mode (-2 only after many periods). The error ratio "
        "-(e_N . e_V) / (e_V . e_V) (e = u - u_ref over all points and components) at the finest dt must lie in "
        "0.4 .. 0.6. The rule conserves the energy of a linear system exactly (the model is linear up to strains "
        "of ~1e-4): the relative balance error at the finest dt must stay below 1e-9. Other Newmark parameters "
        "fail these bands: gamma = 0.6, beta = 0.3025 (numerical damping) gives a rate of 1.1, an error ratio of "
        "10 and loses 3e-5 of the energy; beta = 1/6 (linear acceleration) an error ratio of 0.0004 and an "
        "energy error of 1e-8."
    )
    resolution_name = "steps"
    size_name = "dt (s)"
    error_name = "relative displacement error"
    methods = VerletEnergy.methods
    companions = {"velocity Verlet at the same dt": ("Verlet error", "Verlet wall (s)")}
    rate_band = {m: (1.8, 2.2) for m in methods}
    ENERGY_BAND = 1.0e-9
    RATIO_BAND = (0.4, 0.6)

    def __init__(self) -> None:
        self._verlet = VerletEnergy()
        self._verlet.T_END, self._verlet.V0 = self.T_END, self.V0  # Verlet beside it runs this problem
        self._reference: dict[tuple[str, bool], np.ndarray] = {}

    def ladder(self, method: str, quick: bool) -> list[float]:
        return [4.0, 8.0, 16.0, 32.0] if quick else [4.0, 8.0, 16.0, 32.0, 64.0, 128.0]

    def simulation(self, method: str, quick: bool) -> "Simulation":
        """The model (``verlet-energy``'s) and initial velocity (m/s), ready to run."""
        n = 6 if quick else 8
        sim = build_simulation(cube_deck(self._verlet.material(method), n=n))
        x = sim.fields["Model_Coordinates"]
        sim.fields["Velocity"][:] = self._verlet.initial_velocity(np.array(x), n)
        return sim

    def newmark(self, method: str, steps: int, quick: bool) -> tuple[np.ndarray, dict[str, Any], float]:
        """Run the `Implicit` solver in ``steps`` steps: the final displacement (m), the solver's
        stats and the relative energy balance error."""
        sim = self.simulation(method, quick)
        dt = self.T_END / steps
        unknowns = 3 * sim.num_global
        tol = self.BETA * dt * dt * float(sim.density_per_point().max()) * self.ACCELERATION_TOLERANCE * math.sqrt(unknowns)
        section = ImplicitSection.model_validate({
            "Initial Time": 0.0, "Final Time": self.T_END * (1 + 1e-12),
            "Implicit": {"Fixed dt": dt, "Beta": self.BETA, "Gamma": self.GAMMA, "Absolute Tolerance": tol,
                         "Maximum Solver Iterations": 10}})
        start = sim.kinetic_energy()  # no displacement yet: nothing is stored
        run_section(sim, Implicit(section))
        stats = sim.stats["solvers"][-1]
        if int(stats["steps"]) != steps or not math.isclose(sim.clock.time, self.T_END, rel_tol=1e-9):
            raise RuntimeError(f"the Implicit solver ran {stats['steps']} steps to t = {sim.clock.time} (expected {steps} to {self.T_END})")
        kinetic, stored = sim.kinetic_energy(), sim.stored_energy()
        balance = abs(kinetic + stored - start) / max(start, abs(kinetic), abs(stored), 1e-300)
        return sim.fields["Displacement"].copy(), stats, balance

    def reference_displacement(self, method: str, quick: bool) -> np.ndarray:
        """u_ref (m): velocity Verlet in REFERENCE_FACTOR times the finest point's steps (cached)."""
        key = (method, quick)
        if key not in self._reference:
            steps = int(self.REFERENCE_FACTOR * self.ladder(method, quick)[-1])
            self._reference[key] = self._verlet.run(method, steps, quick)[0]
        return self._reference[key]

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        steps = int(resolution)
        ref = self.reference_displacement(method, quick)
        scale = float(np.abs(ref).max())
        u, stats, balance = self.newmark(method, steps, quick)
        err = float(np.abs(u - ref).max()) / scale
        uv, vstats = self._verlet.run(method, steps, quick)
        verlet = float(np.abs(uv - ref).max()) / scale
        e_n, e_v = (u - ref).ravel(), (uv - ref).ravel()
        ratio = -float(np.dot(e_n, e_v)) / float(np.dot(e_v, e_v)) if np.any(e_v) else math.nan
        return Measurement(err, size=self.T_END / steps, steps=steps, values={
            "energy balance error": balance,
            "Newton iterations": int(stats["nonlinear_iterations"]),
            "Verlet error": verlet,
            "error ratio -(e_N.e_V)/(e_V.e_V)": ratio,
            "Verlet wall (s)": float(vstats["wall"]),
            "wall (s)": float(stats["wall"]),
        })

    def extra_checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        p = points[-1]
        lo, hi = self.RATIO_BAND
        return [
            Check(self.name, method, f"relative energy balance error at the finest dt ({int(p['resolution'])} steps)",
                  p["values"]["energy balance error"], high=self.ENERGY_BAND),
            Check(self.name, method, f"error ratio -(e_N . e_V) / (e_V . e_V), Newmark against Verlet, at the finest dt "
                  f"({int(p['resolution'])} steps)", p["values"]["error ratio -(e_N.e_V)/(e_V.e_V)"], lo, hi),
        ]
