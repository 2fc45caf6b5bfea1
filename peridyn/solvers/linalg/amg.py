"""Smoothed-aggregation algebraic multigrid preconditioner for the tangent systems.

pyamg builds the hierarchy once (strength of connection and aggregation on the 3 x 3 block graph,
the six rigid-body modes as near-null space, the tentative prolongator smoothed by one damped
Jacobi step, the Galerkin coarse operators). The cycle on the finest level is ours, on the
tangent's own compiled matrix-vector product, because a peridynamic tangent is dense within a
horizon (hundreds of entries per row: 800 on the tensile test) and every operation there costs a
full pass over the matrix:

    x  = w D^-1 r                          pre-smoothing from 0 (no product)
    x += P C (P^T (r - A x))               coarse correction (C: the coarse levels' V-cycle)
    x += w D^-1 (r - A x)                  post-smoothing

two products with A per application, the same damped Jacobi before and after, so the
preconditioner is symmetric when A is (conjugate gradients may use it). w = 4 / (3 rho(D^-1 A)),
rho from a few power iterations. Measured on the tensile test's tangent (37,875 unknowns, 30 M
nonzeros, relative tolerance 1e-4): 27 preconditioned iterations (81 products) against 811 for
plain conjugate gradients.

The hierarchy is kept while the matrix changes (Newton iterations, load steps): the coarse
levels stay a good approximation; :meth:`AMGPreconditioner.update` refreshes the finest level's
diagonal. The caller rebuilds when the iteration count grows.
"""
from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

log = logging.getLogger("peridyn.solver")

#: power iterations for the spectral radius of D^-1 A
POWER_ITERATIONS = 12
#: largest coarsest level (solved with a dense pseudo-inverse)
MAX_COARSE = 500


class AMGPreconditioner:
    """M^-1 r for the operator ``matvec`` (x, out) -> out = A x of size n.

    A: scipy sparse matrix (n x n; BSR with 3 x 3 blocks preferred) with the values of the
    operator, used for the set-up only and not kept; coords: (n/3, 3) point coordinates (dof
    order 3 p + c), the rigid-body modes' centre; symmetric: build for conjugate gradients."""

    def __init__(self, A, matvec: Callable[[np.ndarray, np.ndarray], np.ndarray], coords: np.ndarray | None, symmetric: bool = True) -> None:
        import pyamg

        self.n = int(A.shape[0])
        self.matvec = matvec
        B = rigid_body_modes(coords) if coords is not None and coords.shape[0] * 3 == self.n else None
        if self.n == 0:
            self.levels = 0
            return
        ml = pyamg.smoothed_aggregation_solver(
            A, B=B, symmetry="hermitian" if symmetric else "nonsymmetric", max_coarse=MAX_COARSE, keep=False,
            improve_candidates=None,  # the rigid-body modes are the exact near-null space: no smoothing sweeps
        )
        self.levels = len(ml.levels)
        if self.levels == 1:  # small enough to factor directly
            self._coarse = _dense_solver(ml.levels[0].A)
            self.P = None
            return
        lv = ml.levels[0]
        self.P = lv.P.tocsr()
        self.R = lv.R.tocsr() if hasattr(lv, "R") else self.P.T.tocsr()
        rest = ml.levels[1:]
        if len(rest) == 1:
            self._coarse = _dense_solver(rest[0].A)
        else:
            from pyamg.multilevel import MultilevelSolver

            sub = MultilevelSolver(rest, coarse_solver="pinv")
            sub.symmetric_smoothing = ml.symmetric_smoothing
            self._coarse = lambda b: sub.solve(b, maxiter=1, cycle="V", tol=1e-12)
        self._r = np.empty(self.n)
        self._Ax = np.empty(self.n)
        self.omega = None
        self.update(A.diagonal())

    def update(self, diagonal: np.ndarray) -> None:
        """Use the current operator (same hierarchy): its diagonal (n,). The damping w comes from
        the spectral radius of D^-1 A at the first call (a few products; it changes little
        while the hierarchy stays valid)."""
        if self.levels <= 1:
            return
        d = np.asarray(diagonal, dtype=float)
        safe = np.where(d != 0.0, d, 1.0)
        self.dinv = np.where(d != 0.0, 1.0 / safe, 0.0)
        if self.omega is not None:
            return
        v = np.random.default_rng(12345).standard_normal(self.n)
        rho = 1.0
        for _ in range(POWER_ITERATIONS):
            nv = float(np.linalg.norm(v))
            if not nv > 0.0:
                break
            v /= nv
            self.matvec(v, self._Ax)
            v = self.dinv * self._Ax
            rho = float(np.linalg.norm(v))
        self.omega = 4.0 / (3.0 * rho) if rho > 0.0 and np.isfinite(rho) else 1.0

    def __call__(self, r: np.ndarray) -> np.ndarray:
        if self.levels == 0:
            return r.copy()
        if self.levels == 1:
            return self._coarse(r)
        w = self.omega
        x = w * (self.dinv * r)
        self.matvec(x, self._Ax)
        np.subtract(r, self._Ax, out=self._r)
        x += self.P @ self._coarse(self.R @ self._r)
        self.matvec(x, self._Ax)
        np.subtract(r, self._Ax, out=self._r)
        x += w * (self.dinv * self._r)
        return x


def rigid_body_modes(x_rows: np.ndarray) -> np.ndarray:
    """(3n, 6) translations and infinitesimal rotations at the points x_rows (n, 3), dof
    order 3 g + c: the near-null space of an elasticity operator, for smoothed aggregation."""
    n = x_rows.shape[0]
    c = x_rows - x_rows.mean(axis=0) if n else x_rows
    B = np.zeros((n, 3, 6))
    for d in range(3):
        B[:, d, d] = 1.0
    # rotations about x, y, z: omega x r
    B[:, 1, 3], B[:, 2, 3] = -c[:, 2], c[:, 1]
    B[:, 0, 4], B[:, 2, 4] = c[:, 2], -c[:, 0]
    B[:, 0, 5], B[:, 1, 5] = -c[:, 1], c[:, 0]
    return B.reshape(3 * n, 6)


def _dense_solver(A) -> Callable[[np.ndarray], np.ndarray]:
    """x = A^+ b for a small matrix (the coarsest level; pseudo-inverse as pyamg's 'pinv')."""
    M = np.linalg.pinv(A.toarray() if hasattr(A, "toarray") else np.asarray(A))
    return lambda b: M @ b
