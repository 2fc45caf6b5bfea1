"""Every command works from a plain install, without the test extra: peridyn.testing and
peridyn.verify (every module of both) import with pytest unimportable, and ``peridyn verify``,
``peridyn check`` run. A child process is started with pytest (and hypothesis) blocked in
sys.modules, so an import of either fails there as it does where they are not installed."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
BLOCK = "import sys\nfor _m in ('pytest', '_pytest', 'hypothesis'):\n    sys.modules[_m] = None\n"


def run_blocked(code: str, cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    env = dict(os.environ, PERIDYN_NO_PROGRESS="1")
    return subprocess.run([sys.executable, "-c", BLOCK + code], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def test_the_block_makes_pytest_unimportable(tmp_path):
    proc = run_blocked("import pytest\n", tmp_path)
    assert proc.returncode != 0 and "pytest" in proc.stderr


def test_every_module_of_testing_and_verify_imports_without_pytest(tmp_path):
    code = (
        "import importlib, pkgutil\n"
        "import peridyn.testing, peridyn.verify\n"
        "names = []\n"
        "for pkg in (peridyn.testing, peridyn.verify):\n"
        "    for info in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + '.'):\n"
        "        importlib.import_module(info.name)\n"
        "        names.append(info.name)\n"
        "from peridyn.testing import MaterialConformance, build_simulation, cube_deck\n"
        "from peridyn.testing.mpi import mpirun, have_mpi\n"
        "from peridyn.testing.mutants import run_checks\n"
        "assert sys.modules['pytest'] is None\n"
        "print(len(names))\n"
    )
    proc = run_blocked(code, tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert int(proc.stdout.split()[-1]) >= 10  # the kit's and verify's modules, problems included


def cli(args: list[str]) -> str:
    return f"import runpy\nsys.argv = ['peridyn', *{args!r}]\nrunpy.run_module('peridyn', run_name='__main__')\n"


def test_verify_help_and_a_bad_problem_name_without_pytest(tmp_path):
    proc = run_blocked(cli(["verify", "--help"]), tmp_path)
    assert proc.returncode == 0 and "--quick" in proc.stdout, proc.stderr
    proc = run_blocked(cli(["verify", "--problems", "no-such-problem", "--out", str(tmp_path / "v")]), tmp_path)
    assert proc.returncode == 2 and "no-such-problem" in proc.stderr and "pytest" not in proc.stderr, proc.stderr


def test_check_runs_without_pytest(tmp_path):
    deck = ROOT / "examples" / "quickstart.yaml"
    if not deck.exists():
        pytest.skip("examples/quickstart.yaml is not in this checkout")
    proc = run_blocked(cli(["check", str(deck)]), tmp_path)
    assert proc.returncode == 0 and "valid" in proc.stdout, proc.stderr


def test_the_mpi_mark_is_still_a_pytest_mark():
    from peridyn.testing import mpi

    assert mpi.requires_mpi.name == "skipif"
    with pytest.raises(AttributeError):
        mpi.no_such_name  # noqa: B018
