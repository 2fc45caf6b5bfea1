"""Files a command writes (issue #33): a folder or a non-file where a run writes or renames a
file, a Restart folder that is a file, an --output-dir that is one, an XML deck too deep, of an
unknown encoding or with entities, an output path of schema, convert, fragments, plot or
new-plugin that is a folder, under a file or missing: each is exit 2 with one line before any
work, and nothing that was there is changed; files are written whole or not at all."""
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from tests.unit.engine.test_checkpoint_check import CUBE, write_cube


def errors(capsys) -> list[str]:
    return [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("error")]


def run(folder: Path, *extra: str) -> int:
    return main(["run", str(folder / "cube.yaml"), "--output-dir", str(folder), "-q", "--no-progress", *extra])


# -- what a run writes or renames ------------------------------------------------------------------
@pytest.mark.parametrize("in_the_way, key", [
    ("cube.e", "Output > Output Filename"),
    ("cube.partial.e", "Output > Output Filename"),
    ("cube.lock", "Output > Output Filename"),
    ("restart/cube.000.0000000010.npz", "Restart > Folder"),
    ("restart/cube.001.0000000000.npz", "Restart > Folder"),
])
def test_a_folder_where_the_run_writes_a_file_is_refused_before_any_work(tmp_path, capsys, in_the_way, key):
    write_cube(tmp_path)
    (tmp_path / in_the_way).mkdir(parents=True)
    (tmp_path / in_the_way / "keep.txt").write_text("mine")
    assert run(tmp_path) == ExitCode.INPUT_ERROR
    lines = errors(capsys)
    assert len(lines) == 1 and key in lines[0] and "is a folder" in lines[0] and in_the_way.split("/")[-1] in lines[0], lines
    assert (tmp_path / in_the_way / "keep.txt").read_text() == "mine"
    assert not (tmp_path / "cube.partial.e").is_file() and not (tmp_path / "restart" / "cube.000.0000000020.npz").exists()


def test_a_folder_where_a_history_file_goes_is_refused(tmp_path, capsys):
    write_cube(tmp_path)
    deck = tmp_path / "cube.yaml"
    deck.write_text(deck.read_text() + "History Output:\n  Output Filename: \"energy\"\n  Output Frequency: 5\n"
                                       "  Output Variables:\n    Global_Kinetic_Energy: true\n")
    (tmp_path / "energy.h").mkdir()
    assert run(tmp_path) == ExitCode.INPUT_ERROR
    lines = errors(capsys)
    assert len(lines) == 1 and "History Output > Output Filename" in lines[0] and "energy.h" in lines[0], lines
    assert not (tmp_path / "cube.partial.e").exists()


def test_a_restart_folder_that_is_a_file_or_under_one_is_refused(tmp_path, capsys):
    write_cube(tmp_path)
    (tmp_path / "restart").write_text("mine")
    assert run(tmp_path) == ExitCode.INPUT_ERROR
    lines = errors(capsys)
    assert len(lines) == 1 and "Restart > Folder" in lines[0] and "is a file" in lines[0], lines
    deck = tmp_path / "cube.yaml"
    deck.write_text(deck.read_text().replace("  Keep: 10", "  Keep: 10\n  Folder: \"restart/deeper\""))
    assert run(tmp_path) == ExitCode.INPUT_ERROR
    lines = errors(capsys)
    assert len(lines) == 1 and "Restart > Folder" in lines[0] and "is a file, not a folder" in lines[0], lines
    assert (tmp_path / "restart").read_text() == "mine" and not (tmp_path / "cube.partial.e").exists()


@pytest.mark.parametrize("where", ["file", "under a file"])
def test_an_output_dir_that_is_a_file_or_under_one_is_refused(tmp_path, capsys, where):
    write_cube(tmp_path)
    (tmp_path / "f").write_text("mine")
    target = tmp_path / "f" if where == "file" else tmp_path / "f" / "out"
    assert main(["run", str(tmp_path / "cube.yaml"), "--output-dir", str(target), "-q"]) == ExitCode.INPUT_ERROR
    lines = errors(capsys)
    assert len(lines) == 1 and "--output-dir" in lines[0] and "is a file" in lines[0], lines
    assert (tmp_path / "f").read_text() == "mine"


