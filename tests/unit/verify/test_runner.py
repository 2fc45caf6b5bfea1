"""The runner and report of ``peridyn verify`` on made-up problems (no peridyn physics)."""
import json
import logging
import sys

import pytest

from peridyn.core.errors import ExitCode
from peridyn.verify import Measurement, Problem, Run
from peridyn.verify.report import write_report


class Power(Problem):
    """error = size^order; raises KeyboardInterrupt or an error at chosen points."""

    name = "power"
    title = "made-up power law"
    computes = "size^order"
    reference = "0"
    resolution_name = "n"
    size_name = "1/n"
    methods = ("a", "b")
    rate_band = {"a": (1.8, 2.2), "b": (1.8, 2.2)}
    finest_band = {"a": 1e-2}

    def __init__(self, order=2.0, interrupt_at=None, fail_at=None, out=None):
        self.order, self.interrupt_at, self.fail_at, self.out = order, interrupt_at, fail_at, out
        self.seen: list[int] = []

    def ladder(self, method, quick):
        return [4.0, 8.0, 16.0] if quick else [4.0, 8.0, 16.0, 32.0]

    def measure(self, method, resolution, quick):
        if self.out is not None:  # results.json holds every point finished before this one
            self.seen.append(sum(len(e["points"]) for e in json.loads((self.out / "results.json").read_text())["problems"]))
        if (method, resolution) == self.interrupt_at:
            raise KeyboardInterrupt
        if (method, resolution) == self.fail_at:
            raise RuntimeError("boom")
        return Measurement((1.0 / resolution) ** self.order, size=1.0 / resolution, steps=int(resolution), values={"x (m)": resolution})


def load(out):
    return json.loads((out / "results.json").read_text())


@pytest.fixture(autouse=True)
def _one_run_per_point(monkeypatch, request):
    """These tests count the measurements: a short point runs once (its repeats have their own test)."""
    if "median_of_repeats" not in request.node.name:
        from peridyn.verify import runner

        monkeypatch.setattr(runner, "REPEAT_BELOW", 0.0)


def test_a_run_writes_every_point_rate_and_check(tmp_path):
    assert Run([Power()], tmp_path, quick=True).run() == ExitCode.OK
    data = load(tmp_path)
    assert data["status"] == "complete" and data["quick"] is True and data["failed checks"] == 0
    for key in ("platform", "cpu", "cores"):
        assert data["machine"][key]
    assert data["peridyn"]["version"] and data["date"]
    entry = data["problems"][0]
    assert [(p["method"], p["resolution"]) for p in entry["points"]] == [(m, r) for m in "ab" for r in (4.0, 8.0, 16.0)]
    for p in entry["points"]:
        assert p["wall (s)"] >= 0 and p["steps"] == int(p["resolution"]) and p["peak memory (MiB)"] > 0
    assert entry["rates"] == {"a": pytest.approx(2.0), "b": pytest.approx(2.0)}
    assert all(c["passed"] for c in entry["checks"]) and len(entry["checks"]) == 3
    report = (tmp_path / "report.md").read_text()
    assert "## power: made-up power law" in report and "**FAIL**" not in report and "| a | 4 |" in report


def test_results_json_is_rewritten_after_every_point(tmp_path):
    problem = Power(out=tmp_path)
    Run([problem], tmp_path, quick=False).run()
    # each measurement is preceded by the warm-up of its method's coarsest point
    assert problem.seen == [0, 0, 1, 2, 3, 4, 4, 5, 6, 7]


def test_an_interrupted_run_keeps_the_points_it_finished(tmp_path, caplog):
    with caplog.at_level(logging.WARNING, logger="peridyn.verify"):
        code = Run([Power(interrupt_at=("a", 16.0)), Power()], tmp_path, quick=True).run()
    assert code == ExitCode.INTERRUPTED == 130
    data = load(tmp_path)
    assert data["status"] == "interrupted"
    assert [p["resolution"] for p in data["problems"][0]["points"]] == [4.0, 8.0]
    assert data["problems"][1]["points"] == []
    assert "interrupted" in caplog.text
    assert "Not run" in (tmp_path / "report.md").read_text()


