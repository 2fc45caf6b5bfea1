"""The contact manager: when to search, which pairs may touch, and the contact force density
added to the internal force in explicit dynamics (PERIDIGM_CONTACT.md §3, §5).

Peridigm lists, at every ``Search Frequency``-th step, all pairs within the search radius R_s
(on the previous step's positions) and tests every listed pair against the contact radius R_c
at every step. Storing that list costs O(points x points within R_s). Here the search positions
s are kept instead (3 numbers per point) and a short list of the pairs within r_b = R_c + skin
now, that lay within R_s at s and are not bonded, is rebuilt whenever a search is due or some
point has moved more than skin / 2 since the last build. A pair missing from the short list was
farther than R_c + skin apart at the build, and two points that each moved less than skin / 2
cannot have closed that gap, so the pairs that act are exactly Peridigm's.

This schedule is the one of every target. The manager starts on the simulation's own arrays (the
CPU); ``place`` moves it to another backend's arrays (a GPU's), where the same steps run the same
laws (``pair_laws.py``, the model's ``force_on``) and only the binning of the search is the
target's (``search.Binning``). ``to_host`` brings the pairs, the search positions and the
statistics back for output, checkpoints and an instability's diagnosis.
"""
from __future__ import annotations

import logging
import math
import time as _time
from typing import Any

from functools import partial

import numpy as np

from ..core.errors import InputError
from ..core.fields import FieldSpec, Length, Relation
from ..core.interfaces import ContactPairs, ContactState
from ..core.traversal import Backend
from ..kernels.scatter import ZERO_VECTORS
from .bonds import one_sided_partners
from .pair_laws import ADD_VECTORS, COPY_VECTORS, MAX_DISPLACEMENT2, MIN_PAIR_DISTANCE2, TRACK_MIN_DISTANCE
from .search import Binning, CellSearch, build_pairs

log = logging.getLogger("peridyn.contact")

#: the short list's margin beyond the contact radius, as a fraction of it
SKIN_FRACTION = 0.5

#: the contact springs' part of the stable-step estimate is taken this much stiffer (1/0.9^2):
#: over contact springs of 1 to 1000 times the bulk modulus the largest stable step measured
#: 0.91 to 2.2 times the estimate without it (benchmarks/results/contact_stability.md)
STABLE_STEP_MARGIN = 0.9


