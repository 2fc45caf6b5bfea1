"""Conformance suites every model passes (built-in or third-party).

Subclass a suite in a test module and set the class attributes; pytest collects the tests.
Tolerances are relative to the size of the quantities involved. Checks of identities (momentum,
rigid motion, fused against generic kernels, damage) leave room for round-off only (1e-9 of
the force scale or less); a wrong kernel misses them by orders of magnitude. The moduli checks
compare a lattice model with the continuum and allow its lattice error (see
:mod:`peridyn.testing.physics_checks`).
"""
from __future__ import annotations

import contextlib
import tempfile
from typing import Any, ClassVar

import numpy as np

from .harness import build_simulation, cube_deck, isolated_registry, scattered_deck
from .physics_checks import MaterialPhysicsChecks, rotation_matrix


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


class MaterialConformance(MaterialPhysicsChecks):
    """Checks for a material. Set ``material`` (deck name) and ``params`` (deck parameters
    without ``Material Model``); ``plugins`` lists plugin modules to register when the package
    is not installed; ``central`` is True for materials whose bond forces act along the bond
    (then angular momentum is conserved too).

    The physics checks (:mod:`peridyn.testing.physics_checks`) read the elastic constants from
    ``params`` (two of Bulk/Shear/Young's Modulus/Poisson's Ratio, or one of Bulk/Young's Modulus
    for a bond-based material) or from ``moduli = (K, G)``; they build lattices of ``spacing``
    (not 1, so that a missing factor of a length shows) and irregular point clouds, and use
    ``damage_params`` as the damage model of the damage checks.
    """

    material: ClassVar[str] = ""
    params: ClassVar[dict[str, Any]] = {}
    plugins: ClassVar[tuple] = ()
    central: ClassVar[bool] = True
    strain: ClassVar[float] = 1e-3  #: size of the random deformation used by the checks (displacements strain x spacing)
    spacing: ClassVar[float] = 1e-3  #: lattice spacing of the checks' models (L)
    moduli: ClassVar[tuple[float, float] | None] = None  #: (K, G) when the parameters do not state them
    modulus_tolerance: ClassVar[float] = 0.25  #: measured moduli within a factor 1 + this of the stated ones
    modulus_strain: ClassVar[float] = 1e-5  #: size of the quadratic fields of the moduli checks
    modulus_points: ClassVar[int] = 15  #: points per side of the moduli lattice (interior points two horizons deep)
    uniformity_tolerance: ClassVar[float] = 1e-3  #: relative spread allowed between interior points
    dimension: ClassVar[int | None] = None  #: 2 or 3; default: 2 when Plane Strain / Plane Stress is set
    #: the damage model of the damage checks: one that never breaks a bond on its own
    damage_params: ClassVar[dict[str, Any]] = {"Damage Model": "Critical Stretch", "Critical Stretch": 1.0e3}

    # -- helpers ------------------------------------------------------------------------------
    @contextlib.contextmanager
    def _registry(self):
        if self.plugins:
            with isolated_registry(*self.plugins, autoload=False) as reg:
                yield reg
        else:
            yield None

    def material_entry(self, params: dict[str, Any] | None = None) -> dict[str, Any]:
        """The deck's Materials entry: ``Material Model``, ``params`` and the ``params`` overrides."""
        return {"Material Model": self.material, **self.params, **(params or {})}

    def simulation(self, n: int = 5, *, params: dict[str, Any] | None = None, **kw):
        """A lattice cube of n^3 points (``cube_deck`` keywords; default spacing ``spacing``);
        ``params`` overrides material parameters."""
        kw.setdefault("spacing", self.spacing)
        with self._registry() as reg:
            return build_simulation(cube_deck(self.material_entry(params), n=n, **kw), registry=reg)

    def scattered_simulation(self, n: int = 6, *, seed: int = 0, damage: dict[str, Any] | None = None):
        """An irregular cloud (``scattered_deck``: jittered points, random volumes) of n^3
        points of spacing ``spacing``, with the ``damage`` model entry if given."""
        with tempfile.TemporaryDirectory() as tmp, self._registry() as reg:
            tree = scattered_deck(self.material_entry(), tmp, n=n, spacing=self.spacing, seed=seed, damage=damage)
            return build_simulation(tree, directory=tmp, registry=reg, output_dir=tmp)

    def deform(self, sim, seed: int = 0) -> None:
        """Random displacements of size ``strain * spacing`` (L)."""
        x = sim.fields["Model_Coordinates"]
        rng = np.random.default_rng(seed)
        sim.fields["Coordinates"][:] = x + (self.strain * self.spacing) * rng.standard_normal(x.shape)
        sim.fields["Displacement"][:] = sim.fields["Coordinates"] - x

    def force(self, sim) -> np.ndarray:
        """The force density (n, 3) at the current positions (a copy)."""
        return sim.evaluate_forces().copy()

    def scale(self, sim) -> float:
        self.deform(sim)
        return float(np.abs(self.force(sim)).max())

    # -- checks of the engine contract -------------------------------------------------------
    def test_params_validate(self):
        import pytest
        with self._registry() as reg:
            from ..plugins.manager import get_registry

            cls = (reg or get_registry()).get("material", self.material)
            cls.Params.model_validate(self.params)
            with pytest.raises(Exception):
                cls.Params.model_validate({**self.params, "Not A Parameter": 1.0})

    def test_rigid_motion_gives_zero_force(self):
        sim = self.scattered_simulation(seed=3)
        scale = self.scale(sim)
        assert scale > 0, "a random deformation should produce forces"
        x = sim.fields["Model_Coordinates"]
        R = rotation_matrix(0.7, [1.0, 2.0, 0.5])
        sim.fields["Coordinates"][:] = x @ R.T + self.spacing * np.array([0.3, -1.0, 2.0])
        f = self.force(sim)
        np.testing.assert_allclose(f, 0.0, atol=1e-9 * scale)

    def test_fused_and_generic_paths_agree(self):
        import pytest
        sim = self.scattered_simulation(seed=4)
        self.deform(sim, seed=3)
        blk = sim.blocks[0]
        if not blk.fused:
            pytest.skip("the block is not fused")
        fused = self.force(sim)
        blk.fused = False
        generic = self.force(sim)
        np.testing.assert_allclose(generic, fused, rtol=1e-12, atol=1e-12 * float(np.abs(fused).max()))

    def test_the_gpu_step_gives_the_cpu_forces(self):
        """A material that declares "gpu" in ``devices``: the GPU step accepts the model (what
        ``peridyn check --device gpu`` and the run refuse, named) and its device forces on a
        deformed irregular cloud are the CPU's, under numba-cuda's simulator
        (``NUMBA_ENABLE_CUDASIM=1``: the CPU's arithmetic, to round-off) or on a GPU (the
        difference of fused multiply-adds: 1e-9 of the force scale)."""
        import pytest

        with self._registry() as reg:
            from ..plugins.manager import get_registry

            cls = (reg or get_registry()).get("material", self.material)
        if "gpu" not in cls.devices:
            pytest.skip("the material declares no GPU path")
        try:
            from ..kernels.numba_cuda import CudaBackend, require_gpu, simulated

            require_gpu()
        except Exception as exc:  # noqa: BLE001 - no numba-cuda, no GPU and no simulator
            pytest.skip(f"no GPU and no simulator to run the GPU path on ({exc}); set NUMBA_ENABLE_CUDASIM=1")
        from ..core.state import SolverState
        from ..gpu.placement import DevicePlacement
        from ..gpu.support import model_problems

        sim = self.scattered_simulation(n=5, seed=5)
        self.deform(sim, seed=6)
        problems = model_problems(sim)
        assert not problems, f"the GPU step refuses the model: {problems}"
        cpu = self.force(sim)
        backend = CudaBackend()
        gpu = backend.to_host(DevicePlacement(sim, backend, SolverState()).evaluate_forces())[: sim.num_owned]
        scale = float(np.abs(cpu).max())
        np.testing.assert_allclose(gpu, cpu[: sim.num_owned], rtol=0.0, atol=(1e-12 if simulated() else 1e-9) * scale)

    def test_row_local_parts_give_the_same_forces(self):
        """A material that declares ``row_local`` may be computed in parts (under MPI: the
        points without ghost neighbors while the halo messages travel); the forces must be the
        ones of the whole block, bit for bit."""
        import pytest
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


