"""Multiphysics Elastic through the coupled QuasiStatic solve, against closed forms of its own
laws (PERIDIGM_MODELS.md §7):

* (the solid held in place, so that the bonds keep their reference lengths) the flow law q = ((rho_f/mu)(4/(pi delta^2))) (k_e/|eta|^4)(p_j - p_i), k_e = (1-s) k_bar
  |eta|^2 + s k_max, s = 1/(1 + exp(a_p (d - d_c))), k_bar = k - 0.75 k: on a chain of points
  (nearest-neighbour bonds only) with fixed pressures at both ends, the steady pressure is
  linear and the end points' flux densities are -/+ 2 q V (Peridigm adds q V_j at i and
  subtracts q V_i at j, so a pair's two bonds count twice);
* steady pressure through a 3D bar whose end layers (one horizon deep) hold a linear field: every
  free point's family is symmetric in x, so the linear field is the exact steady state;
* the coupling term on two points at rest: t = -(3 omega/m) p_i zeta pushes the points apart
  with f_i = -(t_ij + t_ji) = (3/m)(p_i + p_j) zeta V along -x at the left point.
"""
import math

import netCDF4
import numpy as np

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.deck.files import dump_yaml
from peridyn.testing import build_simulation, cube_deck
from peridyn.testing.harness import node_set_ids

RHO_F, MU_F, K_PERM, K_MAX, A_P, D_C = 1.3, 0.7, 0.5, 1.0, 0.25, 0.1
FLUID = {
    "Permeability": K_PERM, "Fluid density": RHO_F, "Fluid dynamic viscosity": MU_F, "Fluid compressibility": 1.0,
    "Fluid Reynolds viscosity temperature effect": 0.0, "Fluid linear thermal expansion": 0.0,
    "Permeability curve inflection damage": D_C, "Max permeability": K_MAX, "Permeability alpha": A_P,
}
STIFF = {"Material Model": "Multiphysics Elastic", "Density": 1.0, "Bulk Modulus": 1.0e12, "Shear Modulus": 1.0e12, **FLUID}


def bond_flow_coefficient(length: float, delta: float) -> float:
    """q / (p_j - p_i) of an undamaged bond of deformed length ``length`` (closed form)."""
    s = 1.0 / (1.0 + math.exp(A_P * (0.0 - D_C)))
    k_e = (1.0 - s) * (K_PERM - 0.75 * K_PERM) * length**2 + s * K_MAX
    return (RHO_F / MU_F) * (4.0 / (math.pi * delta**2)) * k_e / length**4


def run(tmp_path, tree, outputs=("Fluid_Pressure_U", "Flux_Density", "Displacement")):
    tree = dict(tree, Output={"Output Filename": "run", "Output Frequency": 1, "Output Variables": {k: True for k in outputs}})
    (tmp_path / "d.yaml").write_text(dump_yaml(tree))
    assert main(["run", str(tmp_path / "d.yaml"), "--output-dir", str(tmp_path), "-q", "--no-progress"]) == ExitCode.OK
    with netCDF4.Dataset(tmp_path / "run.e") as d:
        names = ["".join(c.decode() for c in row if c).strip() for row in d.variables["name_nod_var"][:].data]
        x = np.stack([np.asarray(d.variables[c][:]) for c in ("coordx", "coordy", "coordz")], axis=1)
        return x, {n: np.asarray(d.variables[f"vals_nod_var{k + 1}"][-1]) for k, n in enumerate(names)}


def solver(tol=1e-10):
    return {"Final Time": 1.0, "Solve For Displacement": True, "Solve For Pressure": True,
            "QuasiStatic": {"Number of Load Steps": 1, "Absolute Tolerance": tol, "Maximum Solver Iterations": 30, "Linear Solver": "Direct"}}


