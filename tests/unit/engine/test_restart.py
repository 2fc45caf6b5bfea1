"""Checkpoints and restarts (docs/restart.md): a run continued from a checkpoint writes the
same Exodus file, bit for bit, as the run that was never stopped; SIGTERM stops a run at a
checkpoint; a run killed at a random moment leaves a usable checkpoint and a readable output."""
import json
import os
import random
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import netCDF4
import numpy as np
import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.deck.files import dump_yaml
from peridyn.engine.restart import checkpoints_of
from peridyn.io.exodus_reader import read_results
from peridyn.io.exodus_writer import ExodusBlock, ExodusWriter, keep_steps


def flyby_tree(final_time: float = 0.01, frequency: int = 6, keep: int = 100, damage: bool = True) -> dict:
    """A box flying past a row of boxes it grazes: contact with friction (searches every 7
    steps, pair lists rebuilt in between), damage in the row (``damage=False``: none, so no bond
    field), 36 steps for final_time 0.01."""
    shapes = {f"B{k}": {"Shape": "Box", "Block": "block_1", "Min": [4.0 * k, 0.0, 0.0], "Max": [4.0 * k + 3.0, 3.0, 3.0], "Spacing": 1.0}
              for k in range(3)}
    shapes["Fly"] = {"Shape": "Box", "Block": "block_2", "Min": [-4.0, 0.4, 2.2], "Max": [-1.0, 2.4, 4.2], "Spacing": 1.0}
    tree = {
        "Discretization": {"Type": "Shapes", "Omit Bonds Between Blocks": "All", "Shapes": shapes},
        "Materials": {"M": {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1e9, "Shear Modulus": 6e8}},
        "Damage Models": {"D": {"Damage Model": "Critical Stretch", "Critical Stretch": 0.002}},
        "Blocks": {"Row": {"Block Names": "block_1", "Material": "M", "Damage Model": "D", "Horizon": 2.015},
                   "Fly": {"Block Names": "block_2", "Material": "M", "Horizon": 2.015}},
        "Contact": {"Search Radius": 3.0, "Search Frequency": 7,
                    "Models": {"C": {"Contact Model": "Short Range Force", "Contact Radius": 1.0, "Spring Constant": 1e9,
                                     "Friction Coefficient": 0.3}}},
        "Boundary Conditions": {"Go": {"Type": "Initial Velocity", "Node Set": "Fly", "Coordinate": "x", "Value": "800.0"}},
        "Solver": {"Final Time": final_time, "Verlet": {"Safety Factor": 0.5}},
        "Output": {"Output Filename": "flyby", "Output Frequency": 3,
                   "Output Variables": {"Displacement": True, "Velocity": True, "Contact_Force_Density": True, "Damage": True}},
        "History Output": {"Output Filename": "energy", "Output Frequency": 2, "Output Variables": {"Global_Kinetic_Energy": True}},
        "Restart": {"Restart Frequency": frequency, "Keep": keep},
    }
    if not damage:
        del tree["Damage Models"], tree["Blocks"]["Row"]["Damage Model"], tree["Output"]["Output Variables"]["Damage"]
    return tree


def write_deck(folder: Path, **kw) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    deck = folder / "flyby.yaml"
    deck.write_text(dump_yaml(flyby_tree(**kw)))
    return deck


def run(deck: Path, out: Path, *extra: str) -> int:
    return main(["run", str(deck), "--output-dir", str(out), "-q", "--no-progress", *extra])


def exodus_values(path: Path) -> dict[str, np.ndarray]:
    with netCDF4.Dataset(path) as ds:
        return {k: np.array(v[:]) for k, v in ds.variables.items() if k.startswith("vals_") or k == "time_whole"}


def assert_same_file(a: Path, b: Path) -> None:
    va, vb = exodus_values(a), exodus_values(b)
    assert va.keys() == vb.keys()
    for k in va:
        assert va[k].shape == vb[k].shape, k
        assert np.array_equal(va[k], vb[k]), k


def final_state(folder: Path) -> dict[str, np.ndarray]:
    """The arrays of the checkpoint at the end of the run (every field, N and NP1)."""
    (pos, path), = [(p, f) for p, f in checkpoints_of(folder / "restart", "flyby") if p == (1, 0)]
    with np.load(path) as data:
        return {k: data[k] for k in data.files if k != "meta"}


