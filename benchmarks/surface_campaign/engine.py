"""Executing and judging the surface campaign's cases.

Each case runs in a child forked from this warm process (peridyn imported, kernels compiled
once), in its own temporary folder, stdout and stderr to files; ``peridyn.cli.main(argv)`` (or
an API call) and ``os._exit(rc)``. The parent waits with a deadline, kills the child's process
group on a hang and reads a signal death as ``exit1``. MPI cases run ``mpiexec -n 2`` in a
subprocess. Classes (worst first) extend tests/robustness/runner.py's.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "robustness"))
import runner  # noqa: E402  (stderr_problems, exodus_problems, run_exit0_problems)

BAD_CLASSES = ("hang", "exit1", "lost_output", "nan_output", "exit0_bad", "refused_valid", "exit3_bad",
               "api_bad_exception", "exit2_messy")
CLEAN_CLASSES = ("exit0", "exit2_clean", "exit3", "exit130")
ALL_CLASSES = BAD_CLASSES + CLEAN_CLASSES
MEMORY_LIMIT = 6 * 2**30
FILE_LIMIT = 256 * 2**20


@dataclass
class Spec:
    """What a case's set-up wrote and how it is executed."""

    argv: list[str] | None = None  #: peridyn command line (fork or mpi)
    fn: Callable[[Path], Any] | None = None  #: an API case: called in the child
    arg: str = ""  #: API: the argument a refusal must name
    names: set[str] = field(default_factory=set)  #: words an error line may name (files, flags)
    sentinels: list[Path] = field(default_factory=list)  #: earlier files an error must leave alone
    tree: dict | None = None  #: the deck, for runner.run_exit0_problems
    passthrough: tuple = ()  #: API: exception types the user's own callable raises (allowed as they are)
    allowance: float = 1.0  #: a load scaled up by the mutation widens the blow-up bounds by this factor
    detail: str = ""  #: what the set-up did (drawn there), appended to the case's name


@dataclass
class Case:
    family: str
    name: str
    expect: str  #: "valid" (exit 0, or 3 where physics says so, expected), "invalid" (a refusal expected), "any"
    setup: Callable[[Path], Spec]
    mode: str = "fork"  #: "fork", "mpi", "api"
    timeout: float = 60.0


@dataclass
class Outcome:
    klass: str
    rc: int | None
    seconds: float
    flags: list[str]
    line: str


def _sha(path: Path) -> str | None:
    try:
        if path.is_dir():
            return "dir:" + ",".join(sorted(p.name for p in path.iterdir()))
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


def _limits() -> None:
    runner._limits(MEMORY_LIMIT, FILE_LIMIT)