class ContactManager:
    """Contact for one simulation (created by the engine only when the deck has ``Contact``)."""

    def __init__(self, sim: Any, entry: Any) -> None:
        self.sim = sim
        p = entry.params
        self.search_radius = float(p.search_radius)
        self.frequency = int(p.search_frequency)
        mentry = entry.model
        self.model = mentry.cls(mentry.params, options={"deck_dir": sim.deck.directory, "path": mentry.path,
                                                        "blocks": [(blk.name, blk.material) for blk in sim.blocks]})
        self.rc = float(self.model.contact_radius)
        largest = max((float(blk.horizon) for blk in sim.blocks if blk.horizon is not None), default=0.0)
        if largest > 0 and self.rc > 100.0 * largest:
            raise InputError(
                f"the contact radius {self.rc:.4g} is more than 100 times the largest horizon {largest:.4g}",
                file=sim.deck.file, path=tuple(mentry.path) + ("Contact Radius",),
                fix="give a contact radius of the order of the point spacing (a fraction of the horizon)",
            )
        if self.search_radius <= self.rc:
            log.warning("%s: Contact > Search Radius %.4g is not larger than the Contact Radius %.4g: pairs that come into contact "
                        "between two searches are missed; give a search radius of a few contact radii", sim.deck.file, self.search_radius, self.rc)
        element = float(np.cbrt(3.0 * np.max(sim.discretization.volume) / (4.0 * np.pi))) if sim.discretization.num_points else 0.0
        if element > 0 and self.search_radius / element >= 10.0:
            log.warning("%s: Contact > Search Radius %.4g is %.0f times the largest element radius (Peridigm warns from 10 on); "
                        "it only decides which pairs are looked at, so a smaller one costs less", sim.deck.file, self.search_radius,
                        self.search_radius / element)
        others = [e.section for e in sim.deck.solvers if e.method != "Verlet"]
        if others:
            log.warning("%s: contact acts in Verlet solvers only (as in Peridigm); it has no effect in %s", sim.deck.file, ", ".join(others))
        self.skin = SKIN_FRACTION * self.rc
        self.rb = self.rc + self.skin
        for blk in sim.blocks:
            if blk.horizon is None:
                raise InputError(
                    f"block {blk.name!r} has a variable horizon, which contact does not support (Peridigm stops on it too)",
                    file=sim.deck.file, path=tuple(blk.path) + ("Horizon",), fix="give the block a constant horizon",
                )
        n = sim.num_owned
        self.num_owned = n
        block_horizon = np.array([float(blk.horizon) for blk in sim.blocks])
        self.block_horizon = block_horizon
        self.horizon = np.ascontiguousarray(block_horizon[sim.block_index[:n]]) if n else np.zeros(0)
        self.block = np.ascontiguousarray(sim.block_index[:n], dtype=np.int64)
        self.gid = np.ascontiguousarray(sim.gid[:n], dtype=np.int64)
        # Peridigm's first search runs in its constructor, on the reference positions
        self.s = np.ascontiguousarray(sim.fields["Model_Coordinates"][:n], dtype=np.float64).copy()
        sim.fields.declare(FieldSpec("Contact_Force_Density", Relation.NODE, Length.VECTOR))
        self.one_offsets, self.one_gid = one_sided_partners(sim, uniform=bool(np.unique(block_horizon).size <= 1))
        # bonded pairs are recognised by their reference distance where the bond lists are
        # "every point within the horizon" (no grid rule, no bond filters)
        dentry = sim.deck.discretization
        self.near_rule = sim.discretization.neighbor_rule is None and not dentry.bond_filters
        self.cross_block = dentry.omit_bonds_between_blocks != "All"
        self.near2 = (self.horizon * (1.0 - 1e-9)) ** 2 if self.near_rule else np.full(n, -1.0)
        self.ghosts = None
        if sim.comm.size > 1:
            from .ghosts import ContactGhosts

            self.ghosts = ContactGhosts(sim)
        #: the host's view, which checkpoints, output and the diagnosis read: the pairs, the
        #: positions the list was built at (n, 3); on the CPU the placed arrays themselves
        self.pairs: ContactPairs | None = None
        self.state: ContactState | None = None
        self.y_build: np.ndarray | None = None
        self.capacity = 16
        self.stats = {"searches": 1, "builds": 0, "build_time": 0.0, "force_time": 0.0, "force_calls": 0, "pairs": 0,
                      "max_pairs": 0, "overflows": 0, "ghosts": 0, "min_distance": math.inf, "min_distance_time": math.nan, "sync_time": 0.0}
        self._dt_stable: float | None = None
        self._host = True
        self._bind(sim.backend, sim.fields, sim.bonds, CellSearch(sim.backend, n, self.rb))

    # -- where the arrays live ------------------------------------------------------------------
    def place(self, backend: Backend, fields: Any, bonds: Any, binning: Binning) -> "ContactManager":
        """This contact, from now on, on ``backend``'s arrays: ``fields`` the step's fields there
        (a FieldStore's access), ``bonds`` the bond lists there (``offsets``, ``neighbors``),
        ``binning`` the target's binning of the search. The host's search positions, capacity
        and statistics go with it; the pair list is built again at the first force."""
        if self.ghosts is not None:
            raise NotImplementedError("contact on GPUs under MPI is not built")
        if backend.device not in type(self.model).devices:
            raise NotImplementedError(f"the contact model {self.model.name!r} has no {backend.device.upper()} kernels")
        self._host = backend.device == "cpu" and fields is self.sim.fields
        self._bind(backend, fields, bonds, binning)
        return self

    def _bind(self, backend: Backend, fields: Any, bonds: Any, binning: Binning) -> None:
        """The placed arrays (the host's own where they already are)."""
        put = (lambda a: a) if self._host else backend.asarray
        self._backend = backend
        self._fields = fields
        self._bonds = bonds
        self._binning = binning
        self._force = self.model.force if self._host else partial(self.model.force_on, backend)
        self._gid = put(self.gid)
        self._block = put(self.block)
        self._horizon = put(self.horizon)
        self._near2 = put(np.ascontiguousarray(self.near2, dtype=np.float64))
        self._bond_gid = put(np.ascontiguousarray(self.sim.gid, dtype=np.int64))
        self._one_offsets = put(self.one_offsets)
        self._one_gid = put(self.one_gid if self.one_gid.size else np.zeros(1, np.int64))
        self._s = self.s if self._host else backend.asarray(np.array(self.s, dtype=np.float64))
        self._y_build = None
        self._pairs: ContactPairs | None = None
        self._scalar = backend.zeros(1)
        self._step_min = backend.zeros(1)
        self._running = backend.asarray(np.array([self.stats["min_distance"], self.stats["min_distance_time"]], dtype=np.float64))

    def _set_pairs(self, pairs: ContactPairs | None) -> None:
        self._pairs = pairs
        if self._host:
            self.pairs = pairs

    def _read_min(self) -> None:
        md, when = self._backend.to_host(self._running)
        self.stats["min_distance"] = float(md)
        self.stats["min_distance_time"] = float(when)

    def to_host(self) -> None:
        """The host's view made current from the placed arrays (nothing to do on the host): the
        smallest pair distance so far, the pair list, the search positions and where the list
        was built, so that ``potential_energy`` (on host fields the caller downloaded),
        ``diagnosis``, ``summary`` and a checkpoint answer for the run."""
        if self._host:
            return
        b = self._backend
        self._read_min()
        p = self._pairs
        self.pairs = None if p is None else ContactPairs(np.asarray(b.to_host(p.offsets)), np.asarray(b.to_host(p.partners)),
                                                         np.asarray(b.to_host(p.visits)))
        np.copyto(self.s, b.to_host(self._s))
        if p is not None:
            self.y_build = np.asarray(b.to_host(self._y_build))

    # -- what the explicit solver calls ----------------------------------------------------------
    def begin_step(self, step: int) -> None:
        """Start of explicit step ``step`` (1, 2, ...), before the first half kick: a search is
        due when step % Search Frequency == 0, on the current (previous step's) positions."""
        if step % self.frequency == 0:
            self._backend.kernel(COPY_VECTORS)(0, self.num_owned, (self._fields["Coordinates"], self._s))
            self._set_pairs(None)
            self.stats["searches"] += 1

    def add_force(self, f: Any, t: float, step: int) -> None:
        """Contact_Force_Density of the owned points at the current positions and velocities,
        added to the force density f (n, 3), both on the placed arrays. Step 0 uses the friction
        law's value at t = 0."""
        t0 = _time.perf_counter()
        n = self.num_owned
        b = self._backend
        if step > 0:
            self.model.begin_step(t)
        state = self._current_state(t)
        if self._pairs is None or self._moved_too_far(state):
            state = self._build(state)
        pairs = self._pairs
        out = self._fields["Contact_Force_Density"]
        if out.shape[0] != n:  # the host's halo points follow; a GPU's array is not sliced (a device view costs Python)
            out = out[:n]
        if n:
            b.kernel(ZERO_VECTORS)(0, n, (out,))
            self._force(pairs, state, out)
            b.kernel(ADD_VECTORS)(0, n, (out, f))
        st = self.stats
        if pairs.num_pairs:
            if self._host:  # a restart may have set the statistics
                self._running[0] = st["min_distance"]
                self._running[1] = st["min_distance_time"]
            b.kernel(MIN_PAIR_DISTANCE2)(0, n, (pairs.offsets, pairs.partners, state.y), self._step_min)
            b.kernel(TRACK_MIN_DISTANCE)(0, 1, (self._step_min, self._running, float(t)))
            if self._host:
                self._read_min()
        st["force_time"] += _time.perf_counter() - t0
        st["force_calls"] += 1

    # -- pairs ----------------------------------------------------------------------------------
    def _current_state(self, t: float) -> ContactState:
        fields = self._fields
        if self.ghosts is None:
            state = self.state
            y, v, volume = fields["Coordinates"], fields["Velocity"], fields["Volume"]
            if state is None or state.y is not y or state.v is not v or state.volume is not volume or state.gid is not self._gid:
                state = self.state = ContactState(y, v, volume, self._horizon, self._block, self._gid, self.num_owned)
            state.time = t
            return state
        if self.state is not None:
            self.ghosts.update(self.state)
            self.state.time = t
        return self.state  # None before the first build (built with the ghosts)

    def _moved_too_far(self, state: ContactState | None) -> bool:
        if state is None or self._y_build is None:
            return True
        b = self._backend
        b.kernel(MAX_DISPLACEMENT2)(0, state.y.shape[0], (state.y, self._y_build), self._scalar)
        m = max(float(b.to_host(self._scalar)[0]), 0.0)
        if self.ghosts is not None:
            t0 = _time.perf_counter()
            m = self.sim.comm.allreduce_max(m)  # waits for the slowest rank's force evaluation too
            self.stats["sync_time"] += _time.perf_counter() - t0
        return not 2.0 * math.sqrt(m) < self.skin

    def _build(self, state: ContactState | None) -> ContactState:
        t0 = _time.perf_counter()
        n = self.num_owned
        if self.ghosts is not None:
            state, s, x = self.ghosts.build(self, self.rb)
            near2 = np.concatenate([self.near2, (state.horizon[n:] * (1.0 - 1e-9)) ** 2 if self.near_rule else np.full(state.y.shape[0] - n, -1.0)])
        else:
            s, x, near2 = self._s, self._fields["Model_Coordinates"], self._near2
        assert state is not None
        bonds = self._bonds
        test = (s, state.gid, x, near2, state.block, bool(self.cross_block), self.rb * self.rb, self.search_radius * self.search_radius,
                bonds.offsets, bonds.neighbors, self._bond_gid, self._one_offsets, self._one_gid)
        pairs, cap, passes, largest = build_pairs(self._binning, state.y, test, self.capacity)
        if self.ghosts is not None:  # keep the ghosts some pair lists; refresh only those
            partners = pairs.partners
            used = np.zeros(state.y.shape[0] - n, dtype=bool)
            used[partners[partners >= n] - n] = True
            state, new_index = self.ghosts.keep(state, used)
            pairs = ContactPairs(pairs.offsets, new_index[partners].astype(np.int32), pairs.visits)
            self.state = state
            self.stats["ghosts"] = max(self.stats["ghosts"], state.y.shape[0] - n)
        self.stats["overflows"] += passes - 1
        self.capacity = max(16, cap if passes > 1 else min(cap, 2 * largest + 8))
        self._set_pairs(pairs)
        if self._y_build is None or self._y_build.shape != state.y.shape:
            self._y_build = self._backend.zeros(state.y.shape)
            if self._host:
                self.y_build = self._y_build
        self._backend.kernel(COPY_VECTORS)(0, state.y.shape[0], (state.y, self._y_build))
        self.stats["builds"] += 1
        self.stats["pairs"] = pairs.num_pairs
        self.stats["max_pairs"] = max(self.stats["max_pairs"], pairs.num_pairs)
        self.stats["build_time"] += _time.perf_counter() - t0
        return state

    def potential_energy(self) -> float | None:
        """Energy stored in the contact springs now (None if the model does not say). Collective."""
        if self.pairs is None or self.state is None and self.ghosts is not None:
            return 0.0
        if self.ghosts is None:  # the host's fields (a GPU run's downloaded first)
            fields = self.sim.fields
            state = ContactState(fields["Coordinates"], fields["Velocity"], fields["Volume"], self.horizon, self.block, self.gid,
                                 self.num_owned, self.sim.clock.time)
        else:
            state = self.state
        e = self.model.potential_energy(self.pairs, state)
        return None if e is None else float(self.sim.comm.allreduce_sum(e))

    # -- stability ------------------------------------------------------------------------------
    def stable_time_step(self) -> float:
        """The critical time step estimate with contact springs added to the bonds: every point
        is taken to touch partners of total volume P_i = the larger of its own volume, the volume
        of its own body within R_c and the ball of radius R_c (a deep contact),
        dt_i = sqrt(2 rho_i / (sum_bonds V_j c / |xi| + k_c P_i / m^2)), k_c the model's pair stiffness,
        m = STABLE_STEP_MARGIN."""
        if self._dt_stable is not None:
            return self._dt_stable
        sim = self.sim
        n = self.num_owned
        dt_bonds = sim.critical_time_steps()
        rho = sim.density_per_point()[:n]
        stiffness = self.model.pair_stiffness(self.horizon)
        if stiffness is None or n == 0:
            self._dt_stable = sim.comm.allreduce_min(float(dt_bonds.min()) if n else math.inf)
            return self._dt_stable
        from .bonds import partner_volume_kernel

        vol = sim.fields["Volume"]
        partner = np.empty(n)
        partner_volume_kernel(n, sim.bonds.offsets, sim.bonds.neighbors, sim.fields["Bond_Length"], vol, self.rc, partner)
        # a partner body pressed into the whole ball of radius R_c (deep contact)
        np.maximum(partner, (4.0 / 3.0) * np.pi * np.float64(self.rc) ** 3, out=partner)
        with np.errstate(all="ignore"):
            bond_part = np.where(np.isfinite(dt_bonds), 2.0 * rho / (dt_bonds * dt_bonds), 0.0)
            dt = np.sqrt(2.0 * rho / (bond_part + stiffness * partner / STABLE_STEP_MARGIN**2))
        local = float(np.nanmin(dt)) if n else math.inf
        self._dt_stable = sim.comm.allreduce_min(local)
        return self._dt_stable

    def stiffness_ratio(self) -> float:
        """Spring Constant (for another model: the Spring Constant of Short Range Force springs as
        stiff as its stiffest, pi delta^5 / 18 times its pair stiffness) over the smallest bulk
        modulus of the blocks."""
        k = self.model.spring_constant()
        if k is None:
            stiffness = self.model.pair_stiffness(self.block_horizon)
            k = float(np.max(stiffness * np.pi * self.block_horizon**5 / 18.0)) if stiffness is not None else math.nan
        moduli = [float(blk.material.bulk_modulus) for blk in self.sim.blocks if blk.material.bulk_modulus > 0]
        return k / min(moduli) if moduli else math.nan

    def diagnosis(self, dt: float) -> str:
        """A sentence for an instability report when contact may be the cause ('' otherwise)."""
        try:
            dt_c = self.stable_time_step()
        except Exception:  # a diagnosis must never raise
            return ""
        k = self.model.spring_constant()
        key = type(self.model).stiffness_key
        springs = f"{key} {k:.4g}, " if k is not None else "as stiff as Short Range Force springs of "
        if dt > dt_c:
            return (
                f"contact springs ({springs}{self.stiffness_ratio():.3g} times the bulk modulus) lower the stable "
                f"time step to about {dt_c:.4g}, below the time step {dt:.4g}; use a smaller 'Safety Factor' or 'Fixed dt', or a "
                f"softer '{key}'"
            )
        if self.stats["min_distance"] < self.rc:
            return (
                f"contact springs ({springs}{self.stiffness_ratio():.3g} times the bulk modulus) were active "
                f"(smallest pair distance {self.stats['min_distance']:.4g}, contact radius {self.rc:.4g}); the time step {dt:.4g} is "
                f"below the estimate with contact {dt_c:.4g}, which long contacts of stiff springs can still exceed: halve the "
                f"'Safety Factor' or 'Fixed dt', or use a softer '{key}'"
            )
        return ""

    # -- summary --------------------------------------------------------------------------------
    def summary(self) -> dict[str, Any]:
        """Run statistics reduced over ranks (collective under MPI)."""
        if not self._host:
            self._read_min()
        comm = self.sim.comm
        st = dict(self.stats)
        st["min_distance"] = comm.allreduce_min(float(st["min_distance"]))
        st["penetration"] = st["min_distance"] / self.rc if math.isfinite(st["min_distance"]) else math.inf
        st["contact_radius"] = self.rc
        st["build_time"] = comm.allreduce_max(float(st["build_time"]))
        st["force_time"] = comm.allreduce_max(float(st["force_time"]) - float(st["sync_time"]))
        st["sync_time"] = comm.allreduce_max(float(st["sync_time"]))
        st["pairs"] = comm.allreduce_sum(int(st["pairs"]))
        st["max_pairs"] = comm.allreduce_sum(int(st["max_pairs"]))
        st["ghosts"] = comm.allreduce_sum(int(st["ghosts"]))
        return st
