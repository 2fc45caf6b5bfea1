"""Node-set conditions of an explicit step applied to the device fields: the host evaluates each
condition's expression on its node set (as on the CPU, ``BoundaryCondition.evaluate``), the
values go to the device, and a kernel writes them where the CPU code does."""
from __future__ import annotations

from typing import Any

import numpy as np

from . import kernels as K
from .state import DeviceModel


class DeviceConditions:
    """The kinematic and force conditions of a simulation applied to device fields."""

    def __init__(self, sim, dev: DeviceModel) -> None:
        self.sim = sim
        self.dev = dev
        b = dev.backend
        self._points = {id(c): b.asarray(np.ascontiguousarray(c.points)) for c in list(sim.kinematic) + list(sim.force_conditions)}
        self._temperature0: dict[int, Any] = {}

    def _launch(self, kernel, n: int, *args) -> None:
        if n:
            kernel[self.dev.backend.grid(n)](*args)

    def apply_kinematic(self, t: float, t_prev: float) -> None:
        f, b = self.dev.fields, self.dev.backend
        for c in self.sim.kinematic:
            pts = self._points[id(c)]
            n = len(c.points)
            kind = type(c).__name__
            if kind == "PrescribedDisplacement":
                if t == t_prev:
                    continue
                current, previous = b.asarray(c.evaluate(t)), b.asarray(c.evaluate(t_prev))
                self._launch(K.prescribed_displacement, n, pts, c.component, current, previous, 1.0 / (t - t_prev), f["Displacement"], f["Velocity"])
            elif kind == "PrescribedTemperature":
                value = b.asarray(c.evaluate(t))
                self._launch(K.set_scalar, n, pts, value, f["Temperature"])
                if t != t_prev:
                    base = self._temperature0.get(id(c))
                    if base is None:
                        base = self._temperature0[id(c)] = b.asarray(c.evaluate(0.0))
                    self._launch(K.set_difference, n, pts, value, base, f["Temperature_Change"])
            else:  # refused before the run (peridyn.gpu.support)
                raise AssertionError(f"no GPU path for {kind}")

    def apply_body_forces(self, t: float) -> None:
        if not self.sim.force_conditions:
            return
        f, b = self.dev.fields, self.dev.backend
        ext = f["External_Force_Density"]
        self._launch(K.fill, ext.shape[0], ext, 0.0)
        for c in self.sim.force_conditions:
            self._launch(K.set_component, len(c.points), self._points[id(c)], c.component, b.asarray(c.evaluate(t)), ext)
