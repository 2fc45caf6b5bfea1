"""Output names and folders the file system refuses are input errors before any work; two runs
never write the same files at once; random fields are the same for every run of a deck; a
check writes nothing; an output variable of another material is one clear line (issue #19)."""
import os
import textwrap
from pathlib import Path

import numpy as np
import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.deck.model import load_deck
from peridyn.engine.output import OutputLock

DECK = textwrap.dedent(
    """
    {top}
    Discretization:
      Type: "PdQuickGrid"
      NeighborhoodType: "Spherical"
      TensorProduct3DMeshGenerator:
        Type: "PdQuickGrid"
        X Origin: 0.0
        Y Origin: 0.0
        Z Origin: 0.0
        X Length: 4.0
        Y Length: 2.0
        Z Length: 2.0
        Number Points X: 4
        Number Points Y: 2
        Number Points Z: 2
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
        Horizon: 2.1
    Boundary Conditions:
      All Node Set: "1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16"
      Kick X:
        Type: "Initial Velocity"
        Node Set: "All Node Set"
        Coordinate: "x"
        Value: "rnd(1.0)"
      Kick Y:
        Type: "Initial Velocity"
        Node Set: "All Node Set"
        Coordinate: "y"
        Value: "rnd(1.0)"
    Solver:
      Initial Time: 0.0
      Final Time: 1.0e-3
      Verlet:
        Safety Factor: 0.5
    Output:
      Output Filename: "{name}"
      Output Frequency: 1
      Output Variables:
        {variables}
    """
)


def write(folder: Path, name="run", variables=("Velocity",), top="") -> Path:
    deck = folder / "deck.yaml"
    deck.write_text(DECK.format(name=name, variables="\n    ".join(f"{v}: true" for v in variables), top=top))
    return deck


def run(deck: Path, folder: Path | None = None) -> int:
    return main(["run", str(deck), "--output-dir", str(folder or deck.parent), "-q", "--no-progress"])


def error_lines(capsys) -> list[str]:
    return [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]


# ---------------------------------------------------------------------------------------------
# names and folders


def test_a_too_long_output_filename_is_an_input_error_before_any_work(tmp_path, capsys, monkeypatch):
    deck = write(tmp_path, name="a" * 300)
    from peridyn.engine import simulation

    monkeypatch.setattr(simulation.Simulation, "__init__", lambda *a, **k: pytest.fail("set-up started"))
    before = sorted(os.listdir(tmp_path))
    assert run(deck) == ExitCode.INPUT_ERROR
    lines = error_lines(capsys)
    assert len(lines) == 1 and "Output > Output Filename" in lines[0] and "300 characters" in lines[0]
    assert sorted(os.listdir(tmp_path)) == before


def test_a_too_long_output_filename_is_reported_by_check(tmp_path, capsys, monkeypatch):
    deck = write(tmp_path, name="b" * 250)
    monkeypatch.chdir(tmp_path)
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    assert "Output > Output Filename" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["a/b", "bad\0name", "..", "   "])
def test_an_output_filename_that_is_not_a_plain_name_is_an_input_error(tmp_path, capsys, name):
    deck = write(tmp_path)
    text = deck.read_text().replace('Output Filename: "run"', f"Output Filename: {name!r}".replace("'", '"').replace("\0", "\\0"))
    deck.write_text(text)
    assert run(deck) == ExitCode.INPUT_ERROR
    lines = error_lines(capsys)
    assert len(lines) == 1 and "Output Filename" in lines[0]


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs a folder this user cannot write (not root)")
def test_an_output_folder_that_cannot_be_written_is_an_input_error_before_any_work(tmp_path, capsys, monkeypatch):
    deck = write(tmp_path)
    out = tmp_path / "readonly"
    out.mkdir()
    out.chmod(0o555)
    from peridyn.engine import simulation

    monkeypatch.setattr(simulation.Simulation, "__init__", lambda *a, **k: pytest.fail("set-up started"))
    try:
        assert run(deck, out) == ExitCode.INPUT_ERROR
    finally:
        out.chmod(0o755)
    lines = error_lines(capsys)
    assert len(lines) == 1 and "cannot create files in the output folder" in lines[0] and "readonly" in lines[0]


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs /proc")
def test_an_output_folder_where_no_file_can_be_created_is_an_input_error(tmp_path, capsys):
    deck = write(tmp_path)
    assert run(deck, Path("/proc/self")) == ExitCode.INPUT_ERROR  # a folder even root cannot write
    lines = error_lines(capsys)
    assert len(lines) == 1 and "cannot create files in the output folder" in lines[0], lines


