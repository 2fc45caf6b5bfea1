"""What the one explicit step gives the GPU because it is the CPU's step: checkpoints and
restarts (a GPU run continued from its checkpoint writes the uninterrupted GPU run's file bit for
bit, and the CPU continues it within round-off), the data loader, and the Python API's
``step(n)``, ``get`` and ``set`` between steps. Under numba-cuda's simulator (tests/conftest.py)
at small sizes; the fields of a simulated GPU equal the CPU's."""
from __future__ import annotations

import copy
import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("numba.cuda")

from ..solvers.explicit.test_verlet_gpu import CASES, RTOL, contact_deck, frames, lattice_deck, quantity_scale, run, STEEL, LOADS  # noqa: E402


def with_restart(deck: dict, frequency: int) -> dict:
    deck = copy.deepcopy(deck)
    deck["Peridigm"]["Restart"] = {"Restart Frequency": frequency, "Keep": 10}
    return deck


def checkpoint(folder: Path, step: int) -> Path:
    found = sorted((folder / "restart").glob(f"*.000.{step:010d}.npz"))
    assert len(found) == 1, sorted(p.name for p in (folder / "restart").iterdir())
    return found[0]


def assert_identical(a: Path, b: Path) -> None:
    fa, fb = frames(a), frames(b)
    assert fa.keys() == fb.keys()
    for k in fa:
        assert np.array_equal(fa[k], fb[k]), k


DAMAGE = {"Damage Model": "Critical Stretch", "Critical Stretch": 0.0005}


@pytest.mark.parametrize("deck", [
    lattice_deck(STEEL, damage=DAMAGE, conditions=LOADS, steps=8, variables=("Displacement", "Velocity", "Force_Density", "Damage")),
    contact_deck(steps=8),
], ids=["damage_and_loads", "contact_with_friction"])
def test_a_gpu_run_continues_from_its_checkpoint_on_the_gpu_bit_for_bit_and_on_the_cpu(tmp_path, deck):
    deck = with_restart(deck, 4)
    whole = tmp_path / "whole"
    proc = run(whole, deck, "--device", "gpu")
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "on the GPU" in proc.stderr
    for device in ("gpu", "cpu"):
        again = tmp_path / device
        shutil.copytree(whole, again)
        proc = run(again, deck, "--device", device, "--restart", str(checkpoint(again, 4)))
        assert proc.returncode == 0, proc.stderr[-3000:]
        if device == "gpu" or RTOL == 0.0:  # the simulator's arithmetic is the CPU's
            assert_identical(whole / "run.e", again / "run.e")
        else:
            a, b = frames(whole / "run.e"), frames(again / "run.e")
            for k in a:
                np.testing.assert_allclose(b[k], a[k], rtol=1e-12, atol=1e-12 * quantity_scale(a, k), err_msg=k)


def test_a_gpu_run_reads_a_data_loader_as_the_cpu_does(tmp_path):
    """The loaded field (here the temperature of another run, interpolated in time) is output
    the same on both devices, every frame."""
    source = CASES["lps_parabolic_thermal"]
    made = run(tmp_path / "source", source)
    assert made.returncode == 0, made.stderr[-3000:]
    deck = lattice_deck(STEEL, conditions=LOADS, variables=("Displacement", "Temperature"))
    deck["Peridigm"]["Data Loader"] = {"File Name": str(tmp_path / "source" / "run.e"), "Field Name": "Temperature"}
    out = {}
    for device in ("cpu", "gpu"):
        proc = run(tmp_path / device, deck, "--device", device)
        assert proc.returncode == 0, proc.stderr[-3000:]
        out[device] = frames(tmp_path / device / "run.e")
    assert np.abs(out["cpu"]["Temperature"][-1]).max() > 0.0
    for k in out["cpu"]:
        np.testing.assert_allclose(out["gpu"][k], out["cpu"][k], rtol=RTOL, atol=RTOL * quantity_scale(out["cpu"], k), err_msg=k)


def test_the_api_steps_a_gpu_run_and_a_field_set_between_steps_reaches_the_device(tmp_path):
    from peridyn.api import Model

    deck = CASES["bond_based_critical_stretch"]["Peridigm"]
    seen = {}
    for device in ("cpu", "gpu"):
        m = Model({"Peridigm": copy.deepcopy(deck)}, device=device, write_files=False)
        m.step(2)
        u2 = m.get("Displacement")
        v = m.get("Velocity")
        v[:, 2] += 5.0  # a push between steps: the next steps start from it
        m.set("Velocity", v)
        m.step(2)
        seen[device] = (u2, m.get("Displacement"), m.get("Velocity"), m.time)
        m.close()
    assert np.abs(seen["cpu"][1][:, 2]).max() > 0.0
    for a, b in zip(seen["cpu"], seen["gpu"]):
        np.testing.assert_allclose(b, a, rtol=RTOL, atol=RTOL * float(np.max(np.abs(a))))
