"""Mirrored traversal: on one thread, the sums of a closed block computed once per bond.

A gather kernel (the default, and the only one on several threads) visits every bond twice, once
from each end, and computes its geometry (y_j - y_i, a square root) both times. On one thread a
block whose bonds all stay inside it, whose rows are symmetric (j in i's row exactly when i is in
j's) and whose points are stored in ascending row key (global id; serial runs store them so when
that is the better layout, ``geometry.neighbors.storage_rank``) can do each bond once: rows run
in order, and row i visits only its *upper* bonds (neighbors with a larger key), applies the law
from both ends and adds j's term to ``out[j]``. Every point then receives its terms in ascending
key of the neighbor, which is the order of its own row and so the order the gather kernel sums
them in: the results are the same bits (``tests/unit/kernels/test_mirror.py``). j's bond back
to i is found without a reverse index: j's lower neighbors arrive in ascending order, so it is
the next of j's bonds (``cursor[j]``).

This module holds the plan of a range of rows (where each row's upper bonds start, the cursors),
made once per neighbor list and range and checked bond by bond; the kernels are generated with
each law's (``codegen.mirror_body``). Measured on cube40 (64,000 points, 7.15 M bonds, one
core, the kernels alone, against the gathers in the same point order): the elastic force pass
26-27 -> 21-22 ms, the dilatation 15 -> 10 ms, with critical-stretch damage the force 34-35 ->
26 ms (``benchmarks/results/side_by_side.md``).
"""
from __future__ import annotations

import os
from typing import Any, Callable

import numpy as np
from numba import njit

#: (upper, cursor): the first upper bond of each row and scratch cursors (int64, indexed by point)
Plan = tuple[np.ndarray, np.ndarray]


def enabled() -> bool:
    """Whether one-thread runs may mirror (``PERIDYN_MIRROR=0`` turns it off: every law gathers,
    the same results, slower; for comparisons)."""
    return os.environ.get("PERIDYN_MIRROR", "1") != "0"


@njit(cache=True)
def _plan_kernel(start, stop, offsets, neighbors, key, upper, cursor):
    """Fills ``upper`` and checks the plan: the points stored in ascending ``key``, every
    neighbor inside [start, stop), rows strictly ascending in ``key``, no bond to itself, and
    every upper bond i->j matched by j's next lower bond j->i in the traversal's order. False
    when any fails (the gather kernel is then used)."""
    for i in range(start, stop):
        if i > start and not key[i - 1] < key[i]:
            return False
        lo = offsets[i]
        hi = offsets[i + 1]
        u = hi
        for b in range(lo, hi):
            j = neighbors[b]
            if j < start or j >= stop or j == i or key[j] == key[i]:
                return False
            if b > lo and not key[neighbors[b - 1]] < key[j]:
                return False
            if u == hi and key[j] > key[i]:
                u = b
        upper[i] = u
        cursor[i] = 0
    for i in range(start, stop):
        for b in range(upper[i], offsets[i + 1]):
            j = neighbors[b]
            rb = offsets[j] + cursor[j]
            if rb >= upper[j] or neighbors[rb] != i:
                return False
            cursor[j] += 1
    for i in range(start, stop):
        if offsets[i] + cursor[i] != upper[i]:
            return False
    return True


def mirror_plan(nl: Any, start: int, stop: int) -> Plan | None:
    """The plan of rows [start, stop) of the neighbor list ``nl`` (a ``NeighborList``), kept
    with the list; None when those rows cannot be mirrored (a bond leaves the range, a row is not
    in key order, or the rows are not symmetric)."""
    return nl.derived(f"mirror {start} {stop}", lambda: _make_plan(nl, start, stop))


def _make_plan(nl: Any, start: int, stop: int) -> Plan | None:
    if stop <= start or nl.num_bonds == 0:
        return None
    n = nl.num_points
    key = np.ascontiguousarray(nl.row_key[:n]) if nl.row_key is not None else np.arange(n, dtype=np.int64)
    upper = np.zeros(n, dtype=np.int64)
    cursor = np.zeros(n, dtype=np.int64)
    if not _plan_kernel(start, stop, nl.offsets, nl.neighbors, key, upper, cursor):
        return None
    return upper, cursor


def mirrored(block: Any, gather: Callable[..., Any], mirror: Callable[..., Any]) -> Callable[..., Any]:
    """A kernel with the common signature that runs ``mirror`` when called on ``block``'s own
    bonds over a range that has a plan, else ``gather``."""
    nl = block.bonds

    def kernel(start, stop, offsets, neighbors, zeta, y, args, out):
        if offsets is nl.offsets and neighbors is nl.neighbors:
            plan = mirror_plan(nl, int(start), int(stop))
            if plan is not None:
                return mirror(start, stop, offsets, neighbors, zeta, y, args, out, *plan)
        return gather(start, stop, offsets, neighbors, zeta, y, args, out)

    return kernel
