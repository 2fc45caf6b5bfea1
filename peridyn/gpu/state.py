"""The model on the GPU: device copies of a simulation's fields and bonds, and block views over
them that models compute on through the GPU backend.

Set-up (mesh, neighbors, bond filters, initial damage, weighted volumes, initial conditions)
runs on the CPU; :class:`DeviceModel` then copies what the explicit step reads to the device once.
Fields come back only for output frames, the instability diagnosis and the end of the solver.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ..core.fields import FieldStore


class DeviceFields:
    """Device arrays of a :class:`FieldStore`'s fields, with the same access (``[name]`` the NP1
    array, ``n(name)`` the N array, ``swap``); a field read for the first time is copied then."""

    def __init__(self, host: FieldStore, backend) -> None:
        self.host = host
        self.backend = backend
        self.num_points = host.num_points
        self.num_bonds = host.num_bonds
        self.specs = host.specs
        self._np1: dict[str, Any] = {}
        self._n: dict[str, Any] = {}

    def _upload(self, name: str) -> None:
        h = self.host
        self._np1[name] = self.backend.asarray(h[name])
        try:
            self._n[name] = self.backend.asarray(h.n(name))
        except KeyError:
            pass

    def __contains__(self, name: str) -> bool:
        return name in self.host

    def __getitem__(self, name: str) -> Any:
        if name not in self._np1:
            self._upload(name)
        return self._np1[name]

    def n(self, name: str) -> Any:
        if name not in self._np1:
            self._upload(name)
        return self._n[name]

    def np1(self, name: str) -> Any:
        return self[name]

    def get(self, name: str, default=None):
        return self[name] if name in self else default

    def allocated(self, name: str) -> bool:
        return self.host.allocated(name)

    def names(self) -> list[str]:
        return list(self._np1)

    def swap(self) -> None:
        for name, n in self._n.items():
            self._n[name], self._np1[name] = self._np1[name], n

    def resident(self) -> list[str]:
        """Names of the fields on the device."""
        return list(self._np1)

    def download(self, names=None) -> None:
        """Copy device fields (``names``, default every one on the device) into the host store's
        arrays, N and NP1, in place; the host store's N and NP1 follow the device's swaps."""
        h = self.host
        for name in (self._np1 if names is None else names):
            if name not in self._np1:
                continue
            self._np1[name].copy_to_host(h[name])
            if name in self._n:
                self._n[name].copy_to_host(h.n(name))

    def upload(self, names: list[str]) -> None:
        """Copy the host store's arrays of ``names`` (NP1, and N of two-step fields) to the device:
        fields a host-side step wrote (the data loader's, the Python API's ``Model.set``); a
        field not yet on the device is copied when first read."""
        for name in names:
            if name in self._np1:
                self._np1[name].copy_to_device(self.host[name])
            if name in self._n:
                self._n[name].copy_to_device(self.host.n(name))

    def nbytes(self) -> int:
        return sum(int(a.nbytes) for a in self._np1.values()) + sum(int(a.nbytes) for a in self._n.values())


class DeviceBonds:
    """The CSR bonds (``offsets``, ``neighbors``) on the device, and the reverse lookup of one
    bond's twin when a model asks for it."""

    def __init__(self, host, backend) -> None:
        self.host = host
        self.backend = backend
        self.offsets = backend.asarray(host.offsets)
        self.neighbors = backend.asarray(host.neighbors)
        self._reverse = None

    @property
    def num_points(self) -> int:
        return self.host.num_points

    @property
    def num_bonds(self) -> int:
        return self.host.num_bonds

    def reverse(self) -> Any:
        if self._reverse is None:
            self._reverse = self.backend.asarray(self.host.reverse())
        return self._reverse


class DeviceModel:
    """The device side of a :class:`~peridyn.engine.simulation.Simulation` for an explicit run:
    its fields, bonds, and a view per block (and per fused group) that the block's material and
    damage model compute on with the GPU backend."""

    def __init__(self, sim, backend) -> None:
        self.sim = sim
        self.backend = backend
        self.fields = DeviceFields(sim.fields, backend)
        self.bonds = DeviceBonds(sim.bonds, backend)
        self.views: dict[int, Any] = {}
        self.fused_views: dict[int, Any] = {}
        for blk in sim.blocks:
            self.views[blk.index] = self._view(blk.view)
            if blk.fused_view is not None:
                self.fused_views[blk.index] = self._view(blk.fused_view)

    def _view(self, view):
        return replace(view, fields=self.fields, bonds=self.bonds, backend=self.backend)

    def view(self, blk):
        return self.views[blk.index]

    def force_view(self, blk):
        """The view a fused block's material computes its group's forces on."""
        return self.fused_views.get(blk.index, self.views[blk.index])

    def memory_per_point(self) -> float:
        """Bytes of device fields and bonds per owned point."""
        b = self.fields.nbytes() + int(self.bonds.offsets.nbytes) + int(self.bonds.neighbors.nbytes)
        return b / max(self.sim.num_owned, 1)

    def host_array(self, name: str) -> np.ndarray:
        return self.sim.fields[name]
