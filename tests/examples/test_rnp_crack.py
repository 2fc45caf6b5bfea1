"""examples/rnp_crack.yaml as shipped (it is small): the crack in the regularized nonlinear bond
model starts at the notch tip, runs along y = 0 across the ligament, and the bonds it cuts hold
G_c x the crack area.

The cut's energy is computed here from the deformed positions in the output, independently of
the material's code: every pair of points within the horizon on opposite sides of y = 0 whose
segment crosses the ligament (x > 5 mm, beyond the notch) holds 2 J C (1 - exp(-beta r s^2)) /
(pi h delta^3) V_i V_j, with the constants of the deck's E, nu = 1/3 (plane stress) and G_c:
K = E / (2 (1 - nu)), C = pi G_c / 4, beta = 4 K / (pi G_c), J = 12 (1 - r / delta).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from peridyn.io.exodus_reader import read_results

from tests.examples.test_examples import header, run_example

E, NU, GC = 72.0e9, 1.0 / 3.0, 10.0  # the deck's Young's modulus (Pa), Poisson's ratio, Gc (J/m^2)
H, DELTA, NOTCH, WIDTH = 5.0e-4, 0.0015075, 0.005, 0.020  # thickness, horizon, notch length, plate width (m)


def cut_energy(x: np.ndarray, u: np.ndarray, V: np.ndarray) -> float:
    """Energy (J) held by the bonds crossing y = 0 beyond the notch."""
    K = E / (2.0 * (1.0 - NU))
    C, beta = math.pi * GC / 4.0, 4.0 * K / (math.pi * GC)
    i, j = cKDTree(x[:, :2]).query_pairs(DELTA, output_type="ndarray").T
    cross = x[i, 1] * x[j, 1] < 0.0
    i, j = i[cross], j[cross]
    where = x[i, 0] + (x[j, 0] - x[i, 0]) * (-x[i, 1] / (x[j, 1] - x[i, 1]))
    i, j = i[where > NOTCH], j[where > NOTCH]
    xi = x[j, :2] - x[i, :2]
    r = np.linalg.norm(xi, axis=1)
    s = (np.linalg.norm(xi + u[j] - u[i], axis=1) - r) / r
    J = 12.0 * (1.0 - r / DELTA)
    return float(np.sum(2.0 * J * C * -np.expm1(-beta * r * s * s) / (math.pi * H * DELTA**3) * V[i] * V[j]))


def test_crack_runs_from_the_notch_and_costs_gc(tmp_path: Path):
    assert "0.90 G_c" in header("rnp_crack")
    out = run_example("rnp_crack", tmp_path)
    r = read_results(out / "rnp_crack.e")
    x, t = r["coords"], r["times"]
    soft = r["element"]["Softened_Bond_Fraction"]
    cracked = soft > 0.2
    first = next(k for k in range(len(t)) if cracked[k].any())
    assert 5e-6 < t[first] < 20e-6
    tip = x[cracked[first]]
    assert np.all(np.hypot(tip[:, 0] - NOTCH, tip[:, 1]) < 2.0 * DELTA), "the crack starts at the notch tip"
    end = x[cracked[-1]]
    assert end[:, 0].max() > WIDTH - 1e-3 and end[:, 0].min() < NOTCH + 1e-3, "it runs across the ligament"
    assert np.abs(end[:, 1]).max() < DELTA, "along y = 0"
    u = np.stack([r["nodal"][f"Displacement{c}"][-1] for c in "XY"], axis=1)
    V = r["element"]["Volume"][0]
    ratio = cut_energy(x, u, V) / (GC * (WIDTH - NOTCH) * H)
    # the lattice quadrature of the cut (-7.7 % at 3 points per horizon, tests/verification/
    # test_nlmech_fracture.py), the bonds at the plate's edge and the few not fully separated:
    # 0.90 measured, 0.80..1.0 allowed
    assert 0.80 < ratio < 1.0, ratio
