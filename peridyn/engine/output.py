"""Outputs: which variables each ``Output`` section writes, when, and the computes behind them.

Only what an output asks for is computed, and only when that output actually writes (Peridigm
runs its computes inside each writer's write). Every writer keeps its own counter of write calls,
shared across solvers (PERIDIGM_SEMANTICS.md §9.2).
"""
from __future__ import annotations

import contextlib
import difflib
import logging
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..core.errors import InputError, InstabilityError, OutputWriteError, raise_collected
from ..core.fields import FieldSpec, Relation, Temporal, component_names
from ..core.interfaces import Simulation

if TYPE_CHECKING:  # pragma: no cover
    from ..deck.model import Deck, OutputEntry

log = logging.getLogger("peridyn.output")

from .output_paths import (  # noqa: F401,E402 - their home before output_paths.py
    OutputLock,
    check_output_names,
    lock_outputs,
    prepare_output_dir,
    release_locks,
)

#: point fields every deck may write without a compute (allocated on request when not already)
STANDARD_FIELDS = {
    "Model_Coordinates": FieldSpec("Model_Coordinates", Relation.NODE, 3),
    "Coordinates": FieldSpec("Coordinates", Relation.NODE, 3),
    "Displacement": FieldSpec("Displacement", Relation.NODE, 3),
    "Velocity": FieldSpec("Velocity", Relation.NODE, 3),
    "Force_Density": FieldSpec("Force_Density", Relation.NODE, 3),
    "Contact_Force_Density": FieldSpec("Contact_Force_Density", Relation.NODE, 3),
    "External_Force_Density": FieldSpec("External_Force_Density", Relation.NODE, 3),
    "Temperature": FieldSpec("Temperature", Relation.NODE),
    "Temperature_Change": FieldSpec("Temperature_Change", Relation.NODE),
    "Volume": FieldSpec("Volume", Relation.ELEMENT),
    "Horizon": FieldSpec("Horizon", Relation.ELEMENT),
    "Damage": FieldSpec("Damage", Relation.ELEMENT, 1, Temporal.TWO_STEP),
}

@dataclass
class Variable:
    name: str
    spec: FieldSpec
    compute: object | None  #: the compute filling it (None: a plain field)

    @property
    def kind(self) -> str:
        if self.spec.relation is Relation.GLOBAL:
            return "global"
        if int(self.spec.length) == 1 and self.spec.relation is Relation.ELEMENT:
            return "element"
        if int(self.spec.length) in (3,) or self.spec.relation is Relation.NODE:
            return "nodal"
        return "element"


