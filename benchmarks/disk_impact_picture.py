"""Picture of examples/disk_impact.yaml (run on demand, not a test): the damage of the disk at
the last output frame, seen from above, written to docs/images/disk_impact_damage.png.

Every disk point is drawn as a square of one point spacing at its deformed position (x + u,
y + u), coloured by Damage (0: all bonds intact, 1: all broken); points are drawn from the
lowest to the highest, so the picture shows the top of the disk. The ball is not drawn.

Without ``--results`` the full example is run first, in a temporary folder (one
``peridyn run`` process; its wall time and peak memory are printed). matplotlib draws the
picture when it is installed; otherwise (or with ``--raw``) a small numpy rasteriser and a
zlib/struct PNG writer do, without a colour bar.

    python benchmarks/disk_impact_picture.py                        # run the example, draw
    python benchmarks/disk_impact_picture.py --results /path/to/run # draw from disk_impact.e there
"""
from __future__ import annotations

import argparse
import resource
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import zlib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DECK = ROOT / "examples" / "disk_impact.yaml"
PICTURE = ROOT / "docs" / "images" / "disk_impact_damage.png"
SPACING = 0.0005  #: m, the disk's Spacing in the example
DISK_RADIUS = 0.037  #: m


def run_example(folder: Path) -> None:
    """Run the example deck in ``folder``; print its wall time and peak memory."""
    shutil.copy(DECK, folder / DECK.name)
    t0 = time.perf_counter()
    argv = [sys.executable, "-m", "peridyn", "run", DECK.name, "--no-progress"]
    proc = subprocess.run(argv, cwd=folder, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    sys.stdout.write(proc.stderr)
    sys.stdout.write(proc.stdout)
    if proc.returncode != 0:
        raise SystemExit(f"peridyn run failed with exit code {proc.returncode}")
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    print(f"example: {wall:.1f} s wall, peak memory {peak:.0f} MiB")


def final_disk(results: Path) -> tuple[np.ndarray, np.ndarray, float]:
    """(deformed positions (n, 3) in m, damage (n,), time in s) of the disk at the last frame."""
    from peridyn.io.exodus_reader import read_results

    r = read_results(results)
    disk = r["node_sets"]["DISK"]
    k = len(r["times"]) - 1
    u = np.stack([r["nodal"][f"Displacement{c}"][k] for c in "XYZ"], axis=1)
    y = r["coords"][disk] + u[disk]
    damage = np.asarray(r["element"]["Damage"][k])[disk]
    return y, damage, float(r["times"][k])


def draw_matplotlib(y: np.ndarray, damage: np.ndarray, t: float, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    order = np.argsort(y[:, 2], kind="stable")  # lowest first: the top layer ends on top
    half = 1.05 * DISK_RADIUS * 1e3
    fig, ax = plt.subplots(figsize=(6.4, 5.6), dpi=200)
    ax.set_xlim(-half, half)
    ax.set_ylim(-half, half)
    ax.set_aspect("equal")
    fig.canvas.draw()
    # a marker side of one spacing, in points
    bbox = ax.get_window_extent()
    side = SPACING * 1e3 * bbox.width / (2 * half) * 72.0 / fig.dpi
    sc = ax.scatter(y[order, 0] * 1e3, y[order, 1] * 1e3, c=damage[order], s=side * side, marker="s", linewidths=0,
                    cmap="viridis", vmin=0.0, vmax=1.0, rasterized=True)
    fig.colorbar(sc, ax=ax, label="Damage", shrink=0.85)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"Disk impact: damage of the disk at t = {t * 1e6:.0f} µs, seen from above", fontsize=9)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)


#: viridis at 0, 0.25, 0.5, 0.75, 1 (RGB 0-255)
_VIRIDIS = np.array([[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]], dtype=float)


def _colour(values: np.ndarray) -> np.ndarray:
    v = np.clip(values, 0.0, 1.0) * (len(_VIRIDIS) - 1)
    i = np.minimum(v.astype(int), len(_VIRIDIS) - 2)
    f = (v - i)[:, None]
    return ((1 - f) * _VIRIDIS[i] + f * _VIRIDIS[i + 1]).round().astype(np.uint8)


def write_png(path: Path, rgb: np.ndarray) -> None:
    """An 8-bit RGB PNG of the (h, w, 3) uint8 array (zlib + struct, no other dependency)."""
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[row].tobytes() for row in range(h))  # filter type 0 per row

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    path.write_bytes(png)


def draw_raw(y: np.ndarray, damage: np.ndarray, out: Path, pixels: int = 1000) -> None:
    """Each point a square of one spacing on a white (pixels x pixels) image, lowest first."""
    half = 1.05 * DISK_RADIUS
    scale = pixels / (2 * half)
    side = max(1, int(np.ceil(SPACING * scale)))  # no seams between neighbouring points
    img = np.full((pixels, pixels, 3), 255, dtype=np.uint8)
    order = np.argsort(y[:, 2], kind="stable")
    col = np.clip(((y[order, 0] + half) * scale).astype(int) - side // 2, 0, pixels - side)
    row = np.clip(((half - y[order, 1]) * scale).astype(int) - side // 2, 0, pixels - side)  # y up
    rgb = _colour(damage[order])
    for dr in range(side):
        for dc in range(side):
            img[row + dr, col + dc] = rgb  # later (higher) points overwrite earlier ones
    write_png(out, img)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--results", type=Path, help="folder holding disk_impact.e of a finished run (default: run the example)")
    ap.add_argument("--out", type=Path, default=PICTURE, help=f"the PNG to write (default {PICTURE.relative_to(ROOT)})")
    ap.add_argument("--raw", action="store_true", help="draw with the numpy rasteriser even if matplotlib is installed")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.results
        if folder is None:
            folder = Path(tmp)
            run_example(folder)
        y, damage, t = final_disk(folder / "disk_impact.e")
    print(f"t = {t:.4g} s: {damage.size} disk points, {np.mean(damage > 0.5):.1%} with damage above 0.5, largest {damage.max():.3f}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    try:
        if args.raw:
            raise ImportError
        draw_matplotlib(y, damage, t, args.out)
    except ImportError:
        draw_raw(y, damage, args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
