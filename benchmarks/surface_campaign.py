"""Issue #33's campaign of mutated inputs over the new surface, with counts per family and class.

    python benchmarks/surface_campaign.py --cases 2000 --seed 1          # writes benchmarks/results/surface_campaign.md
    python benchmarks/surface_campaign.py --cases 200 --families api cli --keep /tmp/bad

Families: meshes (.msh/.inp/.vtu/.vtk made by gmsh and meshio, then cut, flipped, replaced),
.geo scripts, regions (node sets by geometry), Surface Traction, restart files, stress-law
modules, the Python API's arguments, every command's arguments and paths, and a sample on 2
MPI ranks. Each case runs in a child forked from this warm process (kernels compiled once),
the 2-rank ones under ``mpiexec -n 2``; the classes are tests/robustness/runner.py's plus
``exit3_bad`` (a legal run stopped as unstable) and ``api_bad_exception`` (an API refusal that
is not an InputError/ValueError/TypeError/KeyError naming the argument). The implementation is
the package ``benchmarks/surface_campaign/``.
"""
from __future__ import annotations

import argparse
import json
import re
import sys
import time
from collections import Counter, defaultdict
from pathlib import Path

import os

# before numba is imported: the cases run in children forked from this process, and GNU OpenMP refuses to fork
os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")
os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("PERIDYN_NO_PROGRESS", "1")

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import surface_campaign as sc  # noqa: E402  (the package beside this file)


def normalize(text: str) -> str:
    text = re.sub(r"'[^']*'|\"[^\"]*\"", "'…'", text)
    text = re.sub(r"(?:/[\w.+\-]+)+", "PATH", text)
    text = re.sub(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?", "N", text)
    return text[:140]


def table(results, setup_s: float, run_s: float, args) -> str:
    fams = list(dict.fromkeys(c.family for c, _ in sorted(results, key=lambda r: list(sc.GENERATORS).index(r[0].family))))
    counts = Counter((c.family, o.klass) for c, o in results)
    classes = [k for k in sc.ALL_CLASSES if any(counts[(f, k)] for f in fams)]
    bad_total = sum(1 for _, o in results if o.klass in sc.BAD_CLASSES)
    lines = [f"# Surface campaign (issue #33)", "",
             f"`python benchmarks/surface_campaign.py --cases {args.cases} --seed {args.seed} --jobs {args.jobs}`: "
             f"{len(results)} cases, {bad_total} bad; set-up {setup_s:.0f} s (fixtures, kernels compiled once), "
             f"cases {run_s:.0f} s wall on {args.jobs} jobs ({run_s / max(len(results), 1):.2f} s a case).", "",
             "Classes: bad ones are " + ", ".join(f"`{k}`" for k in sc.BAD_CLASSES) + "; clean ones `exit0`, `exit2_clean` "
             "(one line naming the file and the deck path), `exit3` (stopped as unstable where the input allows it), `exit130`.", "",
             "| family | cases | " + " | ".join(classes) + " |", "|---|---:|" + "---:|" * len(classes)]
    for f in fams:
        n = sum(counts[(f, k)] for k in sc.ALL_CLASSES)
        lines.append(f"| {f} | {n} | " + " | ".join(str(counts[(f, k)] or "") for k in classes) + " |")
    lines.append(f"| **all** | {len(results)} | " + " | ".join(str(sum(counts[(f, k)] for f in fams) or "") for k in classes) + " |")
    groups = defaultdict(list)
    for c, o in results:
        if o.klass in sc.BAD_CLASSES:
            groups[(o.klass, c.family, normalize(o.line))].append((c, o))
    lines += ["", "## Bad outcomes by cause", ""]
    if not groups:
        lines.append("None.")
    for (k, f, _), items in sorted(groups.items(), key=lambda g: (-len(g[1]), g[0])):
        c, o = items[0]
        lines.append(f"* **{k}** ({f}, {len(items)}x): `{c.name[:160]}` -> rc={o.rc}: `{o.line[:300]}` flags: {', '.join(o.flags)[:200]}")
    return "\n".join(lines) + "\n"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", type=int, default=2000)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--families", nargs="+", choices=list(sc.GENERATORS))
    p.add_argument("--keep", type=Path, help="copy the folder of every bad case here")
    p.add_argument("--out", type=Path, default=HERE / "results" / "surface_campaign.md")
    p.add_argument("--json", type=Path, help="every case's outcome as JSON")
    args = p.parse_args()
    if args.keep:
        args.keep.mkdir(parents=True, exist_ok=True)
    t = time.perf_counter()
    results, setup_s, run_s = sc.campaign(args.cases, args.seed, args.jobs, args.families, args.keep, progress=True)
    if args.json:  # first: json escapes every name (case names may hold non-UTF-8 file names)
        args.json.write_text(json.dumps([{"family": c.family, "case": c.name, "expect": c.expect, "class": o.klass, "rc": o.rc,
                                          "seconds": o.seconds, "flags": o.flags, "line": o.line} for c, o in results], indent=1))
    text = table(results, setup_s, run_s, args).encode("utf-8", "backslashreplace").decode("utf-8")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")
    print(text)
    print(f"total {time.perf_counter() - t:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
