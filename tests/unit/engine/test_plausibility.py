"""Unit slips (issue #33): a horizon in millimetres, moduli in GPa, a density in g/cm^3 next to
numbers in SI are named at set-up (a warning, or exit 2 for what cannot be a peridynamic
model), and :func:`unit_slip_hint` names them for the errors a run meets later."""
import logging
import textwrap

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from peridyn.engine.run_services import RunServices
from peridyn.cli import main
from peridyn.core.errors import ExitCode, InputError, InstabilityError
from peridyn.deck.model import load_deck
from peridyn.engine import limits, plausibility
from peridyn.engine.simulation import Simulation
from peridyn.engine.session import run_sections

#: glass in SI: 8 x 4 x 2 points 1 mm apart, a horizon of three spacings, about 30 steps
DECK = textwrap.dedent(
    """
    Discretization:
      Type: PdQuickGrid
      NeighborhoodType: Spherical
      TensorProduct3DMeshGenerator:
        Type: PdQuickGrid
        X Origin: 0.0
        Y Origin: 0.0
        Z Origin: 0.0
        X Length: {xl}
        Y Length: {yl}
        Z Length: {zl}
        Number Points X: 8
        Number Points Y: 4
        Number Points Z: 2
    Materials:
      Glass:
        Material Model: Elastic
        Density: {density}
        Young's Modulus: {modulus}
        Poisson's Ratio: 0.22
    Blocks:
      Plate:
        Block Names: block_1
        Material: Glass
        Horizon: {horizon}
    Boundary Conditions:
      Left Node Set: "1 9 17 25 33 41 49 57"
      Right Node Set: "8 16 24 32 40 48 56 64"
      Pull Left:
        Type: Prescribed Displacement
        Node Set: Left Node Set
        Coordinate: x
        Value: "-{speed}*t"
      Pull Right:
        Type: Prescribed Displacement
        Node Set: Right Node Set
        Coordinate: x
        Value: "{speed}*t"
    Solver:
      Initial Time: 0.0
      Final Time: {final}
      Verlet:
        Safety Factor: 0.8
    Output:
      Output Filename: slip
      Output Frequency: 10
      Output Variables:
        Displacement: true
    """
)
GOOD = dict(xl=0.008, yl=0.004, zl=0.002, density=2440.0, modulus=72.0e9, horizon=0.003015, speed=1.0, final=5.0e-6)


def write(folder, **changes):
    values = GOOD | changes
    path = folder / "slip.yaml"
    path.write_text(DECK.format(**values))
    return path


def slip_warnings(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING and r.name == "peridyn.engine"]


@pytest.fixture(autouse=True)
def _limits_on(monkeypatch):
    monkeypatch.delenv(limits.ENV, raising=False)


# ------------------------------------------------------------------------------------------------
# the ratios and their names


@pytest.mark.parametrize("ratio, horizon, words", [
    (3015.0, 3.015, "a horizon in millimetres with coordinates in metres? give 0.003015"),
    (0.003015, 3.015e-6, "a horizon in metres with coordinates in millimetres? give 0.003015"),
    (301.5, 0.3015, "a horizon in centimetres with coordinates in metres? give 0.003015"),
])
def test_a_horizon_a_unit_factor_off_is_named_with_its_correction(ratio, horizon, words):
    assert plausibility.horizon_slip(ratio, horizon) == words


@given(st.floats(1.5, 50.0))
def test_a_plausible_horizon_names_no_slip_below_fifty_spacings(ratio):
    text = plausibility.horizon_slip(ratio, ratio * 1e-3)
    assert text == "" or (ratio > 8.0 and "give" in text)  # 10 to 50 spacings may be a factor 10 (mm, cm) off


@pytest.mark.parametrize("bulk, density, words", [
    (42.9, 2440.0, "moduli in GPa"),
    (4.29e4, 2440.0, "moduli in MPa"),
    (4.29e10, 2.44, "density in g/cm^3"),
    (4.29e10, 2.44e6, "1e3 times too large"),
    (4.29e19, 2440.0, "1e9 times too large"),
])
def test_the_material_slip_is_named_by_the_size_of_its_numbers(bulk, density, words):
    assert words in plausibility.material_slip(bulk, density)


