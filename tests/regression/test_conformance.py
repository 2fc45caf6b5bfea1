"""Peridigm's reference cases that peridyn passes must keep passing.

The cases live outside the project (../shared/conformance); the tests skip when it is absent.
Each listed case runs through the shared runner, which compares our Exodus output with
Peridigm's gold file under the case's tolerance file.
"""
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
RUNNER = HERE.parents[1].parent / "shared" / "conformance" / "run.py"


def listed(name: str) -> list[str]:
    lines = (HERE / name).read_text().splitlines()
    return [ln.strip() for ln in lines if ln.strip() and not ln.startswith("#")]


@pytest.mark.conformance
@pytest.mark.skipif(not RUNNER.exists(), reason="../shared/conformance is not present")
@pytest.mark.parametrize("case", listed("conformance_serial.txt"))
def test_case_still_passes(case, tmp_path):
    """On one thread, where closed blocks take the mirrored kernels (peridyn.kernels.mirror); the
    gathers are checked by the MPI list and by the mirrored kernels' bit-for-bit tests."""
    cmd = f"{shlex.quote(sys.executable)} -m peridyn run"
    proc = subprocess.run(
        [sys.executable, str(RUNNER), "--cmd", cmd, "--only", case, "--keep", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=900,
        env={**os.environ, "NUMBA_NUM_THREADS": "1"},
    )
    assert "1 passed, 0 failed" in proc.stdout, proc.stdout[-3000:] + proc.stderr[-2000:]


@pytest.mark.conformance
@pytest.mark.skipif(not RUNNER.exists(), reason="../shared/conformance is not present")
@pytest.mark.parametrize("case", listed("conformance_gpu.txt"))
def test_case_passes_on_the_gpu_path(case, tmp_path):
    """The case with ``--device gpu``, under numba-cuda's simulator (or on a GPU where the
    environment says NUMBA_ENABLE_CUDASIM=0)."""
    pytest.importorskip("numba.cuda")
    cmd = f"{shlex.quote(sys.executable)} -m peridyn run --device gpu"
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": os.environ.get("NUMBA_ENABLE_CUDASIM", "1")}
    proc = subprocess.run(
        [sys.executable, str(RUNNER), "--cmd", cmd, "--only", case, "--keep", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=900,
        env=env,
    )
    assert "1 passed, 0 failed" in proc.stdout, proc.stdout[-3000:] + proc.stderr[-2000:]


def test_list_names_real_cases():
    if not RUNNER.exists():
        pytest.skip("../shared/conformance is not present")
    cases = RUNNER.parent / "cases"
    missing = [c for name in ("conformance_serial.txt", "conformance_gpu.txt") for c in listed(name) if not (cases / c).is_dir()]
    assert not missing
