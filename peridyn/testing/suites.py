"""Conformance suites every model passes (built-in or third-party).

Subclass a suite in a test module and set the class attributes; pytest collects the tests.
Tolerances are relative to the size of the quantities involved and leave room for round-off
only (1e-9 of the force scale); a wrong kernel misses them by orders of magnitude.
"""
from __future__ import annotations

import contextlib
from typing import Any, ClassVar

import numpy as np
import pytest

from .harness import build_simulation, cube_deck, isolated_registry


def _rotation(angle: float, axis) -> np.ndarray:
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def forces_in_parts(sim, fraction: float = 0.37) -> np.ndarray:
    """Force densities computed as the engine does under MPI with halo overlap: every block in
    two parts (its first ``fraction`` of rows, then the rest), each phase (damage and
    precompute, then force) on the first part before the second. Force_Density and the
    precompute fields start as NaN, so a model that reads rows it has not computed yet, or
    writes outside its view, shows. Only for blocks whose models declare ``row_local``."""
    splits = [blk.split for blk in sim.blocks]
    overlap = sim.overlap
    try:
        for blk in sim.blocks:
            blk.split = blk.start + int(fraction * (blk.stop - blk.start))
        sim.fields["Force_Density"][:] = np.nan
        for name in sim.precompute_fields:
            sim.fields[name][:] = np.nan
        sim.overlap = True
        return sim.evaluate_forces().copy()
    finally:
        sim.overlap = overlap
        for blk, split in zip(sim.blocks, splits):
            blk.split = split


