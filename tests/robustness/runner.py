"""Run ``peridyn check`` or ``peridyn run`` on a prepared case and classify the outcome.

Outcome classes, worst first: ``code_exec`` (an expression ran Python), ``hang`` (wall-time limit),
``exit1`` (internal error, a crash or a signal), ``lost_output`` (an earlier result was deleted or
corrupted), ``nan_output`` (a non-finite value in a written Exodus file), ``exit0_bad`` (accepted
although obviously invalid, or wrote an unreadable file), ``exit2_messy`` (refused, but not in the
one-line-per-problem form), then the clean ones: ``exit3``, ``exit0``, ``exit2_clean``; ``skipped``
if the mutated tree cannot be written.

``check`` runs in-process (``peridyn.cli.main``) in a warm worker process started once, so
it costs no interpreter or numba start-up; ``run`` runs in a subprocess. Both get a memory limit,
a file-size limit and a wall-time limit.
"""
from __future__ import annotations

import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cases import Case, Prepared, prepare, sha  # noqa: E402
from mutations import EXODUS_SUFFIXES, DeckInfo  # noqa: E402
from values import obviously_invalid  # noqa: E402

BAD_CLASSES = ("code_exec", "hang", "exit1", "lost_output", "nan_output", "exit0_bad", "exit2_messy")
CLEAN_CLASSES = ("exit3", "exit0", "exit2_clean", "skipped")
#: longest acceptable error line, without its "error: <file>:<line>: " start (the issue says ~300)
MAX_LINE = int(os.environ.get("PERIDYN_FUZZ_MAX_LINE", "400"))
#: keys whose extreme values legitimately ask for a lot of work (a hang there may be a design question)
WORK_KEYS = {"Final Time", "Initial Time", "Fixed dt", "Safety Factor", "Number of Load Steps", "Time Steps",
             "Horizon", "Number Points X", "Number Points Y", "Number Points Z", "Number Points Radius",
             "X Length", "Y Length", "Z Length", "Output Frequency", "Maximum Solver Iterations"}
MEMORY_LIMIT = 4 * 2**30
FILE_LIMIT = 512 * 2**20


@dataclass
class Outcome:
    """What happened to one case."""

    klass: str
    rc: int | None
    seconds: float
    flags: list[str] = field(default_factory=list)  #: every problem found (the class is the worst)
    notes: list[str] = field(default_factory=list)  #: facts that are not failures
    stderr: str = ""
    error_line: str = ""  #: the most telling stderr line

    @property
    def bad(self) -> bool:
        return self.klass in BAD_CLASSES

    def to_json(self) -> dict:
        d = asdict(self)
        d["stderr"] = self.stderr[-3000:]
        return d


# ------------------------------------------------------------------------------------------------
# Executing
# ------------------------------------------------------------------------------------------------
def _limits() -> None:
    for res, lim in ((resource.RLIMIT_AS, MEMORY_LIMIT), (resource.RLIMIT_FSIZE, FILE_LIMIT), (resource.RLIMIT_CORE, 0)):
        try:
            resource.setrlimit(res, (lim, lim))
        except (ValueError, OSError):
            pass
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)


def _serve(conn) -> None:
    """The check worker's loop: run ``peridyn.cli.main(argv)`` in ``cwd`` for each request."""
    from peridyn.cli import main

    os.environ["PERIDYN_NO_PROGRESS"] = "1"
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _limits()
    while True:
        try:
            argv, cwd = conn.recv()
        except (EOFError, OSError):
            os._exit(0)
        saved = os.dup(1), os.dup(2)
        os.chdir(cwd)
        for fd, name in ((1, ".stdout"), (2, ".stderr")):
            f = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            os.dup2(f, fd)
            os.close(f)
        sys.stdout = open(1, "w", encoding="utf-8", errors="backslashreplace", closefd=False)
        sys.stderr = open(2, "w", encoding="utf-8", errors="backslashreplace", closefd=False)
        try:
            code = int(main(argv))
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        except BaseException:  # what an uncaught exception does to the command: traceback, exit 1
            traceback.print_exc()
            code = 1
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        os.close(saved[0])
        os.close(saved[1])
        os.chdir("/")
        conn.send(code)


