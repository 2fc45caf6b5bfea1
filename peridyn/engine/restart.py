"""Checkpoints of a run and runs continued from them (``Restart`` section, ``peridyn run
--restart``; docs/restart.md).

A checkpoint is one ``.npz`` file holding everything the rest of the run depends on, in global
(mothership) order so that any number of ranks can read it:

* every allocated field, NP1 and N of two-step ones: point fields as (num_global, ...) rows,
  bond fields as rows sorted by the key ``i * num_global + j`` of the bond's two mothership
  indices (``bond_keys``; a model without bond fields stores only their order-free digest,
  ``bond_digest``, and gathers nothing of its bonds), global fields as they are;
* the acceleration of the last dynamic step; under MPI each rank's ghost rows as well
  (``r<rank>/...``), so a restart on the same number of ranks continues bit for bit;
* time, the solver section and step, every output writer's counter and frame count, the energy
  monitor's accumulators, the contact search's reference positions and the positions its pair
  lists were built at (the lists are rebuilt from them), and a hash of the deck.

``rnd()`` in expressions is a pure hash of the seed and the point's global id (no generator
state), and damage and material state lives in fields, so nothing else is kept.

A checkpoint is written to a temporary file in the same folder, flushed and fsync'ed, renamed
over its final name (``os.replace``) and the folder fsync'ed: a run killed at any moment leaves
the previous checkpoint or the new one, never a torn file.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
import logging
import os
import re
import shlex
import signal
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError, OutputWriteError, PeridynError
from ..core.fields import Relation, Temporal
from ..core.services import OutputFiles
from ..core.state import SolverState
from .checkpoint_check import FORMAT, bond_digest, bond_keys as _bond_keys

log = logging.getLogger("peridyn.restart")

#: under MPI the ranks agree on a pending signal every this many steps (a reduction)
SIGNAL_CHECK_EVERY = 16
#: monitor attributes rebuilt from the model at a restart, not stored
_MONITOR_DERIVED = ("sim", "mass", "free", "_empty", "_rows", "batch", "_step")
_NAME = re.compile(r"^(?P<stem>.+)\.(?P<section>\d{3})\.(?P<step>\d{10})\.npz$")


class RunInterrupted(PeridynError):
    """The run was stopped by SIGTERM or SIGINT after writing a checkpoint (exit 128 + signal:
    143 for SIGTERM, 130 for SIGINT, the shells' convention)."""

    def __init__(self, message: str, signum: int, collective: bool = True) -> None:
        super().__init__(message)
        self.signum = signum
        self.exit_code = 128 + int(signum)  # type: ignore[assignment]
        #: every rank raised it after the same step (else: this rank alone, from the signal handler)
        self.collective = collective


def deck_hash(deck) -> str:
    """SHA-256 of the deck's tree without its ``Restart`` section: a checkpoint continues only
    the deck that wrote it (its Restart keys may change between the runs)."""
    tree = {k: v for k, v in deck.source.tree.items() if k != "Restart"}
    text = json.dumps(tree, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def checkpoint_name(stem: str, section: int, step: int) -> str:
    """``STEM.SSS.NNNNNNNNNN.npz``: solver section ``section`` (0-based) after its step ``step``;
    step 0 means the section has not started (the sections before it are done)."""
    return f"{stem}.{section:03d}.{step:010d}.npz"


def checkpoints_of(folder: Path, stem: str) -> list[tuple[tuple[int, int], Path]]:
    """The deck ``stem``'s checkpoints in ``folder``, ((section, step), path), oldest first."""
    found = []
    if folder.is_dir():
        for p in folder.iterdir():
            m = _NAME.match(p.name)
            if m and m["stem"] == stem:
                found.append(((int(m["section"]), int(m["step"])), p))
    return sorted(found)


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot store {type(value).__name__} in a checkpoint")


class Checkpoints:
    """What a run of ``sim`` with output ``files`` does about checkpoints: writes them (a deck
    with a ``Restart`` section), and continues from one (``--restart``). The run's
    ``checkpoints``: solvers call :meth:`begin_section`, :meth:`resume`, :meth:`after_step`
    and :meth:`end_section`."""

    def __init__(self, sim, files: OutputFiles, params=None) -> None:
        self.sim, self.files = sim, files
        self.params = params  #: RestartParams, or None: no checkpoint is written
        self.folder = sim.output_dir / (params.folder if params is not None else "restart")
        self.stem = Path(sim.deck.file).stem
        self.hash = deck_hash(sim.deck)
        self.section = 0
        self.dt: float | None = None
        self.polling = False  #: a Verlet loop checks for signals at its step ends
        self.writing = False
        self._signal = 0
        self._handlers: dict[int, Any] = {}
        self._resume: dict | None = None  #: the checkpoint continued from, until its section starts
        self.last_written: Path | None = None

    # -- signals ---------------------------------------------------------------------------------
    def install_signals(self) -> None:
        """SIGTERM and SIGINT write a checkpoint at the end of the current step (a batch system
        sends SIGTERM before the wall-time limit) and stop the run; outside an explicit loop
        they stop it at once. Only with a Restart section, only in the main thread."""
        if self.params is None or threading.current_thread() is not threading.main_thread():
            return
        for signum in (signal.SIGTERM, signal.SIGINT):
            self._handlers[signum] = signal.signal(signum, self._on_signal)

    def remove_signals(self) -> None:
        for signum, old in self._handlers.items():
            signal.signal(signum, old)
        self._handlers.clear()

    def _on_signal(self, signum, frame) -> None:
        self._signal = max(self._signal, int(signum))
        if self.polling or self.writing:
            return  # a checkpoint at the end of this step (or after the one being written)
        where = f"; the last checkpoint is {self.last_written}: continue with '{continue_command(self.sim)}'" if self.last_written else ""
        raise RunInterrupted(f"stopped by {signal.Signals(signum).name} outside an explicit step loop{where}", signum, collective=False)

    def _agreed_signal(self, step: int, due: bool) -> int:
        comm = self.sim.comm
        if comm.size == 1:
            return self._signal
        if due or step % SIGNAL_CHECK_EVERY == 0:
            return int(comm.allreduce_max(self._signal))
        return 0

    # -- what the solvers call -------------------------------------------------------------------
    def begin_section(self, k: int, solver) -> bool:
        """Solver section ``k`` starts; False when it was done before the checkpoint continued."""
        self.section = k
        r = self._resume
        if r is not None:
            if k < r["section"]:
                return False
            if r["step"] == 0 or k > r["section"]:
                self._resume = None  # the checkpoint is this section's start: run it from there
        return True

    def resume(self, solver, dt: float):
        """Called as a Verlet loop starts: (the last step done, its energy monitor) when the run
        continues from a checkpoint inside this section, else None."""
        self.dt = dt
        solvers = self.sim.deck.solvers
        # a QuasiStatic section's "Switch to Verlet" continuation is not a section of its own:
        # no checkpoint inside it, and a signal stops it at once
        self.polling = self.params is not None and self.section < len(solvers) and solvers[self.section].section == solver.section
        r = self._resume
        if r is None or r["section"] != self.section:
            return None
        if r.get("dt") != dt:
            raise InputError(f"the checkpoint's time step {r.get('dt')!r} differs from this run's {dt!r}", file=self.sim.deck.file,
                             path=(solver.section, "Verlet"), fix="restart on the machine and deck that wrote it")
        self._resume = None
        return int(r["step"]), _restore_monitor(self.sim, r["monitor"])

    def after_step(self, step: int, monitor, where) -> None:
        """End of Verlet step ``step`` (after the output and the swap of N and NP1): a
        checkpoint of the model and the solver state every ``Restart Frequency`` steps, and on a
        signal (then RunInterrupted). ``where``: the step's
        :class:`~peridyn.core.placement.Placement`, whose arrays (a GPU run's) are brought to
        the host before a checkpoint of its solver state is written."""
        p = self.params
        if p is None or not self.polling:
            return
        due = p.restart_frequency > 0 and step % p.restart_frequency == 0
        signum = self._agreed_signal(step, due)
        if due or signum:
            monitor.flush()  # the accumulators of every step so far (MPI batches them)
            where.to_host()
            self.write(self.section, step, where.state, monitor)
        if signum:
            raise self._interrupted(signum, step)

    def end_section(self, k: int, solver, state: SolverState) -> None:
        """Solver section ``k`` is done, leaving ``state``: a checkpoint at the next section's start."""
        self.polling = False
        if self.params is None:
            return
        self.write(k + 1, 0, state)
        signum = int(self.sim.comm.allreduce_max(self._signal)) if self.sim.comm.size > 1 else self._signal
        if signum:
            raise self._interrupted(signum, None)

    def _interrupted(self, signum: int, step: int | None) -> RunInterrupted:
        name = signal.Signals(signum).name
        sim = self.sim
        at = f"after step {step} of solver section {self.section + 1}" if step is not None else f"after solver section {self.section + 1}"
        return RunInterrupted(f"stopped by {name} {at} (t = {sim.clock.time:.6g}); checkpoint {self.last_written} written: continue with "
                              f"'{continue_command(sim)}'", signum)

    # -- writing ---------------------------------------------------------------------------------
    def write(self, section: int, step: int, state: SolverState, monitor=None) -> Path | None:
        """Write the checkpoint of the model and ``state`` at (``section``, ``step``);
        collective (rank 0 writes)."""
        sim = self.sim
        self.writing = True
        t0 = time.perf_counter()
        try:
            meta, arrays = self._collect(section, step, state, monitor)
            path = None
            if sim.comm.is_root:
                path = self.folder / checkpoint_name(self.stem, section, step)
                try:
                    _write_atomic(path, meta, arrays)
                except OSError as exc:
                    raise OutputWriteError(f"writing the checkpoint {path} failed ({exc.strerror or exc}); the previous "
                                           "checkpoints are left as they were") from None
                self._prune((section, step))
                log.info("checkpoint %s (t = %.6g; %.1f MB in %.2f s)", path, state.time, path.stat().st_size / 1e6, time.perf_counter() - t0)
            self.last_written = self.folder / checkpoint_name(self.stem, section, step)
            return path
        finally:
            self.writing = False

    def _prune(self, now: tuple[int, int]) -> None:
        """Remove this deck's checkpoints after ``now`` (an earlier history) and all but the
        latest ``Keep``."""
        found = checkpoints_of(self.folder, self.stem)
        stale = [p for pos, p in found if pos > now]
        current = [p for pos, p in found if pos <= now]
        for p in stale + current[: max(0, len(current) - self.params.keep)]:
            try:
                p.unlink()
            except OSError:
                pass

    def _collect(self, section: int, step: int, state: SolverState, monitor) -> tuple[dict, dict[str, np.ndarray]]:
        """Gather the state in global order on rank 0 (collective): (meta, arrays); the arrays
        are empty on the other ranks."""
        sim = self.sim
        comm = sim.comm
        root = comm.is_root
        n, total = sim.num_owned, sim.num_global
        owned = sim.mothership_of_local[:n]
        arrays: dict[str, np.ndarray] = {}
        parallel = comm.size > 1

        def point(key: str, values: np.ndarray) -> None:
            full = comm.gather_points(np.ascontiguousarray(values[:n]), owned, total)
            ghosts = comm.gather(np.ascontiguousarray(values[n:])) if parallel else None
            if root:
                arrays[key] = full
                if parallel:
                    for r, g in enumerate(ghosts):
                        arrays[f"r{r}/{key}"] = g

        kinds: dict[str, str] = {}
        store = sim.fields
        order, digest = None, None
        names = sorted(nm for nm in store.names() if nm not in store.derived)  # derived ones are refilled at set-up
        if any(store.specs[nm].relation is Relation.BOND for nm in names):
            gathered = comm.gather(_bond_keys(sim))
            if root:
                all_keys = np.concatenate(gathered)
                order = np.argsort(all_keys, kind="stable")
                arrays["bond_keys"] = all_keys[order]
        else:  # no bond field to place: the bonds are checked by their digest, nothing gathered
            digest = bond_digest(sim)
        for name in names:
            spec = store.specs[name]
            layers = [("np1", store[name])] + ([("n", store.n(name))] if spec.temporal is Temporal.TWO_STEP else [])
            for which, arr in layers:
                key = f"{which}/{name}"
                if spec.relation is Relation.BOND:
                    kinds[name] = "bond"
                    parts = comm.gather(np.ascontiguousarray(arr))
                    if root:
                        arrays[key] = np.concatenate(parts)[order]
                elif spec.relation is Relation.GLOBAL:
                    kinds[name] = "global"
                    if root:
                        arrays[key] = np.array(arr, copy=True)
                else:
                    kinds[name] = "point"
                    point(key, arr)
        if state.acceleration is not None:
            point("acceleration", state.acceleration)
        contact = None
        c = sim.contact
        if c is not None:
            point("contact/s", c.s)
            if c.y_build is not None:
                point("contact/y_build", c.y_build[:n])
            contact = {"capacity": int(c.capacity), "stats": dict(c.stats)}
        meta = {
            "format": FORMAT,
            "deck": str(sim.deck.file),
            "deck_hash": self.hash,
            "written": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "ranks": comm.size,
            "num_global": int(total),
            "num_bonds_global": int(sim.num_bonds_global),
            "section": int(section),
            "step": int(step),
            "sections": len(sim.deck.solvers),
            "dt": self.dt if step > 0 else None,
            "time": state.time,
            "time_prev": state.time_prev,
            "time_step": sim.time_step,
            "nonlinear_iterations": int(state.nonlinear_iterations),
            "fields": kinds,
            "two_step": sorted(nm for nm in kinds if store.specs[nm].temporal is Temporal.TWO_STEP),
            "writers": [{"section": w.entry.section, "count": int(w.count), "frames": int(w.frames)} for w in self.files.writers],
            "monitor": ({k: v for k, v in vars(monitor).items() if k not in _MONITOR_DERIVED} if monitor is not None else None),
            "contact": contact,
            "final_time": float(sim.deck.solvers[-1].params.final_time) if sim.deck.solvers else None,
            "relations": {nm: store.specs[nm].relation.name for nm in kinds},
        }
        if digest is not None:
            meta["bond_digest"] = digest
        if root:
            meta["arrays"] = sorted(arrays)  # every one is required back (a deleted one would be computed afresh)
        return meta, arrays

    # -- reading ---------------------------------------------------------------------------------
    def load(self, path: Path, state: SolverState) -> None:
        """Put the checkpoint ``path`` into the freshly set-up model and into ``state`` (the
        run's solver state, handed to its first section); InputError (one line, the same on
        every rank) for a checkpoint this run cannot continue, before anything changes."""
        from .checkpoint_check import agree, check_checkpoint, read_checkpoint

        digest = bond_digest(self.sim)  # collective: before any rank may refuse

        def checked() -> tuple[dict, dict, bool]:
            meta, arrays = read_checkpoint(path)
            carry = self._check(path, meta)
            check_checkpoint(self.sim, self.files.writers, path, meta, arrays, carry, digest)
            return meta, arrays, carry

        meta, data, carry = agree(self.sim.comm, checked)
        self._restore(data, meta, state, carry=carry)
        self.last_written = path
        if carry:
            log.info("starting from the state at the end of %s (t = %.6g), read from %s", Path(meta["deck"]).name, meta["time"], path)
            return
        self._resume = meta
        if self.params is not None and self.sim.comm.is_root:  # later checkpoints are of the history dropped here
            self._prune((int(meta["section"]), int(meta["step"])))
        log.info("continuing from %s: solver section %d, %s (t = %.6g)", path, meta["section"] + 1,
                 f"after step {meta['step']}" if meta["step"] else "at its start", meta["time"])

    def _check(self, path: Path, meta: dict) -> bool:
        """Refuse (InputError) a checkpoint this run cannot use; True when it is the end of
        another deck's run that this deck continues (Peridigm's restart: see :func:`carries_on`)."""
        from .checkpoint_check import refusal

        sim = self.sim
        carry = meta["deck_hash"] != self.hash
        if carry and not carries_on(meta, sim.deck):
            raise refusal(path, f"written by another deck ({Path(meta['deck']).name}), or by this one before it was changed, and it is not "
                          "the end of a run whose last Final Time is this deck's first Initial Time",
                          "restart with the deck that wrote it, unchanged but for its Restart section, or without --restart")
        if meta["num_global"] != sim.num_global or meta["num_bonds_global"] != sim.num_bonds_global:
            raise refusal(path, f"{meta['num_global']} points and {meta['num_bonds_global']} bonds, this model {sim.num_global} and "
                          f"{sim.num_bonds_global}", "restart with the mesh files that run read")
        if sim.interfaces is not None:
            raise refusal(path, "Construct Interfaces (Interfaces.e) is not continued by a restart", "run the deck from its start")
        if not carry and meta["sections"] != len(sim.deck.solvers):
            raise refusal(path, f"{meta['sections']} solver section(s), this deck {len(sim.deck.solvers)}", "restart with the deck that wrote it")
        missing = [nm for nm in meta["fields"] if nm not in sim.fields]
        if missing and not carry:
            raise refusal(path, f"holds fields this model does not declare ({', '.join(missing[:4])})", "restart with the deck that wrote it")
        return carry

    def _restore(self, data, meta: dict, state: SolverState, carry: bool = False) -> None:
        """Put the checkpoint into the model and ``state``. ``carry``: another deck's final state,
        whose fields this model shares are taken (its outputs, contact lists and monitor start
        afresh)."""
        sim = self.sim
        comm = sim.comm
        n = sim.num_owned
        local = sim.mothership_of_local
        same = meta["ranks"] == comm.size and comm.size > 1 and not carry  # ghost rows as they were

        def point(key: str, target: np.ndarray) -> None:
            target[...] = data[key][local]
            if same:
                target[n:] = data[f"r{comm.rank}/{key}"]

        store = sim.fields
        keys = None
        for name, kind in meta["fields"].items():
            if name in store.derived:
                continue  # refilled from the reference configuration (an older checkpoint holds it)
            if carry and (name not in store or store.specs[name].relation.name != meta.get("relations", {}).get(name, store.specs[name].relation.name)):
                continue
            two_step = store.specs[name].temporal is Temporal.TWO_STEP and name in meta["two_step"]
            for which in ["np1"] + (["n"] if two_step else []):
                target = store[name] if which == "np1" else store.n(name)
                key = f"{which}/{name}"
                if carry and (key not in data or data[key].shape[1:] != target.shape[1:]):
                    continue  # another deck's field of another length
                if kind == "point":
                    point(key, target)
                elif kind == "global":
                    target[...] = data[key]
                else:
                    if keys is None:
                        keys = _bond_index(sim, data["bond_keys"])
                    target[...] = data[key][keys]
        if "acceleration" in data:
            state.acceleration = np.zeros((sim.num_local, 3))
            point("acceleration", state.acceleration)
        state.time, state.time_prev = meta["time"], meta["time_prev"]
        sim.set_time_step(meta["time_step"])
        state.nonlinear_iterations = meta["nonlinear_iterations"]
        if not same:
            sim.exchange_halo_fields()
        c = sim.contact
        if carry:
            if c is not None:  # search from the carried positions, as a search at step 0 would
                np.copyto(c.s, store["Coordinates"][:n])
            return
        if c is not None and meta["contact"] is not None:
            c.s[...] = data["contact/s"][local[:n]]
            if "contact/y_build" in data:  # rebuild the pair lists at the positions they were built at
                y = store["Coordinates"]
                saved = y.copy()
                y[:n] = data["contact/y_build"][local[:n]]
                c.pairs = None
                c._build(c._current_state(state.time))
                np.copyto(y, saved)
            c.capacity = int(meta["contact"]["capacity"])
            c.stats = dict(meta["contact"]["stats"])
        self._restore_outputs(meta)

    def _restore_outputs(self, meta: dict) -> None:
        """Keep each output file's frames up to the checkpoint, drop later ones, append after."""
        from ..io.exodus_writer import keep_steps

        sim = self.sim
        for w, state in zip(self.files.writers, meta["writers"]):  # checked by checkpoint_check.check_outputs
            w.count, w.frames = int(state["count"]), int(state["frames"])
            if not w.frames:
                continue  # the file is (re)written from its start at the next frame
            if sim.comm.is_root:
                partial, final = w.partial_path, w.path
                source = partial if partial.is_file() else final
                if source == final and final.is_file():
                    # append to a copy: NAME.e stays as it was until the continued run ends (an input error
                    # found later in the set-up, or a crash, must not cost the earlier result)
                    import shutil

                    tmp = partial.with_name(f".{partial.name}.{os.getpid()}.tmp")
                    try:
                        shutil.copy2(final, tmp)
                        os.replace(tmp, partial)
                    except OSError as exc:
                        tmp.unlink(missing_ok=True)
                        raise InputError(f"cannot copy {final.name} to append to it: {exc.strerror}", file=sim.deck.file,
                                         path=("--restart",), fix="free space in the output folder") from None
                    source = partial
                try:
                    held = keep_steps(source, w.frames)
                except (OSError, ValueError) as exc:
                    if source == partial and final.is_file():
                        partial.unlink(missing_ok=True)
                    raise InputError(f"cannot continue {final.name}: {exc}", file=sim.deck.file, path=("--restart",),
                                     fix="give the --output-dir of the run that wrote the checkpoint") from None
                if held > w.frames:
                    log.info("%s: %d frame(s) written after the checkpoint dropped", partial.name, held - w.frames)
            w.resume_frames = w.frames
            try:
                w._open()
            except (OSError, ValueError, RuntimeError) as exc:
                raise InputError(f"cannot append to {w.partial_path.name}: {exc}", file=sim.deck.file, path=("--restart",),
                                 fix="restart with the deck that wrote it") from None


# ------------------------------------------------------------------------------------------------
def attach(sim, files: OutputFiles, restart_arg: str | None, state: SolverState) -> Checkpoints | None:
    """The checkpoints (the run's ``checkpoints`` service) of a deck with a Restart section or a
    run given ``--restart`` (``restart_arg``: a checkpoint path, or "latest") whose output files
    are ``files``; load the checkpoint into the model, the files' counters and the run's solver
    state ``state``. Collective only through the contact pair rebuild."""
    params = sim.deck.restart
    if params is None and restart_arg is None:
        return None
    cp = Checkpoints(sim, files, params)
    if restart_arg is None:  # Peridigm: a deck with a Restart section continues the state a previous deck left
        restart_arg = peridigm_continuation(cp.folder, sim.deck, cp.stem)
        if restart_arg is not None:
            restart_arg = str(restart_arg)
    if restart_arg is not None:
        if restart_arg == "latest":
            found = checkpoints_of(cp.folder, cp.stem)
            if not found:
                raise InputError(f"no checkpoint of {cp.stem} in {str(cp.folder)!r}", file=sim.deck.file, path=("--restart",),
                                 fix="give the checkpoint's path, or the --output-dir of the run that wrote it")
            path = found[-1][1]
        else:
            path = Path(restart_arg)
        cp.load(path, state)
    return cp


def continue_command(sim) -> str:
    """The command line that continues this run from its latest checkpoint: the same number of
    ranks (``mpiexec -n N``), deck and output folder."""
    words = (["mpiexec", "-n", str(sim.comm.size)] if sim.comm.size > 1 else []) + ["peridyn", "run", str(sim.deck.file)]
    if Path(sim.output_dir).resolve() != Path.cwd().resolve():
        words += ["--output-dir", str(sim.output_dir)]
    return shlex.join(words + ["--restart"])


def carries_on(meta: dict, deck) -> bool:
    """Whether checkpoint ``meta`` is the end of a run (every solver section done) whose last
    Final Time is ``deck``'s first Initial Time (relative 1e-12): Peridigm's restart, where a
    second deck continues the state the first left (``readRestart`` refuses other times)."""
    if meta.get("section") != meta.get("sections") or meta.get("final_time") is None or not deck.solvers:
        return False
    t0, t1 = float(deck.solvers[0].params.initial_time), float(meta["final_time"])
    return abs(t0 - t1) <= 1e-12 * max(abs(t0), abs(t1), 1e-300)


def peridigm_continuation(folder: Path, deck, stem: str) -> Path | None:
    """The checkpoint a Peridigm deck with a Restart section reads without ``--restart``: the
    newest end-of-run checkpoint of another deck in ``folder`` that this deck continues
    (:func:`carries_on`), as Peridigm reads the newest ``restart-*`` folder; None if none."""
    if not folder.is_dir() or not deck.solvers or float(deck.solvers[0].params.initial_time) == 0.0:
        return None
    from .checkpoint_check import read_meta

    found = []
    for path in folder.glob("*.npz"):
        m = _NAME.match(path.name)
        if m is None or m["stem"] == stem or int(m["step"]) != 0:
            continue
        meta = read_meta(path)
        if meta is not None and carries_on(meta, deck):
            found.append((path.stat().st_mtime, path))
    return max(found)[1] if found else None


def _write_atomic(path: Path, meta: dict, arrays: dict[str, np.ndarray]) -> None:
    """Write to a temporary file beside ``path``, fsync, rename over ``path``, fsync the folder."""
    folder = path.parent
    folder.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    umask = os.umask(0)
    os.umask(umask)
    try:
        os.fchmod(fd, 0o666 & ~umask)  # as an ordinary file (mkstemp makes it 0600)
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, meta=np.array(json.dumps(meta, default=_json_default)), **arrays)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    dfd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(dfd)
    finally:
        os.close(dfd)


def _bond_index(sim, saved_keys: np.ndarray) -> np.ndarray:
    """Position in the checkpoint's sorted ``bond_keys`` of every bond of this rank."""
    keys = _bond_keys(sim)
    idx = np.searchsorted(saved_keys, keys)
    ok = idx < saved_keys.size
    if not (ok.all() and np.array_equal(saved_keys[idx], keys)):
        raise InputError("the checkpoint's bonds are not this model's", file=sim.deck.file, path=("--restart",),
                         fix="restart with the deck and mesh that wrote it")
    return idx


def _restore_monitor(sim, state: dict):
    """The energy monitor of the checkpoint's step, on this model (any number of ranks)."""
    from ..solvers.monitors.energy import EnergyMonitor

    m = EnergyMonitor.__new__(EnergyMonitor)
    n = sim.num_owned
    m.sim = sim
    m.mass = sim.fields["Volume"][:n] * sim.density_per_point()[:n]
    m.free = np.ascontiguousarray(~sim.prescribed_dofs[:n])
    m._empty = np.zeros((0, 3))
    m._rows = []
    m.batch = 1 if sim.comm.size == 1 else 16
    vars(m).update(state)
    return m  # placed by the Verlet loop that continues
