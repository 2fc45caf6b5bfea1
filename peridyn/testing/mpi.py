"""Launching peridyn under mpiexec from tests (for peridyn's own tests and plugin authors').

``requires_mpi`` (a pytest mark) is made on first use, so that the module imports without pytest."""
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

def find_mpiexec() -> str | None:
    here = Path(sys.executable).parent / "mpiexec"
    if here.exists():
        return str(here)
    return shutil.which("mpiexec")


MPIEXEC = find_mpiexec()


def have_mpi() -> bool:
    if MPIEXEC is None:
        return False
    try:
        import mpi4py  # noqa: F401
    except ImportError:
        return False
    return True


def __getattr__(name: str) -> Any:
    if name == "requires_mpi":
        import pytest

        return pytest.mark.skipif(not have_mpi(), reason="mpiexec or mpi4py not installed (pip install mpi4py mpich)")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def mpirun(ranks: int, args: list[str], cwd, timeout: float = 300, env: dict | None = None) -> subprocess.CompletedProcess:
    """Run ``python -m peridyn ARGS`` on ``ranks`` MPI ranks (serially when ranks == 1)."""
    cmd = [sys.executable, "-m", "peridyn", *args]
    if ranks > 1:
        cmd = [MPIEXEC, "-n", str(ranks), *cmd]
    full_env = dict(os.environ, PERIDYN_NO_PROGRESS="1", **(env or {}))
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout, env=full_env)