def test_a_rate_outside_its_band_fails(tmp_path):
    assert Run([Power(order=1.0)], tmp_path, quick=True).run() == ExitCode.FAILURE
    data = load(tmp_path)
    failed = [c for c in data["problems"][0]["checks"] if not c["passed"]]
    assert {c["what"].split(" at ")[0].split(" of ")[0] for c in failed} >= {"fitted rate"}
    assert data["failed checks"] == len(failed) == 3  # both rates and a's finest error (1/16 > 1e-2)
    assert "**FAIL**" in (tmp_path / "report.md").read_text()


def test_a_point_that_raises_is_recorded_and_fails(tmp_path):
    assert Run([Power(fail_at=("b", 8.0))], tmp_path, quick=True).run() == ExitCode.FAILURE
    points = load(tmp_path)["problems"][0]["points"]
    assert [p.get("failure") for p in points].count("RuntimeError: boom") == 1
    assert "failed: RuntimeError: boom" in (tmp_path / "report.md").read_text()


def test_report_without_matplotlib_says_how_to_get_figures(tmp_path, monkeypatch, caplog):
    Run([Power()], tmp_path, quick=True).run()
    for png in tmp_path.glob("*.png"):
        png.unlink()
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib raises ImportError
    with caplog.at_level(logging.WARNING, logger="peridyn.verify"):
        path = write_report(load(tmp_path), tmp_path)
    lines = [r.getMessage() for r in caplog.records if "figures skipped" in r.getMessage()]
    assert len(lines) == 1 and 'pip install "peridyn[plot]"' in lines[0]
    assert path.read_text().startswith("# peridyn verify") and "![" not in path.read_text()
    assert not list(tmp_path.glob("*.png"))


def test_report_with_matplotlib_draws_one_figure_per_curve_problem(tmp_path):
    pytest.importorskip("matplotlib")
    Run([Power()], tmp_path, quick=True).run()
    assert (tmp_path / "power.png").stat().st_size > 1000
    assert "![power: error against wall time](power.png)" in (tmp_path / "report.md").read_text()


def test_a_table_problem_with_an_error_has_its_figure_and_one_without_has_none(tmp_path):
    pytest.importorskip("matplotlib")

    class Table(Power):
        name, kind, rate_band, finest_band = "table", "table", {}, {}

    class Ratio(Table):
        name, plotted = "ratio", False

    Run([Table(), Ratio()], tmp_path, quick=True).run()
    report = (tmp_path / "report.md").read_text()
    assert (tmp_path / "table.png").stat().st_size > 1000 and "![table: error against wall time](table.png)" in report
    assert not (tmp_path / "ratio.png").exists() and "(ratio.png)" not in report


def test_peridigms_own_point_is_in_the_results_the_report_and_the_figure(tmp_path):
    class WithPeridigm(Power):
        peridigm = ({"method": "a", "error": 0.003, "wall (s)": 50.0, "what": "its example, one core"},)

    Run([WithPeridigm()], tmp_path, quick=True).run()
    assert load(tmp_path)["problems"][0]["peridigm"] == [dict(WithPeridigm.peridigm[0])]
    report = (tmp_path / "report.md").read_text()
    assert "Peridigm's own point (a): relative error 0.003 in 50 s; its example, one core" in report


class OnDevice(Power):
    """Power whose method "a" also runs on the GPU; records the device of every measurement."""

    gpu_methods = ("a",)

    def __init__(self, gpu_error=None, **kw):
        super().__init__(**kw)
        self.gpu_error = gpu_error
        self.devices: list[tuple[str, str]] = []

    def measure(self, method, resolution, quick):
        from peridyn.verify.problems.base import current_device

        self.devices.append((method, current_device()))
        m = super().measure(method, resolution, quick)
        if current_device() == "gpu" and self.gpu_error is not None:
            m.error = self.gpu_error
        return m


def test_device_gpu_adds_a_curve_per_gpu_method_held_to_its_bands(tmp_path):
    problem = OnDevice()
    assert Run([problem], tmp_path, quick=True, device="gpu").run() == ExitCode.OK
    data = load(tmp_path)
    assert "simulator" in data["machine"]["gpu"]
    entry = data["problems"][0]
    assert entry["methods"] == ["a", "b", "a (GPU)"]
    assert [(p["method"], p["resolution"]) for p in entry["points"] if p["method"] == "a (GPU)"] == [("a (GPU)", r) for r in (4.0, 8.0, 16.0)]
    # the problem measures its own method "a", on the GPU, for the GPU curve (warm-up included)
    assert problem.devices.count(("a", "gpu")) == 4 and ("b", "gpu") not in problem.devices
    assert entry["rates"]["a (GPU)"] == pytest.approx(2.0)
    gpu_checks = [c for c in entry["checks"] if c["method"] == "a (GPU)"]
    assert len(gpu_checks) == 2 and all(c["passed"] for c in gpu_checks)  # a's finest band and rate band
    assert "GPU: numba-cuda simulator" in (tmp_path / "report.md").read_text()


