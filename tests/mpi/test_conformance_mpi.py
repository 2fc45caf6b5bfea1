"""The reference cases peridyn passes on 2 ranks must keep passing (one merged output file)."""
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from peridyn.testing.mpi import MPIEXEC, requires_mpi

HERE = Path(__file__).resolve().parent
RUNNER = HERE.parents[1].parent / "shared" / "conformance" / "run.py"
LIST = HERE.parent / "regression" / "conformance_mpi.txt"


def listed() -> list[str]:
    return [ln.strip() for ln in LIST.read_text().splitlines() if ln.strip() and not ln.startswith("#")]


@pytest.mark.mpi
@pytest.mark.conformance
@requires_mpi
@pytest.mark.skipif(not RUNNER.exists(), reason="../shared/conformance is not present")
@pytest.mark.parametrize("case", listed())
def test_case_passes_on_two_ranks(case, tmp_path):
    cmd = f"{shlex.quote(sys.executable)} -m peridyn run"
    proc = subprocess.run(
        [sys.executable, str(RUNNER), "--cmd", cmd, "--np", "2", "--mpiexec", MPIEXEC, "--only", case, "--timeout", "600"],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert "1 passed, 0 failed" in proc.stdout, proc.stdout[-3000:] + proc.stderr[-2000:]
