"""The conformance suite for non-ordinary (vector force-state, rate-form) materials: subclass
:class:`NonOrdinaryConformance`.

Such materials (the correspondence family) integrate their stress from the velocity gradient
over the solver's time step, so the checks drive a small lattice cube through a few force
evaluations with prescribed positions and velocities, the way an explicit or quasi-static step
does, and swap the state after each:

* zero force under a rigid motion (translation plus rotation, with the matching velocities);
* linear momentum: the force densities times volumes sum to zero for a random deformation and
  random velocities (all points, surfaces included);
* objectivity: a stretched body rotated rigidly keeps its unrotated stress, and its Cauchy
  stress turns with it;
* a homogeneous stretch gives no force at interior points (a uniform stress has no divergence);
* the stated moduli: under quadratic displacement fields, reached from the reference state in a
  few steps with the matching velocities, the force density at interior points is div sigma of
  Hooke's law with the stated bulk and shear moduli (a stress law of the wrong stiffness or sign
  fails here, though it passes the checks above).
"""
from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from .harness import build_simulation, cube_deck, isolated_registry
from .probes import force_moduli, relative_log_error, stated_moduli


def _rotation(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class NonOrdinaryConformance:
    """Set ``material`` (deck name) and ``params`` (its parameters, without Material Model);
    optionally ``plugins``, ``horizon_factor`` (horizon over the lattice spacing) and
    ``elastic_moduli`` ((K, G) when the parameters do not give Bulk and Shear Modulus)."""

    material: ClassVar[str] = ""
    params: ClassVar[dict[str, Any]] = {}
    plugins: ClassVar[tuple] = ()
    horizon_factor: ClassVar[float] = 3.015
    n: ClassVar[int] = 9
    spacing: ClassVar[float] = 1e-3
    dt: ClassVar[float] = 1e-7
    elastic_moduli: ClassVar[tuple[float, float] | None] = None
    #: points per side of the lattice of the moduli check (interior points to two horizons)
    moduli_n: ClassVar[int] = 15
    #: largest |ln(measured / stated)| of K and G (the built-in correspondence models: 7e-4)
    moduli_tolerance: ClassVar[float] = 0.01

    # -- helpers ------------------------------------------------------------------------------
    def simulation(self, n: int | None = None):
        mat = {"Material Model": self.material, **self.params}
        tree = cube_deck(mat, n=n or self.n, spacing=self.spacing, horizon_factor=self.horizon_factor)
        if self.plugins:
            with isolated_registry(*self.plugins) as reg:
                sim = build_simulation(tree, registry=reg)
        else:
            sim = build_simulation(tree)
        sim.set_time_step(self.dt)
        return sim

    def step(self, sim, y: np.ndarray, v: np.ndarray) -> np.ndarray:
        """One force evaluation at positions y and velocities v (num_local, 3); the state
        becomes the N state afterwards. Returns the force density (num_owned, 3)."""
        s = sim.fields
        s["Coordinates"][:] = y
        s["Displacement"][:] = y - s["Model_Coordinates"]
        s["Velocity"][:] = v
        f = np.array(sim.evaluate_forces()[: sim.num_owned])
        sim.advance()
        return f

    def interior(self, sim) -> np.ndarray:
        x = sim.fields["Model_Coordinates"][: sim.num_owned]
        lo, hi = x.min(axis=0), x.max(axis=0)
        reach = 1.01 * self.horizon_factor * self.spacing
        return np.all((x - lo > reach) & (hi - x > reach), axis=1)

    # -- checks -------------------------------------------------------------------------------
    def test_rigid_motion_gives_zero_force(self):
        sim = self.simulation()
        x = sim.fields["Model_Coordinates"].copy()
        c = x.mean(axis=0)
        omega = 2.0e3  # rad/s
        forces = []
        for k in range(1, 4):
            R = _rotation(omega * self.dt * k)
            W = omega * np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
            y = (x - c) @ R.T + c + np.array([1e-4, -2e-4, 3e-4]) * k
            v = (y - c) @ W.T + np.array([1e-4, -2e-4, 3e-4]) / self.dt
            forces.append(self.step(sim, y, v))
        scale = self._force_scale(sim)
        assert np.abs(np.array(forces)).max() < 1e-6 * scale

    def test_linear_momentum_is_conserved(self):
        sim = self.simulation()
        rng = np.random.default_rng(3)
        x = sim.fields["Model_Coordinates"].copy()
        f = None
        for k in range(1, 3):
            y = x + rng.normal(scale=1e-4 * self.spacing, size=x.shape)
            v = rng.normal(scale=1.0, size=x.shape)
            f = self.step(sim, y, v)
        V = sim.fields["Volume"][: sim.num_owned, None]
        total = (f * V).sum(axis=0)
        assert np.abs(f * V).sum() > 0
        assert np.abs(total).max() <= 1e-10 * np.abs(f * V).sum()

    def test_homogeneous_stretch_gives_uniform_interior_force(self):
        sim = self.simulation()
        x = sim.fields["Model_Coordinates"].copy()
        rate = np.array([[1.0, 0.2, 0.0], [0.2, -0.5, 0.1], [0.0, 0.1, 0.3]]) * 1e2  # 1/s
        f = None
        for k in range(1, 4):
            y = x + (x @ rate.T) * (self.dt * k)
            v = x @ rate.T
            f = self.step(sim, y, v)
        inner = self.interior(sim)
        assert inner.any(), "the lattice has no interior point: raise n"
        scale = self._force_scale(sim)
        # a homogeneous stress has no divergence: interior points feel no net force
        assert np.abs(f[inner]).max() < 1e-6 * scale

    def test_objectivity_stress_turns_with_a_rigid_rotation(self):
        sim = self.simulation()
        specs = {sp.name: sp for sp in self._material(sim).output_fields() + self._material(sim).fields()}
        if "Cauchy_Stress" not in specs:
            return  # the material does not report a Cauchy stress
        sim.require(specs["Cauchy_Stress"])
        x = sim.fields["Model_Coordinates"].copy()
        e_rate = 1e2
        steps = 4
        for k in range(1, steps + 1):  # stretch along x
            y = x.copy()
            y[:, 0] = x[:, 0] * (1.0 + e_rate * self.dt * k)
            v = np.zeros_like(x)
            v[:, 0] = e_rate * x[:, 0]
            self.step(sim, y, v)
        inner = self.interior(sim)
        sigma0 = self._last(sim, "Cauchy_Stress")[inner].reshape(-1, 3, 3).mean(axis=0)
        stretched = y.copy()
        theta_total, nrot = math.pi / 2, 100
        W = (theta_total / (nrot * self.dt)) * np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
        for k in range(1, nrot + 1):
            R = _rotation(theta_total * k / nrot)
            y = stretched @ R.T
            self.step(sim, y, y @ W.T)
        sigma = self._last(sim, "Cauchy_Stress")[inner].reshape(-1, 3, 3).mean(axis=0)
        Q = _rotation(theta_total)
        expected = Q @ sigma0 @ Q.T
        assert np.abs(sigma0).max() > 0
        assert np.abs(sigma - expected).max() < 0.1 * np.abs(sigma0).max()

    def test_stated_moduli_under_quadratic_fields(self):
        """K and G from the force density under quadratic fields (``probes.force_moduli``), each
        field applied to a fresh model in three equal steps with the velocities of the path."""
        stated = self.elastic_moduli or stated_moduli(self.params)
        if stated is None:
            moduli = self._material(self.simulation()).elastic_moduli()
            stated = None if moduli is None else (moduli.bulk, moduli.shear)
        if stated is None:
            import pytest

            pytest.skip("no stated moduli: set elastic_moduli = (K, G)")
        steps = 3

        def driven_force(sim):
            target = sim.fields["Coordinates"][: sim.num_owned].copy()
            fresh = self.simulation(self.moduli_n)
            x = fresh.fields["Model_Coordinates"].copy()
            f = None
            for k in range(1, steps + 1):
                f = self.step(fresh, x + (target - x) * (k / steps), (target - x) / (steps * self.dt))
            return f

        measured = force_moduli(self.simulation(self.moduli_n), self.spacing, force=driven_force)
        K, G = stated
        assert relative_log_error(measured.bulk, K) < self.moduli_tolerance, (measured.bulk, K)
        assert relative_log_error(measured.shear, G) < self.moduli_tolerance, (measured.shear, G)

    # -- internals ----------------------------------------------------------------------------
    @staticmethod
    def _last(sim, name: str) -> np.ndarray:
        """The field as the last evaluation left it (after the state swap: the N value of a
        two-step field)."""
        from ..core.fields import Temporal

        arr = sim.fields.n(name) if sim.fields.specs[name].temporal is Temporal.TWO_STEP else sim.fields[name]
        return arr[: sim.num_owned]

    def _material(self, sim):
        return sim.blocks[0].material

    def _force_scale(self, sim) -> float:
        """A force density of a strain of 1e-5 over one spacing: K 1e-5 / h."""
        return float(self._material(sim).bulk_modulus) * 1e-5 / self.spacing
