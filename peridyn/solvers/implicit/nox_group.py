"""The NOX group that ``NOXQuasiStatic``'s trust region solver works on (``NOX::Epetra::Group``
as Peridigm sets it up): the residual, the tangent as the Jacobian and AztecOO's GMRES as the
Jacobian inverse, over the load step a :class:`peridyn.solvers.implicit.nox.NOXRun` is solving."""
from __future__ import annotations

import logging
from typing import Any, Protocol

import numpy as np

from ..linalg.aztecoo import aztecoo_gmres
from ...core.services import Communicator
from .nox_params import NOXQuasiStaticSection
from .problem import ImplicitProblem
from .trust_region import TransposeProduct

log = logging.getLogger("peridyn.solver")


class NOXRunView(Protocol):
    """What the group reads of the NOX run: its problem (tangent), residual and Jacobian update,
    linear solver keys and preconditioner, communicator, counters and reductions."""

    problem: ImplicitProblem
    p: NOXQuasiStaticSection  #: the section (``linear_params``: the AztecOO options)
    comm: Communicator | None  #: None serially
    section: str
    linear_iterations: int

    def F(self, s: np.ndarray) -> np.ndarray: ...
    def jacobian(self, s: np.ndarray, update_every: int = 1) -> None: ...
    def aztec_preconditioner(self) -> Any: ...
    def _dot(self, a: np.ndarray, b: np.ndarray) -> float: ...
    def _norm(self, a: np.ndarray) -> float: ...


class NOXGroup:
    """The NOX group the trust region solver works on: Peridigm's residual, its tangent (with
    the BC modification, not negated) as the Jacobian, AztecOO's GMRES as the Jacobian inverse."""

    def __init__(self, run: NOXRunView) -> None:
        self.run = run
        self.T = run.problem.tangent
        self._transpose = TransposeProduct(self.T)
        self._prec = None

    def F(self, s: np.ndarray) -> np.ndarray:
        return self.run.F(s)

    def jacobian(self, s: np.ndarray) -> None:
        self.run.jacobian(s)
        self._prec = None

    def apply_jacobian(self, d: np.ndarray) -> np.ndarray:
        return self.T.matvec(d)

    def apply_jacobian_transpose(self, d: np.ndarray) -> np.ndarray:
        return self._transpose(d)

    def solve(self, rhs: np.ndarray, tol: float, x0: np.ndarray | None) -> tuple[np.ndarray, bool]:
        run = self.run
        lin = run.p.linear_params
        precond = None
        if lin.preconditioner != "None":
            if self._prec is None:
                self._prec = run.aztec_preconditioner()
            precond = self._prec
        if lin.zero_initial_guess:
            x0 = None
        res = aztecoo_gmres(
            self.T.matvec, rhs, x0, tol, lin.kspace, lin.max_iterations, precond, classical=lin.orthogonalization == "Classical", comm=run.comm,
            ill_cond_thresh=lin.ill_conditioning_threshold,
        )
        run.linear_iterations += res.iterations
        if not res.converged:
            log.debug("%s: %s; using the direction anyway", run.section, res.message)
        return res.x, res.converged

    def dot(self, a: np.ndarray, b: np.ndarray) -> float:
        return float(self.run._dot(a, b))

    def norm(self, a: np.ndarray) -> float:
        return float(self.run._norm(a))
