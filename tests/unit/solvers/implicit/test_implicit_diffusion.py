"""The ImplicitDiffusion solver: its section, Peridigm's start sequence (initial conditions
re-applied after the t0 boundary conditions), steady state at every load step, reactions,
the linear solvers, failure handling and 2 MPI ranks."""
import netCDF4
import numpy as np
import pytest

from peridyn.engine.run_services import RunServices
from peridyn.cli import main
from peridyn.core.errors import ExitCode, InputError
from peridyn.deck.files import dump_yaml
from peridyn.solvers.implicit.diffusion import DiffusionStepError
from peridyn.testing import build_simulation, cube_deck
from peridyn.testing.harness import node_set_ids
from peridyn.testing.mpi import mpirun, requires_mpi
from peridyn.engine.session import run_sections

SOLVE_FOR = {"Solve For Displacement": False, "Solve For Temperature": True}


def bar_deck(n=16, layers=3, value="100.0 + 20.0*x*t", initial=None, steps=2, **options):
    """A bar of n x 2 x 2 points (spacing 1, horizon 3.015) whose first and last ``layers``
    layers are prescribed to ``value``; optional Initial Temperature on every point."""
    tree = cube_deck({"Material Model": "Diffusion", "Coefficient": 1.5}, shape=(n, 2, 2))
    ends = node_set_ids(tree, lambda x: (x[:, 0] < layers) | (x[:, 0] > n - layers))
    every = node_set_ids(tree, lambda x: x[:, 0] > -1.0)
    bcs = {"Ends Node Set": ends, "All Node Set": every, "T": {"Type": "Prescribed Temperature", "Node Set": "Ends Node Set", "Value": value}}
    if initial is not None:
        bcs["T0"] = {"Type": "Initial Temperature", "Node Set": "All Node Set", "Value": initial}
    tree["Boundary Conditions"] = bcs
    tree["Solver"] = {"Final Time": 1.0, **SOLVE_FOR, "ImplicitDiffusion": {"Number of Load Steps": steps, "Relative Tolerance": 1e-10, **options}}
    return tree


def run_deck(tree, tmp_path, outputs=("Temperature", "Flux_Divergence")):
    tree = dict(tree, Output={"Output Filename": "run", "Output Frequency": 1, "Output Variables": {k: True for k in outputs}})
    sim = build_simulation(tree, directory=tmp_path, output_dir=tmp_path)
    run = RunServices.of(sim)
    try:
        run_sections(sim, run=run)
    finally:
        run.close()
    return sim


def frames(path, name):
    with netCDF4.Dataset(path) as ds:
        names = ["".join(c.decode() for c in row if c) for row in ds["name_nod_var"][:].data]
        x = np.stack([ds[f"coord{c}"][:].data for c in "xyz"], axis=1)
        return ds["time_whole"][:].data, x, ds[f"vals_nod_var{names.index(name) + 1}"][:].data


# -- the section -----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "change, message",
    [
        ({"Solve For Temperature": False}, "Solve For Temperature"),
        ({"Solve For Displacement": True}, "Solve For Displacement"),
        ({"Solve For Pressure": True}, "Solve For Pressure"),
        ({"ImplicitDiffusion": {"Relative Tolerance": 1e-9}}, "no load steps"),
        ({"ImplicitDiffusion": {"Number of Load Steps": 1, "Linear Solver": "LU"}}, "Linear Solver"),
    ],
)
def test_section_errors(change, message):
    tree = bar_deck(n=8)
    tree["Solver"].update(change)
    with pytest.raises(InputError, match=message):
        build_simulation(tree)


