"""Domain decomposition: recursive coordinate bisection weighted by the expected bond count.

Every rank computes the same partition from the same (replicated) discretization, so no
communication is needed to agree on owners.
"""
from __future__ import annotations

import numpy as np


def bond_weights(volume: np.ndarray, horizon: np.ndarray) -> np.ndarray:
    """Expected family size of every point, (4/3) pi delta^3 / V (shape (n,)): the work a point
    costs is proportional to its bonds, and in the bulk of a regular mesh this is its bond count."""
    return (4.0 / 3.0 * np.pi) * horizon**3 / np.maximum(volume, 1e-300)


def recursive_coordinate_bisection(x: np.ndarray, weights: np.ndarray, parts: int) -> np.ndarray:
    """Owner rank of every point, shape (n,) int64.

    x (n, 3) positions, weights (n,) positive work estimates, parts >= 1. The set is split along
    the longest axis of its bounding box at the weighted position that gives each side a share
    of the weight proportional to its number of parts; ties are broken by index, so the result
    is deterministic. With more parts than points some parts are empty.
    """
    n = x.shape[0]
    owner = np.zeros(n, dtype=np.int64)
    stack = [(np.arange(n), 0, parts)]
    while stack:
        idx, first, count = stack.pop()
        if count == 1 or idx.size == 0:
            owner[idx] = first
            continue
        left_parts = count // 2
        pts = x[idx]
        extent = pts.max(axis=0) - pts.min(axis=0)
        axis = int(np.argmax(extent))
        order = np.lexsort((idx, pts[:, axis]))
        w = weights[idx][order]
        cum = np.cumsum(w)
        target = cum[-1] * left_parts / count
        cut = int(np.searchsorted(cum, target, side="left")) + 1
        cut = min(max(cut, 0), idx.size)
        stack.append((idx[order[:cut]], first, left_parts))
        stack.append((idx[order[cut:]], first + left_parts, count - left_parts))
    return owner
