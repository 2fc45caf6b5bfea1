"""Run verification problems point by point: timing, peak memory, ``results.json`` rewritten
after every finished point (an interrupted run keeps what it finished), bands checked."""
from __future__ import annotations

import datetime as _dt
import json
import logging
import math
import os
import platform
import resource
import subprocess
import sys
import time
import traceback
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import ExitCode, InputError
from .problems import PROBLEMS, Check, Problem
from .problems.base import base_method, device_of, on_device

log = logging.getLogger("peridyn.verify")

#: loggers silenced while a point runs: set-up warnings about the deliberately odd models
#: (a single row of points, trial steps above the estimate) are not news here
QUIET = ("peridyn.engine", "peridyn.solver", "peridyn.solvers", "peridyn.geometry")
#: a point that runs in less than REPEAT_BELOW s is run again, up to REPEATS times in all while
#: the repeats take less than REPEAT_BUDGET s: its wall time is the median, with the spread
#: (a single run of a few ms is mostly timer and cache noise); longer points run once
REPEAT_BELOW, REPEATS, REPEAT_BUDGET = 0.1, 5, 0.5


def fails(check: dict[str, Any]) -> bool:
    """Whether a check (as results.json holds it) fails the run: failed, and not a known miss."""
    return not check["passed"] and not check.get("known")


def select_problems(names: Sequence[str] | None, material: str | None = None) -> list[Problem]:
    """The problems named (all, in their order, for None or an empty list), with ``material``
    each restricted to the methods that run that registered material (plugins included; the
    problems with none left out); InputError for a name that is not a problem or a material."""
    if names:
        unknown = [n for n in names if n not in PROBLEMS]
        if unknown:
            raise InputError(f"--problems: unknown problem {unknown[0]!r}", fix=f"choose from {', '.join(PROBLEMS)}")
    chosen = [PROBLEMS[n]() for n in dict.fromkeys(names)] if names else [cls() for cls in PROBLEMS.values()]
    if material is None:
        return chosen
    from .materials import material_names

    known = material_names()
    if material not in known:
        raise InputError(f"--material: {material!r} is not a registered material", path=("--material",),
                         fix=f"choose from {', '.join(known)} ('peridyn plugins' lists the plugins')")
    out = [q for q in (p.for_material(material) for p in chosen) if q is not None]
    if not out:
        raise InputError(f"--material {material!r}: none of the problems chosen runs it", path=("--material",),
                         fix="leave out --problems, or add rigid-rotation (it runs every material)")
    return out


def gpu_name() -> str:
    """The name of the GPU the ``cuda`` backend runs on ("simulator" under numba-cuda's
    simulator); an InputError (how to install, or that no GPU is there) when it cannot run."""
    from ..kernels.numba_cuda import cuda_module, require_gpu, simulated

    require_gpu()
    if simulated():
        return "numba-cuda simulator (NUMBA_ENABLE_CUDASIM=1)"
    name = cuda_module().get_current_device().name
    return name.decode() if isinstance(name, bytes) else str(name)


def prepare_out(out: Path) -> None:
    """Create the --out folder (parents included); InputError when it is a file or cannot be made."""
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {str(out)!r} is a file, not a folder", fix="give a folder for results.json and report.md")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create the folder --out {str(out)!r}: {exc.strerror or exc}", fix="give a folder you can write to") from None