def _child(case: Case, spec: Spec, tmp: Path) -> None:
    """In the forked child: never returns."""
    code = 1
    try:
        os.setsid()
        os.chdir(tmp)
        for fd, name in ((1, ".stdout"), (2, ".stderr")):
            f = os.open(tmp / name, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            os.dup2(f, fd)
            os.close(f)
        sys.stdout = open(1, "w", encoding="utf-8", errors="backslashreplace", closefd=False)
        sys.stderr = open(2, "w", encoding="utf-8", errors="backslashreplace", closefd=False)
        sys.path.insert(0, str(tmp))  # stress-law modules written into the case folder (python -m peridyn does the same)
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        _limits()
        if case.mode == "api":
            code = _api_child(spec, tmp)
        else:
            from peridyn.cli import main

            try:
                code = int(main(spec.argv))
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            except BaseException:  # what an uncaught exception does to the command
                traceback.print_exc()
                code = 1
    except BaseException:  # noqa: BLE001
        try:
            traceback.print_exc()
        except BaseException:  # noqa: BLE001
            pass
        code = 1
    try:
        import logging

        for h in logging.getLogger("peridyn").handlers + logging.getLogger().handlers:
            try:
                h.flush()
            except Exception:  # noqa: BLE001
                pass
        sys.stdout.flush()
        sys.stderr.flush()
    finally:
        os._exit(code)


_FORBIDDEN = ("AttributeError", "IndexError", "ZeroDivisionError", "UnboundLocalError", "NameError", "AssertionError",
              "RecursionError", "OverflowError", "FloatingPointError")


def _api_child(spec: Spec, tmp: Path) -> int:
    """Run an API case; write result.json: ok, or the exception and whether it is clean."""
    from peridyn.errors import InputError

    res: dict[str, Any]
    try:
        spec.fn(tmp)
        res = {"status": "ok"}
    except BaseException as exc:  # noqa: BLE001
        mro = [c.__name__ for c in type(exc).__mro__]
        msg = exc.one_line() if isinstance(exc, InputError) and hasattr(exc, "one_line") else str(exc)
        numba = type(exc).__module__.startswith("numba")
        allowed = isinstance(exc, (InputError, ValueError, TypeError, KeyError)) and not numba \
            and not any(n in mro for n in _FORBIDDEN)
        if spec.passthrough and isinstance(exc, spec.passthrough):
            allowed = True
        res = {"status": "exc", "type": type(exc).__name__, "module": type(exc).__module__, "mro": mro,
               "msg": msg[:600], "allowed": allowed, "tb": traceback.format_exc()[-1500:]}
        if isinstance(exc, KeyboardInterrupt):
            res["allowed"] = False
    (tmp / ".api.json").write_text(json.dumps(res))
    return 0


def _read(path: Path) -> str:
    try:
        return path.read_bytes().decode("utf-8", "backslashreplace")
    except OSError:
        return ""


class Pool:
    """Up to ``jobs`` cases at once: forked children and MPI subprocesses."""

    def __init__(self, jobs: int = 2, keep: Path | None = None) -> None:
        self.jobs = jobs
        self.keep = keep

    def run(self, cases: list[Case], report: Callable[[Case, Outcome, Spec, Path], None]) -> None:
        pending = list(cases)
        running: dict[Any, tuple] = {}
        while pending or running:
            while pending and len(running) < self.jobs:
                case = pending.pop(0)
                tmp = Path(tempfile.mkdtemp(prefix="sc-"))
                limit = sys.getrecursionlimit()
                sys.setrecursionlimit(max(limit, 50000))  # deeply nested regions are written recursively
                try:
                    spec = case.setup(tmp)
                except Exception as exc:  # noqa: BLE001 - a broken generator is the campaign's bug
                    report(case, Outcome("exit1", None, 0.0, [f"campaign set-up failed: {type(exc).__name__}: {exc}"], ""), Spec(), tmp)
                    shutil.rmtree(tmp, ignore_errors=True)
                    continue
                finally:
                    sys.setrecursionlimit(limit)
                if spec.detail:
                    case.name = f"{case.name}: {spec.detail}"
                digests = {p: _sha(p) for p in spec.sentinels}
                digests.update({p: _sha(p) for p in tmp.rglob("*") if p.suffix in (".e", ".h") and p not in digests})
                t0 = time.perf_counter()
                if case.mode == "mpi":
                    env = dict(os.environ, PERIDYN_NO_PROGRESS="1", NUMBA_NUM_THREADS="1", PYTHONPATH=str(tmp))
                    with open(tmp / ".stdout", "wb") as fo, open(tmp / ".stderr", "wb") as fe:
                        proc = subprocess.Popen(["mpiexec", "-n", "2", sys.executable, "-m", "peridyn", *spec.argv], cwd=tmp,
                                                stdout=fo, stderr=fe, env=env, start_new_session=True, preexec_fn=_limits)
                    running[("p", proc.pid)] = (case, spec, tmp, digests, t0, proc)
                else:
                    sys.stdout.flush()
                    sys.stderr.flush()
                    pid = os.fork()
                    if pid == 0:
                        _child(case, spec, tmp)
                    running[("f", pid)] = (case, spec, tmp, digests, t0, None)
            done = []
            for key, (case, spec, tmp, digests, t0, proc) in running.items():
                rc: int | None | str = "running"
                if proc is not None:
                    r = proc.poll()
                    if r is not None:
                        rc = r
                else:
                    pid, status = os.waitpid(key[1], os.WNOHANG)
                    if pid:
                        rc = os.waitstatus_to_exitcode(status)
                if rc == "running" and time.perf_counter() - t0 > case.timeout:
                    try:
                        os.killpg(key[1], signal.SIGKILL)
                    except OSError:
                        pass
                    if proc is not None:
                        proc.wait()
                    else:
                        os.waitpid(key[1], 0)
                    rc = None
                if rc != "running":
                    done.append(key)
                    secs = time.perf_counter() - t0
                    try:
                        out = judge(case, spec, tmp, rc, secs, digests)
                    except Exception as exc:  # noqa: BLE001
                        out = Outcome("exit1", rc, secs, [f"campaign judge failed: {type(exc).__name__}: {exc}"], "")
                    report(case, out, spec, tmp)
                    if self.keep is not None and out.klass in BAD_CLASSES:
                        dest = self.keep / f"{case.family}-{abs(hash(case.name)) % 10**8}"
                        shutil.rmtree(dest, ignore_errors=True)
                        shutil.copytree(tmp, dest, symlinks=True, ignore_dangling_symlinks=True)
                    _rmtree(tmp)
            for key in done:
                del running[key]
            if running and not done:
                time.sleep(0.005)


def _rmtree(tmp: Path) -> None:
    for p in [tmp, *tmp.rglob("*")]:
        try:
            if p.is_dir() and not p.is_symlink():
                os.chmod(p, 0o755)
        except OSError:
            pass
    shutil.rmtree(tmp, ignore_errors=True)


def judge(case: Case, spec: Spec, tmp: Path, rc: int | None, secs: float, digests: dict) -> Outcome:
    """The outcome class of one execution."""
    stderr = _read(tmp / ".stderr")
    flags: list[str] = []
    if rc is None:
        flags.append("hang")
    elif rc < 0:
        flags.append(f"exit1(signal {-rc})")
    elif case.mode == "api":
        return _judge_api(case, spec, tmp, rc, secs, stderr)
    elif rc not in (0, 2, 3, 130):
        flags.append(f"exit1(rc={rc})")
    elif "Traceback (most recent call last)" in stderr and rc == 1:
        flags.append("exit1(traceback)")
    if rc is not None:
        for path, digest in digests.items():
            now = _sha(path)
            if now != digest and rc != 0 and path in spec.sentinels:
                flags.append(f"lost_output({'deleted' if now is None else 'changed'} {path.name})")
    written = []
    for path in sorted(p for p in tmp.rglob("*") if p.suffix in (".e", ".h") and p.is_file()):
        if path in digests and digests[path] == _sha(path):
            continue  # an earlier file left alone
        why, bad = runner.exodus_problems(path)
        if bad:
            flags.append(f"nan_output({path.name}: {', '.join(bad[:3])})")
        if why and rc == 0 and path.suffix == ".e" and ".partial" not in path.name:
            flags.append(f"exit0_bad(unreadable {path.name}: {why[:80]})")
        if not why and not bad:
            written.append(path)
    if rc == 0:
        if case.expect == "invalid":
            flags.append("exit0_bad(accepted invalid input)")
        if spec.argv and spec.argv[0] == "run" and spec.tree is not None:
            more, _ = runner.run_exit0_problems(stderr, written, spec.tree, spec.allowance)
            if "continuing from" in stderr:  # a restart from the last section's end has nothing left to run
                more = [f for f in more if "'done' with no solver run" not in f]
            flags += more
    if rc == 2:
        problems, culprit = runner.stderr_problems(stderr, spec.names)
        if "usage:" in stderr:
            problems.append("argparse_usage")
        if problems:
            flags.append("exit2_messy(" + ", ".join(problems) + ")")
        if case.expect == "valid":
            flags.append("refused_valid")
    if rc == 3 and case.expect == "valid":
        flags.append("exit3_bad(a legal run stopped as unstable)")
    klass = next((c for c in BAD_CLASSES for f in flags if f.startswith(c)), None)
    if klass is None:
        klass = {0: "exit0", 2: "exit2_clean", 3: "exit3", 130: "exit130"}.get(rc, "exit1")
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    line = next((ln for ln in lines if ln.startswith(("error", "internal error"))), lines[-1] if lines else f"rc={rc}")
    return Outcome(klass, rc, round(secs, 3), flags, line[:400])


def _judge_api(case: Case, spec: Spec, tmp: Path, rc: int, secs: float, stderr: str) -> Outcome:
    import re

    try:
        res = json.loads((tmp / ".api.json").read_text())
    except (OSError, ValueError):
        return Outcome("exit1", rc, secs, [f"exit1(api child wrote no result, rc={rc})"], stderr[-300:])
    if res["status"] == "ok":
        if case.expect == "invalid":
            return Outcome("exit0_bad", rc, secs, ["exit0_bad(accepted invalid argument)"], "")
        return Outcome("exit0", rc, secs, [], "")
    msg = res["msg"]
    flags = []
    if not res["allowed"]:
        flags.append(f"api_bad_exception({res['type']})")
    elif spec.arg and not re.search(rf"(?<![A-Za-z_]){re.escape(spec.arg)}(?![A-Za-z_])", msg):
        flags.append(f"api_bad_exception(message does not name {spec.arg!r})")
    if case.expect == "valid" and not flags:
        flags.append("refused_valid")
    klass = next((c for c in BAD_CLASSES for f in flags if f.startswith(c)), "exit2_clean")
    line = f"{res['type']}: {msg}"
    if klass == "api_bad_exception" and not res["allowed"]:
        tb = [ln.strip() for ln in res.get("tb", "").splitlines() if ln.strip().startswith("File ")]
        line += " | at " + (tb[-1] if tb else "?")
    return Outcome(klass, rc, round(secs, 3), flags, line[:500])
