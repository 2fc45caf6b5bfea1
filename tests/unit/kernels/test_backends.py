"""The bond-loop layer: a law's kernel computes what its functions say, on every built-in backend,
bit for bit alike, and the backend of a run is selectable and pluggable."""
from __future__ import annotations

import numpy as np
import pytest

from peridyn.core.errors import InputError
from peridyn.core.traversal import PointSum
from peridyn.kernels import codegen, select_backend
from peridyn.kernels.numba_cpu import NumbaBackend, SerialNumbaBackend
from peridyn.plugins.hookspecs import hookimpl
from peridyn.testing.harness import build_simulation, cube_deck, isolated_registry

from . import laws_for_tests as laws


def random_bonds(n=40, k=7, seed=3):
    rng = np.random.default_rng(seed)
    counts = rng.integers(0, k, n)
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    neighbors = np.concatenate([rng.choice(np.delete(np.arange(n), i), c, replace=False) for i, c in enumerate(counts)]).astype(np.int32)
    x = rng.uniform(0.0, 1.0, (n, 3))
    y = x + 0.05 * rng.standard_normal((n, 3))
    zeta = np.linalg.norm(x[neighbors] - x[np.repeat(np.arange(n), counts)], axis=1)
    return offsets, neighbors, x, y, zeta, rng


def reference(offsets, neighbors, y, zeta, args):
    """The three test laws in plain numpy loops."""
    w, q, c, mark = args
    n = len(offsets) - 1
    total, stretch, force = np.zeros(n), np.zeros(len(neighbors)), np.zeros((n, 3))
    for i in range(n):
        acc = 0.0
        for b in range(offsets[i], offsets[i + 1]):
            j = neighbors[b]
            eta = y[j] - y[i]
            L = np.sqrt(eta @ eta)
            stretch[b] = (L - zeta[b]) / zeta[b]
            if mark[b]:
                continue
            acc += 0.5 * (w[j] * (L - zeta[b])) + q[i]
            force[i] += np.exp(-zeta[b]) * (L - zeta[b]) * w[j] / L * eta
        total[i] = acc * c
    return total, stretch, force


@pytest.mark.parametrize("backend", [NumbaBackend(), SerialNumbaBackend()], ids=lambda b: b.name)
def test_laws_compute_what_their_functions_say(backend):
    offsets, neighbors, x, y, zeta, rng = random_bonds()
    n = len(offsets) - 1
    args = (rng.uniform(1, 2, n), rng.uniform(0, 1, n), 3.0, (rng.uniform(0, 1, len(neighbors)) < 0.3).astype(np.uint8))
    total, stretch, force = reference(offsets, neighbors, y, zeta, args)
    out = np.full(n, np.nan)
    backend.kernel(laws.SUM)(0, n, offsets, neighbors, zeta, y, args, out)
    np.testing.assert_allclose(out, total, rtol=1e-13, atol=1e-15)
    s = np.full(len(neighbors), np.nan)
    backend.kernel(laws.STRETCH)(0, n, offsets, neighbors, zeta, y, (), s)
    np.testing.assert_allclose(s, stretch, rtol=1e-13, atol=1e-15)
    f = np.full((n, 3), np.nan)
    backend.kernel(laws.PAIR)(0, n, offsets, neighbors, zeta, y, (args[0], None, None, args[3]), f)
    np.testing.assert_allclose(f, force, rtol=1e-12, atol=1e-14)
    part = np.full(n, -1.0)  # only [start, stop) is written
    backend.kernel(laws.SUM)(5, 9, offsets, neighbors, zeta, y, args, part)
    assert np.all(part[:5] == -1.0) and np.all(part[9:] == -1.0)
    np.testing.assert_array_equal(part[5:9], out[5:9])


def test_threads_and_serial_agree_bit_for_bit_on_a_material():
    tree = cube_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 0.5}, n=7,
                     damage={"Damage Model": "Critical Stretch", "Critical Stretch": 0.01})
    forces = []
    for name in ("numba", "numba-serial"):
        sim = build_simulation(tree, backend=name)
        assert sim.backend.name == name and all(blk.view.backend is sim.backend for blk in sim.blocks)
        rng = np.random.default_rng(0)
        sim.fields["Coordinates"][:] += 0.02 * rng.standard_normal(sim.fields["Coordinates"].shape)
        forces.append(sim.evaluate_forces().copy())
        assert np.count_nonzero(sim.fields["Bond_Damage"]) > 0  # the damage law ran inside the loop
    np.testing.assert_array_equal(forces[0], forces[1])


def test_a_law_function_must_be_importable():
    def local_term(i, j, b, ex, ey, ez, L, z, p, args):
        return L

    with pytest.raises(TypeError, match="module-level"):
        NumbaBackend().kernel(PointSum(local_term))


