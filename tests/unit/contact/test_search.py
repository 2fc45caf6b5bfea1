"""The contact pair search against brute force: radii, bond exclusion, order, capacity growth."""
import numpy as np
import pytest

from peridyn.contact.search import search_pairs
from peridyn.core.bonds import NeighborList
from peridyn.core.interfaces import VISIT_FROM_PARTNER, VISIT_FROM_POINT


def bonds_within(x, horizon):
    """One-sided reference bonds: j in row i iff |x_j - x_i| <= horizon[i] (rows sorted by index)."""
    n = len(x)
    rows = [[j for j in range(n) if j != i and np.sum((x[j] - x[i]) ** 2) <= horizon[i] ** 2] for i in range(n)]
    offsets = np.concatenate([[0], np.cumsum([len(r) for r in rows])]).astype(np.int64)
    nbrs = np.array([j for r in rows for j in r], dtype=np.int32)
    return NeighborList(offsets, nbrs, row_key=np.arange(n)), rows


def one_sided(rows):
    n = len(rows)
    sets = [set(r) for r in rows]
    lists = [sorted(j for j in range(n) if (j in sets[i]) != (i in sets[j])) for i in range(n)]
    offsets = np.concatenate([[0], np.cumsum([len(r) for r in lists])]).astype(np.int64)
    return offsets, np.array([j for r in lists for j in r], dtype=np.int64)


@pytest.mark.parametrize("cap", [1, 16])
def test_pairs_match_brute_force(cap):
    rng = np.random.default_rng(11)
    n = 300
    x = rng.uniform(0, 4, (n, 3))
    s = x + rng.normal(scale=0.2, size=(n, 3))  # positions at the last search
    y = s + rng.normal(scale=0.1, size=(n, 3))  # now
    horizon = np.where(np.arange(n) < 150, 0.5, 0.8)  # two horizons: some bonds are one-sided
    nl, rows = bonds_within(x, horizon)
    one_off, one_gid = one_sided(rows)
    gid = np.arange(n, dtype=np.int64)
    rb, rs = 0.6, 0.9
    offsets, partners, visits, used_cap, passes = search_pairs(n, y, s, gid, rb, rs, nl, gid, one_off, one_gid, cap)
    if cap == 1:
        assert passes > 1 and used_cap > 1  # the overflow grew the buffer
    sets = [set(r) for r in rows]
    for p in range(n):
        expect = []
        for j in range(n):
            if j == p or np.sum((y[j] - y[p]) ** 2) > rb * rb or np.sum((s[j] - s[p]) ** 2) > rs * rs:
                continue
            node, partner = j not in sets[p], p not in sets[j]
            if node or partner:
                expect.append((j, (VISIT_FROM_POINT if node else 0) | (VISIT_FROM_PARTNER if partner else 0)))
        got = list(zip(partners[offsets[p]:offsets[p + 1]].tolist(), visits[offsets[p]:offsets[p + 1]].tolist()))
        assert got == expect, p  # sorted by gid, the same visit bits


def test_far_flung_points_are_still_found():
    # two points next to each other, one point a million search radii away: the hashed grid
    # must not allocate by extent and must still find the close pair
    y = np.array([[0.0, 0, 0], [0.5, 0, 0], [1e6, -1e6, 3e5]])
    gid = np.arange(3, dtype=np.int64)
    nl = NeighborList(np.zeros(4, np.int64), np.zeros(0, np.int32), row_key=gid)
    offsets, partners, _, _, _ = search_pairs(3, y, y, gid, 1.0, 2.0, nl, gid, np.zeros(4, np.int64), np.zeros(0, np.int64), 4)
    assert partners[offsets[0]:offsets[1]].tolist() == [1]
    assert offsets[3] - offsets[2] == 0


def test_bonded_pairs_never_touch_even_when_broken():
    # the exclusion is by the reference bond list; damage does not enter the search at all
    x = np.array([[0.0, 0, 0], [0.3, 0, 0]])
    nl, rows = bonds_within(x, np.array([0.5, 0.5]))
    gid = np.arange(2, dtype=np.int64)
    offsets, partners, _, _, _ = search_pairs(2, x, x, gid, 1.0, 1.0, nl, gid, np.zeros(3, np.int64), np.zeros(0, np.int64), 4)
    assert partners.size == 0
