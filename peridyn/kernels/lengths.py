"""Reference bond lengths |xi| held as a code per bond into a table of the distinct lengths.

A mesh on a lattice (every PdQuickGrid mesh, most generated meshes) has few distinct bond lengths:
48 among the 7.15 M bonds of a 40^3 cube at horizon 3 spacings, 6,891 among the 14.7 M of the
Users' Guide's fragmenting cylinder. One byte (up to 256 lengths) or two (up to 65,536) per bond
then hold them exactly, instead of eight for ``Bond_Length`` or a square root per bond per loop
for lengths taken from the positions. The table's values are computed with ``Bond_Length``'s
arithmetic, so a loop reading ``table[codes[b]]`` sees the same bits as one reading
``Bond_Length[b]`` or computing it from the positions. Meshes with more distinct lengths (a
randomly perturbed grid, an unstructured mesh) keep those other forms: :func:`coded_lengths`
returns None for them.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numba import njit, prange

MAX_CODES = 65536
NUMPY_MAX_BONDS = 1_000_000  # below, numpy (temporaries of ~60 bytes a bond); above, two passes of a kernel
_SLOTS = 1 << 18  # open-addressing table, at most a quarter full at MAX_CODES
_EMPTY = np.int64(-1)


@njit(cache=True, inline="always")
def _length(x, i, j):
    dx = x[j, 0] - x[i, 0]
    dy = x[j, 1] - x[i, 1]
    dz = x[j, 2] - x[i, 2]
    return math.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True, inline="always")
def _slot(bits):
    return ((bits * np.int64(-7046029254386353131)) >> np.int64(46)) & np.int64(_SLOTS - 1)


@njit(cache=True)
def distinct_lengths_kernel(n, offsets, neighbors, x, keys, codes_of_slot, table, limit):
    """Insert |x_j - x_i| of every bond of rows [0, n) (``bond_length_kernel``'s arithmetic) into
    the hash table ``keys`` (int64 bits, -1 empty; ``_SLOTS`` entries), numbering distinct values in
    bond order into ``codes_of_slot`` and ``table``. Returns the number of distinct values, or
    ``limit + 1`` as soon as there are more than ``limit``."""
    count = 0
    for i in range(n):
        for b in range(offsets[i], offsets[i + 1]):
            z = _length(x, i, neighbors[b])
            bits = np.float64(z).view(np.int64)
            s = _slot(bits)
            while keys[s] != _EMPTY and keys[s] != bits:
                s = (s + 1) & (_SLOTS - 1)
            if keys[s] == _EMPTY:
                if count == limit:
                    return limit + 1
                keys[s] = bits
                codes_of_slot[s] = count
                table[count] = z
                count += 1
    return count


@njit(cache=True, parallel=True)
def code_lengths_kernel(n, offsets, neighbors, x, keys, codes_of_slot, codes):
    """codes[b] = the number of bond b's length in the filled hash table (read only here)."""
    for i in prange(n):
        for b in range(offsets[i], offsets[i + 1]):
            bits = np.float64(_length(x, i, neighbors[b])).view(np.int64)
            s = _slot(bits)
            while keys[s] != bits:
                s = (s + 1) & (_SLOTS - 1)
            codes[b] = codes_of_slot[s]


def code_lengths(offsets: np.ndarray, neighbors: np.ndarray, x: np.ndarray, limit: int = MAX_CODES) -> tuple[np.ndarray, np.ndarray] | None:
    """``(codes, table)`` with ``table[codes[b]]`` bit for bit the reference length |xi| (L) of
    bond b of the CSR bonds ``offsets`` (n+1,), ``neighbors`` (nb,) over positions ``x`` (>= n, 3)
    (L); ``codes`` uint8 (nb,) for up to 256 distinct lengths, else uint16; ``table`` float64, each
    distinct length once. None when there are more than ``limit`` (<= 65,536) distinct lengths or
    no bonds."""
    limit = min(int(limit), MAX_CODES)
    n = offsets.shape[0] - 1
    nb = neighbors.shape[0]
    if nb == 0:
        return None
    if nb < NUMPY_MAX_BONDS:  # numpy's unique: no kernel to compile for a small model
        d = x[neighbors] - np.repeat(x[:n], np.diff(offsets), axis=0)
        z = np.sqrt((d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2])
        table, inverse = np.unique(z, return_inverse=True)
        if len(table) > limit:
            return None
        return inverse.astype(np.uint8 if len(table) <= 256 else np.uint16), table
    keys = np.full(_SLOTS, _EMPTY, dtype=np.int64)
    codes_of_slot = np.zeros(_SLOTS, dtype=np.int32)
    table = np.empty(limit, dtype=np.float64)
    count = distinct_lengths_kernel(n, offsets, neighbors, x, keys, codes_of_slot, table, limit)
    if count > limit:
        return None
    codes = np.empty(nb, dtype=np.uint8 if count <= 256 else np.uint16)
    code_lengths_kernel(n, offsets, neighbors, x, keys, codes_of_slot, codes)
    return codes, table[:count].copy()


def coded_lengths(block) -> tuple[np.ndarray, np.ndarray] | None:
    """The coded reference lengths of every bond of ``block``'s neighbor list (a host
    ``BlockView``), computed from ``Model_Coordinates`` on first use and kept with the neighbor
    list; None for a mesh with too many distinct lengths."""
    nl = block.bonds
    return nl.derived("coded_lengths", lambda: code_lengths(nl.offsets, nl.neighbors, block.fields["Model_Coordinates"]))


_CODED: dict = {}


def reference_lengths(block, law):
    """``(law, zeta)`` for a loop over ``block``'s bonds that reads reference lengths: the law
    reading coded lengths and the ``(codes, table)`` pair where the mesh has few distinct
    lengths and nothing has made ``Bond_Length`` (host arrays); else ``law`` and
    ``Bond_Length``. The loop sees the same bits either way."""
    s = block.fields
    if block.backend is None or block.backend.device == "cpu":
        if not s.allocated("Bond_Length"):
            coded = coded_lengths(block)
            if coded is not None:
                c = _CODED.get(law)
                if c is None:
                    c = _CODED[law] = replace(law, z_from_codes=True)
                return c, coded
    return law, s["Bond_Length"]


def compiled_with_lengths(block, law):
    """The kernel of ``law`` on ``block``'s backend with its reference lengths bound as
    :func:`reference_lengths` chooses them: call it as ``kernel(start, stop, offsets, neighbors,
    y, args, out)``."""
    from . import compiled

    law, zeta = reference_lengths(block, law)
    kernel = compiled(block, law)
    return lambda start, stop, offsets, neighbors, y, args, out: kernel(start, stop, offsets, neighbors, zeta, y, args, out)
