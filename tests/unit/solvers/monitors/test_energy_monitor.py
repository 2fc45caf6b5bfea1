"""The explicit solvers' stability rules (solvers/monitors/energy.py EnergyMonitor, solvers/monitors/stable_step.py,
Verlet's step count): a blow-up, an empty run or a run past the stable limit never ends with
exit 0, also when it lasts a few steps; stable runs raise no alarm."""
import math

import netCDF4
import numpy as np
import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode, InstabilityError
from peridyn.deck.files import dump_yaml
from peridyn.solvers.monitors.energy import EnergyMonitor
from peridyn.solvers.monitors.stable_step import measured_stable_step
from peridyn.solvers.explicit.verlet import Verlet, VerletSection
from peridyn.testing import build_simulation, cube_deck, node_set_ids
from peridyn.engine.session import run_section

ELASTIC = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 130.0e9, "Shear Modulus": 78.0e9}
BOND_BASED = {"Material Model": "Elastic Bond Based", "Density": 7800.0, "Bulk Modulus": 130.0e9}


def verlet(sim, steps, **method):
    dt = method.get("Fixed dt", sim.critical_time_step()) * method.get("Safety Factor", 1.0)
    section = VerletSection.model_validate({"Initial Time": 0.0, "Final Time": steps * dt * (1 + 1e-9), "Verlet": method})
    run_section(sim, Verlet(section))
    return sim.stats["solvers"][-1]


@pytest.fixture
def unmeasured(monkeypatch):
    """Without the check against the measured stable step: the monitor alone."""
    monkeypatch.setattr(Verlet, "MEASURE_ABOVE", math.inf)


def bar_deck(final_time=2.0e-5, verlet_params=None, **top):
    """A 12 x 3 x 3 steel bar struck at one end, as a deck file tree."""
    tree = cube_deck(ELASTIC, shape=(12, 3, 3), spacing=1.0e-3)
    tree["Boundary Conditions"] = {
        "Struck Node Set": node_set_ids(tree, lambda x: x[:, 0] < 1.0e-3),
        "Strike": {"Type": "Initial Velocity", "Node Set": "Struck Node Set", "Coordinate": "x", "Value": "10.0"},
    }
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": final_time, "Verlet": verlet_params or {"Safety Factor": 0.8}}
    tree["Output"] = {"Output Filename": "bar", "Output Frequency": 1, "Output Variables": {"Displacement": True, "Velocity": True}}
    tree.update(top)
    return tree


def bar_sim():
    """The bar as a model, without its output section (nothing written)."""
    tree = bar_deck()
    del tree["Output"]
    return build_simulation(tree)


def run(tmp_path, tree, *args) -> int:
    deck = tmp_path / "deck.yaml"
    deck.write_text(dump_yaml(tree))
    return main(["run", str(deck), "--output-dir", str(tmp_path), "--no-progress", *args])


# -- blow-ups of a few steps -------------------------------------------------------------------
def test_a_four_step_run_far_above_the_stable_step_ends_with_exit_3_and_finite_output(tmp_path, capsys):
    sim = bar_sim()
    dt = 1660.0 * sim.critical_time_step()
    assert run(tmp_path, bar_deck(final_time=4.5 * dt, verlet_params={"Fixed dt": dt})) == ExitCode.UNSTABLE
    err = capsys.readouterr().err
    assert "unstable" in err and "Fixed dt" in err
    with netCDF4.Dataset(tmp_path / "bar.e") as ds:
        for name, var in ds.variables.items():
            if name.startswith("vals_nod_var"):
                assert np.isfinite(var[:]).all()


@pytest.mark.parametrize("ratio", [3.0, 30.0, 1660.0])
def test_the_monitor_alone_stops_a_blow_up_at_the_first_steps(unmeasured, ratio):
    sim = bar_sim()
    sim.fields["Velocity"][sim.fields["Model_Coordinates"][:, 0] < 1e-3, 0] = 10.0
    with pytest.raises(InstabilityError, match="stability limit of the vibrations|kinetic energy grew|non-finite") as info:
        verlet(sim, 4, **{"Safety Factor": ratio})
    step = int(str(info.value).split("at step ")[1].split()[0])
    assert step <= (4 if ratio < 10 else 1)


