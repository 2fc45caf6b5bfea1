"""``peridyn plot RESULT.e``: the histories and frames of a run, and one-line errors."""
from __future__ import annotations

import sys

import numpy as np
import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.deck.files import dump_yaml
from peridyn.io.exodus_reader import read_results
from peridyn.io.plot import default_view, field_names, field_values, histories, positions
from peridyn.testing import cube_deck, node_set_ids


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    """A 6 x 6 x 3 plate pulled apart in x until bonds break: Damage, Displacement, energies."""
    folder = tmp_path_factory.mktemp("plot")
    tree = cube_deck({"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 130e9, "Shear Modulus": 78e9}, n=6, spacing=1e-3,
                     shape=(6, 6, 3), damage={"Damage Model": "Critical Stretch", "Critical Stretch": 0.002})
    tree["Boundary Conditions"] = {
        "All Node Set": node_set_ids(tree, lambda x: x[:, 0] > -1.0),
        "Pull": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "x", "Value": "40.0*(x-0.003)/0.003"},
    }
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 4e-6, "Verlet": {"Fixed dt": 1e-7}}
    tree["Output"] = {"Output Filename": "plate", "Output Frequency": 8,
                      "Output Variables": {"Displacement": True, "Velocity": True, "Damage": True, "Global_Kinetic_Energy": True,
                                           "Global_Linear_Momentum": True}}
    deck = folder / "plate.yaml"
    deck.write_text(dump_yaml(tree))
    assert main(["run", str(deck), "--output-dir", str(folder), "-q", "--no-progress"]) == ExitCode.OK
    return folder / "plate.e"


def test_histories_and_fields_come_from_the_file(result):
    r = read_results(result)
    panels = histories(r)
    assert set(panels) >= {"energy", "momentum", "damage"}
    share = panels["damage"]["points with damage (share)"]
    assert share[0] == 0.0 and share[-1] > 0.0  # the plate starts whole and breaks
    assert "Velocity" in field_names(r) and "Damage" in field_names(r)
    v = field_values(r, "Velocity", -1)
    vx, vy, vz = (r["nodal"][f"Velocity{c}"][-1] for c in "XYZ")
    assert np.allclose(v, np.sqrt(vx**2 + vy**2 + vz**2))
    assert np.allclose(positions(r, -1) - r["coords"], np.stack([r["nodal"][f"Displacement{c}"][-1] for c in "XYZ"], axis=1))
    assert default_view(r) == "xy"  # 6 x 6 x 3: the thin direction is left out


def test_the_command_writes_the_pictures(result, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    prefix = tmp_path / "pic"
    assert main(["plot", str(result), "--frames", "0", "-1", "--out", str(prefix)]) == ExitCode.OK
    out = capsys.readouterr().out
    frames = len(read_results(result)["times"])
    for name in ("pic_history.png", "pic_frame0_Damage.png", f"pic_frame{frames - 1}_Damage.png"):
        assert (tmp_path / name).stat().st_size > 2000 and name in out
    assert main(["plot", str(result), "--field", "Velocity", "--view", "xz", "--out", str(prefix)]) == ExitCode.OK
    assert (tmp_path / f"pic_frame{frames - 1}_Velocity.png").is_file()


@pytest.mark.parametrize("args, words", [
    (["--frames", "99"], "--frames 99"),
    (["--field", "Temperature"], "no such output"),
])
def test_bad_requests_get_one_line_and_exit_2(result, tmp_path, capsys, args, words):
    pytest.importorskip("matplotlib")
    assert main(["plot", str(result), "--out", str(tmp_path / "x"), *args]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err
    assert words in err and not list(tmp_path.glob("*.png"))


def test_a_missing_or_unreadable_file_is_bad_input(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    assert main(["plot", str(tmp_path / "none.e")]) == ExitCode.INPUT_ERROR
    (tmp_path / "junk.e").write_text("not netcdf")
    assert main(["plot", str(tmp_path / "junk.e")]) == ExitCode.INPUT_ERROR
    assert capsys.readouterr().err.count("error:") == 2


def test_without_matplotlib_it_says_how_to_install(result, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    assert main(["plot", str(result)]) == ExitCode.INPUT_ERROR
    assert 'pip install "peridyn[plot]"' in capsys.readouterr().err
