"""The deck's influence function: a named kind or a user expression of ``zeta`` and ``horizon``,
evaluated per bond at set-up (the kernels' side is :mod:`peridyn.core.influence`)."""
from __future__ import annotations

import numpy as np

from ..core.influence import NAMED, ONE, PARABOLIC_DECAY, TABLE


class InfluenceFunction:
    """The deck's ``Influence Function``: a name or an expression of ``zeta`` and ``horizon``."""

    def __init__(self, spec: str = "One") -> None:
        self.spec = spec
        if spec in NAMED:
            self.kind = NAMED[spec]
            self.expression = None
        else:
            from ..deck.expressions import compile_expression

            self.kind = TABLE
            self.expression = compile_expression(spec, ("zeta", "horizon"))

    @property
    def needs_table(self) -> bool:
        return self.kind == TABLE

    def evaluate(self, zeta: np.ndarray, delta: float | np.ndarray) -> np.ndarray:
        """omega at reference bond lengths ``zeta`` (any shape) for horizon(s) ``delta``."""
        zeta = np.asarray(zeta, dtype=float)
        if self.kind == TABLE:
            return np.broadcast_to(np.asarray(self.expression(zeta=zeta, horizon=delta), dtype=float), zeta.shape).copy()
        d = np.broadcast_to(np.asarray(delta, dtype=float), zeta.shape)
        if self.kind == ONE:
            return np.ones(zeta.shape)
        if self.kind == PARABOLIC_DECAY:
            with np.errstate(divide="ignore", invalid="ignore"):
                s = zeta / d
                w = np.where(s < 0.5, 1.0, (-4.0 * s) * s + 4.0 * s)
            return np.where(zeta > d, 0.0, w)
        h2 = ((d * d) * 0.4) * 0.4
        return np.exp(-(zeta * zeta) / h2)

    def table_for(self, offsets: np.ndarray, neighbors: np.ndarray, x: np.ndarray, rows: range | np.ndarray, delta: float | np.ndarray) -> np.ndarray:
        """Per-bond omega for the bonds of ``rows`` (others left 0), shape (num_bonds,)."""
        table = np.zeros(neighbors.shape[0])
        rows = np.asarray(rows)
        if rows.size == 0:
            return table
        counts = offsets[rows + 1] - offsets[rows]
        owner = np.repeat(rows, counts)
        bonds = np.concatenate([np.arange(offsets[r], offsets[r + 1]) for r in rows]) if rows.size else np.zeros(0, int)
        d = x[neighbors[bonds]] - x[owner]
        zeta = np.sqrt((d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2])
        dd = delta if np.ndim(delta) == 0 else np.asarray(delta)[owner]
        table[bonds] = self.evaluate(zeta, dd)
        return table
