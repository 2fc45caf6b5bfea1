"""Progress of solver sections: a tqdm bar on a terminal, silence elsewhere, JSON records with
--log-json, and implicit solvers that report each load step's converged residual."""
from __future__ import annotations

import io
import json

import numpy as np

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.deck.files import dump_yaml
from peridyn.solvers.monitors.progress import Progress, structured_progress
from peridyn.testing import cube_deck, node_set_ids


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_bar_on_a_terminal_nothing_elsewhere(monkeypatch):
    monkeypatch.delenv("PERIDYN_NO_PROGRESS", raising=False)
    tty, pipe = FakeTerminal(), io.StringIO()
    for stream in (tty, pipe):
        p = Progress(5, "Solver", min_seconds=0.0, stream=stream, unit="load step")
        for k in range(1, 6):
            p.note(iteration=2, residual=1e-3, tolerance=1e-6)
            p.update(k, residual=1e-7, tolerance=1e-6)
        p.close()
    text = tty.getvalue()
    assert "Solver" in text and "5/5" in text and "load step" in text and "residual 1e-07" in text
    assert pipe.getvalue() == ""


def test_records_every_tenth_with_log_json(monkeypatch, caplog):
    monkeypatch.delenv("PERIDYN_NO_PROGRESS", raising=False)
    structured_progress(True)
    try:
        with caplog.at_level("INFO", logger="peridyn.progress"):
            p = Progress(100, "Solver", stream=io.StringIO())
            for k in range(1, 101):
                p.update(k)
            p.close()
    finally:
        structured_progress(False)
    fields = [r.fields for r in caplog.records if hasattr(r, "fields")]
    assert [f["done"] for f in fields] == [1] + [10 * k for k in range(1, 11)]  # the first step, then every tenth
    assert fields[-1]["total"] == 100 and fields[-1]["eta_s"] == 0.0


def _bar_deck(tmp_path, solver: dict) -> str:
    tree = cube_deck({"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 130e9, "Shear Modulus": 78e9}, n=4, spacing=1e-3,
                     shape=(8, 3, 3))
    tree["Boundary Conditions"] = {
        "Left Node Set": node_set_ids(tree, lambda x: x[:, 0] < 1e-3),
        "Right Node Set": node_set_ids(tree, lambda x: x[:, 0] > 7e-3),
        **{f"Fix {c}": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": c, "Value": "0.0"} for c in "xyz"},
        "Pull": {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "x", "Value": "1.0e-6*t"},
    }
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0, **solver}
    tree["Output"] = {"Output Filename": "bar", "Output Frequency": 1, "Output Variables": {"Displacement": True}}
    deck = tmp_path / "bar.yaml"
    deck.write_text(dump_yaml(tree))
    return str(deck)


def test_quasistatic_logs_each_load_steps_converged_residual_as_json(tmp_path, capsys):
    deck = _bar_deck(tmp_path, {"QuasiStatic": {"Number of Load Steps": 3, "Absolute Tolerance": 1e-6, "Maximum Solver Iterations": 10}})
    assert main(["run", deck, "--output-dir", str(tmp_path), "--log-json"]) == ExitCode.OK
    records = [json.loads(line) for line in capsys.readouterr().err.splitlines()]
    steps = [r for r in records if r.get("event") == "load_step"]
    assert [r["step"] for r in steps] == [1, 2, 3] and all(r["steps"] == 3 for r in steps)
    assert all(r["outcome"] == "converged" and r["residual"] <= r["tolerance"] for r in steps)
    assert all({"time", "level", "logger", "message"} <= set(r) for r in records)


def test_nox_and_implicit_report_their_steps(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("PERIDYN_NO_PROGRESS", raising=False)
    deck = _bar_deck(tmp_path, {"NOXQuasiStatic": {"Number of Load Steps": 2, "Absolute Tolerance": 1e-6, "Direction": {"Method": "Newton"}}})
    assert main(["run", deck, "--output-dir", str(tmp_path / "nox"), "--log-json"]) == ExitCode.OK
    records = [json.loads(x) for x in capsys.readouterr().err.splitlines()]
    steps = [r for r in records if r.get("event") == "load_step"]
    assert [r["step"] for r in steps] == [1, 2] and np.all([r["residual"] < r["tolerance"] for r in steps])
    deck = _bar_deck(tmp_path, {"Implicit": {"Fixed dt": 0.25, "Absolute Tolerance": 1e-6}})
    assert main(["run", deck, "--output-dir", str(tmp_path / "implicit"), "--log-json"]) == ExitCode.OK
    records = [json.loads(x) for x in capsys.readouterr().err.splitlines()]
    progress = [r for r in records if r.get("event") == "progress"]
    assert progress[-1]["done"] == progress[-1]["total"] == 4 and progress[-1]["residual"] <= 1e-6


def test_errors_are_json_records_too(tmp_path, capsys):
    assert main(["run", str(tmp_path / "missing.yaml"), "--log-json"]) == ExitCode.INPUT_ERROR
    lines = capsys.readouterr().err.splitlines()
    record = json.loads(lines[-1])
    assert record["level"] == "error" and record["event"] == "error" and "missing.yaml" in record["message"]
