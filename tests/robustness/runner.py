"""Run ``peridyn check`` or ``peridyn run`` on a prepared case and classify the outcome.

Outcome classes, worst first: ``code_exec`` (an expression ran Python), ``hang`` (wall-time limit),
``exit1`` (internal error, a crash or a signal), ``lost_output`` (an earlier result was deleted or
corrupted), ``nan_output`` (a non-finite value in a written Exodus file), ``exit0_bad`` (accepted
although obviously invalid, or wrote an unreadable file), ``refused_valid`` (exit 2 for the
unmutated shrunk deck of a ``run`` case, a deck that passes ``check``), ``exit2_messy`` (refused, but not in the
one-line-per-problem form), then the clean ones: ``exit3``, ``exit0``, ``exit2_clean``; ``skipped``
if the mutated tree cannot be written.

Exit 0 of ``run`` must mean the answer is right, so two more kinds of ``exit0_bad`` are looked for
in what the run wrote (:func:`run_exit0_problems`):

* ``exit0_bad(blow_up: ...)``: the run summary on stderr reports an energy balance error above
  :data:`MAX_BALANCE_PCT` percent of the energy scale after at least :data:`MIN_BALANCE_STEPS`
  steps (or the solver's own "energy balance error
  reached N%" warning above it), or a written Exodus file shows explosive growth: displacements
  larger than :data:`BLOWUP_EXTENTS` times the model's extent, velocities that would carry a point
  that many extents over the run's duration, or a global kinetic energy growing by more than
  :data:`KE_GROWTH` (loads the mutation itself scaled up widen these bounds by the same factor);
* ``exit0_bad(empty_run: ...)``: the summary says a solver ran 0 steps (and no fallback of it
  ran any), or no solver ran at all
  ("done" without a Solver line), or an output file holds only its first frame although the run
  took at least as many steps as that output's frequency.

``check`` runs in-process (``peridyn.cli.main``) in a warm worker process started once, so
it costs no interpreter or numba start-up; ``run`` runs in a subprocess (or, with
``run_in_process``, in the warm worker too, non-clean outcomes confirmed in a subprocess). Both get a memory limit,
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

BAD_CLASSES = ("code_exec", "hang", "exit1", "lost_output", "nan_output", "exit0_bad", "refused_valid", "exit2_messy")
CLEAN_CLASSES = ("exit3", "exit0", "exit2_clean", "skipped")
#: longest acceptable error line, without its "error: <file>:<line>: " start (the issue says ~300)
MAX_LINE = int(os.environ.get("PERIDYN_FUZZ_MAX_LINE", "400"))
#: keys whose extreme values legitimately ask for a lot of work (a hang there may be a design question)
WORK_KEYS = {"Final Time", "Initial Time", "Fixed dt", "Safety Factor", "Number of Load Steps", "Time Steps",
             "Horizon", "Number Points X", "Number Points Y", "Number Points Z", "Number Points Radius",
             "X Length", "Y Length", "Z Length", "Output Frequency", "Maximum Solver Iterations"}
#: largest energy balance error (% of the run's energy scale) an exit-0 run may report. The
#: balance of velocity Verlet is its bounded energy error dt^2/8 sum m|a|^2 (solvers/monitors/energy.py):
#: a stable run at a step near its limit reaches tens of percent (WaveInBar at 1.65 times the
#: estimate, 27 %; its measured limit is 2.63 times it), and peridyn itself stops runs past 50 %
MAX_BALANCE_PCT = float(os.environ.get("PERIDYN_FUZZ_MAX_BALANCE", "50"))
#: fewest steps, and smallest energy scale, of a run whose energy balance is judged (a run of a
#: step or two is off by one step's energy; a model at rest has round-off energies of 1e-34)
MIN_BALANCE_STEPS = 10
MIN_ENERGY = 1e-20
#: displacement (or velocity x duration) larger than this many model extents: a blow-up
BLOWUP_EXTENTS = 100.0
#: growth of the global kinetic energy (largest / first positive value) that is a blow-up
KE_GROWTH = 1e6
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
def _limits(memory: int = MEMORY_LIMIT, files: int = FILE_LIMIT) -> None:
    """This process's memory, file-size and core limits (a file past its limit fails to write)."""
    for res, lim in ((resource.RLIMIT_AS, memory), (resource.RLIMIT_FSIZE, files), (resource.RLIMIT_CORE, 0)):
        try:
            resource.setrlimit(res, (lim, lim))
        except (ValueError, OSError):
            pass
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)