def test_other_materials_are_refused(tmp_path):
    tree = bar_deck(n=8)
    tree["Materials"]["M"] = {"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 1.0}
    with pytest.raises(InputError, match="diffusion material"):
        run_deck(tree, tmp_path, outputs=("Temperature",))


# -- Peridigm's sequence -------------------------------------------------------------------------------
def test_initial_conditions_overwrite_the_t0_boundary_values(tmp_path):
    """At t0 the prescribed value (here 50 + x at t = 0) is set first, then the initial
    condition (7) overwrites it everywhere; the t0 frame holds 7 and no flux (no evaluation)."""
    run_deck(bar_deck(n=10, value="50.0 + x + 10.0*t", initial=7.0), tmp_path)
    t, x, T = frames(tmp_path / "run.e", "Temperature")
    _, _, Q = frames(tmp_path / "run.e", "Flux_Divergence")
    np.testing.assert_allclose(t, [0.0, 0.5, 1.0])
    assert np.all(T[0] == 7.0) and np.all(Q[0] == 0.0)
    ends = (x[:, 0] < 3) | (x[:, 0] > 7)
    np.testing.assert_allclose(T[2][ends], 60.0 + x[ends, 0], rtol=1e-15)


def test_every_load_step_is_a_steady_state_with_reactions(tmp_path):
    """Volume-constrained ends with a linear prescribed field: the steady state is that linear
    field at every load step (not a transient), the free points carry no flux, the prescribed
    ones carry the reactions, and the reactions of the two ends cancel (heat in = heat out)."""
    sim = run_deck(bar_deck(n=16), tmp_path)
    t, x, T = frames(tmp_path / "run.e", "Temperature")
    _, _, Q = frames(tmp_path / "run.e", "Flux_Divergence")
    ends = (x[:, 0] < 3) | (x[:, 0] > 13)
    V = 1.0
    reactions = []
    for k in (1, 2):
        exact = 100.0 + 20.0 * x[:, 0] * t[k]
        np.testing.assert_allclose(T[k], exact, rtol=1e-12)
        assert np.abs(Q[k][~ends]).max() < 1e-9
        R_left = Q[k][x[:, 0] < 3].sum() * V
        R_right = Q[k][x[:, 0] > 13].sum() * V
        assert R_left > 1.0 and R_right < -1.0
        np.testing.assert_allclose(R_left, -R_right, rtol=1e-10)
        reactions.append(R_left)
    np.testing.assert_allclose(reactions[1], 2.0 * reactions[0], rtol=1e-10)  # proportional to the gradient
    assert sim.stats["solvers"][-1]["steps"] == 2


@pytest.mark.parametrize("options", [{"Linear Solver": "Belos"}, {"Linear Solver": "Belos", "Belos Linear Solver": "BlockGMRES"}, {"Linear Solver": "Direct"}])
def test_linear_solvers_reach_the_same_steady_state(tmp_path, options):
    """Single prescribed layers (a nonlocal boundary layer at each end): whatever the linear
    solver, the converged temperatures agree with a direct dense solve of Q(T) = 0."""
    sim = run_deck(bar_deck(n=14, layers=1, steps=1, **options), tmp_path)
    n = sim.num_owned
    x = sim.fields["Model_Coordinates"][:n, 0]
    T = sim.fields["Temperature"][:n]
    from peridyn.solvers.implicit.diffusion import DiffusionMatrix

    A = DiffusionMatrix(sim)
    A.assemble(sim)
    J = A.to_scipy().toarray()
    rows = A.row_of_local[:n]
    fixed = (x < 1) | (x > 13)
    Tref = np.where(fixed, 100.0 + 20.0 * x, 0.0)[A.local_of_row]
    free = ~fixed[A.local_of_row]
    Tref[free] = np.linalg.solve(J[np.ix_(free, free)], -J[np.ix_(free, ~free)] @ Tref[~free])
    np.testing.assert_allclose(T, Tref[rows], rtol=1e-9)
    assert np.abs(T - (100.0 + 20.0 * x)).max() > 1e-3  # not the linear field: the ends' boundary layers
    st = sim.stats["solvers"][-1]
    if options["Linear Solver"] == "Direct":
        assert st["nonlinear_iterations"] == 1


def test_absolute_tolerance_and_no_work_when_converged(tmp_path):
    """A uniform field already in equilibrium: no iteration at all."""
    sim = run_deck(bar_deck(n=8, value=300.0, initial=300.0, steps=2), tmp_path)
    assert sim.clock.nonlinear_iterations == 0
    tree = bar_deck(n=8, steps=1, **{"Absolute Tolerance": 1e-6})
    tree["Solver"]["ImplicitDiffusion"].pop("Relative Tolerance")
    sim = run_deck(tree, tmp_path)
    assert sim.stats["solvers"][-1]["load_steps"][0]["tolerance"] == 1e-6


def test_a_step_that_cannot_converge_stops_the_run(tmp_path):
    tree = bar_deck(n=8, steps=2, **{"Maximum Solver Iterations": 0})
    with pytest.raises(DiffusionStepError, match="load step 1"):
        run_deck(tree, tmp_path)
    t, _, _ = frames(tmp_path / "run.e", "Temperature")
    assert list(t) == [0.0]


def test_explicit_dynamics_is_refused(tmp_path):
    tree = bar_deck(n=6)
    tree["Solver"] = {"Final Time": 1e-6, "Verlet": {"Fixed dt": 1e-7}}
    (tmp_path / "d.yaml").write_text(dump_yaml(tree))
    assert main(["run", str(tmp_path / "d.yaml"), "--output-dir", str(tmp_path), "-q", "--no-progress"]) == ExitCode.INPUT_ERROR


# -- MPI -------------------------------------------------------------------------------------------------
@requires_mpi
@pytest.mark.parametrize("solver", ["Belos", "Direct"])
def test_two_ranks_give_the_serial_answer(tmp_path, solver):
    tree = bar_deck(n=16, layers=1, steps=2, **{"Linear Solver": solver})
    tree["Output"] = {"Output Filename": "run", "Output Frequency": 1, "Output Variables": {"Temperature": True, "Flux_Divergence": True}}
    results = {}
    for ranks in (1, 2):
        folder = tmp_path / f"np{ranks}"
        folder.mkdir()
        (folder / "d.yaml").write_text(dump_yaml(tree))
        proc = mpirun(ranks, ["run", "d.yaml", "-q"], cwd=folder)
        assert proc.returncode == 0, proc.stderr
        results[ranks] = frames(folder / "run.e", "Temperature")[2], frames(folder / "run.e", "Flux_Divergence")[2]
    (T1, Q1), (T2, Q2) = results[1], results[2]
    np.testing.assert_allclose(T2, T1, rtol=1e-10)
    np.testing.assert_allclose(Q2, Q1, atol=1e-7 * np.abs(Q1).max())