def test_without_the_new_rules_a_short_blow_up_ended_done(unmeasured, monkeypatch):
    """The failure the rules were made for: a 4-step run at 30 times the estimate completed."""
    monkeypatch.setattr(EnergyMonitor, "unstable_ratio", math.inf)
    monkeypatch.setattr(EnergyMonitor, "excess", math.inf)
    sim = bar_sim()
    sim.fields["Velocity"][sim.fields["Model_Coordinates"][:, 0] < 1e-3, 0] = 10.0
    stats = verlet(sim, 4, **{"Safety Factor": 30.0})
    assert stats["energy"]["kinetic"] > 1e6 * stats["energy"]["kinetic_initial"]


def test_a_stable_run_with_a_large_energy_error_ends_with_a_warning(unmeasured, caplog):
    """The bar struck at one end at the estimate's step: stable (the measured limit is above the
    step), its energy oscillating by about the strike's energy: Verlet's answer, warned about."""
    import logging

    sim = bar_sim()
    limit, _ = measured_stable_step(sim, 1e-9, iterations=40)
    assert limit > 1.05 * sim.critical_time_step()
    sim.fields["Velocity"][sim.fields["Model_Coordinates"][:, 0] < 1e-3, 0] = 10.0
    with caplog.at_level(logging.WARNING, logger="peridyn.solver"):
        stats = verlet(sim, 200, **{"Safety Factor": 1.0})
    assert stats["steps"] == 200 and stats["energy"]["resolution"] > 0.5
    assert any("energy of the run was off by up to" in r.getMessage() for r in caplog.records)


def test_a_smaller_step_runs_the_struck_bar_to_its_end(unmeasured):
    sim = bar_sim()
    sim.fields["Velocity"][sim.fields["Model_Coordinates"][:, 0] < 1e-3, 0] = 10.0
    stats = verlet(sim, 100, **{"Safety Factor": 0.5})
    assert stats["steps"] == 100 and stats["energy"]["resolution"] < 0.5


def test_kinetic_energy_from_an_untracked_source_is_stopped(unmeasured, monkeypatch):
    """Velocity that appears without work (here injected each step) exceeds the supply."""
    sim = build_simulation(cube_deck(ELASTIC, n=4, spacing=1e-3))
    sim.fields["Velocity"][:, 0] = 1.0
    real = type(sim).load_data

    def inject(self, t):
        real(self, t)
        self.fields["Velocity"][:, 1] += 0.5

    monkeypatch.setattr(type(sim), "load_data", inject)
    with pytest.raises(InstabilityError, match="exceeds all the energy the initial state and the loads supplied"):
        verlet(sim, 20, **{"Safety Factor": 0.5})


def test_without_an_energy_account_a_kinetic_energy_that_grows_a_thousandfold_per_step_is_stopped(unmeasured):
    material = dict(ELASTIC, **{"Thermal Expansion Coefficient": 1.0e-5})
    tree = cube_deck(material, n=4, spacing=1e-3)
    tree["Boundary Conditions"] = {"All Node Set": " ".join(str(i) for i in range(1, 65)),
                                   "Heat": {"Type": "Prescribed Temperature", "Node Set": "All Node Set", "Value": "100.0"}}
    sim = build_simulation(tree)
    sim.fields["Velocity"][sim.fields["Model_Coordinates"][:, 0] < 1e-3, 0] = 1.0
    with pytest.raises(InstabilityError, match="kinetic energy grew|non-finite") as info:
        verlet(sim, 8, **{"Safety Factor": 100.0})
    assert "at step 3 " in str(info.value) or "non-finite" in str(info.value)


# -- the measures behind the rules ---------------------------------------------------------------
def test_a_sudden_uniform_body_force_holds_a_sixth_of_the_supply_in_the_shadow_term():
    """With f = 0 and a = b / rho, C = C_b = dt^2/8 m a^2 and W_b = dt^2/2 m a^2 after one step,
    S = W_b + 2 C_b: C/S is exactly 1/6 for any step, well below the alarm (and not a vibration
    at all)."""
    tree = cube_deck(ELASTIC, n=3, spacing=1e-3)
    tree["Boundary Conditions"] = {"All Node Set": " ".join(str(i) for i in range(1, 28)),
                                   "Push": {"Type": "Body Force", "Node Set": "All Node Set", "Coordinate": "x", "Value": "1.0e15"}}
    for fraction in (0.1, 0.5):
        sim = build_simulation(tree)
        stats = verlet(sim, 1, **{"Safety Factor": fraction})
        assert stats["energy"]["resolution"] == pytest.approx(1.0 / 6.0, rel=1e-9)


