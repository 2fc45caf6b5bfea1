"""Pieces the implicit solvers share: load times, the quasi-static residual, reactions and the
conversions between point arrays and global-id-ordered vectors (PERIDIGM_SEMANTICS.md §11.1).

Vectors handed to linear algebra (residuals, Newton increments) are in **row order**: global id
major, component minor (dof 3 g + c), as in Peridigm, and their norms and dot products are
sequential sums in that order. Point arrays (Coordinates, Displacement, ...) stay in the
engine's local order. Global reductions go through ``sim.comm``.

Under MPI each rank's vectors hold its owned points' rows (in global-id order); norms and dot
products are the ranks' sequential sums reduced with ``allreduce_sum`` (the inf-norm with
``allreduce_max``), forces come from the engine's distributed evaluation, and the tangent is
stored by subdomain (:mod:`peridyn.solvers.linalg.tangent`). Every method that reduces is a collective
call: all ranks make the same calls in the same order, whatever they own (possibly nothing).
"""
from __future__ import annotations

import contextlib
import logging
import math

import numpy as np

from pydantic import Field

from ...core.state import SolverState
from ...core.errors import InputError
from ...core.params import ModelParams
from ...core.solver_section import SolverSection
from ..linalg.linear import norm_inf, seq_dot, seq_norm2
from ..linalg.tangent import TangentMatrix

log = logging.getLogger("peridyn.solver")


def parse_time_steps(text: str) -> list[float]:
    """Peridigm's ``Time Steps`` string: whitespace-separated doubles (reading stops at the first
    token that is not a number, as istream_iterator does)."""
    out = []
    for tok in str(text).split():
        try:
            out.append(float(tok))
        except ValueError:
            break
    return out


class LoadTimes(ModelParams):
    """The keys of an implicit sublist that give its load steps (:func:`load_times`)."""

    number_of_load_steps: int | None = Field(None, alias="Number of Load Steps", ge=1, description="load steps from Initial Time to Final Time (needs Final Time)")
    time_steps: str | None = Field(None, alias="Time Steps", description="times of the load steps, initial time first, e.g. \"0.0 0.5 1.0\"")


def load_times(section: SolverSection, sublist: LoadTimes, *, path: tuple[str, ...], file) -> list[float]:
    """t_0 .. t_N of a load-stepping solver: t_k = t0 + (k (tf - t0))/N from ``Number of Load
    Steps`` when the section gives ``Final Time``, else the ``Time Steps`` list."""
    n = sublist.number_of_load_steps
    if section.given("final_time") and n is not None:
        t0, tf = section.initial_time, section.final_time
        return [t0] + [t0 + ((k + 1) * (tf - t0)) / n for k in range(n)]
    if sublist.time_steps is not None:
        return parse_time_steps(sublist.time_steps)
    raise InputError(
        "no load steps given",
        file=file,
        path=path,
        fix="give 'Final Time' in the solver section and 'Number of Load Steps', or 'Time Steps' (a list of times)",
    )


def planned_load_steps(section: SolverSection, sublist: LoadTimes) -> int | None:
    """The number of load steps :func:`load_times` will give, without building the list."""
    n = sublist.number_of_load_steps
    if section.given("final_time") and n is not None:
        return int(n)
    if sublist.time_steps is not None:
        return max(len(str(sublist.time_steps).split()) - 1, 0)
    return None


def check_time_steps(text: str) -> str:
    """Validator of ``Time Steps``: at least one number, strictly increasing."""
    values = parse_time_steps(text)
    if not values:
        raise ValueError("'Time Steps' must list the times of the load steps, the initial time first (e.g. \"0.0 0.5 1.0\")")
    if len(values) != len(str(text).split()):
        raise ValueError(f"'Time Steps' holds something that is not a number: {text!r}")
    if any(b <= a for a, b in zip(values, values[1:])):
        raise ValueError(f"'Time Steps' must increase strictly (got {text!r})")
    return text