class MaterialConformance:
    """Checks for a material. Set ``material`` (deck name) and ``params`` (deck parameters
    without ``Material Model``); ``plugins`` lists plugin modules to register when the package
    is not installed; ``central`` is True for materials whose bond forces act along the bond
    (then angular momentum is conserved too)."""

    material: ClassVar[str] = ""
    params: ClassVar[dict[str, Any]] = {}
    plugins: ClassVar[tuple] = ()
    central: ClassVar[bool] = True
    strain: ClassVar[float] = 1e-3  #: size of the random deformation used by the checks

    # -- helpers ------------------------------------------------------------------------------
    @contextlib.contextmanager
    def _registry(self):
        if self.plugins:
            with isolated_registry(*self.plugins, autoload=False) as reg:
                yield reg
        else:
            yield None

    def simulation(self, n: int = 5, **kw):
        mat = {"Material Model": self.material, **self.params}
        with self._registry() as reg:
            return build_simulation(cube_deck(mat, n=n, **kw), registry=reg)

    def deform(self, sim, seed: int = 0) -> None:
        x = sim.fields["Model_Coordinates"]
        rng = np.random.default_rng(seed)
        sim.fields["Coordinates"][:] = x + self.strain * rng.standard_normal(x.shape)
        sim.fields["Displacement"][:] = sim.fields["Coordinates"] - x

    def force(self, sim) -> np.ndarray:
        return sim.evaluate_forces().copy()

    def scale(self, sim) -> float:
        self.deform(sim)
        return float(np.abs(self.force(sim)).max())

    # -- checks -------------------------------------------------------------------------------
    def test_params_validate(self):
        with self._registry() as reg:
            from ..plugins.manager import get_registry

            cls = (reg or get_registry()).get("material", self.material)
            cls.Params.model_validate(self.params)
            with pytest.raises(Exception):
                cls.Params.model_validate({**self.params, "Not A Parameter": 1.0})

    def test_rigid_motion_gives_zero_force(self):
        sim = self.simulation()
        scale = self.scale(sim)
        assert scale > 0, "a random deformation should produce forces"
        x = sim.fields["Model_Coordinates"]
        R = _rotation(0.7, [1.0, 2.0, 0.5])
        sim.fields["Coordinates"][:] = x @ R.T + np.array([0.3, -1.0, 2.0])
        f = self.force(sim)
        np.testing.assert_allclose(f, 0.0, atol=1e-9 * scale)

    def test_linear_momentum_is_conserved(self):
        sim = self.simulation()
        self.deform(sim, seed=1)
        f = self.force(sim)
        vol = sim.fields["Volume"][:, None]
        total = (f * vol).sum(axis=0)
        np.testing.assert_allclose(total, 0.0, atol=1e-9 * float(np.abs(f * vol).sum()))

    def test_angular_momentum_is_conserved(self):
        if not self.central:
            pytest.skip("non-central material")
        sim = self.simulation()
        self.deform(sim, seed=2)
        f = self.force(sim)
        y = sim.fields["Coordinates"]
        vol = sim.fields["Volume"][:, None]
        torque = np.cross(y, f * vol).sum(axis=0)
        np.testing.assert_allclose(torque, 0.0, atol=1e-9 * float(np.abs(np.cross(y, f * vol)).sum()))

    def test_fused_and_generic_paths_agree(self):
        sim = self.simulation()
        self.deform(sim, seed=3)
        blk = sim.blocks[0]
        if not blk.fused:
            pytest.skip("the block is not fused")
        fused = self.force(sim)
        blk.fused = False
        generic = self.force(sim)
        np.testing.assert_allclose(generic, fused, rtol=1e-12, atol=1e-12 * float(np.abs(fused).max()))

    def test_row_local_parts_give_the_same_forces(self):
        """A material that declares ``row_local`` may be computed in parts (under MPI: the
        points without ghost neighbors while the halo messages travel); the forces must be the
        ones of the whole block, bit for bit."""
        sim = self.simulation()
        blk = sim.blocks[0]
        if not (blk.material.row_local and blk.fused):
            pytest.skip("the material does not declare row_local, or the block is not fused")
        for fraction in (0.0, 0.37, 0.81, 1.0):
            self.deform(sim, seed=8)
            self.force(sim)  # whatever a model caches now belongs to another configuration
            self.deform(sim, seed=7)
            parts = forces_in_parts(sim, fraction)
            np.testing.assert_array_equal(parts, self.force(sim))

    def test_thread_count_does_not_change_results(self):
        import numba

        sim = self.simulation(n=7)
        self.deform(sim, seed=4)
        old = numba.get_num_threads()
        try:
            numba.set_num_threads(1)
            one = self.force(sim)
            numba.set_num_threads(max(2, min(old, numba.config.NUMBA_NUM_THREADS)))
            many = self.force(sim)
        finally:
            numba.set_num_threads(old)
        np.testing.assert_array_equal(one, many)

    def test_stable_time_step_is_positive(self):
        sim = self.simulation()
        dt = sim.critical_time_step()
        assert np.isfinite(dt) and dt > 0

    def test_force_is_minus_gradient_of_stored_energy(self):
        sim = self.simulation(n=4)
        self.deform(sim, seed=5)
        if sim.stored_energy() == 0.0:
            pytest.skip("the material defines no stored energy")
        y = sim.fields["Coordinates"]
        vol = sim.fields["Volume"]
        f = self.force(sim)
        h = 1e-6 * self.strain * float(np.abs(sim.fields["Model_Coordinates"]).max() or 1.0)
        rng = np.random.default_rng(6)
        checked = 0
        for i in rng.choice(sim.num_owned, size=min(6, sim.num_owned), replace=False):
            for c in range(3):
                old = y[i, c]
                y[i, c] = old + h
                sim.evaluate_forces()
                e_plus = sim.stored_energy()
                y[i, c] = old - h
                sim.evaluate_forces()
                e_minus = sim.stored_energy()
                y[i, c] = old
                grad = (e_plus - e_minus) / (2 * h)
                np.testing.assert_allclose(-grad / vol[i], f[i, c], rtol=1e-5, atol=1e-6 * float(np.abs(f).max()))
                checked += 1
        assert checked > 0


