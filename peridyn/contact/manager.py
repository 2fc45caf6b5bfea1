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
"""
from __future__ import annotations

import logging
import math
import time as _time
from typing import Any

import numpy as np

from ..core.errors import InputError
from ..core.fields import FieldSpec, Length, Relation
from ..core.interfaces import ContactPairs, ContactState
from .bonds import one_sided_partners
from .search import max_displacement2_kernel, min_pair_distance2_kernel, search_pairs

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
        self.pairs: ContactPairs | None = None
        self.state: ContactState | None = None
        self.y_build: np.ndarray | None = None
        self.capacity = 16
        self.stats = {"searches": 1, "builds": 0, "build_time": 0.0, "force_time": 0.0, "force_calls": 0, "pairs": 0,
                      "max_pairs": 0, "overflows": 0, "ghosts": 0, "min_distance": math.inf, "min_distance_time": math.nan, "sync_time": 0.0}
        self._dt_stable: float | None = None

    # -- what the explicit solver calls ----------------------------------------------------------
    def begin_step(self, step: int) -> None:
        """Start of explicit step ``step`` (1, 2, ...), before the first half kick: a search is
        due when step % Search Frequency == 0, on the current (previous step's) positions."""
        if step % self.frequency == 0:
            np.copyto(self.s, self.sim.fields["Coordinates"][: self.num_owned])
            self.pairs = None
            self.stats["searches"] += 1

    def add_force(self, f: np.ndarray, t: float, step: int) -> None:
        """Contact_Force_Density of the owned points at the current positions and velocities,
        added to the force density f (n, 3). Step 0 uses the friction law's value at t = 0."""
        t0 = _time.perf_counter()
        sim = self.sim
        n = self.num_owned
        if step > 0:
            self.model.begin_step(t)
        state = self._current_state(t)
        if self.pairs is None or self._moved_too_far(state):
            state = self._build(state)
        fc = sim.fields["Contact_Force_Density"]
        out = fc[:n]
        out[...] = 0.0
        self.model.force(self.pairs, state, out)
        f[:n] += out
        d2 = min_pair_distance2_kernel(n, self.pairs.offsets, self.pairs.partners, state.y) if self.pairs.num_pairs else math.inf
        if d2 < self.stats["min_distance"] ** 2:
            self.stats["min_distance"] = math.sqrt(d2)
            self.stats["min_distance_time"] = t
        self.stats["force_time"] += _time.perf_counter() - t0
        self.stats["force_calls"] += 1

    # -- pairs ----------------------------------------------------------------------------------
    def _current_state(self, t: float) -> ContactState:
        sim = self.sim
        fields = sim.fields
        if self.ghosts is None:
            n = self.num_owned
            state = self.state
            if state is None:
                state = self.state = ContactState(
                    fields["Coordinates"], fields["Velocity"], fields["Volume"], self.horizon, self.block, self.gid, n
                )
            state.time = t
            return state
        if self.state is not None:
            self.ghosts.update(self.state)
            self.state.time = t
        return self.state  # None before the first build (built with the ghosts)

    def _moved_too_far(self, state: ContactState | None) -> bool:
        if state is None or self.y_build is None:
            return True
        m = max_displacement2_kernel(state.y.shape[0], state.y, self.y_build)
        if self.ghosts is not None:
            t0 = _time.perf_counter()
            m = self.sim.comm.allreduce_max(m)  # waits for the slowest rank's force evaluation too
            self.stats["sync_time"] += _time.perf_counter() - t0
        return not 2.0 * math.sqrt(m) < self.skin

    def _build(self, state: ContactState | None) -> ContactState:
        t0 = _time.perf_counter()
        sim = self.sim
        n = self.num_owned
        if self.ghosts is not None:
            state, s, x = self.ghosts.build(self, self.rb)
            near2 = np.concatenate([self.near2, (state.horizon[n:] * (1.0 - 1e-9)) ** 2 if self.near_rule else np.full(state.y.shape[0] - n, -1.0)])
        else:
            s, x, near2 = self.s, sim.fields["Model_Coordinates"], self.near2
        assert state is not None
        offsets, partners, visits, cap, passes = search_pairs(
            n, state.y, s, state.gid, self.rb, self.search_radius, sim.bonds, sim.gid, self.one_offsets, self.one_gid, self.capacity,
            shortcut=(x, near2, state.block, self.cross_block),
        )
        if self.ghosts is not None:  # keep the ghosts some pair lists; refresh only those
            used = np.zeros(state.y.shape[0] - n, dtype=bool)
            used[partners[partners >= n] - n] = True
            state, new_index = self.ghosts.keep(state, used)
            partners = new_index[partners].astype(np.int32)
            self.state = state
            self.stats["ghosts"] = max(self.stats["ghosts"], state.y.shape[0] - n)
        self.stats["overflows"] += passes - 1
        largest = int(np.diff(offsets).max()) if n else 0
        self.capacity = max(16, cap if passes > 1 else min(cap, 2 * largest + 8))
        self.pairs = ContactPairs(offsets, partners, visits)
        self.y_build = np.array(state.y, copy=True)
        self.stats["builds"] += 1
        self.stats["pairs"] = self.pairs.num_pairs
        self.stats["max_pairs"] = max(self.stats["max_pairs"], self.pairs.num_pairs)
        self.stats["build_time"] += _time.perf_counter() - t0
        return state

    def potential_energy(self) -> float | None:
        """Energy stored in the contact springs now (None if the model does not say). Collective."""
        if self.pairs is None or self.state is None and self.ghosts is not None:
            return 0.0
        state = self._current_state(self.sim.state.time) if self.ghosts is None else self.state
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
        k = float(getattr(self.model.params, "spring_constant", math.nan))
        if not math.isfinite(k):
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
        k = getattr(self.model.params, "spring_constant", None)
        key = type(self.model).stiffness_key
        springs = f"{key} {k:.4g}, " if isinstance(k, float) else "as stiff as Short Range Force springs of "
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
