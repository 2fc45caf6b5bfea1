"""The ``peridyn`` command: run, check, plugins, schema, convert, new-plugin, verify."""
from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import time
from pathlib import Path
from typing import NoReturn

from .core.errors import ExitCode, InputError, InstabilityError, OutputWriteError, PeridynError
from .core.logs import say, setup_logging
from .core.resources import usable_cores

log = logging.getLogger("peridyn")
#: set from --log-json before the command runs
_LOG_JSON = {"on": False}


def _setup_logging(verbosity: int, rank: int = 0) -> None:
    from .solvers.monitors.progress import structured_progress

    as_json = bool(_LOG_JSON["on"])
    setup_logging(verbosity, rank, as_json=as_json)
    structured_progress(as_json)


def _report_input_error(exc: InputError) -> None:
    for line in exc.one_line().splitlines():
        say("error", line)


# ------------------------------------------------------------------------------------------------
def cmd_run(args) -> int:
    from .engine.session import ReportedInputError, RunSession
    from .parallel.comm import get_comm

    comm = get_comm()
    _setup_logging(args.verbose - args.quiet, comm.rank)
    session = RunSession(args.deck, output_dir=args.output_dir or None, comm=comm, progress=not args.no_progress,
                         backend=args.backend, device=args.device, restart=args.restart)
    if comm.size == 1:
        session.run()  # errors reach main(): one line and their exit code
        return ExitCode.OK
    try:
        session.open()
    except ReportedInputError:
        return ExitCode.INPUT_ERROR
    except Exception as exc:  # a failure on one rank must not leave the others waiting
        _abort(comm, exc, args)
        return ExitCode.FAILURE
    return _run_parallel(session, comm, args)


def _run_parallel(session, comm, args) -> int:
    """The sections of an MPI run: an error on every rank at the same step ends each rank with
    its exit code; one found on one rank alone ends every rank (MPI_Abort), never a hang."""
    from .engine.restart import RunInterrupted
    from .engine.session import keeps_output

    try:
        session.run()
    except RunInterrupted as exc:
        if not exc.collective:  # a signal outside an explicit loop: the other ranks may wait in a collective
            _abort(comm, exc, args)
        elif comm.rank == 0:  # every rank stops after the same step, after the checkpoint
            print(f"{exc}", file=sys.stderr)
        return exc.exit_code
    except InstabilityError as exc:
        if not keeps_output(exc, comm.size):  # found on this rank alone: the others must be stopped
            _abort(comm, exc, args)
        elif comm.rank == 0:
            say("error", str(exc))
            say("", "the output written so far is kept and readable")
        return ExitCode.UNSTABLE
    except BaseException as exc:
        _abort(comm, exc, args)
        return ExitCode.FAILURE
    return ExitCode.OK


def _abort(comm, exc: BaseException, args) -> None:
    """Report an error raised on this rank and end every rank (MPI_Abort): never a hang."""
    if getattr(args, "debug", False):
        import traceback

        traceback.print_exc()
    code = exc.exit_code if isinstance(exc, PeridynError) else ExitCode.INTERRUPTED if isinstance(exc, KeyboardInterrupt) else ExitCode.FAILURE
    text = exc.one_line() if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
    say(f"error on rank {comm.rank} of {comm.size}", f"{text}; stopping all ranks", rank=comm.rank)
    sys.stderr.flush()
    if comm.size > 1:
        # MPI_Abort has the launcher kill every rank, racing the forwarding of this rank's
        # stderr: without a moment for it the line was lost (once in three runs of tests/mpi)
        time.sleep(0.5)
    comm.abort(int(code))


