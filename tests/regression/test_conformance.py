"""Peridigm's reference cases that peridyn passes must keep passing.

The cases live outside the project (../shared/conformance); the tests skip when it is absent.
Each listed case runs through the shared runner, which compares our Exodus output with
Peridigm's gold file under the case's tolerance file.
"""
import importlib.util
import os
import shlex
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from peridyn.core.resources import usable_cores

HERE = Path(__file__).resolve().parent
RUNNER = HERE.parents[1].parent / "shared" / "conformance" / "run.py"


def listed(name: str) -> list[str]:
    lines = (HERE / name).read_text().splitlines()
    return [ln.strip() for ln in lines if ln.strip() and not ln.startswith("#")]


#: test name -> (list of cases, ``peridyn run`` options, environment the run adds)
SUITES = {
    "test_case_still_passes": ("conformance_serial.txt", "", {"NUMBA_NUM_THREADS": "1"}),
    "test_case_passes_on_the_gpu_path": ("conformance_gpu.txt", " --device gpu",
                                         {"NUMBA_ENABLE_CUDASIM": os.environ.get("NUMBA_ENABLE_CUDASIM", "1")}),
}


def _run(case: str, options: str, env: dict[str, str], keep: Path) -> subprocess.CompletedProcess:
    cmd = f"{shlex.quote(sys.executable)} -m peridyn run{options}"
    return subprocess.run(
        [sys.executable, str(RUNNER), "--cmd", cmd, "--only", case, "--keep", str(keep)],
        capture_output=True,
        text=True,
        timeout=900,
        env={**os.environ, **env},
    )


@pytest.fixture(scope="module")
def runs(request, tmp_path_factory):
    """The selected cases started at once on a pool of one-thread runs, one per core; each test
    waits for its own case (independent processes, each in its own folder)."""
    cores = usable_cores()
    pool = ThreadPoolExecutor(max_workers=max(1, min(cores, 8)))
    futures = {}
    for item in request.session.items:
        name = getattr(item, "originalname", None)
        if name in SUITES and not any(m.args and m.args[0] is True for m in item.iter_markers("skipif")):
            _, options, env = SUITES[name]
            case = item.callspec.params["case"]
            futures[name, case] = pool.submit(_run, case, options, env, tmp_path_factory.mktemp(case))
    try:
        yield futures
    finally:
        pool.shutdown(cancel_futures=True)


def _passes(runs, name: str, case: str) -> None:
    proc = runs[name, case].result()
    assert "1 passed, 0 failed" in proc.stdout, proc.stdout[-3000:] + proc.stderr[-2000:]


@pytest.mark.conformance
@pytest.mark.skipif(not RUNNER.exists(), reason="../shared/conformance is not present")
@pytest.mark.parametrize("case", listed("conformance_serial.txt"))
def test_case_still_passes(case, runs):
    """On one thread, where closed blocks take the mirrored kernels (peridyn.kernels.mirror); the
    gathers are checked by the MPI list and by the mirrored kernels' bit-for-bit tests."""
    _passes(runs, "test_case_still_passes", case)


@pytest.mark.conformance
@pytest.mark.skipif(not RUNNER.exists(), reason="../shared/conformance is not present")
@pytest.mark.skipif(importlib.util.find_spec("numba.cuda") is None, reason="numba-cuda is not installed")
@pytest.mark.parametrize("case", listed("conformance_gpu.txt"))
def test_case_passes_on_the_gpu_path(case, runs):
    """The case with ``--device gpu``, under numba-cuda's simulator (or on a GPU where the
    environment says NUMBA_ENABLE_CUDASIM=0)."""
    _passes(runs, "test_case_passes_on_the_gpu_path", case)


def test_list_names_real_cases():
    if not RUNNER.exists():
        pytest.skip("../shared/conformance is not present")
    cases = RUNNER.parent / "cases"
    missing = [c for name in ("conformance_serial.txt", "conformance_gpu.txt") for c in listed(name) if not (cases / c).is_dir()]
    assert not missing
