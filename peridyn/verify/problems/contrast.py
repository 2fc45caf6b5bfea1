"""``density-contrast``: two bonded blocks whose densities differ by 1e4 (a light bar fixed at one
end carrying a heavy block at the other) vibrating in their fundamental mode: the period of the
explicit run against the closed-form frequency of the two-segment bar, and against the exact
fundamental of the same semi-discrete chain (its stiffness and masses written here from the bond
law, not read from the code)."""
from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy.linalg import eigh
from scipy.optimize import brentq

from ...engine.run_services import RunServices
from ...engine.session import run_section
from ...solvers.explicit.verlet import Verlet, VerletSection
from ...testing import build_simulation
from .base import Check, Measurement, Problem
from .dynamics import quiet

K = 1.0e9  #: bulk modulus of both blocks (Pa)
RHO = 1000.0  #: density of the light bar (kg/m^3)
CONTRAST = 1.0e4  #: heavy density / light density
H = 1.0e-3  #: spacing (m); every point's volume is H^3
BONDS = 3  #: bonds each way along the row: horizon (BONDS + 1/2) H, the cut-off half-way between points
HEAVY = 4  #: points of the heavy block (a horizon and a half: it moves almost rigidly)
SAFETY = 0.9  #: the fixed step / the set-up estimate (the stable limit is 1.6 .. 2.4 times it: `stability`)
V0 = 1.0e-3  #: the heavy block's initial velocity (m/s)


def micromodulus() -> float:
    """c = 18 K / (pi delta^4) (N/m^6), delta = (BONDS + 1/2) H."""
    return 18.0 * K / (math.pi * ((BONDS + 0.5) * H) ** 4)


def lattice_modulus() -> float:
    """The row's long-wave modulus (Pa): rho omega^2 = sum_j c V (1 - cos k xi_j) / |xi_j| ->
    k^2 c V sum_j |xi_j| / 2 = k^2 c V H BONDS (BONDS + 1) / 2, V = H^3."""
    return micromodulus() * H**3 * H * BONDS * (BONDS + 1) / 2.0


def continuum_omega(light: float, heavy: float) -> float:
    """The fundamental (rad/s) of a bar fixed at x = 0: ``light`` m of density RHO, then ``heavy`` m
    of density CONTRAST RHO, free at its end, modulus :func:`lattice_modulus` throughout. With
    u = a sin(k1 x) in the light part and b cos(k2 (L - x)) in the heavy part (k_i = omega / c_i),
    continuity of u and of the stress at the joint gives k1 cot(k1 L1) = k2 tan(k2 L2)."""
    E = lattice_modulus()
    c1, c2 = math.sqrt(E / RHO), math.sqrt(E / (CONTRAST * RHO))

    def f(w: float) -> float:
        k1, k2 = w / c1, w / c2
        return k1 * math.cos(k1 * light) * math.cos(k2 * heavy) - k2 * math.sin(k1 * light) * math.sin(k2 * heavy)

    spring_mass = math.sqrt(E / (light * heavy * CONTRAST * RHO))
    return brentq(f, 0.5 * spring_mass, min(1.5 * spring_mass, 0.999 * 0.5 * math.pi * c2 / heavy), xtol=1e-14 * spring_mass)


