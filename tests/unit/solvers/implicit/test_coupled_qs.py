"""The coupled (displacement + fluid pressure) QuasiStatic solve: the 4x4-block tangent's
operations, the pressure boundary conditions, the Newton loop, deck errors and 2 MPI ranks."""
import netCDF4
import numpy as np
import pytest

from peridyn.engine.run_services import RunServices
from peridyn.core.errors import InputError
from peridyn.deck.files import dump_yaml
from peridyn.solvers.implicit.coupled import CoupledProblem
from peridyn.solvers.linalg.coupled_tangent import CoupledTangent
from peridyn.testing import build_simulation, cube_deck
from peridyn.testing.harness import node_set_ids
from peridyn.testing.mpi import mpirun, requires_mpi
from peridyn.engine.session import run_sections

FLUID = {
    "Permeability": 1.0e-12, "Fluid density": 1.0, "Fluid dynamic viscosity": 1.0, "Fluid compressibility": 1.0e-9,
    "Fluid Reynolds viscosity temperature effect": 0.0, "Fluid linear thermal expansion": 0.0,
    "Permeability curve inflection damage": 0.1, "Max permeability": 1.0, "Permeability alpha": 0.25,
}
MATERIAL = {"Material Model": "Multiphysics Elastic", "Density": 1.0, "Bulk Modulus": 50.0, "Shear Modulus": 30.0, **FLUID}
SOLVE_FOR = {"Solve For Displacement": True, "Solve For Pressure": True}


def bar_deck(n=8, p_left="2.0*t", p_right="0.0", steps=2, solver=None, initial=None, extra_bcs=None, section=None):
    """A bar of n x 2 x 2 points (spacing 1, horizon 1.75), x = 0 face clamped in x, the two
    end layers with prescribed pressures, Multiphysics: 1."""
    tree = cube_deck(MATERIAL, shape=(n, 2, 2), horizon_factor=1.75, extra={"Multiphysics": 1})
    left = node_set_ids(tree, lambda x: x[:, 0] < 1.0)
    right = node_set_ids(tree, lambda x: x[:, 0] > n - 1.0)
    every = node_set_ids(tree, lambda x: x[:, 0] > -1.0)
    bcs = {
        "Left Node Set": left, "Right Node Set": right, "All Node Set": every,
        "Clamp": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": "x", "Value": "0.0"},
        "PL": {"Type": "Prescribed Fluid Pressure U", "Node Set": "Left Node Set", "Value": p_left},
        "PR": {"Type": "Prescribed Fluid Pressure U", "Node Set": "Right Node Set", "Value": p_right},
    }
    for axis, name in ((1, "Y"), (2, "Z")):
        bcs[f"Fix {name}"] = {"Type": "Prescribed Displacement", "Node Set": "All Node Set", "Coordinate": name.lower(), "Value": "0.0"}
    if initial is not None:
        bcs["P0"] = {"Type": "Initial Fluid Pressure U", "Node Set": "All Node Set", "Value": initial}
    bcs.update(extra_bcs or {})
    tree["Boundary Conditions"] = bcs
    qs = {"Number of Load Steps": steps, "Absolute Tolerance": 1.0e-9, "Maximum Solver Iterations": 20, **(solver or {})}
    tree["Solver"] = {"Final Time": 1.0, **SOLVE_FOR, "QuasiStatic": qs, **(section or {})}
    return tree


def run(tree, tmp_path, outputs=("Displacement", "Fluid_Pressure_U", "Flux_Density")):
    tree = dict(tree, Output={"Output Filename": "run", "Output Frequency": 1, "Output Variables": {k: True for k in outputs}})
    sim = build_simulation(tree, directory=tmp_path, output_dir=tmp_path)
    run = RunServices.of(sim)
    try:
        run_sections(sim, run=run)
    finally:
        run.close()
    return sim


def frames(path, name):
    with netCDF4.Dataset(path) as d:
        names = ["".join(c.decode() for c in row if c).strip() for row in d.variables["name_nod_var"][:].data]
        x = np.asarray(d.variables["coordx"][:])
        return x, np.asarray(d.variables[f"vals_nod_var{names.index(name) + 1}"][:])


# -- the tangent --------------------------------------------------------------------------------------
def state(seed=1):
    sim = build_simulation(cube_deck(MATERIAL, shape=(4, 3, 2), horizon_factor=1.75, extra={"Multiphysics": 1}))
    rng = np.random.default_rng(seed)
    x = sim.fields["Model_Coordinates"]
    sim.fields["Coordinates"][:] = x + 0.01 * rng.standard_normal(x.shape)
    sim.fields["Fluid_Pressure_Y"][:] = rng.uniform(0.0, 1.0, x.shape[0])
    return sim


