"""Validation that follows Peridigm: not looser (ignored keys keep their values checked, absurd
horizons, values whose products under/overflow) and not stricter (a parameter the deck's
settings make unused is not range-checked); plus the set-up warnings."""
import logging
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from peridyn.cli import main
from peridyn.core.errors import ExitCode

DECK = """
Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    TensorProduct3DMeshGenerator:
      Type: "PdQuickGrid"
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 4.0
      Y Length: 1.0
      Z Length: 1.0
      Number Points X: 4
      Number Points Y: 1
      Number Points Z: 1
  Materials:
    Steel:
{material}
  Blocks:
    All:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: {horizon}
  Solver:
    Initial Time: 0.0
    Final Time: 2.0e-6
    Verlet:
      Fixed dt: 1.0e-6
  Output:
    Output File Type: "ExodusII"
    Output Filename: "run"
    Output Frequency: 1
    Output Variables:
      Displacement: true
      Velocity: {velocity}
"""
ELASTIC = """      Material Model: "Elastic"
      Density: 7800.0
      Bulk Modulus: 130.0e9
      Shear Modulus: 78.0e9"""


def deck_text(extra="", material=ELASTIC, horizon="3.1", velocity="true"):
    body = material + "".join(f"\n      {line}" for line in extra.splitlines() if line)
    return DECK.format(material=body, horizon=horizon, velocity=velocity)


def plastic(model="Elastic Plastic", **keys):
    lines = [f'      Material Model: "{model}"', "      Density: 7800.0", "      Bulk Modulus: 130.0e9", "      Shear Modulus: 78.0e9"]
    lines += [f"      {k}: {v}" for k, v in keys.items()]
    return "\n".join(lines)


def check(tmp_path, text, capsys):
    deck = tmp_path / "deck.yaml"
    deck.write_text(text)
    capsys.readouterr()
    code = main(["check", str(deck), "--quiet"])
    err = capsys.readouterr().err
    return code, [line for line in err.splitlines() if line.startswith("error")]


def assert_refused(tmp_path, text, capsys, *words):
    code, errors = check(tmp_path, text, capsys)
    assert code == ExitCode.INPUT_ERROR, errors
    assert len(errors) == 1 and "deck.yaml" in errors[0], errors
    for w in words:
        assert w in errors[0], errors[0]
    return errors[0]


def build(tmp_path, text):
    """Load and set up the deck in this process (caplog sees the warnings)."""
    from peridyn.deck.model import load_deck
    from peridyn.engine.simulation import Simulation

    deck = tmp_path / "deck.yaml"
    deck.write_text(text)
    return Simulation(load_deck(str(deck)), output_dir=tmp_path)


def assert_accepted(tmp_path, text, capsys):
    code, errors = check(tmp_path, text, capsys)
    assert code == ExitCode.OK, errors


SETTINGS = settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


# ---- 1. ignored keys keep their values checked ---------------------------------------------
@SETTINGS
@given(value=st.sampled_from(["-.inf", ".inf", ".nan", "-1.0", "abc", "true", "-1e-300"]))
def test_ignored_hourglass_coefficient_value_is_checked(tmp_path, capsys, value):
    line = assert_refused(tmp_path, deck_text(f"Hourglass Coefficient: {value}"), capsys, "Materials > Steel > Hourglass Coefficient", "ignored")
    assert "Traceback" not in line


@pytest.mark.parametrize("key,value", [("Apply Shear Correction Factor", "3.5"), ("Apply Shear Correction Factor", ".nan")])
def test_ignored_switch_value_is_checked(tmp_path, capsys, key, value):
    assert_refused(tmp_path, deck_text(f"{key}: {value}"), capsys, f"Materials > Steel > {key}")


def test_ignored_keys_with_good_values_warn_once(tmp_path, capsys, caplog):
    with caplog.at_level(logging.WARNING, logger="peridyn"):
        build(tmp_path, deck_text("Hourglass Coefficient: 0.05\nApply Shear Correction Factor: false"))
    assert sum("'Hourglass Coefficient' is ignored" in r.getMessage() for r in caplog.records) == 1


def test_ignored_top_level_key_value_is_checked(tmp_path, capsys):
    text = deck_text().replace("Peridigm:\n", "Peridigm:\n  Verbose: .inf\n", 1)
    assert_refused(tmp_path, text, capsys, "Verbose")


# ---- 2. absurd horizons ----------------------------------------------------------------------
@SETTINGS
@given(horizon=st.sampled_from(["1e308", "1e80", "1e10", "5e4", "1e-80", '"1e300 + x"']))
def test_absurd_horizon_is_refused(tmp_path, capsys, horizon):
    assert_refused(tmp_path, deck_text(horizon=horizon), capsys, "Blocks > All > Horizon")


