"""``peridyn verify --quick`` end to end, in a subprocess: every problem with at least three
points per curve whose rate is banded, every fitted rate and error inside its band; and wrong physics (a stiffer
bond-based micromodulus) fails the bands with exit 1."""
import json
import math
import subprocess
import sys
import time

from peridyn.verify import PROBLEMS


def test_verify_quick_passes(tmp_path):
    # two worker processes (CI has two cores); the results are the serial run's (tests/unit/verify/test_jobs.py)
    p = subprocess.run([sys.executable, "-m", "peridyn", "verify", "--quick", "--jobs", "2", "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    data = json.loads((tmp_path / "results.json").read_text())
    assert data["status"] == "complete" and data["failed checks"] == 0 and data["jobs"] == 2
    assert [e["name"] for e in data["problems"]] == list(PROBLEMS)
    for entry in data["problems"]:
        problem = PROBLEMS[entry["name"]]()
        # a known miss (rigid-rotation's rate-form correspondence models) is shown as FAIL with its reason, not counted
        assert entry["checks"] and all(c["passed"] or c.get("known") for c in entry["checks"]), entry["checks"]
        for method in problem.methods:
            points = [q for q in entry["points"] if q["method"] == method]
            assert all("failure" not in q for q in points), points
            if problem.kind == "curve":
                assert len(points) >= (3 if method in problem.rate_band else 1), (entry["name"], method)  # a fitted rate needs three
                assert all(q["error"] is not None and q["error"] >= 0 and q["wall (s)"] > 0 for q in points)
            else:
                assert len(points) >= 1
            if method in problem.rate_band and (problem.kind == "curve" or len(points) >= 3):  # a table's rate needs three points too
                lo, hi = problem.rate_band[method]
                assert lo <= entry["rates"][method] <= hi, (entry["name"], method, entry["rates"])
    report = (tmp_path / "report.md").read_text()
    assert report.count("**FAIL**") == report.count("**FAIL** (known: ") == data["known misses"]
    assert all(f"## {name}:" in report for name in PROBLEMS)
    extreme = next(e for e in data["problems"] if e["name"] == "extreme-cases")
    assert {q["values"]["outcome"] for q in extreme["points"]} <= {"converged", "diagnosed"}, extreme["points"]
    for name in ("wave-speed", "force-convergence", "verlet-energy", "static-modulus"):
        assert f"[{name}: error against wall time]({name}.png)" in report or "figures skipped" in p.stderr
    assert sum(line.startswith("[") for line in p.stderr.splitlines()) == len(PROBLEMS)  # a progress line per problem


WRONG = """
import sys
from peridyn.materials.elastic_bond_based import ElasticBondBased
init = ElasticBondBased.__init__
def stiffer(self, *args, **kwargs):
    init(self, *args, **kwargs)
    self.c *= 1.1
ElasticBondBased.__init__ = stiffer
from peridyn.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_a_ten_percent_stiffer_bond_fails_the_bands(tmp_path):
    p = subprocess.run([sys.executable, "-c", WRONG, "verify", "--quick", "--problems", "wave-speed", "force-convergence", "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 1, p.stderr[-3000:]
    data = json.loads((tmp_path / "results.json").read_text())
    failed = {(c["problem"], c["what"].split(" at ")[0]) for e in data["problems"] for c in e["checks"] if not c["passed"]}
    assert ("force-convergence", "relative force error") in failed
    assert ("wave-speed", "relative speed error") in failed and ("wave-speed", "|c/c0 - 1|") in failed
    assert "**FAIL**" in (tmp_path / "report.md").read_text() and "FAIL" in p.stderr
    assert not math.isnan(data["wall (s)"])


def test_ctrl_c_keeps_the_finished_points_and_exits_130(tmp_path):
    import signal

    p = subprocess.Popen([sys.executable, "-m", "peridyn", "verify", "--problems", "force-convergence", "stability", "--out", str(tmp_path)],
                         stderr=subprocess.PIPE, text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    results = tmp_path / "results.json"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and p.poll() is None:  # until the first problem's points are on disk
        if results.exists() and len(json.loads(results.read_text())["problems"][0]["points"]) == 5:
            break
        time.sleep(0.2)
    p.send_signal(signal.SIGINT)
    err = p.communicate(timeout=300)[1]
    assert p.returncode == 130, err[-3000:]
    data = json.loads(results.read_text())
    assert data["status"] == "interrupted" and len(data["problems"][0]["points"]) == 5
    assert len(data["problems"][1]["points"]) < 12 and "interrupted" in err
    assert (tmp_path / "report.md").exists()
