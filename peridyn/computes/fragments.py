"""Fragments: the connected components of the intact bonds, and each one's mass, centre-of-mass
velocity and kinetic energy (no peridynamics code has it built in).

A fragment is a set of points joined by chains of bonds whose ``Bond_Damage`` is below 1 (every
bond in a run without damage). Fragments are numbered 1, 2, ... in the order of their smallest
global point id, so the numbers are the same serially and on any number of ranks. Under MPI the
labels (the smallest global id of the component) spread across rank boundaries through the halo
until no rank changes one; the per-fragment sums are combined over the ranks.

Outputs (each a compute; one labelling per output step serves all of them):
``Fragment_Id`` (element), ``Fragment_Mass`` (element, M: the mass of the point's fragment),
``Fragment_Velocity`` (node, L/T: its centre-of-mass velocity), ``Fragment_Kinetic_Energy``
(element, M L^2/T^2: the sum of 1/2 m |v|^2 over its points), ``Number_Of_Fragments`` (global).
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from ..core.fields import FieldSpec, Relation
from ..core.interfaces import Compute


@njit(cache=True)
def _root(parent: np.ndarray, i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(cache=True)
def component_labels(rows: int, offsets: np.ndarray, neighbors: np.ndarray, intact: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """The smallest of ``labels`` over each point's component of the graph of intact bonds.

    rows: points whose bond rows are read (the owned points); offsets (rows+1,), neighbors (nb,)
    local indices (owned or ghost); intact (nb,) uint8, or empty for every bond intact; labels
    (n_local,) float64, a point's current label (its global id at first; a ghost's, its
    owner's). Returns (n_local,) float64. Serial union-find with path halving, the root of each
    union the one with the smaller label: the same components whatever the bond order."""
    n = labels.shape[0]
    parent = np.arange(n)
    every = intact.shape[0] == 0
    for i in range(rows):
        for b in range(offsets[i], offsets[i + 1]):
            if every or intact[b]:
                ri, rj = _root(parent, i), _root(parent, neighbors[b])
                if ri != rj:
                    if labels[rj] < labels[ri]:
                        parent[ri] = rj
                    else:
                        parent[rj] = ri
    out = np.empty(n)
    for i in range(n):
        out[i] = labels[_root(parent, i)]
    return out


@dataclass
class FragmentState:
    """One labelling: at ``time``, every local point's fragment number (1..count) and the
    fragments' masses (count,), centre-of-mass velocities (count, 3) and kinetic energies (count,)."""

    time: float
    number: np.ndarray
    mass: np.ndarray
    velocity: np.ndarray
    kinetic: np.ndarray

    @property
    def count(self) -> int:
        return int(self.mass.shape[0])


def _intact(sim: Any) -> np.ndarray:
    """(nb,) uint8, 1 for a bond whose damage is below 1; empty (every bond intact) without damage."""
    if sim.fields.allocated("Bond_Damage"):
        return np.ascontiguousarray(sim.fields["Bond_Damage"] < 1.0, dtype=np.uint8)
    return np.zeros(0, dtype=np.uint8)


def label_fragments(sim: Any) -> FragmentState:
    """Label the fragments of ``sim`` now (collective under MPI)."""
    nl = sim.bonds
    owned = sim.num_owned
    intact = _intact(sim)
    labels = np.asarray(sim.gid, dtype=np.float64).copy()
    while True:
        new = component_labels(owned, nl.offsets, nl.neighbors, intact, labels)
        changed = bool(np.any(new[:owned] != labels[:owned]))
        labels = new
        if sim.comm.size == 1:
            break
        sim.halo.exchange(labels)  # ghosts take their owners' labels
        if not sim.comm.allreduce_max(1.0 if changed else 0.0):
            break
    own = labels[:owned]
    rho = sim.density_per_point()[:owned]
    m = rho * sim.fields["Volume"][:owned]
    v = sim.fields["Velocity"][:owned]
    ke = 0.5 * m * np.einsum("ij,ij->i", v, v)
    keys, inverse = np.unique(own, return_inverse=True)
    part = np.zeros((keys.shape[0], 5))  # mass, momentum (3), kinetic energy
    np.add.at(part, inverse, np.column_stack([m, m[:, None] * v, ke]))
    if sim.comm.size > 1:
        tables = sim.comm.allgather((keys, part))
        every = np.concatenate([k for k, _ in tables])
        keys, where = np.unique(every, return_inverse=True)
        total = np.zeros((keys.shape[0], 5))
        np.add.at(total, where, np.concatenate([p for _, p in tables]))
        part = total
        inverse = np.searchsorted(keys, own)
    mass = part[:, 0]
    velocity = part[:, 1:4] / np.where(mass > 0.0, mass, 1.0)[:, None]
    return FragmentState(float(sim.clock.time), inverse + 1, mass, velocity, part[:, 4])


#: the labelling of each live simulation at its last output time, shared by the fragment computes
_LABELLED: "weakref.WeakKeyDictionary[Any, FragmentState]" = weakref.WeakKeyDictionary()


class _FragmentCompute(Compute):
    def state(self, sim: Any) -> FragmentState:
        hit = _LABELLED.get(sim)
        if hit is None or hit.time != float(sim.clock.time):
            hit = _LABELLED[sim] = label_fragments(sim)
        return hit


class FragmentId(_FragmentCompute):
    """The number (1, 2, ...) of each point's fragment, in the order of the fragments' smallest global ids."""

    name = "Fragment_Id"

    def outputs(self, sim):
        return [FieldSpec(self.name, Relation.ELEMENT)]

    def compute(self, sim):
        sim.fields[self.name][: sim.num_owned] = self.state(sim).number


class FragmentMass(_FragmentCompute):
    """The mass (M) of each point's fragment."""

    name = "Fragment_Mass"

    def outputs(self, sim):
        return [FieldSpec(self.name, Relation.ELEMENT)]

    def compute(self, sim):
        s = self.state(sim)
        sim.fields[self.name][: sim.num_owned] = s.mass[s.number - 1]


class FragmentVelocity(_FragmentCompute):
    """The centre-of-mass velocity (L/T) of each point's fragment."""

    name = "Fragment_Velocity"

    def outputs(self, sim):
        return [FieldSpec(self.name, Relation.NODE, 3)]

    def compute(self, sim):
        s = self.state(sim)
        sim.fields[self.name][: sim.num_owned] = s.velocity[s.number - 1]


class FragmentKineticEnergy(_FragmentCompute):
    """The kinetic energy (M L^2/T^2) of each point's fragment: the sum of 1/2 m |v|^2 over its points."""

    name = "Fragment_Kinetic_Energy"

    def outputs(self, sim):
        return [FieldSpec(self.name, Relation.ELEMENT)]

    def compute(self, sim):
        s = self.state(sim)
        sim.fields[self.name][: sim.num_owned] = s.kinetic[s.number - 1]


class NumberOfFragments(_FragmentCompute):
    """How many fragments the model has (global)."""

    name = "Number_Of_Fragments"

    def outputs(self, sim):
        return [FieldSpec(self.name, Relation.GLOBAL)]

    def compute(self, sim):
        sim.fields[self.name][0] = float(self.state(sim).count)
