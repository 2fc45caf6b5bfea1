import math

import pytest

from peridyn.verify.fit import fit_rate


def test_fit_rate_recovers_the_exponent():
    sizes = [0.4, 0.2, 0.1, 0.05]
    assert fit_rate(sizes, [3.0 * h**2 for h in sizes]) == pytest.approx(2.0)
    assert fit_rate(sizes, [h**0.5 for h in sizes]) == pytest.approx(0.5)


def test_fit_rate_least_squares_through_noise():
    sizes = [1.0, 0.5, 0.25]
    errors = [1.0, 0.26, 0.06]
    assert 1.9 < fit_rate(sizes, errors) < 2.2


def test_fit_rate_leaves_out_unusable_points_and_needs_two():
    assert fit_rate([1.0, 0.5, 0.25], [1.0, 0.0, 1.0 / 16]) == pytest.approx(2.0)
    assert math.isnan(fit_rate([1.0], [1.0]))
    assert math.isnan(fit_rate([1.0, 0.5], [float("nan"), 1.0]))
    assert math.isnan(fit_rate([1.0, 1.0], [1.0, 0.5]))
