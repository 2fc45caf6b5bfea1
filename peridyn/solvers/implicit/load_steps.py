"""What the QuasiStatic solves share (the displacement-only one in :mod:`.quasistatic`, the coupled
displacement-pressure one in :mod:`.coupled`): Peridigm's line-search candidates and Newton
heuristics constants, the load-step failure, adaptive load stepping's step and output-frequency
rules (PERIDIGM_MODELS.md §13)."""
from __future__ import annotations

import logging
import math
from collections.abc import Callable

import numpy as np

from ...core.errors import InstabilityError

log = logging.getLogger("peridyn.solver")

#: Peridigm's quasiStaticsLineSearch candidate lists
FIRST_CANDIDATES = (0.1, 0.2, 0.3, 0.5, 0.75, 1.0)
SECOND_CANDIDATES = tuple(
    [0.002 * (i + 1) for i in range(25)] + [0.01 * (i + 1) + 0.05 for i in range(15)] + [0.05 * (i + 1) + 0.2 for i in range(6)]
    + [0.75, 1.0, 1.5, 2.0, 5.0, 10.0]
)
PURE_NEWTON_STEPS = 50
#: most load steps 'Reduce all remaining load steps' may create (each halving doubles them)
MAX_LOAD_STEPS = 10_000_000
DAMPED_TANGENT_INTERVAL = 8


def line_search(trial: Callable[[np.ndarray], tuple[float, np.ndarray]], x0: np.ndarray, lhs: np.ndarray, lhs_rows: np.ndarray,
                rho0: float, r0: np.ndarray, dot: Callable[[np.ndarray, np.ndarray], float], section: str, *,
                first_pass_at_epsilon: bool = False) -> float:
    """Peridigm's quasiStaticsLineSearch: the step length alpha along ``lhs`` from the unknowns
    ``x0`` whose residual norm is ``rho0 > 0`` (residual ``r0``; ``lhs_rows`` the direction in
    the residual's rows, ``dot`` the reduction over them). ``trial(x)`` sets the unknowns to x
    and returns (residual norm, residual). A secant guess and the first candidates are tried;
    if they reduce the residual by less than 2 %, the second candidates; failing a reduction of
    0.01 %, the candidate raising it closest to 10 % (to leave a local minimum).
    ``first_pass_at_epsilon``: Peridigm's multiphysics branch evaluates every first-pass
    candidate at x0 + 1e-4 lhs instead of x0 + alpha lhs (kept for its results)."""
    best_alpha, best = 1.0, 1.0e50
    eps = 1.0e-4
    _, r_plus = trial(x0 + eps * lhs)
    S = dot(lhs_rows, r0)
    S_plus = dot(lhs_rows, r_plus)
    with np.errstate(divide="ignore", invalid="ignore"):
        guess = float(np.float64(-1.0 * eps * S) / np.float64(S_plus - S))
    candidates = ([guess] if -0.1 < guess < 10.0 else []) + list(FIRST_CANDIDATES)
    for alpha in candidates:
        rho, _ = trial(x0 + (eps if first_pass_at_epsilon else alpha) * lhs)
        if math.isfinite(rho) and rho < best:
            best_alpha, best = alpha, rho
    if (rho0 - best) / rho0 > 0.02:
        return best_alpha
    increases = []
    for alpha in SECOND_CANDIDATES:
        rho, _ = trial(x0 + alpha * lhs)
        if math.isfinite(rho):
            if rho < best:
                best_alpha, best = alpha, rho
            elif rho > rho0:
                increases.append((alpha, (rho - rho0) / rho0))
    if (rho0 - best) / rho0 > 0.0001:
        return best_alpha
    log.info("%s: line search cannot reduce the residual; trying to leave a local minimum by raising it about 10%%", section)
    closest = 1.0e50
    for alpha, inc in increases:
        if abs(inc - 0.1) < closest:
            best_alpha, closest = alpha, abs(inc - 0.1)
    return best_alpha


class LoadStepError(InstabilityError):
    """A QuasiStatic load step did not converge and could not be cut back: the run stops (exit
    status 3), the output of the converged load steps is kept."""


def halve_load_step(times: list[float], step: int, t_prev: float, dt: float) -> None:
    """Adaptive load stepping after a failed step: insert t_prev + dt/2.0 before target ``step``
    (the step is retried with the shorter increment from the same t_prev)."""
    times.insert(step, t_prev + dt / 2.0)


def reduce_remaining_load_steps(times: list[float], step: int, t_cur: float, dt: float, t_final: float) -> None:
    """``Reduce all remaining load steps``, after a step that needed halvings converged: the
    later times become t_cur + (i+1) dt, appended while the last one is below the original final
    time (so the last may pass it, as in Peridigm)."""
    del times[step + 1 :]
    if not (dt > 0.0 and (t_final - t_cur) / dt <= MAX_LOAD_STEPS):
        raise LoadStepError(f"'Reduce all remaining load steps' would need {(t_final - t_cur) / dt:.3g} load steps of {dt:.3g} "
                            f"from t = {t_cur:.6g} to {t_final:.6g} (at most {MAX_LOAD_STEPS:.0e}); allow fewer load step reductions")
    i = 0
    while times[step + i] < t_final:
        times.append(t_cur + (i + 1) * dt)
        i += 1


def multiply_output_frequency(writers, multiplier: float) -> None:
    """Peridigm's ``multiplyOutputFrequency``: ``frequency *= multiplier`` on an int, i.e. the
    product truncated toward zero, for every writer."""
    for w in writers:
        w.frequency = int(w.frequency * multiplier)


def change_output_frequency(writers, frequency: int) -> None:
    """Peridigm's ``changeOutputFrequency`` (Switch to Verlet's ``Output Frequency``)."""
    for w in writers:
        w.frequency = frequency


def fmod_zero(a: int, b: int) -> bool:
    """C's ``a % b == 0`` (the remainder takes the sign of a)."""
    return math.fmod(a, b) == 0.0