def test_an_output_folder_under_a_file_is_an_input_error(tmp_path, capsys):
    deck = write(tmp_path)
    (tmp_path / "file").write_text("")
    assert run(deck, tmp_path / "file" / "sub") == ExitCode.INPUT_ERROR
    assert len(error_lines(capsys)) == 1


# ---------------------------------------------------------------------------------------------
# one run at a time per output file


def test_a_second_run_writing_the_same_files_is_refused_at_start(tmp_path, capsys, monkeypatch):
    deck = write(tmp_path)
    (tmp_path / "run.e").write_bytes(b"an earlier result")
    other = OutputLock(tmp_path / "run.lock")  # a run in progress (another open file: flock conflicts)
    assert other.acquire()
    from peridyn.engine import simulation

    monkeypatch.setattr(simulation.Simulation, "__init__", lambda *a, **k: pytest.fail("set-up started"))
    try:
        assert run(deck) == ExitCode.INPUT_ERROR
    finally:
        other.release()
    lines = error_lines(capsys)
    assert len(lines) == 1 and "another run" in lines[0] and f"process {os.getpid()}" in lines[0]
    assert "Output > Output Filename" in lines[0]
    assert (tmp_path / "run.e").read_bytes() == b"an earlier result"
    assert not (tmp_path / "run.partial.e").exists()


def test_the_lock_is_released_after_a_run_and_a_stale_lock_does_not_block(tmp_path):
    deck = write(tmp_path)
    (tmp_path / "run.lock").write_text("999999999\n")  # left by a run that crashed: nobody holds it
    assert run(deck) == ExitCode.OK
    assert (tmp_path / "run.e").exists()
    assert not (tmp_path / "run.lock").exists()  # released and removed
    assert run(deck) == ExitCode.OK  # and the next run may go


def test_an_output_and_a_history_section_of_one_name_are_one_run(tmp_path):
    """Peridigm's decks write NAME.e and NAME.h (a section of global variables only) under one
    Output Filename: the run's own second section is not "another run"."""
    deck = write(tmp_path)
    deck.write_text(deck.read_text() + textwrap.dedent(
        """
        Output History:
          Output Filename: "run"
          Output Frequency: 1
          Output Variables:
            Global_Kinetic_Energy: true
        """))
    assert run(deck) == ExitCode.OK
    assert (tmp_path / "run.e").exists() and (tmp_path / "run.h").exists()
    assert not (tmp_path / "run.lock").exists()


def test_the_lock_is_released_when_a_run_fails(tmp_path, monkeypatch):
    deck = write(tmp_path)
    from peridyn.engine import session

    def boom(sim):
        raise RuntimeError("simulated crash")

    monkeypatch.setattr(session, "run_sections", boom)
    assert run(deck) == ExitCode.FAILURE
    lock = OutputLock(tmp_path / "run.lock")
    assert lock.acquire()
    lock.release()


def test_a_held_lock_refuses_a_second_holder(tmp_path):
    a, b = OutputLock(tmp_path / "x.lock"), OutputLock(tmp_path / "x.lock")
    assert a.acquire()
    assert not b.acquire()
    a.release()
    assert b.acquire()
    b.release()
    assert not (tmp_path / "x.lock").exists()


# ---------------------------------------------------------------------------------------------
# random fields


def velocities(folder: Path, top="") -> np.ndarray:
    from peridyn.engine.simulation import Simulation

    deck = load_deck(write(folder, top=top))
    sim = Simulation(deck, output_dir=folder)
    v = np.empty((sim.num_global, 3))
    v[sim.gid[: sim.num_owned]] = sim.fields["Velocity"][: sim.num_owned]
    return v


