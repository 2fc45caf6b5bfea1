"""A stable Verlet run whose energy account is off by more than 10 % ends as a diagnosis (exit 3),
not as a result: exit 0 means the answer can be trusted."""
from __future__ import annotations

import numpy as np
import pytest

from peridyn.core.errors import InstabilityError
from peridyn.solvers.common import INACCURATE_BALANCE_ERROR
from peridyn.solvers.verlet import Verlet, VerletSection
from peridyn.testing import build_simulation, cube_deck

LPS = {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1.0e9, "Shear Modulus": 0.6e9}


def impact(n: int, ratio: float, safety: float, steps: int = 120):
    """An n^3 cube (spacing 1 mm) whose x = max face starts at -1 m/s, run ``steps`` Verlet steps."""
    sim = build_simulation(cube_deck(LPS, n=n, spacing=1e-3, horizon_factor=ratio))
    x = sim.fields["Model_Coordinates"]
    sim.fields["Velocity"][x[:, 0] > x[:, 0].max() - 5e-4, 0] = -1.0
    dt = sim.critical_time_step() * safety
    section = VerletSection.model_validate({"Initial Time": 0.0, "Final Time": steps * dt * (1 + 1e-9), "Verlet": {"Safety Factor": safety}})
    Verlet(section).run(sim)
    return sim


def test_a_body_no_larger_than_its_horizon_at_half_the_estimate_is_diagnosed_not_done():
    """5^3 points, horizon 6 spacings: stable (limit 0.97 x the estimate) but its energy is off by
    about half at half the estimate: the run must not end as a trusted answer."""
    with pytest.raises(InstabilityError, match=r"energy was off by up to .*'Safety Factor' of"):
        impact(5, 6.0, 0.5)


def test_the_same_body_at_a_small_enough_step_is_a_result():
    sim = impact(5, 6.0, 0.05, steps=1200)
    e = sim.stats["solvers"][-1]["energy"]
    assert e["max_relative_error"] < INACCURATE_BALANCE_ERROR and np.all(np.isfinite(sim.fields["Velocity"]))


def test_an_ordinary_impact_at_the_default_factor_is_a_result():
    sim = impact(7, 3.015, 0.8)
    assert sim.stats["solvers"][-1]["energy"]["max_relative_error"] < INACCURATE_BALANCE_ERROR