# ------------------------------------------------------------------------------------------------
def cmd_check(args) -> int:
    import numpy as np

    from .deck.model import load_deck
    from .engine.simulation import Simulation

    _setup_logging(args.verbose - args.quiet)
    from .engine.output import OutputFiles
    from .engine.output_paths import check_output_names, check_run_paths

    deck = load_deck(args.deck)
    check_output_names(deck, Path.cwd())
    sim = Simulation(deck, output_dir=Path.cwd(), write_files=False, device=args.device)  # a check writes nothing
    files = OutputFiles(sim)  # what a run would write: listed and its paths checked, nothing written
    check_run_paths(sim, files)
    nl = sim.bonds
    counts = nl.counts()
    vol = sim.fields["Volume"]
    print(f"{deck.file}: valid")
    if sim.device == "gpu":
        print("  device: gpu (every model, condition and solver of the deck has a GPU path)")
    print(f"  discretization: {deck.discretization.type}, {sim.num_global} points, {nl.num_bonds} bonds")
    if counts.size:
        print(f"  neighbors per point: min {counts.min()}, mean {counts.mean():.1f}, max {counts.max()}")
    for blk in sim.blocks:
        n = blk.stop - blk.start
        if n:
            spacing = float(np.mean(np.cbrt(vol[blk.start : blk.stop])))
            h = sim.horizon_local[blk.start : blk.stop]
            ratio = f"{float(np.mean(h)) / spacing:.3g}" if spacing > 0 else "?"
        else:
            ratio = "-"
        hz = f"{blk.horizon:.6g}" if blk.horizon is not None else f"{blk.horizon_text!r}"
        dmg = f", damage {blk.damage.name}" if blk.damage is not None else ""
        print(f"  block {blk.name} (id {blk.block_id}): {n} points, material {blk.material.name}{dmg}, horizon {hz}, horizon/spacing {ratio}")
    try:
        dt = sim.critical_time_step()
        print(f"  estimated stable time step (Verlet): {dt:.6g}")
    except Exception as exc:  # a material without a bulk modulus
        print(f"  estimated stable time step: unavailable ({exc})")
    if sim.contact is not None:
        c = sim.contact
        print(f"  contact: {c.model.name}, contact radius {c.rc:.6g}, search radius {c.search_radius:.6g} every {c.frequency} step(s); "
              f"stable time step with the contact springs {c.stable_time_step():.6g}")
    from .engine.limits import human_seconds

    for entry, (_, steps, seconds) in zip(deck.solvers, sim.plan_solvers()):
        planned = f", {steps} steps, estimated {human_seconds(seconds)} on one core" if steps is not None else ""
        print(f"  solver {entry.section}: {entry.method}{planned}")
    for w in files.writers:
        print(f"  output {w.entry.section}: {w.path.name}, every {w.frequency} step(s), {len(w.names)} variable(s)")
    if deck.restart is not None:
        r = deck.restart
        every = f"every {r.restart_frequency} Verlet step(s), " if r.restart_frequency else ""
        print(f"  restart: checkpoints in {r.folder}/ {every}after each solver section and on SIGTERM/SIGINT, the latest {r.keep} kept")
    mem = sim.memory_bytes()
    print(f"  memory estimate: {mem / 2**20:.1f} MiB for fields and neighbor lists")
    return ExitCode.OK


# ------------------------------------------------------------------------------------------------
def cmd_plugins(args) -> int:
    from .core.params import describe_params
    from .plugins.manager import KINDS, get_registry

    reg = get_registry()
    for kind, (_, human, _) in KINDS.items():
        names = reg.names(kind)
        print(f"{human}{'es' if human.endswith('s') else 's'} ({len(names)}):")
        for name in names:
            entry = reg.entry(kind, name)
            try:
                cls = entry.load()
            except Exception as exc:
                print(f"  {name}  [{entry.plugin}]  failed to load: {exc}")
                continue
            print(f"  {name}  [{entry.plugin}]" + (f"  {cls.description}" if kind == "backend" and cls.description else ""))
            params = None if kind == "backend" else cls.Params
            if params is None or args.brief:
                continue
            for row in describe_params(params):
                req = "required" if row["required"] else ("optional" if row["default"] is None else f"default {row['default']!r}")
                desc = f" - {row['description']}" if row["description"] else ""
                print(f"      {row['name']}: {row['type']} ({req}){desc}")
    if reg.failed:
        print("plugins that failed to import:")
        for name, err in reg.failed.items():
            print(f"  {name}: {err}")
    return ExitCode.OK


