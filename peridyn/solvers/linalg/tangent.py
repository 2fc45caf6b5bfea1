"""The tangent stiffness K = d(f V)/dy of the implicit solvers (PERIDIGM_SEMANTICS.md §11.1).

K is stored block-sparse (3x3 blocks, BSR) with rows and columns in **global-id order**, the
degree of freedom (g, c) at index 3 g + c as in Peridigm, so that matrix-vector products and
the Krylov solvers that reproduce Peridigm's (:mod:`peridyn.solvers.linalg.linear`) sum in Peridigm's
order. Sparsity: every point i couples all degrees of freedom of S_i = {i} U N_i (Peridigm's
pattern, including pairs that only share a neighbor); when every material's tangent couples
bonded pairs only (bond-based), the pattern is just the bonded pairs. NOX preconditioners use a
block-diagonal pattern.

Filling: each block's material adds its points' contributions through ``Material.tangent``
(analytic; see :mod:`peridyn.materials.tangents` for the derivation); a material without one
(or ``Apply Automatic Differentiation Jacobian: false`` on Elastic) gets Peridigm's central
finite differences: for every point i, each degree of freedom q of S_i (neighbors first, i last)
is moved by -eps and +eps, only point i's force state is re-evaluated (``precompute`` and
``force_state`` on a one-point view) and the column is ((F+ - F-)/eps * 0.5) * V_s.

Kinematic boundary conditions (``apply_kinematic_bc``): D = -(sum_k |K_kk|)/N_dof from the
diagonal before any change; rows and columns of prescribed degrees of freedom are zeroed and
their diagonal set to D.

Under MPI (``sim.comm.size > 1``) the matrix is stored **by subdomain**: K = sum over ranks of
K_r, where K_r holds the contributions of the points rank r owns (their families S_i), with rows
and columns numbered over the rank's local points: its owned points first (by global id), then
its ghosts (in local order). Peridigm's family-by-family pattern couples the whole of S_i, so a
row of an owned point receives contributions of other ranks' points whose columns can lie two
horizons away, beyond the ghost layer; keeping each rank's own contributions instead needs no
second ghost layer and no exchange of matrix entries when the tangent is rebuilt. Products
refresh the ghost entries of x through the engine's halo (``halo.exchange``), multiply by K_r and
add the ghost rows of the result into their owners (``halo.reverse_sum``). After every assembly
the diagonal blocks are consolidated on the owners (the ghost rows' diagonal blocks are added
into them and zeroed), so the diagonal and the 3x3 diagonal blocks of owned rows are those of
the assembled matrix, and the operations on the diagonal (kinematic BCs with a D reduced over all
ranks, damping with a global max, adding a mass term) work on owned rows only. Vectors handed to
the solvers hold the owned rows only (row order); reductions over them go through ``sim.comm``.
The assembled owned-by-owned block (block-Jacobi / AMG-per-rank preconditioners) and the whole
matrix on rank 0 (the direct solver) are built on request (:meth:`TangentMatrix.owned_block`,
:meth:`TangentMatrix.gather_to_root`).
"""
from __future__ import annotations

import dataclasses
import logging
import time as _time

import numpy as np

from ...core.assembly import TangentTarget, local_scalar_state_force_kernel, local_vector_force_kernel, scatter_local_kernel
from .bsr import PointBlockMatrix

log = logging.getLogger("peridyn.solver")


