"""The exact motion of a small linear(ised) model by modal decomposition: the continuous solution
of M u'' = -K u and the exact sequence velocity Verlet produces for it, mode by mode.

The stiffness is the model's own: ``K = -d f / d u`` (force density per unit displacement) by
central differences of the model's forces at the reference configuration, so the reference is the
exact solution of the same semi-discrete model the integrator advances, not another run of the
integrator. Every point has the same density here (a = f / rho), so the operator is
A = K / rho (1/s^2), symmetric for a model with a strain energy and equal point volumes."""
from __future__ import annotations

import math
from typing import Any

import numpy as np


def force_stiffness(sim: Any, step: float) -> np.ndarray:
    """(3n, 3n) -d f / d u of ``sim``'s force density f (n, 3) at the reference positions, by
    central differences with displacement ``step`` (m) of one component at a time (columns in the
    order point 0 x, y, z, point 1 x, ...); units force density per m. The model is left at its
    reference positions."""
    x = np.array(sim.fields["Model_Coordinates"])
    n = len(x)
    out = np.empty((3 * n, 3 * n))
    y = sim.fields["Coordinates"]
    for k in range(3 * n):
        i, c = divmod(k, 3)
        y[:] = x
        y[i, c] += step
        plus = np.array(sim.evaluate_forces()).reshape(-1)
        y[:] = x
        y[i, c] -= step
        minus = np.array(sim.evaluate_forces()).reshape(-1)
        out[:, k] = -(plus - minus) / (2.0 * step)
    y[:] = x
    return out


class Modes:
    """The modes of u'' = -A u, A = ``stiffness`` / ``density`` ((3n, 3n), 1/s^2), started from
    u = 0 with the velocity ``v0`` (n, 3; m/s). Eigenvalues below ``RIGID`` times the largest are
    rigid motions (omega = 0)."""

    RIGID = 1.0e-9

    def __init__(self, stiffness: np.ndarray, density: float, v0: np.ndarray) -> None:
        a = stiffness / density
        #: largest |A - A^T| / largest |A| (the symmetry of the model's linearised forces)
        self.asymmetry = float(np.abs(a - a.T).max() / np.abs(a).max())
        lam, phi = np.linalg.eigh(0.5 * (a + a.T))
        lam[lam < self.RIGID * lam.max()] = 0.0
        self.lam, self.phi = lam, phi
        self.q = phi.T @ np.asarray(v0, dtype=float).reshape(-1)  # modal velocities
        self.shape = np.asarray(v0).shape

    @property
    def omega_max(self) -> float:
        """The largest angular frequency (rad/s)."""
        return math.sqrt(float(self.lam.max()))

    def continuous(self, t: float) -> np.ndarray:
        """u(t) (n, 3; m) of the exact motion: sum_k phi_k q_k sin(omega_k t) / omega_k."""
        w = np.sqrt(self.lam)
        amp = np.where(w > 0.0, np.sin(w * t) / np.where(w > 0.0, w, 1.0), t)
        return (self.phi @ (self.q * amp)).reshape(self.shape)

    def verlet(self, dt: float, steps: int) -> np.ndarray:
        """u_N (n, 3; m) of velocity Verlet with step ``dt`` (s) after ``steps`` steps, exactly: each
        mode obeys u_{n+1} - 2 u_n + u_{n-1} = -lambda dt^2 u_n with u_0 = 0, u_1 = dt q, so
        u_N = dt q sin(N theta) / sin(theta), cos(theta) = 1 - lambda dt^2 / 2, i.e. theta =
        2 arcsin(omega dt / 2) (N dt q for a rigid mode). ValueError at or above the stability
        limit omega dt >= 2."""
        half = 0.5 * np.sqrt(self.lam) * dt
        if np.any(half >= 1.0):
            raise ValueError(f"dt = {dt:g} s is at or above Verlet's stability limit 2 / omega_max = {2.0 / self.omega_max:g} s")
        theta = 2.0 * np.arcsin(half)
        amp = np.where(theta > 0.0, dt * np.sin(steps * theta) / np.where(theta > 0.0, np.sin(theta), 1.0), steps * dt)
        return (self.phi @ (self.q * amp)).reshape(self.shape)