def cmd_schema(args) -> int:
    from .engine.output_paths import check_output_file, write_text_atomic

    target, option = (args.reference, "--reference") if args.reference else (args.output, "-o")
    if target:
        check_output_file(Path(target), option)  # before the schema is built
    if args.reference:
        from .deck.reference import reference_markdown

        write_text_atomic(Path(args.reference), reference_markdown(), "--reference")
        print(f"wrote {args.reference}")
        return ExitCode.OK
    from .deck.schema import deck_json_schema

    text = json.dumps(deck_json_schema(), indent=2)
    if args.output:
        write_text_atomic(Path(args.output), text + "\n", "-o")
    else:
        print(text)
    return ExitCode.OK


def cmd_convert(args) -> int:
    from .deck.files import convert
    from .engine.output_paths import check_output_file

    check_output_file(Path(args.output), "convert OUT")
    convert(args.input, args.output)
    print(f"wrote {args.output}")
    return ExitCode.OK


def cmd_new_plugin(args) -> int:
    from .engine.output_paths import check_output_folder
    from .plugins.scaffold import new_plugin

    check_output_folder(Path(args.directory), "--directory")
    path = new_plugin(args.name, kind=args.kind, directory=Path(args.directory))
    print(f"created {path}")
    print(f"  pip install -e {path} && pytest {path}")
    return ExitCode.OK


def cmd_fragments(args) -> int:
    """Print the fragment-mass distribution of a result file (and plot it with --plot)."""
    from .io.fragment_report import format_table, fragment_table, plot_distribution

    from .engine.output_paths import check_output_file, replace_atomic

    _setup_logging(0)
    if args.plot:
        check_output_file(Path(args.plot), "--plot")
    table = fragment_table(args.result, args.frame)
    print(format_table(table, top=args.top))
    if args.plot:
        import importlib.util

        if importlib.util.find_spec("matplotlib") is None:
            log.warning('no plot: matplotlib is not installed (pip install "peridyn[plot]")')
        else:
            replace_atomic(Path(args.plot), lambda tmp: plot_distribution(table, tmp), "--plot")
            print(f"wrote {args.plot}")
    return ExitCode.OK


def cmd_merge(args) -> int:
    """Join the per-rank pieces NAME.e.N.r of a run into NAME.e (what SEACAS epu does)."""
    from .engine.output_paths import check_output_file, replace_atomic
    from .engine.output_pieces import pieces_of
    from .io.exodus_merge import merge_pieces

    _setup_logging(args.verbose - args.quiet)
    result = Path(args.result)
    size, pieces = pieces_of(result)
    if not pieces:
        raise InputError(f"no pieces {result.name}.N.r beside it", file=str(result),
                         fix="give the name without .N.r of a file that ran on N ranks with Merge Rank Files: false")
    if len(pieces) != size:
        have = {int(p.name.rsplit(".", 1)[-1]) for p in pieces}
        missing = [r for r in range(size) if r not in have]
        log.warning("%s: no piece of rank%s %s (a rank that owned no point writes none)", result.name,
                    "s" if len(missing) > 1 else "", ", ".join(map(str, missing[:8])))
    out = Path(args.output) if args.output else result
    check_output_file(out, "--output")

    def write(tmp: Path) -> None:
        try:
            steps = merge_pieces(pieces, tmp)
        except ValueError as exc:
            raise InputError(str(exc), file=str(result), fix="give the pieces of one run, all of them") from None
        log.info("%d pieces, %d frames", len(pieces), steps)

    replace_atomic(out, write, "--output")
    print(f"wrote {out} from {len(pieces)} pieces")
    return ExitCode.OK


def _readable_path(path: str) -> None:
    """An input path the system cannot even look at (a name too long, a loop of links) is bad
    input naming it (shortened), not an internal error."""
    try:
        os.stat(path)
    except FileNotFoundError:
        return  # the reader says it does not exist
    except OSError as exc:
        shown = path if len(path) <= 80 else path[:40] + "..." + path[-30:]
        raise InputError(f"cannot open the file: {exc.strerror}", file=shown, fix="give a shorter or existing path") from None


def cmd_plot(args) -> int:
    """PREFIX_history.png and PREFIX_frame<K>_<field>.png of a result file."""
    from .engine.output_paths import check_output_prefix
    from .io.plot import plot

    _setup_logging(0)
    _readable_path(args.result)
    if args.out:
        check_output_prefix(Path(args.out), "--out", longest_suffix=40)  # PREFIX_frame<K>_<field>.png
    for png in plot(args.result, frames=args.frames, field=args.field, view=args.view, prefix=args.out):
        print(f"wrote {png}")
    return ExitCode.OK