# ---- 3. parameters the settings make unused are not range-checked -----------------------------
@pytest.mark.parametrize(
    "material",
    [
        plastic(**{"Yield Stress": 0.0, "Disable Plasticity": "true"}),
        plastic(**{"Yield Stress": -5.0, "Disable Plasticity": "true"}),
        plastic(**{"Yield Stress": "1e-300", "Disable Plasticity": "true"}),
        plastic("Elastic Plastic Hardening", **{"Yield Stress": 0.0, "Hardening Modulus": 0.0, "Disable Plasticity": "true"}),
        plastic(**{"Yield Stress": 1e8, "Thickness": 0.0}),  # Thickness is read by planar problems only
        plastic(**{"Yield Stress": 1e8, "Finite Difference Probe Length": 0.0}),  # AD tangent: no probe
        ELASTIC + "\n      Finite Difference Probe Length: -1.0",
        ELASTIC + "\n      Thermal Expansion Coefficient: -1.0e-5",
    ],
)
def test_unused_out_of_range_parameter_is_accepted(tmp_path, capsys, material):
    assert_accepted(tmp_path, deck_text(material=material), capsys)


@pytest.mark.parametrize(
    "material,key",
    [
        (plastic(**{"Yield Stress": 0.0}), "Yield Stress"),
        (plastic("Elastic Plastic Hardening", **{"Yield Stress": 1e8, "Hardening Modulus": 0.0}), "Hardening Modulus"),
        (plastic(**{"Yield Stress": 1e8, "Thickness": 0.0, "Planar Problem": "true"}), "Thickness"),
        (plastic(**{"Yield Stress": 1e8, "Finite Difference Probe Length": 0.0, "Apply Automatic Differentiation Jacobian": "false"}),
         "Finite Difference Probe Length"),
    ],
)
def test_used_out_of_range_parameter_is_refused(tmp_path, capsys, material, key):
    assert_refused(tmp_path, deck_text(material=material), capsys, f"Materials > Steel > {key}", "when")


@SETTINGS
@given(value=st.sampled_from(["-.inf", ".inf", ".nan"]))
def test_unused_parameter_must_still_be_finite(tmp_path, capsys, value):
    assert_refused(tmp_path, deck_text(material=plastic(**{"Yield Stress": value, "Disable Plasticity": "true"})), capsys, "Yield Stress")


# ---- 4. values whose products under- or overflow ----------------------------------------------
@SETTINGS
@given(exponent=st.integers(min_value=155, max_value=307), sign=st.sampled_from([-1, 1]))
def test_yield_stress_whose_square_is_not_representable_is_refused(tmp_path, capsys, exponent, sign):
    value = f"1e{sign * exponent}"
    assert_refused(tmp_path, deck_text(material=plastic(**{"Yield Stress": value})), capsys, "Materials > Steel > Yield Stress", "flow")


@SETTINGS
@given(ratio=st.floats(min_value=101, max_value=140))
def test_yield_stress_far_below_the_modulus_is_refused(tmp_path, capsys, ratio):
    value = 130.0e9 * 10.0 ** -ratio
    assert_refused(tmp_path, deck_text(material=plastic(**{"Yield Stress": repr(value)})), capsys, "Yield Stress", "modulus")


@pytest.mark.parametrize("key,value", [("Density", "1e-200"), ("Bulk Modulus", "1e200")])
def test_moduli_and_densities_whose_square_is_not_representable_are_refused(tmp_path, capsys, key, value):
    material = ELASTIC.replace(f"{key}: {'7800.0' if key == 'Density' else '130.0e9'}", f"{key}: {value}")
    assert_refused(tmp_path, deck_text(material=material), capsys, f"Materials > Steel > {key}")


def test_refusal_leaves_earlier_output_untouched(tmp_path, capsys):
    deck = tmp_path / "deck.yaml"
    deck.write_text(deck_text())
    assert main(["run", str(deck), "--no-progress", "--quiet", "--output-dir", str(tmp_path)]) == ExitCode.OK
    before = (tmp_path / "run.e").read_bytes()
    for text in (deck_text("Hourglass Coefficient: -.inf"), deck_text(horizon="1e308"),
                 deck_text(material=plastic(**{"Yield Stress": "1e-300"}))):
        deck.write_text(text)
        capsys.readouterr()
        assert main(["run", str(deck), "--no-progress", "--output-dir", str(tmp_path)]) == ExitCode.INPUT_ERROR
        errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("error")]
        assert len(errors) == 1 and "deck.yaml" in errors[0]
        assert (tmp_path / "run.e").read_bytes() == before


# ---- 5. set-up warnings -----------------------------------------------------------------------
def test_small_horizon_per_spacing_warns_once(tmp_path, capsys, caplog):
    with caplog.at_level(logging.WARNING, logger="peridyn"):
        build(tmp_path, deck_text(horizon="1.2"))
    hits = [r for r in caplog.records if "point spacings" in r.getMessage()]
    assert len(hits) == 1 and "neighbors per point" in hits[0].getMessage()


def test_ample_horizon_does_not_warn(tmp_path, capsys, caplog):
    with caplog.at_level(logging.WARNING, logger="peridyn"):
        build(tmp_path, deck_text(horizon="3.1"))
    assert not [r for r in caplog.records if "point spacings" in r.getMessage()]


def test_velocity_false_is_written_and_says_so_once(tmp_path, capsys, caplog):
    with caplog.at_level(logging.WARNING, logger="peridyn"):
        build(tmp_path, deck_text(velocity="false"))
    hits = [r for r in caplog.records if "set to false but written" in r.getMessage()]
    assert len(hits) == 1 and "Velocity" in hits[0].getMessage()


def test_horizon_limits_are_consistent():
    from peridyn.engine.checks import _HUGE4, _TINY4

    assert math.isfinite(_HUGE4 ** 4) and _TINY4 ** 4 > 0
