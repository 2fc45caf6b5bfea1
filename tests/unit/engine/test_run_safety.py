"""A run never destroys an earlier result before it has its own, never writes a non-finite
frame, and turns nonsense that parses into one clear error line."""
import textwrap
from pathlib import Path

import netCDF4
import numpy as np
import pytest

from peridyn.engine.run_services import RunServices
from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.io.exodus_reader import read_results

DECK = textwrap.dedent(
    """
    Discretization:
      Type: "PdQuickGrid"
      NeighborhoodType: "Spherical"
      TensorProduct3DMeshGenerator:
        Type: "PdQuickGrid"
        X Origin: 0.0
        Y Origin: 0.0
        Z Origin: 0.0
        X Length: 8.0
        Y Length: 2.0
        Z Length: 2.0
        Number Points X: 8
        Number Points Y: 2
        Number Points Z: 2
    Materials:
      Steel:
        Material Model: "{material}"
        Density: 7800.0
        Bulk Modulus: 130.0e9
        Shear Modulus: 78.0e9
    Blocks:
      All:
        Block Names: "block_1"
        Material: "Steel"
        Horizon: 2.1
    Boundary Conditions:
      End Node Set: "8 16 24 32"
      Pull:
        Type: "Prescribed Displacement"
        Node Set: "End Node Set"
        Coordinate: "x"
        Value: "{value}"
    Solver:
      Initial Time: 0.0
      Final Time: {final}
      Verlet:
        Safety Factor: 0.5
    Output:
      Output Filename: "run"
      Output Frequency: 5
      Output Variables:
        Displacement: true
        Velocity: true
    """
)


def write(folder: Path, material="Elastic", value="1.0e-3*t", final="4.0e-3") -> Path:
    deck = folder / "deck.yaml"
    text = DECK.format(material=material, value=value, final=final)
    if material == "Elastic Bond Based":
        text = text.replace("    Shear Modulus: 78.0e9\n", "")
    deck.write_text(text)
    return deck


def run(deck: Path, *extra: str) -> int:
    return main(["run", str(deck), "--output-dir", str(deck.parent), "-q", "--no-progress", *extra])


def frames_are_finite(path: Path) -> bool:
    with netCDF4.Dataset(path) as ds:
        return all(np.isfinite(np.asarray(v[:])).all() for name, v in ds.variables.items() if name.startswith("vals_"))


@pytest.mark.parametrize("material", ["Elastic", "Elastic Bond Based"])
def test_a_nan_boundary_value_stops_the_run_naming_it(tmp_path, capsys, material):
    deck = write(tmp_path, material=material, value="(t - t)/(t - t)")
    assert run(deck) == ExitCode.UNSTABLE
    err = capsys.readouterr().err
    assert "Boundary Conditions > Pull: the value '(t - t)/(t - t)' is nan" in err
    assert frames_are_finite(tmp_path / "run.e")


def test_a_constant_nan_expression_is_refused_at_once(tmp_path, capsys):
    deck = write(tmp_path, value="0/0")
    assert run(deck) == ExitCode.INPUT_ERROR
    assert "evaluates to nan" in capsys.readouterr().err
    assert not (tmp_path / "run.e").exists()


def test_an_earlier_result_survives_a_failed_run(tmp_path, monkeypatch):
    deck = write(tmp_path)
    assert run(deck) == ExitCode.OK
    good = (tmp_path / "run.e").read_bytes()
    frames = len(read_results(tmp_path / "run.e")["times"])

    from peridyn.engine.output import OutputWriter

    writes = {"n": 0}
    original = OutputWriter.write

    def crash_after_two_frames(self, t):
        original(self, t)
        writes["n"] += 1
        if writes["n"] == 12:
            raise RuntimeError("simulated crash")

    monkeypatch.setattr(OutputWriter, "write", crash_after_two_frames)
    assert run(deck) == ExitCode.FAILURE
    assert (tmp_path / "run.e").read_bytes() == good  # untouched
    partial = read_results(tmp_path / "run.partial.e")  # the crashed run's frames, readable
    assert 1 <= len(partial["times"]) < frames


def test_an_unstable_run_keeps_its_frames_under_the_final_name(tmp_path, capsys):
    deck = write(tmp_path, value="(t - t)/(t - t) + t")
    (tmp_path / "run.e").write_bytes(b"an earlier result")
    assert run(deck) == ExitCode.UNSTABLE
    assert len(read_results(tmp_path / "run.e")["times"]) >= 1
    assert not (tmp_path / "run.partial.e").exists()


