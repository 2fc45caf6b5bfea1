"""``mpiexec -n 2 peridyn verify``: the same command as serially, the ranks sharing out the points;
one results.json and report written by rank 0, with every point the serial run has and the same
errors where a point's answer does not depend on timing; the ``mpi`` problem, which launches
``mpiexec`` itself and compares each method's two points, still passes; and a child ``peridyn run``
of a table problem starts as a serial run, not as a rank of the job."""
import json

import pytest

from peridyn.testing.mpi import mpirun, requires_mpi

pytestmark = [pytest.mark.mpi, requires_mpi]

PROBLEMS = ["force-convergence", "verlet-energy", "mpi"]


def load(folder):
    return json.loads((folder / "results.json").read_text())


def test_two_ranks_share_out_the_points_of_the_serial_run(tmp_path):
    args = ["verify", "--quick", "--problems", *PROBLEMS]
    serial = mpirun(1, args + ["--out", str(tmp_path / "serial")], cwd=tmp_path, timeout=600)
    assert serial.returncode == 0, serial.stderr[-3000:]
    two = mpirun(2, args + ["--out", str(tmp_path / "two")], cwd=tmp_path, timeout=600)
    assert two.returncode == 0, two.stderr[-3000:]
    a, b = load(tmp_path / "serial"), load(tmp_path / "two")
    assert a["ranks"] == 1 and b["ranks"] == 2 and b["status"] == "complete" and b["failed checks"] == 0
    for ea, eb in zip(a["problems"], b["problems"]):
        assert [(p["method"], p["resolution"]) for p in ea["points"]] == [(p["method"], p["resolution"]) for p in eb["points"]]
        if ea["name"] != "mpi":  # its error is 0 either way; the rest are deterministic in-process runs
            assert [p["error"] for p in ea["points"]] == [p["error"] for p in eb["points"]], ea["name"]
    assert "shared out the points" in (tmp_path / "two" / "report.md").read_text()
    assert two.stderr.count("[1/3]") == 1  # the progress lines come from rank 0 only


def test_a_table_problem_runs_its_decks_as_serial_children(tmp_path):
    """extreme-cases runs ``peridyn run`` in subprocesses: under the job's launcher variables a
    child would start as a rank of it; they are removed from its environment."""
    p = mpirun(2, ["verify", "--quick", "--problems", "extreme-cases", "--out", str(tmp_path / "o")], cwd=tmp_path, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    entry = load(tmp_path / "o")["problems"][0]
    assert entry["points"] and all(c["passed"] for c in entry["checks"])
