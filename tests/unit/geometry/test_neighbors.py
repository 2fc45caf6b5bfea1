"""Neighbor search and CSR bond structure (peridyn.geometry.neighbors, peridyn.core.bonds)."""
from __future__ import annotations

import numba
import numpy as np
import pytest

from peridyn.core.bonds import NeighborList
from peridyn.geometry.neighbors import (
    compact,
    hilbert_keys,
    omit_bonds_between_blocks,
    radius_search,
    renumber,
    row_runs,
    sort_rows,
    space_filling_order,
    storage_rank,
)


def brute_force(x, h, points=None, inclusive=True):
    """Reference search: numpy all-pairs with the same arithmetic ((dx*dx + dy*dy) + dz*dz)."""
    n = len(x)
    points = np.arange(n) if points is None else np.asarray(points)
    d = x[None, :, :] - x[points][:, None, :]
    d2 = (d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]) + d[..., 2] * d[..., 2]
    hh = (h[points] * h[points])[:, None]
    m = d2 <= hh if inclusive else d2 < hh
    m[np.arange(len(points)), points] = False
    offsets = np.concatenate([[0], np.cumsum(m.sum(axis=1))]).astype(np.int64)
    return offsets, np.nonzero(m)[1].astype(np.int64)


def lattice(m, spacing=1.0):
    g = np.arange(m, dtype=np.float64) * spacing
    return np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)


def rows_of(offsets, neighbors):
    return [list(neighbors[offsets[i]:offsets[i + 1]]) for i in range(len(offsets) - 1)]