def chain(n_light: int, n_heavy: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The row: x (m) of every point (BONDS grip points, n_light light, n_heavy heavy), its density
    (kg/m^3), and the stiffness (N/m^6 per m of displacement) of the linearised bond law
    f_i = sum_j c V (u_j - u_i) / |xi_ij| over |xi| <= delta."""
    n = BONDS + n_light + n_heavy
    x = (np.arange(n) + 0.5) * H
    rho = np.where(np.arange(n) < BONDS + n_light, RHO, CONTRAST * RHO)
    k = np.zeros((n, n))
    cv = micromodulus() * H**3
    for j in range(1, BONDS + 1):
        idx = np.arange(n - j)
        k[idx, idx + j] = k[idx + j, idx] = -cv / (j * H)
    k[np.diag_indices(n)] = -k.sum(axis=1)
    return x, rho, k


class Chain:
    """The exact semi-discrete model of the row (grip fixed, the heavy points started at V0):
    its modes (stiffness and masses from :func:`chain`, not from the code) and the heavy block's
    mean velocity (m/s), continuous and as velocity Verlet produces it, mode by mode."""

    def __init__(self, n_light: int, n_heavy: int) -> None:
        _, rho, k = chain(n_light, n_heavy)
        free = slice(BONDS, None)
        mass = rho[free]
        lam, phi = eigh(k[free, free], np.diag(mass))  # phi^T M phi = I
        self.lam = lam
        q = phi.T @ (mass * np.where(mass > RHO, V0, 0.0))  # modal velocities
        self.weight = phi[mass > RHO].mean(axis=0) * q  # each mode's share of the heavy block's mean velocity

    @property
    def fundamental(self) -> float:
        """The lowest angular frequency (rad/s)."""
        return math.sqrt(float(self.lam[0]))

    def quarter(self) -> float:
        """The first time (s) the continuous motion's mean heavy velocity passes zero."""
        w = np.sqrt(self.lam)
        t = 0.5 * math.pi / w[0]
        return brentq(lambda s: float(np.dot(self.weight, np.cos(w * s))), 0.8 * t, 1.2 * t, xtol=1e-15 * t)

    def verlet(self, dt: float, steps: int) -> np.ndarray:
        """(steps + 1,) the mean heavy velocity at steps 0 .. steps of velocity Verlet with ``dt``:
        per mode u_n = dt q sin(n theta) / sin(theta), theta = 2 arcsin(omega dt / 2) (as
        :meth:`peridyn.verify.problems.modal.Modes.verlet`), and v_n = (u_{n+1} - u_n) / dt +
        lambda dt u_n / 2 (the second half kick)."""
        theta = 2.0 * np.arcsin(0.5 * np.sqrt(self.lam) * dt)
        n = np.arange(steps + 2)[:, None]
        u = dt * np.sin(n * theta) / np.sin(theta)  # per unit modal velocity
        v = (u[1:] - u[:-1]) / dt + 0.5 * self.lam * dt * u[:-1]
        return v @ self.weight


class DensityContrast(Problem):
    name = "density-contrast"
    title = "Bonded blocks with a density contrast of 1e4: the period against its closed form"
    computes = (
        f"A row of points of spacing h = {H * 1e3:g} mm along x (volume h^3 each), `Elastic Bond Based` (K = 1 GPa, horizon "
        f"{BONDS + 0.5:g} h): {BONDS} grip points held at u = 0, a light bar of N points (rho = {RHO:g} kg/m^3, block 1) and a "
        f"heavy block of {HEAVY} points (rho = {CONTRAST:g} x {RHO:g} kg/m^3, block 2) bonded to it, its far end free. The heavy "
        f"points start at {V0:g} m/s along x, everything else at rest; velocity Verlet at a fixed step of {SAFETY:g} times the "
        "set-up estimate (set by the light bar: the heavy block's own waves are 100 times slower) until the heavy block's mean "
        "velocity, read at every step, has passed through zero: a quarter period T/4 (linear interpolation between the "
        "steps); omega = (pi / 2) / (T/4). Error: |omega / omega_closed - 1|."
    )
    reference = (
        "The closed form: a bar fixed at x = 0, light over 0 < x < L1 (L1 = N h + h/2, from the last grip point to the blocks' "
        "joint, N h from the first free point), heavy over L1 < x < L1 + L2 (L2 = 4 h), its end free, one modulus E: "
        "k1 cot(k1 L1) = k2 tan(k2 L2), k_i = omega / c_i, c_i = sqrt(E / rho_i) (about the spring and mass "
        "sqrt(E / (rho_2 L1 L2)), the bar's own mass N / 4e4 of the block's). E is the row's long-wave modulus from the bond "
        "sum, c V h B (B + 1) / 2 (B = 3 bonds each way, c = 18 K / (pi delta^4)): it is the discrete model's, so that the "
        "error is the two-block problem's, not the lattice's (`wave-speed` holds the lattice's E). Where the row's fixed end "
        "lies is uncertain by about a spacing, so the error falls as h / L1. Beside it, the same semi-discrete chain solved "
        "exactly: its stiffness (c V / |xi| per bond) and masses (rho of each point's block) written here, the first zero "
        "of the heavy block's mean velocity as velocity Verlet produces it, mode by mode (u_n = dt q sin(n theta) / sin theta, "
        "theta = 2 arcsin(omega dt / 2)): the run must follow it to 1e-6 V0 at every step (measured 1e-10 .. 5e-9). Bands on "
        "the closed form: 2.5 % at every point and 1 % at the finest (measured -1.72 %, -0.94 %, -0.46 %, -0.26 %, -0.14 % at "
        "N = 16 .. 256, rate 0.9 .. 1.0 in h / L1; band 0.8 .. 1.3). A density of the heavy block 10 % off moves omega by "
        "4.9 % and 5 % off by 2.5 %: both fail; the light block's density given to every point moves it 100 times."
    )
    resolution_name = "N (light points)"
    size_name = "h/L1"
    error_name = "|omega / omega_closed - 1|"
    methods = ("Elastic Bond Based",)
    rate_band = {"Elastic Bond Based": (0.8, 1.3)}
    every_band = {"Elastic Bond Based": 0.025}
    finest_band = {"Elastic Bond Based": 0.01}
    DISCRETE_BAND = 1.0e-6

    def ladder(self, method: str, quick: bool) -> list[float]:
        return [16.0, 32.0, 64.0] if quick else [16.0, 32.0, 64.0, 128.0, 256.0]

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        t0 = time.perf_counter()
        n_light = int(resolution)
        n_heavy = HEAVY
        x, rho, _ = chain(n_light, n_heavy)
        block = np.where(rho > RHO, 2, 1)
        mat = {"Material Model": "Elastic Bond Based", "Bulk Modulus": K}
        delta = (BONDS + 0.5) * H
        with tempfile.TemporaryDirectory(prefix="peridyn-verify-contrast-") as d, quiet("peridyn.engine", "peridyn.geometry", "peridyn.solvers"):
            lines = [f"{xi!r} 0.0 0.0 {b} {H**3!r}" for xi, b in zip(x.tolist(), block.tolist())]
            (Path(d) / "row.txt").write_text("# x y z block volume\n" + "\n".join(lines) + "\n")
            (Path(d) / "grip.txt").write_text("\n".join(str(i + 1) for i in range(BONDS)) + "\n")
            tree = {
                "Discretization": {"Type": "Text File", "Input Mesh File": "row.txt"},
                "Materials": {"Light": dict(mat, Density=RHO), "Heavy": dict(mat, Density=CONTRAST * RHO)},
                "Blocks": {"Bar": {"Block Names": "block_1", "Material": "Light", "Horizon": delta},
                           "Mass": {"Block Names": "block_2", "Material": "Heavy", "Horizon": delta}},
                "Boundary Conditions": {"Grip Node Set": "grip.txt",
                                        "Grip": {"Type": "Prescribed Displacement", "Node Set": "Grip Node Set", "Coordinate": "x", "Value": "0.0"}},
            }
            sim = build_simulation(tree, directory=d)
            dt = SAFETY * sim.critical_time_step()
            ref = Chain(n_light, n_heavy)
            t_cross = ref.quarter()
            heavy = np.array(sim.fields["Model_Coordinates"])[:, 0] > (BONDS + n_light) * H
            sim.fields["Velocity"][heavy, 0] = V0
            history: list[tuple[float, float]] = []

            def record(t: float) -> None:
                history.append((t, float(np.mean(sim.fields["Velocity"][heavy, 0]))))

            section = {"Initial Time": 0.0, "Final Time": 1.1 * t_cross, "Verlet": {"Fixed dt": dt}}
            # the harness reads every step, as an output would
            run_section(sim, Verlet(VerletSection.model_validate(section)), run=RunServices.reading(record))
            steps = int(sim.stats["solvers"][-1]["steps"])
        t, v = np.array(history).T
        at = np.rint(t / dt).astype(int)
        exact = ref.verlet(dt, int(at.max()))
        trajectory = float(np.abs(v - exact[at]).max() / V0)
        k = int(np.nonzero((v[1:] <= 0.0) & (v[:-1] > 0.0))[0][0])
        t_quarter = float(t[k] + (t[k + 1] - t[k]) * v[k] / (v[k] - v[k + 1]))
        omega = 0.5 * math.pi / t_quarter
        L1, L2 = (n_light + 0.5) * H, n_heavy * H
        closed = continuum_omega(L1, L2)
        values = {"omega (rad/s)": omega, "omega_closed (rad/s)": closed, "omega / omega_closed - 1": omega / closed - 1.0,
                  "max |v - v_Verlet exact| / V0": trajectory, "T/4 / T/4 of the exact chain - 1": t_quarter / t_cross - 1.0,
                  "chain's fundamental / omega_closed - 1": ref.fundamental / closed - 1.0,
                  "omega dt": omega * dt, "points": int(len(x)), "wall (s)": time.perf_counter() - t0}
        return Measurement(abs(omega / closed - 1.0), size=H / L1, steps=steps, values=values)

    def extra_checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        return [Check(self.name, method, f"max |v - v_Verlet exact| / V0 of the heavy block's mean velocity at N = {p['resolution']:g} "
                      "(the exact Verlet sequence of the same semi-discrete chain)", p["values"]["max |v - v_Verlet exact| / V0"],
                      high=self.DISCRETE_BAND) for p in points]
