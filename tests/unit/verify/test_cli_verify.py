"""``peridyn verify``'s arguments, and a band that wrong physics fails."""
import json

import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode


def test_unknown_problem_is_exit_2_with_one_line(tmp_path, capsys):
    assert main(["verify", "--problems", "no-such", "--out", str(tmp_path / "o")]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no-such" in err[0] and "wave-speed" in err[0]
    assert not (tmp_path / "o").exists()


def test_out_that_is_a_file_is_exit_2_with_one_line(tmp_path, capsys):
    f = tmp_path / "f"
    f.write_text("x")
    assert main(["verify", "--problems", "force-convergence", "--out", str(f)]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is a file" in err[0]


def test_one_problem_runs_and_passes(tmp_path):
    assert main(["verify", "--quick", "--problems", "force-convergence", "--out", str(tmp_path)]) == ExitCode.OK
    data = json.loads((tmp_path / "results.json").read_text())
    assert [e["name"] for e in data["problems"]] == ["force-convergence"]


@pytest.mark.parametrize("scale", [1.02, 0.98])
def test_a_two_percent_wrong_micromodulus_fails_the_wave_speed(tmp_path, monkeypatch, scale):
    """c 2 % off moves the phase velocity by 1 %: the comparison with the dispersion relation
    (1e-3 at the finest resolution) fails whichever way, and the error no longer converges."""
    from peridyn.materials.elastic_bond_based import ElasticBondBased

    init = ElasticBondBased.__init__

    def wrong(self, *args, **kwargs):
        init(self, *args, **kwargs)
        self.c *= scale

    monkeypatch.setattr(ElasticBondBased, "__init__", wrong)
    assert main(["verify", "--quick", "--problems", "wave-speed", "--out", str(tmp_path)]) == ExitCode.FAILURE
    checks = json.loads((tmp_path / "results.json").read_text())["problems"][0]["checks"]
    failed = [c["what"] for c in checks if not c["passed"]]
    assert "relative speed error at the finest delta/h = 15.5" in failed
    assert "fitted rate of the relative speed error in h/delta" in failed