def cmd_verify(args) -> int:
    """Run the verification problems; 0 every band holds, 1 one fails, 130 interrupted."""
    from .parallel.comm import get_comm
    from .verify import run_verify

    comm = get_comm()  # under mpiexec the ranks share out the points
    _setup_logging(args.verbose - args.quiet, comm.rank)
    command = ("peridyn verify" + (" --quick" if args.quick else "") + (" --device gpu" if args.device == "gpu" else "")
               + (f" --problems {' '.join(args.problems)}" if args.problems else "") + (f" --material {args.material!r}" if args.material else "")
               + (f" --compare {args.compare}" if args.compare else ""))
    return run_verify(args.problems, Path(args.out), quick=args.quick, command=command, device=args.device or "cpu", comm=comm,
                      material=args.material, compare=args.compare, jobs=args.jobs)


# ------------------------------------------------------------------------------------------------
class _Parser(argparse.ArgumentParser):
    """argparse with the project's form of a usage error: one line on stderr, exit 2 (no usage block)."""

    def error(self, message: str) -> NoReturn:  # type: ignore[override]
        text = " ".join(message.split())
        sys.stderr.write(f"error: {self.prog}: {text}; see {self.prog} --help\n")
        sys.exit(int(ExitCode.INPUT_ERROR))


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    p = _Parser(prog="peridyn", description="Peridynamics: run Peridigm and peridyn decks.")
    p.add_argument("--version", action="version", version=f"peridyn {__version__}")
    p.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = p.add_subparsers(dest="command", required=True)

    def common(sp):
        sp.add_argument("-v", "--verbose", action="count", default=0, help="more output")
        sp.add_argument("-q", "--quiet", action="count", default=0, help="less output")
        sp.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help="show tracebacks")
        sp.add_argument("--log-json", action="store_true", help="log one JSON object per line on stderr (progress records included) for batch systems")
        sp.add_argument("--no-limits", action="store_true", help="run models estimated too large for memory or too long to finish (a warning instead of an error)")

    r = sub.add_parser("run", help="run a deck (YAML or Peridigm XML)")
    r.add_argument("deck")
    r.add_argument("--output-dir", help="where output files go (default: the current folder)")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.add_argument("--backend", help="where arrays live and bond loops run: numba (CPU threads, the default), numba-serial, cuda (the GPU), or a plugin's (default: PERIDYN_BACKEND)")
    r.add_argument("--device", choices=("cpu", "gpu"), type=str.lower, help="run explicit solvers on one NVIDIA GPU (needs peridyn[gpu]) or the CPU; wins over the solver's Device (default: cpu)")
    r.add_argument("--restart", nargs="?", const="latest", metavar="CHECKPOINT",
                   help="continue from a checkpoint of this deck (alone: the latest in the Restart section's folder); docs/restart.md")
    common(r)
    r.set_defaults(func=cmd_run)

    c = sub.add_parser("check", help="validate a deck and describe the model without running it")
    c.add_argument("deck")
    c.add_argument("--device", choices=("cpu", "gpu"), type=str.lower, help="also check that every part of the deck runs on that device")
    common(c)
    c.set_defaults(func=cmd_check)

    pl = sub.add_parser("plugins", help="list every model with its parameters")
    pl.add_argument("--brief", action="store_true", help="names only")
    pl.set_defaults(func=cmd_plugins)

    s = sub.add_parser("schema", help="JSON Schema of the deck format, installed plugins included")
    s.add_argument("-o", "--output", help="write to a file")
    s.add_argument("--reference", metavar="FILE", help="write the parameter reference (Markdown, docs/reference.md) to FILE instead")
    s.set_defaults(func=cmd_schema)

    cv = sub.add_parser("convert", help="convert a Peridigm XML deck to YAML")
    cv.add_argument("input")
    cv.add_argument("output")
    cv.set_defaults(func=cmd_convert)

    n = sub.add_parser("new-plugin", help="create a plugin package skeleton")
    n.add_argument("name", help="package name, e.g. my_material")
    n.add_argument("--kind", choices=("material", "damage", "contact", "compute", "stress-law"), default="material",
                   help="stress-law: a numba stress law for the built-in Stress Law Correspondence material")
    n.add_argument("--directory", default=".", help="where to create it")
    n.set_defaults(func=cmd_new_plugin)

    fr = sub.add_parser("fragments", help="the fragment-mass distribution of a result file (outputs Fragment_Id and Fragment_Mass)")
    fr.add_argument("result", help="an Exodus file a run wrote, e.g. cylinder.e")
    fr.add_argument("--frame", type=int, default=-1, help="output frame (default -1: the last)")
    fr.add_argument("--top", type=int, default=10, help="how many of the largest fragments to list (default 10)")
    fr.add_argument("--plot", metavar="PNG", help="also draw the cumulative distribution into PNG (needs peridyn[plot])")
    common(fr)
    fr.set_defaults(func=cmd_fragments)

    mg = sub.add_parser("merge", help="join the per-rank pieces NAME.e.N.r of a run into NAME.e (as SEACAS epu does)")
    mg.add_argument("result", help="the file the pieces are of, e.g. cylinder.e for cylinder.e.4.0 ... cylinder.e.4.3")
    mg.add_argument("--output", metavar="FILE", help="write the joined file here (default: RESULT itself)")
    common(mg)
    mg.set_defaults(func=cmd_merge)

    pl = sub.add_parser("plot", help="pictures of a result file: energy, momentum and damage histories, frames (needs peridyn[plot])")
    pl.add_argument("result", help="an Exodus file a run wrote, e.g. cylinder.e")
    pl.add_argument("--frames", type=int, nargs="+", metavar="K", help="output frames to draw (default: the last; -1 is the last)")
    pl.add_argument("--field", help="colour the points by this output (default Damage, else the displacement's magnitude); "
                                    "a vector's name (Velocity) draws its magnitude")
    pl.add_argument("--view", choices=("xy", "xz", "yz"), help="the coordinate plane to project on (default: the body's two largest extents)")
    pl.add_argument("--out", metavar="PREFIX", help="file name prefix (default: the result's name without .e)")
    common(pl)
    pl.set_defaults(func=cmd_plot)

    from .verify.listing import ProblemListFormatter  # the problem list is read only when --help prints it

    vf = sub.add_parser("verify", help="run the verification problems: error against wall time, convergence rates, stable time steps",
                        formatter_class=ProblemListFormatter)
    vf.add_argument("--quick", action="store_true", help="the coarsest resolutions only (3 points per curve; a few minutes)")
    vf.add_argument("--problems", nargs="+", metavar="NAME", help="run only these (default: all; listed below)")
    vf.add_argument("--material", metavar="NAME", help="run every problem that applies to this registered material (plugins included), "
                                                     "each with its methods of that material only")
    vf.add_argument("--compare", metavar="RESULTS.json", help="an earlier run's results.json: fail (exit 1) when a point's error moves "
                                                              "beyond its tolerance (5 %% unless the problem says)")
    vf.add_argument("--device", choices=("cpu", "gpu"), type=str.lower,
                    help="gpu: also run every method that has a GPU path on one NVIDIA GPU, as its own curve (needs peridyn[gpu])")
    vf.add_argument("--jobs", type=int, default=1, metavar="N",
                    help="run the problems in N worker processes, each problem in one (the results are the same; default 1)")
    vf.add_argument("--out", default="peridyn-verify", help="folder for results.json, report.md and the figures (default: ./peridyn-verify)")
    common(vf)
    vf.set_defaults(func=cmd_verify)
    return p


