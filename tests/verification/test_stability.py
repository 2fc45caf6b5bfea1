"""Stability: energy conservation, a run that goes unstable stops with a diagnosis, and stiff
and extreme cases with clear outcomes."""
import logging

import numpy as np
import pytest

from peridyn.engine.run_services import RunServices
from peridyn.core.errors import InstabilityError
from peridyn.solvers.explicit.verlet import Verlet, VerletSection
from peridyn.testing import build_simulation, cube_deck
from peridyn.engine.session import run_section

ELASTIC = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 130.0e9, "Shear Modulus": 78.0e9}


def verlet(sim, final_time=None, steps=None, run=None, **method):
    if steps is not None:
        dt = sim.critical_time_step() * method.get("Safety Factor", 1.0) if "Fixed dt" not in method else method["Fixed dt"] * method.get("Safety Factor", 1.0)
        final_time = steps * dt * (1 + 1e-9)
    section = VerletSection.model_validate({"Initial Time": 0.0, "Final Time": final_time, "Verlet": method})
    run_section(sim, Verlet(section), run=run)
    return sim.stats["solvers"][-1]


def total_energy(sim) -> float:
    sim.evaluate_forces()
    return sim.kinetic_energy() + sim.stored_energy()


def kick_face(sim, speed=5.0):
    """An impact: the x = max face starts moving inward (a non-smooth initial condition)."""
    x = sim.fields["Model_Coordinates"]
    face = x[:, 0] > x[:, 0].max() - 0.5 * (x[1, 0] - x[0, 0] if len(x) > 1 else 1.0)
    sim.fields["Velocity"][face, 0] = -speed
    return face


@pytest.mark.parametrize("material", [ELASTIC, {"Material Model": "Elastic Bond Based", "Density": 7800.0, "Bulk Modulus": 130.0e9}])
def test_energy_drift_below_one_percent_over_1000_steps(material):
    sim = build_simulation(cube_deck(material, n=6, spacing=1e-3))
    x = sim.fields["Model_Coordinates"]
    sim.fields["Velocity"][:] = 2.0 * np.sin(np.pi * x[:, [1, 2, 0]] / 6e-3)
    e0 = total_energy(sim)
    stats = verlet(sim, steps=1000, **{"Safety Factor": 0.7})
    assert stats["steps"] == 1000
    drift = abs(total_energy(sim) - e0) / e0
    assert drift < 0.01, drift
    # the cheap running balance of the monitor agrees with the exact energies
    assert abs(stats["energy"]["balance_error"]) < 0.01 * e0


@pytest.fixture
def unmeasured(monkeypatch):
    """Verlet without the set-up check against the measured stable step, so that the monitor
    meets the blow-up."""
    monkeypatch.setattr(Verlet, "MEASURE_ABOVE", float("inf"))


def test_time_step_three_times_the_estimate_stops_within_50_steps(tmp_path, unmeasured):
    extra = {"Output": {"Output Filename": "unstable", "Output Frequency": 5, "Output Variables": {"Displacement": True, "Velocity": True}}}
    sim = build_simulation(cube_deck(ELASTIC, n=6, spacing=1e-3, extra=extra), output_dir=tmp_path)
    kick_face(sim)
    run = RunServices.of(sim)
    with pytest.raises(InstabilityError) as info:
        verlet(sim, final_time=1.0, run=run, **{"Safety Factor": 3.0})
    run.close()
    msg = str(info.value)
    step = int(msg.split("at step ")[1].split()[0])
    assert step <= 50, msg
    assert "point" in msg and ("grew" in msg or "non-finite" in msg or "stability limit of the vibrations" in msg)
    assert "Safety Factor" in msg and "3.00 times the stable estimate" in msg
    from peridyn.io.exodus_reader import read_results

    frames = read_results(tmp_path / "unstable.e")["times"]
    assert len(frames) >= 1 and np.all(np.diff(frames) > 0)


def test_non_finite_values_stop_the_run_at_once():
    """A body force that is NaN stops the run before it reaches a field, naming the condition."""
    tree = cube_deck(ELASTIC, n=3)
    tree["Boundary Conditions"] = {"All Node Set": " ".join(str(i) for i in range(1, 28)), "Push": {"Type": "Body Force", "Node Set": "All Node Set", "Coordinate": "x", "Value": "sqrt(x - 1000.0)"}}
    sim = build_simulation(tree)
    with pytest.raises(InstabilityError, match=r"Push: the value 'sqrt\(x - 1000.0\)' is nan at the point .* at t = 0"):
        verlet(sim, steps=10, **{"Safety Factor": 0.5})
    assert np.isfinite(sim.fields["External_Force_Density"]).all()