def test_a_gpu_curve_outside_its_methods_band_fails(tmp_path):
    assert Run([OnDevice(gpu_error=0.5)], tmp_path, quick=True, device="gpu").run() == ExitCode.FAILURE
    failed = [c for c in load(tmp_path)["problems"][0]["checks"] if not c["passed"]]
    assert failed and {c["method"] for c in failed} == {"a (GPU)"}


def test_a_cpu_run_has_no_gpu_curves(tmp_path):
    problem = OnDevice()
    Run([problem], tmp_path, quick=True).run()
    assert load(tmp_path)["problems"][0]["methods"] == ["a", "b"] and {d for _, d in problem.devices} == {"cpu"}


class WithCompanion(Power):
    """Power with a second curve measured beside each point (error 4x smaller, same order)."""

    companions = {"beside": ("beside error", "beside wall (s)")}

    def measure(self, method, resolution, quick):
        m = super().measure(method, resolution, quick)
        m.values.update({"beside error": m.error / 4.0, "beside wall (s)": 0.01 * resolution})
        return m


def test_a_companion_curve_is_drawn_beside_each_method(tmp_path, monkeypatch):
    from peridyn.verify import report

    drawn = []
    plt = report.pyplot()
    if plt is None:
        pytest.skip("matplotlib is not installed")
    real = plt.Axes.loglog

    def loglog(self, *args, label=None, **kw):
        drawn.append(label)
        return real(self, *args, label=label, **kw)

    monkeypatch.setattr(plt.Axes, "loglog", loglog)
    assert Run([WithCompanion()], tmp_path, quick=True).run() == ExitCode.OK
    assert load(tmp_path)["problems"][0]["companions"] == {"beside": ["beside error", "beside wall (s)"]}
    assert "a: beside (rate 2.00 in 1/n)" in drawn and "b: beside (rate 2.00 in 1/n)" in drawn


def test_the_commit_of_a_non_editable_install_comes_from_its_metadata(monkeypatch, tmp_path):
    """Outside a checkout the commit is pip's record of a git install (PEP 610 vcs_info), else the
    HEAD of the checkout it was installed from, else None with the reason; each says its source."""
    from peridyn.verify import runner

    heads = {str(tmp_path): "f" * 40}
    monkeypatch.setattr(runner, "_git_head", lambda folder: heads.get(str(folder)))
    monkeypatch.setattr(runner, "_direct_url", lambda: {"url": "https://example.invalid/peridyn.git", "vcs_info": {"vcs": "git", "commit_id": "a" * 40}})
    v = runner.peridyn_version()
    assert v["commit"] == "a" * 40 and "metadata" in v["commit from"]
    monkeypatch.setattr(runner, "_direct_url", lambda: {"url": tmp_path.as_uri(), "dir_info": {}})
    v = runner.peridyn_version()
    assert v["commit"] == "f" * 40 and "may be older" in v["commit from"]
    monkeypatch.setattr(runner, "_direct_url", lambda: None)
    v = runner.peridyn_version()
    assert v["commit"] is None and "not known" in v["commit from"]


def test_a_short_point_is_timed_as_the_median_of_repeats_with_its_spread(tmp_path):
    from peridyn.verify import runner

    class Tiny(Problem):
        name, title, computes, reference, resolution_name = "tiny", "t", "c", "r", "n"
        methods = ("a",)
        calls = 0

        def ladder(self, method, quick):
            return [1.0]

        def measure(self, method, resolution, quick):
            Tiny.calls += 1
            return Measurement(0.5, size=1.0)

    point = Run([Tiny()], tmp_path, quick=True).point(Tiny(), "a", 1.0)
    assert point["wall runs"] == Tiny.calls == runner.REPEATS and point["error"] == 0.5
    lo, hi = point["wall spread (s)"]
    assert lo <= point["wall (s)"] <= hi