@pytest.mark.parametrize(
    "old, new, words",
    [
        ("Density: 7800.0", "Density: true", "must be a number, got the boolean true"),
        ("Density: 7800.0", "density: 7800.0", "'density' is not a deck key: write 'Density'"),
        ("Bulk Modulus: 130.0e9", "Bulk Modulus: inf", "finite"),
        ('Material Model: "Elastic"', "Material Model: [Elastic]", "expected the name of a material model"),
        ("Final Time: 4.0e-3", "Final Time: 0.0", "must be later than 'Initial Time'"),
        ('Output Filename: "run"', 'Output Filename: "out/run"', "plain file name"),
        ('End Node Set: "8 16 24 32"', 'End Node Set: "lonely.txt"', "node-set file"),
        ("Horizon: 2.1", "Horizon: -1.0", "Horizon"),
    ],
)
def test_nonsense_that_parses_is_one_clear_line(tmp_path, capsys, old, new, words):
    deck = write(tmp_path)
    text = deck.read_text()
    assert old in text
    deck.write_text(text.replace(old, new, 1))
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip()
    assert words in err and "Traceback" not in err
    assert all(line.startswith("error: ") and len(line) < 500 for line in err.splitlines())


def test_an_empty_node_set_used_by_a_condition_is_refused(tmp_path, capsys):
    deck = write(tmp_path)
    (tmp_path / "empty.txt").write_text("# no points\n")
    deck.write_text(deck.read_text().replace('End Node Set: "8 16 24 32"', 'End Node Set: "empty.txt"'))
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    assert "node set 'End Node Set' is empty" in capsys.readouterr().err


def test_an_output_label_may_not_shadow_a_field(tmp_path, capsys):
    deck = write(tmp_path)
    deck.write_text(deck.read_text() + textwrap.dedent(
        """
        Compute Class Parameters:
          Shadow:
            Compute Class: "Block_Data"
            Calculation Type: "Sum"
            Block: "block_1"
            Variable: "Force"
            Output Label: "Velocity"
        """))
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    assert "the output label 'Velocity' is already the name of a field" in capsys.readouterr().err


def test_two_outputs_may_not_write_one_file(tmp_path, capsys):
    deck = write(tmp_path)
    text = deck.read_text()
    second = text[text.index("Output:"):].replace("Output:", "Output2:", 1)
    deck.write_text(text + second)
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    assert "writes the same file as 'Output' (run.e)" in capsys.readouterr().err


def test_peridigm_brace_escapes_load(tmp_path):
    deck = write(tmp_path, value=r"if(t <= 1.0e-3)\\{ value = 1.0e-3*t; \\} else\\{ value = 1.0e-8; \\}")
    assert run(deck) == ExitCode.OK


def test_a_folder_or_a_damaged_file_as_mesh_is_an_input_error(tmp_path, capsys):
    (tmp_path / "mesh.g").mkdir()
    deck = tmp_path / "deck.yaml"
    deck.write_text(write(tmp_path).read_text().split("Materials:")[0].replace('Type: "PdQuickGrid"', 'Type: "Exodus"\n  Input Mesh File: "mesh.g"', 1)
                    .split("  NeighborhoodType")[0] + "Materials:" + write(tmp_path).read_text().split("Materials:")[1])
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    assert "is a folder, not a file" in capsys.readouterr().err
    (tmp_path / "mesh.g").rmdir()
    (tmp_path / "mesh.g").write_bytes(b"CDF\x01" + bytes(range(256)) * 4)
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    assert "Exodus" in capsys.readouterr().err


def test_a_deeply_nested_deck_is_an_input_error(tmp_path, capsys):
    deck = tmp_path / "deep.yaml"
    deck.write_text("Peridigm:\n  A: " + "[" * 5000 + "]" * 5000 + "\n")
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    assert "nested too deeply" in capsys.readouterr().err


def test_a_frame_with_nan_is_never_written(tmp_path):
    from peridyn.core.errors import InstabilityError
    from peridyn.deck.model import load_deck
    from peridyn.engine.simulation import Simulation

    sim = Simulation(load_deck(write(tmp_path)), output_dir=tmp_path)
    run = RunServices.of(sim)
    run.write_output(0.0)
    sim.fields["Velocity"][5, 1] = np.nan
    for _ in range(5):  # the output frequency is 5
        try:
            run.write_output(1.0)
        except InstabilityError as exc:
            assert f"Velocity is not finite at point {int(sim.gid[5]) + 1} at t = 1" in str(exc)
            break
    else:
        pytest.fail("the NaN frame was written")
    run.close(complete=True)
    assert frames_are_finite(tmp_path / "run.e")
    assert len(read_results(tmp_path / "run.e")["times"]) == 1
