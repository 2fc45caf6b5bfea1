"""A stable Verlet run whose energy account ends far off is Verlet's answer to the deck (as
Peridigm's) and is not stopped, but the run says so and names the step that brings the error to
about 1 %; an accurate run says nothing."""
from __future__ import annotations

import logging

import numpy as np

from peridyn.solvers.explicit.verlet import Verlet, VerletSection
from peridyn.testing import build_simulation, cube_deck
from peridyn.engine.session import run_section

LPS = {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1.0e9, "Shear Modulus": 0.6e9}


def impact(n: int, ratio: float, safety: float, steps: int = 120):
    """An n^3 cube (spacing 1 mm) whose x = max face starts at -1 m/s, run ``steps`` Verlet steps."""
    sim = build_simulation(cube_deck(LPS, n=n, spacing=1e-3, horizon_factor=ratio))
    x = sim.fields["Model_Coordinates"]
    sim.fields["Velocity"][x[:, 0] > x[:, 0].max() - 5e-4, 0] = -1.0
    dt = sim.critical_time_step() * safety
    section = VerletSection.model_validate({"Initial Time": 0.0, "Final Time": steps * dt * (1 + 1e-9), "Verlet": {"Safety Factor": safety}})
    run_section(sim, Verlet(section))
    return sim


def warnings(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if "energy of the run was off" in r.getMessage()]


def test_a_body_no_larger_than_its_horizon_at_half_the_estimate_names_the_step_that_fixes_it(caplog):
    """5^3 points, horizon 6 spacings: stable (limit 0.97 x the estimate), energy about half off at
    half the estimate; the Safety Factor the warning names brings it to a few percent."""
    with caplog.at_level(logging.WARNING, logger="peridyn.solver"):
        sim = impact(5, 6.0, 0.5)
    worst = sim.stats["solvers"][-1]["energy"]["max_relative_error"]
    said = warnings(caplog)
    assert worst > 0.2 and len(said) == 1 and f"{100 * worst:.1f}%" in said[0]
    factor = float(said[0].split("'Safety Factor' of ")[1].split()[0])
    assert factor < 0.5
    caplog.clear()
    better = impact(5, 6.0, factor, steps=int(120 * 0.5 / factor))
    assert better.stats["solvers"][-1]["energy"]["max_relative_error"] < 0.05 and np.all(np.isfinite(better.fields["Velocity"]))


def test_an_ordinary_impact_at_a_small_step_says_nothing(caplog):
    with caplog.at_level(logging.WARNING, logger="peridyn.solver"):
        sim = impact(7, 3.015, 0.25, steps=240)
    assert sim.stats["solvers"][-1]["energy"]["max_relative_error"] < 0.03 and not warnings(caplog)
