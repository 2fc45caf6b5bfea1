"""Explicit dynamics speed against Peridigm on this machine type (run on demand, not a test).

Runs ../shared/benchmarks/cube40_lps.yaml and cube40_lps_damage.yaml (64,000 points, 7.15 M
bonds, 400 steps) with 1 and 2 numba threads, each in a fresh process, and prints whole-run wall
time (set-up included), bond evaluations per second, point-steps per second and peak memory,
next to Peridigm's figures from ../shared/benchmarks/README.md.

    python benchmarks/explicit.py [--threads 1 2] [--repeat 3] [--decks cube40_lps cube40_lps_damage]
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

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "benchmarks"
PERIDIGM = {"cube40_lps": (75.4, 36.3, 344), "cube40_lps_damage": (109.5, None, 344)}  # s serial, s 2 ranks, MiB
BONDS = 7_153_608
POINTS = 64_000
STEPS = 400


def run(deck: str, threads: int, folder: Path) -> tuple[float, float]:
    """(wall seconds, peak MiB) of one `peridyn run` in a fresh process."""
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), PERIDYN_NO_PROGRESS="1")
    cmd = ["/usr/bin/time", "-f", "%M", sys.executable, "-m", "peridyn", "run", f"{deck}.yaml", "-q"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=folder, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    peak_kib = int(re.findall(r"^(\d+)$", proc.stderr, re.M)[-1])
    return wall, peak_kib / 1024


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--decks", nargs="+", default=list(PERIDIGM))
    a = ap.parse_args()
    if not SHARED.is_dir():
        raise SystemExit(f"{SHARED} not found")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for f in SHARED.glob("cube40*"):
            shutil.copy(f, folder / f.name)
        run(a.decks[0], 1, folder)  # warm the numba cache so no run pays for compilation
        print(f"{'deck':20s} {'threads':>7s} {'wall s':>8s} {'M bond/s':>9s} {'M pt-step/s':>11s} {'peak MiB':>9s}   Peridigm 1 process")
        for deck in a.decks:
            for threads in a.threads:
                runs = [run(deck, threads, folder) for _ in range(a.repeat)]
                wall = statistics.median(w for w, _ in runs)
                peak = max(m for _, m in runs)
                ref = PERIDIGM[deck]
                print(
                    f"{deck:20s} {threads:7d} {wall:8.1f} {BONDS * STEPS / wall / 1e6:9.1f} {POINTS * STEPS / wall / 1e6:11.2f} {peak:9.0f}"
                    f"   {ref[0]:.1f} s ({ref[0] / wall:.2f}x), {ref[2]} MiB"
                )


if __name__ == "__main__":
    main()