def two_points(stretch: float):
    """Two bond-based points 1 mm apart along x, the bond stretched by ``stretch`` at the start."""
    tree = cube_deck(BOND_BASED, shape=(2, 1, 1), spacing=1.0e-3, horizon_factor=1.5)
    tree["Boundary Conditions"] = {
        "Right Node Set": "2",
        "Pull": {"Type": "Initial Displacement", "Node Set": "Right Node Set", "Coordinate": "x", "Value": str(stretch * 1e-3)},
    }
    return build_simulation(tree)


def test_one_vibration_measures_its_stability_parameter_exactly(unmeasured):
    """For one mode C0/E0 = (w dt)^2/4, and the power iteration finds w: the monitor's start
    measure and the measured limit agree, and both scale with dt^2."""
    sim = two_points(1e-4)
    dt = 1e-9
    limit, _ = measured_stable_step(sim, dt, iterations=5)
    ratios = []
    for fraction in (0.3, 0.6):
        sim = two_points(1e-4)
        step = fraction * limit
        verlet(sim, 3, **{"Fixed dt": step})
        ratios.append(sim.stats["solvers"][-1]["energy"]["resolution"])
    assert ratios[0] == pytest.approx(0.3**2, rel=2e-3)  # the stretch of 1e-4 is not quite linear
    assert ratios[1] == pytest.approx(0.6**2, rel=2e-3)


@pytest.mark.parametrize("fraction,stopped", [(0.6, False), (0.8, True)])
def test_an_initial_state_resolved_by_too_few_steps_is_stopped_at_step_0(unmeasured, fraction, stopped):
    """(w dt)^2/4 = fraction^2 on the initial stretch: above 0.5 (w dt > 1.41) the run's answer
    cannot be trusted, even if Verlet would not blow up."""
    sim = two_points(1e-4)
    limit, _ = measured_stable_step(sim, 1e-9, iterations=5)
    if stopped:
        with pytest.raises(InstabilityError, match="at step 0 .* fewer than 4.4 steps per period"):
            verlet(sim, 5, **{"Fixed dt": fraction * limit})
    else:
        assert verlet(sim, 5, **{"Fixed dt": fraction * limit})["steps"] == 5


def test_the_probe_leaves_every_field_as_it_was():
    tree = cube_deck(ELASTIC, n=4, spacing=1e-3, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 1.0e-9})
    sim = build_simulation(tree)
    sim.fields["Displacement"][:, 0] = 1e-7 * sim.fields["Model_Coordinates"][:, 1]
    sim.fields["Coordinates"][:] = sim.fields["Model_Coordinates"] + sim.fields["Displacement"]
    sim.evaluate_forces()
    before = sim.fields.snapshot()
    measured_stable_step(sim, 1e-8)
    after = sim.fields.snapshot()
    assert before.keys() == after.keys()
    for key in before:
        assert np.array_equal(before[key], after[key]), key


def test_a_run_that_is_measured_gives_the_same_answer_as_one_that_is_not(monkeypatch):
    sims = []
    for measure in (0.9, math.inf):
        monkeypatch.setattr(Verlet, "MEASURE_ABOVE", measure)
        sim = bar_sim()
        x = sim.fields["Model_Coordinates"]
        sim.fields["Velocity"][:, 0] = np.sin(np.pi * x[:, 0] / 12e-3)
        verlet(sim, 30, **{"Safety Factor": 1.0})
        sims.append(sim)
    assert np.array_equal(sims[0].fields["Displacement"], sims[1].fields["Displacement"])


def test_the_measured_limit_is_the_same_on_one_and_on_a_second_call():
    sim = build_simulation(cube_deck(ELASTIC, n=4, spacing=1e-3))
    a = measured_stable_step(sim, 1e-8, iterations=30)
    b = measured_stable_step(sim, 1e-8, iterations=30)
    assert a == b and 1.0 < a[0] / sim.critical_time_step() < 1.5


