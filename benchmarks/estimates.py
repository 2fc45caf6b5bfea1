"""How good is ``peridyn check``'s wall-time estimate? For each deck: the estimate of every solver
section (``peridyn check``) against the time the section's loop took (``peridyn run``, the
"SECTION (METHOD): N steps in T s" line), one thread, each in a fresh process.

    python benchmarks/estimates.py [--shared ../shared] [--skip-long]

Decks: every YAML example, and from ../shared the benchmark decks with implicit solvers (the
tensile test, the quasi-static LPS bar) and the reference cases with implicit solvers. Prints a
Markdown table (estimate, measured, measured / estimate) and the spread of the ratio per kind of
solver.
"""
from __future__ import annotations

import argparse
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
IMPLICIT = ("QuasiStatic", "NOXQuasiStatic", "Implicit")


def seconds(text: str) -> float:
    value, unit = text.split()
    return float(value) * {"s": 1.0, "min": 60.0, "h": 3600.0, "days": 86400.0}[unit]


def measure(deck: Path, folder: Path) -> list[tuple[str, str, float, float]]:
    """(section, method, estimate s, measured s) of each solver section of ``deck``."""
    env = dict(os.environ, NUMBA_NUM_THREADS="1", PERIDYN_NO_PROGRESS="1")
    check = subprocess.run([sys.executable, "-m", "peridyn", "check", deck.name], cwd=folder, env=env, capture_output=True, text=True)
    estimates = {m.group(1): (m.group(2), seconds(m.group(3)))
                 for m in re.finditer(r"solver (\S+): (\w+), \d+ steps, estimated ([\d.e+-]+ \w+) on one core", check.stdout)}
    run = subprocess.run([sys.executable, "-m", "peridyn", "run", deck.name, "--no-progress"], cwd=folder, env=env, capture_output=True, text=True)
    measured = {m.group(1): float(m.group(3)) for m in re.finditer(r"^(\S+) \((\w+)\): \d+ steps in ([\d.]+) s", run.stderr, re.M)}
    return [(section, method, est, measured[section]) for section, (method, est) in estimates.items() if section in measured]


def decks(shared: Path | None, skip_long: bool) -> list[Path]:
    out = sorted((ROOT / "examples").glob("*.yaml"))
    if shared is not None and shared.is_dir():
        out += [shared / "benchmarks" / "bar_qs_lps.yaml"]
        if not skip_long:
            out += [shared / "benchmarks" / "tensile_test" / "tensile_test.yaml"]
        for case in sorted((shared / "conformance" / "cases").glob("*/*")):
            if case.suffix in (".yaml", ".xml") and any(f"<ParameterList name=\"{m}\"" in case.read_text() or f"{m}:" in case.read_text()
                                                          for m in IMPLICIT):
                out.append(case)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--shared", default=str(ROOT.parent / "shared"))
    ap.add_argument("--skip-long", action="store_true", help="leave out the tensile test (about a minute)")
    ap.add_argument("--implicit-only", action="store_true", help="only the decks with an implicit solver")
    a = ap.parse_args()
    rows = []
    for deck in decks(Path(a.shared), a.skip_long):
        if a.implicit_only and not any(m in deck.read_text() for m in IMPLICIT):
            continue
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp) / "case"
            shutil.copytree(deck.parent, folder)
            for section, method, est, meas in measure(folder / deck.name, folder):
                rows.append((deck.name, section, method, est, meas))
                print(f"| {deck.name} | {section} | {method} | {est:.3g} | {meas:.3g} | {meas / est:.2f} |", flush=True)
    print()
    for kind, methods in (("explicit", ("Verlet",)), ("implicit", IMPLICIT)):
        ratios = [m / e for _, _, method, e, m in rows if method in methods and e > 0 and m >= 0.5]
        if ratios:
            logs = [math.log10(r) for r in ratios]
            print(f"{kind}: {len(ratios)} sections of 0.5 s or more, measured/estimate from {min(ratios):.2f} to {max(ratios):.2f}, "
                  f"geometric mean {10 ** (sum(logs) / len(logs)):.2f}")


if __name__ == "__main__":
    main()