def energy_monitor(folder: Path) -> dict:
    """The energy monitor's accumulators after the last step (checkpoint (0, 36))."""
    (pos, path), = [(p, f) for p, f in checkpoints_of(folder / "restart", "flyby") if p == (0, 36)]
    with np.load(path) as data:
        return json.loads(str(data["meta"]))["monitor"]


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("whole")
    deck = write_deck(out)
    assert run(deck, out) == ExitCode.OK
    return out


def test_the_deck_exercises_contact_and_damage(uninterrupted):
    res = read_results(uninterrupted / "flyby.e")
    assert res["times"].size == 13
    assert np.nanmax(res["element"]["Damage"]) > 0.05  # bonds broke
    assert np.abs(res["nodal"]["Contact_Force_DensityX"]).max() > 0.0
    assert [p for p, _ in checkpoints_of(uninterrupted / "restart", "flyby")] == [(0, k) for k in range(6, 37, 6)] + [(1, 0)]


@pytest.mark.parametrize("checkpoint", [(0, 6), (0, 18), (0, 30), (1, 0)])
def test_a_run_continued_from_any_checkpoint_writes_the_uninterrupted_file(uninterrupted, tmp_path, checkpoint):
    """The output folder as a run stopped after the checkpoint left it (with frames written
    after it, which the restart drops) continues to the same file and final state."""
    out = tmp_path / "again"
    shutil.copytree(uninterrupted, out)
    path = dict(checkpoints_of(out / "restart", "flyby"))[checkpoint]
    assert run(out / "flyby.yaml", out, "--restart", str(path)) == ExitCode.OK
    assert_same_file(uninterrupted / "flyby.e", out / "flyby.e")
    assert_same_file(uninterrupted / "energy.h", out / "energy.h")
    assert not (out / "flyby.partial.e").exists() and not (out / "energy.partial.h").exists()
    a, b = final_state(uninterrupted), final_state(out)
    assert a.keys() == b.keys() and "np1/Bond_Damage" in a and "contact/y_build" in a
    for k in a:
        assert np.array_equal(a[k], b[k]), k
    if checkpoint < (0, 36):
        assert energy_monitor(out) == energy_monitor(uninterrupted)  # the energy account goes on as it was


def test_restart_alone_takes_the_latest_checkpoint_and_a_changed_restart_section_is_allowed(uninterrupted, tmp_path):
    out = tmp_path / "again"
    shutil.copytree(uninterrupted, out)
    for pos, p in checkpoints_of(out / "restart", "flyby"):
        if pos > (0, 18):
            p.unlink()
    (out / "flyby.yaml").write_text(dump_yaml(flyby_tree(frequency=4, keep=2)))  # only Restart changed
    assert run(out / "flyby.yaml", out, "--restart") == ExitCode.OK
    assert_same_file(uninterrupted / "flyby.e", out / "flyby.e")
    assert [p for p, _ in checkpoints_of(out / "restart", "flyby")] == [(0, 36), (1, 0)]  # Keep 2
    assert energy_monitor(out) == energy_monitor(uninterrupted)


