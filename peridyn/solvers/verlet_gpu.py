"""Velocity-Verlet on one GPU (``peridyn run --device gpu``): the step of :class:`peridyn.solvers.verlet.Verlet`, operation for
operation, with the fields on the device.

Per step the host evaluates the node-set conditions' expressions (their values, one array per
condition, go to the device), and reads back seven sums for the energy monitor. Output frames,
the instability diagnosis and the end of the solver copy fields back to the host, where the
output writers and computes run as on the CPU.
"""
from __future__ import annotations

import logging
import math
import time as _time
from typing import Any

import numpy as np

from ..core.errors import InstabilityError
from ..gpu import kernels as K
from ..gpu.conditions import DeviceConditions
from ..gpu.state import DeviceModel
from .common import EnergyMonitor, judge_energy
from .progress import Progress

log = logging.getLogger("peridyn.solver")


def evaluate_forces(sim, dev: DeviceModel) -> Any:
    """``Simulation.evaluate_forces`` on the device (every block fused; see gpu.support):
    damage, precompute, fused force. Returns the device Force_Density."""
    f = dev.fields["Force_Density"]
    for blk in sim.blocks:
        if blk.damage is not None:
            blk.damage.update(dev.view(blk))
    for blk in sim.blocks:
        blk.material.precompute(dev.view(blk))
    for blk in sim.blocks:
        if blk.group and not blk.material.force_fused(dev.force_view(blk), f):
            raise RuntimeError(f"material {blk.material.name!r} declined the fused force of block {blk.name!r} on the GPU")
    return f