def machine() -> dict[str, Any]:
    """Platform, CPU model and cores of this machine, and numba's thread count."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    try:
        import numba

        threads = int(numba.get_num_threads())
    except Exception:  # pragma: no cover - numba is a dependency
        threads = None
    return {"platform": platform.platform(), "python": platform.python_version(), "cpu": cpu,
            "cores": os.cpu_count(), "usable cores": cores, "numba threads": threads}


def _git_head(folder: Path) -> str | None:
    """``git rev-parse HEAD`` in ``folder`` (None when it is not a checkout or git is missing)."""
    if not (folder / ".git").exists():
        return None
    try:
        p = subprocess.run(["git", "-C", str(folder), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return (p.stdout.strip() or None) if p.returncode == 0 else None


def _direct_url() -> dict[str, Any] | None:
    """The installed distribution's PEP 610 record (``direct_url.json``: where pip installed it
    from), None when there is none (an install from an index, or no metadata)."""
    from importlib import metadata

    try:
        text = metadata.distribution("peridyn").read_text("direct_url.json")
        return json.loads(text) if text else None
    except (metadata.PackageNotFoundError, ValueError, OSError):
        return None


def peridyn_version() -> dict[str, Any]:
    """peridyn's version, its commit and where the commit was read ("commit from"), in this order:
    the git checkout the imported package lies in (an editable install or a source tree on the
    path); for a non-editable install, its PEP 610 metadata: the commit pip recorded for an install
    from a git URL (``vcs_info.commit_id``: exact), or the HEAD of the local folder it was
    installed from when that is a checkout (its HEAD now, which may have moved since the
    install: said so). None with the reason otherwise (an index install of a release records only
    its version)."""
    from .. import __version__

    here = Path(__file__).resolve().parents[2]
    commit = _git_head(here)
    if commit:
        return {"version": __version__, "commit": commit, "commit from": f"the git checkout at {here}"}
    info = _direct_url() or {}
    vcs = info.get("vcs_info") or {}
    if vcs.get("commit_id"):
        return {"version": __version__, "commit": vcs["commit_id"], "commit from": f"the install's metadata (installed from {info.get('url')})"}
    url = str(info.get("url", ""))
    if url.startswith("file://"):
        from urllib.parse import unquote, urlparse

        source = Path(unquote(urlparse(url).path))
        commit = _git_head(source)
        if commit:
            return {"version": __version__, "commit": commit,
                    "commit from": f"the HEAD now of the folder it was installed from ({source}); the install may be older"}
    return {"version": __version__, "commit": None,
            "commit from": "not known: installed without a record of its commit (install from a git URL or a checkout to have it)"}


def peak_memory_mib() -> float:
    """Peak resident memory of this process so far (MiB; ``getrusage``: it never falls, so a
    point's value is the largest of it and every point before)."""
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / 2**20 if sys.platform == "darwin" else rss / 1024.0


def _json_default(value: Any) -> Any:
    if hasattr(value, "item"):  # numpy scalars
        return _finite(value.item())
    raise TypeError(f"not JSON: {type(value).__name__}")


def _finite(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def write_json(path: Path, data: dict[str, Any]) -> None:
    """Write ``data`` to ``path`` atomically (a temporary file renamed over it): a reader, or a
    Ctrl-C during the write, never sees half a file. inf and NaN become null."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(_finite(data), indent=1, default=_json_default) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def _worker_start(threads: int | None, level: int) -> None:
    """A ``--jobs`` worker's set-up: numba's threads (the machine's shared among the workers),
    the parent's log level on stderr, and Ctrl-C left to the parent (it ends the workers)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    logging.basicConfig(level=level, format="%(message)s")
    if threads:
        import numba

        numba.set_num_threads(threads)


def _worker_problem(problem: Problem, quick: bool, device: str) -> tuple[list[dict[str, Any]], float]:
    """In a ``--jobs`` worker: every point of ``problem`` as :meth:`Run.in_turn` measures them
    (same order, warm-ups and repeats), and the seconds they took together."""
    t0 = time.perf_counter()
    run = Run([problem], Path("."), quick=quick, device=device)  # never saved: the parent gathers the points
    ladders = {m: problem.ladder(base_method(m), quick) for m in run.state["problems"][0]["methods"]}
    return list(run.points_of(problem, ladders)), time.perf_counter() - t0


class WorkerPool:
    """``peridyn verify --jobs N``: N worker processes (spawned: numba's threads are not forked)
    that run whole problems, every problem submitted at once in the run's order; the parent
    takes their points in that order (:meth:`result`), so results.json is the serial run's."""

    def __init__(self, problems: Sequence[Problem], jobs: int, *, quick: bool, device: str) -> None:
        import multiprocessing

        try:
            import numba

            threads = max(1, int(numba.get_num_threads()) // jobs)
        except Exception:  # pragma: no cover - numba is a dependency
            threads = None
        self.pool = multiprocessing.get_context("spawn").Pool(jobs, initializer=_worker_start,
                                                              initargs=(threads, logging.getLogger("peridyn").getEffectiveLevel()))
        self.pending = [self.pool.apply_async(_worker_problem, (p, quick, device)) for p in problems]

    def result(self, index: int) -> tuple[list[dict[str, Any]], float]:
        """The points of the problem ``index`` (in the run's order) and the seconds they took,
        waiting for its worker; a worker's crash is raised here."""
        return self.pending[index].get()

    def close(self) -> None:
        """Let the workers finish and end them."""
        self.pool.close()
        self.pool.join()

    def stop(self) -> None:
        """End the workers now (Ctrl-C), the problems they were running lost."""
        self.pool.terminate()
        self.pool.join()


class Run:
    """One ``peridyn verify`` run: its state is what ``results.json`` holds."""

    def __init__(self, problems: Sequence[Problem], out: Path, *, quick: bool, command: str = "peridyn verify", device: str = "cpu",
                 comm: Any = None, compare: dict[str, Any] | None = None, compare_path: str | None = None, jobs: int = 1) -> None:
        from ..parallel.comm import SerialComm

        #: under ``mpiexec`` the ranks share out each problem's points and rank 0 writes the results
        self.comm = comm or SerialComm()
        self.problems = list(problems)
        self.out = Path(out)
        self.quick = quick
        self.device = device
        #: worker processes that run whole problems at once (``--jobs``; 1: every point in this process)
        self.jobs = max(1, int(jobs))
        self.t0 = time.perf_counter()
        self.state: dict[str, Any] = {
            "format": 1,
            "command": command,
            "quick": quick,
            "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "peridyn": peridyn_version(),
            "machine": machine(),
            "status": "running",
            "wall (s)": 0.0,
            "failed checks": 0,
            "ranks": self.comm.size,
            "jobs": self.jobs,
            "problems": [self._entry(p) for p in self.problems],
        }
        if device == "gpu":
            self.state["machine"]["gpu"] = gpu_name()
        #: an earlier run's results to compare each point's error with (``--compare``)
        self.before = compare
        self.before_path = compare_path

    def _entry(self, p: Problem) -> dict[str, Any]:
        curves = p.curves(self.device)
        unfitted = {m: p.unfitted[base_method(m)] for m in curves if base_method(m) in p.unfitted}
        return {"name": p.name, "title": p.title, "unfitted": unfitted, "kind": p.kind, "plotted": p.plotted, "computes": p.computes, "reference": p.reference,
                "resolution": p.resolution_name, "size": p.size_name, "error": p.error_name, "methods": list(curves),
                "points": [], "rates": {}, "checks": [], "peridigm": [dict(q) for q in p.peridigm],
                "companions": {k: list(v) for k, v in p.companions.items()}}

    @property
    def results_path(self) -> Path:
        return self.out / "results.json"

    def save(self) -> None:
        if self.comm.rank != 0:
            return
        self.state["wall (s)"] = time.perf_counter() - self.t0
        write_json(self.results_path, self.state)

    def point(self, problem: Problem, method: str, resolution: float) -> dict[str, Any]:
        """Run and time one point of the curve ``method`` (a GPU curve measures its method on
        the GPU); a failure other than Ctrl-C is recorded with the point."""
        from .problems.dynamics import quiet

        t0 = time.perf_counter()
        failure = None
        try:
            with quiet(*QUIET), on_device(device_of(method)):
                m = problem.measure(base_method(method), resolution, self.quick)
        except (KeyboardInterrupt, SystemExit):
            raise
        except Exception as exc:
            log.debug("%s", traceback.format_exc())
            failure, m = f"{type(exc).__name__}: {exc}", None
        wall = time.perf_counter() - t0
        wall = m.values.pop("wall (s)", wall) if m else wall
        walls = [wall] if m else []
        if m and wall < REPEAT_BELOW and problem.kind == "curve" and problem.independent_points:
            walls += self.repeats(problem, method, resolution)
        point = {"problem": problem.name, "method": method, "resolution": resolution,
                 "size": m.size if m else None, "error": m.error if m else None,
                 "wall (s)": float(np.median(walls)) if walls else wall, "steps": m.steps if m else 0,
                 "wall runs": len(walls), "wall spread (s)": [min(walls), max(walls)] if len(walls) > 1 else None,
                 "peak memory (MiB)": peak_memory_mib(), "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                 "values": m.values if m else {}}
        if failure:
            point["failure"] = failure
        return point

    def repeats(self, problem: Problem, method: str, resolution: float) -> list[float]:
        """The wall times of further runs of a short point (see REPEATS); a repeat that fails
        ends them (the first run's result stands)."""
        from .problems.dynamics import quiet

        walls: list[float] = []
        spent = 0.0
        while len(walls) + 1 < REPEATS and spent < REPEAT_BUDGET:
            t0 = time.perf_counter()
            try:
                with quiet(*QUIET), on_device(device_of(method)):
                    m = problem.measure(base_method(method), resolution, self.quick)
            except Exception:  # noqa: BLE001 - the first run is the point's result
                break
            took = time.perf_counter() - t0
            walls.append(m.values.get("wall (s)", took))
            spent += took
        return walls

    def warm_up(self, problem: Problem, method: str, resolution: float) -> None:
        """Run ``method``'s coarsest point once, untimed, so that compiling its kernels (or
        loading them from the cache) is not in the first point's wall time; a failure here is
        left for the timed point to record."""
        from .problems.dynamics import quiet

        try:
            with quiet(*QUIET), on_device(device_of(method)):
                problem.measure(base_method(method), resolution, self.quick)
        except Exception:  # noqa: BLE001 - reported by the point itself
            pass

    def points_of(self, problem: Problem, ladders: dict[str, list[float]]) -> Iterator[dict[str, Any]]:
        """Every point of ``problem`` in turn, method by method (each method of a curve problem
        warmed up first), as each finishes."""
        for method, ladder in ladders.items():
            if problem.kind == "curve" and ladder:
                self.warm_up(problem, method, ladder[0])
            for resolution in ladder:
                yield self.point(problem, method, resolution)

    def in_turn(self, problem: Problem, entry: dict[str, Any], ladders: dict[str, list[float]]) -> None:
        """Serially: every point in turn, ``entry`` and results.json updated after each."""
        for point in self.points_of(problem, ladders):
            method, resolution = point["method"], point["resolution"]
            entry["points"].append(point)
            self.update(problem, entry)
            self.save()
            log.debug("  %s %s = %g: error %s, %.3g s%s", method, problem.resolution_name, resolution, point["error"],
                          point["wall (s)"], f", FAILED: {point['failure']}" if "failure" in point else "")

    def shared_out(self, problem: Problem, entry: dict[str, Any], ladders: dict[str, list[float]]) -> None:
        """Under ``mpiexec``: rank r measures the points k with k % ranks == r (in the serial
        order; each warms up the methods it measures), or, for a problem whose points of a method
        depend on each other, the methods m with m % ranks == r; rank 0 gathers them, in that order,
        into ``entry`` and results.json. The points' wall times are each their own, taken while
        the other ranks run theirs on the same machine."""
        work = [(m, r) for m, rs in ladders.items() for r in rs]
        rank, size = self.comm.rank, self.comm.size
        methods = list(ladders)
        owner = [k % size if problem.independent_points else methods.index(m) % size for k, (m, _) in enumerate(work)]
        mine: list[tuple[int, dict[str, Any]]] = []
        warmed: set[str] = set()
        for k in (k for k in range(len(work)) if owner[k] == rank):
            method, resolution = work[k]
            if problem.kind == "curve" and method not in warmed:
                self.warm_up(problem, method, ladders[method][0])
                warmed.add(method)
            mine.append((k, self.point(problem, method, resolution)))
        parts = self.comm.gather(mine)
        if rank == 0:
            entry["points"].extend(point for _, point in sorted((x for part in parts for x in part), key=lambda kp: kp[0]))
            self.update(problem, entry)
            self.save()

    def update(self, problem: Problem, entry: dict[str, Any]) -> None:
        """Recompute ``entry``'s rates and checks from its points."""
        checks: list[Check] = []
        rates = {}
        for method in entry["methods"]:
            pts = [p for p in entry["points"] if p["method"] == method and "failure" not in p]
            failed = [p for p in entry["points"] if p["method"] == method and "failure" in p]
            for p in failed:
                checks.append(Check(problem.name, method, f"point {p['resolution']:g} failed: {p['failure']}", math.nan))
            if problem.kind == "curve" and len(pts) >= 2:
                rates[method] = None if base_method(method) in problem.unfitted else problem.rate(pts)
            checks.extend(problem.checks(method, pts, self.quick))
        entry["rates"] = rates
        entry["checks"] = [c.as_dict() for c in checks]
        self.state["failed checks"] = sum(1 for e in self.state["problems"] for c in e["checks"] if fails(c))
        self.state["known misses"] = sum(1 for e in self.state["problems"] for c in e["checks"] if not c["passed"] and c.get("known"))

    def compare(self) -> int:
        """With ``--compare``: each point's error against the earlier run's, into the state
        ("compare"); the number of points that moved beyond their tolerance."""
        if self.before is None:
            return 0
        from .compare import compare

        result = compare(self.before, self.state, {p.name: p.compare_rtol for p in self.problems})
        result["against"] = self.before_path
        self.state["compare"] = result
        for m in result["moved"]:
            log.info("  MOVED %s %s at %s = %g: %s -> %s, %s", m["problem"], m["method"], "resolution", m["resolution"], m["before"], m["now"], m["why"])
        log.info("compare: %d point(s) against %s, %d moved beyond their tolerance", result["compared"], self.before_path, len(result["moved"]))
        return len(result["moved"])

    def run(self) -> int:
        """Run every problem; ExitCode.OK, 1 when a check fails, INTERRUPTED on Ctrl-C (the
        points finished so far kept in results.json and report.md)."""
        from .report import write_report

        self.save()
        total = len(self.problems)
        pool = WorkerPool(self.problems, self.jobs, quick=self.quick, device=self.device) if self.jobs > 1 else None
        try:
            for i, (problem, entry) in enumerate(zip(self.problems, self.state["problems"]), 1):
                t0 = time.perf_counter()
                ladders = {m: problem.ladder(base_method(m), self.quick) for m in entry["methods"]}
                log.info("[%d/%d] %s: %s; %d points (%s)", i, total, problem.name, problem.title, sum(map(len, ladders.values())),
                         ", ".join(f"{m}: {problem.resolution_name} {' '.join(f'{r:g}' for r in rs)}" for m, rs in ladders.items()))
                took = None
                if pool is not None:  # the problem's points, measured in a worker (in the same order as in_turn's)
                    points, took = pool.result(i - 1)
                    entry["points"].extend(points)
                    self.update(problem, entry)
                    self.save()
                else:
                    (self.shared_out if self.comm.size > 1 else self.in_turn)(problem, entry, ladders)
                failed = [c for c in entry["checks"] if fails(c)]
                known = sum(1 for c in entry["checks"] if not c["passed"] and c.get("known"))
                rates = ", ".join(f"{m} {r:.2f}" for m, r in entry["rates"].items() if r is not None and math.isfinite(r))
                log.info("  %s: %.1f s%s; %d of %d checks pass%s%s", problem.name, time.perf_counter() - t0 if took is None else took,
                         f", fitted rates {rates}" if rates else "", len(entry["checks"]) - len(failed) - known, len(entry["checks"]),
                         f" ({known} known miss(es) FAIL, not counted: see report.md)" if known else "",
                         "".join(f"\n  FAIL {c['method']}: {c['what']} = {c['value']!r}, band {c['band']}" for c in failed))
        except KeyboardInterrupt:
            if pool is not None:
                pool.stop()
            self.state["status"] = "interrupted"
            self.save()
            if self.comm.rank == 0:
                write_report(self.state, self.out)
            log.warning("interrupted: %s and report.md keep the %d point(s) finished", self.results_path,
                        sum(len(e["points"]) for e in self.state["problems"]))
            return int(ExitCode.INTERRUPTED)
        if pool is not None:
            pool.close()
        self.state["status"] = "complete"
        moved = self.compare()
        self.save()
        if self.comm.rank == 0:
            write_report(self.state, self.out)
        failed = self.comm.bcast(self.state["failed checks"] + moved)
        log.info("verify: %d problem(s) in %.1f s; %s; wrote %s and %s", total, self.state["wall (s)"],
                 f"{failed} check(s) FAIL" if failed else "every check passes", self.results_path, self.out / "report.md")
        return int(ExitCode.FAILURE) if failed else int(ExitCode.OK)


def run_verify(names: Sequence[str] | None, out: str | Path, *, quick: bool = False, command: str = "peridyn verify",
               device: str = "cpu", comm: Any = None, material: str | None = None, compare: str | Path | None = None,
               jobs: int = 1) -> int:
    """``peridyn verify``: run the named problems (all for None) into the folder ``out``; the
    exit status (0 every band holds, 1 one fails, 130 interrupted). ``device="gpu"`` adds a
    curve on the GPU backend for every method that has one; ``jobs`` > 1 runs the problems in
    that many worker processes (each problem's points in one worker, the results the same as with
    1 apart from the wall times and peak memories). InputError for an unknown name, an ``out``
    that is a file, ``device="gpu"`` without a usable GPU, or ``jobs`` < 1 or with MPI ranks."""
    if jobs < 1:
        raise InputError(f"--jobs {jobs}: give 1 or more worker processes", path=("--jobs",), fix="--jobs 2 on two cores")
    if jobs > 1 and comm is not None and comm.size > 1:
        raise InputError("--jobs with mpiexec: the ranks already share out the points", path=("--jobs",),
                         fix="leave out --jobs under mpiexec, or run without mpiexec")
    problems = select_problems(names, material)
    before = None
    if compare is not None:
        from .compare import load

        before = load(compare)
    if device == "gpu":
        gpu_name()
        if not any(p.gpu_methods for p in problems):
            raise InputError("--device gpu: none of the problems chosen has a method that runs on the GPU",
                             path=("--device",), fix="add --problems " + " ".join(n for n, c in PROBLEMS.items() if c.gpu_methods))
    out = Path(out)
    prepare_out(out)
    return Run(problems, out, quick=quick, command=command, device=device, comm=comm, compare=before,
               compare_path=None if compare is None else str(compare), jobs=jobs).run()
