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


def test_device_gpu_with_no_gpu_method_chosen_is_exit_2_with_one_line(tmp_path, capsys):
    assert main(["verify", "--device", "gpu", "--problems", "force-convergence", "--out", str(tmp_path / "o")]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "GPU" in err[0] and "verlet-energy" in err[0]
    assert not (tmp_path / "o").exists()


def test_device_gpu_without_a_gpu_is_exit_2_with_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("NUMBA_ENABLE_CUDASIM", "0")
    from numba import config

    monkeypatch.setattr(config, "ENABLE_CUDASIM", 0)
    from numba import cuda

    monkeypatch.setattr(cuda, "is_available", lambda: False)
    assert main(["verify", "--device", "gpu", "--problems", "verlet-energy", "--out", str(tmp_path / "o")]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no CUDA GPU" in err[0]
    assert not (tmp_path / "o").exists()


def test_the_verlet_energy_gpu_curve_runs_its_model_on_the_gpu_backend():
    """The GPU curve's runs are the CPU's on the GPU backend (the simulator here): same
    displacements to round-off."""
    from peridyn.verify.problems.base import on_device
    from peridyn.verify.problems.dynamics import VerletEnergy

    problem = VerletEnergy()
    u_cpu, st_cpu = problem.run("Elastic Bond Based", 4, quick=True)
    with on_device("gpu"):
        u_gpu, st_gpu = problem.run("Elastic Bond Based", 4, quick=True)
    assert st_gpu["device"] == "gpu" and st_cpu.get("device", "cpu") == "cpu"
    assert abs(u_gpu - u_cpu).max() <= 1e-12 * abs(u_cpu).max() and abs(u_cpu).max() > 0


def test_help_lists_every_problem(capsys):
    from peridyn.verify import PROBLEMS

    with pytest.raises(SystemExit) as stop:
        main(["verify", "--help"])
    assert stop.value.code == 0
    out = capsys.readouterr().out
    listed = [line.split()[0] for line in out.split("problems (", 1)[1].splitlines()[1:] if line.startswith("  ") and not line.startswith("   ")]
    assert listed == list(PROBLEMS)


def test_compare_fails_when_a_points_error_moves_beyond_its_tolerance(tmp_path):
    first = tmp_path / "first"
    assert main(["verify", "--quick", "--problems", "contact-step", "--out", str(first), "-q"]) == ExitCode.OK
    same = tmp_path / "same"
    assert main(["verify", "--quick", "--problems", "contact-step", "--out", str(same), "--compare", str(first / "results.json"), "-q"]) == ExitCode.OK
    assert json.loads((same / "results.json").read_text())["compare"]["compared"] == 8
    state = json.loads((first / "results.json").read_text())
    state["problems"][0]["points"][3]["error"] *= 1.06  # the earlier run's error 6 % away: this run's moved by 5.7 %
    (first / "moved.json").write_text(json.dumps(state))
    moved = tmp_path / "moved"
    assert main(["verify", "--quick", "--problems", "contact-step", "--out", str(moved), "--compare", str(first / "moved.json"), "-q"]) == ExitCode.FAILURE
    result = json.loads((moved / "results.json").read_text())
    assert result["failed checks"] == 0 and len(result["compare"]["moved"]) == 1
    assert "Compared with" in (moved / "report.md").read_text()


def test_compare_with_a_file_that_is_not_results_is_exit_2_with_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    assert main(["verify", "--problems", "contact-step", "--out", str(tmp_path / "o"), "--compare", str(bad)]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--compare" in err[0]


def test_material_runs_the_problems_that_apply_to_it_and_rejects_an_unknown_one(tmp_path, capsys):
    from peridyn.verify.runner import select_problems

    chosen = select_problems(None, "Elastic Bond Based")
    names = [p.name for p in chosen]
    assert {"wave-speed", "lattice-constants", "critical-stretch", "rigid-rotation", "kalthoff-winkler"} <= set(names)
    assert "kirsch" not in names and "diffusion" not in names
    assert all(p.material_of(m) == "Elastic Bond Based" for p in chosen for m in p.methods)
    assert [p.methods for p in select_problems(["rigid-rotation"], "Pals")] == [("Pals",)]
    assert main(["verify", "--material", "No Such Model", "--out", str(tmp_path / "o")]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "No Such Model" in err[0] and "Elastic" in err[0]
