"""Stress laws for ``Stress Law Correspondence`` (:mod:`.user_law`), written as a plugin author
writes one: a numba function (F_old, F_new, state, dt, params) -> (Cauchy stress (3, 3), state (9,))."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def neo_hookean(F_old, F_new, state, dt, params):
    """Compressible Neo-Hookean (Bonet & Wood, Nonlinear Continuum Mechanics, eq. 5.29):
    sigma = (mu / J)(B - I) + (lambda / J) ln(J) I, B = F F^T, J = det F; params = (mu, lambda)
    (stress units); no state. Its small-strain limit is Hooke's law with the same mu and lambda."""
    mu, lam = params[0], params[1]
    J = np.linalg.det(F_new)
    B = F_new @ F_new.T
    sigma = (mu / J) * (B - np.eye(3)) + (lam / J) * np.log(J) * np.eye(3)
    return sigma, state.copy()
