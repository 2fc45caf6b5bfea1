"""The step's arrays on one GPU (:class:`~peridyn.core.placement.Placement` on the device): the
simulation's fields and bonds copied to the device once (:class:`~peridyn.gpu.state.DeviceModel`),
the materials' and damage models' laws run on them by the GPU backend, and the host's arrays
made current only where the run's services read them (output frames, checkpoints, the
instability diagnosis, the range watch, the Python API, the end of the solver).

Set-up (mesh, neighbors, bond filters, initial damage, weighted volumes, initial conditions,
a checkpoint's state) runs on the CPU before this placement is made.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..core.placement import StepContact
from ..core.state import SolverState
from ..core.traversal import Backend
from .state import DeviceModel


class DevicePlacement:
    """A :class:`~peridyn.core.placement.Placement` on the GPU backend ``backend``, whose
    acceleration is a device copy of ``state``'s (made zero where it has none yet)."""

    delta_u = None  #: implicit solvers run on the host
    delta_p = None

    def __init__(self, sim: Any, backend: Backend, state: SolverState) -> None:
        self.sim = sim
        self.state = state
        self.backend = backend
        self.model = DeviceModel(sim, backend)
        self.fields = self.model.fields
        self.no_vectors = backend.zeros((0, 3))
        if state.acceleration is None:
            state.acceleration = np.zeros((sim.num_local, 3))
        self.acceleration = backend.asarray(state.acceleration)
        self._contact = None
        if sim.contact is not None:  # the manager's schedule on the device arrays, the GPU's binning
            from .pair_search import BucketSearch

            c = sim.contact
            self._contact = c.place(backend, self.fields, self.model.bonds, BucketSearch(backend, c.num_owned, c.rb))

    @property
    def contact(self) -> StepContact | None:
        return self._contact

    def resident(self, array: Any) -> Any:
        return self.backend.resident(array)

    def asarray(self, array: Any) -> Any:
        return self.backend.asarray(array)

    def zeros(self, shape: int | tuple[int, ...], dtype: Any = float) -> Any:
        return self.backend.zeros(shape, dtype)

    def evaluate_forces(self) -> Any:
        """Damage, precompute and the fused force of every block on the device (every block is
        fused; ``peridyn.gpu.support``); returns the device Force_Density."""
        sim, dev = self.sim, self.model
        f = self.fields["Force_Density"]
        for blk in sim.blocks:
            if blk.damage is not None:
                blk.damage.update(dev.view(blk))
        for blk in sim.blocks:
            blk.material.precompute(dev.view(blk))
        for blk in sim.blocks:
            if blk.group and not blk.material.force_fused(dev.force_view(blk), f):
                raise RuntimeError(f"material {blk.material.name!r} declined the fused force of block {blk.name!r} on the GPU")
        return f

    def load_data(self, t: float) -> None:
        loader = self.sim.data_loader
        if loader is not None:
            loader.load(t)
            self.upload([loader.name])

    def upload(self, names: list[str]) -> None:
        """Copy host fields ``names`` that code outside the step wrote to the device."""
        self.fields.upload(names)

    def to_host(self, names: list[str] | None = None) -> None:
        """Copy the device's fields (``names``, default all), the acceleration and the contact
        state into the simulation's and the solver state's host arrays."""
        self.fields.download(names)
        if names is None:
            self.acceleration.copy_to_host(self.state.acceleration)
            if self._contact is not None:
                self._contact.to_host()

    def advance(self) -> None:
        self.fields.swap()
        self.sim.fields.swap()

    def memory_per_point(self) -> float | None:
        return self.model.memory_per_point()