# ------------------------------------------------------------------------------------------------
# radius_search
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e3])
@pytest.mark.parametrize("inclusive", [True, False])
def test_radius_search_matches_brute_force_variable_horizons(scale, inclusive):
    rng = np.random.default_rng(int(scale * 1e6) % 1000 + inclusive)
    for n in (2, 7, 60, 250):
        x = rng.random((n, 3)) * scale
        x[n // 2] = x[0]  # a duplicate point
        h = (0.05 + 0.4 * rng.random(n)) * scale
        off, nb = radius_search(x, h, inclusive=inclusive)
        ref_off, ref_nb = brute_force(x, h, inclusive=inclusive)
        assert off.dtype == np.int64 and nb.dtype == np.int64
        np.testing.assert_array_equal(off, ref_off)
        np.testing.assert_array_equal(nb, ref_nb)
    # variable horizons make families one-sided somewhere
    rows = [set(r) for r in rows_of(off, nb)]
    assert any(i not in rows[j] for i in range(n) for j in rows[i])


def test_duplicates_are_neighbors():
    x = np.zeros((4, 3))
    off, nb = radius_search(x, np.full(4, 1e-6))
    assert rows_of(off, nb) == [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]
    off, nb = radius_search(x, 1e-6, inclusive=False)  # distance 0 < delta still
    assert np.diff(off).tolist() == [3, 3, 3, 3]


def test_inclusive_boundary_on_lattice():
    # spacing 0.5 and horizon 1.0 are exact: points at exactly delta are kept only when inclusive
    x = lattice(6, 0.5)
    h = np.full(len(x), 1.0)
    for inclusive in (True, False):
        off, nb = radius_search(x, h, inclusive=inclusive)
        ref = brute_force(x, h, inclusive=inclusive)
        np.testing.assert_array_equal(off, ref[0])
        np.testing.assert_array_equal(nb, ref[1])
    interior = np.ravel_multi_index((2, 2, 2), (6, 6, 6))
    inc = np.diff(radius_search(x, h)[0])[interior]
    exc = np.diff(radius_search(x, h, inclusive=False)[0])[interior]
    assert inc - exc == 6  # the six points two spacings away along an axis are at exactly delta
    d = np.linalg.norm(x - x[interior], axis=1)
    assert inc == np.count_nonzero((d <= 1.0) & (d > 0)) and exc == np.count_nonzero((d < 1.0) & (d > 0))


def test_inclusive_boundary_inexact_spacing():
    # 0.1 spacing, horizon 0.2: decided by the exact double comparison, like Peridigm
    x = lattice(5, 0.1)
    h = np.full(len(x), 0.2)
    off, nb = radius_search(x, h)
    ref = brute_force(x, h)
    np.testing.assert_array_equal(off, ref[0])
    np.testing.assert_array_equal(nb, ref[1])


def test_edge_cases_sizes():
    off, nb = radius_search(np.zeros((0, 3)), np.zeros(0))
    assert off.tolist() == [0] and nb.size == 0
    off, nb = radius_search(np.array([[1.0, 2.0, 3.0]]), np.array([0.5]))
    assert off.tolist() == [0, 0] and nb.size == 0
    # isolated points (no neighbors) between clustered ones
    x = np.array([[0, 0, 0], [0.1, 0, 0], [5, 5, 5], [10, 0, 0]], dtype=float)
    off, nb = radius_search(x, np.full(4, 0.2))
    assert rows_of(off, nb) == [[1], [0], [], []]
    with pytest.raises(ValueError):
        radius_search(x, np.array([0.2, 0.2, 0.0, 0.2]))
    with pytest.raises(ValueError):
        radius_search(np.zeros((3, 2)), 1.0)


def test_huge_horizon_everyone_neighbors_everyone():
    rng = np.random.default_rng(3)
    x = rng.random((300, 3))
    off, nb = radius_search(x, np.full(300, 1e9))
    assert np.all(np.diff(off) == 299)
    # wide spread with a tiny horizon: the cell grid stays bounded (~2n cells)
    x = np.array([[0, 0, 0], [1e-7, 0, 0], [1e3, 1e3, 1e3]])
    off, nb = radius_search(x, np.full(3, 1e-6))
    assert rows_of(off, nb) == [[1], [0], []]


def test_points_subset_and_int32():
    rng = np.random.default_rng(5)
    x = rng.random((200, 3))
    h = 0.1 + 0.1 * rng.random(200)
    pts = np.array([150, 3, 77, 3])
    off, nb = radius_search(x, h, pts, dtype=np.int32)
    assert nb.dtype == np.int32
    ref = brute_force(x, h, pts)
    np.testing.assert_array_equal(off, ref[0])
    np.testing.assert_array_equal(nb, ref[1])


def test_thread_count_independence():
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs 2 numba threads")
    rng = np.random.default_rng(11)
    x = rng.random((3000, 3))
    h = 0.06 + 0.04 * rng.random(3000)
    keys = rng.permutation(3000)
    old = numba.get_num_threads()
    try:
        results = []
        for nt in (1, 2):
            numba.set_num_threads(nt)
            off, nb = radius_search(x, h, dtype=np.int32)
            nl = NeighborList(off, nb)
            nl2 = NeighborList(off, sort_rows(off, nb, keys))
            results.append((off, nb, nl.reverse(), *nl.transpose(), nl2.neighbors, nl2.reverse(),
                            space_filling_order(x)))
    finally:
        numba.set_num_threads(old)
    for a, b in zip(*results):
        np.testing.assert_array_equal(a, b)


# ------------------------------------------------------------------------------------------------
# NeighborList
# ------------------------------------------------------------------------------------------------
def asymmetric_list():
    rng = np.random.default_rng(7)
    x = rng.random((120, 3))
    h = 0.1 + 0.2 * rng.random(120)
    off, nb = radius_search(x, h)
    return NeighborList(off, nb)


def check_reverse(nl: NeighborList):
    rev = nl.reverse()
    assert rev.dtype == np.int32 and rev.shape == (nl.num_bonds,)
    src = nl.sources()
    one_sided = 0
    for b in range(nl.num_bonds):
        i, j = src[b], nl.neighbors[b]
        row_j = list(nl.neighbors[nl.offsets[j]:nl.offsets[j + 1]])
        if i in row_j:
            assert rev[b] == nl.offsets[j] + row_j.index(i)
            assert rev[rev[b]] == b
        else:
            assert rev[b] == -1
            one_sided += 1
    return one_sided


def test_reverse_asymmetric_and_after_resorting():
    nl = asymmetric_list()
    assert check_reverse(nl) > 0
    # rows sorted by another key (e.g. global ids): the general path must agree
    key = np.random.default_rng(1).permutation(nl.num_points)
    nl2 = NeighborList(nl.offsets, sort_rows(nl.offsets, nl.neighbors, key))
    assert check_reverse(nl2) > 0
    # ... and with the key given: the keyed search must agree
    nl3 = NeighborList(nl.offsets, nl2.neighbors, row_key=key)
    np.testing.assert_array_equal(nl3.reverse(), nl2.reverse())
    # a key with ties (rows ascending in key, ties in any order)
    ties = key // 3
    nl4 = NeighborList(nl.offsets, sort_rows(nl.offsets, nl.neighbors, ties), row_key=ties)
    assert check_reverse(nl4) > 0
    # a wrong key is detected and the general method used
    nl5 = NeighborList(nl.offsets, nl2.neighbors, row_key=-key)
    np.testing.assert_array_equal(nl5.reverse(), nl2.reverse())
    with pytest.raises(ValueError):
        NeighborList(nl.offsets, nl.neighbors, row_key=key[:3])


def test_reverse_symmetric_lattice():
    x = lattice(7)
    off, nb = radius_search(x, np.full(len(x), 2.01), dtype=np.int32)
    nl = NeighborList(off, nb)
    assert check_reverse(nl) == 0
    tin, tb = nl.transpose()  # shortcut: (offsets, reverse)
    assert tin is nl.offsets and tb is nl.reverse()
    ref = NeighborList(off, nb)
    rin, rb = ref.transpose()  # general path (reverse not computed)
    np.testing.assert_array_equal(tin, rin)
    np.testing.assert_array_equal(tb, rb)


def test_transpose():
    nl = asymmetric_list()
    nl.reverse()  # has -1 entries: transpose must not take the shortcut
    in_off, in_b = nl.transpose()
    src = nl.sources()
    assert in_off.shape == (nl.num_points + 1,) and in_b.dtype == np.int32
    for t in range(nl.num_points):
        bonds = in_b[in_off[t]:in_off[t + 1]]
        expected = np.nonzero(nl.neighbors == t)[0]
        np.testing.assert_array_equal(np.sort(bonds), expected)
        assert np.all(np.diff(src[bonds]) > 0)  # ascending source order


def test_neighbor_list_basics():
    off = np.array([0, 2, 2, 3])
    nl = NeighborList(off, np.array([1, 2, 0], dtype=np.int64))
    assert nl.neighbors.dtype == np.int32 and nl.offsets.dtype == np.int64
    assert nl.num_points == 3 and nl.num_bonds == 3
    assert nl.counts().tolist() == [2, 0, 1]
    assert nl.sources().tolist() == [0, 0, 2]
    assert nl.reverse().tolist() == [-1, 2, 1]
    assert nl.nbytes() == 4 * 8 + 3 * 4 + 3 * 4 + 3 * 4
    with pytest.raises(ValueError):
        NeighborList(np.array([0, 2]), np.array([1]))
    empty = NeighborList(np.zeros(1, np.int64), np.zeros(0, np.int32))
    assert empty.reverse().size == 0 and empty.transpose()[0].tolist() == [0]


def test_bonds_to_points_without_rows():
    # ghost-like targets past the last row: reverse -1, transpose covers them
    nl = NeighborList(np.array([0, 2, 3]), np.array([1, 4, 0]))
    assert nl.reverse().tolist() == [2, -1, 0]
    in_off, in_b = nl.transpose()
    assert in_off.tolist() == [0, 1, 2, 2, 2, 3]
    assert in_b.tolist() == [2, 0, 1]


# ------------------------------------------------------------------------------------------------
# Row operations
# ------------------------------------------------------------------------------------------------
def test_sort_rows_stable():
    off = np.array([0, 4, 4, 7])
    nb = np.array([0, 1, 2, 3, 3, 2, 1], dtype=np.int32)
    key = np.array([5, 1, 5, 0])
    out = sort_rows(off, nb, key)
    assert out.dtype == np.int32
    assert out.tolist() == [3, 1, 0, 2, 3, 1, 2]
    # general keys (float, negative) take the other kernel: same answers
    assert sort_rows(off, nb, key.astype(float)).tolist() == out.tolist()
    rng = np.random.default_rng(8)
    off2, nb2 = radius_search(rng.random((300, 3)), 0.2, dtype=np.int32)
    k2 = rng.integers(0, 50, 300)  # many ties
    ref = [sorted(r, key=lambda j: k2[j]) for r in rows_of(off2, nb2)]  # Python's sort is stable
    assert rows_of(off2, sort_rows(off2, nb2, k2)) == ref
    assert rows_of(off2, sort_rows(off2, nb2, k2.astype(np.float64))) == ref


def test_renumber_round_trip_and_consistency():
    rng = np.random.default_rng(2)
    x = rng.random((400, 3))
    h = np.full(400, 0.12)
    off, nb = radius_search(x, h, dtype=np.int32)
    order = space_filling_order(x)  # old index of each new point
    new_of_old = np.empty_like(order)
    new_of_old[order] = np.arange(order.size)
    off2, nb2 = renumber(off, nb, new_of_old, order)
    # same as searching the renumbered points, once rows are re-sorted
    ref = radius_search(x[order], h[order])
    np.testing.assert_array_equal(off2, ref[0])
    np.testing.assert_array_equal(sort_rows(off2, nb2, np.arange(400)), ref[1])
    # round trip
    off3, nb3 = renumber(off2, nb2, order, new_of_old)
    np.testing.assert_array_equal(off3, off)
    np.testing.assert_array_equal(nb3, nb)


def test_compact_and_omit_bonds_between_blocks():
    x = lattice(4)
    off, nb = radius_search(x, np.full(len(x), 1.5), dtype=np.int32)
    block = np.where(x[:, 0] < 1.5, 1, 2)
    o2, n2 = omit_bonds_between_blocks(off, nb, block)
    ref_rows = [[j for j in r if block[j] == block[i]] for i, r in enumerate(rows_of(off, nb))]
    assert rows_of(o2, n2) == ref_rows
    # with a row map (a subset of points in CSR rows)
    pts = np.array([5, 40, 63])
    o3, n3 = radius_search(x, np.full(len(x), 1.5), pts, dtype=np.int32)
    o4, n4 = omit_bonds_between_blocks(o3, n3, block, rows=pts)
    assert rows_of(o4, n4) == [ref_rows[p] for p in pts]
    keep = np.zeros(nb.size, bool)
    keep[::3] = True
    o5, n5 = compact(off, nb, keep)
    assert n5.tolist() == nb[::3].tolist() and o5[-1] == n5.size


# ------------------------------------------------------------------------------------------------
# Space-filling order
# ------------------------------------------------------------------------------------------------
def test_hilbert_curve_is_continuous_on_a_full_grid():
    x = lattice(8)
    keys = hilbert_keys(x, bits=3)
    assert sorted(keys.tolist()) == list(range(512))
    path = x[np.argsort(keys)]
    steps = np.abs(np.diff(path, axis=0)).sum(axis=1)
    assert np.all(steps == 1.0)  # consecutive cells share a face


def test_space_filling_order_improves_locality():
    rng = np.random.default_rng(9)
    x = lattice(16)
    x = x[rng.permutation(len(x))]
    order = space_filling_order(x)
    assert np.array_equal(np.sort(order), np.arange(len(x)))
    h = np.full(len(x), 1.5)
    off, nb = radius_search(x, h)
    src = np.repeat(np.arange(len(x)), np.diff(off))
    before = np.abs(src - nb).mean()
    y = x[order]
    off, nb = radius_search(y, h)
    src = np.repeat(np.arange(len(y)), np.diff(off))
    after = np.abs(src - nb).mean()
    assert after < 0.2 * before
    # degenerate inputs
    assert space_filling_order(np.zeros((0, 3))).size == 0
    assert space_filling_order(np.ones((5, 3))).tolist() == [0, 1, 2, 3, 4]


def test_row_runs_counts_breaks_in_consecutive_storage():
    offsets = np.array([0, 3, 5, 5], dtype=np.int64)
    neighbors = np.array([1, 2, 4, 0, 2], dtype=np.int32)
    assert row_runs(offsets, neighbors, np.arange(5, dtype=np.int64)) == 2 + 2
    assert row_runs(offsets, neighbors, np.array([0, 4, 3, 2, 1], dtype=np.int64)) == 3 + 2
    assert row_runs(offsets, neighbors, np.arange(5, dtype=np.int64), 2) == 2 + 0  # rows 0 and 2 of a sample


def test_a_serial_lattice_numbered_axis_by_axis_is_stored_by_id_else_along_the_curve():
    x = lattice(10)
    n = len(x)
    gid = np.arange(n)
    block = np.zeros(n, dtype=np.int64)
    owned = np.arange(n)
    off, nb = radius_search(x, np.full(n, 3.0))
    hilbert = np.empty(n, dtype=np.int64)
    hilbert[space_filling_order(x)] = np.arange(n)
    assert np.array_equal(storage_rank(x, gid, block, owned, off, nb, serial=True), gid)
    assert np.array_equal(storage_rank(x, gid, block, owned, off, nb, serial=False), hilbert)  # MPI: the curve
    # ids that scatter the lattice: the curve (rows sorted by id then jump around either way,
    # and the id order has no locality at all)
    shuffled = np.random.default_rng(0).permutation(n)
    rank = storage_rank(x, shuffled, block, owned, off, nb, serial=True)
    assert np.array_equal(rank, hilbert)