class OutputManager:
    """What the Output sections compute: their variables and the computes behind them (the
    files they write are a run's :class:`OutputFiles`)."""

    def __init__(self, sim: "Simulation") -> None:
        self.sim = sim
        self.computes: dict[str, object] = {}  # creation order = Peridigm's
        self.variables: dict[str, Variable] = {}

    def build(self) -> None:
        """Create and check the computes and outputs of the deck (the simulation holds this
        manager already: computes look up variables through ``sim.outputs`` while checked)."""
        sim = self.sim
        deck = sim.deck
        registry = deck.registry
        errors: list[InputError] = []
        labels = {c.name: c for c in deck.computes}
        material_fields = self._model_fields()
        loader_name = deck.data_loader.field_name if deck.data_loader is not None else None

        def add_compute(name: str, obj) -> None:
            for dep in obj.requires(sim):
                resolve(dep, None)
            self.computes[name] = obj
            for spec in obj.outputs(sim):
                self.variables.setdefault(spec.name, Variable(spec.name, spec, obj))

        def resolve(name: str, path) -> Variable | None:
            if name in self.variables:
                return self.variables[name]
            if name in labels:
                return None  # created with the compute classes, below
            if registry.has("compute", name):
                cls = registry.get("compute", name, path=path or (), file=deck.file)
                if cls.Params is None:
                    add_compute(name, cls())
                    return self.variables.get(name)
            if name in material_fields:
                self.variables[name] = Variable(name, material_fields[name], None)
                return self.variables[name]
            if name in STANDARD_FIELDS:
                self.variables[name] = Variable(name, STANDARD_FIELDS[name], None)
                return self.variables[name]
            if loader_name is not None and name == loader_name:
                self.variables[name] = Variable(name, FieldSpec(name, Relation.NODE, 1, Temporal.TWO_STEP), None)
                return self.variables[name]
            if path is not None:
                errors.append(self._unknown_variable(name, path, material_fields, labels))
            return None

        for out in deck.outputs:
            for var in out.variables:
                resolve(var, out.path + ("Output Variables", var))
            off = [str(k) for k, v in out.params.output_variables.items() if v is False or str(v).strip().lower() == "false"]
            if off:  # Peridigm writes every listed variable, whatever its value
                log.warning("%s: %s: %s set to false but written all the same (Peridigm writes every listed variable, whatever its value); "
                            "remove %s from Output Variables to leave it out", deck.file, " > ".join(out.path), ", ".join(off), "them" if len(off) > 1 else "it")
        taken = set(STANDARD_FIELDS) | set(material_fields) | set(sim.fields.specs) | set(registry.names("compute"))
        for entry in deck.computes:
            if entry.name in taken:
                errors.append(InputError(f"the output label {entry.name!r} is already the name of a field peridyn computes",
                                         file=deck.file, path=entry.path + ("Output Label",), fix="choose another Output Label"))
                continue
            obj = entry.cls(entry.params, label=entry.name)
            add_compute(entry.name, obj)
        raise_collected(errors)
        for entry in deck.computes:
            problems = self.computes[entry.name].check(sim)
            for p in problems:
                errors.append(InputError(p, file=deck.file, path=entry.path))
        raise_collected(errors)
        seen: dict[str, OutputEntry] = {}
        for out in deck.outputs:
            name = self.file_name(out)
            first = seen.setdefault(name, out)
            if first is not out:
                errors.append(InputError(f"writes the same file as {first.section!r} ({name})", file=deck.file,
                                         path=out.path + ("Output Filename",), fix="give each output section its own Output Filename"))
        raise_collected(errors)

    def _unknown_variable(self, name: str, path, material_fields, labels) -> InputError:
        """One line for an output variable nothing in this deck produces: the models that
        would (a deck whose material changed), else the close names."""
        deck = self.sim.deck
        by = model_producers(deck.registry).get(name)
        if by:
            used = {"material": sorted({deck.materials[b.material].model for b in deck.blocks if b.material in deck.materials}),
                    "damage model": sorted({deck.damage_models[b.damage_model].model for b in deck.blocks
                                            if b.damage_model in deck.damage_models})}
            parts = []
            for kind in ("material", "damage model"):
                names = by.get(kind, [])
                if names:
                    names = sorted(names, key=lambda n: (len(n), n))  # the shortest names: the line stays short
                    shown = ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
                    parts.append(f"the {shown} {kind}{'s' if len(names) > 1 else ''}")
            kinds = [k for k in ("material", "damage model") if by.get(k)]
            mine = "; ".join(f"this deck's {k}s ({', '.join(used[k]) or 'none'})" for k in kinds)
            return InputError(f"produced by {' and '.join(parts)}; {mine} do not", file=deck.file, path=path,
                              fix=f"remove it or change the {' or '.join(kinds)}")
        known = sorted(set(STANDARD_FIELDS) | set(material_fields) | set(labels) | set(self._parameterless(deck.registry)))
        close = difflib.get_close_matches(name, known, n=3, cutoff=0.6)
        if close:
            fix = f"did you mean {' or '.join(map(repr, close))}?"
        else:
            fix = f"this deck can write {', '.join(known[:8])}, ... ({len(known)} in all; 'peridyn plugins' lists the computes)"
        return InputError(f"unknown output variable {name!r}", file=deck.file, path=path, fix=fix)

    def _model_fields(self) -> dict[str, FieldSpec]:
        out: dict[str, FieldSpec] = {}
        for blk in self.sim.blocks:
            specs = blk.material.fields() + blk.material.output_fields() + (blk.damage.fields() if blk.damage is not None else [])
            for spec in specs:
                if spec.relation is not Relation.BOND:
                    out.setdefault(spec.name, spec)
        return out

    @staticmethod
    def _parameterless(registry) -> list[str]:
        names = []
        for name in registry.names("compute"):
            try:
                cls = registry.get("compute", name)
            except InputError:
                continue
            if cls.Params is None:
                names.append(name)
        return names

    def global_only(self, entry: "OutputEntry") -> bool:
        """Whether every variable of an Output section is global (it writes a history file)."""
        return bool(entry.variables) and all(self.variables[n].kind == "global" for n in entry.variables)

    def file_name(self, entry: "OutputEntry") -> str:
        """The file an Output section writes: ``NAME.h`` when all its variables are global,
        else the Exodus ``NAME.e``."""
        return f"{entry.filename}{'.h' if self.global_only(entry) else '.e'}"

    def field_specs(self) -> list[FieldSpec]:
        """Fields the outputs need allocated."""
        return [v.spec for v in self.variables.values() if v.spec.relation is not Relation.BOND]

    def blocks_with(self, name: str) -> list[bool]:
        """Truth table row: which blocks have the element variable ``name``."""
        var = self.variables[name]
        if var.compute is None and name not in STANDARD_FIELDS:
            return [
                any(s.name == name for s in blk.material.fields() + blk.material.output_fields() + (blk.damage.fields() if blk.damage is not None else []))
                for blk in self.sim.blocks
            ]
        return [True] * len(self.sim.blocks)

    def initialize(self) -> None:
        for obj in self.computes.values():
            obj.initialize(self.sim)

    def run_computes(self, names) -> None:
        """Run the computes behind ``names`` (and their dependencies) in creation order."""
        wanted = set()
        for n in names:
            var = self.variables.get(n)
            if var is not None and var.compute is not None:
                wanted.add(id(var.compute))
        changed = True
        while changed:  # dependencies
            changed = False
            for obj in self.computes.values():
                if id(obj) in wanted:
                    for dep in obj.requires(self.sim):
                        d = self.variables.get(dep)
                        if d is not None and d.compute is not None and id(d.compute) not in wanted:
                            wanted.add(id(d.compute))
                            changed = True
        for obj in self.computes.values():
            if id(obj) in wanted:
                obj.compute(self.sim)