def _quiet_floating_point() -> None:
    """No NumPy floating-point warnings on stderr: every value that reaches a field, an output
    frame or a condition is checked for NaN and inf and reported once, with its source."""
    import warnings

    import numpy as np

    np.seterr(all="ignore")
    warnings.simplefilter("ignore", RuntimeWarning)


def _single_threaded_blas() -> None:
    """peridyn's parallelism is its numba kernels; BLAS thread pools that spin between calls
    steal their cores (measured: 60 % slower explicit runs on 2 cores). Set before numpy loads.
    Under MPI, each rank gets its share of the node's cores for its numba threads (unless
    NUMBA_NUM_THREADS is set). Idle threads sleep instead of spinning (OMP_WAIT_POLICY=PASSIVE
    unless set), so ranks, threads and other programs do not fight for cores: with one core
    busy elsewhere, two threads take 2.2 s on the quickstart like one thread, against 3.3 s
    spinning (benchmarks/busy_machine.py, docs/parallel.md)."""
    for var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS"):
        os.environ.setdefault(var, "1")
    from .parallel.comm import launched_with_mpi, ranks_on_this_node

    if launched_with_mpi():
        cores = usable_cores()
        os.environ.setdefault("NUMBA_NUM_THREADS", str(max(1, cores // ranks_on_this_node())))
    # idle numba threads sleep instead of spinning: a spinning thread holds a core another
    # process needs, and a thread that process preempts stalls the spinning one at the next
    # barrier (measured in benchmarks/busy_machine.py)
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


def main(argv: list[str] | None = None) -> int:
    """Run the command line; the logging set-up is undone on return (main may be called from
    Python, e.g. by tests)."""
    logger = logging.getLogger("peridyn")
    saved = (list(logger.handlers), logger.level, logger.propagate)
    try:
        return _main(argv)
    finally:
        logger.handlers[:] = saved[0]
        logger.setLevel(saved[1])
        logger.propagate = saved[2]


def _main(argv: list[str] | None) -> int:
    _single_threaded_blas()
    _quiet_floating_point()
    parser = build_parser()
    args = parser.parse_args(argv)
    debug = args.debug
    if not hasattr(args, "verbose"):
        args.verbose, args.quiet = 0, 0
    _LOG_JSON["on"] = bool(getattr(args, "log_json", False))
    if getattr(args, "no_limits", False):
        from .engine.limits import ENV

        os.environ[ENV] = "1"
    try:
        from .engine.output_paths import refuse_empty_arguments

        refuse_empty_arguments(args)
        return int(args.func(args))
    except InputError as exc:
        if debug:
            raise
        _report_input_error(exc)
        return int(ExitCode.INPUT_ERROR)
    except InstabilityError as exc:
        if debug:
            raise
        say("error", str(exc))
        say("", "the output written so far is kept and readable")
        return int(ExitCode.UNSTABLE)
    except OutputWriteError as exc:
        if debug:
            raise
        say("error", str(exc))
        return int(exc.exit_code)
    except KeyboardInterrupt:
        say("", "interrupted")
        return int(ExitCode.INTERRUPTED)
    except BrokenPipeError:  # `peridyn check deck | head`: the reader has gone; nothing to report
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return int(ExitCode.OK)
    except OSError as exc:
        import errno

        if debug or exc.errno not in (errno.ENAMETOOLONG, errno.ELOOP, errno.EILSEQ):
            if debug:
                raise
            say("internal error", f"{type(exc).__name__}: {exc} (run with --debug for the traceback; please report it)")
            return int(ExitCode.FAILURE)
        name = str(exc.filename or "")
        shown = name if len(name) <= 80 else name[:40] + "..." + name[-30:]
        say("error", f"{shown}: {exc.strerror}; give a shorter path (each name at most 255 bytes) or one without link loops")
        return int(ExitCode.INPUT_ERROR)
    except UnicodeEncodeError as exc:
        if debug:
            raise
        path = ascii(exc.object) if isinstance(exc.object, str) else "a path"
        shown = path if len(path) <= 80 else path[:40] + "..." + path[-30:]
        say("error", f"{shown}: holds characters that are not UTF-8 ({exc.object[exc.start:exc.end]!a}); rename it with UTF-8 characters")
        return int(ExitCode.INPUT_ERROR)
    except MemoryError as exc:
        if debug:
            raise
        say("error", f"{getattr(args, 'deck', '')}: the model does not fit in memory ({exc}); use fewer points or a smaller horizon")
        return int(ExitCode.INPUT_ERROR)
    except PeridynError as exc:
        if debug:
            raise
        say("error", str(exc))
        return int(exc.exit_code)
    except Exception as exc:  # a bug: say so, show the traceback only with --debug
        if debug:
            raise
        say("internal error", f"{type(exc).__name__}: {exc} (run with --debug for the traceback; please report it)")
        return int(ExitCode.FAILURE)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
