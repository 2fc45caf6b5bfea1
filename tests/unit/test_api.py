"""The Python API (docs/python-api.md): a Model runs a deck exactly as ``peridyn run`` does, steps,
reads and writes fields in mesh order, takes boundary conditions and computes from Python, and
``peridyn.read`` reads the results back."""
from __future__ import annotations

import copy
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import peridyn
from peridyn.cli import main
from peridyn.core.errors import ExitCode, InputError
from peridyn.deck.files import dump_yaml
from peridyn.io.exodus_reader import read_results

#: a 24 x 8 x 2 glass plate pulled at both ends until it cracks (critical stretch): 384 points,
#: 51 Verlet steps; the node sets are filled in by ``plate_deck``
PLATE = {
    "Discretization": {"Type": "PdQuickGrid", "NeighborhoodType": "Spherical",
                       "TensorProduct3DMeshGenerator": {"Type": "PdQuickGrid", "X Origin": 0.0, "Y Origin": 0.0, "Z Origin": 0.0,
                                                        "X Length": 0.024, "Y Length": 0.008, "Z Length": 0.002,
                                                        "Number Points X": 24, "Number Points Y": 8, "Number Points Z": 2}},
    "Materials": {"Glass": {"Material Model": "Elastic", "Density": 2440.0, "Young's Modulus": 72.0e9, "Poisson's Ratio": 0.22}},
    "Damage Models": {"Brittle": {"Damage Model": "Critical Stretch", "Critical Stretch": 0.0015}},
    "Blocks": {"Plate": {"Block Names": "block_1", "Material": "Glass", "Damage Model": "Brittle", "Horizon": 0.003015}},
    "Solver": {"Initial Time": 0.0, "Final Time": 1.0e-5, "Verlet": {"Safety Factor": 0.8}},
    "Output": {"Output Filename": "plate", "Output Frequency": 5,
               "Output Variables": {"Displacement": True, "Velocity": True, "Damage": True, "Element_Id": True}},
}
LEFT = lambda x: x[:, 0] < 0.002  # noqa: E731  the two left-most point layers
RIGHT = lambda x: x[:, 0] > 0.022  # noqa: E731


def plate_ids() -> tuple[np.ndarray, np.ndarray]:
    """1-based ids of the left and right end layers (read off a model that writes nothing)."""
    m = peridyn.Model(copy.deepcopy(PLATE), write_files=False)
    return m.ids[LEFT(m.x)], m.ids[RIGHT(m.x)]


def plate_deck(with_pull: bool = True) -> dict:
    tree = copy.deepcopy(PLATE)
    if with_pull:
        left, right = plate_ids()
        tree["Boundary Conditions"] = {
            "Left Node Set": " ".join(map(str, left)),
            "Right Node Set": " ".join(map(str, right)),
            "Pull Left": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": "x", "Value": "-5.0*t"},
            "Pull Right": {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "x", "Value": "5.0*t"},
        }
    return tree


@pytest.fixture(scope="module")
def cli_run(tmp_path_factory) -> tuple[Path, dict]:
    """The plate deck as a file, run by ``peridyn run``: (deck file, what its plate.e holds)."""
    folder = tmp_path_factory.mktemp("cli")
    deck = folder / "plate.yaml"
    deck.write_text(dump_yaml(plate_deck()))
    assert main(["run", str(deck), "--output-dir", str(folder / "out"), "-q", "--no-progress"]) == ExitCode.OK
    return deck, read_results(folder / "out" / "plate.e")


def same_frames(a: dict, b: dict) -> None:
    """Two result files hold bit-identical frames."""
    assert np.array_equal(a["times"], b["times"])
    for kind in ("nodal", "element", "global"):
        assert sorted(a[kind]) == sorted(b[kind])
        for name in a[kind]:
            assert np.array_equal(a[kind][name], b[kind][name], equal_nan=True), name


def test_import_peridyn_is_cheap() -> None:
    code = ("import sys, peridyn\n"
            "heavy = [m for m in sys.modules if m.split('.')[0] in ('numba', 'mpi4py', 'netCDF4') or m.startswith('peridyn.')]\n"
            "assert not heavy, heavy\n"
            "assert peridyn.Model.__module__ == 'peridyn.api.model' and 'mpi4py' not in sys.modules\n")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_run_equals_peridyn_run(cli_run, tmp_path) -> None:
    deck, expected = cli_run
    model = peridyn.Model(deck, output_dir=tmp_path).run()
    assert model.finished and model.steps_taken == 51
    got = read_results(tmp_path / "plate.e")
    same_frames(got, expected)
    assert got["element"]["Damage"][-1].max() > 0.5  # the plate cracked
    assert not list(tmp_path.glob("*.lock")) and not list(tmp_path.glob("*.partial.e"))


