"""``peridyn.Study``: runs of one deck with varied parameters, a results table, resumable after an
interruption, in one process or several."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

import peridyn
from peridyn.api.study import set_deck_value

#: a 20 x 4 x 2 steel bar struck at its left end (Initial Velocity on the left-most layer): 160
#: points, a few dozen Verlet steps
BAR = {
    "Discretization": {"Type": "PdQuickGrid", "NeighborhoodType": "Spherical",
                       "TensorProduct3DMeshGenerator": {"Type": "PdQuickGrid", "X Origin": 0.0, "Y Origin": 0.0, "Z Origin": 0.0,
                                                        "X Length": 0.020, "Y Length": 0.004, "Z Length": 0.002,
                                                        "Number Points X": 20, "Number Points Y": 4, "Number Points Z": 2}},
    "Materials": {"Steel": {"Material Model": "Elastic", "Density": 7800.0, "Young's Modulus": 200.0e9, "Poisson's Ratio": 0.29}},
    "Blocks": {"Bar": {"Block Names": "block_1", "Material": "Steel", "Horizon": 0.003015}},
    "Boundary Conditions": {"Strike": {"Type": "Body Force", "Node Set": "All Node Set", "Coordinate": "x", "Value": "1.0e9"},
                            "All Node Set": " ".join(str(i) for i in range(1, 161))},
    "Solver": {"Initial Time": 0.0, "Final Time": 2.0e-6, "Verlet": {"Safety Factor": 0.8}},
    "Output": {"Output Filename": "bar", "Output Frequency": 5, "Output Variables": {"Displacement": True}},
}
DENSITY = "Materials/Steel/Density"


def mean_velocity(model) -> dict:
    """What the study keeps: the mean x velocity (m/s) and the run's time step."""
    return {"mean_vx": float(model["Velocity"][:, 0].mean()), "dt": model.dt}


calls: list[float] = []


def interrupted_on_second(model) -> dict:
    calls.append(model.time)
    if len(calls) == 2:
        raise KeyboardInterrupt
    return mean_velocity(model)


def test_study_table_and_resume(tmp_path) -> None:
    params = peridyn.Study.grid(**{DENSITY: [7800.0, 3900.0, 1950.0]})
    study = peridyn.Study(BAR, params, tmp_path / "study", extract=interrupted_on_second)
    with pytest.raises(KeyboardInterrupt):  # as if Ctrl-C during the second run
        study.run()
    assert [study.status(k)["status"] if study.status(k) else None for k in range(3)] == ["done", "running", None]
    assert study.pending() == [1, 2]
    done_first = (study.run_folder(0) / "status.json").read_text()
    rows = study.run()  # picks up where it stopped
    assert len(calls) == 4  # the first run was not run again
    assert (study.run_folder(0) / "status.json").read_text() == done_first
    assert [r["status"] for r in rows] == ["done"] * 3 and study.pending() == []
    # a uniform body force b accelerates every point alike: v = b t / rho, exact for Verlet (no internal force)
    for row in rows:
        steps = round(2.0e-6 / row["dt"] - 0.5)  # floor, as the solver counts
        assert row["mean_vx"] == pytest.approx(1.0e9 * steps * row["dt"] / row[DENSITY], rel=1e-9)
    assert rows[2]["mean_vx"] == pytest.approx(4.0 * rows[0]["mean_vx"], rel=0.3)  # dt changes with the density
    with open(tmp_path / "study" / "results.csv") as fh:
        table = list(csv.DictReader(fh))
    assert [float(r["mean_vx"]) for r in table] == [r["mean_vx"] for r in rows]
    assert json.loads((tmp_path / "study" / "results.json").read_text()) == rows
    assert (study.run_folder(2) / "bar.e").is_file() and (study.run_folder(2) / "deck.yaml").is_file()
    r = peridyn.read(study.run_folder(2) / "bar.e")
    assert np.all(r.field("Displacement")[:, 0] > 0)


def test_study_reruns_a_run_whose_parameters_changed_and_records_failures(tmp_path) -> None:
    first = peridyn.Study(BAR, [{DENSITY: 7800.0}, {DENSITY: 3900.0}], tmp_path, extract=mean_velocity)
    first.run()
    second = peridyn.Study(BAR, [{DENSITY: 7800.0}, {DENSITY: -1.0}], tmp_path, extract=mean_velocity)
    assert second.pending() == [1]
    rows = second.run()
    assert rows[0]["status"] == "done" and rows[1]["status"] == "failed" and "Density" in rows[1]["error"]
    assert second.pending() == [1]  # a failed run is tried again next time


@pytest.mark.slow
def test_study_in_two_processes_equals_one(tmp_path, monkeypatch) -> None:
    # the workers import ``extract`` by this module's name, tests.unit.api.test_api_study: they
    # start from this process's sys.path, which must hold the repository root for that
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[3]))
    params = [{DENSITY: d} for d in (7800.0, 5000.0)]
    one = peridyn.Study(BAR, params, tmp_path / "one", extract=mean_velocity).run()
    two = peridyn.Study(BAR, params, tmp_path / "two", extract=mean_velocity).run(processes=2)
    assert [r["status"] for r in two] == ["done", "done"]
    assert [(r["mean_vx"], r["dt"]) for r in two] == [(r["mean_vx"], r["dt"]) for r in one]


def test_set_deck_value() -> None:
    tree = {"Materials": {"Steel": {"Density": 1.0}}}
    set_deck_value(tree, "Materials/Steel/Density", 2.0)
    set_deck_value(tree, "Solver/Verlet/Safety Factor", 0.5)
    assert tree == {"Materials": {"Steel": {"Density": 2.0}}, "Solver": {"Verlet": {"Safety Factor": 0.5}}}
    with pytest.raises(ValueError, match="holds a value"):
        set_deck_value(tree, "Materials/Steel/Density/x", 1.0)
    with pytest.raises(ValueError):
        peridyn.Study(BAR, [], "unused")  # no parameter set


def test_a_grid_axis_given_as_a_set_is_refused():
    """Found by benchmarks/surface_campaign.py: a set (unordered: run numbers would differ between sessions) was taken."""
    from peridyn.api.checks import ArgumentTypeError

    with pytest.raises(ArgumentTypeError, match=r"Study.grid > x: x: the values of an axis are a list, not a set"):
        peridyn.Study.grid(x={1.0, 2.0})


def test_a_study_folder_that_is_a_file_is_named(tmp_path):
    """Found by benchmarks/surface_campaign.py: a FileExistsError from mkdir."""
    from peridyn.api.checks import ArgumentError

    (tmp_path / "afile").write_text("x")
    study = peridyn.Study(str(Path(__file__).resolve().parents[3] / "examples" / "quickstart.yaml"),
                          [{"Materials/Glass/Density": 2440.0}], tmp_path / "afile")
    with pytest.raises(ArgumentError, match=r"Study > folder: folder .* cannot be a folder"):
        study.run()
