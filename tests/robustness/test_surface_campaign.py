"""A CI-sized sample of the surface campaign (benchmarks/surface_campaign.py, issue #33): meshes
and .geo scripts, regions, Surface Traction, restart files, stress-law modules, the Python API's
arguments, the commands' arguments and a few runs on 2 MPI ranks; fails on any bad outcome
class. About a minute on two cores. PERIDYN_SURFACE_CASES (default 80) and
PERIDYN_SURFACE_SEED (default 7) pick the sample; the full campaign is
``python benchmarks/surface_campaign.py --cases 2000 --seed 1``.
"""
from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.robustness

ROOT = Path(__file__).resolve().parents[2]
CASES = int(os.environ.get("PERIDYN_SURFACE_CASES", "80"))
SEED = int(os.environ.get("PERIDYN_SURFACE_SEED", "7"))


def _campaign_in_a_child(out: Path) -> None:
    """The campaign forks its cases from a warm parent whose numba threading layer must be
    workqueue (GNU OpenMP refuses fork): run it in a fresh interpreter, not in pytest's."""
    import subprocess

    env = dict(os.environ, NUMBA_THREADING_LAYER="workqueue", NUMBA_NUM_THREADS="1")
    cmd = [sys.executable, str(ROOT / "benchmarks" / "surface_campaign.py"), "--cases", str(CASES), "--seed", str(SEED),
           "--out", str(out / "table.md"), "--json", str(out / "cases.json")]
    subprocess.run(cmd, env=env, check=True, timeout=600, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _bad_classes() -> tuple[str, ...]:
    """The campaign's BAD_CLASSES, read from its source: importing the campaign package here would
    set NUMBA_NUM_THREADS=1 in pytest's process (it prepares a forking parent), and every later
    test that starts numba's threads would then fail."""
    import ast

    tree = ast.parse((ROOT / "benchmarks" / "surface_campaign" / "engine.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "BAD_CLASSES" for t in node.targets):
            return tuple(ast.literal_eval(node.value))
    raise AssertionError("BAD_CLASSES not found in benchmarks/surface_campaign/engine.py")


@pytest.mark.skipif(shutil.which("mpiexec") is None, reason="needs mpiexec (the mpi extra)")
def test_a_sample_of_every_family_has_no_bad_outcome(tmp_path):
    pytest.importorskip("gmsh")
    pytest.importorskip("meshio")
    import json

    BAD_CLASSES = _bad_classes()
    _campaign_in_a_child(tmp_path)
    rows = json.loads((tmp_path / "cases.json").read_text())
    families = {r["family"] for r in rows}
    assert families >= {"mesh", "geo", "regions", "traction", "restart", "stress_law", "api", "cli", "mpi"}, families
    bad = [f"{r['class']}: {r['family']}: {r['case'][:120]} -> rc={r['rc']}: {r['line'][:200]}" for r in rows if r["class"] in BAD_CLASSES]
    assert not bad, "\n".join(bad)