def test_stepping_equals_full_run(cli_run, tmp_path) -> None:
    deck, expected = cli_run
    model = peridyn.Model(deck, output_dir=tmp_path)
    assert model.time == 0.0 and model.steps_taken == 0
    model.step(7)
    assert model.steps_taken == 7 and model.time == pytest.approx(7 * model.dt, rel=1e-12)
    model.run(until=5.0e-6)
    assert model.time >= 5.0e-6 > model.time - model.dt
    steps = model.steps_taken
    model.step(50 - steps)
    frame = expected["times"].size - 1  # written at step 50
    assert model.time == expected["times"][frame]
    u = np.stack([expected["nodal"][f"Displacement{c}"][frame] for c in "XYZ"], axis=1)
    assert np.array_equal(model["Displacement"], u)
    assert np.array_equal(model["Damage"], expected["element"]["Damage"][frame])
    model.run()
    assert model.finished
    with pytest.raises(peridyn.RunEnded):
        model.step()
    same_frames(read_results(tmp_path / "plate.e"), expected)


def test_dict_deck_runs_without_a_file(cli_run, tmp_path) -> None:
    _, expected = cli_run
    model = peridyn.Model({"Peridigm": plate_deck()}, output_dir=tmp_path / "new" / "folder")  # a missing folder is created
    model.run()
    same_frames(read_results(tmp_path / "new" / "folder" / "plate.e"), expected)
    assert model.deck.file.endswith("<python deck>")


def test_python_conditions_equal_the_deck_conditions(cli_run, tmp_path) -> None:
    _, expected = cli_run
    model = peridyn.Model(plate_deck(with_pull=False), output_dir=tmp_path)
    model.add_condition("Prescribed Displacement", LEFT, lambda t, x: -5.0 * t)  # a mask callable of x
    right = np.nonzero(RIGHT(model.x))[0]
    model.add_condition("Prescribed Displacement", right, lambda t, x: np.full(len(x), 5.0 * t), coordinate="x")  # indices
    model.run()
    same_frames(read_results(tmp_path / "plate.e"), expected)


def test_python_condition_that_differs_gives_other_results(cli_run, tmp_path) -> None:
    """The comparison above can fail: a pull at 4 m/s instead of 5 changes the frames."""
    _, expected = cli_run
    model = peridyn.Model(plate_deck(with_pull=False), output_dir=tmp_path)
    model.add_condition("Prescribed Displacement", LEFT, lambda t, x: -5.0 * t)
    model.add_condition("Prescribed Displacement", RIGHT, lambda t, x: 4.0 * t)
    model.run()
    got = read_results(tmp_path / "plate.e")
    assert not np.array_equal(got["nodal"]["DisplacementX"], expected["nodal"]["DisplacementX"])


def test_initial_velocity_written_as_a_field_equals_the_deck_condition(tmp_path) -> None:
    tree = plate_deck(with_pull=False)
    tree.pop("Damage Models")
    tree["Blocks"]["Plate"].pop("Damage Model")
    tree["Output"]["Output Variables"].pop("Damage")
    left, _ = plate_ids()
    with_bc = copy.deepcopy(tree)
    with_bc["Boundary Conditions"] = {"Struck Node Set": " ".join(map(str, left)),
                                      "Strike": {"Type": "Initial Velocity", "Node Set": "Struck Node Set", "Coordinate": "x", "Value": "10.0*y"}}
    a = peridyn.Model(with_bc, output_dir=tmp_path / "a").run()
    b = peridyn.Model(tree, output_dir=tmp_path / "b")
    v = b["Velocity"]
    v[LEFT(b.x), 0] = 10.0 * b.x[LEFT(b.x), 1]
    b["Velocity"] = v
    assert np.array_equal(b.get("Velocity")[:, 0], v[:, 0])
    b.run()
    assert np.array_equal(a["Displacement"], b["Displacement"]) and np.abs(a["Displacement"]).max() > 0
    same_frames(read_results(tmp_path / "a" / "plate.e"), read_results(tmp_path / "b" / "plate.e"))


