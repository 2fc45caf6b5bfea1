"""The Python API examples (examples/api_quickstart.py, api_study.py, api_tour.ipynb) run at a
small size and do what their comments say."""
from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def load(name: str):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_api_quickstart_plate_cracks_in_the_middle(tmp_path, capsys) -> None:
    out = load("api_quickstart").main(tmp_path, small=True)
    x, damage = out["x"], out["damage"]
    left, right = out["grips"]
    assert np.unique(x[left]).size == np.unique(x[right]).size == 2  # two columns each at --small (three at full size)
    assert np.allclose(np.sort(x[left]), np.sort(0.060 - x[right]), atol=1e-12)  # mirror images
    ends = left | right
    assert damage[~ends].max() > 0.5  # a crack
    crack = x[(damage > 0.3) & ~ends]
    assert np.all(np.abs(crack - 0.030) < 0.008)  # across the middle, where the pull waves meet
    times, growth = out["history"]
    assert growth[0] == 0.0 and np.all(np.diff(growth) >= 0)  # damage only grows
    result = out["result"]
    assert result.num_frames == 4 and result.field("Damage")[~ends].max() > 0.5  # frames at steps 0, 50, 100, 150 of 153
    assert "cracked points" in capsys.readouterr().out


def test_api_study_tougher_plate_breaks_less(tmp_path, capsys) -> None:
    example = load("api_study")
    rows = example.study(tmp_path / "study", [0.0015, 0.02], small=True)
    assert [r["status"] for r in rows] == ["done", "done"]
    assert rows[0]["max_damage"] > 0.5 and rows[1]["max_damage"] == 0.0
    assert (tmp_path / "study" / "results.csv").read_text().count("\n") == 3
    stamp = (tmp_path / "study" / "run_0001" / "status.json").stat().st_mtime_ns
    again = example.study(tmp_path / "study", [0.0015, 0.02], small=True)  # finished runs are skipped
    assert again == rows and (tmp_path / "study" / "run_0001" / "status.json").stat().st_mtime_ns == stamp


def test_api_tour_notebook_runs(tmp_path, monkeypatch, capsys) -> None:
    """Every code cell in order, in one namespace (as a kernel would), without Jupyter."""
    monkeypatch.chdir(tmp_path)
    notebook = json.loads((EXAMPLES / "api_tour.ipynb").read_text())
    assert notebook["nbformat"] == 4
    cells = ["".join(c["source"]) for c in notebook["cells"] if c["cell_type"] == "code"]
    assert len(cells) >= 3 and all(not c.get("outputs") for c in notebook["cells"] if c["cell_type"] == "code")
    ns: dict = {"__name__": "__main__"}
    for k, code in enumerate(cells):
        exec(compile(code, f"api_tour.ipynb cell {k}", "exec"), ns)
    # the struck end: 3 layers of 5 x 5 points of 1 mm^3 steel at 10 m/s, K = m v^2 / 2
    mass = 3 * 25 * 1.0e-9 * 7800.0
    t, ke = ns["model"].history("kinetic_energy")
    assert ke[0] == pytest.approx(0.5 * mass * 10.0**2, rel=1e-12)
    assert ke[-1] < ke[0]  # part of it is now stored in the bar
    assert ns["result"].num_frames == 8 and (tmp_path / "tour" / "bar.e").is_file()
