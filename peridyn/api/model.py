"""``Model``: a deck's simulation driven from Python: run, step, fields in mesh order, boundary
conditions and computes given as Python callables.

Point order: every array the API takes or returns is in *mesh order*, the order of the points
in the discretization (the Exodus node order of the output files); ``model.ids`` holds their
1-based global ids (``Element_Id`` in the output). Internally the engine keeps its own order
(blocks, then a space-filling curve); the API maps between the two.
"""
from __future__ import annotations

import logging
import math
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Union

import numpy as np

from ..core.errors import InputError, PeridynError
from ..core.fields import Temporal
from ..core.services import RunServices
from ..deck.model import tidy
from ..solvers.explicit.verlet import Verlet
from .checks import (ArgumentError, ArgumentTypeError, UnknownNameError, a_callable, finite_number, name_text, real_array,
                     region_mapping, whole_number)
from .decks import DeckLike, build_deck, point_indices, points_deck

log = logging.getLogger("peridyn.api")

#: a node set: a deck node-set name, a region mapping (``{"Half Space": {...}}``, docs/regions.md,
#: with the regions' round-off tolerance), 0-based mesh indices, a (n,) bool mask in mesh order,
#: or a callable of the (n, 3) reference positions returning such a mask
NodesLike = Union[str, Mapping, np.ndarray, list, Callable[[np.ndarray], np.ndarray]]


class RunEnded(PeridynError):
    """The model's solvers have all run (or the run was stopped by an error): nothing to step."""


