"""`peridyn new-plugin` makes packages that pip-install and whose own tests pass."""
import os
import re
import subprocess
import sys

import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode


@pytest.mark.parametrize("kind", ["material", "damage", "contact", "compute", "stress-law"])
def test_generated_plugin_installs_and_its_tests_pass(kind, tmp_path):
    name = f"my_{kind.replace('-', '_')}"
    assert main(["new-plugin", name, "--kind", kind, "--directory", str(tmp_path)]) == ExitCode.OK
    pkg = tmp_path / name
    site = tmp_path / "site"
    install = subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation", "--target", str(site), str(pkg)],
        capture_output=True,
        text=True,
    )
    assert install.returncode == 0, install.stderr
    assert list(site.glob(f"{name}-*.dist-info/entry_points.txt")), "the entry point must be installed"
    env = dict(os.environ, PYTHONPATH=str(site))
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(pkg / "tests")], cwd=pkg, capture_output=True, text=True, env=env)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    if kind == "stress-law":
        # the law's own checks and the non-ordinary kit's on the built-in material with it
        passed = re.search(r"(\d+) passed", run.stdout)
        assert passed and int(passed.group(1)) >= 6, run.stdout[-3000:]
    if kind == "material":
        # the kit's checks ran (moduli, momentum, damage, density, energy, ...), not just a few
        passed = re.search(r"(\d+) passed", run.stdout)
        assert passed and int(passed.group(1)) >= 17, run.stdout[-3000:]
        # installed, the plugin is found through its entry point and listed with its parameters
        listing = subprocess.run([sys.executable, "-m", "peridyn", "plugins"], capture_output=True, text=True, env=env)
        assert "My Material" in listing.stdout and "Bulk Modulus" in listing.stdout


def test_existing_folder_is_refused(tmp_path, capsys):
    (tmp_path / "taken").mkdir()
    assert main(["new-plugin", "taken", "--directory", str(tmp_path)]) == ExitCode.INPUT_ERROR
    assert "already exists" in capsys.readouterr().err


def test_bad_package_name_is_refused(tmp_path, capsys):
    assert main(["new-plugin", "1abc", "--directory", str(tmp_path)]) == ExitCode.INPUT_ERROR
    assert "package name" in capsys.readouterr().err