class OutputFiles:
    """The output files of one run of ``sim``: a writer per ``Output`` section of its deck, in
    deck order, in ``sim.output_dir``; a file is created at its first frame. ``write=False``
    (``peridyn check``'s run, a harness that reads the fields itself): no writer, nothing is
    written. The file names were checked with the deck's outputs (``OutputManager.build``)."""

    def __init__(self, sim: "Simulation", *, write: bool = True) -> None:
        manager = sim.outputs
        self.writers = [OutputWriter(sim, manager, out) for out in sim.deck.outputs] if write else []

    def write(self, t: float) -> None:
        for w in self.writers:
            w.write(t)

    def due_next(self) -> bool:
        """Whether the next ``write`` writes a frame in some file (a GPU run copies its fields
        back only then)."""
        return any(w.due_next() for w in self.writers)

    def close(self, complete: bool = True) -> None:
        """Close every file. ``complete``: the run ended or was stopped on purpose (finished, or
        unstable): each file takes its final name. Otherwise (an error, an interrupt) the new
        frames stay in ``NAME.partial.e`` and an earlier ``NAME.e`` is left as it was."""
        for w in self.writers:
            w.close(complete)


_PRODUCERS: dict[int, dict[str, dict[str, list[str]]]] = {}


def _stand_in_values(params_cls) -> dict:
    """Values for a model's required parameters (and a pair of elastic moduli) that let it be
    built to ask which fields it declares; never used to compute."""
    values = {}
    for fname, f in params_cls.model_fields.items():
        if fname in ("bulk_modulus", "shear_modulus"):
            values[fname] = 1.0
        elif f.is_required():
            ann = f.annotation
            values[fname] = 1 if ann is int else False if ann is bool else "1.0" if ann is str else 1.0
    return values