# -- runs that would do nothing ------------------------------------------------------------------
def test_a_time_step_longer_than_the_interval_is_an_input_error(tmp_path, capsys):
    (tmp_path / "bar.e").write_bytes(b"an earlier result")
    assert run(tmp_path, bar_deck(final_time=1.0e-9, verlet_params={"Fixed dt": 1.0e-8})) == ExitCode.INPUT_ERROR
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("error")]
    assert len(lines) == 1 and "Solver > Verlet" in lines[0] and "longer than the solver's interval" in lines[0]
    assert (tmp_path / "bar.e").read_bytes() == b"an earlier result"


def test_a_modulus_in_gigapascal_is_caught_by_the_step_count(tmp_path, capsys):
    """A new user's unit slip: 'Young's Modulus: 72.0' makes the estimate ~3e4 times too long."""
    tree = bar_deck(final_time=2.0e-6)
    tree["Materials"]["M"] = {"Material Model": "Elastic", "Density": 2440.0, "Young's Modulus": 72.0, "Poisson's Ratio": 0.22}
    assert run(tmp_path, tree) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err
    assert "not one step would be run" in err and "GPa" in err


def test_a_deck_without_a_solver_is_an_input_error(tmp_path, capsys):
    tree = bar_deck()
    del tree["Solver"]
    assert run(tmp_path, tree) == ExitCode.INPUT_ERROR
    assert "no solver section" in capsys.readouterr().err
    assert main(["check", str(tmp_path / "deck.yaml")]) == ExitCode.INPUT_ERROR


def test_a_run_too_short_for_its_unstable_vibration_to_grow_is_run_with_a_warning(caplog):
    """Peridigm's VariableHorizonParsing runs 2 steps at 3.4 times the estimate and moves
    nothing: an unstable vibration grows at most ~6-fold in 2 steps, so the answer stands."""
    import logging

    sim = build_simulation(cube_deck(ELASTIC, n=4, spacing=1e-3))
    with caplog.at_level(logging.WARNING, logger="peridyn.solver"):
        stats = verlet(sim, 2, **{"Safety Factor": 1.6})
    assert stats["steps"] == 2
    assert any("above the stable limit measured" in r.getMessage() for r in caplog.records)
    with pytest.raises(InstabilityError, match="would go unstable from its first step"):
        verlet(build_simulation(cube_deck(ELASTIC, n=4, spacing=1e-3)), 40, **{"Safety Factor": 1.6})


def test_an_implicit_time_step_longer_than_the_interval_is_an_input_error(tmp_path, capsys):
    tree = bar_deck(final_time=1.0e-6)
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0e-6, "Implicit": {"Fixed dt": 1.0e-5}}
    assert run(tmp_path, tree) == ExitCode.INPUT_ERROR
    assert "Solver > Implicit: the time step 1e-05 ('Fixed dt') is longer than the solver's interval" in capsys.readouterr().err


def test_a_run_let_start_beyond_its_limit_is_stopped_once_its_energy_error_shows(monkeypatch):
    """A short run above the measured limit is let start (its unstable vibration could not
    grow far), but a run with loads shows the vibration at once: its energy error stops it."""
    monkeypatch.setattr(Verlet, "MAX_AMPLIFICATION", 1e300)
    sim = bar_sim()
    limit, _ = measured_stable_step(sim, 1e-9, iterations=60)
    sim.fields["Velocity"][sim.fields["Model_Coordinates"][:, 0] < 1e-3, 0] = 10.0
    with pytest.raises(InstabilityError, match="above the stable limit measured on the model and its unstable vibration now holds"):
        verlet(sim, 40, **{"Fixed dt": 1.02 * limit})


def test_round_off_energies_raise_no_energy_error_warning(caplog):
    """A model at rest that a step past the estimate barely moves (energies of 1e-26 J): its
    'energy error' is round-off and is not reported."""
    import logging

    sim = build_simulation(cube_deck(ELASTIC, n=4, spacing=1e-3))
    sim.fields["Velocity"][:, 0] = 1e-12
    with caplog.at_level(logging.WARNING, logger="peridyn.solver"):
        verlet(sim, 2, **{"Safety Factor": 1.6})
    assert not any("energy of the run was off" in r.getMessage() for r in caplog.records)