def test_safety_factor_above_one_warns_but_runs(caplog):
    """The LPS cube's measured limit is about 1.3 times the estimate (its surfaces stiffen it):
    1.2 runs, with a warning that names the measured limit."""
    sim = build_simulation(cube_deck(ELASTIC, n=6, spacing=1e-3))
    kick_face(sim, 1.0)
    with caplog.at_level(logging.WARNING, logger="peridyn.solver"):
        stats = verlet(sim, steps=200, **{"Safety Factor": 1.2})
    assert any("Safety Factor" in r.getMessage() and "no bound" in r.getMessage() for r in caplog.records)
    assert stats["steps"] == 200 and stats["energy"]["max_relative_error"] < 0.25


def test_a_safety_factor_above_the_measured_limit_is_stopped_before_the_first_step():
    """1.4 times the estimate is past the small LPS cube's stable limit (power iteration on its
    forces proves a vibration with w dt > 2): stopped before step 1, naming the limit."""
    sim = build_simulation(cube_deck(ELASTIC, n=4, spacing=1e-3))
    kick_face(sim, 1.0)
    u0 = sim.fields["Displacement"].copy()
    with pytest.raises(InstabilityError, match=r"would go unstable from its first step: .* above the stable limit measured on the model") as info:
        verlet(sim, steps=100, **{"Safety Factor": 1.4})
    limit = float(str(info.value).split("Safety Factor' below ")[1].split()[0])
    assert 1.0 < limit < 1.4
    assert np.array_equal(sim.fields["Displacement"], u0)  # nothing ran, the probe left no trace


# -- stiff and extreme cases -------------------------------------------------------------------
def run_impact(tree, steps=300, sf=0.7):
    """An impact at safety factor 0.7 for ``steps`` steps. The non-smooth start excites the
    highest modes, for which velocity Verlet's energy oscillates by O((omega dt)^2), a few
    percent here (the monitor's trapezoidal work estimate adds an error of the same order); an
    unstable run grows without bound, so 10 % (15 % for the monitor) separates the two."""
    sim = build_simulation(tree)
    kick_face(sim, 1.0)
    e0 = total_energy(sim)
    stats = verlet(sim, steps=steps, **{"Safety Factor": sf})
    assert stats["steps"] == steps
    assert abs(total_energy(sim) - e0) / e0 < 0.10
    assert stats["energy"]["max_relative_error"] < 0.15
    return sim, stats, e0


def test_nearly_incompressible_material_is_stable():
    """K/G = 1000: the time step estimate uses K, so the run stays stable."""
    material = {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1.0e12, "Shear Modulus": 1.0e9}
    run_impact(cube_deck(material, n=6, spacing=1e-3))


@pytest.mark.parametrize("ratio,neighbors", [(1.01, 6), (6.0, None)])
def test_extreme_horizon_to_spacing_ratios_are_stable(ratio, neighbors):
    tree = cube_deck(ELASTIC, n=6 if ratio < 2 else 8, spacing=1e-3, horizon_factor=ratio)
    sim, stats, e0 = run_impact(tree)
    if neighbors is not None:
        assert sim.bonds.counts().max() == neighbors
    else:
        assert sim.bonds.counts().max() > 400


def test_fifty_percent_compression_completes_without_instability():
    """One face pushed in by half the cube's length; the opposite face held."""
    n, h = 6, 1e-3
    tree = cube_deck(ELASTIC, n=n, spacing=h)
    ids = np.arange(n**3).reshape(n, n, n)  # [z, y, x] with x fastest
    left = " ".join(str(i + 1) for i in ids[:, :, 0].ravel())
    right = " ".join(str(i + 1) for i in ids[:, :, -1].ravel())
    t_end = 2e-4
    tree["Boundary Conditions"] = {
        "Left Node Set": left,
        "Right Node Set": right,
        "Hold": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": "x", "Value": "0.0"},
        "Push": {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "x", "Value": f"-{0.5 * (n - 1) * h}*t/{t_end}"},
    }
    sim = build_simulation(tree)
    stats = verlet(sim, final_time=t_end, **{"Safety Factor": 0.7})
    x = sim.fields["Model_Coordinates"][:, 0]
    u = sim.fields["Displacement"][:, 0]
    right_face = x > x.max() - 0.5 * h
    np.testing.assert_allclose(u[right_face], -0.5 * (n - 1) * h, rtol=1e-3)
    assert np.all(np.isfinite(sim.fields["Velocity"]))
    assert stats["energy"]["max_relative_error"] < 0.05


