"""``manufactured-lps``: a cubic field and its body force (div b != 0) against the LPS solve."""
import numpy as np

from peridyn.verify.problems import manufactured
from peridyn.verify.problems.manufactured import ManufacturedLPS, body_force_terms


def test_the_body_force_is_linear_with_a_divergence_and_balances_the_local_operator():
    b = body_force_terms(1.515)
    assert all(sum(p) == 1 for comp in b for _, p in comp)  # linear in position
    div = sum(c for i, comp in enumerate(b) for c, p in comp if p[i] == 1)
    assert abs(div) > 0.1 * manufactured.K
    # b_x against the cubic-symmetry operator by finite differences of the field
    from peridyn.verify.problems.lattice import lattice_stiffness

    S = lattice_stiffness("Elastic", manufactured.K, manufactured.G, 1.515)
    c11, c12, c44 = S[0, 0], S[0, 1], S[3, 3]
    X0, e = np.array([[0.3, -0.2, 0.5]]), 1e-3

    def u(c, X):
        return manufactured._evaluate(manufactured.FIELD[c], X)

    def d2(c, i, j):
        ei, ej = np.eye(3)[i] * e, np.eye(3)[j] * e
        return float((u(c, X0 + ei + ej) - u(c, X0 + ei - ej) - u(c, X0 - ei + ej) + u(c, X0 - ei - ej))[0]) / (4 * e * e)

    fx = c11 * d2(0, 0, 0) + c44 * (d2(0, 1, 1) + d2(0, 2, 2)) + (c12 + c44) * (d2(1, 0, 1) + d2(2, 0, 2))
    assert np.isclose(manufactured._evaluate(b[0], X0)[0], -fx, rtol=1e-6)


def test_the_solve_returns_the_field_and_a_body_force_5_percent_off_fails():
    problem = ManufacturedLPS()
    for factor, passes in ((1.0, True), (0.95, False)):
        m = problem.measure("Elastic", 1.515, True, force_factor=factor)
        checks = problem.checks("Elastic", [{"resolution": 1.515, "error": m.error, "values": m.values}], True)
        assert len(checks) == 1 and checks[0].passed is passes, (factor, m.error)