class CheckWorker:
    """A warm process (started fresh, never forked from a process with OpenMP threads) that runs ``check`` in-process.

    One request at a time; the process is replaced after a timeout or any exit code other
    than 0, 2 or 3, so a broken state never leaks into the next case.
    """

    def __init__(self) -> None:
        self._proc = None
        self._conn = None

    def _start(self) -> None:
        import multiprocessing

        ctx = multiprocessing.get_context("spawn")  # not fork: this process may already run OpenMP threads
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(target=_serve, args=(child,), daemon=True)
        self._proc.start()
        child.close()

    def stop(self) -> None:
        if self._proc is not None:
            self._proc.kill()
            self._proc.join()
            self._conn.close()
        self._proc = self._conn = None

    def run(self, argv: list[str], cwd: Path, timeout: float) -> tuple[int | None, str, str, float]:
        """(exit code or None on timeout, stdout, stderr, seconds) of ``peridyn argv`` in ``cwd``."""
        if self._proc is None or not self._proc.is_alive():
            self._start()
        t0 = time.perf_counter()
        self._conn.send((argv, str(cwd)))
        rc: int | None
        if not self._conn.poll(timeout):
            rc = None
        else:
            try:
                rc = self._conn.recv()
            except (EOFError, OSError):  # the process died (a signal, os._exit)
                self._proc.join()
                rc = self._proc.exitcode
        secs = time.perf_counter() - t0
        if rc not in (0, 2, 3):
            self.stop()
        return rc, _read(cwd / ".stdout"), _read(cwd / ".stderr"), secs


_LOCAL = threading.local()


def check_worker() -> CheckWorker:
    """This thread's check worker."""
    if getattr(_LOCAL, "worker", None) is None:
        _LOCAL.worker = CheckWorker()
    return _LOCAL.worker


def run_subprocess(argv: list[str], cwd: Path, timeout: float, threads: int | None = 1) -> tuple[int | None, str, str, float]:
    """``python -m peridyn argv`` with limits: (exit code or None on timeout, stdout, stderr, s)."""
    env = dict(os.environ, PERIDYN_NO_PROGRESS="1")
    if threads:
        env["NUMBA_NUM_THREADS"] = str(threads)
    out_path, err_path = cwd / ".stdout", cwd / ".stderr"
    t0 = time.perf_counter()
    with open(out_path, "wb") as fo, open(err_path, "wb") as fe:
        proc = subprocess.Popen([sys.executable, "-m", "peridyn", *argv], cwd=cwd, stdout=fo, stderr=fe, env=env,
                                start_new_session=True, preexec_fn=_limits)
        try:
            rc: int | None = proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            rc = None
    return rc, _read(out_path), _read(err_path), time.perf_counter() - t0


def _read(path: Path) -> str:
    try:
        return path.read_bytes().decode("utf-8", "backslashreplace")
    except OSError:
        return ""


# ------------------------------------------------------------------------------------------------
# Judging
# ------------------------------------------------------------------------------------------------
def exodus_problems(path: Path) -> tuple[str | None, list[str]]:
    """(why the file is not a readable Exodus file or None, names of variables with non-finite values)."""
    import netCDF4

    try:
        with netCDF4.Dataset(str(path), "r") as ds:
            ds.set_auto_maskandscale(False)
            if "time_whole" not in ds.variables:
                return "no time_whole variable", []
            bad = []
            for name, var in ds.variables.items():
                data = np.asarray(var[...])
                if data.dtype.kind == "f" and data.size and not np.all(np.isfinite(data)):
                    bad.append(name)
            return None, bad
    except Exception as exc:  # netCDF4 raises OSError, RuntimeError, IndexError, ...
        return f"{type(exc).__name__}: {exc}", []