class DamageConformance:
    """Checks for a damage model: no damage without deformation, damage in [0, 1] that never
    heals, and bonds that break under a large stretch. Set ``damage`` (deck name), ``params``
    and optionally ``material`` / ``material_params`` and ``plugins``."""

    damage: ClassVar[str] = ""
    params: ClassVar[dict[str, Any]] = {}
    material: ClassVar[str] = "Elastic"
    material_params: ClassVar[dict[str, Any]] = {"Density": 1000.0, "Bulk Modulus": 1.0e9, "Shear Modulus": 0.4e9}  # 3K != 5mu: the dilatation term of LPS is not zero
    plugins: ClassVar[tuple] = ()
    breaking_strain: ClassVar[float] = 0.5  #: a uniform stretch that must break some bonds

    def simulation(self, n: int = 5):
        mat = {"Material Model": self.material, **self.material_params}
        dmg = {"Damage Model": self.damage, **self.params}
        if self.plugins:
            with isolated_registry(*self.plugins) as reg:
                return build_simulation(cube_deck(mat, n=n, damage=dmg), registry=reg)
        return build_simulation(cube_deck(mat, n=n, damage=dmg))

    def test_no_damage_at_rest(self):
        sim = self.simulation()
        sim.evaluate_forces()
        assert float(np.abs(sim.fields["Bond_Damage"]).max()) == 0.0
        assert float(np.abs(sim.fields["Damage"]).max()) == 0.0

    def test_fused_and_generic_paths_agree_with_broken_bonds(self):
        sim = self.simulation()
        blk = sim.blocks[0]
        if not blk.fused:
            pytest.skip("the block is not fused")
        x = sim.fields["Model_Coordinates"]
        rng = np.random.default_rng(11)
        sim.fields["Coordinates"][:] = x * (1.0 + self.breaking_strain * rng.random(x.shape))
        fused = sim.evaluate_forces().copy()
        d = sim.fields["Bond_Damage"]
        assert 0.0 < float(np.mean(d)) < 1.0, "some bonds, not all, should break"
        blk.fused = False
        generic = sim.evaluate_forces().copy()
        np.testing.assert_allclose(generic, fused, rtol=1e-12, atol=1e-12 * float(np.abs(fused).max()))

    def test_row_local_parts_give_the_same_damage_and_forces(self):
        """With ``row_local`` models, computing each block in two parts (as under MPI with halo
        overlap) gives the same damage and forces as the whole block, with broken bonds."""
        sim = self.simulation()
        blk = sim.blocks[0]
        if not (blk.material.row_local and blk.fused and blk.damage.row_local):
            pytest.skip("the models do not declare row_local, or the block is not fused")
        x = sim.fields["Model_Coordinates"]
        sim.fields["Coordinates"][:] = x * (1.0 + 0.1 * self.breaking_strain)
        sim.evaluate_forces()  # whatever a model caches now belongs to another configuration
        rng = np.random.default_rng(12)
        sim.fields["Coordinates"][:] = x * (1.0 + self.breaking_strain * rng.random(x.shape))
        parts = forces_in_parts(sim, 0.41)
        d = sim.fields["Bond_Damage"].copy()
        damage = sim.fields["Damage"].copy()
        assert 0.0 < float(np.mean(d)) < 1.0, "some bonds, not all, should break"
        np.testing.assert_array_equal(parts, sim.evaluate_forces())
        np.testing.assert_array_equal(sim.fields["Bond_Damage"], d)
        np.testing.assert_array_equal(sim.fields["Damage"], damage)

    def test_large_stretch_breaks_bonds_for_good(self):
        sim = self.simulation()
        x = sim.fields["Model_Coordinates"]
        sim.fields["Coordinates"][:] = x * (1.0 + self.breaking_strain)
        sim.evaluate_forces()
        d = sim.fields["Bond_Damage"].copy()
        assert d.max() > 0.0, "a large uniform stretch should break bonds"
        assert d.min() >= 0.0 and d.max() <= 1.0
        damage = sim.fields["Damage"]
        assert damage.min() >= 0.0 and damage.max() <= 1.0
        sim.advance()
        sim.fields["Coordinates"][:] = x
        sim.evaluate_forces()
        assert np.all(sim.fields["Bond_Damage"] >= d), "damage must not heal"
