"""Contact cost (run on demand, not a test): pair-list build time per build, contact force time
per step, whole-run wall time and peak memory, serially and on 2 ranks, and what the contact
ghost layer moves against what a re-decomposition would move.

Scenes:

* ``peridigm_disk_impact``: Peridigm's own deck ../shared/benchmarks/disk_impact unchanged but
  for ``Final Time: 4.0e-5`` (358 steps; Peridigm on this machine type: 48.2 s, 602 MiB);
* ``disk_impact``: examples/disk_impact.yaml (our generators), ``--final`` cuts it;
* ``projectile40``: a 40 x 40 x 40 lattice target (64,000 points, spacing 1 mm) struck by a
  5 mm sphere at 200 m/s, contact active from the first steps (cube40-sized).

    python benchmarks/contact.py [--scenes ...] [--repeat 3] [--final 2e-5]

Ghosts against re-decomposition: after the run of ``projectile40`` on 2 ranks, the recursive
coordinate bisection of the final positions is compared with the reference one; the points
whose rank would change, times what each carries (its fields and its bonds), is what one
re-decomposition moves; the contact ghost layer moves 13 numbers per ghost per build and 6 per
ghost per step.
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from peridyn.deck.files import dump_yaml
from peridyn.testing.mpi import MPIEXEC

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "benchmarks"


def projectile40() -> dict:
    h = 1e-3
    return {
        "Discretization": {
            "Type": "Shapes",
            "Omit Bonds Between Blocks": "All",
            "Shapes": {
                "Target": {"Shape": "Box", "Block": "block_1", "Min": [0.0, 0.0, 0.0], "Max": [0.04, 0.04, 0.04], "Spacing": h},
                "Ball": {"Shape": "Sphere", "Block": "block_2", "Center": [0.02, 0.02, 0.0461], "Radius": 0.005, "Spacing": h},
            },
        },
        "Materials": {
            "Target": {"Material Model": "Elastic", "Density": 2200.0, "Bulk Modulus": 14.9e9, "Shear Modulus": 8.94e9},
            "Ball": {"Material Model": "Elastic", "Density": 7700.0, "Bulk Modulus": 160e9, "Shear Modulus": 78.3e9},
        },
        "Damage Models": {"Brittle": {"Damage Model": "Critical Stretch", "Critical Stretch": 0.0005}},
        "Blocks": {
            "Target": {"Block Names": "block_1", "Material": "Target", "Damage Model": "Brittle", "Horizon": 3.015 * h},
            "Ball": {"Block Names": "block_2", "Material": "Ball", "Horizon": 3.015 * h},
        },
        "Contact": {
            "Search Radius": 3.0 * h,
            "Search Frequency": 20,
            "Models": {"Springs": {"Contact Model": "Short Range Force", "Contact Radius": 0.9 * h, "Spring Constant": 1e12}},
        },
        "Boundary Conditions": {"Shot": {"Type": "Initial Velocity", "Node Set": "Ball", "Coordinate": "z", "Value": "-200.0"}},
        "Solver": {"Final Time": 3.0e-5, "Verlet": {"Safety Factor": 0.5}},
        "Output": {"Output Filename": "projectile40", "Output Frequency": 50, "Output Variables": {"Displacement": True}},
    }


def prepare(scene: str, folder: Path, final: float | None) -> str:
    if scene == "peridigm_disk_impact":
        for f in (SHARED / "disk_impact").iterdir():
            shutil.copy(f, folder / f.name)
        deck = folder / "disk_impact.yaml"
        deck.write_text(re.sub(r"Final Time: [0-9.eE+-]+", "Final Time: 4.0e-5", deck.read_text()))
        return deck.name
    if scene == "disk_impact":
        text = (ROOT / "examples" / "disk_impact.yaml").read_text()
        if final is not None:
            text = re.sub(r"Final Time: [0-9.eE+-]+", f"Final Time: {final!r}", text)
        (folder / "disk_impact_example.yaml").write_text(text)
        return "disk_impact_example.yaml"
    (folder / "projectile40.yaml").write_text(dump_yaml(projectile40()))
    return "projectile40.yaml"


def run(folder: Path, deck: str, ranks: int, threads: int) -> dict:
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), PERIDYN_NO_PROGRESS="1")
    cmd = ["/usr/bin/time", "-v", sys.executable, "-m", "peridyn", "run", deck]
    if ranks > 1:
        cmd = [MPIEXEC, "-n", str(ranks), sys.executable, "-m", "peridyn", "run", deck]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=folder, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(proc.stderr[-3000:])
    err = proc.stderr
    out = {"wall": wall}
    m = re.search(r"contact: (\d+) searches, (\d+) pair-list builds \(([0-9.e+-]+) ms each\), contact force ([0-9.e+-]+) ms per step", err)
    if m:
        out.update(searches=int(m[1]), builds=int(m[2]), build_ms=float(m[3]), force_ms=float(m[4]))
    m = re.search(r"(\d+) contact ghosts at most", err)
    out["ghosts"] = int(m[1]) if m else 0
    m = re.search(r"Verlet\): (\d+) steps in ([0-9.]+) s", err)
    if m:
        out.update(steps=int(m[1]), solver_s=float(m[2]))
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", err)
    rss = [float(x) for x in re.findall(r"peak memory (\d+) MiB", err)]
    out["rss_mib"] = int(m[1]) / 1024 if m else (max(rss) if rss else float("nan"))
    m = re.search(r"smallest pair distance .* \(penetration ([0-9.]+)%\)", err)
    out["penetration_pct"] = float(m[1]) if m else 0.0
    return out


def redecomposition_bytes(folder: Path, deck: str) -> dict:
    """What one re-decomposition at the end of the run would move (2 ranks), from the output."""
    import netCDF4

    from peridyn.geometry.decomposition import recursive_coordinate_bisection

    with netCDF4.Dataset(folder / deck.replace(".yaml", ".e")) as ds:
        x = np.stack([ds["coordx"][:].data, ds["coordy"][:].data, ds["coordz"][:].data], axis=1)
        names = ["".join(c.decode() for c in row if c) for row in ds["name_nod_var"][:].data]
        u = np.stack([ds[f"vals_nod_var{names.index('Displacement' + c) + 1}"][-1].data for c in "XYZ"], axis=1)
    w = np.ones(x.shape[0])
    before = recursive_coordinate_bisection(x, w, 2)
    after = recursive_coordinate_bisection(x + u, w, 2)
    moved = int(np.count_nonzero(before != after))
    bonds_per_point = 4.0 / 3.0 * np.pi * 3.015**3  # lattice points within the horizon
    per_point = 8 * (3 * 6 + 4) + bonds_per_point * (4 + 8 + 8 + 8)  # vectors, scalars; per bond: index, length, damage N/NP1
    return {"moved_points": moved, "moved_bytes": moved * per_point}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["peridigm_disk_impact", "disk_impact", "projectile40"])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--final", type=float, default=None, help="Final Time of the disk_impact example")
    a = ap.parse_args()
    configs = [(1, 1), (1, 2), (2, 1)]
    for scene in a.scenes:
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            deck = prepare(scene, folder, a.final)
            results: dict[tuple[int, int], list[dict]] = {c: [] for c in configs}
            for _ in range(a.repeat):  # interleaved rounds
                for ranks, threads in configs:
                    results[(ranks, threads)].append(run(folder, deck, ranks, threads))
            print(f"\n{scene} ({deck}), medians of {a.repeat}")
            print("ranks x threads | wall s | solver s | steps | builds | ms per build | contact ms per step | ghosts | peak MiB | penetration")
            for (ranks, threads), rs in results.items():
                med = {k: statistics.median(r[k] for r in rs) for k in rs[0] if isinstance(rs[0][k], (int, float))}
                print(f"{ranks} x {threads} | {med['wall']:.2f} | {med.get('solver_s', float('nan')):.2f} | {med.get('steps', 0):.0f} | "
                      f"{med.get('builds', 0):.0f} | {med.get('build_ms', float('nan')):.2f} | {med.get('force_ms', float('nan')):.3f} | "
                      f"{med.get('ghosts', 0):.0f} | {med['rss_mib']:.0f} | {med.get('penetration_pct', 0):.1f}%")
            if scene == "projectile40":
                r = results[(2, 1)][-1]
                red = redecomposition_bytes(folder, deck)
                ghost_build = r["ghosts"] * 13 * 8
                ghost_steps = r["ghosts"] * 6 * 8 * r.get("steps", 0)
                print(f"re-decomposition at the end would move {red['moved_points']} points, {red['moved_bytes'] / 1e6:.2f} MB; "
                      f"contact ghosts: {r['ghosts']} at most, {ghost_build / 1e6:.3f} MB per build, "
                      f"{ghost_steps / 1e6:.2f} MB of per-step refreshes over the whole run")


if __name__ == "__main__":
    main()
