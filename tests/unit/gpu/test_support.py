"""A deck with something that has no GPU path is refused with one line naming it and
``--device cpu`` (exit 2), by ``peridyn run --device gpu`` and by ``peridyn check --device gpu``
before anything runs; nothing falls back to the CPU silently."""
from __future__ import annotations

import subprocess
import sys

import pytest
import yaml

pytest.importorskip("numba.cuda")

from ..solvers.explicit.test_verlet_gpu import STEEL, lattice_deck, run  # noqa: E402


def check(folder, deck, *extra):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "deck.yaml").write_text(yaml.safe_dump(deck, sort_keys=False))
    return subprocess.run([sys.executable, "-m", "peridyn", "check", "deck.yaml", *extra], cwd=folder, capture_output=True, text=True, timeout=300)


def refused(proc, *words):
    assert proc.returncode == 2, proc.stdout + proc.stderr
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, proc.stderr
    for w in words + ("--device cpu", "deck.yaml"):
        assert w in errors[0], errors[0]


def quasi_static():
    deck = lattice_deck(STEEL)
    deck["Peridigm"]["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": 2}}
    return deck


def correspondence():
    return lattice_deck({"Material Model": "Elastic Correspondence", "Density": 7800.0, "Bulk Modulus": 130.0e9, "Shear Modulus": 78.0e9,
                         "Hourglass Coefficient": 0.02})


def two_materials():
    """Two blocks of different materials bonded to each other: the engine's bond-force gather."""
    deck = lattice_deck(STEEL)
    tree = deck["Peridigm"]
    tree["Discretization"] = {"Type": "Shapes",
                              "Shapes": {"A": {"Shape": "Box", "Block": "block_1", "Min": [0.0, 0.0, 0.0], "Max": [3e-3, 3e-3, 3e-3], "Spacing": 1e-3},
                                         "B": {"Shape": "Box", "Block": "block_2", "Min": [3e-3, 0.0, 0.0], "Max": [6e-3, 3e-3, 3e-3], "Spacing": 1e-3}}}
    tree["Materials"]["Bonds"] = {"Material Model": "Elastic Bond Based", "Density": 7800.0, "Bulk Modulus": 130.0e9}
    tree["Blocks"] = {"B1": {"Block Names": "block_1", "Material": "M", "Horizon": 2.015e-3},
                      "B2": {"Block Names": "block_2", "Material": "Bonds", "Horizon": 2.015e-3}}
    tree["Boundary Conditions"] = {}
    return deck


@pytest.mark.parametrize("make, words", [(quasi_static, ("QuasiStatic",)), (correspondence, ("Elastic Correspondence",)),
                                         (two_materials, ("bond-force gather",))], ids=["solver", "material", "bonds-across-blocks"])
def test_what_has_no_gpu_path_is_refused_before_the_run(tmp_path, make, words):
    deck = make()
    refused(check(tmp_path / "check", deck, "--device", "gpu"), *words)
    refused(run(tmp_path / "run", deck, "--device", "gpu"), *words)
    assert not list((tmp_path / "run").glob("*.e"))
    ok = check(tmp_path / "cpu", deck)
    assert ok.returncode == 0, ok.stderr


def test_check_says_a_deck_runs_on_the_gpu(tmp_path):
    proc = check(tmp_path, lattice_deck(STEEL, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 0.01}), "--device", "gpu")
    assert proc.returncode == 0 and "device: gpu" in proc.stdout, proc.stdout + proc.stderr


def test_backend_and_device_must_agree(tmp_path):
    deck = lattice_deck(STEEL, steps=2)
    refused(run(tmp_path / "a", deck, "--device", "gpu", "--backend", "numba"), "--backend numba")
    proc = run(tmp_path / "b", deck, "--backend", "cuda")  # the GPU backend means the GPU
    assert proc.returncode == 0 and "Verlet on the GPU" in proc.stderr, proc.stderr


def test_without_a_gpu_the_run_says_so(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_ENABLE_CUDASIM", "0")
    proc = run(tmp_path, lattice_deck(STEEL, steps=2), "--device", "gpu")
    if proc.returncode == 0:
        pytest.skip("this machine has a GPU")
    refused(proc, "no CUDA GPU")


def test_a_material_that_declares_the_gpu_without_a_fused_force_is_refused(tmp_path):
    """The GPU step computes forces only through ``Material.force_fused``: a model that declares
    "gpu" without one would die inside the run; the check names it first."""
    from peridyn.core.interfaces import Material
    from peridyn.gpu.support import model_problems
    from peridyn.testing.harness import build_simulation

    sim = build_simulation(lattice_deck(STEEL)["Peridigm"], directory=tmp_path)
    assert model_problems(sim) == []
    material = sim.blocks[0].material
    material.__class__ = type("NoFusedForce", (type(material),), {"force_fused": Material.force_fused})
    (path, what), = model_problems(sim)
    assert "fused force" in what and "force_fused" in what
