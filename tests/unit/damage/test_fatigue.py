"""``Fatigue`` (Silling-Askari): the plugin kit, bad input, the life decrement of one bond per load
step, the fatigue limit, the phase switch and static failure."""
from typing import ClassVar

import numpy as np
import pytest
from pydantic import ValidationError

from peridyn.damage.fatigue import FatigueParams
from peridyn.testing import DamageConformance, build_simulation

GOOD = {"Load Ratio": 0.1, "Frequency": 10.0, "A1": 1.0e3, "m1": 2.0, "A2": 4.0e3, "m2": 3.0}


class TestFatigueConformance(DamageConformance):
    """The kit's checks. Its evaluations are single configurations outside a solver (no load
    step: Delta N = 0), and a bond whose life runs out breaks only in the next load step's
    solve, so the bonds it breaks are those over the static ``Critical Stretch``."""

    damage = "Fatigue"
    params: ClassVar[dict] = {**GOOD, "Critical Stretch": 0.05}
    material = "Elastic Bond Based"
    material_params: ClassVar[dict] = {"Density": 1000.0, "Bulk Modulus": 1.0e9}


@pytest.mark.parametrize(
    "change",
    [
        {"Load Ratio": 1.0},
        {"Load Ratio": 1.5},
        {"Load Ratio": float("nan")},
        {"Frequency": 0.0},
        {"Frequency": -1.0},
        {"Frequency": float("inf")},
        {"A1": 0.0},
        {"A1": -1.0},
        {"A2": float("nan")},
        {"m1": 0.0},
        {"m2": -2.0},
        {"m2": 1000.0},
        {"Fatigue Limit": -1e-4},
        {"Fatigue Limit": 1.0},
        {"Critical Stretch": 0.0},
        {"A1": True},
        {"Frequency": None},
        {"Paris Exponent": 3.0},
    ],
)
def test_bad_input_is_refused(change):
    params = {**GOOD, **change}
    params = {k: v for k, v in params.items() if v is not None}
    with pytest.raises(ValidationError):
        FatigueParams.model_validate(params, context={"deck": True})


@pytest.mark.parametrize("missing", ["Load Ratio", "Frequency", "A1", "m1", "A2", "m2"])
def test_required_keys(missing):
    with pytest.raises(ValidationError, match=missing):
        FatigueParams.model_validate({k: v for k, v in GOOD.items() if k != missing})


def test_deck_error_is_one_line_naming_the_key(tmp_path):
    from peridyn.deck.model import load_deck
    from peridyn.core.errors import InputError

    deck = tmp_path / "bad.yaml"
    deck.write_text(
        "Peridigm:\n  Discretization:\n    Type: PdQuickGrid\n    TensorProduct3DMeshGenerator:\n      Type: PdQuickGrid\n"
        "      X Origin: 0.0\n      Y Origin: 0.0\n      Z Origin: 0.0\n      X Length: 1.0\n      Y Length: 1.0\n      Z Length: 1.0\n"
        "      Number Points X: 3\n      Number Points Y: 3\n      Number Points Z: 3\n"
        "  Materials:\n    M:\n      Material Model: Elastic Bond Based\n      Density: 1.0\n      Bulk Modulus: 1.0\n"
        "  Damage Models:\n    F:\n      Damage Model: Fatigue\n      Load Ratio: 1.2\n      Frequency: 1.0\n"
        "      A1: 1.0\n      m1: 2.0\n      A2: 1.0\n      m2: 2.0\n"
        "  Blocks:\n    B:\n      Block Names: block_1\n      Material: M\n      Damage Model: F\n      Horizon: 1.0\n"
    )
    with pytest.raises(InputError) as exc:
        load_deck(deck)
    text = str(exc.value)
    assert "Load Ratio" in text and "bad.yaml" in text and "\n" not in text.strip()


# -- one bond ---------------------------------------------------------------------------------------
def pair_deck(params: dict) -> dict:
    """Two points 1 apart along x (one bond each way), bond-based."""
    return {
        "Discretization": {
            "Type": "PdQuickGrid",
            "NeighborhoodType": "Spherical",
            "TensorProduct3DMeshGenerator": {"Type": "PdQuickGrid", "X Origin": 0.0, "Y Origin": 0.0, "Z Origin": 0.0, "X Length": 2.0,
                                             "Y Length": 1.0, "Z Length": 1.0, "Number Points X": 2, "Number Points Y": 1, "Number Points Z": 1},
        },
        "Materials": {"M": {"Material Model": "Elastic Bond Based", "Density": 1.0, "Bulk Modulus": 1.0e9}},
        "Damage Models": {"F": {"Damage Model": "Fatigue", **params}},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Damage Model": "F", "Horizon": 1.5}},
    }


def step(sim, stretch: float) -> None:
    """One load step: evaluate at the given stretch of the bond, then accept it."""
    x = sim.fields["Model_Coordinates"]
    y = sim.fields["Coordinates"]
    y[:] = x
    y[1, 0] = x[0, 0] + (x[1, 0] - x[0, 0]) * (1.0 + stretch)
    sim.evaluate_forces()
    sim.advance()


def test_life_decreases_by_a_eps_m_dn_per_step():
    R, f, dt, A1, m1, s = -0.5, 3.0, 0.25, 2.0e3, 2.5, 0.004
    sim = build_simulation(pair_deck({**GOOD, "Load Ratio": R, "Frequency": f, "A1": A1, "m1": m1}))
    assert sim.bonds.num_bonds == 2
    sim.set_time_step(dt)
    dN = f * dt
    drop = A1 * ((1 - R) * s) ** m1 * dN  # 0.0176 per step
    for k in range(1, 6):
        step(sim, s)
        np.testing.assert_allclose(sim.fields.n("Remaining_Life"), 1.0 - k * drop, rtol=1e-13)
    step(sim, -s)  # compression at the peak: the same strain range
    np.testing.assert_allclose(sim.fields.n("Remaining_Life"), 1.0 - 6 * drop, rtol=1e-13)
    assert not np.any(sim.fields.n("Bond_Damage"))


