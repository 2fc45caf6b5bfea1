"""The full mutation sweep of ``peridyn verify`` (peridyn.verify.mutations): each physics error put
into its own copy of the package (own kernel caches), the problems meant to measure it run on the
copy in a child process (``--quick``), and which of them catch it; the unchanged package run on the
union of those problems first. Writes benchmarks/results/verify_mutations.md and .json.

    python benchmarks/verify_mutations.py [--jobs 2] [--only NAME ...] [--work DIR]

A mutation is *caught* when the child exits 1 with at least one failed check of a problem; the
table names every problem that failed a check, and the first check of each. The run time of each
child includes compiling its kernels from cold (the copy shares no cache)."""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import logging
import os
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from peridyn.verify.mutation import Outcome, run_mutation, run_problems
from peridyn.verify.mutations import MUTATIONS, Mutation
from peridyn.verify.runner import machine, peridyn_version

log = logging.getLogger("verify_mutations")
RESULTS = Path(__file__).resolve().parent / "results"


def sweep(mutations: list[Mutation], work: Path, jobs: int) -> tuple[Outcome, list[tuple[Mutation, Outcome]]]:
    """The baseline (the unchanged package on the union of the problems, in place) and each
    mutation's outcome, ``jobs`` children at a time."""
    problems = list(dict.fromkeys(p for m in mutations for p in m.problems))
    (work / "baseline").mkdir(parents=True, exist_ok=True)
    base = run_problems(problems, work / "baseline" / "out", quick=True, cache=work / "baseline" / "cache")
    log.info("baseline: rc %d, %.0f s, failed %s", base.returncode, base.wall, base.caught_by or "none")

    def one(m: Mutation) -> tuple[Mutation, Outcome]:
        o = run_mutation(m, work)
        log.info("%s: rc %d, %.0f s, caught by %s", m.name, o.returncode, o.wall, ", ".join(o.caught_by) or "NOTHING")
        return m, o

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        return base, list(pool.map(one, mutations))


def markdown(base: Outcome, rows: list[tuple[Mutation, Outcome]], wall: float, jobs: int, note: str = "") -> str:
    """The results table (``note``: a line on what was swept, printed under the header)."""
    ver, mach = peridyn_version(), machine()
    out = [
        "# `peridyn verify` mutation sweep", "",
        f"{_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M} UTC, commit {ver['commit']}, {mach['cpu']} ({mach['usable cores']} "
        f"usable cores, load {os.getloadavg()[0]:.1f} at the end), {jobs} children at a time, {wall:.0f} s in all. Produced by "
        "`python benchmarks/verify_mutations.py`; the catalogue is `peridyn/verify/mutations.py`. Every problem runs with "
        "`--quick` in a child process on a copy of the package with one substitution, its kernels compiled cold.", "",
        *([note, ""] if note else []),
        f"**Unchanged package** on the union of the problems: exit {base.returncode}, {base.wall:.0f} s, "
        + (f"failed checks in {', '.join(base.caught_by)}" if base.failed else "every check passes") + ".", "",
        "| mutation | area | what | problems run | caught by | first failed check of each | exit | wall (s) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for m, o in rows:
        first = "; ".join(f"{c['problem']}: {c['method']}: {c['what']} = {c['value']!r:.12} (band {c['band']})"
                          for c in {c["problem"]: c for c in reversed(o.failed)}.values())
        caught = ", ".join(o.caught_by) or "**not caught**"
        out.append(f"| `{m.name}` | {m.area} | {m.what} | {', '.join(m.problems)} | {caught} | {first.replace('|', '/')} | "
                   f"{o.returncode} | {o.wall:.0f} |")
    missed = [m.name for m, o in rows if not o.failed]
    out += ["", f"{len(rows) - len(missed)} of {len(rows)} caught" + (f"; not caught: {', '.join(missed)}" if missed else "") + "."]
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2, help="children at a time (default 2)")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="these mutations only")
    ap.add_argument("--work", type=Path, help="folder for the copies (default: a temporary one)")
    ap.add_argument("--out", type=Path, default=RESULTS, help="folder for verify_mutations.md/.json")
    ap.add_argument("--note", default="", help="a line on what was swept, for the report")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    chosen = [m for m in MUTATIONS if not args.only or m.name in args.only]
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="peridyn-mutations-") as tmp:
        base, rows = sweep(chosen, args.work or Path(tmp), args.jobs)
    wall = time.perf_counter() - t0
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "verify_mutations.md").write_text(markdown(base, rows, wall, args.jobs, args.note), encoding="utf-8")
    data = {"wall (s)": wall, "commit": peridyn_version()["commit"],
            "baseline": {"returncode": base.returncode, "wall (s)": base.wall, "failed": base.failed},
            "mutations": [{"name": m.name, "area": m.area, "what": m.what, "problems": list(m.problems), "returncode": o.returncode,
                           "wall (s)": o.wall, "caught by": o.caught_by, "failed": o.failed} for m, o in rows]}
    (args.out / "verify_mutations.json").write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {args.out / 'verify_mutations.md'}")
    return 0 if base.returncode == 0 and all(o.failed for _, o in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