def _start(deck: Path, out: Path) -> subprocess.Popen:
    env = dict(os.environ, PERIDYN_NO_PROGRESS="1")
    return subprocess.Popen([sys.executable, "-m", "peridyn", "run", str(deck), "--output-dir", str(out), "-q"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def _wait_for_checkpoint(proc: subprocess.Popen, folder: Path, timeout: float = 120.0) -> None:
    t0 = time.monotonic()
    while not checkpoints_of(folder / "restart", "flyby"):
        assert proc.poll() is None, proc.communicate()[1][-2000:]
        assert time.monotonic() - t0 < timeout
        time.sleep(0.01)


LONG = {"final_time": 0.1, "frequency": 25, "keep": 2}  # 364 steps


@pytest.fixture(scope="module")
def uninterrupted_long(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("long")
    deck = write_deck(out, **LONG)
    assert run(deck, out) == ExitCode.OK
    return out


@pytest.mark.parametrize("signum, status", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_signal_writes_a_checkpoint_at_the_step_end_and_exits_128_plus_it(uninterrupted_long, tmp_path, signum, status):
    deck = write_deck(tmp_path, **LONG)
    proc = _start(deck, tmp_path)
    _wait_for_checkpoint(proc, tmp_path)
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=120)
    if proc.returncode == 0:
        pytest.skip("the run ended before the signal came")  # not seen on this machine: a 364-step run
    assert proc.returncode == status, err
    m = re.search(rf"stopped by {signal.Signals(signum).name} after step (\d+) of solver section 1 .*--restart", err)
    assert m, err
    assert checkpoints_of(tmp_path / "restart", "flyby")[-1][0] == (0, int(m[1]))  # written at the step the signal stopped
    partial = read_results(tmp_path / "flyby.partial.e")  # readable, frames so far
    assert 0 < partial["times"].size < 122
    command = re.search(r"continue with '(.+)'", err)[1]  # the command the message gives, run as given
    assert command == f"peridyn run {deck} --output-dir {tmp_path} --restart", err
    assert main(shlex.split(command)[1:] + ["-q", "--no-progress"]) == ExitCode.OK
    assert_same_file(uninterrupted_long / "flyby.e", tmp_path / "flyby.e")


@pytest.mark.parametrize("seed", [1, 2])
def test_a_run_killed_at_a_random_moment_continues_to_the_uninterrupted_file(uninterrupted_long, tmp_path, seed):
    """SIGKILL (no chance to clean up) at a random moment after the first checkpoint: the latest
    checkpoint is usable, the partial output readable, and the restart equals the whole run."""
    deck = write_deck(tmp_path, **LONG)
    proc = _start(deck, tmp_path)
    _wait_for_checkpoint(proc, tmp_path)
    time.sleep(random.Random(seed).uniform(0.0, 0.4))
    proc.kill()
    proc.communicate(timeout=60)
    output = tmp_path / ("flyby.partial.e" if (tmp_path / "flyby.partial.e").exists() else "flyby.e")  # killed as it ended
    assert read_results(output)["times"].size >= 1
    assert run(deck, tmp_path, "--restart") == ExitCode.OK
    assert_same_file(uninterrupted_long / "flyby.e", tmp_path / "flyby.e")


# -- what is refused --------------------------------------------------------------------------
def _bad_checkpoint(out: Path) -> str:
    p = out / "garbage.npz"
    p.write_bytes(b"not a zip file")
    return str(p)


@pytest.mark.parametrize("case, expected", [
    ("changed deck", "written by another deck"),
    ("missing file", "no checkpoint"),
    ("not a checkpoint", "not a readable peridyn checkpoint"),
    ("no checkpoint in folder", "no checkpoint of flyby"),
    ("output gone", "frame(s) written before the checkpoint are gone"),
])
def test_a_checkpoint_this_run_cannot_continue_is_refused_in_one_line(uninterrupted, tmp_path, capsys, case, expected):
    out = tmp_path / "again"
    shutil.copytree(uninterrupted, out)
    deck = out / "flyby.yaml"
    args = ["--restart", str(dict(checkpoints_of(out / "restart", "flyby"))[(0, 18)])]
    if case == "changed deck":
        tree = flyby_tree()
        tree["Materials"]["M"]["Density"] = 1001.0
        deck.write_text(dump_yaml(tree))
    elif case == "missing file":
        args = ["--restart", str(out / "nothing.npz")]
    elif case == "not a checkpoint":
        args = ["--restart", _bad_checkpoint(out)]
    elif case == "no checkpoint in folder":
        shutil.rmtree(out / "restart")
        args = ["--restart"]
    elif case == "output gone":
        (out / "flyby.e").unlink()
    capsys.readouterr()
    assert run(deck, out, *args) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.startswith("error")]
    assert len(lines) == 1 and expected in lines[0], err


@pytest.mark.parametrize("section, expected", [
    ({"Restart Frequency": -1}, "Restart Frequency"),
    ({"Restart Frequency": 2.5}, "Restart Frequency"),
    ({"Keep": 0}, "Keep"),
    ({"Folder": ""}, "Folder"),
    ({"Restart Frequncy": 10}, "Restart Frequncy"),
])
def test_bad_restart_sections_are_refused(tmp_path, capsys, section, expected):
    tree = flyby_tree()
    tree["Restart"] = section
    deck = tmp_path / "flyby.yaml"
    deck.write_text(dump_yaml(tree))
    assert run(deck, tmp_path) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err
    assert "Restart" in err and expected in err, err


def test_peridigms_restart_section_writes_a_checkpoint_after_each_solver(tmp_path):
    """Peridigm's decks carry ``Restart: {Restart: true}``: state written at the end of each
    solver section (Peridigm's writeRestart after execute)."""
    tree = flyby_tree()
    tree["Restart"] = {"Restart": True}
    tree["Solver2"] = {"Initial Time": 0.01, "Final Time": 0.012, "Verlet": {"Safety Factor": 0.5}}
    deck = tmp_path / "flyby.yaml"
    deck.write_text(dump_yaml(tree))
    assert run(deck, tmp_path) == ExitCode.OK
    assert [p for p, _ in checkpoints_of(tmp_path / "restart", "flyby")] == [(1, 0), (2, 0)]


# -- the Exodus file -------------------------------------------------------------------------
def test_keep_steps_drops_later_steps_and_the_writer_appends_after_them(tmp_path):
    path = tmp_path / "r.e"
    kw = dict(coords=np.arange(6.0).reshape(2, 3), node_num_map=np.array([1, 2]), blocks=[ExodusBlock(1, "b", np.array([0, 1]))],
              nodal_vars=["U"], global_vars=["E"])
    with ExodusWriter(path, **kw) as w:
        for k in range(5):
            w.write_step(0.1 * k, nodal={"U": np.full(2, float(k))}, glob={"E": float(k)})
    assert keep_steps(path, 3) == 5
    assert read_results(path)["times"].size == 3
    with ExodusWriter(path, **kw, append_after=3) as w:
        w.write_step(9.0, nodal={"U": np.full(2, 9.0)}, glob={"E": 9.0})
    res = read_results(path)
    assert np.array_equal(res["times"], [0.0, 0.1, 0.2, 9.0])
    assert np.array_equal(res["nodal"]["U"][:, 0], [0.0, 1.0, 2.0, 9.0])
    assert np.array_equal(res["global"]["E"], [0.0, 1.0, 2.0, 9.0])
    with pytest.raises(ValueError, match="holds 4 steps, fewer than the 6"):
        keep_steps(path, 6)
    with pytest.raises(ValueError, match="nodal variables"):
        ExodusWriter(path, **{**kw, "nodal_vars": ["V"]}, append_after=4)


# -- sections of other solvers ---------------------------------------------------------------
def twist_tree() -> dict:
    """Peridigm's twist_and_pull_with_restart pattern in one deck: a bar pulled quasi-statically
    (2 load steps), then released into explicit dynamics."""
    box = lambda x0, x1: {"Shape": "Box", "Block": "block_1", "Min": [x0, 0.0, 0.0], "Max": [x1, 3.0, 3.0], "Spacing": 1.0}  # noqa: E731
    return {
        "Discretization": {"Type": "Shapes", "Shapes": {"Left": box(0.0, 1.0), "Mid": box(1.0, 5.0), "Right": box(5.0, 6.0)}},
        "Materials": {"M": {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1e9, "Shear Modulus": 6e8}},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": 2.015}},
        "Boundary Conditions": {
            **{f"L{c}": {"Type": "Prescribed Displacement", "Node Set": "Left", "Coordinate": c, "Value": "0.0"} for c in "xyz"},
            "R": {"Type": "Prescribed Displacement", "Node Set": "Right", "Coordinate": "x", "Value": "if(t <= 1.0) { value = 0.01*t; } else { value = 0.01; }"},
        },
        "Solver1": {"Initial Time": 0.0, "Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": 2, "Relative Tolerance": 1e-10}},
        "Solver2": {"Initial Time": 1.0, "Final Time": 1.005, "Verlet": {"Safety Factor": 0.5}},
        "Output": {"Output Filename": "bar", "Output Frequency": 2, "Output Variables": {"Displacement": True, "Velocity": True, "Force_Density": True}},
        "Restart": {"Restart": True, "Restart Frequency": 5, "Keep": 100},
    }


def test_a_run_continues_at_the_end_of_a_quasistatic_section(tmp_path):
    whole, again = tmp_path / "whole", tmp_path / "again"
    whole.mkdir()
    (whole / "bar.yaml").write_text(dump_yaml(twist_tree()))
    assert run(whole / "bar.yaml", whole) == ExitCode.OK
    found = dict(checkpoints_of(whole / "restart", "bar"))
    assert (1, 0) in found and (0, 5) not in found and (1, 5) in found  # no checkpoint inside a QuasiStatic section
    shutil.copytree(whole, again)
    assert run(again / "bar.yaml", again, "--restart", str(again / "restart" / found[(1, 0)].name)) == ExitCode.OK
    assert_same_file(whole / "bar.e", again / "bar.e")
    assert np.abs(read_results(again / "bar.e")["nodal"]["DisplacementX"][-1]).max() > 1e-3  # pulled


def test_a_peridigm_restart_deck_continues_the_state_the_previous_deck_left(tmp_path):
    """Peridigm's restart: run 1 (0 to 0.005) and run 2 (0.005 to 0.01, Restart section, no
    --restart) in one folder: run 2 starts from run 1's end, as Peridigm's readRestart, and
    equals one run from 0 to 0.01 bit for bit (no contact here: a contact search schedule
    restarts with the new deck)."""
    tree = flyby_tree()
    tree.pop("Contact")
    tree["Output"]["Output Variables"].pop("Contact_Force_Density")
    tree["Discretization"].pop("Omit Bonds Between Blocks")
    tree["Boundary Conditions"]["Tear"] = {"Type": "Initial Velocity", "Node Set": "B0", "Coordinate": "x", "Value": "-300.0"}
    tree["Solver"]["Verlet"] = {"Fixed dt": 0.00025}
    tree["Restart"] = {"Restart": True}
    whole, chain = tmp_path / "whole", tmp_path / "chain"
    for d in (whole, chain):
        d.mkdir()
    (whole / "one.yaml").write_text(dump_yaml({**tree, "Solver": {**tree["Solver"], "Final Time": 0.01}}))
    (chain / "run1.yaml").write_text(dump_yaml({**tree, "Solver": {**tree["Solver"], "Final Time": 0.005}}))
    (chain / "run2.yaml").write_text(dump_yaml({**tree, "Solver": {**tree["Solver"], "Initial Time": 0.005, "Final Time": 0.01},
                                                "Output": {**tree["Output"], "Output Filename": "second", "Output Frequency": 1}}))
    assert run(whole / "one.yaml", whole) == ExitCode.OK
    assert run(chain / "run1.yaml", chain) == ExitCode.OK
    assert run(chain / "run2.yaml", chain) == ExitCode.OK
    one, second = read_results(whole / "flyby.e"), read_results(chain / "second.e")
    assert second["times"].size == 21
    compared = 0
    for j, t in enumerate(one["times"]):
        k = int(np.argmin(np.abs(second["times"] - t)))
        if abs(second["times"][k] - t) < 1e-9 and t > 0.005:
            compared += 1
            for name in ("DisplacementX", "VelocityX", "VelocityY"):
                assert np.array_equal(one["nodal"][name][j], second["nodal"][name][k]), (name, t)
            assert np.array_equal(one["element"]["Damage"][j], second["element"]["Damage"][k])
    assert compared == 7
    assert np.nanmax(second["element"]["Damage"]) > 0.0  # bonds break in run 2, compared too


PERIDIGM_RUN1 = """<ParameterList>
  <ParameterList name="Discretization">
    <Parameter name="Type" type="string" value="PdQuickGrid"/>
    <Parameter name="NeighborhoodType" type="string" value="Spherical"/>
    <ParameterList name="TensorProduct3DMeshGenerator">
      <Parameter name="Type" type="string" value="PdQuickGrid"/>
      <Parameter name="X Origin" type="double" value="0.0"/>
      <Parameter name="Y Origin" type="double" value="0.0"/>
      <Parameter name="Z Origin" type="double" value="0.0"/>
      <Parameter name="X Length" type="double" value="0.008"/>
      <Parameter name="Y Length" type="double" value="0.004"/>
      <Parameter name="Z Length" type="double" value="0.002"/>
      <Parameter name="Number Points X" type="int" value="8"/>
      <Parameter name="Number Points Y" type="int" value="4"/>
      <Parameter name="Number Points Z" type="int" value="2"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Materials">
    <ParameterList name="Glass">
      <Parameter name="Material Model" type="string" value="Elastic"/>
      <Parameter name="Density" type="double" value="2440.0"/>
      <Parameter name="Bulk Modulus" type="double" value="4.3e10"/>
      <Parameter name="Shear Modulus" type="double" value="2.9e10"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Blocks">
    <ParameterList name="My Block">
      <Parameter name="Block Names" type="string" value="block_1"/>
      <Parameter name="Material" type="string" value="Glass"/>
      <Parameter name="Horizon" type="double" value="0.00301"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Boundary Conditions">
    <Parameter name="Left Node Set" type="string" value="1 2 3 4"/>
    <ParameterList name="Initial Velocity">
      <Parameter name="Type" type="string" value="Initial Velocity"/>
      <Parameter name="Node Set" type="string" value="Left Node Set"/>
      <Parameter name="Coordinate" type="string" value="x"/>
      <Parameter name="Value" type="string" value="-10.0"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Restart">
    <Parameter name="Restart" type="bool" value="true"/>
  </ParameterList>
  <ParameterList name="Solver">
    <Parameter name="Initial Time" type="double" value="0.0"/>
    <Parameter name="Final Time" type="double" value="2.0e-6"/>
    <ParameterList name="Verlet">
      <Parameter name="Fixed dt" type="double" value="5.0e-8"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Output">
    <Parameter name="Output File Type" type="string" value="ExodusII"/>
    <Parameter name="Output Filename" type="string" value="run1"/>
    <Parameter name="Output Frequency" type="int" value="10"/>
    <ParameterList name="Output Variables">
      <Parameter name="Displacement" type="bool" value="true"/>
      <Parameter name="Velocity" type="bool" value="true"/>
    </ParameterList>
  </ParameterList>
</ParameterList>
"""


def test_peridigms_xml_restart_decks_run_one_after_the_other(tmp_path):
    """The XML form Peridigm's decks use (<ParameterList name="Restart"> with Restart = true):
    run 2 (Initial Time 2e-6) picks up the state run 1 left at its Final Time 2e-6."""
    run2 = (PERIDIGM_RUN1.replace('name="Initial Time" type="double" value="0.0"', 'name="Initial Time" type="double" value="2.0e-6"')
            .replace('name="Final Time" type="double" value="2.0e-6"', 'name="Final Time" type="double" value="4.0e-6"')
            .replace('value="run1"', 'value="run2"'))
    (tmp_path / "run1.xml").write_text(PERIDIGM_RUN1)
    (tmp_path / "run2.xml").write_text(run2)
    assert run(tmp_path / "run1.xml", tmp_path) == ExitCode.OK
    assert run(tmp_path / "run2.xml", tmp_path) == ExitCode.OK
    one, two = read_results(tmp_path / "run1.e"), read_results(tmp_path / "run2.e")
    assert one["times"][-1] == pytest.approx(2e-6) and two["times"][0] == pytest.approx(2e-6)
    for name in ("DisplacementX", "VelocityX"):
        assert np.array_equal(one["nodal"][name][-1], two["nodal"][name][0]), name
    assert np.abs(two["nodal"]["DisplacementX"][-1]).max() > np.abs(one["nodal"]["DisplacementX"][-1]).max()  # it went on moving


def test_check_describes_the_restart_section(tmp_path, capsys):
    deck = write_deck(tmp_path, frequency=50, keep=3)
    assert main(["check", str(deck)]) == ExitCode.OK
    out = capsys.readouterr().out
    assert "restart: checkpoints in restart/ every 50 Verlet step(s), after each solver section and on SIGTERM/SIGINT, the latest 3 kept" in out


def test_an_input_error_found_after_the_checkpoint_is_read_leaves_the_result_alone(tmp_path, monkeypatch):
    """Found by benchmarks/surface_campaign.py: a checkpoint whose Volume makes the stable step 0
    (an input error after the outputs were restored) lost NAME.e: it had been trimmed and renamed to
    NAME.partial.e for appending. Now a copy is appended to; NAME.e is untouched until the run ends."""
    import hashlib
    import sys

    import numpy as np

    sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))
    from surface_campaign.decks import RESTART, base, write_deck
    from peridyn.cli import main

    monkeypatch.chdir(tmp_path)
    tree = base()
    tree["Restart"] = dict(RESTART)
    write_deck(tmp_path, tree)
    assert main(["run", "deck.yaml", "--no-progress"]) == 0
    digest = hashlib.sha256((tmp_path / "base.e").read_bytes()).hexdigest()
    ck = tmp_path / "restart" / "deck.000.0000000010.npz"
    z = dict(np.load(ck))
    z["np1/Volume"][3] = 1e308
    np.savez(ck, **z)
    assert main(["run", "deck.yaml", "--no-progress", "--restart", str(ck)]) == 2
    assert hashlib.sha256((tmp_path / "base.e").read_bytes()).hexdigest() == digest
    # and a good continuation still replaces it with the continued run's frames
    assert main(["run", "deck.yaml", "--no-progress", "--restart", "restart/deck.000.0000000005.npz"]) == 0
    assert not (tmp_path / "base.partial.e").exists()
