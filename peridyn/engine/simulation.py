"""The engine: from a validated deck to blocks, fields, neighbor lists, models and outputs, and
the force evaluation every solver calls.

Local point order: owned points first, grouped by block (in block order) and sorted along a
space-filling curve inside each block, then ghosts (MPI). Each block owns a contiguous range of
local indices. Neighbor lists are CSR over local indices, each list sorted by global id so sums
do not depend on the decomposition. Output is always written in mothership order.
"""
from __future__ import annotations

import logging
import math
import time as _time
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError, raise_collected
from ..core.fields import FieldSpec, FieldStore, Length, Relation
from ..core.interfaces import BlockView
from ..core.placement import Placement
from ..core.state import Clock, SolverState
from ..core.traversal import Backend
from ..deck.model import Deck, ModelEntry
from ..geometry.influence import InfluenceFunction
from ..kernels import select_backend
from ..parallel.comm import SerialComm
from . import checks, limits
from .blocks import Block, block_id_from_name, plan_fusion
from .devices import resolve_device
from .mesh_parts import read_in_parts
from .conditions import create_conditions
from .placement import HostPlacement
from ..kernels.scatter import apply_body_forces, apply_kinematic
from .kernels import (
    bond_length_kernel,
    foreign_neighbor_kernel,
)
from .critical_step import critical_time_steps
from .forces import evaluate_forces

log = logging.getLogger("peridyn.engine")