class ImplicitProblem:
    """The equilibrium problem of a model: residual r = (f + b) V (force units, zero on
    prescribed dofs), its norms, the reactions and the tangent, all in row order."""

    def __init__(self, sim, state: SolverState | None = None, tangent_kind: str = "full", *, section: str = "Solver") -> None:
        self.sim = sim
        #: the solver state of the section (its shared tangents, iteration count); None: a fresh one
        self.state = state = state if state is not None else SolverState()
        self.comm = sim.comm if sim.comm.size > 1 else None  # None: the serial arithmetic
        n = sim.num_owned
        self.n = n
        cache = state.solver_cache.setdefault("implicit tangents", {})
        if tangent_kind not in cache:
            cache[tangent_kind] = TangentMatrix(sim, tangent_kind)
        self.tangent: TangentMatrix = cache[tangent_kind]
        T = self.tangent
        self.fixed_local = np.ascontiguousarray(sim.prescribed_dofs[:n])
        self.fixed_rows = np.ascontiguousarray(self.fixed_local[T.owned_local])
        self.fixed_flat = self.fixed_rows.reshape(-1)
        f = sim.fields
        self.volume = f["Volume"][:n]
        self.has_body_force = "External_Force_Density" in f
        self.evaluations = 0

    # -- vectors --------------------------------------------------------------------------------
    def to_rows(self, a: np.ndarray) -> np.ndarray:
        return self.tangent.to_rows(a)

    def to_local(self, v: np.ndarray, out=None) -> np.ndarray:
        return self.tangent.to_local(v, out)

    def pad(self, a: np.ndarray) -> np.ndarray:
        """An owned-points array (n, 3) as a local one (num_local, 3), zero on ghosts (itself
        when there are none)."""
        nl = self.sim.num_local
        if a.shape[0] == nl:
            return a
        out = np.zeros((nl,) + a.shape[1:])
        out[: a.shape[0]] = a
        return out

    def norm2(self, v: np.ndarray) -> float:
        if self.comm is not None:
            return math.sqrt(self.comm.allreduce_sum(seq_dot(v, v)))
        return seq_norm2(v)

    def norm_inf(self, v: np.ndarray) -> float:
        return self.sim.comm.allreduce_max(norm_inf(v))

    def dot(self, a: np.ndarray, b: np.ndarray) -> float:
        return self.sim.comm.allreduce_sum(seq_dot(a, b))

    # -- residual -------------------------------------------------------------------------------
    def force_vector(self) -> np.ndarray:
        """Evaluate forces (damage, precompute, force) at the current Coordinates and return
        (f + b) V as a row-order vector with prescribed dofs zeroed."""
        sim = self.sim
        n = self.n
        fd = sim.evaluate_forces()[:n]
        self.evaluations += 1
        F = fd + sim.fields["External_Force_Density"][:n] if self.has_body_force else fd.copy()
        F *= self.volume[:, None]
        F[self.fixed_local] = 0.0
        return self.to_rows(F)

    def qs_residual(self) -> tuple[float, np.ndarray]:
        """Peridigm's computeQuasiStaticResidual: (||r||_2 + 20 ||r||_inf, r)."""
        r = self.force_vector()
        return self.norm2(r) + 20.0 * self.norm_inf(r), r

    def reaction_norm(self) -> float:
        """||R||_2 with R = f V on the prescribed dofs (f the internal force density of the last
        evaluation), 0 elsewhere: the scale of a relative tolerance."""
        n = self.n
        f = self.sim.fields["Force_Density"][:n]
        R = np.where(self.fixed_local, f * self.volume[:, None], 0.0)
        return self.norm2(self.to_rows(R))

    def assemble_tangent(self, probe_length: float | None = None) -> TangentMatrix:
        self.tangent.assemble(probe_length)
        return self.tangent


#: below this many bonds, implicit solvers run their kernels on one thread: each parallel kernel
#: launch costs tens of microseconds (milliseconds on a loaded machine), more than the work of a
#: small model, and Newton-Krylov solvers launch tens of thousands of them. Kernels give the same
#: results on any number of threads.
SMALL_MODEL_BONDS = 200_000


@contextlib.contextmanager
def threads_for(sim):
    """Run a solver on one thread for small models (see SMALL_MODEL_BONDS), restoring the
    thread count afterwards."""
    import numba

    before = numba.get_num_threads()
    small = sim.comm.allreduce_sum(sim.bonds.num_bonds) < SMALL_MODEL_BONDS
    if small and before > 1:
        numba.set_num_threads(1)
    try:
        yield
    finally:
        if small and before > 1:
            numba.set_num_threads(before)


def solver_stats(sim, section: str, method: str, steps: int, wall: float, problem: ImplicitProblem, **extra) -> dict:
    """The entry a solver appends to ``sim.stats["solvers"]``."""
    T = problem.tangent
    st = {
        "section": section,
        "method": method,
        "steps": steps,
        "wall": wall,
        "bond_evaluations": problem.evaluations * sim.bonds.num_bonds,
        "point_steps": steps * sim.num_global,
        "force_evaluations": problem.evaluations,
        "tangent_nonzeros": T.nnz,
        "tangent_bytes": T.nbytes() if T.nnz else 0,
        "tangent_assemblies": T.assemblies,
        "tangent_assembly_time": T.assembly_time,
        "tangent_allocation_time": T.allocation_time,
        "nonlinear_iterations": problem.state.nonlinear_iterations,
    }
    st.update(extra)
    sim.stats.setdefault("solvers", []).append(st)
    return st
