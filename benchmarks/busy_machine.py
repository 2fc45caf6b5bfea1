"""Threads on a busy machine (run on demand, not a test).

Runs the quickstart with 1 and 2 numba threads under several threading set-ups, on a quiet
machine and with another process keeping one core busy, and prints the whole-run wall time
(min / median / max over ``--repeat`` runs). A laptop or a shared node is never quiet: two
threads must not be much slower than one whatever else runs.

    python benchmarks/busy_machine.py [--repeat 5] [--deck examples/quickstart.yaml]

Set-ups: numba's OpenMP layer with GNU OpenMP's default wait policy (threads spin at a barrier
before sleeping), the OpenMP layer with ``OMP_WAIT_POLICY=PASSIVE`` (threads sleep at once:
peridyn's default), and numba's own ``workqueue`` layer.
"""
from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SETUPS = {
    "1 thread": {"NUMBA_NUM_THREADS": "1"},
    "2 threads, omp, spin (GNU default)": {"NUMBA_NUM_THREADS": "2", "NUMBA_THREADING_LAYER": "omp", "OMP_WAIT_POLICY": "ACTIVE"},
    "2 threads, omp, passive": {"NUMBA_NUM_THREADS": "2", "NUMBA_THREADING_LAYER": "omp", "OMP_WAIT_POLICY": "PASSIVE"},
    "2 threads, workqueue": {"NUMBA_NUM_THREADS": "2", "NUMBA_THREADING_LAYER": "workqueue"},
    "2 threads, peridyn default": {"NUMBA_NUM_THREADS": "2"},
}


def busy_core() -> subprocess.Popen:
    """Another process that keeps one core busy."""
    return subprocess.Popen([sys.executable, "-c", "while True:\n    pass"])


def run_once(deck: Path, folder: Path, env_extra: dict[str, str]) -> float:
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_THREADING_LAYER", "OMP_WAIT_POLICY", "NUMBA_NUM_THREADS")}
    env.update(env_extra, PERIDYN_NO_PROGRESS="1")
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "peridyn", "run", deck.name, "-q", "--no-progress"], cwd=folder, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    return wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--deck", default=str(ROOT / "examples" / "quickstart.yaml"))
    args = ap.parse_args()
    src = Path(args.deck)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for f in src.parent.iterdir():
            if f.suffix in (".yaml", ".txt", ".g", ".e"):
                shutil.copy(f, folder / f.name)
        deck = folder / src.name
        run_once(deck, folder, SETUPS["1 thread"])  # compile and cache the kernels
        print(f"{src.name}: whole-run wall time, s (min / median / max of {args.repeat})")
        for condition in ("quiet", "one core busy"):
            hog = busy_core() if condition != "quiet" else None
            try:
                times = {name: [] for name in SETUPS}
                for _ in range(args.repeat):  # interleaved, so drift hits every set-up alike
                    for name, env in SETUPS.items():
                        times[name].append(run_once(deck, folder, env))
            finally:
                if hog is not None:
                    hog.kill()
                    hog.wait()
            print(f"\n{condition}:")
            for name, ts in times.items():
                print(f"  {name:38s} {min(ts):6.2f} / {statistics.median(ts):6.2f} / {max(ts):6.2f}")


if __name__ == "__main__":
    main()