def test_the_kernel_file_changes_with_the_physics_and_its_helpers(monkeypatch):
    text = NumbaBackend().source(laws.SUM)
    key = codegen.law_digest(laws.SUM, text)
    assert codegen.law_digest(laws.SUM, text) == key  # stable
    assert codegen.law_digest(PointSum(laws.sum_term), NumbaBackend().source(PointSum(laws.sum_term))) != key

    original = codegen._dependencies

    def edited(fn, seen):
        parts = original(fn, seen)
        return [p.replace("0.5 * x", "0.25 * x") for p in parts]

    monkeypatch.setattr(codegen, "_dependencies", edited)  # as if the helper ``half`` were edited
    assert codegen.law_digest(laws.SUM, text) != key


def test_unknown_backend_is_an_input_error_naming_the_option(monkeypatch):
    with pytest.raises(InputError) as err:
        select_backend("cuda-please")
    line = err.value.one_line() if hasattr(err.value, "one_line") else str(err.value)
    assert "--backend" in line and "numba" in line
    monkeypatch.setenv("PERIDYN_BACKEND", "numba-seriall")
    with pytest.raises(InputError, match="PERIDYN_BACKEND"):
        select_backend()
    monkeypatch.setenv("PERIDYN_BACKEND", "numba-serial")
    assert select_backend().name == "numba-serial"


class CountingBackend(NumbaBackend):
    """A plugin's backend: the numba kernels, counting the laws it was asked to compile."""

    name = "counting"
    asked: list = []

    def kernel(self, law):
        CountingBackend.asked.append(law)
        return super().kernel(law)


class CountingPlugin:
    @hookimpl
    def peridyn_backends(self):
        return [("counting", f"{__name__}:CountingBackend")]


def test_a_plugin_adds_a_backend_that_runs_the_materials_loops():
    tree = cube_deck({"Material Model": "Elastic Bond Based", "Density": 1.0, "Bulk Modulus": 1.0}, n=5)
    CountingBackend.asked.clear()
    with isolated_registry(CountingPlugin()):
        sim = build_simulation(tree, backend="counting")
        sim.evaluate_forces()
    assert CountingBackend.asked, "the material's loops did not go through the plugin's backend"


@pytest.mark.parametrize("backend", [NumbaBackend(), SerialNumbaBackend()], ids=lambda b: b.name)
def test_vector_laws(backend):
    """width > 1: a tuple per bond, summed component by component in bond order, or stored per bond."""
    offsets, neighbors, x, y, zeta, rng = random_bonds()
    n = len(offsets) - 1
    w = rng.uniform(1, 2, n)
    out = np.full((n, 3), np.nan)
    backend.kernel(laws.MOMENT)(0, n, offsets, neighbors, zeta, y, (w, 4.0), out)
    unit = np.full((len(neighbors), 3), np.nan)
    backend.kernel(laws.UNIT)(0, n, offsets, neighbors, zeta, y, (), unit)
    for i in range(n):
        acc = np.zeros(3)
        for b in range(offsets[i], offsets[i + 1]):
            eta = y[neighbors[b]] - y[i]
            acc += eta * w[neighbors[b]]
            np.testing.assert_allclose(unit[b], eta / np.linalg.norm(eta), rtol=1e-14)
        np.testing.assert_array_equal(out[i], acc / 4.0)


@pytest.mark.parametrize("law", [laws.SUM, laws.STRETCH, laws.PAIR], ids=["PointSum", "BondMap", "PairForce"])
def test_bond_lengths_from_reference_positions_are_the_same_bits(law):
    """z_from_positions: |x_j - x_i| computed in the loop equals the engine's Bond_Length bit for bit."""
    from dataclasses import replace

    from peridyn.engine.kernels import bond_length_kernel

    offsets, neighbors, x, y, zeta, rng = random_bonds(seed=8)
    n = len(offsets) - 1
    zeta = np.empty(len(neighbors))
    bond_length_kernel(n, offsets, neighbors, x, zeta)
    args = (rng.uniform(1, 2, n), rng.uniform(0, 1, n), 3.0, np.zeros(len(neighbors), np.uint8))
    shape = (n,) if isinstance(law, PointSum) else (len(neighbors),) if law is laws.STRETCH else (n, 3)
    a, b = np.zeros(shape), np.zeros(shape)
    backend = NumbaBackend()
    backend.kernel(law)(0, n, offsets, neighbors, zeta, y, args, a)
    backend.kernel(replace(law, z_from_positions=True))(0, n, offsets, neighbors, x, y, args, b)
    np.testing.assert_array_equal(a, b)


def test_law_functions_are_compiled_without_reference_counting_unless_they_allocate():
    """Unpacking arrays from args in a function compiled with numba's reference counting costs
    atomic operations per array per bond (2-4x on the elastic loops): the kernel source says which."""
    from dataclasses import replace

    text = NumbaBackend().source(laws.SUM)
    assert text.count("_nrt=False, inline=\"always\")") == len(codegen.law_functions(laws.SUM))
    assert "_nrt=False" not in NumbaBackend().source(replace(laws.SUM, allocates=True))