# ------------------------------------------------------------------------------------------------
# kernels
# ------------------------------------------------------------------------------------------------
# ------------------------------------------------------------------------------------------------
class TangentMatrix(PointBlockMatrix):
    """K = d(f V)/dy of the owned points (serial: all points), 3x3-block sparse, rows in
    global-id order (see module docstring; under MPI the subdomain part K_r of this rank, with
    owned and ghost rows). The storage and operations are :class:`PointBlockMatrix`'s.

    ``kind``: "full" (Peridigm's pattern), or "block diagonal" (3x3 diagonal blocks only)."""

    def __init__(self, sim, kind: str = "full") -> None:
        self.kind = kind
        if kind == "block diagonal":
            pattern = "block diagonal"
        else:
            pattern = "pairs" if all(blk.material.tangent_coupling == "pairs" for blk in sim.blocks) else "family"
        super().__init__(sim, 3, pattern)
        n, nrows = self.n, self.nrows
        nl = sim.bonds
        self.in_offsets, self.in_bonds = nl.transpose()
        self.sources = nl.sources()
        counts = nl.counts()[:n]
        in_counts = np.diff(self.in_offsets)[:nrows] if nrows else np.zeros(0, np.int64)
        self.max_degree = int(counts.max()) if n else 0
        self.max_in = int(in_counts.max()) if in_counts.size else 0
        self.nchunks = max(1, min(nrows, 8 * _num_threads()))
        self._fd_scratch = None
        self._fd_scratch_vector = None
        self._allocated()

    # -- filling --------------------------------------------------------------------------------
    def target(self) -> TangentTarget:
        return TangentTarget(
            self.indptr, self.indices, self.data, self.row_of_local, self.local_of_row, self.eval_rank,
            self.in_offsets, self.in_bonds, self.sources, self.nrows, self.nchunks, self.max_degree, self.max_in,
        )

    def assemble(self, probe_length: float | None = None) -> None:
        """K at the current Coordinates (bond damage as it stands): zero, then every block's
        material adds its points' contributions (analytic tangent or finite differences).
        Under MPI the ghost positions are refreshed first and the diagonal blocks consolidated
        on their owners afterwards."""
        t0 = _time.perf_counter()
        sim = self.sim
        if self.parallel:
            sim.halo.exchange(sim.fields["Coordinates"])
            if "Temperature_Change" in sim.fields:
                sim.halo.exchange(sim.fields["Temperature_Change"])
        self.data[:] = 0.0
        for blk in sim.blocks:
            blk.material.precompute(blk.view)
        target = self.target()
        for blk in sim.blocks:
            target.probe_length = _probe_length(sim, blk, probe_length)
            if not blk.material.tangent(blk.view, target):
                self._finite_difference(blk, target.probe_length)
        if self.parallel:
            self.consolidate_diagonal()
        self.assembly_time += _time.perf_counter() - t0
        self.assemblies += 1

    def _finite_difference(self, blk, eps: float) -> None:
        """Peridigm's central-difference tangent of one block (Material::computeFiniteDifferenceJacobian).

        Runs on one thread: every kernel call covers a single point, where a parallel launch
        costs more than the work."""
        import numba

        before = numba.get_num_threads()
        numba.set_num_threads(1)
        try:
            self._finite_difference_points(blk, eps)
        finally:
            numba.set_num_threads(before)

    def _finite_difference_points(self, blk, eps: float) -> None:
        sim = self.sim
        mat = blk.material
        view = blk.view
        s = sim.fields
        nl = sim.bonds
        y = s["Coordinates"]
        volume = s["Volume"]
        vector = mat.force_state_kind == "vector"
        if vector:
            if self._fd_scratch_vector is None:
                self._fd_scratch_vector = np.zeros((nl.num_bonds, 3))
            t = self._fd_scratch_vector
        else:
            if self._fd_scratch is None:
                self._fd_scratch = np.zeros(nl.num_bonds)
            t = self._fd_scratch
        # rate-form materials: Peridigm's probe moves the velocity by eps/dt with the position
        v = s["Velocity"] if mat.tangent_perturbs_velocity else None
        dv = eps / view.time_step if v is not None and view.time_step > 0 else 0.0

        def local(out):
            if vector:
                local_vector_force_kernel(i, nl.offsets, nl.neighbors, volume, t, out)
            else:  # i's own force states only: t[o:e]
                local_scalar_state_force_kernel(i, nl.offsets, nl.neighbors, y, volume, t[o:e], out)
        pts = np.arange(blk.start, blk.stop)
        pts = pts[np.argsort(self.eval_rank[pts], kind="stable")]
        for i in pts:
            i = int(i)
            o, e = int(nl.offsets[i]), int(nl.offsets[i + 1])
            S = np.concatenate([nl.neighbors[o:e].astype(np.int64), [i]])
            ns = S.shape[0]
            vi = dataclasses.replace(view, start=i, stop=i + 1)
            Fp = np.empty(3 * ns)
            Fm = np.empty(3 * ns)
            Kloc = np.empty((3 * ns, 3 * ns))
            Vs = np.repeat(volume[S], 3)
            for a in range(ns):
                q = int(S[a])
                for c in range(3):
                    orig = y[q, c]
                    vorig = v[q, c] if v is not None else 0.0
                    y[q, c] = orig - eps
                    if v is not None:
                        v[q, c] = vorig - dv
                    mat.precompute(vi)
                    mat.force_state(vi, t)
                    local(Fm)
                    y[q, c] = orig + eps
                    if v is not None:
                        v[q, c] = vorig + dv
                    mat.precompute(vi)
                    mat.force_state(vi, t)
                    local(Fp)
                    y[q, c] = orig
                    if v is not None:
                        v[q, c] = vorig
                    Kloc[:, 3 * a + c] = (((Fp - Fm) / eps) * 0.5) * Vs
            mat.precompute(vi)  # leave point i's state as at the unperturbed configuration
            keep = S < self.nrows
            rows = self.row_of_local[S[keep]]
            if not keep.all():
                idx = np.flatnonzero(np.repeat(keep, 3))
                Kloc = Kloc[np.ix_(idx, idx)]
            scatter_local_kernel(rows, np.ascontiguousarray(Kloc), self.indptr, self.indices, self.data)


def _num_threads() -> int:
    import numba

    return int(numba.get_num_threads())


def _probe_length(sim, blk, probe_length: float | None) -> float:
    """Finite-difference probe: the material's ``Finite Difference Probe Length``, else the
    solver's, else 1e-6 * minElementRadius (Peridigm's default)."""
    own = blk.material.finite_difference_probe_length()
    if own is not None:
        return float(own)
    if probe_length is not None:
        return float(probe_length)
    return 1.0e-6 * float(sim.discretization.min_element_radius)
