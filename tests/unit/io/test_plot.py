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
    assert set(panels) >= {"energy", "linear momentum", "damage"}
    assert list(panels["linear momentum"]) == ["Global_Linear_Momentum: |total p| (one block)"]
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


def synthetic(blocks: int, **tables) -> dict:
    """A read_results-like dict: 4 frames, 3 points."""
    base = {"times": np.arange(4.0), "coords": np.zeros((3, 3)), "blocks": [{"id": k + 1} for k in range(blocks)],
            "global": {}, "nodal": {}, "element": {}}
    for key, table in tables.items():
        base[key] = table
    return base


def test_peridigms_global_momentum_is_labelled_as_a_sum_of_block_magnitudes():
    r = synthetic(2, **{"global": {"Global_Linear_Momentum": np.array([1.0, 1.2, 1.5, 1.7]),
                                   "Global_Angular_Momentum": np.ones(4)}})
    panels = histories(r)
    (label,) = panels["linear momentum"]
    assert "sum over the 2 blocks of |p_block|" in label and "not |total p|" in label
    (label,) = panels["angular momentum"]
    assert "sum over the 2 blocks of |L_block|" in label
    (label,) = histories(synthetic(1, **{"global": {"Global_Linear_Momentum": np.ones(4)}}))["linear momentum"]
    assert "|total p| (one block)" in label


def test_the_total_momentum_comes_from_the_per_point_vectors_when_written():
    rng = np.random.default_rng(3)
    p = rng.normal(size=(4, 3, 3))  # frames, points, xyz
    p[:, 2] = -p[:, 0] - p[:, 1]  # two bodies pushing each other: the total is zero
    nodal = {f"Linear_Momentum{c}": p[:, :, k] for k, c in enumerate("XYZ")}
    r = synthetic(2, nodal=nodal, **{"global": {"Global_Linear_Momentum": np.linalg.norm(p[:, :2].sum(1), axis=1) + 1.0}})
    curves = histories(r)["linear momentum"]
    total = curves["|total p| (magnitude of the sum)"]
    assert np.allclose(total, 0.0, atol=1e-12)  # conserved, whatever the sum of block magnitudes does
    for k, axis in enumerate("xyz"):
        assert np.allclose(curves[f"total p_{axis} (sum of Linear_Momentum over points)"], p[:, :, k].sum(axis=1))


def test_a_global_vector_is_drawn_as_its_components_and_magnitude_and_tensors_are_not_vectors():
    g = {"Reaction_SumX": np.full(4, 3.0), "Reaction_SumY": np.full(4, 4.0), "Reaction_SumZ": np.zeros(4),
         "Global_Kinetic_Energy": np.ones(4)}
    stress = {f"Cauchy_Stress{s}": np.ones((4, 3)) for s in ("XX", "XY", "XZ", "YX", "YY", "YZ", "ZX", "ZY", "ZZ")}
    r = synthetic(1, element=stress, **{"global": g})
    panels = histories(r)
    assert np.allclose(panels["other global outputs"]["|Reaction_Sum| (magnitude of the vector)"], 5.0)
    assert set(panels["energy"]) == {"Global_Kinetic_Energy"}
    names = field_names(r)
    assert "Cauchy_StressX" not in names and "Cauchy_StressXY" in names
    with pytest.raises(KeyError):
        field_values(r, "Cauchy_StressX", 0)


def test_the_damage_share_counts_only_points_that_carry_damage():
    d = np.array([[0.0, 0.5, np.nan]] * 4)
    curves = histories(synthetic(1, element={"Damage": d}))["damage"]
    assert np.allclose(curves["points with damage (share)"], 0.5)
    assert np.allclose(curves["mean damage over points (not volume-weighted)"], 0.25)


@pytest.mark.parametrize("folder, there", [("missing", "does not exist"), ("afile", "is a file")])
def test_an_out_prefix_in_a_folder_that_is_not_there_is_refused_before_drawing(result, tmp_path, capsys, folder, there):
    """Found by benchmarks/surface_campaign.py: `plot base.e --out missing/p` was exit 1 (FileNotFoundError at the first picture)."""
    (tmp_path / "afile").write_text("mine")
    assert main(["plot", str(result), "--out", str(tmp_path / folder / "p")]) == ExitCode.INPUT_ERROR
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: --out: ") and there in lines[0], lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"] and (tmp_path / "afile").read_text() == "mine"
