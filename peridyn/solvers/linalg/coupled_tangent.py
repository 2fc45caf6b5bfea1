"""The 4x4-block tangent of the coupled (displacement and fluid pressure) QuasiStatic solve:
K = d(f V, flow V)/d(y, p), 4 degrees of freedom per point (u_x, u_y, u_z, p), the dof (g, c) at
row 4 g + c (PERIDIGM_MODELS.md §7).

The same storage as :class:`peridyn.solvers.linalg.tangent.TangentMatrix` (Peridigm's pattern: every
point couples all dofs of S_i = {i} U N_i; rows in global-id order; under MPI stored by
subdomain, owned rows then ghost rows, diagonal blocks consolidated on their owners after every
assembly; products exchange x's ghost entries and add the ghost rows back to their owners),
with 4x4 blocks. The materials fill it through ``coupled_tangent(view, target)``. Provides what
:class:`peridyn.solvers.linalg.linear.LinearSolver` uses for its ``Belos`` (Peridigm's CG) and
``Direct`` methods: ``matvec``, ``ndof``, ``parallel``/``comm``, ``to_scipy``, ``gather_*``.
"""
from __future__ import annotations

import time as _time
from dataclasses import dataclass

import numpy as np

from .bsr import PointBlockMatrix

B = 4  #: dofs per point


@dataclass
class CoupledTangentTarget:
    """What ``Material.coupled_tangent`` writes into: BSR arrays (data (nnzb, 4, 4),
    ``data[p, d, c] = d(F_(row,d) V_row)/d(unknown_(col,c))``), the local-to-row map and
    Peridigm's evaluation order of the points."""

    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray
    row_of_local: np.ndarray
    eval_rank: np.ndarray


class CoupledTangent(PointBlockMatrix):
    """K = d(f V, flow V)/d(y, p) of the owned points, 4x4-block sparse (see module docstring).
    ``n`` owned points; vectors handed to the solvers have 4 n entries in row order. Peridigm's
    pattern (every point couples all dofs of its family); storage and operations are
    :class:`PointBlockMatrix`'s with B = 4."""

    def __init__(self, sim) -> None:
        super().__init__(sim, B, "family")
        self._allocated()

    # -- assembly -------------------------------------------------------------------------------
    def assemble(self) -> None:
        """K at the current Coordinates and Fluid_Pressure_Y (bond damage as it stands)."""
        t0 = _time.perf_counter()
        sim = self.sim
        if self.parallel:
            sim.halo.exchange(sim.fields["Coordinates"])
            sim.halo.exchange(sim.fields["Fluid_Pressure_Y"])
            if "Temperature_Change" in sim.fields:
                sim.halo.exchange(sim.fields["Temperature_Change"])
        self.data[:] = 0.0
        for blk in sim.blocks:
            blk.material.precompute(blk.view)
        if self.parallel:
            for name in sim.precompute_fields:
                sim.halo.exchange(sim.fields[name])
        target = CoupledTangentTarget(self.indptr, self.indices, self.data, self.row_of_local, self.eval_rank)
        for blk in sim.blocks:
            blk.material.coupled_tangent(blk.view, target)
        if self.parallel:
            self.consolidate_diagonal()
        self.assembly_time += _time.perf_counter() - t0
        self.assemblies += 1