def test_writing_displacement_moves_the_coordinates(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    model = peridyn.Model(plate_deck(with_pull=False), write_files=False)
    u = np.zeros((model.num_points, 3))
    u[:, 0] = 1.0e-4 * model.x[:, 0]  # a uniform stretch of 1e-4
    model["Displacement"] = u
    assert np.array_equal(model["Coordinates"], model.x + u)
    model.step(1)
    assert np.abs(model["Force_Density"]).max() > 0  # the stretched plate pulls back
    model.run()
    assert list(tmp_path.iterdir()) == []  # write_files=False: no file, not even during the run


def test_compute_history_and_read_back(cli_run, tmp_path) -> None:
    deck, expected = cli_run
    model = peridyn.Model(deck, output_dir=tmp_path)
    model.add_compute("kinetic_energy", lambda m: m.sim.kinetic_energy(), every=10)
    model.add_compute("max_damage", lambda m: m["Damage"].max(), every=25)
    model.run()
    t, ke = model.history("kinetic_energy")
    assert t.size == 6 and t[0] == 0.0 and ke[0] == 0.0 and np.all(ke[1:] > 0)  # steps 0, 10, ..., 50
    assert np.allclose(np.diff(t), 10 * model.dt, rtol=1e-12)
    _, dmg = model.history("max_damage")
    assert dmg.size == 3 and dmg[0] == 0.0 and dmg[-1] == expected["element"]["Damage"][-1].max()
    r = peridyn.read(tmp_path / "plate.e")
    assert r.fields == ["Damage", "Displacement", "Element_Id", "Velocity"]
    assert r["Displacement"].shape == (11, model.num_points, 3) and np.array_equal(r.times, expected["times"])
    assert np.array_equal(r.field("Element_Id", 0), model.ids) and np.array_equal(r.ids, model.ids)
    assert np.array_equal(r.x, model.x)
    assert r.frame_at(2.1 * 5 * model.dt) == 2
    assert np.array_equal(model.results().field("Damage"), r.field("Damage"))
    with pytest.raises(KeyError, match="no field 'Stress'"):
        r["Stress"]
    with pytest.raises(InputError, match="does not exist"):
        peridyn.read(tmp_path / "missing.e")


def test_from_points_equals_a_text_file_mesh(tmp_path) -> None:
    h = 0.001
    g = np.arange(12) * h
    x = np.stack(np.meshgrid(g, g[:4], [0.0, h], indexing="ij"), axis=-1).reshape(-1, 3)
    tree = plate_deck(with_pull=False)
    tree["Output"]["Output Variables"].pop("Element_Id")
    tree["Solver"]["Final Time"] = 3.0e-6
    text = tmp_path / "points.txt"
    text.write_text("".join(f"{float(p[0])!r} {float(p[1])!r} {float(p[2])!r} 1 {h**3!r}\n" for p in x))
    mesh = copy.deepcopy(tree)
    mesh["Discretization"] = {"Type": "Text File", "Input Mesh File": "points.txt"}
    a = peridyn.Model(mesh, directory=tmp_path, output_dir=tmp_path / "a")
    tree.pop("Discretization")
    b = peridyn.Model.from_points(x, h**3, tree, node_sets={"Ends": x[:, 0] > 0.0105}, output_dir=tmp_path / "b")
    for m in (a, b):
        m.add_condition("Prescribed Displacement", x[:, 0] > 0.0105, lambda t, x: 5.0 * t)
    a.run(), b.run()
    assert b.node_set("Ends").size == 8 and np.array_equal(a["Displacement"], b["Displacement"])
    assert np.abs(b["Displacement"]).max() > 0


@pytest.mark.parametrize("bad, error", [
    (lambda m: m.get("Stress"), KeyError),
    (lambda m: m.set("Velocity", np.full((m.num_points, 3), np.nan)), ValueError),
    (lambda m: m.set("Velocity", np.zeros((3, 3))), ValueError),
    (lambda m: m.add_condition("Prescribed Displacement", [0, 10**6], lambda t, x: t), InputError),
    (lambda m: m.add_condition("Prescribed Displacement", np.zeros(5, bool), lambda t, x: t), InputError),
    (lambda m: m.add_condition("Prescribed Displacement", LEFT, lambda t, x: t, coordinate="w"), ValueError),
    (lambda m: m.add_condition("Prescribed Velocity Of Nothing", LEFT, lambda t, x: t), InputError),
    (lambda m: m.add_condition("Body Force", lambda x: x[:, 0] < -1.0, lambda t, x: t), InputError),
    (lambda m: m.node_set("Nowhere"), KeyError),
    (lambda m: (m.step(1), m.add_condition("Body Force", LEFT, lambda t, x: 1.0)), peridyn.RunEnded),
    (lambda m: m.add_compute("c", lambda m: 0.0, every=0), ValueError),
])
def test_bad_use_is_a_clear_error(bad, error) -> None:
    model = peridyn.Model(plate_deck(with_pull=False), write_files=False)
    with pytest.raises(error):
        bad(model)


def test_a_condition_value_that_is_not_finite_stops_the_run(tmp_path) -> None:
    from peridyn.core.errors import InstabilityError

    model = peridyn.Model(plate_deck(with_pull=False), output_dir=tmp_path)
    model.add_condition("Prescribed Displacement", RIGHT, lambda t, x: np.full(len(x), np.nan if t > 2e-6 else 5.0 * t))
    with pytest.raises(InstabilityError, match="python"):
        model.run()
    assert model.finished and (tmp_path / "plate.e").is_file()  # frames up to the stop are kept


@pytest.mark.parametrize("folder", ["file", "below-a-file"])
def test_an_output_folder_that_cannot_be_made_is_an_input_error(tmp_path, folder) -> None:
    (tmp_path / "file").write_text("")
    with pytest.raises(InputError, match="output folder"):
        peridyn.Model(plate_deck(with_pull=False), output_dir=tmp_path / "file" / ("x" if folder != "file" else ""))


def test_bad_dict_deck_names_the_problem() -> None:
    tree = plate_deck(with_pull=False)
    tree["Materials"]["Glass"]["Density"] = -1.0
    with pytest.raises(InputError) as info:
        peridyn.Model(tree, write_files=False)
    assert "Density" in info.value.one_line() and "<python deck>" in info.value.one_line()


def test_two_models_writing_one_folder_are_refused(tmp_path) -> None:
    first = peridyn.Model(plate_deck(with_pull=False), output_dir=tmp_path)
    with pytest.raises(InputError, match="another run"):
        peridyn.Model(plate_deck(with_pull=False), output_dir=tmp_path)
    first.close()
    peridyn.Model(plate_deck(with_pull=False), output_dir=tmp_path).close()  # free again


def test_a_quasi_static_section_runs_whole_then_verlet_steps(tmp_path) -> None:
    """Two solver sections: QuasiStatic (runs as one piece) then Verlet (stepped): the same
    frames as ``peridyn run``."""
    tree = plate_deck()
    tree.pop("Damage Models")
    tree["Blocks"]["Plate"].pop("Damage Model")
    tree["Output"]["Output Variables"].pop("Damage")
    tree["Output"]["Output Frequency"] = 1
    for name in ("Pull Left", "Pull Right"):
        tree["Boundary Conditions"][name]["Value"] = tree["Boundary Conditions"][name]["Value"].replace("5.0", "1.0e-5")
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0,
                      "QuasiStatic": {"Number of Load Steps": 2, "Relative Tolerance": 1.0e-8, "Maximum Solver Iterations": 10}}
    tree["Solver 2"] = {"Initial Time": 1.0, "Final Time": 1.0 + 1.0e-6, "Verlet": {"Safety Factor": 0.8}}
    deck = tmp_path / "two.yaml"
    deck.write_text(dump_yaml(tree))
    assert main(["run", str(deck), "--output-dir", str(tmp_path / "cli"), "-q", "--no-progress"]) == ExitCode.OK
    model = peridyn.Model(deck, output_dir=tmp_path / "api")
    with pytest.raises(peridyn.RunEnded, match="one piece"):
        model.step()
    with pytest.raises(peridyn.RunEnded, match="one piece"):
        model.run(until=0.5)  # the section cannot stop half way
    model.run(until=1.0)  # the whole quasi-static section
    assert model.time == 1.0 and model.steps_taken == 1 and np.abs(model["Displacement"]).max() > 0
    model.step(2)
    assert model.time == pytest.approx(1.0 + 2 * model.dt, rel=1e-15)
    model.run()
    assert model.finished and [s["method"] for s in model.summary()["solvers"]] == ["QuasiStatic", "Verlet"]
    same_frames(read_results(tmp_path / "api" / "plate.e"), read_results(tmp_path / "cli" / "plate.e"))


def test_a_history_file_reads_back_its_global_variables(tmp_path) -> None:
    tree = plate_deck()
    tree["Output History"] = {"Output Filename": "plate_history", "Output Frequency": 10,
                              "Output Variables": {"Global_Kinetic_Energy": True}}
    model = peridyn.Model(tree, output_dir=tmp_path)
    model.add_compute("kinetic_energy", lambda m: m.sim.kinetic_energy(), every=10)
    model.run()
    h = model.results("Output History")
    assert h.fields == [] and list(h.globals) == ["Global_Kinetic_Energy"]
    t, ke = model.history("kinetic_energy")
    assert np.array_equal(h.times, t)
    assert np.allclose(h["Global_Kinetic_Energy"], ke, rtol=1e-12, atol=0.0)  # the deck's compute and a Python one agree
