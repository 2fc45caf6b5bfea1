"""The stable Verlet step the model's bonds allow, estimated from the reference configuration
(Peridigm's estimate; the measured one is :mod:`peridyn.solvers.monitors.stable_step`)."""
from __future__ import annotations

import math

import numpy as np

from ..core.interfaces import Simulation
from .kernels import critical_time_step_kernel


def critical_time_steps(sim: Simulation) -> np.ndarray:
    """(num_owned,) Peridigm's (Silling-Askari) stable step of each owned point (T):
    sqrt(2 rho / sum_j V_j c / |xi_ij|), c = 18 K / (pi delta^4) of its block (inf without bonds)."""
    nl = sim.bonds
    s = sim.fields
    dt = np.full(sim.num_local, np.inf)
    for blk in sim.blocks:
        K = blk.material.bulk_modulus
        if blk.horizon is not None:
            d = np.float64(blk.horizon)
            with np.errstate(all="ignore"):  # a horizon whose 4th power under- or overflows
                c = float((18.0 * K) / ((((math.pi * d) * d) * d) * d))
            c_point = np.zeros(0)
        else:
            h = sim.horizon_local
            c = 0.0
            with np.errstate(all="ignore"):
                c_point = (18.0 * K) / ((((math.pi * h) * h) * h) * h)
        critical_time_step_kernel(blk.start, blk.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Volume"], blk.density, c, c_point, dt)
    return dt[: sim.num_owned]