_CONTROL = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")
def _pydantic_phrases() -> re.Pattern:
    """pydantic's own message templates (their fixed beginnings), to spot untranslated errors."""
    phrases = {"validation error for", "validation errors for", "errors.pydantic.dev", "[type=", "Value error,",
               "Assertion failed,", "Input should be", "Field required", "Unable to parse", "Extra inputs are not"}
    try:
        import typing

        from pydantic_core import PydanticKnownError
        from pydantic_core.core_schema import ErrorType

        for kind in typing.get_args(ErrorType):
            try:
                text = PydanticKnownError(kind).message_template
            except Exception:  # needs a context: its template is not fixed text
                continue
            phrases.add(text.split("{")[0][:40].strip())
    except Exception:  # pragma: no cover - another pydantic version
        pass
    return re.compile("|".join(re.escape(p) for p in sorted(phrases) if len(p) >= 12))


_PYDANTIC = _pydantic_phrases()
_PYREPR = re.compile(r"<class '|<function |object at 0x|Traceback \(most recent|File \"[^\"]+\", line \d+")
_FILE_TOKEN = re.compile(r"[\w.\-/]+\.(?:g|e|h|exo|txt|csv|yaml|yml|xml|dat)\b", re.IGNORECASE)


def _shown_length(line: str) -> int:
    """Length of an error line without its ``error: <file>[:<line>]: `` start (the user's path)."""
    return len(re.sub(r"^error: [^:]*\.(?:yaml|yml|xml)(?::\d+)?: ", "", line))


def stderr_problems(stderr: str, names: set[str]) -> tuple[list[str], str]:
    """Ways an exit-2 stderr misses the one-line-per-problem form, and the first line at fault."""
    problems: list[str] = []
    lines = stderr.splitlines()
    errors = [ln for ln in lines if ln.startswith("error")]
    if "Traceback" in stderr:
        problems.append("traceback")
    if "internal error" in stderr:
        problems.append("internal_error_text")
    if not errors:
        problems.append("no_error_line")
    culprit = ""
    for ln in errors:
        found = []
        if _shown_length(ln) > MAX_LINE:
            found.append(f"long_line({_shown_length(ln)})")
        if _CONTROL.search(ln):
            found.append("control_chars")
        if _PYDANTIC.search(ln) and "; " not in ln:
            found.append("pydantic_text")
        if _PYREPR.search(ln):
            found.append("python_repr")
        if not (_FILE_TOKEN.search(ln) or any(n in ln for n in names)):
            found.append("no_file_named")
        if found and not culprit:
            culprit = ln
        problems += found
    if _CONTROL.search(stderr) and "control_chars" not in problems:
        problems.append("control_chars(outside the error lines)")
    culprit = culprit or (errors[0] if errors else (lines[-1] if lines else ""))
    return list(dict.fromkeys(problems)), culprit


def classify(case: Case, prep: Prepared, rc: int | None, stderr: str, seconds: float, tree: dict) -> Outcome:
    """The outcome class of one execution, with every problem found."""
    flags, notes = [], []
    if any(prep.root.rglob("PWNED")):
        flags.append("code_exec")
    if rc is None:
        flags.append("hang")
        if case.mutation.path and case.mutation.path[-1] in WORK_KEYS:
            notes.append(f"the mutated {case.mutation.path[-1]!r} may ask for a huge amount of work")
    elif rc not in (0, 2, 3):
        flags.append("exit1" if rc == 1 else f"exit1(rc={rc})")
    # earlier results and written files
    for path, digest in prep.sentinels.items():
        if rc is None:
            break
        if not path.exists():
            if rc != 0:
                flags.append(f"lost_output(deleted {path.name})")
            continue
        if sha(path) == digest:
            continue
        why, _ = exodus_problems(path)
        if case.command == "check":
            flags.append(f"lost_output(check modified {path.name})")
        elif why and rc != 0:
            flags.append(f"lost_output(corrupted {path.name}: {why[:120]})")
        elif why:
            flags.append(f"exit0_bad(unreadable {path.name}: {why[:120]})")
        elif rc == 2:
            notes.append(f"replaced {path.name} before the input error")
    for path in sorted(prep.out.glob("*")):
        if path.suffix not in EXODUS_SUFFIXES or not path.is_file() or prep.sentinels.get(path) == sha(path):
            continue  # not a result, or an earlier result left alone
        why, bad = exodus_problems(path)
        if bad:
            flags.append(f"nan_output({path.name}: {', '.join(bad[:4])})")
        if why and path not in prep.sentinels and rc == 0:
            flags.append(f"exit0_bad(unreadable {path.name}: {why[:120]})")
    problems, culprit = stderr_problems(stderr, prep.names | {prep.deck.name})
    if rc == 2 and problems:
        flags.append("exit2_messy(" + ", ".join(problems) + ")")
    if rc == 0:
        why = obviously_invalid(tree) or case.mutation.expect_refusal
        if why:
            flags.append(f"exit0_bad(accepted: {why})")
    klass = next((c for c in BAD_CLASSES for f in flags if f.startswith(c)), None)
    if klass is None:
        klass = {0: "exit0", 2: "exit2_clean", 3: "exit3"}.get(rc, "exit1")
    line = culprit
    if klass == "exit1":
        lines = [ln for ln in stderr.splitlines() if ln.strip()]
        line = next((ln for ln in lines if "internal error" in ln), lines[-1] if lines else f"rc={rc}, no stderr")
    return Outcome(klass, rc, round(seconds, 3), flags, notes, stderr, line[:500])