@pytest.mark.parametrize("bulk, density", [(4.29e10, 2440.0), (1.52e5, 8.0e-9), (1.3e5, 0.0078), (1.6e12, 8.05), (0.0, 1.0)])
def test_consistent_materials_name_no_slip(bulk, density):
    """SI, tonne-mm-s-MPa, g-mm-ms-MPa, CGS (the reference decks' systems), and no modulus."""
    assert plausibility.material_slip(bulk, density) == ""


# ------------------------------------------------------------------------------------------------
# set-up: refusals and warnings


def test_the_valid_deck_gets_no_warning_and_no_hint(tmp_path, caplog):
    sim = Simulation(load_deck(write(tmp_path)), write_files=False)
    assert slip_warnings(caplog) == []
    assert plausibility.unit_slip_hint(sim) == ""


def test_a_horizon_in_millimetres_is_refused_naming_the_slip(tmp_path, capsys):
    deck = write(tmp_path, horizon=3.015)
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Blocks > Plate > Horizon" in err
    assert "3015 point spacings" in err and "all 64 points bonded to each other" in err
    assert "a horizon in millimetres with coordinates in metres?" in err and "give 0.003015" in err
    assert "PERIDYN_NO_LIMITS" in err


def test_no_limits_runs_the_horizon_anyway_with_a_warning(tmp_path, monkeypatch, caplog):
    monkeypatch.setenv(limits.ENV, "1")
    sim = Simulation(load_deck(write(tmp_path, horizon=3.015)), write_files=False)
    assert sim.num_bonds_global == 64 * 63
    assert any("millimetres" in w for w in slip_warnings(caplog))


def test_a_horizon_in_metres_with_coordinates_in_millimetres_is_named(tmp_path, capsys):
    deck = write(tmp_path, xl=8.0, yl=4.0, zl=2.0)
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err
    assert "no point has a neighbor" in err and "a horizon in metres with coordinates in millimetres?" in err and "give 3.015" in err


def test_tens_of_spacings_warn_and_run(tmp_path, caplog):
    sim = Simulation(load_deck(write(tmp_path, horizon=0.06)), write_files=False)  # 60 spacings, all bonded
    assert sim.num_bonds_global == 64 * 63
    assert any("60 point spacings" in w for w in slip_warnings(caplog))


def test_all_to_all_bonding_of_many_points_is_refused(tmp_path, capsys):
    """A 12^3 cube with a horizon of 40 spacings: inside the warning band of the ratio, but every
    one of its 1,728 points would be bonded to every other."""
    text = write(tmp_path, horizon=0.04).read_text()
    for axis in "XYZ":
        text = text.replace(f"Number Points {axis}: {dict(X=8, Y=4, Z=2)[axis]}", f"Number Points {axis}: 12")
    deck = tmp_path / "cube.yaml"
    deck.write_text(text.replace("X Length: 0.008", "X Length: 0.012").replace("Y Length: 0.004", "Y Length: 0.012")
                    .replace("Z Length: 0.002", "Z Length: 0.012"))
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    assert "all 1728 points bonded to each other" in capsys.readouterr().err


@pytest.mark.parametrize("second, words", [
    (dict(bulk=42.9, density=2440.0), "moduli in GPa and Pa in one deck?"),
    (dict(bulk=4.29e4, density=2440.0), "moduli in MPa and Pa (or GPa and kPa) in one deck?"),
    (dict(bulk=4.29e10, density=2.44), "one in kg/m^3 and one in g/cm^3?"),
])
def test_blocks_of_moduli_or_densities_in_two_units_are_named(second, words):
    glass = plausibility.BlockScales("glass", 100, 1e-3, 3e-3, 4.29e10, 2440.0)
    other = plausibility.BlockScales("other", 100, 1e-3, 3e-3, second["bulk"], second["density"])
    found = plausibility.material_findings([glass, other])
    assert len(found) == 1 and words in found[0]


def test_steel_next_to_rubber_is_no_slip():
    steel = plausibility.BlockScales("steel", 100, 1e-3, 3e-3, 1.6e11, 7800.0)
    rubber = plausibility.BlockScales("rubber", 100, 1e-3, 3e-3, 1.0e7, 1100.0)  # examples/neo_hookean_stretch.yaml
    foam = plausibility.BlockScales("foam", 100, 1e-3, 3e-3, 1.0e7, 30.0)
    assert plausibility.material_findings([steel, rubber, foam]) == []