def _serve(conn) -> None:
    """The check worker's loop: run ``peridyn.cli.main(argv)`` in ``cwd`` for each request."""
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")  # ``run`` cases in this worker: one thread, as the subprocesses
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


# ------------------------------------------------------------------------------------------------
# Exit 0 of ``run``: is the answer plausible? (blow-ups and empty runs reported as success)
# ------------------------------------------------------------------------------------------------
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|[-+]?inf|nan"
_SOLVER_LINE = re.compile(rf"^(?P<section>\S.*?) \((?P<method>[\w ]+)\): (?P<steps>\d+) steps in (?P<wall>{_NUM}) s", re.M)
_ENERGY_LINE = re.compile(rf"^\s+energy: kinetic (?P<k0>{_NUM}) -> (?P<k1>{_NUM}), stored (?P<stored>{_NUM}), "
                          rf"work by loads (?P<work>{_NUM}), by prescribed motion (?P<motion>{_NUM}); "
                          rf"balance error (?P<err>{_NUM}) \((?P<pct>{_NUM})% of the energy scale, worst (?P<worst>{_NUM})%\)", re.M)
_BALANCE_WARNING = re.compile(rf"energy (?:balance error (?:reached |of )?|of the run was off by up to )(?P<pct>{_NUM})%")
_DONE_LINE = re.compile(r"^done in .*?; wrote (?P<files>.*)$", re.M)


@dataclass
class RunSummary:
    """What ``peridyn run`` reported at its end (stderr, default verbosity)."""

    solvers: list[tuple[str, str, int]] = field(default_factory=list)  #: (section, method, steps)
    energy: list[dict[str, float]] = field(default_factory=list)  #: the "energy:" lines' numbers
    balance_warnings: list[float] = field(default_factory=list)  #: percents in energy-balance warnings
    done: bool = False
    wrote: list[str] = field(default_factory=list)

    @property
    def steps(self) -> int:
        return sum(s for _, _, s in self.solvers)


def run_summary(stderr: str) -> RunSummary:
    """Parse the end-of-run summary (solver steps, energy balance, "done") from ``stderr``."""
    out = RunSummary()
    events = sorted([(m.start(), "s", m) for m in _SOLVER_LINE.finditer(stderr)] + [(m.start(), "e", m) for m in _ENERGY_LINE.finditer(stderr)],
                    key=lambda x: x[0])
    for _, kind, m in events:
        if kind == "s":
            out.solvers.append((m["section"], m["method"], int(m["steps"])))
        else:  # the energy of the solver line above it
            e = {k: float(v) for k, v in m.groupdict().items()}
            e["steps"] = float(out.solvers[-1][2]) if out.solvers else 0.0
            out.energy.append(e)
    for m in _BALANCE_WARNING.finditer(stderr):
        out.balance_warnings.append(float(m["pct"]))
    done = list(_DONE_LINE.finditer(stderr))
    if done:
        out.done = True
        files = done[-1]["files"].strip()
        out.wrote = [] if files == "no output" else [f.strip() for f in files.split(",")]
    return out


def summary_problems(summary: RunSummary, max_pct: float | None = None) -> list[str]:
    """``exit0_bad(blow_up | empty_run ...)`` flags that an exit-0 run's summary justifies."""
    max_pct = MAX_BALANCE_PCT if max_pct is None else max_pct
    flags = []
    if summary.done and not summary.solvers:
        flags.append("exit0_bad(empty_run: 'done' with no solver run)")
    for section, method, steps in summary.solvers:
        # a solver whose fallback (QuasiStatic > ... > Switch to Verlet) took over did not run empty
        if steps == 0 and not any(s > 0 and sec.startswith(section) for sec, _, s in summary.solvers):
            flags.append(f"exit0_bad(empty_run: {section} ({method}) ran 0 steps)")
    for e in summary.energy:
        scale = max(abs(e["k0"]), abs(e["k1"]), abs(e["stored"]), abs(e["work"]) + abs(e["motion"]))
        if not all(map(np.isfinite, e.values())):
            flags.append("exit0_bad(blow_up: non-finite energy in the run summary)")
        elif e["steps"] < MIN_BALANCE_STEPS or scale < MIN_ENERGY:
            continue  # a step or two (an error of one step's energy) or round-off of a model at rest
        elif e["pct"] > max_pct:
            flags.append(f"exit0_bad(blow_up: energy balance error {e['pct']:.3g}% of the energy scale > {max_pct:g}%)")
    worst = max(summary.balance_warnings, default=0.0)
    if worst > max_pct and not any("energy balance" in f for f in flags):
        flags.append(f"exit0_bad(blow_up: energy balance error warning {worst:.3g}% > {max_pct:g}%)")
    return flags