def run_case(case: Case, *, check_timeout: float = 30.0, run_timeout: float = 60.0, in_process: bool = True,
             keep: Path | None = None, threads: int | None = 1) -> Outcome:
    """Write, execute and classify one case (in a temporary folder, or in ``keep`` if given)."""
    tmp = Path(tempfile.mkdtemp(prefix="peridyn-fuzz-")) if keep is None else keep
    try:
        try:
            tree = case.tree()
            prep = prepare(case, tmp)
        except (ValueError, TypeError, UnicodeEncodeError) as exc:  # a tree no deck file can hold
            return Outcome("skipped", None, 0.0, notes=[f"cannot write the deck: {type(exc).__name__}: {exc}"[:300]])
        deck = os.path.relpath(prep.deck, prep.out)  # as a user would type it
        if case.command == "check":
            argv = ["check", deck]
            if in_process and hasattr(os, "fork"):
                rc, _, err, secs = check_worker().run(argv, prep.out, check_timeout)
            else:
                rc, _, err, secs = run_subprocess(argv, prep.out, check_timeout, threads)
        else:
            argv = ["run", deck, "--output-dir", ".", "--no-progress"]
            rc, _, err, secs = run_subprocess(argv, prep.out, run_timeout, threads)
        return classify(case, prep, rc, err, secs, tree)
    finally:
        if keep is None:
            shutil.rmtree(tmp, ignore_errors=True)


def calibrate(deck: DeckInfo, timeout: float = 60.0) -> DeckInfo:
    """Fill ``deck.baseline`` (exit code of ``check``) and ``deck.dt_hint`` (its stable time step)."""
    with tempfile.TemporaryDirectory(prefix="peridyn-fuzz-cal-") as tmp:
        rc, out, _, _ = check_worker().run(["check", str(deck.path)], Path(tmp), timeout)
    deck.baseline = rc
    m = re.search(r"stable time step \(Verlet\): ([0-9.eE+-]+)", out)
    deck.dt_hint = float(m.group(1)) if m else None
    return deck


def debug_traceback(case: Case, timeout: float = 120.0) -> str:
    """The end of the traceback ``--debug`` shows for a case (to locate an internal error)."""
    tmp = Path(tempfile.mkdtemp(prefix="peridyn-fuzz-dbg-"))
    try:
        prep = prepare(case, tmp)
        deck = os.path.relpath(prep.deck, prep.out)
        extra = ["--output-dir", ".", "--no-progress"] if case.command == "run" else []
        rc, _, err, _ = run_subprocess([case.command, deck, "--debug", *extra], prep.out, timeout)
        frames = [ln.strip() for ln in err.splitlines() if ln.startswith("  File ")]
        ours = [f.replace(str(Path(__file__).resolve().parents[2]) + "/", "") for f in frames if "/peridyn/" in f]
        last = err.strip().splitlines()[-1][:300] if err.strip() else f"rc={rc}"
        return " <- ".join(reversed((ours or frames)[-3:])) + " | " + last
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
