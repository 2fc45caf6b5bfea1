"""The GPU against every CPU thread of the same machine (run on demand on a machine with an
NVIDIA GPU; not a test).

Writes cube decks of N^3 points (spacing 1 mm, horizon 3.015 spacings, the LPS ``Elastic``
material of ../shared/benchmarks/cube40_lps.yaml stretched by an initial velocity), with and
without ``Critical Stretch`` damage, runs each with ``peridyn run --device gpu`` and with
``peridyn run`` on all CPU threads, each in a fresh process, and prints whole-run wall time (set-up
included), the solver's bond evaluations per second, and the device memory per point; then the
disk impact with contact of ../shared/benchmarks the same way.

    python benchmarks/gpu.py [--sizes 100 200 300] [--steps 100] [--no-cpu] [--cpu-sizes 100] [--no-contact]

Sizes 100, 200 and 300 are 1 M, 8 M and 27 M points (118 M, 954 M and 3.2 G bonds): the largest
needs about 60 GB of GPU memory and far more host memory for set-up.
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

SPACING = 1.0e-3


def cube_deck(n: int, steps: int, damage: bool) -> dict:
    """An n^3 cube of LPS steel (1 mm spacing), every point moving outwards at up to 10 m/s."""
    length = n * SPACING
    c = length / 2
    tree = {
        "Discretization": {"Type": "PdQuickGrid", "NeighborhoodType": "Spherical",
                           "TensorProduct3DMeshGenerator": {"Type": "PdQuickGrid", "X Origin": 0.0, "Y Origin": 0.0, "Z Origin": 0.0,
                                                            "X Length": length, "Y Length": length, "Z Length": length,
                                                            "Number Points X": n, "Number Points Y": n, "Number Points Z": n}},
        "Materials": {"Steel": {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 130.0e9, "Shear Modulus": 78.0e9}},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "Steel", "Horizon": 3.015 * SPACING}},
        "Boundary Conditions": {
            "All Node Set": "all_points.txt",
            "Spread X": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "x", "Value": f"10.0*(x-{c})/{c}"},
            "Spread Y": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "y", "Value": f"-5.0*(y-{c})/{c}"},
        },
        "Solver": {"Initial Time": 0.0, "Final Time": steps * 1.0e-7, "Verlet": {"Fixed dt": 1.0e-7}},
        "Output": {"Output File Type": "ExodusII", "Output Filename": "cube", "Output Frequency": steps,
                   "Output Variables": {"Displacement": True, "Velocity": True} | ({"Damage": True} if damage else {})},
    }
    if damage:
        tree["Damage Models"] = {"Stretch": {"Damage Model": "Critical Stretch", "Critical Stretch": 0.0015}}
        tree["Blocks"]["B"]["Damage Model"] = "Stretch"
    return {"Peridigm": tree}


def run(folder: Path, deck: str, *extra: str) -> dict:
    """Figures of one ``peridyn run`` in a fresh process (wall, solver rate, device memory)."""
    env = dict(os.environ, PERIDYN_NO_PROGRESS="1")
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "peridyn", "run", deck, "--no-progress", *extra], cwd=folder, env=env,
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    out = {"wall": wall, "rc": proc.returncode}
    if proc.returncode != 0:
        out["error"] = (proc.stderr.strip().splitlines() or ["?"])[-1]
        return out
    m = re.search(r"steps in ([\d.]+) s, ([\d.]+) M bond evaluations/s", proc.stderr)
    if m:
        out["solver"], out["rate"] = float(m.group(1)), float(m.group(2)) * 1e6
    m = re.search(r"device: .* ([\d.]+) bytes per point", proc.stderr)
    if m:
        out["bytes_per_point"] = float(m.group(1))
    return out


def contact_scene(folder: Path, cpu: bool) -> None:
    """The disk impact with contact (../shared/benchmarks/disk_impact) on the GPU and the CPU."""
    shared = Path(__file__).resolve().parents[1].parent / "shared" / "benchmarks" / "disk_impact"
    decks = (sorted(shared.glob("*.yaml")) + sorted(shared.glob("*.xml"))) if shared.is_dir() else []
    if not decks:
        print("contact scene: not found (../shared/benchmarks/disk_impact)")
        return
    folder.mkdir()
    for f in shared.iterdir():
        if f.is_file():
            (folder / f.name).write_bytes(f.read_bytes())
    for device, extra in [("gpu", ("--device", "gpu"))] + ([("cpu", ())] if cpu else []):
        for old in folder.glob("*.e"):
            old.unlink()
        r = run(folder, decks[0].name, *extra)
        if r["rc"] != 0:
            print(f"{'disk_impact (contact)':28s} {device:6s} exit {r['rc']}: {r['error']}")
            continue
        bpp = f"{r['bytes_per_point']:8.0f}" if "bytes_per_point" in r else f"{'-':>8s}"
        print(f"{'disk_impact (contact)':28s} {device:6s} {r['wall']:8.2f} {r.get('solver', float('nan')):9.2f} {r.get('rate', 0.0) / 1e9:9.3f} {bpp}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 200, 300], help="points per edge")
    ap.add_argument("--cpu-sizes", type=int, nargs="+", default=None, help="sizes also run on the CPU (default: every size)")
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--no-cpu", action="store_true")
    ap.add_argument("--no-contact", action="store_true", help="leave out the disk impact")
    a = ap.parse_args()
    cpu_sizes = set(a.sizes if a.cpu_sizes is None else a.cpu_sizes)
    print(f"{'deck':28s} {'device':6s} {'wall s':>8s} {'solver s':>9s} {'G bond/s':>9s} {'B/point':>8s}")
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for n in a.sizes:
            for damage in (False, True):
                name = f"cube{n}_lps" + ("_damage" if damage else "")
                folder = root / name
                folder.mkdir()
                (folder / "deck.yaml").write_text(yaml.safe_dump(cube_deck(n, a.steps, damage), sort_keys=False))
                np.savetxt(folder / "all_points.txt", np.arange(1, n**3 + 1), fmt="%d")
                runs = [("gpu", ("--device", "gpu"))]
                if not a.no_cpu and n in cpu_sizes:
                    runs.append(("cpu", ()))
                for device, extra in runs:
                    for old in folder.glob("cube.*"):
                        old.unlink()
                    r = run(folder, "deck.yaml", *extra)
                    if r["rc"] != 0:
                        print(f"{name:28s} {device:6s} exit {r['rc']}: {r['error']}")
                        continue
                    bpp = f"{r['bytes_per_point']:8.0f}" if "bytes_per_point" in r else f"{'-':>8s}"
                    print(f"{name:28s} {device:6s} {r['wall']:8.2f} {r.get('solver', float('nan')):9.2f} {r.get('rate', 0.0) / 1e9:9.3f} {bpp}",
                          flush=True)
        if not a.no_contact:
            contact_scene(root / "disk_impact", cpu=not a.no_cpu)


if __name__ == "__main__":
    main()