class DamageConformance:
    """Checks for a damage model: no damage without deformation, damage in [0, 1] that never
    heals, every bond broken by a stretch far beyond the critical one, point damage that
    follows bond damage, and equal damage at both bond ends when the model declares it. Set
    ``damage`` (deck name), ``params`` and optionally ``material`` / ``material_params`` and
    ``plugins``."""

    damage: ClassVar[str] = ""
    params: ClassVar[dict[str, Any]] = {}
    material: ClassVar[str] = "Elastic"
    material_params: ClassVar[dict[str, Any]] = {"Density": 1000.0, "Bulk Modulus": 1.0e9, "Shear Modulus": 0.4e9}  # 3K != 5mu: the dilatation term of LPS is not zero
    plugins: ClassVar[tuple] = ()
    breaking_strain: ClassVar[float] = 0.5  #: a uniform stretch that must break some bonds

    def simulation(self, n: int = 5, **kw):
        """A lattice cube of n^3 points of spacing 1 (``cube_deck`` keywords) with the material
        and the damage model."""
        mat = {"Material Model": self.material, **self.material_params}
        dmg = {"Damage Model": self.damage, **self.params}
        if self.plugins:
            with isolated_registry(*self.plugins) as reg:
                return build_simulation(cube_deck(mat, n=n, damage=dmg, **kw), registry=reg)
        return build_simulation(cube_deck(mat, n=n, damage=dmg, **kw))

    def test_no_damage_at_rest(self):
        sim = self.simulation()
        sim.evaluate_forces()
        assert float(np.abs(sim.fields["Bond_Damage"]).max()) == 0.0
        assert float(np.abs(sim.fields["Damage"]).max()) == 0.0

    def test_fused_and_generic_paths_agree_with_broken_bonds(self):
        import pytest
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
        import pytest
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

    def _random_stretch(self, sim, seed: int) -> None:
        x = sim.fields["Model_Coordinates"]
        rng = np.random.default_rng(seed)
        sim.fields["Coordinates"][:] = x * (1.0 + self.breaking_strain * rng.random(x.shape))
        sim.evaluate_forces()

    def test_uniform_stretch_damages_every_bond(self):
        """A uniform stretch of ``breaking_strain`` stretches every bond alike, far beyond the
        critical value: every bond is damaged, and so is every point."""
        sim = self.simulation()
        x = sim.fields["Model_Coordinates"]
        sim.fields["Coordinates"][:] = x * (1.0 + self.breaking_strain)
        sim.evaluate_forces()
        d = sim.fields["Bond_Damage"]
        intact = int(np.count_nonzero(d <= 0.0))
        assert intact == 0, f"{intact} of {d.size} bonds stretched by {self.breaking_strain} are undamaged"
        assert float(sim.fields["Damage"][: sim.num_owned].min()) > 0.0, "points whose bonds are all damaged have no Damage"

    def test_point_damage_follows_bond_damage(self):
        """Damage is in [0, 1], zero at points whose bonds are intact and positive at points
        with a damaged bond."""
        sim = self.simulation(shape=(12, 4, 4))  # a bar: random stretches in one end only
        x = sim.fields["Model_Coordinates"]
        rng = np.random.default_rng(13)
        lo, hi = float(x[:, 0].min()), float(x[:, 0].max())
        end = x[:, 0] > lo + 0.7 * (hi - lo)
        sim.fields["Coordinates"][end] = x[end] * (1.0 + self.breaking_strain * rng.random((int(end.sum()), 3)))
        sim.evaluate_forces()
        nl = sim.bonds
        n = sim.num_owned
        d = np.asarray(sim.fields["Bond_Damage"][: nl.offsets[n]], dtype=float)
        damaged = np.zeros(n, bool)
        damaged[np.repeat(np.arange(n), np.diff(nl.offsets[: n + 1]))[d > 0.0]] = True
        assert 0 < damaged.sum() < n, "a random stretch should damage the bonds of some points, not all"
        damage = sim.fields["Damage"][:n]
        assert damage.min() >= 0.0 and damage.max() <= 1.0
        assert np.all(damage[~damaged] == 0.0), "points with intact bonds have Damage"
        assert np.all(damage[damaged] > 0.0), "points with damaged bonds have no Damage"

    def test_declared_symmetry_holds(self):
        """A model that declares ``symmetric`` (materials then skip the reverse bond) gives
        both ends of every bond the same damage."""
        import pytest
        sim = self.simulation()
        if not sim.blocks[0].damage.symmetric:
            pytest.skip("the damage model does not declare symmetric damage")
        self._random_stretch(sim, seed=14)
        d = sim.fields["Bond_Damage"]
        reverse = sim.bonds.reverse()
        assert 0.0 < float(np.mean(d)) < 1.0, "some bonds, not all, should break"
        np.testing.assert_array_equal(d, d[reverse])