def test_point_without_neighbors_moves_freely(tmp_path, caplog):
    mesh = tmp_path / "mesh.txt"
    rows = [f"{i * 1e-3} 0 0 1 1e-9" for i in range(4)] + ["1.0 1.0 1.0 1 1e-9"]
    mesh.write_text("\n".join(rows) + "\n")
    tree = {
        "Discretization": {"Type": "Text File", "Input Mesh File": "mesh.txt"},
        "Materials": {"M": ELASTIC},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": 1.5e-3}},
        "Boundary Conditions": {"Lonely Node Set": "5", "Go": {"Type": "Initial Velocity", "Node Set": "Lonely Node Set", "Coordinate": "y", "Value": "2.0"}},
    }
    with caplog.at_level(logging.WARNING, logger="peridyn.engine"):
        sim = build_simulation(tree, directory=tmp_path)
    assert any("no neighbors" in r.getMessage() for r in caplog.records)
    stats = verlet(sim, steps=100, **{"Safety Factor": 0.7})
    lonely = np.nonzero(sim.gid == 4)[0][0]
    np.testing.assert_allclose(sim.fields["Displacement"][lonely], [0.0, 2.0 * sim.clock.time, 0.0], rtol=1e-12)
    assert np.all(sim.fields["Force_Density"][lonely] == 0.0)


def test_micrometre_horizon_in_si_units():
    """delta = 1e-6 m: neighbor search, time step (~1e-11 s) and forces all work at this scale."""
    tree = cube_deck(ELASTIC, n=5, spacing=1e-6 / 3.015)
    sim = build_simulation(tree)
    assert sim.bonds.counts().max() > 100
    dt = sim.critical_time_step()
    assert 1e-12 < dt < 1e-10
    run_impact(tree, steps=200)


# -- blow-ups that break bonds -------------------------------------------------------------------
def pulled_plate(nx=30, ny=15, nz=3, spacing=1.0e-3):
    """A brittle glass plate (critical stretch 0.0015) pulled apart by its ends at 5 m/s each,
    the quickstart at a quarter of its points."""
    from peridyn.testing import node_set_ids

    glass = {"Material Model": "Elastic", "Density": 2440.0, "Young's Modulus": 72.0e9, "Poisson's Ratio": 0.22}
    tree = cube_deck(glass, shape=(nx, ny, nz), spacing=spacing, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 0.0015})
    left = node_set_ids(tree, lambda x: x[:, 0] < 3 * spacing)
    right = node_set_ids(tree, lambda x: x[:, 0] > (nx - 3) * spacing)
    tree["Boundary Conditions"] = {
        "Left Node Set": left,
        "Right Node Set": right,
        "Pull Left": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": "x", "Value": "-5.0*t"},
        "Pull Right": {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "x", "Value": "5.0*t"},
    }
    return build_simulation(tree)


@pytest.mark.parametrize("factor", [2.0, 3.0, 5.0])
def test_a_blow_up_that_shatters_a_damaged_plate_is_stopped(factor, unmeasured):
    """Bonds break as the run blows up, so the kinetic energy does not double step after step
    and the balance closes; the energy created from nothing still shows."""
    sim = pulled_plate()
    with pytest.raises(InstabilityError, match="appeared that no load supplied|kinetic energy grew|non-finite|stability limit of the vibrations|exceeds all the energy"):
        verlet(sim, final_time=4.0e-5, **{"Safety Factor": factor})


def test_the_created_energy_test_is_what_catches_it(monkeypatch, unmeasured):
    """Without the created-energy criterion the damaged blow-up at three times the stable step
    runs to the end (the failure the criterion was made for)."""
    from peridyn.solvers.monitors.energy import EnergyMonitor

    monkeypatch.setattr(EnergyMonitor, "created_fraction", float("inf"))
    monkeypatch.setattr(EnergyMonitor, "unstable_ratio", float("inf"))  # the rules that need no history
    monkeypatch.setattr(EnergyMonitor, "excess", float("inf"))
    sim = pulled_plate()
    stats = verlet(sim, final_time=4.0e-5, **{"Safety Factor": 3.0})
    v = np.abs(sim.fields["Velocity"]).max()
    assert v > 100.0  # shattered: a stable run moves at about 10 m/s
    assert stats["energy"]["stored_from_work"] < 0  # kinetic energy from nowhere


@pytest.mark.parametrize("factor", [0.5, 0.8, 1.0])
def test_stable_damaged_runs_raise_no_false_alarm(factor):
    sim = pulled_plate()
    stats = verlet(sim, final_time=4.0e-5, **{"Safety Factor": factor})
    assert np.abs(sim.fields["Velocity"]).max() < 50.0
    assert stats["energy"]["max_relative_error"] < 0.02
