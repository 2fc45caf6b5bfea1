"""Every iterative loop of the solvers has a cap (issue #19): a NaN trust-region radius and a
load step cut back to nothing end the run instead of looping (for ever, or for 2^k steps)."""
import math
import signal

import numpy as np
import pytest

from peridyn.solvers.implicit.load_steps import MAX_LOAD_STEPS, LoadStepError, reduce_remaining_load_steps
from peridyn.solvers.implicit.trust_region import MAX_INNER_ITERATIONS, ForcingTermOptions, TrustRegionOptions, TrustRegionSolver


A = np.array([[1.0, 0.3, -0.1], [0.2, 1.0, 0.1], [-0.1, 0.25, 1.0]])  # J: the Cauchy step is no solution


class NaNNewton:
    """F(x) = c, a constant (finite everywhere: no step ever improves it), and the linear solver
    returns a NaN Newton step: the inexact method's recovery then sets the radius to
    ||newton|| = NaN, which neither meets the minimum radius nor lets a step be accepted."""

    def __init__(self):
        self.evaluations = 0

    def F(self, s):
        self.evaluations += 1
        return np.array([1.0, -2.0, 0.5])

    def jacobian(self, s):
        pass

    def apply_jacobian(self, d):
        return A @ d

    def apply_jacobian_transpose(self, d):
        return A.T @ d

    def solve(self, rhs, tol, x0):
        return np.full_like(rhs, np.nan), True

    def dot(self, a, b):
        return float(np.dot(a, b))

    def norm(self, a):
        return float(np.linalg.norm(a))


def _alarm(signum, frame):
    raise TimeoutError("the loop did not stop")


@pytest.mark.parametrize("method", ["Inexact Trust Region", "Standard Trust Region"])
def test_a_nan_newton_step_does_not_trap_the_trust_region(method):
    def status(F, niter):
        if not math.isfinite(float(np.linalg.norm(F))):
            return "failed"
        return "converged" if np.linalg.norm(F) < 1e-12 else ("failed" if niter >= 3 else "unconverged")

    prob = NaNNewton()
    solver = TrustRegionSolver(prob, np.array([1.0, -2.0, 0.5]), TrustRegionOptions(inner_iteration_method=method), ForcingTermOptions(), status)
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(120)
    try:
        result = "unconverged"
        for _ in range(10):
            result = solver.step()
            if result != "unconverged":
                break
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    assert result == "failed"
    assert prob.evaluations <= 4 * (MAX_INNER_ITERATIONS + 2)


def test_reducing_all_remaining_load_steps_to_nothing_stops_the_run():
    times = [0.0, 0.5, 1.0]
    with pytest.raises(LoadStepError, match="Reduce all remaining load steps"):
        reduce_remaining_load_steps(times, 1, 0.25, 1.0 / 2.0**60, 1.0)


def test_reducing_all_remaining_load_steps_is_unchanged_within_the_cap():
    times = [0.0, 0.5, 1.0]
    reduce_remaining_load_steps(times, 1, 0.25, 0.25, 1.0)
    assert times == [0.0, 0.5, 0.5, 0.75, 1.0]
    assert 1e6 < MAX_LOAD_STEPS
