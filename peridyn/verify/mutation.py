"""Mutation testing of ``peridyn verify``: put one physics error into a copy of the package (a
textual substitution that must match), run the verify problems meant to measure it in a child
process on that copy, and read which checks fail.

The copy lives in its own folder with its own kernel caches (``PERIDYN_KERNEL_CACHE``,
``NUMBA_CACHE_DIR``), so no compiled kernel of the unchanged package is reused. The catalogue of
errors is :mod:`.mutations`; ``tests/verification/test_mutations.py`` runs part of it in CI and
``benchmarks/verify_mutations.py`` all of it (docs/verify.md)."""
from __future__ import annotations

import json
import logging
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

log = logging.getLogger("peridyn.verify.mutation")

#: the package's own folder (the one copied)
PACKAGE = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Substitution:
    """Replace ``old`` by ``new`` in the package file ``path`` (relative to the package folder,
    e.g. ``"materials/elastic.py"``), ``count`` times exactly (0: every occurrence, at least one)."""

    path: str
    old: str
    new: str
    count: int = 1


@dataclass(frozen=True)
class Mutation:
    """One physics error: its name, what it does, its substitutions, and the verify problems that
    must catch it (each run with ``--quick`` unless ``full``)."""

    name: str
    what: str
    substitutions: tuple[Substitution, ...]
    problems: tuple[str, ...]
    #: area of the package it belongs to (materials, damage, contact, solvers, time step)
    area: str = "materials"
    full: bool = False


@dataclass
class Outcome:
    """What a run of verify problems on a package (copy) gave: its exit status, the failed checks
    (problem, method, what, value, band), its wall time (s) and the problems run."""

    returncode: int
    failed: list[dict[str, Any]] = field(default_factory=list)
    wall: float = 0.0
    problems: tuple[str, ...] = ()
    log_tail: str = ""

    @property
    def caught_by(self) -> list[str]:
        """The problems with at least one failed check, in order."""
        return list(dict.fromkeys(c["problem"] for c in self.failed))


def apply(text: str, sub: Substitution) -> str:
    """``text`` with ``sub`` applied; ValueError when it does not match ``sub.count`` times (a
    mutation that no longer matches the source must not pass silently as "not caught")."""
    found = text.count(sub.old)
    if found == 0 or (sub.count and found != sub.count):
        raise ValueError(f"{sub.path}: {sub.old!r} occurs {found} times, expected {sub.count or 'at least 1'}")
    return text.replace(sub.old, sub.new)


def package_copy(root: Path, substitutions: Sequence[Substitution] = ()) -> Path:
    """Copy the package to ``root``/peridyn (no ``__pycache__``), apply ``substitutions``; ``root``
    (to put first on PYTHONPATH)."""
    root = Path(root)
    target = root / "peridyn"
    if target.exists():
        shutil.rmtree(target)
    shutil.copytree(PACKAGE, target, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    for sub in substitutions:
        path = target / sub.path
        path.write_text(apply(path.read_text(encoding="utf-8"), sub), encoding="utf-8")
    return root


def child_env(root: Path | None, cache: Path | None) -> dict[str, str]:
    """The environment of a child run: ``root`` first on PYTHONPATH (None: the installed package)
    and its own kernel caches under ``cache`` (None: the default caches)."""
    env = dict(os.environ)
    if root is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(root)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    if cache is not None:
        env["PERIDYN_KERNEL_CACHE"] = str(cache / "kernels")
        env["NUMBA_CACHE_DIR"] = str(cache / "numba")
    return env


def run_problems(problems: Sequence[str], out: Path, *, root: Path | None = None, cache: Path | None = None,
                 quick: bool = True, timeout: float = 1800.0) -> Outcome:
    """``python -m peridyn verify --problems ...`` in a child process (on the package under ``root``
    when given) into ``out``; its exit status and failed checks from ``results.json``. A child that
    fails to write results (a crash) returns its exit status and no checks."""
    out = Path(out)
    cmd = [sys.executable, "-m", "peridyn", "verify", "--problems", *problems, "--out", str(out), "-q"] + (["--quick"] if quick else [])
    t0 = time.perf_counter()
    p = subprocess.run(cmd, env=child_env(root, cache), cwd=str(out.parent), capture_output=True, text=True, timeout=timeout)
    wall = time.perf_counter() - t0
    failed: list[dict[str, Any]] = []
    results = out / "results.json"
    if results.exists():
        state = json.loads(results.read_text(encoding="utf-8"))
        failed = [{k: c[k] for k in ("problem", "method", "what", "value", "band")}
                  for e in state["problems"] for c in e["checks"] if not c["passed"] and not c.get("known")]
    tail = (p.stdout + p.stderr)[-2000:]
    log.debug("%s: rc %d in %.1f s, %d failed checks", " ".join(problems), p.returncode, wall, len(failed))
    return Outcome(p.returncode, failed, wall, tuple(problems), tail)


def run_mutation(mutation: Any, work: Path, problems: Sequence[str] | None = None, *, quick: bool | None = None) -> Outcome:
    """Put ``mutation`` into a copy of the package under ``work``/``mutation.name`` and run its
    problems (or ``problems``) on it, with caches of its own."""
    base = Path(work) / mutation.name
    base.mkdir(parents=True, exist_ok=True)
    root = package_copy(base / "src", mutation.substitutions)
    return run_problems(problems or mutation.problems, base / "out", root=root, cache=base / "cache",
                        quick=(not mutation.full) if quick is None else quick)