def test_the_command_exits_2_with_one_line_when_name_e_is_a_folder(tmp_path):
    write_cube(tmp_path)
    (tmp_path / "cube.e").mkdir()
    proc = subprocess.run([sys.executable, "-m", "peridyn", "run", "cube.yaml", "--no-progress"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1 and "cube.e" in proc.stderr and "is a folder" in proc.stderr, proc.stderr
    assert not (tmp_path / "restart").exists()  # no step ran, no checkpoint was written


def test_check_reports_a_folder_where_the_run_writes(tmp_path, capsys, monkeypatch):
    write_cube(tmp_path)
    (tmp_path / "cube.e").mkdir()
    monkeypatch.chdir(tmp_path)
    assert main(["check", "cube.yaml", "-q"]) == ExitCode.INPUT_ERROR
    assert "is a folder" in errors(capsys)[0]


def test_a_dot_in_the_output_filename_is_named_in_a_warning(tmp_path, capsys):
    """Peridigm replaces every '.' and space of Output Filename by '_' (its Exodus writer, with a
    warning): the same file is written, and the warning says which."""
    write_cube(tmp_path)
    deck = tmp_path / "cube.yaml"
    deck.write_text(deck.read_text().replace('Output Filename: "cube"', 'Output Filename: "bar_1.0"'))
    assert run(tmp_path) == ExitCode.OK
    err = capsys.readouterr().err
    assert (tmp_path / "bar_1_0.e").is_file()
    assert [ln for ln in err.splitlines() if "bar_1.0" in ln and "bar_1_0.e" in ln], err


# -- the continue command --------------------------------------------------------------------------
def test_the_command_to_continue_names_the_output_dir_and_runs(tmp_path, monkeypatch):
    """The message of a stopped run gives a command that, run as given, continues it."""
    from types import SimpleNamespace

    from peridyn.engine.restart import continue_command

    out = tmp_path / "out dir"
    sim = SimpleNamespace(comm=SimpleNamespace(size=1), deck=SimpleNamespace(file="cube.yaml"), output_dir=out)
    monkeypatch.chdir(tmp_path)
    assert shlex.split(continue_command(sim)) == ["peridyn", "run", "cube.yaml", "--output-dir", str(out), "--restart"]
    sim.comm.size = 2
    assert shlex.split(continue_command(sim))[:4] == ["mpiexec", "-n", "2", "peridyn"]
    sim.output_dir = tmp_path
    assert continue_command(sim) == "mpiexec -n 2 peridyn run cube.yaml --restart"


# -- XML decks -------------------------------------------------------------------------------------
def _xml(depth: int) -> str:
    return '<ParameterList name="x">' + '<ParameterList name="a">' * depth + "</ParameterList>" * depth + "</ParameterList>"


BAD_XML = {
    "deep": _xml(5000),
    "deep unknown elements": '<ParameterList name="x">' + "<foo>" * 5000 + "</foo>" * 5000 + "</ParameterList>",
    "billion laughs": '<?xml version="1.0"?><!DOCTYPE l [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]>'
                      '<ParameterList name="x"><Parameter name="v" type="string" value="&b;"/></ParameterList>',
    "external entity": '<?xml version="1.0"?><!DOCTYPE l [<!ENTITY e SYSTEM "/etc/passwd">]><ParameterList name="x">&e;</ParameterList>',
    "undefined entity": '<ParameterList name="x"><Parameter name="v" type="string" value="&e;"/></ParameterList>',
    "unknown encoding": '<?xml version="1.0" encoding="nonsense"?><ParameterList name="x"/>',
    "malformed": '<ParameterList name="x"><Parameter name="v" type="string"',
    "not a ParameterList": "<deck/>",
    "empty": "",
}


@pytest.mark.parametrize("case", sorted(BAD_XML))
@pytest.mark.parametrize("command", ["convert", "run"])
def test_a_bad_xml_deck_is_one_line_exit_2(tmp_path, capsys, case, command):
    deck = tmp_path / "deck.xml"
    deck.write_text(BAD_XML[case])
    argv = ["convert", str(deck), str(tmp_path / "out.yaml")] if command == "convert" else ["run", str(deck), "-q", "--output-dir", str(tmp_path)]
    assert main(argv) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.startswith("error")]  # (an ignored element is a warning of its own)
    assert len(lines) == 1 and lines[0].startswith(f"error: {deck}") and "Traceback" not in err, err
    assert not (tmp_path / "out.yaml").exists()


def test_a_deck_nested_within_the_limit_converts(tmp_path, capsys):
    from peridyn.deck.xml_reader import MAX_DEPTH

    deck = tmp_path / "deck.xml"
    deck.write_text(_xml(MAX_DEPTH - 2))
    assert main(["convert", str(deck), str(tmp_path / "out.yaml")]) == ExitCode.OK
    deck.write_text(_xml(MAX_DEPTH))
    assert main(["convert", str(deck), str(tmp_path / "out2.yaml")]) == ExitCode.INPUT_ERROR
    assert f"more than {MAX_DEPTH} levels" in capsys.readouterr().err


def test_convert_of_a_5000_deep_deck_exits_2_in_one_line(tmp_path):
    (tmp_path / "deep.xml").write_text(BAD_XML["deep"])
    proc = subprocess.run([sys.executable, "-m", "peridyn", "convert", "deep.xml", "deep.yaml"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and "levels deep" in proc.stderr, proc.stderr


VALID_XML = ('<ParameterList name="x"><ParameterList name="Materials"><ParameterList name="M">'
             '<Parameter name="Material Model" type="string" value="Elastic"/><Parameter name="Density" type="double" value="1.0"/>'
             "</ParameterList></ParameterList></ParameterList>")


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cut=st.integers(0, len(VALID_XML) - 1), junk=st.text(max_size=3))
def test_an_xml_deck_cut_anywhere_is_one_line_exit_2(tmp_path, capsys, cut, junk):
    deck = tmp_path / "cut.xml"
    deck.write_text(VALID_XML[:cut] + junk)
    capsys.readouterr()
    status = main(["convert", str(deck), str(tmp_path / "cut.yaml")])
    lines = capsys.readouterr().err.strip().splitlines()
    assert status == ExitCode.INPUT_ERROR and len(lines) == 1 and lines[0].startswith("error: "), lines


# -- output paths of the other commands ------------------------------------------------------------
def _paths(tmp_path: Path) -> dict[str, Path]:
    (tmp_path / "adir").mkdir()
    (tmp_path / "afile").write_text("mine")
    return {"a folder": tmp_path / "adir", "under a file": tmp_path / "afile" / "x.out", "a missing folder": tmp_path / "nodir" / "x.out",
            "a name too long": tmp_path / ("n" * 300 + ".out")}


@pytest.mark.parametrize("kind", ["a folder", "under a file", "a missing folder", "a name too long"])
@pytest.mark.parametrize("command", ["schema -o", "schema --reference", "convert", "fragments --plot"])
def test_an_output_path_that_cannot_be_a_file_is_one_line_exit_2(tmp_path, capsys, command, kind):
    target = _paths(tmp_path)[kind]
    if command == "convert":
        write_cube(tmp_path)
        target = target.with_suffix(".yaml") if kind != "a folder" else target
        if kind == "a folder":
            target = tmp_path / "d.yaml"
            target.mkdir()
        argv = ["convert", str(tmp_path / "cube.yaml"), str(target)]
    elif command == "fragments --plot":
        argv = ["fragments", str(tmp_path / "none.e"), "--plot", str(target)]
    else:
        argv = command.split() + [str(target)]
    capsys.readouterr()
    assert main(argv) == ExitCode.INPUT_ERROR
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    assert command.split()[-1] in lines[0] or "convert OUT" in lines[0], lines
    assert (tmp_path / "afile").read_text() == "mine" and sorted(p.name for p in (tmp_path / "adir").iterdir()) == []
    assert not (tmp_path / "nodir").exists()


@pytest.mark.parametrize("command", [["new-plugin", "my_model", "--directory"], ["plot", "none.e", "--out"]])
def test_a_folder_argument_under_a_file_is_one_line_exit_2(tmp_path, capsys, command):
    (tmp_path / "afile").write_text("mine")
    target = tmp_path / "afile" / ("x" if command[0] == "plot" else "")
    assert main(command + [str(target / "p") if command[0] == "plot" else str(tmp_path / "afile")]) == ExitCode.INPUT_ERROR
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "is a file" in lines[0], lines
    assert (tmp_path / "afile").read_text() == "mine"


def test_a_schema_that_fails_to_build_leaves_the_old_file_and_no_temporary_one(tmp_path, capsys, monkeypatch):
    import peridyn.deck.schema as schema

    out = tmp_path / "schema.json"
    out.write_text("old")

    def broken():
        raise RuntimeError("boom")

    monkeypatch.setattr(schema, "deck_json_schema", broken)
    assert main(["schema", "-o", str(out)]) == ExitCode.FAILURE
    assert out.read_text() == "old" and sorted(os.listdir(tmp_path)) == ["schema.json"]
    monkeypatch.undo()
    assert main(["schema", "-o", str(out)]) == ExitCode.OK
    assert out.read_text().startswith("{") and sorted(os.listdir(tmp_path)) == ["schema.json"]
    assert main(["schema", "--reference", str(tmp_path / "ref.md")]) == ExitCode.OK
    assert (tmp_path / "ref.md").read_text().startswith("#")
    assert sorted(os.listdir(tmp_path)) == ["ref.md", "schema.json"]


def test_an_empty_output_dir_is_refused_not_taken_for_the_current_folder(tmp_path):
    """Found by benchmarks/surface_campaign.py: `run deck --output-dir ""` was exit 0, writing into the current folder."""
    write_cube(tmp_path)
    proc = subprocess.run([sys.executable, "-m", "peridyn", "run", "cube.yaml", "--output-dir", "", "-q", "--no-progress"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == ExitCode.INPUT_ERROR, proc.stderr
    assert proc.stderr.splitlines() == ["error: --output-dir is empty; give a folder (or leave it out for the current one)"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cube.yaml"]
