"""The GPU step indexes no device array from Python. numba-cuda slices a device array on the host
one element at a time in Python when the slice is not contiguous (a column of an (n, 2) array):
seconds a slice at a million points. A slice made once at set-up is allowed; one made every step
made an LPS run of 1 M points on an H200 take minutes a step. Counted under the simulator, where
device arrays are numpy-backed: the indexing that peridyn's own code does on the host (kernels run
in other threads) must not grow with the number of steps."""
from __future__ import annotations

import threading
import traceback
from collections import Counter

import pytest
import yaml

pytest.importorskip("numba.cuda")

from ..solvers.explicit.test_verlet_gpu import CASES  # noqa: E402

SIMULATOR = pytest.importorskip("numba.cuda.simulator.cudadrv.devicearray")


def host_indexing(tmp_path, monkeypatch, case: str, steps: int) -> Counter:
    """(file:line of peridyn code) -> how often it indexed a device array on the host thread."""
    from peridyn.cli import main

    deck = yaml.safe_load(yaml.safe_dump(CASES[case]))
    solver = deck["Peridigm"]["Solver"]
    solver["Final Time"] = steps * solver["Verlet"]["Fixed dt"]
    deck["Peridigm"]["Output"]["Output Frequency"] = steps
    folder = tmp_path / f"{case}_{steps}"
    folder.mkdir()
    (folder / "deck.yaml").write_text(yaml.safe_dump(deck))
    seen: Counter = Counter()
    host = threading.main_thread()
    original = SIMULATOR.FakeCUDAArray.__getitem__

    def getitem(self, item):
        if threading.current_thread() is host:
            caller = traceback.extract_stack(limit=2)[0]
            if "/peridyn/" in caller.filename.replace("\\", "/"):
                seen[f"{caller.filename.rsplit('/', 1)[-1]}:{caller.lineno}"] += 1
        return original(self, item)

    monkeypatch.setattr(SIMULATOR.FakeCUDAArray, "__getitem__", getitem)
    monkeypatch.chdir(folder)
    assert main(["run", "deck.yaml", "--device", "gpu", "--no-progress", "-q"]) == 0
    return seen


@pytest.mark.parametrize("case", ["lps_critical_stretch_loads", "bond_based_critical_stretch", "lps_two_bodies_contact_friction",
                                  "lps_parabolic_thermal"])
def test_the_step_indexes_no_device_array_from_python(tmp_path, monkeypatch, case):
    if not __import__("numba").config.ENABLE_CUDASIM:
        pytest.skip("counted under the simulator (NUMBA_ENABLE_CUDASIM=1)")
    short, long = host_indexing(tmp_path, monkeypatch, case, 2), host_indexing(tmp_path, monkeypatch, case, 6)
    assert long == short, f"indexing of device arrays that grows with the steps: {long - short}"