def test_a_fixed_dt_far_above_the_wave_crossing_warns_naming_the_moduli(tmp_path, caplog):
    deck = write(tmp_path, modulus=72.0e18)
    deck.write_text(deck.read_text().replace("Safety Factor: 0.8", "Fixed dt: 1.6e-7"))
    Simulation(load_deck(deck), write_files=False)
    found = [w for w in slip_warnings(caplog) if "'Fixed dt' 1.6e-07" in w]
    assert len(found) == 1 and "1e9 times too large" in found[0]


def test_moduli_in_gpa_on_a_short_run_are_named_where_no_step_fits(tmp_path, capsys):
    deck = write(tmp_path, modulus=72.0)
    sim = Simulation(load_deck(deck), write_files=False)
    with pytest.raises(InputError, match="not one step would be run") as info:
        sim.plan_solvers()
    hint = plausibility.unit_slip_hint(sim)
    assert hint.startswith("likely a unit slip: ") and "moduli in GPa with the density in kg/m^3" in hint
    line = info.value.one_line()  # the printed line names the slip whole, not the Safety Factor
    assert "moduli in GPa with the density in kg/m^3" in line and "1e9 times larger" in line and " ... " not in line


def test_moduli_in_gpa_on_a_long_run_name_the_slip_at_the_instability(tmp_path):
    """Issue #33: 72 (GPa meant) on a run long enough for steps: the pulled ends move faster than
    sound; the instability that follows is the slip's, not the Safety Factor's."""
    sim = Simulation(load_deck(write(tmp_path, modulus=72.0, final=0.5)), output_dir=tmp_path)
    assert plausibility.unit_slip_hint(sim) == ""  # nothing yet: the body is at rest
    run = RunServices.of(sim)
    with pytest.raises(InstabilityError):
        run_sections(sim, run=run)
    run.close(complete=False)
    hint = plausibility.unit_slip_hint(sim)
    assert "the prescribed motion (" in hint and "times the wave speed sqrt(bulk modulus/density) = 0.133" in hint
    assert "moduli in GPa" in hint


# ------------------------------------------------------------------------------------------------
# unit-slip mutations of the valid deck

MUTATIONS = {
    "horizon x1e3": ("horizon", 1e3, "horizon"),
    "horizon x1e-3": ("horizon", 1e-3, "horizon"),
    "modulus x1e-9": ("modulus", 1e-9, "moduli"),
    "modulus x1e9": ("modulus", 1e9, "modul"),
    "density x1e-3": ("density", 1e-3, "density"),
    "density x1e3": ("density", 1e3, "density"),
    "coordinates x1e3": ("coordinates", 1e3, "horizon"),
    "coordinates x1e-3": ("coordinates", 1e-3, "horizon"),
}
NAMES = ("horizon", "modul", "density", "units")


def mutate(tmp_path, names: list[str], final: float):
    values = dict(GOOD, final=final)
    for name in names:
        key, factor, _ = MUTATIONS[name]
        for k in (("xl", "yl", "zl") if key == "coordinates" else (key,)):
            values[k] = values[k] * factor
    return write(tmp_path, **values)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(names=st.lists(st.sampled_from(sorted(MUTATIONS)), min_size=1, max_size=2, unique=True),
       final=st.sampled_from([5.0e-6, 5.0e-3]))
def test_every_unit_slip_runs_warns_or_is_refused_naming_it(tmp_path, caplog, names, final):
    """Each mutation is legal (runs), or warns naming a slip, or is refused (exit 2) naming one;
    an instability of a mutated deck always has a hint, so its advice never rests on the Safety
    Factor alone. Runs planned beyond 3,000 steps are judged by their set-up only."""
    caplog.clear()
    deck = mutate(tmp_path, names, final)
    try:
        sim = Simulation(load_deck(deck), output_dir=tmp_path)
    except InputError as exc:
        assert any(word in str(exc) for word in NAMES), str(exc)
        return
    warned = [w for w in slip_warnings(caplog) if any(word in w for word in NAMES)]
    try:
        plan = sim.plan_solvers()
    except InputError as exc:
        assert "not one step would be run" in str(exc) or "steps" in str(exc)
        assert any(word in plausibility.unit_slip_hint(sim) for word in NAMES), (names, str(exc))
        return
    steps = plan[0][1]
    if steps > 3000:
        return
    run = RunServices.of(sim)
    try:
        run_sections(sim, run=run)
    except InstabilityError as exc:
        hint = plausibility.unit_slip_hint(sim)
        assert any(word in hint for word in NAMES) or warned, (names, str(exc))
    finally:
        run.close(complete=False)
