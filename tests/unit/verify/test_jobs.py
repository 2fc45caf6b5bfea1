"""``peridyn verify --jobs N``: the problems run in N worker processes, the results those of one."""
import json

import pytest

from peridyn.core.errors import InputError
from peridyn.verify.runner import run_verify

#: what differs between runs whatever the jobs: the timings, the dates, the process's memory
TIMING = ("wall (s)", "wall runs", "wall spread (s)", "date", "peak memory (MiB)")


def measured(path):
    data = json.loads((path / "results.json").read_text())

    def strip(o):
        if isinstance(o, dict):
            return {k: strip(v) for k, v in o.items() if k not in TIMING}
        return [strip(v) for v in o] if isinstance(o, list) else o

    return data, strip(data["problems"])


def test_two_workers_give_the_serial_runs_results_in_its_order(tmp_path):
    names = ["critical-stretch", "manufactured-lps", "lame-cylinder"]
    assert run_verify(names, tmp_path / "one", quick=True) == 0
    assert run_verify(names, tmp_path / "two", quick=True, jobs=2) == 0
    one, a = measured(tmp_path / "one")
    two, b = measured(tmp_path / "two")
    assert [e["name"] for e in two["problems"]] == names and two["jobs"] == 2 and two["status"] == "complete"
    assert all(e["points"] for e in b) and a == b
    assert (tmp_path / "two" / "report.md").exists()


def test_jobs_below_one_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="--jobs 0"):
        run_verify(["critical-stretch"], tmp_path, quick=True, jobs=0)