def model_producers(registry) -> dict[str, dict[str, list[str]]]:
    """variable -> {"material" | "damage model": [model names]}: the point fields each
    installed material and damage model declares with its default parameters (cached per
    registry). A model that cannot be built without its parameters is left out."""
    cached = _PRODUCERS.get(id(registry))
    if cached is not None:
        return cached
    out: dict[str, dict[str, list[str]]] = {}
    for kind, human in (("material", "material"), ("damage", "damage model")):
        for name, cls in registry.all_classes(kind).items():
            if isinstance(cls, Exception) or cls.Params is None:
                continue
            try:
                params = cls.Params.model_construct(**_stand_in_values(cls.Params))
                obj = cls(params, horizon=1.0, options={}) if kind == "material" else cls(params, options={})
                specs = list(obj.fields()) + list(obj.output_fields() if kind == "material" else [])
            except Exception:  # needs a parameter it was not given
                continue
            for spec in specs:
                if spec.relation is not Relation.BOND:
                    names = out.setdefault(spec.name, {}).setdefault(human, [])
                    if name not in names:
                        names.append(name)
    for by in out.values():
        for names in by.values():
            names.sort()
    _PRODUCERS[id(registry)] = out
    return out


class OutputWriter:
    """Writes the variables of one Output section when its counter says so (§9.2): call k
    writes iff frequency > 0, (k - 1) % frequency == 0 and initial <= k <= final + 1."""

    def __init__(self, sim: "Simulation", manager: "OutputManager", entry: "OutputEntry") -> None:
        self.sim = sim
        self.manager = manager
        self.entry = entry
        p = entry.params
        self.frequency = p.output_frequency
        self.initial = p.initial_output_step
        self.final = p.final_output_step
        self.count = 0
        self._broken = False  # a write to the file failed (see _writing)
        self.names = list(dict.fromkeys(entry.variables))  # a name listed twice is written once
        self.vars = [manager.variables[n] for n in self.names]
        self.global_only = manager.global_only(entry)
        self.path = sim.output_dir / manager.file_name(entry)
        self._writer = None
        #: on several ranks, this rank's share of its own piece of the file (output_pieces)
        self.piece = None
        self.frames = 0
        #: a restarted run: the frames of ``partial_path`` kept, the next ones appended (peridyn.engine.restart)
        self.resume_frames: int | None = None
        # Exodus variable lists, in Output Variables order per kind
        self.nodal = [(v, c, k) for v in self.vars if v.kind == "nodal" for k, c in enumerate(component_names(v.spec, v.name))]
        self.element = [(v, c, k) for v in self.vars if v.kind == "element" for k, c in enumerate(component_names(v.spec, v.name))]
        self.glob = [(v, c, k) for v in self.vars if v.kind == "global" for k, c in enumerate(component_names(v.spec, v.name))]

    def due(self, k: int | None = None) -> bool:
        k = self.count if k is None else k
        return self.frequency > 0 and (k - 1) % self.frequency == 0 and self.initial <= k <= self.final + 1

    def due_next(self) -> bool:
        return self.due(self.count + 1)

    def write(self, t: float) -> None:
        self.count += 1
        if not self.due():
            return
        sim = self.sim
        self.manager.run_computes(self.names)
        if sim.interfaces is not None:  # Interfaces.e first, at this file's step
            sim.interfaces.write(self.frames + 1, t)
        if self._writer is None:
            with self._writing(t):
                self._open()
        if self.piece is not None:
            self._write_piece(t)
            return
        nodal = {}
        element = {}
        glob = {}
        n_owned = sim.num_owned
        index = sim.mothership_of_local[:n_owned]
        comm = sim.comm
        cache: dict[str, np.ndarray | None] = {}

        def mothership(v) -> np.ndarray | None:
            if v.name not in cache:
                data = sim.fields[v.name][:n_owned]
                cache[v.name] = comm.gather_points(np.ascontiguousarray(data), index, sim.num_global)
            return cache[v.name]

        for v, cname, k in self.nodal:
            data = mothership(v)
            if data is not None:
                nodal[cname] = data if data.ndim == 1 else data[:, k]
        for v, cname, k in self.element:
            data = mothership(v)
            if data is None:
                continue
            col = data if data.ndim == 1 else data[:, k]
            rows = self.manager.blocks_with(v.name)
            element[cname] = [col[nodes] if has else None for nodes, has in zip(self._block_nodes, rows)]
        for v, cname, k in self.glob:
            arr = sim.fields[v.name]
            glob[cname] = float(arr[k])
        self._check_finite(t)
        if comm.is_root:
            with self._writing(t):
                self._writer.write_step(t, nodal=nodal, element=element, glob=glob)
        self.frames += 1

    def _write_piece(self, t: float) -> None:
        """A frame of this rank's points in its piece (several ranks: no gather), one column at
        a time (a column of the rank's points is the most it copies)."""
        sim, piece, w = self.sim, self.piece, self._writer
        n_owned = sim.num_owned
        self._check_finite(t)
        glob = [float(sim.fields[v.name][k]) for v, _, k in self.glob]
        if piece.num_nodes:
            step = w.num_steps

            def column(v, k) -> np.ndarray:
                data = sim.fields[v.name][:n_owned]
                return piece.values(data if data.ndim == 1 else data[:, k])

            with self._writing(t):
                for i, (v, _, k) in enumerate(self.nodal):
                    w.write_nodal_slice(step, i, 0, column(v, k))
                for i, (v, _, k) in enumerate(self.element):
                    blocks = piece.block_values(column(v, k))
                    for b, (values, has) in enumerate(zip(blocks, self.manager.blocks_with(v.name))):
                        if has and values.size:
                            w.write_element_slice(step, i, b, 0, values)
                w.end_step(step, t, glob)
        self.frames += 1

    @contextlib.contextmanager
    def _writing(self, t: float):
        """OutputWriteError (exit 3) for a file the system refuses to write (disk full, a file
        size limit): a failed run, not a bug."""
        try:
            yield
        except (OSError, RuntimeError) as exc:
            self._broken = True
            reason = getattr(exc, "strerror", None) or str(exc)
            raise OutputWriteError(
                f"{self.entry.section}: writing {self.partial_path.name} failed at t = {t:.6g} ({reason}); the frames written "
                f"before it are in {self.partial_path.name}, and {self.path.name} is left as it was"
            ) from None

    def _check_finite(self, t: float) -> None:
        """Stop (exit 3, on every rank) before a frame with a non-finite value is written,
        naming the variable, the point and the time."""
        sim = self.sim
        n_owned = sim.num_owned
        first = None  # (global id, variable) of the first non-finite value on this rank
        for v in self.vars:
            data = sim.fields[v.name]
            rows = data if v.kind == "global" else data[:n_owned]
            bad = ~np.isfinite(rows)
            if bad.ndim > 1:
                bad = bad.any(axis=tuple(range(1, bad.ndim)))
            if bad.any():
                gid = -1 if v.kind == "global" else int(sim.gid[int(np.argmax(bad))])
                if first is None or gid < first[0]:
                    first = (gid, v.name)
        found = [f for f in sim.comm.allgather(first) if f is not None]
        if not found:
            return
        gid, name = min(found)
        where = "" if gid < 0 else f" at point {gid + 1}"
        raise InstabilityError(
            f"{self.entry.section}: {name} is not finite{where} at t = {t:.6g}; the frame is not written (the file holds "
            "the frames before it). Likely causes: a time step above the stable one, or a boundary condition, "
            "initial condition or material parameter that produces NaN or inf"
        )

    def _open(self) -> None:
        from ..io.exodus_writer import ExodusBlock, ExodusWriter

        sim = self.sim
        comm = sim.comm
        disc = sim.discretization
        if comm.is_root and not self.resume_frames:
            from .output_pieces import drop_stale_pieces

            drop_stale_pieces(self.partial_path, comm.size)
        if comm.size > 1 and not self.global_only:
            self._open_piece()
            return
        # element blocks in block order, each block's points in mothership order
        self._block_nodes = []
        blocks = []
        for blk in sim.blocks:
            nodes = np.sort(np.nonzero(sim.block_index_mothership == blk.index)[0])
            self._block_nodes.append(nodes)
            blocks.append(ExodusBlock(blk.block_id, blk.name, nodes))
        if not comm.is_root:
            self._writer = _NullWriter()
            return
        if self.global_only:
            self._writer = ExodusWriter.global_only(self.partial_path, [c for _, c, _ in self.glob], append_after=self.resume_frames)
            return
        node_sets = [(name, members) for name, members in sorted(sim.node_sets.items())]
        self._writer = ExodusWriter(self.partial_path, coords=disc.x, node_num_map=disc.gid + 1, blocks=blocks,
                                    node_sets=node_sets, append_after=self.resume_frames, **self._variables())

    def _variables(self) -> dict:
        """The Exodus writer's variable names and truth table (which block has which element
        variable), the same for the whole file and a rank's piece."""
        truth = np.array([self.manager.blocks_with(v.name) for v, _, _ in self.element], dtype=bool).T.reshape(len(self.sim.blocks), len(self.element))
        return {"nodal_vars": [c for _, c, _ in self.nodal], "element_vars": [c for _, c, _ in self.element],
                "global_vars": [c for _, c, _ in self.glob], "truth_table": truth}

    def _open_piece(self) -> None:
        from .output_pieces import APPEND_AFTER, RankPiece, rank_file

        sim = self.sim
        self.piece = piece = RankPiece(sim)
        if not piece.num_nodes:
            self._writer = _NullWriter()
            return
        self._writer = piece.writer(rank_file(self.partial_path, sim.comm.size, sim.comm.rank), **self._variables())
        if self.resume_frames:
            self._writer.set_attribute(APPEND_AFTER, self.resume_frames)

    @property
    def partial_path(self) -> Path:
        """Where frames go while the run lasts: ``NAME.partial.e`` beside ``NAME.e``."""
        return self.path.with_name(f"{self.path.stem}.partial{self.path.suffix}")

    def close(self, complete: bool = True) -> None:
        if self._writer is None:
            return
        if self._broken:
            # netCDF's C library crashes closing (or freeing) a file whose write failed: keep the
            # handle alive to the end of the process and leave the file as written
            import ctypes

            _FAILED_WRITERS.append(self._writer)
            ctypes.pythonapi.Py_IncRef(ctypes.py_object(self._writer))  # never freed, not even at exit
            self._writer = None
            log.warning("the frames of this run are in %s; %s is left as it was", self.partial_path, self.path.name)
            return
        try:
            self._writer.close()
        except (OSError, RuntimeError) as exc:
            if complete:
                raise OutputWriteError(f"{self.entry.section}: closing {self.partial_path.name} failed ({exc})") from None
            log.warning("closing %s failed (%s)", self.partial_path.name, exc)
        if self.piece is not None:
            from .output_pieces import close_pieces

            self._writer = None
            close_pieces(self, complete)
            return
        if isinstance(self._writer, _NullWriter):
            return
        self._writer = None
        if complete:
            os.replace(self.partial_path, self.path)
        else:
            log.warning("the frames of this run are in %s; %s is left as it was", self.partial_path, self.path.name)


#: writers whose file failed to write, never closed nor freed (see OutputFile.close)
_FAILED_WRITERS: list = []


class _NullWriter:
    def write_step(self, *a, **k) -> None:
        pass

    def close(self) -> None:
        pass