def test_chain_steady_profile_and_end_fluxes(tmp_path):
    n, h = 9, 0.5
    delta = 1.5 * h  # nearest neighbours only
    tree = cube_deck(STIFF, shape=(n, 1, 1), spacing=h, horizon_factor=1.5, extra={"Multiphysics": 1})
    left = node_set_ids(tree, lambda x: x[:, 0] < h)
    right = node_set_ids(tree, lambda x: x[:, 0] > (n - 1) * h)
    every = node_set_ids(tree, lambda x: x[:, 0] > -1.0)
    tree["Boundary Conditions"] = {
        "Left Node Set": left, "Right Node Set": right, "All Node Set": every,
        "X": {"Type": "Prescribed Displacement", "Node Set": "All Node Set", "Coordinate": "x", "Value": "0.0"},
        "Y": {"Type": "Prescribed Displacement", "Node Set": "All Node Set", "Coordinate": "y", "Value": "0.0"},
        "Z": {"Type": "Prescribed Displacement", "Node Set": "All Node Set", "Coordinate": "z", "Value": "0.0"},
        "PL": {"Type": "Prescribed Fluid Pressure U", "Node Set": "Left Node Set", "Value": "2.0*t"},
        "PR": {"Type": "Prescribed Fluid Pressure U", "Node Set": "Right Node Set", "Value": "0.0"},
    }
    tree["Solver"] = solver()
    x, out = run(tmp_path, tree)
    p, Q = out["Fluid_Pressure_U"], out["Flux_Density"]
    k = np.round(x[:, 0] / h - 0.5).astype(int)
    np.testing.assert_allclose(p, 2.0 * (1.0 - k / (n - 1)), atol=1e-9)  # linear
    V = h**3
    q = bond_flow_coefficient(h, delta) * (2.0 / (n - 1))  # |p_j - p_i| between neighbours
    np.testing.assert_allclose(Q[k == 0], -2.0 * q * V, rtol=1e-6)  # the high-pressure end loses fluid
    np.testing.assert_allclose(Q[k == n - 1], 2.0 * q * V, rtol=1e-6)
    np.testing.assert_allclose(Q[(k > 0) & (k < n - 1)], 0.0, atol=1e-8 * q * V)


def test_bar_with_linear_end_layers_is_linear_everywhere(tmp_path):
    n = 12
    tree = cube_deck(STIFF, shape=(n, 2, 2), spacing=1.0, horizon_factor=1.75, extra={"Multiphysics": 1})
    ends = node_set_ids(tree, lambda x: (x[:, 0] < 2.0) | (x[:, 0] > n - 2.0))
    left = node_set_ids(tree, lambda x: x[:, 0] < 1.0)
    every = node_set_ids(tree, lambda x: x[:, 0] > -1.0)
    tree["Boundary Conditions"] = {
        "Ends Node Set": ends, "Left Node Set": left, "All Node Set": every,
        "X": {"Type": "Prescribed Displacement", "Node Set": "All Node Set", "Coordinate": "x", "Value": "0.0"},
        "Y": {"Type": "Prescribed Displacement", "Node Set": "All Node Set", "Coordinate": "y", "Value": "0.0"},
        "Z": {"Type": "Prescribed Displacement", "Node Set": "All Node Set", "Coordinate": "z", "Value": "0.0"},
        "P": {"Type": "Prescribed Fluid Pressure U", "Node Set": "Ends Node Set", "Value": "t*(3.0 - 0.25*x)"},
    }
    tree["Solver"] = solver()
    x, out = run(tmp_path, tree)
    p = out["Fluid_Pressure_U"]
    np.testing.assert_allclose(p, 3.0 - 0.25 * x[:, 0], atol=1e-9)
    free = (x[:, 0] > 2.0) & (x[:, 0] < n - 2.0)
    assert free.sum() == 4 * (n - 4)
    np.testing.assert_allclose(out["Flux_Density"][free], 0.0, atol=1e-8)


def test_two_point_coupling_force_and_flow():
    """Two points 1 apart at rest, V = 1, omega = 1 (m = 1): t_ij = -3 p_i, t_ji = -3 p_j."""
    tree = cube_deck({**STIFF, "Bulk Modulus": 1.0, "Shear Modulus": 1.0}, shape=(2, 1, 1), spacing=1.0, horizon_factor=1.5, extra={"Multiphysics": 1})
    sim = build_simulation(tree)
    x = sim.fields["Model_Coordinates"]
    left = int(np.argmin(x[:, 0]))
    right = 1 - left
    np.testing.assert_allclose(sim.fields["Weighted_Volume"][:2], 1.0)
    p = np.zeros(2)
    p[left], p[right] = 5.0, 2.0
    sim.fields["Fluid_Pressure_Y"][:2] = p
    f = sim.evaluate_forces()
    expected = 3.0 * (5.0 + 2.0)  # (3/m)(p_i + p_j) zeta V
    np.testing.assert_allclose(f[left], [-expected, 0.0, 0.0], rtol=1e-14)  # pushed apart
    np.testing.assert_allclose(f[right], [expected, 0.0, 0.0], rtol=1e-14)
    from peridyn.solvers.implicit.coupled import CoupledProblem

    flow = CoupledProblem(sim).flow()
    q = bond_flow_coefficient(1.0, 1.5) * (2.0 - 5.0)
    np.testing.assert_allclose(flow[left], 2.0 * q, rtol=1e-14)  # fluid leaves the high pressure point
    np.testing.assert_allclose(flow[right], -2.0 * q, rtol=1e-14)