def test_matvec_is_the_block_matrix_product():
    sim = state()
    T = CoupledTangent(sim)
    T.assemble()
    x = np.random.default_rng(2).standard_normal(4 * sim.num_owned)
    np.testing.assert_allclose(T.matvec(x), T.to_scipy() @ x, rtol=1e-13, atol=1e-13 * np.abs(T.data).max())
    assert T.ndof == 4 * sim.num_global and T.shape == (4 * sim.num_owned,) * 2


def test_kinematic_rows_and_columns_over_four_dofs():
    """D = -(sum |K_kk|)/(4 N), prescribed rows and columns zero with D on the diagonal: the
    pressure dof (offset 3) is treated like a displacement dof."""
    sim = state()
    T = CoupledTangent(sim)
    T.assemble()
    A = T.to_scipy(copy=True).toarray()
    fixed = np.zeros((sim.num_owned, 4), dtype=bool)
    fixed[0, 3] = True
    fixed[2, 1] = True
    D = T.apply_kinematic_bc(fixed)
    total = 0.0
    for value in np.abs(np.diag(A)):  # in dof order, as the kernel sums (numpy's sum pairs them)
        total += float(value)
    assert D == (-1.0 * total) / A.shape[0]
    B = T.to_scipy().toarray()
    k = np.flatnonzero(fixed.reshape(-1))
    for dof in k:
        assert np.count_nonzero(B[dof]) == 1 and np.count_nonzero(B[:, dof]) == 1 and B[dof, dof] == D
    free = np.setdiff1d(np.arange(A.shape[0]), k)
    np.testing.assert_array_equal(B[np.ix_(free, free)], A[np.ix_(free, free)])


def test_residual_holds_flow_times_volume_and_zero_on_prescribed_pressure(tmp_path):
    sim = build_simulation(bar_deck(), directory=tmp_path)
    prob = CoupledProblem(sim)
    sim.fields["Fluid_Pressure_Y"][:] = sim.fields["Model_Coordinates"][:, 0] ** 2
    _, r = prob.qs_residual()
    R = prob.to_local(r)
    flow = sim.fields["Flux_Density"][: sim.num_owned] * sim.fields["Volume"][: sim.num_owned]
    free = ~prob.fixed_local[:, 3]
    np.testing.assert_array_equal(R[free, 3], flow[free])
    assert np.all(R[~free, 3] == 0.0) and (~free).sum() == 8
    assert np.abs(flow[free]).max() > 0  # a quadratic field has a nonzero nonlocal Laplacian


# -- the solve ----------------------------------------------------------------------------------------
def test_pressure_follows_its_boundary_conditions_and_converges(tmp_path):
    sim = run(bar_deck(steps=2), tmp_path)
    x, p = frames(tmp_path / "run.e", "Fluid_Pressure_U")
    assert p.shape[0] == 3
    np.testing.assert_allclose(p[1][x < 1.0], 1.0, rtol=1e-14)  # 2 t at t = 0.5
    np.testing.assert_allclose(p[2][x < 1.0], 2.0, rtol=1e-14)
    np.testing.assert_allclose(p[2][x > 7.0], 0.0, atol=1e-14)
    inner = (x > 1.0) & (x < 7.0)
    assert np.all((p[2][inner] > 0.0) & (p[2][inner] < 2.0))
    st = sim.stats["solvers"][-1]
    assert st["converged"] and all(a["outcome"] == "converged" for a in st["load_steps"])
    assert st["unknowns_per_point"] == 4


def test_constant_pressure_value_is_an_increment_of_zero(tmp_path):
    """Trap 7: 'Prescribed Fluid Pressure U' has no constant-value rule: a constant 3.0 on top of
    an initial pressure 5.0 leaves the pressure at 5.0 (a displacement BC would move it to 3)."""
    run(bar_deck(p_left="3.0", p_right="3.0", initial="5.0", steps=1), tmp_path)
    _, p = frames(tmp_path / "run.e", "Fluid_Pressure_U")
    np.testing.assert_allclose(p[0], 5.0)
    np.testing.assert_allclose(p[1], 5.0, rtol=1e-12)


