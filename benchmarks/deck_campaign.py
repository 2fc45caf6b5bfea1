"""A long deck-mutation campaign on demand: counts outcome classes and lists reproducers.

    python benchmarks/deck_campaign.py --cases 3000 --seed 1 --jobs 2
    python benchmarks/deck_campaign.py --cases 500 --run-fraction 0.2 --save-reproducers /tmp/repro

Mutations of every example and conformance deck (see tests/robustness/mutations.py) are drawn
with hypothesis (generation only, seeded), executed with ``peridyn check`` (in-process, warm) or
``peridyn run`` (subprocess, on a shrunk deck), and classified (tests/robustness/runner.py). The
table counts each class; each non-clean class is grouped by root cause (class, mutation kind,
normalized error text) with one reproducer and its stderr tail. ``--json`` saves everything.
The report also gives the throughput (decks per minute of case time, for ``check`` and ``run``),
the share of ``run`` cases that actually ran, and how many cases reached each model family.
The unmutated decks' calibration (``check`` of each) is cached in ``--calibration-cache`` while
peridyn's sources are unchanged, so a campaign's set-up is seconds after the first.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import re
import sys
import time
from collections import Counter, defaultdict
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests" / "robustness"))

from hypothesis import HealthCheck, Phase, given, settings  # noqa: E402
from hypothesis import seed as hseed  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from mutations import FAMILIES, family_of_case, find_decks  # noqa: E402
from cases import Case, cases, keep_reproducer  # noqa: E402
import runner  # noqa: E402
from runner import BAD_CLASSES, Outcome, calibrate, debug_traceback, run_case  # noqa: E402


def generate(decks, n: int, command: str, seed: int) -> list[Case]:
    """``n`` distinct cases for ``command``, drawn by hypothesis with ``seed``."""
    out: list[Case] = []
    seen: set[str] = set()
    if n <= 0:
        return out

    @hseed(seed)
    @settings(max_examples=int(n * 1.4) + 10, phases=[Phase.generate], database=None, deadline=None,
              suppress_health_check=list(HealthCheck))
    @given(st.data())
    def collect(data) -> None:
        case = data.draw(cases(decks, command))  # drawn more than n times to make up for duplicates
        key = case.describe()
        if key not in seen and len(out) < n:
            seen.add(key)
            out.append(case)

    collect()
    return out[:n]


def _code_stamp() -> str:
    """A stamp of peridyn's sources (names and modification times): calibrations are reused
    only while the code is unchanged."""
    root = HERE.parent / "peridyn"
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(f"{path.relative_to(root)}:{path.stat().st_mtime_ns}".encode())
    return h.hexdigest()[:16]


def calibrate_all(decks, cache: Path | None) -> int:
    """``calibrate`` every deck (``check`` unmutated: baseline exit code and stable time step),
    reusing ``cache`` entries of the same deck text and peridyn sources. Returns the number reused."""
    stamp = _code_stamp()
    known = {}
    if cache is not None and cache.is_file():
        try:
            known = json.loads(cache.read_text())
        except (OSError, ValueError):
            known = {}
    reused = 0
    for d in decks:
        key = f"{d.name}|{hashlib.sha256(d.path.read_bytes()).hexdigest()[:16]}|{stamp}"
        if key in known:
            d.baseline, d.dt_hint = known[key]
            reused += 1
        else:
            calibrate(d)
            known[key] = [d.baseline, d.dt_hint]
    if cache is not None:
        try:
            cache.write_text(json.dumps(known))
        except OSError:
            pass
    return reused


def normalize(text: str) -> str:
    """Error text with file names, quoted values and numbers replaced, to group by cause."""
    text = re.sub(r"^error(?: on rank \d+ of \d+)?: ", "", text.strip())
    text = re.sub(r"^internal error: ", "", text)
    text = re.sub(r"^[^:]*\.(?:yaml|xml)(?::\d+)?: ", "", text)
    text = re.sub(r"'[^']*'|\"[^\"]*\"", "'…'", text)
    text = re.sub(r"(?:/[\w.+\-]+)+", "PATH", text)
    text = re.sub(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?", "N", text)
    return text[:150]


def group_key(case: Case, outcome: Outcome) -> str:
    """Root-cause key of a non-clean outcome."""
    flag = next((f for f in outcome.flags if f.startswith(outcome.klass)), outcome.klass)
    kind = case.mutation.kind
    if outcome.klass in ("exit1",):
        return f"exit1 | {case.command} | {kind} | {normalize(outcome.error_line)}"
    if outcome.klass == "exit2_messy":
        problems = re.sub(r"\(\d+\)", "", flag[len("exit2_messy"):])
        return f"exit2_messy {problems} | {kind} | {normalize(outcome.error_line)[:90]}"
    if outcome.klass == "exit0_bad":
        what = re.match(r"exit0_bad\((blow_up|empty_run)", flag)
        if what:  # by cause, not by file or number
            return f"exit0_bad {what.group(1)} | {case.command} | {kind} | {normalize(re.sub(r' in [^ ]+$', '', flag))[:90]}"
        return f"exit0_bad | {case.command} | {kind} | {normalize(flag)}"
    if outcome.klass == "refused_valid":
        return f"refused_valid | {case.command} | {normalize(outcome.error_line)[:110]}"
    if outcome.klass in ("hang", "nan_output", "lost_output", "code_exec"):
        tail = case.mutation.path[-1] if case.mutation.path else ""
        return f"{outcome.klass} | {case.command} | {kind} | {tail} | {normalize(flag)}"
    return outcome.klass


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", type=int, default=1000, help="number of cases (check + run)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--run-fraction", type=float, default=0.15, help="share of cases that run a shrunk deck")
    p.add_argument("--check-timeout", type=float, default=30.0)
    p.add_argument("--run-timeout", type=float, default=60.0)
    p.add_argument("--run-subprocess", action="store_true",
                   help="every run case in a fresh subprocess (default: in the warm worker, non-clean ones confirmed in a subprocess)")
    p.add_argument("--decks", default="", help="only decks whose name contains this text")
    p.add_argument("--no-conformance", action="store_true", help="example decks only")
    p.add_argument("--max-line", type=int, default=runner.MAX_LINE, help="longest clean error line (chars)")
    p.add_argument("--examples", type=int, default=3, help="reproducers shown per group")
    p.add_argument("--save-reproducers", type=Path, help="folder for one reproducer deck per group")
    p.add_argument("--json", type=Path, default=Path("/tmp/campaign_results.json"), help="full results")
    p.add_argument("--calibration-cache", type=Path, default=Path("/tmp/peridyn_campaign_calibration.json"),
                   help="reuse the unmutated decks' check results while peridyn's sources are unchanged ('' = off)")
    args = p.parse_args(argv)
    runner.MAX_LINE = args.max_line

    t0 = time.perf_counter()
    decks = [d for d in find_decks(not args.no_conformance) if args.decks in d.name]
    if not decks:
        print("no decks found", file=sys.stderr)
        return 2
    reused = calibrate_all(decks, args.calibration_cache if str(args.calibration_cache) not in ("", ".") else None)
    t_cal = time.perf_counter() - t0
    n_run = int(round(args.cases * args.run_fraction))
    todo = generate(decks, args.cases - n_run, "check", args.seed) + generate(decks, n_run, "run", args.seed + 1)
    print(f"{len(decks)} decks ({sum(d.baseline == 0 for d in decks)} pass check unmutated), {len(todo)} cases "
          f"({sum(c.command == 'run' for c in todo)} run), set-up {time.perf_counter() - t0:.1f} s "
          f"(calibration {t_cal:.1f} s, {reused} reused)", flush=True)

    results: list[tuple[Case, Outcome]] = []

    walls: dict[int, float] = {}

    def one(case: Case) -> tuple[Case, Outcome]:
        t = time.perf_counter()
        try:
            return case, run_case(case, check_timeout=args.check_timeout, run_timeout=args.run_timeout,
                                  run_in_process=not args.run_subprocess)
        except Exception as exc:  # a harness bug must not end the campaign
            return case, Outcome("harness_error", None, 0.0, notes=[f"{type(exc).__name__}: {exc}"])
        finally:
            walls[id(case)] = time.perf_counter() - t

    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = [pool.submit(one, c) for c in todo]
        for i, fut in enumerate(as_completed(futures), 1):
            results.append(fut.result())
            if i % 50 == 0 or i == len(todo):
                counts = Counter(o.klass for _, o in results)
                print(f"  {i}/{len(todo)} in {time.perf_counter() - t0:.0f} s: {dict(sorted(counts.items()))}", flush=True)

    report(results, args, time.perf_counter() - t0, walls)
    return 0


def report(results: list[tuple[Case, Outcome]], args, wall: float, walls: dict[int, float] | None = None) -> None:
    """Print the table, throughput, family coverage and the grouped reproducers; save the JSON."""
    walls = walls or {}
    counts = Counter(o.klass for _, o in results)
    by_cmd = {cmd: Counter(o.klass for c, o in results if c.command == cmd) for cmd in ("check", "run")}
    print(f"\n{'class':<14}{'total':>7}{'check':>7}{'run':>7}")
    for klass in sorted(counts, key=lambda k: (k not in BAD_CLASSES, k)):
        print(f"{klass:<14}{counts[klass]:>7}{by_cmd['check'][klass]:>7}{by_cmd['run'][klass]:>7}")
    throughput = {}
    for cmd in ("check", "run"):
        secs = sum(walls.get(id(c), o.seconds) for c, o in results if c.command == cmd)
        n = sum(c.command == cmd for c, _ in results)
        if n:
            throughput[cmd] = {"cases": n, "seconds": round(secs, 1), "per_minute": round(60.0 * n / max(secs, 1e-9), 1)}
            print(f"{cmd}: {n} decks in {secs:.0f} s of case time = {throughput[cmd]['per_minute']:.0f} decks/minute "
                  f"(jobs {args.jobs})")
    runs = [o for c, o in results if c.command == "run"]
    if runs:
        healthy = sum(o.klass in ("exit0", "exit3") or (o.klass == "exit0_bad" and o.rc == 0) for o in runs)
        print(f"run cases that ran (exit 0 or 3): {healthy}/{len(runs)} = {100.0 * healthy / len(runs):.0f}%")
    fams = Counter()
    fam_bad = Counter()
    for c, o in results:
        fam = family_of_case(c.deck.tree, c.mutation) or "(other)"
        fams[fam] += 1
        fam_bad[fam] += o.bad
    print("\nfamily coverage (cases whose mutation reached the family; non-clean in brackets):")
    print("  " + ", ".join(f"{f} {fams[f]} [{fam_bad[f]}]" for f in (*FAMILIES, "(other)")))
    groups: dict[str, list[tuple[Case, Outcome]]] = defaultdict(list)
    for case, outcome in results:
        if outcome.bad:
            groups[group_key(case, outcome)].append((case, outcome))
    ordered = sorted(groups.items(), key=lambda kv: (BAD_CLASSES.index(kv[1][0][1].klass), -len(kv[1])))
    print(f"\n{len(ordered)} distinct root causes among {sum(len(v) for v in groups.values())} non-clean outcomes")
    saved, traces = {}, {}
    for gi, (key, members) in enumerate(ordered, 1):
        print(f"\n[{gi}] {key}  (x{len(members)})")
        if members[0][1].klass == "exit1":
            first = min(members, key=lambda m: len(m[0].describe()))[0]
            try:
                traces[key] = debug_traceback(first)
            except Exception as exc:  # the report matters more than the traceback
                traces[key] = f"(no traceback: {type(exc).__name__}: {exc})"
            print(f"    traceback (--debug): {traces[key][:600]}")
        for case, outcome in sorted(members, key=lambda m: len(m[0].describe()))[: args.examples]:
            tail = " | ".join(outcome.stderr.strip().splitlines()[-2:])[-300:]
            print(f"    {case.describe()[:300]}")
            print(f"      flags: {'; '.join(outcome.flags)[:300]}")
            print(f"      stderr: {tail}")
        if args.save_reproducers:
            folder = args.save_reproducers / f"{gi:03d}-{members[0][1].klass}"
            keep_reproducer(min(members, key=lambda m: len(m[0].describe()))[0], folder)
            saved[key] = str(folder)
    data = {
        "meta": {"cases": len(results), "seed": args.seed, "jobs": args.jobs, "wall_seconds": round(wall, 1),
                 "max_line": args.max_line,
                 "run_fraction": args.run_fraction, "check_timeout": args.check_timeout, "run_timeout": args.run_timeout},
        "counts": dict(counts),
        "counts_by_command": {k: dict(v) for k, v in by_cmd.items()},
        "throughput": throughput,
        "families": dict(fams),
        "groups": [{"key": k, "count": len(m), "class": m[0][1].klass, "reproducer_folder": saved.get(k), "traceback": traces.get(k),
                    "examples": [_case_json(c, o) for c, o in sorted(m, key=lambda x: len(x[0].describe()))[:5]]}
                   for k, m in ordered],
        "cases": [_case_json(c, o) for c, o in results],
    }
    args.json.write_text(json.dumps(data, indent=1, default=str))
    print(f"\nwrote {args.json} ({len(results)} cases, {wall:.0f} s)")


def _case_json(case: Case, outcome: Outcome) -> dict:
    return {"description": case.describe(), "deck": case.deck.name, "command": case.command,
            "shrink": case.shrink.describe() if case.shrink else None, "mutation": case.mutation.to_json(),
            "outcome": outcome.to_json()}


if __name__ == "__main__":
    sys.exit(main())