def _names(ds, var: str) -> list[str]:
    import netCDF4

    if var not in ds.variables:
        return []
    return [str(x).strip() for x in netCDF4.chartostring(np.asarray(ds.variables[var][:]))]


def _nodal(ds, names: list[str], wanted: str) -> np.ndarray | None:
    """(frames, nodes) values of the nodal variable ``wanted``, or None."""
    if wanted not in names:
        return None
    i = names.index(wanted)
    if f"vals_nod_var{i + 1}" in ds.variables:
        return np.asarray(ds.variables[f"vals_nod_var{i + 1}"][:], dtype=float)
    if "vals_nod_var" in ds.variables:
        return np.asarray(ds.variables["vals_nod_var"][:, i, :], dtype=float)
    return None


def _magnitude(ds, names: list[str], stem: str) -> np.ndarray | None:
    """(frames, nodes) |stem| from its X/Y/Z (or _X ...) components, or None."""
    parts = [p for p in (_nodal(ds, names, f"{stem}{a}") if f"{stem}{a}" in names else _nodal(ds, names, f"{stem}_{a}")
                         for a in "XYZ") if p is not None]
    if not parts:
        return None
    return np.sqrt(sum(np.where(np.isfinite(p), p, 0.0) ** 2 for p in parts))


def exodus_growth(path: Path, allowance: float = 1.0, span: float | None = None) -> list[str]:
    """``exit0_bad(blow_up ...)`` flags for explosive growth in an Exodus file: |u| or |v| x
    duration above BLOWUP_EXTENTS x allowance model extents, or a global kinetic energy growing
    more than KE_GROWTH x allowance**2. ``span``: the deck's run time (when the file has one frame)."""
    import netCDF4

    flags: list[str] = []
    try:
        with netCDF4.Dataset(str(path), "r") as ds:
            ds.set_auto_maskandscale(False)
            coords = [np.asarray(ds.variables[c][:], dtype=float) for c in ("coordx", "coordy", "coordz") if c in ds.variables]
            coords = [c[np.isfinite(c)] for c in coords]
            extent = max((float(c.max() - c.min()) for c in coords if c.size), default=0.0)
            times = np.asarray(ds.variables["time_whole"][:], dtype=float) if "time_whole" in ds.variables else np.zeros(0)
            names = _names(ds, "name_nod_var")
            limit = BLOWUP_EXTENTS * extent * allowance
            if extent > 0:
                u = _magnitude(ds, names, "Displacement")
                if u is not None and u.size and float(u.max()) > limit:
                    flags.append(f"exit0_bad(blow_up: |u| = {float(u.max()):.3g} > {BLOWUP_EXTENTS:g} x the extent {extent:.3g} in {path.name})")
                v = _magnitude(ds, names, "Velocity")
                duration = float(times[-1] - times[0]) if times.size > 1 and np.all(np.isfinite(times)) else 0.0
                duration = duration if duration > 0 else (span or 0.0)
                if v is not None and v.size and duration > 0 and float(v.max()) * duration > limit:
                    flags.append(f"exit0_bad(blow_up: |v| = {float(v.max()):.3g} moves {float(v.max()) * duration / extent:.3g} "
                                 f"extents in {duration:.3g} in {path.name})")
            gnames = _names(ds, "name_glo_var")
            for i, g in enumerate(gnames):
                if "kinetic" not in g.lower() or "vals_glo_var" not in ds.variables:
                    continue
                ke = np.asarray(ds.variables["vals_glo_var"][:, i], dtype=float)
                ke = ke[np.isfinite(ke)]
                pos = ke[ke > 0]
                if pos.size >= 2 and float(pos.max()) > KE_GROWTH * allowance**2 * float(pos[0]):
                    flags.append(f"exit0_bad(blow_up: {g} grew {float(pos.max()) / float(pos[0]):.3g}-fold in {path.name})")
    except Exception:  # an unreadable file is exodus_problems' business
        return []
    return flags


def frame_count(path: Path) -> int | None:
    """Number of frames (time_whole entries) in an Exodus file, or None if unreadable."""
    import netCDF4

    try:
        with netCDF4.Dataset(str(path), "r") as ds:
            return int(ds.variables["time_whole"].shape[0])
    except Exception:
        return None


