"""peridyn and Peridigm side by side on one machine (run on demand, not a test).

Runs each deck with Peridigm (an executable built by ../shared/tools/build-peridigm.sh) and with
``peridyn run`` alternately, ``--repeat`` times each, one core each (peridyn with
NUMBA_NUM_THREADS=1), every run a fresh process in its own folder, and prints the medians of
whole-run wall time and peak memory (``/usr/bin/time``) and their ratio. Only ratios measured
in one run hold: these machines drift.

    python benchmarks/side_by_side.py --peridigm /path/to/Peridigm [--repeat 3] DECK [DECK ...]

A deck's folder is copied whole (node-set and mesh files with it). With ``--peridyn-only`` the
Peridigm runs are skipped (peridyn against itself at two commits: set PYTHONPATH).
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
from pathlib import Path


def timed(cmd: list[str], folder: Path, env: dict[str, str]) -> tuple[float, float]:
    """(wall s, peak MiB) of one command, from /usr/bin/time -v."""
    proc = subprocess.run(["/usr/bin/time", "-v", *cmd], cwd=folder, env=env, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed in {folder}:\n{proc.stderr[-2000:]}")
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", proc.stderr).group(1)
    parts = [float(p) for p in wall.split(":")]
    seconds = parts[-1] + 60 * parts[-2] + (3600 * parts[-3] if len(parts) > 2 else 0)
    peak = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr).group(1)) / 1024
    return seconds, peak


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("decks", nargs="+")
    ap.add_argument("--peridigm", help="the Peridigm executable")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--peridyn-only", action="store_true")
    args = ap.parse_args()
    env1 = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
    rows = []
    for deck in args.decks:
        deck = Path(deck).resolve()
        with tempfile.TemporaryDirectory() as tmp:
            work = Path(tmp)
            for tool in ("peridyn", "peridigm"):
                shutil.copytree(deck.parent, work / tool)
            times: dict[str, list[tuple[float, float]]] = {"peridyn": [], "peridigm": []}
            for _ in range(args.repeat):
                if not args.peridyn_only:
                    times["peridigm"].append(timed([args.peridigm, deck.name], work / "peridigm", env1))
                times["peridyn"].append(timed([sys.executable, "-m", "peridyn", "run", deck.name, "-q", "--no-progress"], work / "peridyn", env1))
                print(deck.name, {k: v[-1] for k, v in times.items() if v}, flush=True)
        med = {k: (statistics.median(t for t, _ in v), statistics.median(m for _, m in v)) for k, v in times.items() if v}
        rows.append((deck.name, med))
    print("\n| deck | Peridigm | peridyn | ratio | peak memory Peridigm / peridyn |\n|---|---|---|---|---|")
    for name, med in rows:
        pd = med["peridyn"]
        if "peridigm" in med:
            pg = med["peridigm"]
            print(f"| {name} | {pg[0]:.1f} s | {pd[0]:.1f} s | {pg[0] / pd[0]:.2f}x | {pg[1]:.0f} / {pd[1]:.0f} MiB |")
        else:
            print(f"| {name} | - | {pd[0]:.1f} s | - | - / {pd[1]:.0f} MiB |")


if __name__ == "__main__":
    main()
