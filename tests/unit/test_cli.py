"""The command line: exit codes, one-line errors, no traceback, output kept safe."""
import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode

DECK = textwrap.dedent(
    """
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
        Material Model: "Elastic"
        Density: 7800.0
        Bulk Modulus: 130.0e9
        Shear Modulus: 78.0e9
    Blocks:
      All:
        Block Names: "block_1"
        Material: "Steel"
        Horizon: 1.5
    Boundary Conditions:
      End Node Set: "4"
      Kick:
        Type: "Initial Velocity"
        Node Set: "End Node Set"
        Coordinate: "x"
        Value: "1.0"
    Solver:
      Initial Time: 0.0
      Final Time: 1.0e-2
      Verlet:
        Safety Factor: 0.5
    Output:
      Output Filename: "run"
      Output Frequency: 10
      Output Variables:
        Displacement: true
        Velocity: true
        Dilatation: true
        Element_Id: true
    """
)


@pytest.fixture
def deck(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    p = tmp_path / "deck.yaml"
    p.write_text(DECK)
    return p


def test_run_writes_output_and_summary(deck, capsys):
    assert main(["run", str(deck), "--no-progress"]) == ExitCode.OK
    err = capsys.readouterr().err
    assert "steps in" in err and "energy" in err and "wrote run.e" in err
    from peridyn.io.exodus_reader import read_results

    r = read_results(deck.parent / "run.e")
    assert r["times"][0] == 0.0 and len(r["times"]) > 1
    assert set(r["nodal"]) >= {"DisplacementX", "VelocityX"} and "Dilatation" in r["element"]
    np.testing.assert_array_equal(r["element"]["Element_Id"][0], [1, 2, 3, 4])


def test_bad_input_is_one_line_exit_2_and_leaves_output_alone(deck, capsys):
    assert main(["run", str(deck), "--no-progress"]) == ExitCode.OK
    before = (deck.parent / "run.e").read_bytes()
    deck.write_text(DECK.replace("Bulk Modulus", "Bulk Modulos"))
    capsys.readouterr()
    assert main(["run", str(deck)]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "deck.yaml" in err[0] and "Materials > Steel" in err[0] and "did you mean 'Bulk Modulus'" in err[0]
    assert "Traceback" not in "\n".join(err)
    assert (deck.parent / "run.e").read_bytes() == before


def test_output_dir_is_created_with_its_parents(deck, capsys):
    assert main(["run", str(deck), "--no-progress", "--output-dir", "results/run1"]) == ExitCode.OK
    assert (deck.parent / "results" / "run1" / "run.e").is_file()


def test_output_dir_that_is_a_file_is_an_input_error(deck, capsys):
    (deck.parent / "taken").write_text("not a folder")
    assert main(["run", str(deck), "--output-dir", "taken"]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--output-dir 'taken' is a file" in err[0] and "Traceback" not in err[0]
    assert (deck.parent / "taken").read_text() == "not a folder"


def test_missing_deck_file(tmp_path, capsys):
    assert main(["run", str(tmp_path / "nope.yaml")]) == ExitCode.INPUT_ERROR
    assert "nope.yaml" in capsys.readouterr().err


def test_debug_shows_the_traceback(deck):
    deck.write_text(DECK.replace("Bulk Modulus", "Bulk Modulos"))
    proc = subprocess.run([sys.executable, "-m", "peridyn", "run", str(deck), "--debug"], capture_output=True, text=True)
    assert proc.returncode != 0 and "Traceback" in proc.stderr
    proc = subprocess.run([sys.executable, "-m", "peridyn", "run", str(deck)], capture_output=True, text=True)
    assert proc.returncode == ExitCode.INPUT_ERROR and "Traceback" not in proc.stderr


def test_check_describes_the_model(deck, capsys):
    assert main(["check", str(deck)]) == ExitCode.OK
    out = capsys.readouterr().out
    assert "4 points" in out and "block block_1" in out and "horizon/spacing 1.5" in out
    assert "stable time step" in out and "memory estimate" in out
    assert not (deck.parent / "run.e").exists()  # check writes nothing


def test_unknown_model_in_check_names_it_and_the_available_ones(deck, capsys):
    deck.write_text(DECK.replace('"Elastic"', '"Elastic Plastik"'))
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "'Elastic Plastik'" in line and "did you mean 'Elastic Plastic'" in line and "peridyn plugins" in line


def test_plugins_lists_parameters(capsys):
    assert main(["plugins"]) == ExitCode.OK
    out = capsys.readouterr().out
    assert "Elastic" in out and "Bulk Modulus" in out and "Critical Stretch" in out and "Verlet" in out


def test_schema_is_json_with_plugin_parameters(capsys):
    assert main(["schema"]) == ExitCode.OK
    schema = json.loads(capsys.readouterr().out)
    text = json.dumps(schema)
    assert "Bulk Modulus" in text and "Critical Stretch" in text and "Fixed dt" in text


def test_convert_round_trip(tmp_path, capsys):
    xml = tmp_path / "d.xml"
    xml.write_text('<ParameterList><ParameterList name="Materials"><ParameterList name="M">'
                   '<Parameter name="Density" type="double" value="1.0"/></ParameterList></ParameterList></ParameterList>')
    assert main(["convert", str(xml), str(tmp_path / "d.yaml")]) == ExitCode.OK
    from peridyn.deck.files import load_deck_file

    assert load_deck_file(tmp_path / "d.yaml").tree == {"Materials": {"M": {"Density": 1.0}}}


def test_exit_codes_are_an_intenum():
    assert int(ExitCode.INPUT_ERROR) == 2 and ExitCode.OK == 0


@pytest.mark.parametrize("argv, names", [(["check", "deck.yaml", "--bogus"], "unrecognized arguments: --bogus"),
                                         (["run", "deck.yaml", "--device", "tpu"], "argument --device: invalid choice"),
                                         (["verify", "--problems"], "argument --problems: expected at least one argument"),
                                         (["fragments", "x.e", "--top", "abc"], "argument --top: invalid int value"),
                                         (["run"], "the following arguments are required: deck")])
def test_a_usage_error_is_one_line_exit_2(argv, names, capsys):
    """Found by benchmarks/surface_campaign.py: argparse printed its usage block and a line without 'error: ' first."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and err.startswith("error: peridyn") and names in err and "; see peridyn" in err


def test_no_limits_does_not_break_the_command(deck, capsys):
    """Found by benchmarks/surface_campaign.py: `peridyn check DECK --no-limits` was an internal error
    (UnboundLocalError: a later `import os` in main made os local)."""
    assert main(["check", str(deck), "--no-limits"]) == 0


def test_plot_of_a_name_too_long_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    """Found by benchmarks/surface_campaign.py: an input name over the system's limit was an internal error."""
    monkeypatch.chdir(tmp_path)
    assert main(["plot", "n" * 300 + ".e"]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and "File name too long" in err and len(err) < 200


def test_plot_out_prefix_too_long_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    """Found by benchmarks/surface_campaign.py: a --out prefix past the file-name limit was an internal error."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "r.e").write_bytes(b"")
    assert main(["plot", "r.e", "--out", "n" * 300]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and "--out prefix" in err


def test_paths_too_long_or_not_utf8_are_one_line_exit_2(deck, tmp_path, capsys):
    """Found by benchmarks/surface_campaign.py: schema -o, new-plugin --directory and fragments with a
    name past the system's limit, and run --output-dir with a name that is not UTF-8, were internal errors."""
    long_path = "/".join(["x" * 200] * 30)
    assert main(["schema", "-o", long_path + ".json"]) == 2
    assert main(["run", str(deck), "--no-progress", "--output-dir", os.fsdecode(b"d\xff\xfeck")]) == 2
    err = capsys.readouterr().err.splitlines()
    errors = [ln for ln in err if ln.startswith("error")]
    assert len(errors) == 2 and "File name too long" in errors[0] and len(errors[0]) < 200 and "not UTF-8" in errors[1] and "d\\udcff" in errors[1]  # the path named


@pytest.mark.parametrize("argv, shown", [
    (["check", ""], "DECK"),
    (["run", ""], "DECK"),
    (["run", "deck.yaml", "--output-dir", ""], "--output-dir"),
    (["run", "deck.yaml", "--restart", ""], "--restart"),
    (["convert", "", "out.yaml"], "IN"),
    (["convert", "in.xml", ""], "OUT"),
    (["schema", "-o", ""], "-o"),
    (["schema", "--reference", ""], "--reference"),
    (["fragments", ""], "RESULT"),
    (["fragments", "r.e", "--plot", ""], "--plot"),
    (["plot", ""], "RESULT"),
    (["plot", "r.e", "--out", ""], "--out"),
    (["new-plugin", ""], "NAME"),
    (["new-plugin", "x", "--directory", ""], "--directory"),
    (["verify", "--out", ""], "--out"),
])
def test_an_empty_argument_is_one_line_naming_it_exit_2(tmp_path, monkeypatch, capsys, argv, shown):
    """Found by benchmarks/surface_campaign.py: `run deck --output-dir ""` wrote into the current
    folder, `check ""` said '.: cannot tell the deck format'."""
    monkeypatch.chdir(tmp_path)
    assert main(argv) == ExitCode.INPUT_ERROR
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {shown} is empty; give "), lines
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("name", ["", " ", "9lives"])
def test_new_plugin_without_a_usable_name_names_the_argument(tmp_path, capsys, name):
    assert main(["new-plugin", name, "--directory", str(tmp_path)]) == ExitCode.INPUT_ERROR
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: NAME ") and "; give " in lines[0], lines
    assert not list(tmp_path.iterdir())