def test_pressure_rate(tmp_path):
    """p_V = dp/dt: 2 on the ramped points, 0 on the constant ones, the converged increment
    over the step size at the free points."""
    sim = run(bar_deck(steps=2), tmp_path)
    n = sim.num_owned
    pV = sim.fields["Fluid_Pressure_V"][:n]
    x = sim.fields["Model_Coordinates"][:n, 0]
    np.testing.assert_allclose(pV[x < 1.0], 2.0, rtol=1e-12)
    np.testing.assert_array_equal(pV[x > 7.0], 0.0)
    free = (x > 1.0) & (x < 7.0)
    _, p = frames(tmp_path / "run.e", "Fluid_Pressure_U")
    order = np.argsort(sim.gid[:n])  # Exodus rows are in global-id order
    np.testing.assert_allclose(pV[order][free[order]], (p[2] - p[1])[free[order]] / 0.5, rtol=1e-10)


@pytest.mark.parametrize("section, match", [
    ({"Solve For Pressure": False}, "displacement and fluid pressure together"),
    ({"Initialize Predictor From Previous Solver": True}, "cannot be combined with Multiphysics"),
])
def test_deck_errors(tmp_path, section, match):
    tree = bar_deck(section=section)
    with pytest.raises(InputError, match=match):
        run(tree, tmp_path)


def test_pressure_unknown_needs_multiphysics(tmp_path):
    tree = cube_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 1.0}, n=3)
    tree["Solver"] = {"Final Time": 1.0, **SOLVE_FOR, "QuasiStatic": {"Number of Load Steps": 1}}
    with pytest.raises(InputError, match="only in a Multiphysics deck"):
        run(tree, tmp_path, outputs=("Displacement",))


def test_adaptive_and_direct_solvers_agree(tmp_path):
    """The default ('Adaptive': Peridigm's CG, GMRES once CG fails on the unsymmetric coupled
    matrix, as it does here) and the direct solver reach the same pressures."""
    out = {}
    for method in ("Adaptive", "Direct"):
        (tmp_path / method).mkdir()
        sim = run(bar_deck(solver={"Linear Solver": method}), tmp_path / method)
        assert sim.stats["solvers"][-1]["converged"]
        out[method] = frames(tmp_path / method / "run.e", "Fluid_Pressure_U")[1]
    np.testing.assert_allclose(out["Adaptive"], out["Direct"], atol=1e-9)


def test_peridigms_cg_alone_fails_like_peridigm(tmp_path):
    """'Linear Solver: Belos' keeps Peridigm's CG only: here it cannot solve the coupled system
    (also after damping), and the run stops at the last converged load step."""
    from peridyn.solvers.implicit.quasistatic import LoadStepError

    with pytest.raises(LoadStepError, match="linear solve of iteration 1 failed"):
        run(bar_deck(solver={"Linear Solver": "Belos"}), tmp_path)


@requires_mpi
def test_two_ranks_give_the_serial_answer(tmp_path):
    tree = bar_deck(n=10, steps=2)
    tree["Output"] = {"Output Filename": "run", "Output Frequency": 1,
                      "Output Variables": {"Displacement": True, "Fluid_Pressure_U": True, "Flux_Density": True}}
    results = {}
    for ranks in (1, 2):
        folder = tmp_path / f"np{ranks}"
        folder.mkdir()
        (folder / "d.yaml").write_text(dump_yaml(tree))
        proc = mpirun(ranks, ["run", "d.yaml", "-q"], cwd=folder)
        assert proc.returncode == 0, proc.stderr
        results[ranks] = frames(folder / "run.e", "Fluid_Pressure_U")[1], frames(folder / "run.e", "Flux_Density")[1]
    (p1, q1), (p2, q2) = results[1], results[2]
    np.testing.assert_allclose(p2, p1, atol=1e-10)
    np.testing.assert_allclose(q2, q1, atol=1e-9 * np.abs(q1).max())


def test_relative_tolerance_scales_with_the_four_dof_reactions(tmp_path):
    """Relative Tolerance: tol ||R||_2 with R = [f V, flow V] on the prescribed dofs of the
    first residual (clamp reactions and the flow at the prescribed pressures)."""
    tree = bar_deck(steps=1)
    qs = tree["Solver"]["QuasiStatic"]
    del qs["Absolute Tolerance"]
    qs["Relative Tolerance"] = 1.0e-8
    sim = run(tree, tmp_path)
    step = sim.stats["solvers"][-1]["load_steps"][0]
    assert step["outcome"] == "converged" and step["iterations"] >= 1
    assert 0.0 < step["tolerance"] < 1.0e-6
    assert CoupledProblem(sim).fixed_local[:, 3].sum() == 8  # 4 + 4 prescribed pressures