class Simulation:
    """A model built from a deck, ready for solvers: points, blocks, bonds, node sets, fields and
    conditions (what solvers, computes and models may read is the contract
    :class:`peridyn.core.interfaces.Simulation`). What solvers write is the solver state they are
    handed (:class:`peridyn.core.state.SolverState`); the run services around it (output files,
    folder and locks, checkpoints, signals, progress) are the run session's
    (:mod:`peridyn.engine.session`, :mod:`peridyn.engine.run_services`); its force evaluation is
    :mod:`peridyn.engine.forces`.
    """

    def __init__(self, deck: Deck, *, comm=None, output_dir: str | Path | None = None, write_files: bool = True,
                 backend: str | None = None, device: str | None = None) -> None:
        self.deck = deck
        #: "cpu", or "gpu": explicit solvers run on one GPU (``--device``, else the solver's ``Device``)
        self._device_backend = None
        try:
            self.device, gpu_backend = resolve_device(deck, device, backend)
            self._gpu_backend_name = gpu_backend or "cuda"
            #: where arrays live and bond loops run (``peridyn run --backend``, ``PERIDYN_BACKEND``); set-up runs here
            self.backend = select_backend(None if gpu_backend else backend)
            if self.device == "gpu" and write_files:  # ``peridyn check --device gpu`` needs no GPU
                self._device_backend = self._make_device_backend()
        except InputError as exc:
            raise exc.in_file(deck.file) from None
        self.comm = comm or SerialComm()
        self.output_dir = Path(output_dir) if output_dir is not None else Path.cwd()
        #: False for ``peridyn check``: set-up creates no file (no Interfaces.e)
        self.write_files = write_files
        #: the time the fields are at: the running section's solver state (read-only; ``show_clock``)
        self.clock: Clock = SolverState()
        self.time_step = 0.0  #: the running solver's step (T), which rate-form models read
        self.bond_force_vector: np.ndarray | None = None  #: (num_bonds, 3) vector force states (non-ordinary materials only)
        self.reverse_forces: bool | None = None  #: MPI: whether evaluations sum ghost forces into owners (engine.forces)
        self._rho: np.ndarray | None = None
        self.contact = None
        self.interfaces = None
        self.element_nodes: np.ndarray | None = None
        self.timers: dict[str, float] = {}
        self.stats: dict[str, Any] = {}
        t0 = _time.perf_counter()
        from ..deck.expressions import random_seed

        try:
            with random_seed(deck.random_seed):  # rnd() of every expression compiled in set-up
                self._setup()
        except InputError as exc:  # every message names a file
            raise exc.in_file(deck.file) from None
        if self.device == "gpu":
            from ..gpu.support import check_gpu

            check_gpu(self)
        self.timers["setup"] = _time.perf_counter() - t0

    @property
    def device_backend(self) -> Backend | None:
        """The GPU backend of a "gpu" run (made when first asked for: a run that writes nothing,
        such as ``peridyn check --device gpu``, needs no GPU until it steps), else None."""
        if self._device_backend is None and self.device == "gpu":
            self._device_backend = self._make_device_backend()
        return self._device_backend

    def _make_device_backend(self) -> Backend:
        from ..kernels.numba_cuda import require_gpu

        require_gpu()
        return select_backend(self._gpu_backend_name)

    # ============================================================================================
    # set-up
    # ============================================================================================
    def _setup(self) -> None:
        deck = self.deck
        dentry = deck.discretization
        reader = dentry.cls(dentry.params, deck_dir=deck.directory)
        try:
            planned = reader.estimate_points()
        except (ArithmeticError, ValueError):  # a generator whose sizes overflow
            planned = math.inf
        if planned is not None:
            limits.check_memory(float(planned), 0.0, file=deck.file, path=dentry.path, what="the discretization")
        t0 = _time.perf_counter()
        disc = read_in_parts(reader, self.comm) or reader.read()  # the pieces of a pre-split mesh, else the whole
        disc.validate()
        checks.finite_points(disc, checks.mesh_file(disc, deck.file), dentry.path)
        self.discretization = disc
        self.timers["read mesh"] = _time.perf_counter() - t0
        self.num_global = disc.num_points
        self.influence = InfluenceFunction(dentry.influence_function)

        self._assign_blocks(disc)
        horizon = self._point_horizons(disc)
        checks.horizon_scale(self, disc, horizon)
        self.bonds_estimate = limits.estimate_bonds(disc.volume, horizon)
        limits.check_memory(float(disc.num_points), self.bonds_estimate, file=deck.file, path=("Blocks",), what="the model")
        t0 = _time.perf_counter()
        offsets, neighbors = self._build_neighbors(disc, horizon)
        self.timers["neighbor search"] = _time.perf_counter() - t0
        self._order_points(disc, offsets, neighbors, horizon)
        del offsets, neighbors  # the search's lists in mesh order (4 bytes a bond): renumbered into self.bonds
        self.interfaces = None
        if disc.construct_interfaces:  # PERIDIGM_MODELS.md §11
            from ..io.interfaces import setup_interfaces

            self.interfaces = setup_interfaces(self)
        self._create_models()
        self._declare_fields()
        bound = create_conditions(self)
        self.node_sets, self.conditions, self.kinematic = bound.node_sets, bound.conditions, bound.kinematic
        self.force_conditions, self.prescribed_points, self.prescribed_dofs = bound.force_conditions, bound.prescribed_points, bound.prescribed_dofs
        from .output import OutputManager

        self.outputs = OutputManager(self)
        self.outputs.build()
        self._declare_fields_late()
        self._fill_fields(disc)
        if self.element_nodes is not None:  # the partial-volume bond fields some model declared
            from ..geometry.partial_volumes import fill_partial_volumes

            fill_partial_volumes(self, self.element_nodes, dentry.params.intersection_recursion_level, dentry.params.intersection_number_of_samples)
        self.contact = None
        if deck.contact is not None:  # contact code is imported only by decks that use it
            from ..contact.manager import ContactManager

            self.contact = ContactManager(self, deck.contact)
        self._make_views()
        plan = plan_fusion(self)
        self.generic_blocks, self.overlap, self.bond_force = plan.generic_blocks, plan.overlap, plan.bond_force
        self.num_bonds_global = int(self.comm.allreduce_sum(int(self.bonds.num_bonds)))
        checks.connected(self)
        checks.horizon_spacing(self)
        self._apply_initial_conditions()
        for blk in self.blocks:
            blk.material.initialize(blk.view)
            if blk.damage is not None:
                blk.damage.initialize(blk.view)
        self.exchange_halo_fields()
        self.data_loader = None
        if deck.data_loader is not None:
            from .data_loader import DataLoader

            self.data_loader = DataLoader(self, deck.data_loader)
        self.outputs.initialize()

    # -- blocks --------------------------------------------------------------------------------
    def _assign_blocks(self, disc) -> None:
        deck = self.deck
        errors: list[InputError] = []
        mesh_ids = sorted(disc.block_names)
        names_by_id = dict(disc.block_names)
        entries: list[tuple[str, Any]] = []  # (block name, BlockEntry)
        default = None
        for entry in deck.blocks:
            for name in entry.names:
                if name.lower() == "default":
                    default = entry
                else:
                    entries.append((name, entry))
        used_ids: dict[int, str] = {}
        specs = []
        for name, entry in entries:
            bid = block_id_from_name(name, names_by_id)
            if bid is None or bid not in names_by_id:
                available = ", ".join(names_by_id[i] for i in mesh_ids) or "none"
                errors.append(
                    InputError(f"block {name!r} is not in the discretization", file=deck.file, path=entry.path + ("Block Names",), fix=f"blocks of {disc.source or 'the mesh'}: {available}")
                )
                continue
            if bid in used_ids:
                errors.append(InputError(f"block {name!r} is the same mesh block as {used_ids[bid]!r}", file=deck.file, path=entry.path + ("Block Names",)))
                continue
            used_ids[bid] = name
            specs.append((name, bid, entry))
        missing = [bid for bid in mesh_ids if bid not in used_ids]
        if missing:
            if default is None:
                errors.append(
                    InputError(
                        f"mesh block(s) {', '.join(names_by_id[b] for b in missing)} have no entry in Blocks",
                        file=deck.file,
                        path=("Blocks",),
                        fix="add them to 'Block Names' of a block entry, or add an entry with 'Block Names: default'",
                    )
                )
            else:
                for bid in sorted(missing, key=lambda b: names_by_id[b]):  # Peridigm sorts by name
                    specs.append((names_by_id[bid], bid, default))
        raise_collected(errors)
        self.block_specs = specs
        index_of_id = {bid: k for k, (_, bid, _) in enumerate(specs)}
        self.block_index_mothership = np.array([index_of_id[b] for b in disc.block_id], dtype=np.int64) if disc.num_points else np.zeros(0, np.int64)

    def _point_horizons(self, disc) -> np.ndarray:
        from ..deck.expressions import compile_expression

        horizon = np.empty(disc.num_points)
        for k, (name, bid, entry) in enumerate(self.block_specs):
            mask = self.block_index_mothership == k
            h = entry.horizon
            if isinstance(h, str):
                expr = compile_expression(h, ("x", "y", "z"), stream=" > ".join(map(str, entry.path + ("Horizon",))))
                xs = disc.x[mask]
                values = np.broadcast_to(np.asarray(expr(disc.gid[mask], x=xs[:, 0], y=xs[:, 1], z=xs[:, 2]), float), (int(mask.sum()),))
                bad = ~(np.isfinite(values) & (values > 0))
                if np.any(bad):
                    at = xs[int(np.argmax(bad))]
                    raise InputError(
                        f"the horizon expression gives {float(values[int(np.argmax(bad))])!r} at ({at[0]:g}, {at[1]:g}, {at[2]:g}) in block {name!r}",
                        file=self.deck.file, path=entry.path + ("Horizon",), fix="give an expression that is positive and finite at every point",
                    )
                horizon[mask] = values
            else:
                # Peridigm prints a double horizon with %.16g and re-parses it
                horizon[mask] = float(f"{h:.16g}")
        return horizon

    def _decompose(self, disc, horizon) -> np.ndarray:
        """Owner rank of every point (all zeros in a serial run)."""
        if self.comm.size == 1:
            return np.zeros(disc.num_points, dtype=np.int64)
        from ..geometry.decomposition import (
            bond_weights,
            recursive_coordinate_bisection,
        )

        return recursive_coordinate_bisection(disc.x, bond_weights(disc.volume, horizon), self.comm.size)

    def _build_neighbors(self, disc, horizon):
        """Neighbor lists (CSR rows in the order of ``self.owned_mothership``, entries mothership
        indices) of the points this rank owns."""
        from ..geometry.neighbors import omit_bonds_between_blocks, radius_search

        self.owner = self._decompose(disc, horizon)
        points = np.nonzero(self.owner == self.comm.rank)[0].astype(np.int64)
        self.owned_mothership = points
        dentry = self.deck.discretization
        self.element_nodes = None  # (n, 8, 3) hexahedron nodes: Compute Element-Horizon Intersections
        if disc.neighbor_rule is not None:
            offsets, neighbors = disc.neighbor_rule(points, horizon)
            neighbors = neighbors.astype(np.int32, copy=False)  # 4 bytes per bond from here on
        elif disc.element_horizon_intersections:
            from ..geometry.partial_volumes import intersecting_neighbors
            from ..io.interfaces import element_hex_nodes

            self.element_nodes = element_hex_nodes(self.deck, disc)
            offsets, neighbors = intersecting_neighbors(disc.x, horizon, points, self.element_nodes)
        else:
            offsets, neighbors = radius_search(disc.x, horizon, points, dtype=np.int32)
        if dentry.bond_filters:
            from ..geometry.bond_filters import apply_bond_filters, make_filter

            filters = [make_filter(raw, deck_dir=self.deck.directory, path=path) for _, raw, path in dentry.bond_filters]
            offsets, neighbors = apply_bond_filters(disc.x, offsets, neighbors, filters, rows=points)
        if dentry.omit_bonds_between_blocks == "All":
            offsets, neighbors = omit_bonds_between_blocks(offsets, neighbors, disc.block_id, rows=points)
        return offsets, neighbors

    def _order_points(self, disc, offsets, neighbors, horizon) -> None:
        """Local order: owned points by block, then along a space-filling curve or by global id
        (``geometry.neighbors.storage_rank``); then ghosts (by owner, then global id). Rows are
        sorted by global id; ghosts have empty rows."""
        from ..core.bonds import NeighborList
        from ..geometry.neighbors import renumber, sort_rows, storage_rank

        owned = self.owned_mothership
        n_owned = owned.size
        rank = storage_rank(disc.x, disc.gid, self.block_index_mothership, owned, offsets, neighbors, serial=self.comm.size == 1)
        # under MPI the rows with a ghost neighbor go after the others within each block, so
        # the others can be computed while the ghosts' values travel
        boundary = self._has_ghost_neighbor(offsets, neighbors, n_owned)
        row_order = np.lexsort((rank, boundary, self.block_index_mothership[owned]))  # owned row per new index
        owned_sorted = owned[row_order]
        if self.comm.size > 1 and neighbors.size:
            mask = np.zeros(disc.num_points, dtype=bool)
            mask[neighbors] = True
            mask[owned] = False
            ghosts = np.nonzero(mask)[0]
            ghosts = ghosts[np.lexsort((disc.gid[ghosts], self.owner[ghosts]))]
        else:
            ghosts = np.zeros(0, dtype=np.int64)
        order = np.concatenate([owned_sorted, ghosts]).astype(np.int64)
        n_local = order.size
        new_of_old = np.full(disc.num_points, -1, dtype=np.int64)
        new_of_old[order] = np.arange(n_local)
        if not (n_local == disc.num_points and np.array_equal(order, np.arange(n_local))):  # else already so
            offsets, neighbors = renumber(offsets, neighbors, new_of_old, row_order)
        if ghosts.size:
            offsets = np.concatenate([offsets, np.full(ghosts.size, offsets[-1], dtype=np.int64)])
        gid_local = disc.gid[order]
        neighbors = sort_rows(offsets, neighbors, gid_local)
        self.bonds = NeighborList(np.ascontiguousarray(offsets, dtype=np.int64), np.ascontiguousarray(neighbors, dtype=np.int32), row_key=gid_local)
        self.mothership_of_local = order
        self.local_of_mothership = new_of_old
        self.gid = gid_local
        self.block_index = self.block_index_mothership[order]
        self.horizon_local = horizon[order]
        self.num_owned = n_owned
        self.num_local = n_local
        counts = np.bincount(self.block_index[:n_owned], minlength=len(self.block_specs))
        self.block_ranges = np.concatenate([[0], np.cumsum(counts)])
        interior = np.bincount(self.block_index[:n_owned][~boundary[row_order]], minlength=len(self.block_specs))
        self.block_splits = self.block_ranges[:-1] + interior
        self.halo = self.comm.make_halo(order[n_owned:], self.owner[order[n_owned:]], np.arange(n_owned, n_local), new_of_old)

    def _has_ghost_neighbor(self, offsets: np.ndarray, neighbors: np.ndarray, n_owned: int) -> np.ndarray:
        """(n_owned,) bool: the owned row (rows of ``offsets``, mothership neighbor indices) has
        a neighbor owned by another rank. All False in a serial run."""
        if self.comm.size == 1 or not neighbors.size:
            return np.zeros(n_owned, dtype=bool)
        out = np.zeros(n_owned, dtype=np.bool_)
        foreign_neighbor_kernel(n_owned, offsets, neighbors, self.owner, self.comm.rank, out)
        return out

    def _create_models(self) -> None:
        deck = self.deck
        self.blocks: list[Block] = []
        errors: list[InputError] = []
        for k, (name, bid, entry) in enumerate(self.block_specs):
            mentry: ModelEntry = deck.materials[entry.material]
            horizon = float(f"{entry.horizon:.16g}") if isinstance(entry.horizon, float) else None
            try:
                material = mentry.cls(mentry.params, horizon=horizon, options={"deck_dir": deck.directory, "path": mentry.path})
            except (ValueError, InputError) as exc:
                errors.append(exc if isinstance(exc, InputError) else InputError(str(exc), file=deck.file, path=mentry.path))
                continue
            damage = None
            if entry.damage_model is not None:
                dentry = deck.damage_models[entry.damage_model]
                try:
                    damage = dentry.cls(dentry.params, options={"deck_dir": deck.directory, "path": dentry.path})
                    damage.bind_material(material)
                except (ValueError, InputError) as exc:
                    errors.append(exc if isinstance(exc, InputError) else InputError(str(exc), file=deck.file, path=dentry.path))
                    continue
            if horizon is None and material.requires_constant_horizon and self.influence.kind != 0:
                errors.append(
                    InputError(
                        f"material {mentry.model!r} with influence function {self.influence.spec!r} needs a constant horizon",
                        file=deck.file,
                        path=entry.path + ("Horizon",),
                        fix="give the horizon as a number",
                    )
                )
            blk = Block(k, name, bid, entry.material, material, damage, horizon, entry.horizon, path=entry.path)
            blk.damage_adopted = bool(damage is not None and material.adopt_damage(damage))
            blk.start, blk.stop = int(self.block_ranges[k]), int(self.block_ranges[k + 1])
            blk.split = int(self.block_splits[k])
            self.blocks.append(blk)
        raise_collected(errors)
        #: point fields some material reads at ghosts (exchanged before every evaluation)
        self.ghost_inputs = list(dict.fromkeys(n for blk in self.blocks for n in blk.material.ghost_inputs))
        #: point fields some material's precompute writes (exchanged to ghosts after it)
        self.precompute_fields = list(dict.fromkeys(n for blk in self.blocks for n in blk.material.precompute_fields))

    # -- fields --------------------------------------------------------------------------------
    def _declare_fields(self) -> None:
        store = FieldStore(self.num_local, self.bonds.num_bonds)
        self.fields = store
        for name in ("Model_Coordinates", "Coordinates", "Displacement", "Velocity", "Force_Density"):
            store.declare(FieldSpec(name, Relation.NODE, Length.VECTOR))
        store.declare(FieldSpec("Volume", Relation.ELEMENT))
        # reference bond lengths |xi| (L, 8 bytes a bond), filled when a kernel first reads them:
        # loops that take them from packed reference positions never allocate them
        store.declare_lazy(FieldSpec("Bond_Length", Relation.BOND, units="L"), self._fill_bond_lengths)
        for blk in self.blocks:
            store.declare_all(blk.material.fields())
            if blk.damage is not None:
                store.declare_all(blk.damage.fields())

    def _declare_fields_late(self) -> None:
        """Fields the outputs asked for (allocated only now, after the outputs are known)."""
        for spec in self.outputs.field_specs():
            self.fields.declare(spec)

    def require(self, spec: FieldSpec) -> np.ndarray:
        """Declare (if needed) and return a field; for computes and solvers."""
        self.fields.declare(spec)
        return self.fields[spec.name]

    def _fill_fields(self, disc) -> None:
        s = self.fields
        x = disc.x[self.mothership_of_local]
        s["Model_Coordinates"][:] = x
        s["Coordinates"][:] = x
        s["Volume"][:] = disc.volume[self.mothership_of_local]
        checks.no_coincident_points(self, disc)
        if "Horizon" in s:
            s["Horizon"][:] = self.horizon_local

    def _fill_bond_lengths(self, zeta: np.ndarray) -> None:
        bond_length_kernel(self.num_local, self.bonds.offsets, self.bonds.neighbors, self.fields["Model_Coordinates"], zeta)

    def _make_views(self) -> None:
        for blk in self.blocks:
            blk.view = BlockView(
                name=blk.name,
                block_id=blk.block_id,
                start=blk.start,
                stop=blk.stop,
                horizon=blk.horizon if blk.horizon is not None else float("nan"),
                density=blk.material.density,
                fields=self.fields,
                bonds=self.bonds,
                num_owned=self.num_owned,
                # no damage model: the block's bonds stay intact at both ends
                damage_symmetric=bool(blk.damage is None or blk.damage.symmetric),
                influence=self.influence,
                backend=self.backend,
            )

    def _apply_initial_conditions(self) -> None:
        for c in self.conditions:
            if c.stage == "initial":
                try:
                    c.apply_initial(self)
                except InputError as exc:
                    raise exc.with_context(file=self.deck.file) from None

    # ============================================================================================
    # what solvers call
    # ============================================================================================
    def begin_step(self, time: float) -> None:
        """Start of an explicit step: damage models see the new time (Peridigm re-creates them)."""
        for blk in self.blocks:
            if blk.damage is not None:
                blk.damage.begin_step(blk.view, time)

    def set_time_step(self, dt: float) -> None:
        """The solver's time step (or load-step increment), for rate-form materials (T)."""
        self.time_step = float(dt)
        for blk in self.blocks:
            blk.view.time_step = self.time_step
            if blk.fused_view is not None:
                blk.fused_view.time_step = self.time_step

    def show_clock(self, state: SolverState) -> None:
        """From now on ``clock`` reads ``state`` (a solver section starts from it)."""
        self.clock = state

    def host_placement(self, state: SolverState) -> Placement:
        """The step's arrays where this simulation holds them, with ``state``'s acceleration and
        increments (nothing is copied; forces are the simulation's, MPI halos included)."""
        return HostPlacement(self, state)

    def prescribe(self, points: np.ndarray, component: int) -> None:
        """Mark displacement ``component`` of the local ``points`` as prescribed (a condition
        added after set-up, e.g. from the Python API)."""
        self.prescribed_dofs[points, component] = True
        self.prescribed_points = np.unique(np.concatenate([self.prescribed_points, np.asarray(points, dtype=np.int64)]))

    def exchange_halo_fields(self) -> None:
        """Refresh the ghost copies of the current positions and of every field marked halo."""
        if self.comm.size == 1:
            return
        self.halo.exchange(self.fields["Coordinates"])
        for name, spec in self.fields.specs.items():
            if spec.halo and spec.is_point:
                self.halo.exchange(self.fields[name])

    def plan_solvers(self) -> list[tuple[Any, int | None, float | None]]:
        """The deck's solvers in order, each as (solver, planned steps, estimated seconds), after
        refusing absurd step counts (see :mod:`peridyn.engine.limits`)."""
        plan = []
        if not self.deck.solvers:
            names = ", ".join(self.deck.registry.names("solver")) if self.deck.registry is not None else "Verlet, QuasiStatic"
            raise InputError("the deck has no solver section: nothing would be run", file=self.deck.file, path=("Solver",),
                             fix=f"add a section named 'Solver' with one of: {names} (and its Final Time)")
        for entry in self.deck.solvers:
            solver = entry.cls(entry.params, section=entry.section)
            steps = solver.planned_steps(self)
            seconds = None
            if steps is not None:
                seconds = self.check_steps(steps, entry.path, entry.section, implicit=solver.implicit)
            plan.append((solver, steps, seconds))
        return plan

    def check_steps(self, steps: float, path: tuple[str, ...], section: str, implicit: bool = False) -> float:
        """Refuse (InputError) a step count over the limits of :mod:`peridyn.engine.limits`, for
        a solver planned at set-up or one that starts during the run (a fallback); returns the
        estimated wall time (s). ``implicit``: the solver solves with a tangent."""
        entries, differences = 0.0, False
        if implicit:
            materials = [blk.material for blk in self.blocks]
            coupling = "family" if any(m.tangent_coupling == "family" for m in materials) else "pairs"
            nl = self.bonds
            entries = limits.estimate_tangent_entries(nl.offsets, nl.neighbors, self.num_owned, coupling, self.comm if self.comm.size > 1 else None)
            differences = not all(m.analytic_tangent for m in materials)
        return limits.check_steps(steps, float(self.num_global), float(self.num_bonds_global), file=self.deck.file, path=path, section=section,
                                  tangent_entries=entries, finite_differences=differences)

    def evaluate_forces(self) -> np.ndarray:
        """Peridigm's evalModel: damage, precompute, force. Returns Force_Density (n, 3)."""
        return evaluate_forces(self)

    def apply_kinematic(self, t: float, t_prev: float, state: SolverState | None = None) -> None:
        apply_kinematic(HostPlacement(self, state), self.kinematic, t, t_prev)

    def apply_body_forces(self, t: float) -> None:
        apply_body_forces(HostPlacement(self, None), self.force_conditions, t)

    def load_data(self, t: float) -> None:
        if self.data_loader is not None:
            self.data_loader.load(t)

    def advance(self) -> None:
        """End of a completed step: swap N and NP1 of two-step fields."""
        self.fields.swap()

    def density_per_point(self) -> np.ndarray:
        """(num_owned,) mass density of every owned point."""
        if self._rho is None:
            densities = np.array([blk.density for blk in self.blocks])
            self._rho = densities[self.block_index] if self.num_local else np.zeros(0)
        return self._rho

    def critical_time_step(self) -> float:
        """Peridigm's critical time step estimate min_i sqrt(2 rho / sum_j V_j c / |xi_ij|)."""
        dt = self.critical_time_steps()
        local = float(dt.min()) if self.num_owned else math.inf
        return self.comm.allreduce_min(local)

    def critical_time_steps(self) -> np.ndarray:
        """(num_owned,) each point's sqrt(2 rho / sum_j V_j c / |xi_ij|) (inf without bonds)."""
        return critical_time_steps(self)

    # -- energies (owned points; reduced over ranks) --------------------------------------------
    def kinetic_energy(self) -> float:
        v = self.fields["Velocity"][: self.num_owned]
        m = self.fields["Volume"][: self.num_owned] * self.density_per_point()[: self.num_owned]
        return self.comm.allreduce_sum(0.5 * float(np.dot(m, np.einsum("ij,ij->i", v, v))))

    def unit_slip_hint(self) -> str:
        """The likely unit slip of the model ("" when none): :func:`plausibility.unit_slip_hint`."""
        from .plausibility import unit_slip_hint

        return unit_slip_hint(self)

    def stored_energy(self) -> float:
        """Total stored elastic energy (sum of W_i V_i over owned points)."""
        W = np.zeros(self.num_local)
        for blk in self.blocks:
            blk.material.stored_energy_density(blk.view, W)
        total = self.comm.allreduce_sum(float(np.dot(W[: self.num_owned], self.fields["Volume"][: self.num_owned])))
        if self.contact is not None:
            e = self.contact.potential_energy()
            total = total + e if e is not None else math.nan
        return total

    def memory_bytes(self) -> int:
        total = self.fields.nbytes() + self.bonds.nbytes()
        if self.bond_force is not None:
            total += self.bond_force.nbytes
        if self.bond_force_vector is not None:
            total += self.bond_force_vector.nbytes
        return total
