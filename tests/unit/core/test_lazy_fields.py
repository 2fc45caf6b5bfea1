"""Lazy fields: declared, visible to ``in``, allocated and filled on first read only; a run whose
loops take bond lengths from the reference positions, or from codes into the table of a lattice's
few distinct lengths, never holds Bond_Length."""
from __future__ import annotations

import numpy as np
import pytest

from peridyn.core.fields import FieldSpec, FieldStore, Relation, Temporal
from peridyn.testing.harness import build_simulation, cube_deck


def test_a_lazy_field_is_filled_once_on_first_read():
    store = FieldStore(4, 10)
    calls = []
    store.declare_lazy(FieldSpec("Bond_Length", Relation.BOND), lambda a: (calls.append(1), a.__setitem__(slice(None), 2.5)))
    assert "Bond_Length" in store and not store.allocated("Bond_Length") and store.nbytes() == 0
    assert np.all(store["Bond_Length"] == 2.5) and store["Bond_Length"].shape == (10,)
    assert store.get("Bond_Length") is store["Bond_Length"] and calls == [1]
    with pytest.raises(ValueError):
        store.declare_lazy(FieldSpec("Bond_Length", Relation.BOND), lambda a: None)
    with pytest.raises(ValueError):
        store.declare_lazy(FieldSpec("Other", Relation.NODE, 3, Temporal.TWO_STEP), lambda a: None)
    with pytest.raises(KeyError):
        store["Nothing"]


ELASTIC = {"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 0.5}


@pytest.fixture
def many_lengths(monkeypatch):
    """As on a mesh with too many distinct bond lengths to code (an unstructured mesh)."""
    from peridyn.kernels import lengths

    monkeypatch.setattr(lengths, "code_lengths", lambda *a, **k: None)


@pytest.mark.parametrize("damage", [None, {"Damage Model": "Critical Stretch", "Critical Stretch": 0.01}])
def test_plain_lps_runs_never_hold_bond_lengths(damage, monkeypatch, many_lengths):
    """Above POSITIONS_MIN_BONDS bonds (here: from 0 up) the packed LPS kernels take |xi| from
    the reference positions; without damage nothing else reads Bond_Length."""
    from peridyn.materials import elastic

    monkeypatch.setattr(elastic, "POSITIONS_MIN_BONDS", 0)
    sim = build_simulation(cube_deck(ELASTIC, n=6, damage=damage))
    sim.fields["Coordinates"][:] *= 1.005  # below the critical stretch: intact bonds, pulling
    f = sim.evaluate_forces().copy()
    sim.stored_energy()
    assert sim.fields.allocated("Bond_Length") == (damage is not None)
    x = sim.fields["Model_Coordinates"]
    zeta = sim.fields["Bond_Length"]  # read on demand: the same lengths the loops computed
    nl = sim.bonds
    i = np.repeat(np.arange(sim.num_local), np.diff(nl.offsets))
    np.testing.assert_array_equal(zeta, np.sqrt(((x[nl.neighbors] - x[i]) ** 2).sum(axis=1)))
    assert np.abs(f).max() > 0


def test_models_that_read_bond_lengths_get_them(many_lengths):
    sim = build_simulation(cube_deck({**ELASTIC, "Thermal Expansion Coefficient": 1e-5}, n=5))
    sim.evaluate_forces()
    assert sim.fields.allocated("Bond_Length")


@pytest.mark.parametrize("damage", [None, {"Damage Model": "Critical Stretch", "Critical Stretch": 0.01}])
def test_lengths_from_positions_or_from_the_field_give_the_same_bits(damage, monkeypatch, many_lengths):
    from peridyn.materials import elastic

    out = []
    for threshold in (0, 10**12):
        monkeypatch.setattr(elastic, "POSITIONS_MIN_BONDS", threshold)
        sim = build_simulation(cube_deck(ELASTIC, n=6, damage=damage))
        sim.fields["Coordinates"][:] += 0.003 * np.random.default_rng(1).standard_normal(sim.fields["Coordinates"].shape)
        out.append((sim.evaluate_forces().copy(), sim.fields["Dilatation"].copy()))
    np.testing.assert_array_equal(out[0][0], out[1][0])
    np.testing.assert_array_equal(out[0][1], out[1][1])


@pytest.mark.parametrize("extra", [{}, {"Thermal Expansion Coefficient": 1e-5}], ids=["plain", "thermal"])
@pytest.mark.parametrize("damage", [None, {"Damage Model": "Critical Stretch", "Critical Stretch": 0.01}], ids=["intact", "damage"])
def test_lattice_runs_read_coded_lengths_and_never_hold_bond_lengths(damage, extra):
    """On a lattice every LPS loop reads the coded lengths (one byte a bond here), the same bits."""
    sim = build_simulation(cube_deck({**ELASTIC, **extra}, n=6, damage=damage))
    sim.fields["Coordinates"][:] *= 1.005
    f = sim.evaluate_forces().copy()
    sim.stored_energy()
    assert not sim.fields.allocated("Bond_Length") and np.abs(f).max() > 0
    codes, table = sim.bonds.derived("coded_lengths", lambda: None)
    assert codes.dtype == np.uint8 and len(table) < 20
    np.testing.assert_array_equal(table[codes], sim.fields["Bond_Length"])