def test_bond_breaks_in_the_step_after_its_life_runs_out():
    R, A1, m1, s = 0.0, 1.0e3, 2.0, 0.01  # 0.1 of the life per cycle: gone after cycle 10
    sim = build_simulation(pair_deck({**GOOD, "Load Ratio": R, "Frequency": 1.0, "A1": A1, "m1": m1}))
    sim.set_time_step(1.0)
    broken_at = None
    for k in range(1, 15):
        step(sim, s * (1 + 1e-9))
        if broken_at is None and sim.fields.n("Bond_Damage").all():
            broken_at = k
    assert broken_at == 11  # the solve of step 11 is the first without the bond
    assert sim.fields.n("Damage").tolist() == [1.0, 1.0]
    step(sim, 0.0)
    assert sim.fields.n("Bond_Damage").all(), "a broken bond heals"


def test_fatigue_limit_applies_to_phase_one():
    A1, m1, s, limit = 1.0e3, 2.0, 0.01, 0.004  # (1 - R) s = 0.009
    sim = build_simulation(pair_deck({**GOOD, "A1": A1, "m1": m1, "Fatigue Limit": limit, "Frequency": 1.0}))
    sim.set_time_step(1.0)
    step(sim, s)
    np.testing.assert_allclose(sim.fields.n("Remaining_Life"), 1.0 - A1 * (0.9 * s - limit) ** m1, rtol=1e-13)
    step(sim, limit)  # strain range (1 - R) eps_inf = 0.9 eps_inf: below the limit, no life taken
    np.testing.assert_allclose(sim.fields.n("Remaining_Life"), 1.0 - A1 * (0.9 * s - limit) ** m1, rtol=1e-13)


def test_no_cycles_outside_a_load_step():
    sim = build_simulation(pair_deck(GOOD))
    step(sim, 0.02)  # time step 0: no cycles
    assert np.all(sim.fields.n("Remaining_Life") == 1.0)


def chain_deck(params: dict) -> dict:
    """Three points in a row, 1 apart, horizon 1.5: bonds 0-1 and 1-2."""
    tree = pair_deck(params)
    g = tree["Discretization"]["TensorProduct3DMeshGenerator"]
    g["X Length"], g["Number Points X"] = 3.0, 3
    return tree


def test_phase_two_once_an_end_point_is_damaged():
    """Bond 1-2 uses phase I until bond 0-1 is broken (point 1 then has Damage 1/2), and phase
    II from the next load step on. Bond 0-1 takes 10 (0.8 x 0.2)^2 = 0.256 of its life a step:
    gone after step 4, broken in the solve of step 5, so bond 1-2 is in phase II from step 6."""
    A1, m1, A2, m2, R = 10.0, 2.0, 50.0, 3.0, 0.2
    sim = build_simulation(chain_deck({**GOOD, "A1": A1, "m1": m1, "A2": A2, "m2": m2, "Load Ratio": R, "Frequency": 1.0}))
    sim.set_time_step(1.0)
    nl = sim.bonds
    x = sim.fields["Model_Coordinates"]
    y = sim.fields["Coordinates"]
    s01, s12 = 0.2, 0.01
    bond12 = [b for b in range(nl.num_bonds) if {int(nl.neighbors[b]), int(np.searchsorted(nl.offsets, b, side="right") - 1)} == {1, 2}]
    assert len(bond12) == 2
    expected = 1.0
    phases = []
    for k in range(1, 9):
        phase2 = bool(sim.fields.n("Damage")[1] > 0)
        y[:] = x
        y[1, 0] = x[0, 0] + 1.0 + s01
        y[2, 0] = y[1, 0] + 1.0 + s12
        sim.evaluate_forces()
        eps = (1 - R) * s12
        expected -= A2 * eps**m2 if phase2 else A1 * eps**m1
        phases.append(phase2)
        np.testing.assert_allclose(sim.fields["Remaining_Life"][bond12], expected, rtol=1e-12)
        sim.advance()
    assert phases == [False] * 5 + [True] * 3
    assert sim.fields.n("Damage")[0] == 1.0


def test_static_critical_stretch_breaks_at_once():
    sim = build_simulation(pair_deck({**GOOD, "Critical Stretch": 0.01}))
    step(sim, 0.0099)
    assert not sim.fields.n("Bond_Damage").any()
    step(sim, 0.0101)
    assert sim.fields.n("Bond_Damage").all()


def test_life_field_only_with_the_model():
    from peridyn.testing import cube_deck

    sim = build_simulation(cube_deck({"Material Model": "Elastic Bond Based", "Density": 1.0, "Bulk Modulus": 1.0}, n=3))
    assert "Remaining_Life" not in sim.fields
    sim = build_simulation(pair_deck(GOOD))
    assert sim.fields["Remaining_Life"].shape == (2,)


def test_explicit_solver_is_refused(tmp_path, capsys):
    from peridyn.cli import main
    from peridyn.core.errors import ExitCode
    from peridyn.deck.files import dump_yaml

    tree = pair_deck(GOOD)
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0e-6, "Verlet": {"Fixed dt": 1.0e-7}}
    deck = tmp_path / "verlet.yaml"
    deck.write_text(dump_yaml(tree))
    assert main(["run", str(deck), "--output-dir", str(tmp_path), "-q", "--no-progress"]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err
    assert "Damage Models > F" in err and "QuasiStatic" in err
