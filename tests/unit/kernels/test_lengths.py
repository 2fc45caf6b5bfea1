"""Coded reference bond lengths (peridyn.kernels.lengths): exact, compact, refused when not."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from peridyn.core.traversal import PointSum
from peridyn.engine.kernels import bond_length_kernel
from peridyn.geometry.neighbors import radius_search
from peridyn.kernels.lengths import code_lengths
from peridyn.kernels.numba_cpu import NumbaBackend
from peridyn.testing.harness import build_simulation, cube_deck

from . import laws_for_tests as laws


def lattice(n: int, h: float, origin=(0.0, 0.0, 0.0), jitter: float = 0.0, seed: int = 0):
    g = (np.arange(n) + 0.5) * h
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3) + np.asarray(origin)
    if jitter:
        x = x + jitter * h * np.random.default_rng(seed).standard_normal(x.shape)
    offsets, neighbors = radius_search(x, np.full(len(x), 3.015 * h), np.arange(len(x)), dtype=np.int32)
    return offsets, neighbors, x


def bond_lengths(offsets, neighbors, x):
    z = np.empty(len(neighbors))
    bond_length_kernel(len(offsets) - 1, offsets, neighbors, x, z)
    return z


@pytest.mark.parametrize("h, origin", [(1.0, (0, 0, 0)), (0.1, (0.3, -7.1, 2.0)), (1e-3, (-0.02, 0.01, 0.0))])
def test_a_lattice_has_few_lengths_and_the_table_gives_the_same_bits(h, origin):
    offsets, neighbors, x = lattice(8, h, origin)
    codes, table = code_lengths(offsets, neighbors, x)
    z = bond_lengths(offsets, neighbors, x)
    assert codes.dtype == np.uint8 and codes.shape == z.shape
    np.testing.assert_array_equal(table[codes].view(np.int64), z.view(np.int64))
    assert len(table) == len(np.unique(z))  # every distinct value once, none invented


def test_more_than_256_lengths_take_two_bytes_and_more_than_the_limit_none():
    offsets, neighbors, x = lattice(6, 1.0, jitter=1e-3)
    z = bond_lengths(offsets, neighbors, x)
    distinct = len(np.unique(z))
    assert 256 < distinct < 65536
    codes, table = code_lengths(offsets, neighbors, x)
    assert codes.dtype == np.uint16
    np.testing.assert_array_equal(table[codes], z)
    assert code_lengths(offsets, neighbors, x, limit=distinct - 1) is None
    assert code_lengths(offsets, neighbors, x, limit=distinct) is not None


def test_no_bonds_gives_none():
    x = np.zeros((3, 3))
    assert code_lengths(np.zeros(4, np.int64), np.zeros(0, np.int32), x) is None


@pytest.mark.parametrize("law", [laws.SUM, laws.STRETCH, laws.PAIR], ids=["PointSum", "BondMap", "PairForce"])
def test_laws_reading_codes_compute_the_same_bits_as_from_bond_lengths(law):
    offsets, neighbors, x = lattice(6, 0.25, jitter=1e-4, seed=2)
    rng = np.random.default_rng(5)
    n = len(offsets) - 1
    y = x + 0.01 * rng.standard_normal(x.shape)
    zeta = bond_lengths(offsets, neighbors, x)
    coded = code_lengths(offsets, neighbors, x)
    args = (rng.uniform(1, 2, n), rng.uniform(0, 1, n), 3.0, (rng.random(len(neighbors)) < 0.1).astype(np.uint8))
    shape = (n,) if isinstance(law, PointSum) else (len(neighbors),) if law is laws.STRETCH else (n, 3)
    a, b = np.zeros(shape), np.zeros(shape)
    backend = NumbaBackend()
    backend.kernel(law)(0, n, offsets, neighbors, zeta, y, args, a)
    backend.kernel(replace(law, z_from_codes=True))(0, n, offsets, neighbors, coded, y, args, b)
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("damage", [None, {"Damage Model": "Critical Stretch", "Critical Stretch": 0.002}], ids=["plain", "critical stretch"])
def test_elastic_steps_on_coded_lengths_hold_no_bond_length_and_match_the_general_path(damage, monkeypatch):
    """The packed elastic path reads coded lengths on a lattice, and its forces are those of the
    general path (Bond_Length, per-bond arrays) to round-off; no Bond_Length is allocated."""
    import peridyn.kernels.lengths as lengths

    material = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 1.6e11, "Shear Modulus": 7.9e10}
    deck = cube_deck(material, n=7, spacing=1e-3, damage=damage)
    sim = build_simulation(deck)
    rng = np.random.default_rng(1)
    s = sim.fields
    s["Coordinates"][:] = s["Model_Coordinates"] * (1.0 + 0.003 * rng.random((len(s["Coordinates"]), 3)))
    f = sim.evaluate_forces().copy()
    assert sim.bonds.derived("coded_lengths", lambda: None) is not None
    assert not s.allocated("Bond_Length")

    monkeypatch.setattr(lengths, "code_lengths", lambda *a, **k: None)  # as on a mesh of many lengths
    sim2 = build_simulation(deck)
    sim2.fields["Coordinates"][:] = s["Coordinates"]
    f2 = sim2.evaluate_forces()
    assert sim2.fields.allocated("Bond_Length")
    np.testing.assert_array_equal(f, f2)