class _PythonValue:
    """A condition's value as a Python callable ``f(t, x) -> (k,)``, with the call signature of a
    compiled deck expression (``expr(gid, x=, y=, z=, t=)``)."""

    def __init__(self, fn: Callable[[float, np.ndarray], Any], call: str = "Model.add_condition") -> None:
        self.fn = fn
        self.call = call

    def __call__(self, gid, *, x, y, z, t):
        from .checks import ArgumentError, ArgumentTypeError

        out = self.fn(float(t), np.stack([x, y, z], axis=1))
        try:
            arr = np.asarray(out, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ArgumentTypeError(f"value(t, x) returned {type(out).__name__} {repr(out)[:60]}, not numbers ({exc})",
                                    path=(self.call, "value"), fix="return one number or one number per point of x") from None
        if arr.ndim > 1 or (arr.ndim == 1 and arr.shape[0] not in (1, len(x))):
            raise ArgumentError(f"value(t, x) returned shape {arr.shape} for {len(x)} points, expected () or ({len(x)},)",
                                path=(self.call, "value"), fix="return one number or one number per point of x")
        return arr


class Model:
    """A simulation built from a deck, advanced from Python.

    ``deck``: a deck file (YAML or Peridigm XML), a dict deck (the YAML tree, no file), or a
    validated ``Deck``. ``output_dir``: where the deck's output files go (created with its
    parents when missing; default: the current folder). ``directory``: the folder relative file
    names of a dict deck are read from (default: the current folder). ``write_files=False``:
    outputs write nothing. ``backend``, ``device``, ``restart`` (a checkpoint path or "latest"): as
    ``peridyn run --backend/--device/--restart``; a deck with a ``Restart`` section writes its
    checkpoints (docs/restart.md).

    The run follows the deck's solver sections in order, exactly as ``peridyn run`` does (the
    same operations, bit for bit). ``run()`` runs to the end, ``run(until=t)`` and ``step(n)``
    advance an explicit (Verlet) section step by step, on the CPU or the GPU. The output files are complete when
    the last section ends, or on ``close()`` (the frames written so far).
    """

    def __init__(self, deck: DeckLike, *, output_dir: str | os.PathLike | None = None, directory: str | os.PathLike | None = None,
                 write_files: bool = True, progress: bool = False, backend: str | None = None, device: str | None = None,
                 restart: str | os.PathLike | None = None) -> None:
        from ..engine.session import RunSession

        for arg, value in (("backend", backend), ("device", device)):
            if value is not None and not isinstance(value, str):
                raise ArgumentTypeError(f"{arg} must be a name (str) or None, not {type(value).__name__} {value!r}", path=("Model", arg),
                                        fix=f"give {arg} as text, e.g. " + ("'numba'" if arg == "backend" else "'cpu' or 'gpu'"))
        for arg, value in (("output_dir", output_dir), ("directory", directory), ("restart", restart)):
            if value is not None and not isinstance(value, (str, os.PathLike)):
                raise ArgumentTypeError(f"{arg} must be a folder name (str or os.PathLike), not {type(value).__name__} {value!r}",
                                        path=("Model", arg), fix=f"give {arg} as a path")
        self.deck = build_deck(deck, directory)
        self.output_dir = Path(output_dir) if output_dir is not None else Path.cwd()
        #: the run services (output folder and locks, checkpoints, signals, closing): those of ``peridyn run``
        self.session = RunSession(self.deck, output_dir=self.output_dir, progress=progress, write_files=write_files,
                                  backend=backend, device=device, restart=None if restart is None else os.fspath(restart), option="the output folder")
        #: the engine's Simulation (internal point order; see the module docstring)
        self.sim = sim = self.session.open()
        self._owned = sim.mothership_of_local[: sim.num_owned]
        self._plan: list | None = None
        self._section = 0  # index of the solver section that runs next (or now)
        self._generator = None  # the stepping section's generator
        self._started = False
        self._ended = False
        #: time steps (or whole non-explicit sections) taken so far
        self.steps_taken = 0
        self._computes: dict[str, tuple[Callable[["Model"], Any], int]] = {}
        self._history: dict[str, tuple[list[float], list[Any]]] = {}

    @classmethod
    def from_points(cls, x: np.ndarray, volume: np.ndarray | float, deck: Mapping, *, block_id: np.ndarray | int = 1,
                    node_sets: Mapping[str, Any] | None = None, **options: Any) -> "Model":
        """A model whose points are arrays: ``x`` (n, 3) reference positions (L), ``volume``
        (n,) or one number, cell volumes (L^3), ``block_id`` (n,) or one int (block ``k`` is
        named ``block_k`` in the deck's Blocks). ``deck``: a dict deck without a
        Discretization section (or one with only Influence Function / Bond Filters / Omit Bonds
        Between Blocks). ``node_sets``: name -> 0-based indices or (n,) bool mask, usable as
        ``Node Set`` in the deck. ``options``: as for ``Model``."""
        deck_obj = points_deck(x, volume, deck, block_id=block_id, node_sets=node_sets, directory=options.pop("directory", None))
        return cls(deck_obj, **options)

    # -- what the model is ----------------------------------------------------------------------
    @property
    def num_points(self) -> int:
        """Number of points n (every array of the API has n rows)."""
        return int(self.sim.num_global)

    @property
    def x(self) -> np.ndarray:
        """(n, 3) reference positions (L), mesh order (a copy)."""
        return self.sim.discretization.x.copy()

    @property
    def ids(self) -> np.ndarray:
        """(n,) 1-based global ids of the points, mesh order (``Element_Id`` of the output)."""
        return self.sim.discretization.gid + 1

    @property
    def time(self) -> float:
        """Current time (T): the time of the last step taken (the first section's initial time
        before any)."""
        if not self._started:
            plan = self._solvers()
            return float(plan[0][0].params.initial_time) if plan else 0.0
        return float(self.sim.clock.time)

    @property
    def dt(self) -> float:
        """Time step (T) of the section running now; before the first step, the step the first
        section will take, computed as its solver computes it (Verlet: the critical time step
        estimate or Fixed dt, times the Safety Factor; Implicit: its Fixed dt). A section whose
        steps are not known before it runs (QuasiStatic, NOXQuasiStatic, ...) is an
        ArgumentError saying so."""
        if self._started:
            return float(self.sim.time_step)
        plan = self._solvers()
        solver = plan[0][0]
        dt = solver.planned_time_step(self.sim)
        if dt is not None:
            return float(dt)
        raise ArgumentError(f"{solver.section}: {type(solver).__name__} chooses its steps as it runs; its time step is known after the "
                            "first step", path=("Model.dt",), fix="read model.dt after step() or run(until=...)")

    @property
    def finished(self) -> bool:
        """True when every solver section has run (or the run was stopped)."""
        return self._ended

    def node_set(self, name: str) -> np.ndarray:
        """0-based mesh indices of a node set of the deck or the mesh (sorted)."""
        sets = self.sim.node_sets
        key = tidy(name_text("Model.node_set", "name", name))
        if key not in sets:
            raise UnknownNameError(f"no node set {name!r}", path=("Model.node_set", "name"),
                                   fix=f"node sets: {', '.join(sorted(sets)) or 'none'}")
        return np.unique(sets[key])

    def select(self, region: Mapping) -> np.ndarray:
        """(n,) bool mask, mesh order: the points whose reference positions lie in ``region``, a
        region mapping as a deck's node set writes it (docs/regions.md), e.g.
        ``{"Half Space": {"Point": [0.003, 0, 0], "Normal": [-1, 0, 0]}}``. Boundaries are
        inclusive within 1e-4 of each point's spacing (``geometry.regions.TOLERANCE``), so a
        lattice plane on a face is selected whatever the round-off of its coordinates, and
        mirrored regions select mirrored points. Lengths in the deck's unit L."""
        return self._select(region, "Model.select", "region")

    def _select(self, region: Mapping, call: str, arg: str) -> np.ndarray:
        from ..geometry.regions import region_mask

        spec = region_mapping(call, arg, region)
        disc = self.sim.discretization
        return region_mask(spec, disc.x, disc.volume, path=(call, arg))

    # -- fields --------------------------------------------------------------------------------
    @property
    def field_names(self) -> list[str]:
        """Names of the point fields this run holds (only what its deck uses)."""
        store = self.sim.fields
        return sorted(n for n, spec in store.specs.items() if spec.is_point and store.allocated(n))

    def __getitem__(self, name: str) -> np.ndarray:
        return self.get(name)

    def __setitem__(self, name: str, values: Any) -> None:
        self.set(name, values)

    def get(self, name: str) -> np.ndarray:
        """A point field in mesh order, as a new array: (n,) for scalars, (n, k) otherwise;
        ``Damage``, ``Displacement``, ``Velocity``, ``Force_Density`` (F L^-6 per unit
        volume), ... with the deck's units. A two-step field gives its value at the last step."""
        array = self._field(name, "Model.get")
        out = np.zeros((self.num_points,) + array.shape[1:], dtype=array.dtype)
        out[self._owned] = array[: self.sim.num_owned]
        return out

    def set(self, name: str, values: Any) -> None:
        """Write a point field, ``values`` in mesh order ((n,) or (n, k), or anything that
        broadcasts to it; real, finite numbers, whole numbers for an integer field: anything else
        is an ArgumentError naming the field and the shape). Writing ``Displacement`` also moves ``Coordinates`` (= reference +
        displacement) and the reverse. Write before the first step to set an initial state; a
        write between steps changes the state the next step starts from (the energy check of an
        explicit run counts it as unexplained energy)."""
        array = self._field(name, "Model.set")
        new = real_array("Model.set", f"values of {name}", values, (self.num_points,) + array.shape[1:], array.dtype)
        targets = [array]
        spec = self.sim.fields.specs[name]
        if spec.temporal is Temporal.TWO_STEP:
            targets = [self.sim.fields[name], self.sim.fields.n(name)]
        local = new[self._owned]
        for target in targets:
            target[: self.sim.num_owned] = local
        f = self.sim.fields
        if name == "Displacement":
            f["Coordinates"][: self.sim.num_owned] = f["Model_Coordinates"][: self.sim.num_owned] + local
        elif name == "Coordinates":
            f["Displacement"][: self.sim.num_owned] = local - f["Model_Coordinates"][: self.sim.num_owned]
        self.sim.exchange_halo_fields()
        solver = self._solvers()[self._section][0] if self._generator is not None else None
        if isinstance(solver, Verlet) and solver.placed is not None:  # a GPU run's next step reads its device copies
            solver.placed.upload([name] + {"Displacement": ["Coordinates"], "Coordinates": ["Displacement"]}.get(name, []))

    def _field(self, name: str, call: str) -> np.ndarray:
        store = self.sim.fields
        spec = store.specs.get(name_text(call, "name", name))
        if spec is None or not spec.is_point or name not in store:
            raise UnknownNameError(f"no point field {name!r} in this run", path=(call, "name"), fix=f"fields: {', '.join(self.field_names)}")
        if spec.temporal is Temporal.TWO_STEP and self.steps_taken:
            return store.n(name)  # after a completed step N holds the newest values (N and NP1 swap)
        return store[name]

    # -- conditions and computes from Python --------------------------------------------------
    def add_condition(self, type: str, nodes: NodesLike, value: Callable[[float, np.ndarray], Any], *, coordinate: str = "x",
                      name: str | None = None) -> None:
        """A boundary condition whose value is a Python callable ``value(t, x) -> (k,)`` (or a
        number), evaluated exactly where the deck's expression would be: ``t`` the time (T),
        ``x`` the (k, 3) reference positions of the node set's points. ``type``: a deck
        boundary-condition Type (``"Prescribed Displacement"`` (L), ``"Body Force"``
        (F L^-3), ``"Initial Velocity"`` (L T^-1), ``"Initial Displacement"``,
        ``"Prescribed Temperature"``, ...); ``coordinate``: x, y or z. ``nodes``: see
        ``NodesLike``. Add conditions before the first step; initial conditions act at once."""
        if self._started:
            raise RunEnded("add conditions before the first step: the run has started")
        from pydantic import ValidationError

        from ..engine.conditions import BCParams, declare_condition_fields

        call = "Model.add_condition"
        sim = self.sim
        key = tidy(name_text(call, "type", type))
        registry = self.deck.registry
        try:
            cls = registry.get("boundary_condition", key, path=(call, "type"))
        except InputError as exc:
            raise ArgumentError(exc.message, path=(call, "type"), fix=exc.fix) from None
        if name is not None:
            name_text(call, "name", name)
        if not callable(value):
            value = finite_number(call, "value", value) if not isinstance(value, str) else a_callable(call, "value", value, "value(t, x) -> (k,) or a number")
        else:
            a_callable(call, "value", value, "value(t, x) -> (k,) or a number", nargs=2)
        label = name or f"python {type} {len(sim.conditions) + 1}"
        if not isinstance(coordinate, str):
            raise ArgumentTypeError(f"coordinate must be 'x', 'y' or 'z', not {coordinate!r}", path=(call, "coordinate"), fix="give 'x', 'y' or 'z'")
        try:
            params = BCParams.model_validate({"Type": type, "Node Set": label, "Coordinate": coordinate, "Value": 0.0})
        except ValidationError as exc:
            raise ArgumentError(f"coordinate {coordinate!r}: {exc.errors()[0]['msg']}", path=(call, "coordinate"),
                                fix="give 'x', 'y' or 'z'") from None
        problems = [p for p in cls.check(params) if not p.startswith("Value")]
        if problems:
            raise ArgumentError("; ".join(problems), path=(call, "coordinate"), fix="see the condition's Coordinate")
        cond = cls(params, entry_name=label)
        cond.params = params.model_copy(update={"value": f"<python {getattr(value, '__name__', 'callable')}>"})
        cond.expr = _PythonValue(value if callable(value) else (lambda t, x, c=float(value): np.full(len(x), c)))
        members = self._local_points(nodes, call)
        if members.size == 0:
            raise ArgumentError(f"{label}: the node set holds no point", path=(call, "nodes"), fix="give at least one point")
        cond.bind(members, sim.discretization.x[sim.mothership_of_local], sim.gid)
        declare_condition_fields(sim.fields, cond)
        sim.conditions.append(cond)
        if cond.stage == "initial":
            cond.apply_initial(sim)
            sim.exchange_halo_fields()
        elif cond.stage == "kinematic":
            sim.kinematic.append(cond)
            if cond.target == "displacement":
                sim.prescribe(cond.points, cond.component)
        elif cond.stage == "force":
            sim.force_conditions.append(cond)

    def _local_points(self, nodes: NodesLike, call: str) -> np.ndarray:
        """Owned local indices of ``nodes`` (sorted, unique)."""
        sim = self.sim
        if isinstance(nodes, str):
            mesh = self.node_set(nodes)
        elif isinstance(nodes, Mapping):
            mesh = np.nonzero(self._select(nodes, call, "nodes"))[0]
        else:
            if callable(nodes):
                a_callable(call, "nodes", nodes, "nodes(x) -> (n,) bool mask or indices", nargs=1)
            raw = nodes(self.sim.discretization.x.copy()) if callable(nodes) else nodes
            mesh = point_indices(call, "nodes", raw, self.num_points)
        local = sim.local_of_mothership[mesh]
        return np.unique(local[(local >= 0) & (local < sim.num_owned)])

    def add_compute(self, name: str, fn: Callable[["Model"], Any], *, every: int = 1) -> None:
        """A quantity computed by ``fn(model)`` after the initial state (step 0) and after every
        ``every``-th step (and after a whole non-explicit section), kept in ``history(name)``.
        ``fn`` may return a number or an array (e.g. a field in mesh order); it is copied."""
        call = "Model.add_compute"
        name_text(call, "name", name)
        a_callable(call, "fn", fn, "fn(model) -> number or array", nargs=1)
        every = whole_number(call, "every", every, 1)
        self._computes[name] = (fn, every)
        self._history.setdefault(name, ([], []))

    def history(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(times (m,), values (m, ...)) recorded by the compute ``name``."""
        if name not in self._history:
            raise UnknownNameError(f"no compute {name!r}", path=("Model.history", "name"), fix=f"computes: {', '.join(self._history) or 'none'}")
        times, values = self._history[name]
        return np.asarray(times, dtype=float), np.asarray(values)

    def _record(self, step: int, force: bool = False) -> None:
        for name, (fn, every) in self._computes.items():
            if force or step % every == 0:
                value = fn(self)
                self._history[name][0].append(float(self.sim.clock.time))
                self._history[name][1].append(np.array(value, copy=True) if isinstance(value, np.ndarray) else value)

    # -- running -------------------------------------------------------------------------------
    def _solvers(self) -> list:
        if self._plan is None:
            self._plan = self.sim.plan_solvers()
        return self._plan

    def _advance(self, whole_until: float | None) -> bool:
        """One time step, or a whole section that cannot be stepped when it ends at or before
        ``whole_until`` (T; None: never); False when every section has run."""
        if self._ended:
            return False
        plan = self._solvers()
        while True:
            if self._generator is None:
                if self._section >= len(plan):
                    self._finish(summary=True)
                    return False
                solver = plan[self._section][0]
                restart = self._services.checkpoints
                if restart is not None and not restart.begin_section(self._section, solver):
                    self._section += 1  # done before the checkpoint this run continues from
                    continue
                if isinstance(solver, Verlet):
                    self._started = True
                    # a GPU run's fields come back at every step, so that what a step(n) caller reads is current
                    self.sim.show_clock(self.session.state)
                    self._generator = solver.steps(self.sim, self.session.state, self._services, host_each_step=self.sim.device == "gpu")
                    self._guard(lambda: next(self._generator))  # step 0: forces and output at the initial time
                    self._record(0)
                    continue
                final = float(solver.params.final_time)
                if whole_until is None or final > whole_until * (1.0 + 1e-12):
                    raise RunEnded(f"{solver.section}: {type(solver).__name__} runs as one piece, "
                                   f"to t = {final:.6g}; use run() or run(until=t) with t at or after its end (stepping needs "
                                   "an explicit Verlet section)")
                self._started = True
                from ..engine.session import run_section

                self.session.state = self._guard(lambda: run_section(self.sim, solver, self.session.state, self._services))
                self._end_section(solver)
                self.steps_taken += 1
                self._record(0, force=True)
                return True
            try:
                step = self._guard(lambda: next(self._generator))
            except StopIteration:
                self._generator = None
                self._end_section(plan[self._section][0])
                continue
            self.steps_taken += 1
            self._record(step)
            if step == plan[self._section][1]:  # the section's last step: let it finish (statistics, energy verdict)
                generator = self._generator
                self._guard(lambda: [None for _ in generator])
                self._generator = None
                self._end_section(plan[self._section][0])
                if self._section >= len(plan):
                    self._finish(summary=True)
            return True

    @property
    def _services(self) -> RunServices:
        """The run's output files, checkpoints and progress (the session's, made with the model)."""
        services = self.session.services
        assert services is not None  # the session was opened in __init__
        return services

    def _end_section(self, solver) -> None:
        """The section now running has ended: its checkpoint (with a Restart section), the next."""
        restart = self._services.checkpoints
        if restart is not None:
            self._guard(lambda: restart.end_section(self._section, solver, self.session.state))
        self._section += 1

    def _guard(self, action: Callable[[], Any]) -> Any:
        """Run ``action``; on an error close the outputs as ``peridyn run`` does (an unstable run
        keeps its frames under the final name) and end the run."""
        from ..engine.session import keeps_output

        try:
            return action()
        except StopIteration:
            raise
        except BaseException as exc:
            self._finish(complete=keeps_output(exc, self.sim.comm.size))
            raise

    def _finish(self, complete: bool = True, summary: bool = False) -> None:
        if self._ended:
            return
        self._ended = True
        self._generator = None
        self.session.close(complete=complete, summary=summary)

    def step(self, n: int = 1) -> "Model":
        """Take ``n`` time steps of the explicit section running now (its first call also does
        the section's step 0: forces and output at the initial time). ``n``: a whole number >= 0.
        Returns the model."""
        n = whole_number("Model.step", "n", n, 0)
        for _ in range(n):
            if not self._advance(None):
                raise RunEnded(f"the run has ended after {self.steps_taken} steps, at t = {self.time:.6g}")
        return self

    def run(self, until: float | None = None) -> "Model":
        """Run every remaining solver section to its end (``until`` None; the output files are
        then complete), or step until the first step whose time is at or after ``until`` (T,
        within 1e-9 of a step); a section that cannot be stepped (not Verlet on the CPU) runs
        whole when it ends at or before ``until``, else RunEnded. Returns the model."""
        if until is None:
            while self._advance(math.inf):
                pass
            return self
        until = finite_number("Model.run", "until", until)
        if until < self.time:
            raise ArgumentError(f"until = {until!r} is before the current time {self.time!r}", path=("Model.run", "until"),
                                fix="give a time at or after model.time, or None to run to the end")
        while not self._ended:
            if self._started and self.sim.clock.time >= until - 1e-9 * max(self.sim.time_step, 0.0):
                break
            if not self._advance(until):
                break
        return self

    def close(self) -> None:
        """Close the output files (the frames written so far, under their final names) and
        release the output folder. Also done at the end of the last section."""
        self._finish(complete=True)

    def __enter__(self) -> "Model":
        return self

    def __exit__(self, kind, exc, tb) -> None:
        from ..engine.session import keeps_output

        self._finish(complete=keeps_output(exc, self.sim.comm.size))

    # -- results -------------------------------------------------------------------------------
    @property
    def output_files(self) -> list[Path]:
        """The output files of the deck (final names), in deck order."""
        return [w.path for w in self._services.files.writers]

    def results(self, which: int | str = 0):
        """The results of an output file read back (``peridyn.read``): its index in the deck's
        outputs or its section name; after the run (or ``close()``)."""
        from .results import read

        writers = self._services.files.writers
        sections = ", ".join(repr(w.entry.section) for w in writers) or "none (the deck writes no output, or write_files=False)"
        if isinstance(which, str):
            chosen = [w for w in writers if w.entry.section == which]
            if not chosen:
                raise UnknownNameError(f"no output section {which!r}", path=("Model.results", "which"), fix=f"output sections: {sections}")
        else:
            k = whole_number("Model.results", "which", which, -len(writers))
            if not writers:
                raise ArgumentError("the model has no output file", path=("Model.results", "which"), fix=f"output sections: {sections}")
            if k >= len(writers):
                raise ArgumentError(f"which = {k}: the model has {len(writers)} output file(s), 0..{len(writers) - 1}",
                                    path=("Model.results", "which"), fix=f"give 0..{len(writers) - 1} or a section name: {sections}")
            chosen = [writers[k]]
        return read(chosen[0].path)

    def summary(self) -> dict[str, Any]:
        """What ``peridyn run`` logs: per solver section its steps, time step and energy."""
        return {"solvers": [dict(s) for s in self.sim.stats.get("solvers", [])], "points": self.num_points,
                "bonds": int(self.sim.num_bonds_global)}
