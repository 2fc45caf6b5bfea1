"""Mirrored traversal (peridyn.kernels.mirror): each bond once, for both ends, on one thread; the
same bits as the gather kernels, and refused wherever that could not hold."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from peridyn.core.bonds import NeighborList
from peridyn.geometry.neighbors import radius_search
from peridyn.kernels import compiled
from peridyn.kernels.mirror import mirror_plan
from peridyn.kernels.numba_cpu import NumbaBackend, SerialNumbaBackend
from peridyn.testing.harness import build_simulation, cube_deck

from . import laws_for_tests as laws


def lattice(n: int = 6, jitter: float = 0.05, seed: int = 0):
    g = np.arange(n, dtype=float)
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    x = x + jitter * np.random.default_rng(seed).standard_normal(x.shape)
    offsets, neighbors = radius_search(x, np.full(len(x), 2.2), np.arange(len(x)), dtype=np.int32)
    return NeighborList(offsets, neighbors), x


def inputs(nl: NeighborList, x: np.ndarray, seed: int = 1):
    rng = np.random.default_rng(seed)
    n = nl.num_points
    y = x + 0.01 * rng.standard_normal(x.shape)
    zeta = np.empty(nl.num_bonds)
    for i in range(n):
        d = x[nl.neighbors[nl.offsets[i]:nl.offsets[i + 1]]] - x[i]
        zeta[nl.offsets[i]:nl.offsets[i + 1]] = np.sqrt((d * d).sum(axis=1))
    marks = (rng.random(nl.num_bonds) < 0.2).astype(np.int64)  # gates differ between a bond's two ends
    return y, zeta, (rng.random(n), rng.random(n), 1.7, marks)


@pytest.mark.parametrize("law, width", [(laws.SUM, 0), (laws.PAIR, 3), (laws.MOMENT, 3)], ids=["sum", "pair", "vector-sum"])
def test_mirrored_kernels_give_the_gather_kernels_bits(law, width):
    nl, x = lattice()
    n = nl.num_points
    y, zeta, args = inputs(nl, x)
    if law is laws.PAIR:
        args = (args[0], None, None, args[3])
    if law is laws.MOMENT:
        args = (args[0], 4.0)
    backend = SerialNumbaBackend()
    shape = (n, width) if width else n
    gathered, mirrored = np.full(shape, np.nan), np.full(shape, np.nan)
    backend.kernel(law)(0, n, nl.offsets, nl.neighbors, zeta, y, args, gathered)
    plan = mirror_plan(nl, 0, n)
    assert plan is not None
    backend.mirror_kernel(law)(0, n, nl.offsets, nl.neighbors, zeta, y, args, mirrored, *plan)
    assert np.array_equal(gathered.view(np.int64), mirrored.view(np.int64))
    again = np.full(shape, np.nan)  # the cursors are reset by every call
    backend.mirror_kernel(law)(0, n, nl.offsets, nl.neighbors, zeta, y, args, again, *plan)
    assert np.array_equal(again.view(np.int64), mirrored.view(np.int64))


def test_a_changed_term_changes_the_mirrored_sum():
    """The comparison above can fail: one bond's mark flipped changes the mirrored result."""
    nl, x = lattice()
    n = nl.num_points
    y, zeta, args = inputs(nl, x)
    backend = SerialNumbaBackend()
    plan = mirror_plan(nl, 0, n)
    out = [np.empty(n), np.empty(n)]
    backend.mirror_kernel(laws.SUM)(0, n, nl.offsets, nl.neighbors, zeta, y, args, out[0], *plan)
    marks = args[3].copy()
    b = int(nl.offsets[7])  # a lower bond of point 7's first neighbor's row sees it as upper
    marks[b] = 1 - marks[b]
    backend.mirror_kernel(laws.SUM)(0, n, nl.offsets, nl.neighbors, zeta, y, args[:3] + (marks,), out[1], *plan)
    assert np.flatnonzero(out[0] != out[1]).tolist() == [7]


def test_the_plan_is_refused_where_the_order_could_not_hold():
    nl, x = lattice(5)
    n = nl.num_points
    assert mirror_plan(nl, 0, n) is not None
    assert mirror_plan(nl, 10, n) is None  # bonds leave the range
    # one direction of one bond removed: rows no longer symmetric
    cut = np.ones(nl.num_bonds, dtype=bool)
    cut[int(nl.offsets[3])] = False
    offsets = np.concatenate([[0], np.cumsum([np.count_nonzero(cut[nl.offsets[i]:nl.offsets[i + 1]]) for i in range(n)])])
    assert mirror_plan(NeighborList(offsets, nl.neighbors[cut]), 0, n) is None
    # points not stored in key order (a Hilbert layout): rows sorted by key, storage not
    key = np.random.default_rng(3).permutation(n)
    rows = [sorted(nl.neighbors[nl.offsets[i]:nl.offsets[i + 1]], key=lambda j: key[j]) for i in range(n)]
    permuted = NeighborList(nl.offsets, np.concatenate(rows).astype(np.int32), row_key=key)
    assert mirror_plan(permuted, 0, n) is None
    # a row out of order
    shuffled = nl.neighbors.copy()
    lo = int(nl.offsets[4])
    shuffled[lo], shuffled[lo + 1] = shuffled[lo + 1], shuffled[lo]
    assert mirror_plan(NeighborList(nl.offsets, shuffled), 0, n) is None


