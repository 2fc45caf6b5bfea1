"""Neighbor-search benchmark (run on demand, not a test).

Cubes of m^3 points (m = 20, 40, 60, 80), spacing 1, horizon 3.015 spacings, spherical search
(:func:`peridyn.geometry.neighbors.radius_search`, int32 neighbors). For each size it prints: points,
bonds, build time (best of 3 after a warm-up compile), bytes per bond of the NeighborList with
its reverse index, peak RSS growth of the build + reverse, and the times of ``reverse()``,
``transpose()`` (for a one-sided list the general path; here the lists are symmetric) and
``space_filling_order``.

Each size runs in its own process so its peak RSS is its own.

    python benchmarks/neighbors.py            # all sizes
    python benchmarks/neighbors.py --sizes 80 # one size
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import numpy as np

HORIZON = 3.015


def lattice(m: int) -> np.ndarray:
    g = np.arange(m, dtype=np.float64)
    return np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)


def peak_rss_bytes() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: KiB


def best_of(f, reps: int = 3) -> tuple[float, object]:
    best = float("inf")
    out = None
    for _ in range(reps):
        out = None
        t = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t)
    return best, out


def run_one(m: int) -> dict:
    from peridyn.core.bonds import NeighborList
    from peridyn.geometry.neighbors import radius_search, space_filling_order

    # warm-up: compile (or load from cache) every kernel on a small cube
    xw = lattice(6)
    ow, nw = radius_search(xw, HORIZON, dtype=np.int32)
    NeighborList(ow, nw).reverse()
    NeighborList(ow, nw).transpose()
    space_filling_order(xw)

    x = lattice(m)
    base = peak_rss_bytes()
    t0 = time.perf_counter()
    offsets, neighbors = radius_search(x, HORIZON, dtype=np.int32)
    first = time.perf_counter() - t0
    nl = NeighborList(offsets, neighbors)
    t0 = time.perf_counter()
    nl.reverse()
    t_reverse_first = time.perf_counter() - t0
    peak_growth = peak_rss_bytes() - base
    bytes_per_bond = nl.nbytes() / max(nl.num_bonds, 1)
    num_bonds = nl.num_bonds
    del nl

    t_build, res = best_of(lambda: radius_search(x, HORIZON, dtype=np.int32))
    t_build = min(t_build, first)
    offsets, neighbors = res
    del res
    t_reverse, _ = best_of(lambda: NeighborList(offsets, neighbors).reverse())
    t_reverse = min(t_reverse, t_reverse_first)
    t_transpose, _ = best_of(lambda: NeighborList(offsets, neighbors).transpose())
    t_sfc, _ = best_of(lambda: space_filling_order(x))
    return {
        "m": m,
        "points": int(x.shape[0]),
        "bonds": int(num_bonds),
        "build_s": t_build,
        "bytes_per_bond": bytes_per_bond,
        "peak_rss_growth_MB": peak_growth / 2**20,
        "reverse_s": t_reverse,
        "transpose_s": t_transpose,
        "space_filling_order_s": t_sfc,
    }


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[20, 40, 60, 80])
    ap.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one is not None:
        print(json.dumps(run_one(args.one)))
        return
    import numba

    print(f"numba threads: {numba.get_num_threads()}, horizon {HORIZON} spacings, int32 neighbors")
    header = (f"{'points':>8} {'bonds':>11} {'build s':>8} {'B/bond':>7} {'peak RSS MB':>12} "
              f"{'reverse s':>10} {'transpose s':>12} {'sfc order s':>12}")
    print(header)
    for m in args.sizes:
        out = subprocess.run([sys.executable, __file__, "--one", str(m)], check=True, capture_output=True, text=True)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"{r['points']:>8} {r['bonds']:>11} {r['build_s']:>8.3f} {r['bytes_per_bond']:>7.2f} "
              f"{r['peak_rss_growth_MB']:>12.1f} {r['reverse_s']:>10.3f} {r['transpose_s']:>12.3f} "
              f"{r['space_filling_order_s']:>12.3f}")


if __name__ == "__main__":
    main()