class DeviceEnergyMonitor(EnergyMonitor):
    """:class:`EnergyMonitor` whose per-step sums are reduced on the device (seven numbers cross
    to the host per step); its diagnoses copy the fields back first."""

    def __init__(self, sim, dev: DeviceModel, acceleration, dt: float, dt_estimate: float, *, beyond_limit: bool) -> None:
        super().__init__(sim, dt, dt_estimate, beyond_limit=beyond_limit)
        self.dev = dev
        b = dev.backend
        n = sim.num_owned
        self._n = n
        self._free = b.asarray(np.ascontiguousarray(self.free))
        self._mass = b.asarray(np.ascontiguousarray(self.mass))
        self._a = acceleration
        self._blocks = max(1, min(K.REDUCE_BLOCKS, (n + K.REDUCE_THREADS - 1) // K.REDUCE_THREADS))
        self._partial = b.zeros((max(self._blocks, 1), K.SUMS))
        self._out = b.zeros(K.SUMS)
        self._work = None
        self._empty = b.zeros((0, 3))
        self.contact = None  #: the run's DeviceContact, synchronized for a diagnosis

    def force_work(self, du, f_old, f_new, b_old, b_new) -> None:
        self._work = (du, f_old, f_new, b_old if b_old is not None else self._empty, b_new if b_new is not None else self._empty)

    def check(self, step: int, time: float) -> None:
        du, f_old, f_new, b_old, b_new = self._work
        f = self.dev.fields
        K.energy_partials[self._blocks, K.REDUCE_THREADS](self._n, du, f_old, f_new, b_old, b_new, f["Volume"], self._free,
                                                           f["Velocity"], self._mass, self._a, self._partial)
        K.reduce_partials[1, K.REDUCE_THREADS](self._partial, self._blocks, self._out)
        s = self._out.copy_to_host()
        s[5] *= 0.25 * self.dt * self.dt
        s[6] *= 0.25 * self.dt * self.dt
        self._account(step, time, s)

    def _sync(self) -> None:
        self.dev.fields.download(["Velocity", "Force_Density", "Displacement", "Coordinates"])
        if self.sim.acceleration is not None:
            self._a.copy_to_host(self.sim.acceleration)
        if self.contact is not None:
            self.contact.to_host()

    def _locate(self, vectors):
        self._sync()
        return super()._locate(vectors)

    def _advice(self) -> str:
        self._sync()
        return super()._advice()


def run(solver, sim) -> None:
    """``Verlet.run`` on the GPU backend of ``sim`` (arrays copied to the device here)."""
    s = solver.params
    dt, dt_crit = solver.time_step(sim)
    t0 = s.initial_time
    nsteps = solver._steps(sim, dt)
    dt2 = dt / 2.0
    n = sim.num_local
    backend = sim.device_backend
    setup0 = _time.perf_counter()
    dev = DeviceModel(sim, backend)
    f = dev.fields
    has_b = "External_Force_Density" in f
    rho = backend.asarray(sim.density_per_point())
    if sim.acceleration is None:
        sim.acceleration = np.zeros((n, 3))
    a = backend.asarray(sim.acceleration)
    sim.set_time_step(dt)
    dev.set_time(t0, dt)
    x, y, u, v = f["Model_Coordinates"], f["Coordinates"], f["Displacement"], f["Velocity"]
    no_b = backend.zeros((0, 3))
    conditions = DeviceConditions(sim, dev)
    contact = None
    if sim.contact is not None:
        from ..gpu.contact import DeviceContact

        contact = DeviceContact(sim.contact, dev)
    grid = backend.grid(n)
    log.info("%s: Verlet on the GPU, dt = %.6g (critical estimate %.6g), %d steps from t = %.6g to %.6g", solver.section, dt, dt_crit,
             nsteps, t0, t0 + nsteps * dt)

    # step 0
    sim.time_prev = sim.time = t = t0
    evaluate_forces(sim, dev)
    if contact is not None:
        contact.add_force(f["Force_Density"], t, 0)
    conditions.apply_kinematic(t, t)
    conditions.apply_body_forces(t)
    K.acceleration_kick[grid](n, f["Force_Density"], f["External_Force_Density"] if has_b else no_b, rho, dt2, a, v, False)
    f.download()
    a.copy_to_host(sim.acceleration)
    if contact is not None:
        contact.to_host()
    sim.write_output(t)
    limit = solver._measure(sim, dt, dt_crit, nsteps)
    if math.isfinite(limit):
        log.info("%s: stable limit measured on the model: at most %.4g (%.3g x the estimate)", solver.section, limit, limit / dt_crit)
    monitor = DeviceEnergyMonitor(sim, dev, a, dt, dt_crit, beyond_limit=dt >= limit)
    monitor.contact = contact
    f_old = backend.zeros((n, 3))
    b_old = backend.zeros((n, 3)) if has_b else None
    du = backend.zeros((n, 3))
    progress = Progress(nsteps, f"{solver.section}", enabled=sim.progress)
    writers = sim.outputs
    setup = _time.perf_counter() - setup0
    wall0 = _time.perf_counter()
    try:
        for step in range(1, nsteps + 1):
            t_prev = t
            t = t0 + float(step) * dt
            sim.time_prev, sim.time = t_prev, t
            sim.begin_step(t)
            if contact is not None:
                contact.begin_step(step)
            K.kick[grid](n, v, a, dt2)
            conditions.apply_kinematic(t, t_prev)
            f_old.copy_to_device(f["Force_Density"])
            if has_b:
                b_old.copy_to_device(f["External_Force_Density"])
            conditions.apply_body_forces(t)
            K.drift[grid](n, v, dt, x, u, y, du)
            evaluate_forces(sim, dev)
            if contact is not None:
                contact.add_force(f["Force_Density"], t, step)
            K.acceleration_kick[grid](n, f["Force_Density"], f["External_Force_Density"] if has_b else no_b, rho, dt2, a, v, True)
            monitor.force_work(du, f_old, f["Force_Density"], b_old, f["External_Force_Density"] if has_b else None)
            monitor.check(step, t)
            if writers.due_next():
                f.download()
                a.copy_to_host(sim.acceleration)
                if contact is not None:
                    contact.to_host()
            sim.write_output(t)
            f.swap()
            sim.fields.swap()
            progress.update(step)
    except InstabilityError:
        f.download()
        a.copy_to_host(sim.acceleration)
        if contact is not None:
            contact.to_host()
        raise
    backend.synchronize()
    wall = _time.perf_counter() - wall0
    f.download()
    a.copy_to_host(sim.acceleration)
    if contact is not None:
        contact.to_host()
    monitor.flush()
    progress.close()
    sim.stats.setdefault("solvers", []).append(
        {
            "section": solver.section,
            "method": "Verlet",
            "device": "gpu",
            "steps": nsteps,
            "dt": dt,
            "dt_estimate": dt_crit,
            "wall": wall,
            "device_setup": setup,
            "force_time": wall,
            "bond_evaluations": nsteps * sim.num_bonds_global,
            "point_steps": nsteps * sim.num_global,
            "device_bytes_per_point": dev.memory_per_point(),
            "contact": contact.summary() if contact is not None else None,
            "energy": monitor.account(),
        }
    )
    p = solver.params.verlet
    judge_energy(monitor, solver.section, dt, dt_crit, fixed_dt=p.fixed_dt is not None or p.safety_factor is None)