ELASTIC = {"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 0.5}
DECKS = {
    "elastic": (ELASTIC, None),
    "elastic, critical stretch": (ELASTIC, {"Damage Model": "Critical Stretch", "Critical Stretch": 0.01}),
    "elastic, parabolic influence": (ELASTIC, None),
    "bond based, critical stretch": ({"Material Model": "Elastic Bond Based", "Density": 1.0, "Bulk Modulus": 1.0},
                                     {"Damage Model": "Critical Stretch", "Critical Stretch": 0.01}),
    "pals": ({"Material Model": "Pals", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 0.5}, None),
    "viscoelastic": ({"Material Model": "Viscoelastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 0.5,
                      "lambda_i": 0.5, "tau b": 0.1}, None),
}


@pytest.mark.parametrize("name", list(DECKS))
def test_a_one_thread_run_mirrors_and_gives_the_gathered_forces(name, monkeypatch):
    material, damage = DECKS[name]
    tree = cube_deck(material, n=6, damage=damage)
    if "influence" in name:
        tree["Discretization"]["Influence Function"] = "Parabolic Decay"
    results = []
    for mirror in ("0", "1"):
        monkeypatch.setenv("PERIDYN_MIRROR", mirror)
        sim = build_simulation(tree, backend="numba-serial")
        rng = np.random.default_rng(0)
        sim.fields["Coordinates"][:] += 0.02 * rng.standard_normal(sim.fields["Coordinates"].shape)
        forces = [sim.evaluate_forces().copy() for _ in range(2)]  # twice: state advanced by the first
        used = [k for k, v in sim.bonds._derived.items() if k.startswith("mirror") and v is not None]
        assert bool(used) == (mirror == "1")
        results.append((forces, {k: sim.fields[k].copy() for k in ("Bond_Damage", "Damage", "Dilatation") if sim.fields.allocated(k)}))
    (f0, s0), (f1, s1) = results
    for a, b in zip(f0, f1):
        assert np.array_equal(a.view(np.int64), b.view(np.int64))
    assert s0.keys() == s1.keys()
    for key in s0:
        assert np.array_equal(s0[key], s1[key]), key


def test_only_one_thread_and_closed_blocks_mirror(monkeypatch):
    sim = build_simulation(cube_deck(ELASTIC, n=4), backend="numba-serial")
    view = sim.blocks[0].view
    assert view.closed
    law = laws.SUM
    assert compiled(view, law) is not sim.backend.kernel(law)  # mirrored wrapper
    monkeypatch.setenv("PERIDYN_MIRROR", "0")
    assert compiled(view, law) is sim.backend.kernel(law)
    monkeypatch.delenv("PERIDYN_MIRROR")
    view.closed = False
    assert compiled(view, law) is sim.backend.kernel(law)
    view.closed = True
    threads = NumbaBackend()
    monkeypatch.setattr(threads, "one_thread", lambda: False)
    view.backend = threads
    assert compiled(view, law) is threads.kernel(law)
    view.backend = sim.backend
    assert compiled(view, laws.STRETCH) is sim.backend.kernel(laws.STRETCH)  # a bond map: nothing to mirror


CASES = Path(__file__).resolve().parents[3].parent / "shared" / "conformance" / "cases"


@pytest.mark.skipif(not CASES.is_dir(), reason="../shared/conformance is not present")
@pytest.mark.parametrize("case", ["BondBreakingInitialVelocity", "Compression_3x1x1_InfluenceFunction", "ElasticBondBased3D",
                                  "ThermalExpansionBondFailure", "Contact_Friction"])
def test_a_reference_case_on_one_thread_is_the_same_with_and_without_mirroring(case, tmp_path):
    netCDF4 = pytest.importorskip("netCDF4")
    deck = next(p.name for p in (CASES / case).iterdir() if p.suffix in (".xml", ".yaml", ".peridigm"))
    results = []
    for mirror in ("0", "1"):
        work = tmp_path / mirror
        shutil.copytree(CASES / case, work, ignore=shutil.ignore_patterns("*_gold.*", "*.comp", "CASE.json"))
        env = {**os.environ, "NUMBA_NUM_THREADS": "1", "PERIDYN_MIRROR": mirror}
        proc = subprocess.run([sys.executable, "-m", "peridyn", "run", deck, "-q", "--no-progress"], cwd=work, env=env,
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr[-2000:]
        files = {}
        for path in sorted(work.glob("*.e")):
            with netCDF4.Dataset(path) as ds:
                files[path.name] = {k: np.asarray(v[:]) for k, v in ds.variables.items() if v.dtype.kind in "fiu"}
        results.append(files)
    assert results[0] and results[0].keys() == results[1].keys()
    for name, variables in results[0].items():
        for key, value in variables.items():
            assert np.array_equal(value, results[1][name][key], equal_nan=value.dtype.kind == "f"), (name, key)