def output_frequencies(tree: dict) -> dict[str, int | None]:
    """Output file base name -> its Output Frequency (None: a frequency this check cannot judge:
    an Initial/Final Output Step, a non-integer, or adaptive output)."""
    out: dict[str, int | None] = {}
    adaptive = any("Adaptive" in str(k) for p, _ in _keys(tree) for k in p)
    for key, sec in tree.items():
        if "Output" in str(key) and isinstance(sec, dict):
            base = sec.get("Output Filename", "dump")
            f = sec.get("Output Frequency", 1)
            ok = isinstance(f, int) and not isinstance(f, bool) and f > 0 and not adaptive
            ok = ok and "Initial Output Step" not in sec and "Final Output Step" not in sec
            if isinstance(base, str):  # two sections may share a name (.e and .h): the rarer one decides
                prev = out.get(base, 0)
                out[base] = None if (not ok or prev is None) else max(prev, f)
    return out


def _keys(tree: dict, prefix: tuple = ()):
    for k, v in tree.items():
        yield prefix + (k,), v
        if isinstance(v, dict):
            yield from _keys(v, prefix + (k,))


def deck_span(tree: dict) -> float:
    """Sum of the solver sections' Final Time - Initial Time (0 if unknown)."""
    total = 0.0
    for name, sec in tree.items():
        if "Solver" in str(name) and isinstance(sec, dict):
            t0, t1 = sec.get("Initial Time", 0.0), sec.get("Final Time")
            if all(isinstance(t, (int, float)) and not isinstance(t, bool) for t in (t0, t1)) and t1 > t0:
                total += float(t1) - float(t0)
    return total if np.isfinite(total) else 0.0


def run_exit0_problems(stderr: str, written: list[Path], tree: dict, allowance: float = 1.0) -> tuple[list[str], list[str]]:
    """(flags, notes) for an exit-0 ``run``: blow-ups and empty runs (see the module docstring)."""
    summary = run_summary(stderr)
    flags, notes = summary_problems(summary), []
    if not summary.done:
        notes.append("no 'done' line in the run summary: steps and energy balance not checked")
    span = deck_span(tree)
    freqs = output_frequencies(tree)
    for path in written:
        flags += exodus_growth(path, allowance, span)
        base = path.name.rsplit(".", 1)[0]
        freq = freqs.get(base)
        frames = frame_count(path)
        if freq and summary.solvers and frames == 1 and summary.steps >= freq and span > 0:
            flags.append(f"exit0_bad(empty_run: {path.name} holds only its first frame after {summary.steps} steps, "
                         f"Output Frequency {freq})")
    return list(dict.fromkeys(flags)), notes


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
    written = []
    for path in sorted(prep.out.glob("*")):
        if path.suffix not in EXODUS_SUFFIXES or not path.is_file() or prep.sentinels.get(path) == sha(path):
            continue  # not a result, or an earlier result left alone
        why, bad = exodus_problems(path)
        if bad:
            flags.append(f"nan_output({path.name}: {', '.join(bad[:4])})")
        if why and path not in prep.sentinels and rc == 0:
            flags.append(f"exit0_bad(unreadable {path.name}: {why[:120]})")
        if not why and not bad:
            written.append(path)
    if rc == 0 and case.command == "run":
        more, facts = run_exit0_problems(stderr, written, tree, getattr(case.mutation, "load_factor", 1.0))
        flags += more
        notes += facts
    if case.mutation.kind == "none" and rc == 2:
        flags.append("refused_valid(the unmutated shrunk deck was refused)")
    elif case.mutation.kind == "none" and rc == 3:
        notes.append("the unmutated shrunk deck stopped as unstable")
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
             keep: Path | None = None, threads: int | None = 1, run_in_process: bool = False) -> Outcome:
    """Write, execute and classify one case (in a temporary folder, or in ``keep`` if given).

    ``run_in_process``: ``run`` cases too go to the warm worker (no interpreter, import or JIT
    cache start-up: several times the throughput); an outcome that is not clean is then confirmed
    in a subprocess, whose verdict is kept."""
    if run_in_process and case.command == "run" and keep is None:
        outcome = _run_case(case, check_timeout, run_timeout, in_process, None, threads, True)
        if not outcome.bad:
            return outcome
        confirmed = _run_case(case, check_timeout, run_timeout, in_process, None, threads, False)
        confirmed.notes.append(f"in the warm worker: {outcome.klass}" if confirmed.klass != outcome.klass else "confirmed in a subprocess")
        return confirmed
    return _run_case(case, check_timeout, run_timeout, in_process, keep, threads, False)


def _run_case(case: Case, check_timeout: float, run_timeout: float, in_process: bool, keep: Path | None,
              threads: int | None, run_in_process: bool) -> Outcome:
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
            if run_in_process:
                rc, _, err, secs = check_worker().run(argv, prep.out, run_timeout)
            else:
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