def test_random_initial_conditions_are_the_same_for_a_second_simulation_in_one_process(tmp_path):
    from peridyn.deck.expressions import compile_expression

    first = velocities(tmp_path)
    compile_expression("rnd(1)", ("x",))(x=np.zeros(100))  # anything drawn in between changes nothing
    second = velocities(tmp_path)
    np.testing.assert_array_equal(first, second)
    assert np.all(np.abs(first[:, :2]) <= 1.0) and np.all(first[:, 2] == 0.0)
    assert len(np.unique(first[:, :2])) == first[:, :2].size  # X and Y, and every point, differ
    # the values are the hash of the seed, the condition and the global id
    ids = np.arange(first.shape[0])
    kick_x = compile_expression("rnd(1.0)", ("x", "y", "z", "t"), seed=0, stream="Boundary Conditions > Kick X")
    np.testing.assert_array_equal(first[:, 0], kick_x(ids))


def test_the_random_seed_is_set_in_the_deck(tmp_path):
    base = velocities(tmp_path)
    seeded = velocities(tmp_path, top="Random Seed: 12345")
    assert not np.any(seeded[:, :2] == base[:, :2])
    np.testing.assert_array_equal(velocities(tmp_path, top="Random Seed: 0"), base)


@pytest.mark.parametrize("value", ["-1", "1.5", "true", '"abc"'])
def test_a_bad_random_seed_is_an_input_error(tmp_path, capsys, value):
    deck = write(tmp_path, top=f"Random Seed: {value}")
    assert run(deck) == ExitCode.INPUT_ERROR
    lines = error_lines(capsys)
    assert len(lines) == 1 and "Random Seed" in lines[0]


# ---------------------------------------------------------------------------------------------
# output variables of other models


def test_an_output_variable_of_another_material_is_one_line_naming_the_models(tmp_path, capsys):
    deck = write(tmp_path, variables=("Velocity", "Von_Mises_Stress", "Cauchy_Stress", "Displacment"))
    assert run(deck) == ExitCode.INPUT_ERROR
    lines = error_lines(capsys)
    assert len(lines) == 3, lines
    vm = next(ln for ln in lines if "Von_Mises_Stress" in ln)
    assert "Output > Output Variables > Von_Mises_Stress: produced by the " in vm
    assert "Elastic Plastic Correspondence" in vm and "this deck's materials (Elastic) do not" in vm
    assert "Max_Von_Mises_Stress" not in vm and "remove it or change the material" in vm
    assert "Elastic Correspondence" in next(ln for ln in lines if "Cauchy_Stress" in ln)
    assert "did you mean 'Displacement'" in next(ln for ln in lines if "Displacment" in ln)
    assert all(len(ln.replace(str(deck), "deck.yaml")) < 300 for ln in lines)


def test_an_output_the_system_refuses_to_write_is_a_failed_run_not_a_bug(tmp_path, capsys, monkeypatch):
    """Disk full or a file-size limit: exit 3 with one line, the earlier NAME.e untouched, the
    frames written before in NAME.partial.e (it was exit 1, 'internal error')."""
    import errno

    from peridyn.io.exodus_writer import ExodusWriter

    deck = write(tmp_path)
    (tmp_path / "run.e").write_bytes(b"an earlier result")
    calls = []

    def full(self, *a, **k):
        calls.append(1)
        if len(calls) > 2:
            raise OSError(errno.EFBIG, "File too large")

    monkeypatch.setattr(ExodusWriter, "write_step", full)
    assert run(deck) == ExitCode.UNSTABLE
    lines = error_lines(capsys)
    assert lines[-1].startswith("error: Output: writing run.partial.e failed at t = ") and "File too large" in lines[-1]
    assert (tmp_path / "run.e").read_bytes() == b"an earlier result"
    assert (tmp_path / "run.partial.e").exists()
    assert not (tmp_path / "run.lock").exists()
