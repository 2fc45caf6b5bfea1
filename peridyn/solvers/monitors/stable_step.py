"""The stable Verlet time step measured on the model: the largest vibration frequency of the
linearized force operator, by power iteration on finite differences of the force evaluation.

Velocity Verlet is stable for a vibration of angular frequency w when w dt <= 2. The critical
time step estimate (Silling and Askari's, Peridigm's) bounds w from the bond-based micromodulus
18 K / (pi delta^4); it is no bound for state-based materials, whose dilatation term stiffens
points near free surfaces (a brittle LPS plate becomes unstable at 1.43 times the estimate),
nor for horizons larger than the body. The Rayleigh quotient v.Kv / v.Mv of any v is at most
w_max^2, so ``2 / sqrt(quotient)`` is an upper bound of the true limit: a time step above it is
unstable for certain, from the first step.
"""
from __future__ import annotations

import math

import numpy as np

#: probe size relative to the point spacing: small strain, far from any damage threshold
PROBE = 1.0e-7


def measured_stable_step(sim, dt: float, *, iterations: int = 40, stop_below: float = 0.0, seed: float = 0.0) -> tuple[float, int]:
    """(upper bound of the stable Verlet step of the model in its present state (T), iterations
    used), for a run at time step ``dt`` (T; rate-form materials see the probe as a velocity of
    probe / dt, as in Peridigm's finite-difference tangent). Stops early once the bound falls
    below ``stop_below``. Every field is restored exactly afterwards (damage, material state and
    forces included), and the time step; collective under MPI."""
    f = sim.fields
    n = sim.num_owned
    comm = sim.comm
    rho = sim.density_per_point()[:n]
    free = ~np.asarray(sim.prescribed_dofs[:n], dtype=bool)
    if comm.allreduce_sum(int(free.sum())) == 0:
        return math.inf, 0
    x, u, y, vel = f["Model_Coordinates"], f["Displacement"], f["Coordinates"], f["Velocity"]
    rate = any(blk.material.tangent_perturbs_velocity for blk in sim.blocks)
    saved = f.snapshot()
    saved_dt = sim.time_step
    if rate:
        sim.set_time_step(dt)
        v0 = vel[:n].copy()
    spacing = float(np.cbrt(np.median(f["Volume"][:n]))) if n else 0.0
    spacing = max(comm.allgather(spacing))
    # a start vector that is a function of the global point id: the same on any number of ranks
    g = np.asarray(sim.gid[:n], dtype=np.float64)[:, None] * 3.0 + np.arange(3.0) + seed
    v = (np.modf(g * 0.6180339887498949)[0] - 0.5) * free
    bound = math.inf
    it = 0
    try:
        y[:n] = x[:n] + u[:n]
        sim.evaluate_forces()
        f0 = f["Force_Density"][:n].copy()
        for it in range(1, iterations + 1):
            norm = math.sqrt(comm.allreduce_sum(float(np.sum(rho[:, None] * v * v))))
            big = comm.allreduce_max(float(np.abs(v).max())) if n else comm.allreduce_max(0.0)
            if not (norm > 0.0 and big > 0.0):
                break
            v /= norm
            eps = PROBE * spacing / (big / norm)
            y[:n] = x[:n] + u[:n] + eps * v
            if rate:
                vel[:n] = v0 + (eps / dt) * v
            sim.evaluate_forces()
            kv = (f0 - f["Force_Density"][:n]) * free / eps  # K v, free components
            quotient = comm.allreduce_sum(float(np.sum(v * kv)))
            if not math.isfinite(quotient):
                break
            if quotient > 0.0:
                bound = min(bound, 2.0 / math.sqrt(quotient))
            if bound < stop_below:
                break
            v = kv / rho[:, None]
    finally:
        f.restore(saved)
        if rate and saved_dt is not None:
            sim.set_time_step(saved_dt)
    return bound, it
