"""Declared fields and the store that allocates them (DESIGN.md decision 4).

Models, damage models, contact models and computes declare the fields they read and write as
:class:`FieldSpec`; the engine allocates exactly those (plus the few every run needs) and nothing
else. A deck without a damage model therefore has no ``Bond_Damage`` array at all.

Point fields (``NODE`` and ``ELEMENT``) have one row per local point (owned points first, then
ghosts); ``BOND`` fields one row per bond of the neighbor list (CSR order); ``GLOBAL`` fields one
row. Two-step fields keep an N and an NP1 array and advance by swapping references.
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import Enum, IntEnum
from typing import Callable

import numpy as np


class Relation(Enum):
    NODE = "node"  #: per point, written as an Exodus nodal variable (vectors split X/Y/Z)
    ELEMENT = "element"  #: per point, written as an Exodus element variable
    BOND = "bond"  #: per bond (never written to Exodus)
    GLOBAL = "global"  #: one value (or vector) for the whole model


class Length(IntEnum):
    SCALAR = 1
    VECTOR = 3
    TENSOR = 9


class Temporal(Enum):
    CONSTANT = "constant"
    TWO_STEP = "two_step"


@dataclass(frozen=True)
class FieldSpec:
    """What a field is.

    name: Peridigm's field name (``Dilatation``, ``Bond_Damage``); output variables use it.
    relation: per point (NODE/ELEMENT), per bond or global.
    length: components per entry (1, 3 or 9; any positive int for N-length data).
    temporal: CONSTANT (one array) or TWO_STEP (N and NP1 arrays, swapped after each step).
    halo: under MPI, ghost copies are refreshed when the engine exchanges halos.
    units: for documentation.
    dtype: numpy dtype name; e.g. ``"uint8"`` for bond damage that is only ever 0 or 1 (one byte
        per bond instead of eight). Two declarations with different dtypes get float64.
    """

    name: str
    relation: Relation = Relation.ELEMENT
    length: int = Length.SCALAR
    temporal: Temporal = Temporal.CONSTANT
    halo: bool = False
    units: str = ""
    dtype: str = "float64"

    @property
    def is_point(self) -> bool:
        return self.relation in (Relation.NODE, Relation.ELEMENT)

    def compatible(self, other: "FieldSpec") -> bool:
        return (self.relation, int(self.length)) == (other.relation, int(other.length))


class FieldStore:
    """Arrays of the declared fields.

    ``store[name]`` is the NP1 (current) array, ``store.n(name)`` the N (previous step) array of a
    two-step field. Point arrays have shape (num_points,) for scalars and (num_points, length)
    otherwise; bond arrays (num_bonds,) or (num_bonds, length); global arrays (length,).
    """

    def __init__(self, num_points: int, num_bonds: int) -> None:
        self.num_points = num_points
        self.num_bonds = num_bonds
        self.specs: dict[str, FieldSpec] = {}
        self._np1: dict[str, np.ndarray] = {}
        self._n: dict[str, np.ndarray] = {}
        self._lazy: dict[str, Callable[[np.ndarray], None]] = {}
        #: the fields declared lazy: constants the store fills itself from the reference
        #: configuration, whenever first read (a checkpoint need not hold them)
        self.derived: set[str] = set()

    # declaration -----------------------------------------------------------------------------
    def declare(self, spec: FieldSpec) -> None:
        """Declare ``spec``; a field declared twice must agree in relation and length. Declaring
        a field two-step where it was constant (or the reverse) makes it two-step."""
        old = self.specs.get(spec.name)
        if old is None:
            self.specs[spec.name] = spec
        else:
            if not old.compatible(spec):
                raise ValueError(f"field {spec.name} declared twice with different shapes: {old} vs {spec}")
            temporal = Temporal.TWO_STEP if Temporal.TWO_STEP in (old.temporal, spec.temporal) else Temporal.CONSTANT
            dtype = old.dtype if old.dtype == spec.dtype else "float64"
            merged = FieldSpec(old.name, old.relation, old.length, temporal, old.halo or spec.halo, old.units or spec.units, dtype)
            self.specs[spec.name] = merged
            if spec.name in self._np1 and dtype != old.dtype:
                self._np1[spec.name] = self._np1[spec.name].astype(dtype)
                if spec.name in self._n:
                    self._n[spec.name] = self._n[spec.name].astype(dtype)
            if spec.name in self._np1 and temporal is Temporal.TWO_STEP and spec.name not in self._n:
                self._n[spec.name] = self._np1[spec.name].copy()
        if spec.name not in self._np1:
            self._allocate(self.specs[spec.name])

    def declare_lazy(self, spec: FieldSpec, fill: Callable[[np.ndarray], None]) -> None:
        """Declare a constant field allocated and filled (``fill(array)``) only when first read:
        a run whose kernels never read it never holds it (e.g. Bond_Length, 8 bytes a bond, for
        models that take bond lengths from the reference positions)."""
        if spec.temporal is not Temporal.CONSTANT or spec.name in self.specs:
            raise ValueError(f"field {spec.name}: only a new constant field can be lazy")
        self.specs[spec.name] = spec
        self._lazy[spec.name] = fill
        self.derived.add(spec.name)

    def allocated(self, name: str) -> bool:
        """Whether the field's array exists (a lazy field before its first read does not)."""
        return name in self._np1

    def declare_all(self, specs) -> None:
        for spec in specs:
            self.declare(spec)

    def _shape(self, spec: FieldSpec) -> tuple[int, ...]:
        rows = {Relation.BOND: self.num_bonds, Relation.GLOBAL: None}.get(spec.relation, self.num_points)
        length = int(spec.length)
        if rows is None:
            return (length,)
        return (rows,) if length == 1 else (rows, length)

    def _allocate(self, spec: FieldSpec) -> None:
        shape = self._shape(spec)
        self._np1[spec.name] = np.zeros(shape, dtype=spec.dtype)
        if spec.temporal is Temporal.TWO_STEP:
            self._n[spec.name] = np.zeros(shape, dtype=spec.dtype)

    # access ----------------------------------------------------------------------------------
    def __contains__(self, name: str) -> bool:
        return name in self._np1 or name in self._lazy

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self._np1[name]
        except KeyError:
            fill = self._lazy.pop(name, None)
            if fill is None:
                raise KeyError(f"field {name!r} was not declared by any model, compute or output") from None
            self._allocate(self.specs[name])
            fill(self._np1[name])
            return self._np1[name]

    def n(self, name: str) -> np.ndarray:
        """The N (previous step) array of a two-step field."""
        return self._n[name]

    def np1(self, name: str) -> np.ndarray:
        return self[name]

    def get(self, name: str, default=None):
        return self[name] if name in self else default

    def set(self, name: str, array: np.ndarray) -> None:
        """Replace the NP1 array of a declared field (same shape)."""
        if self._np1[name].shape != array.shape:
            raise ValueError(f"field {name}: shape {array.shape} != {self._np1[name].shape}")
        self._np1[name] = array

    def names(self) -> list[str]:
        return list(self._np1)

    def swap(self) -> None:
        """Advance two-step fields: N <-> NP1 by reference (no copy)."""
        for name, n in self._n.items():
            self._n[name], self._np1[name] = self._np1[name], n

    def nbytes(self) -> int:
        return sum(a.nbytes for a in self._np1.values()) + sum(a.nbytes for a in self._n.values())

    def snapshot(self) -> dict[tuple[str, str], np.ndarray]:
        """Copies of every array (N and NP1), for :meth:`restore`."""
        out = {("np1", k): a.copy() for k, a in self._np1.items()}
        out.update({("n", k): a.copy() for k, a in self._n.items()})
        return out

    def restore(self, snapshot: dict[tuple[str, str], np.ndarray]) -> None:
        """Put back the values of :meth:`snapshot` into the same arrays (references held
        elsewhere stay valid): every field exactly as it was."""
        for (which, name), saved in snapshot.items():
            np.copyto((self._np1 if which == "np1" else self._n)[name], saved)


TENSOR_SUFFIXES = ("XX", "XY", "XZ", "YX", "YY", "YZ", "ZX", "ZY", "ZZ")


def component_names(spec: FieldSpec, name: str | None = None) -> list[str]:
    """Exodus names of a field's components: V -> VX VY VZ, T -> TXX..TZZ, others _1.._n."""
    name = name or spec.name
    n = int(spec.length)
    if n == 1:
        return [name]
    if n == 3:
        return [name + c for c in "XYZ"]
    if n == 9:
        return [name + c for c in TENSOR_SUFFIXES]
    return [f"{name}_{k + 1}" for k in range(n)]
