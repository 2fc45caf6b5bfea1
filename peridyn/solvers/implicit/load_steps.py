"""What the QuasiStatic solves share (the displacement-only one in :mod:`.quasistatic`, the coupled
displacement-pressure one in :mod:`.coupled`): Peridigm's line-search candidates and Newton
heuristics constants, the load-step failure, adaptive load stepping's step and output-frequency
rules (PERIDIGM_MODELS.md §13)."""
from __future__ import annotations

import math

from ...core.errors import InstabilityError

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
