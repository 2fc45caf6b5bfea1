"""QuasiStatic, NOXQuasiStatic and Implicit as plugins: parameter validation (one-line errors with
deck paths), reactions in the outputs, the RANK_DEFICIENT_NODES node set, solver chaining and the
linear-solver choices."""
import numpy as np
import pytest

from peridyn.engine.run_services import RunServices
from peridyn.core.errors import InputError
from peridyn.engine.session import run_section, run_sections


def bar_deck(h, solver, *, damage=False, shape=(6, 3, 3), pull=0.01):
    """A bar clamped at x < 1 and pulled at x > shape[0] - 1 (x displacement pull * t)."""
    tree = h.box_deck(h.LPS, shape=shape, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 0.5} if damage else None)
    sim0 = h.build(tree)
    x, gid = sim0.discretization.x, sim0.discretization.gid
    ids = lambda mask: " ".join(str(g + 1) for g in gid[mask])  # noqa: E731
    tree["Boundary Conditions"] = {
        "Left Node Set": ids(x[:, 0] < 1.0),
        "Right Node Set": ids(x[:, 0] > shape[0] - 1.0),
        **{f"L{c}": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": c, "Value": "0.0"} for c in "xyz"},
        "RX": {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "x", "Value": f"{pull}*t"},
    }
    tree["Solver"] = solver
    return tree


QS = {"Initial Time": 0.0, "Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": 2, "Relative Tolerance": 1e-10}}


def error_for(h, solver, **kw):
    with pytest.raises(InputError) as info:
        h.build(bar_deck(h, solver, **kw))
    text = info.value.one_line()
    assert "\n" not in text
    return text


@pytest.mark.parametrize(
    "solver, path, words",
    [
        ({"Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": 0}}, "Solver > QuasiStatic > Number of Load Steps", "must be at least 1"),
        ({"QuasiStatic": {"Number of Load Steps": 4}}, "Solver", "no load steps"),
        ({"QuasiStatic": {"Time Steps": "0.0 0.5 0.4"}}, "Solver > QuasiStatic > Time Steps", "increase strictly"),
        ({"Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": 1, "Belos Linear Solver": "BlockQMR"}}, "Solver > QuasiStatic > Belos Linear Solver", "BlockCG"),
        ({"Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": 1, "Maximum Solver Iteration": 3}}, "Solver > QuasiStatic", "Maximum Solver Iterations"),
        ({"Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": 1, "Linear Solver": "LU"}}, "Solver > QuasiStatic > Linear Solver", "Direct"),
        (
            {"Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": 1, "Adaptive Load-Stepping": {"Maximum load step reductions in one step": 4, "Maximum total load step reductions": 2}}},
            "Solver > QuasiStatic > Adaptive Load-Stepping",
            "cannot be smaller",
        ),
        ({"Final Time": 1.0, "Implicit": {"Beta": 0.25}}, "Solver > Implicit", "Fixed dt"),
        ({"Final Time": 1.0, "Implicit": {"Fixed dt": 0.1, "Gamma": 2.0}}, "Solver > Implicit > Gamma", "must be at most 1"),
        ({"Final Time": 1.0, "NOXQuasiStatic": {"Number of Load Steps": 1, "Direction": {"Method": "Broyden"}}}, "Solver > NOXQuasiStatic > Direction > Method", "Newton"),
        ({"Final Time": 1.0, "NOXQuasiStatic": {"Number of Load Steps": 1}}, "Solver > NOXQuasiStatic", "Direction"),
        (
            {"Final Time": 1.0, "NOXQuasiStatic": {"Number of Load Steps": 1, "Direction": {"Method": "Newton", "Newton": {"Linear Solver": {"Max Iteration": 3}}}}},
            "Solver > NOXQuasiStatic > Direction > Newton > Linear Solver",
            "unknown key 'Max Iteration': did you mean 'Max Iterations'?",
        ),
        ({"Final Time": 0.0, "QuasiStatic": {"Number of Load Steps": 1}}, "Solver", "must be later than 'Initial Time'"),
        (
            {
                "Final Time": 1.0,
                "Peridigm Preconditioner": "Block 3x3",
                "NOXQuasiStatic": {"Number of Load Steps": 1, "Direction": {"Method": "Newton", "Newton": {"Linear Solver": {"Jacobian Operator": "Matrix-Free", "Preconditioner": "Ifpack"}}}},
            },
            "Solver",
            "User Defined",
        ),
        ({"Final Time": 1.0, "Peridigm Preconditioner": "Jacobi", "NOXQuasiStatic": {"Number of Load Steps": 1, "Direction": {"Method": "Newton"}}}, "Solver > Peridigm Preconditioner", "Block 3x3"),
    ],
)
def test_bad_solver_parameters_are_one_line_input_errors(h, solver, path, words):
    text = error_for(h, solver)
    assert path in text
    assert words in text


def test_nox_option_trees_are_accepted(h):
    solver = {
        "Final Time": 1.0,
        "NOXQuasiStatic": {
            "Number of Load Steps": 1,
            "Relative Tolerance": 1e-8,
            "Printing": {"Output Precision": 20, "Output Processor": 0},
            "Solver Options": {"Status Test Check Type": "Complete"},
            "Line Search": {"Method": "Polynomial", "More'-Thuente": {"Sufficient Decrease": 1e-4}},
            "Direction": {"Method": "Newton", "Newton": {"Forcing Term Method": "Constant", "Linear Solver": {"Preconditioner": "None", "RCM Reordering": "Enabled"}}},
        },
    }
    sim = h.build(bar_deck(h, solver))
    run_sections(sim)
    assert sim.clock.nonlinear_iterations >= 1


def test_reactions_balance_and_force_output(h):
    """Force_Density at the prescribed points holds the internal force (the negated reaction)
    at the converged configuration; internal forces sum to zero, so the reactions at the two
    ends are equal and opposite and the free points are in equilibrium."""
    sim = h.build(bar_deck(h, QS))
    run_sections(sim)
    n = sim.num_owned
    F = sim.fields["Force_Density"][:n] * sim.fields["Volume"][:n, None]
    x = sim.fields["Model_Coordinates"][:n]
    left, right = x[:, 0] < 1.0, x[:, 0] > 5.0
    free = ~(left | right)
    scale = np.abs(F[right, 0]).sum()
    assert scale > 0
    np.testing.assert_allclose(F[left, 0].sum(), -F[right, 0].sum(), rtol=1e-9)
    # free points: only the solver tolerance (1e-10 of the reactions) remains
    assert np.abs(F[free]).max() < 1e-8 * scale
    np.testing.assert_allclose(sim.fields["Displacement"][right, 0], 0.01, rtol=1e-12)


@pytest.mark.parametrize(
    "solver, damage, expected",
    [
        (QS, True, True),
        (QS, False, False),
        ({"Final Time": 1.0, "Implicit": {"Fixed dt": 0.5}}, True, True),
        ({"Final Time": 1.0, "Peridigm Preconditioner": "Block 3x3", "NOXQuasiStatic": {"Number of Load Steps": 1, "Direction": {"Method": "Newton"}}}, True, False),
        ({"Final Time": 1.0, "NOXQuasiStatic": {"Number of Load Steps": 1, "Direction": {"Method": "Newton"}}}, True, True),
    ],
)
def test_rank_deficient_node_set(h, tmp_path, solver, damage, expected):
    """Peridigm writes an empty RANK_DEFICIENT_NODES node set when a full tangent is allocated and
    a block has a damage model (PERIDIGM_SEMANTICS.md §1.4)."""
    import netCDF4

    tree = bar_deck(h, solver, damage=damage)
    tree["Output"] = {"Output Filename": "bar", "Output Frequency": 1, "Output Variables": {"Displacement": True}}
    sim = h.build(tree, output_dir=tmp_path)
    assert ("RANK_DEFICIENT_NODES" in sim.node_sets) is expected
    run = RunServices.of(sim)
    run.write_output(0.0)
    run.close()
    with netCDF4.Dataset(tmp_path / "bar.e") as ds:
        names = ["".join(c.decode() for c in row if c) for row in ds.variables["ns_names"][:].data] if "ns_names" in ds.variables else []
        assert ("RANK_DEFICIENT_NODES" in names) is expected
        if expected:
            k = names.index("RANK_DEFICIENT_NODES") + 1
            assert f"node_ns{k}" not in ds.variables or ds.variables[f"node_ns{k}"].size == 0


@pytest.mark.parametrize("method", ["Belos", "Direct", "AMG", "Auto"])
def test_linear_solver_choice_gives_the_same_solution(h, method):
    """Every linear solver converges Newton to the same equilibrium (tolerance 1e-10 of the
    reactions, i.e. displacements agree to ~1e-10 relative)."""
    solver = {"Initial Time": 0.0, "Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": 1, "Relative Tolerance": 1e-10, "Linear Solver": method}}
    sim = h.build(bar_deck(h, solver, pull=0.02))
    run_sections(sim)
    ref = h.build(bar_deck(h, dict(solver, QuasiStatic=dict(solver["QuasiStatic"], **{"Linear Solver": "Direct"})), pull=0.02))
    run_sections(ref)
    u, u_ref = sim.fields["Displacement"], ref.fields["Displacement"]
    np.testing.assert_allclose(u, u_ref, rtol=0, atol=1e-8 * np.abs(u_ref).max())


def test_quasistatic_then_verlet_starts_from_the_quasistatic_state(h):
    """QS leaves v = increment / load step; a following Verlet solver starts from it (Peridigm's
    solver chaining)."""
    solver = {"Initial Time": 0.0, "Final Time": 1.0e-5, "QuasiStatic": {"Number of Load Steps": 2, "Relative Tolerance": 1e-10}}
    tree = bar_deck(h, solver, pull=1000.0)
    tree["Solver2"] = {"Initial Time": 1.0e-5, "Final Time": 1.2e-5, "Verlet": {"Fixed dt": 1.0e-6}}
    sim = h.build(tree)
    entries = sim.deck.solvers
    run = RunServices.of(sim)
    state = run_section(sim, entries[0].cls(entries[0].params, section=entries[0].section), run=run)
    u_qs = sim.fields["Displacement"].copy()
    v_qs = sim.fields["Velocity"].copy()
    x = sim.fields["Model_Coordinates"]
    right = x[:, 0] > 5.0
    np.testing.assert_allclose(v_qs[right, 0], 0.005 / 5.0e-6, rtol=1e-12)  # (1000 t) over the second load step
    run_section(sim, entries[1].cls(entries[1].params, section=entries[1].section), state, run)
    du = sim.fields["Displacement"] - u_qs
    steps = sim.stats["solvers"][-1]["steps"]  # floor((t_f - t_0)/dt), Peridigm's count
    assert steps >= 1
    np.testing.assert_allclose(du[right, 0], steps * 1.0e-6 * 1000.0, rtol=1e-9)


def test_switch_to_verlet_after_too_many_reductions(h):
    """Adaptive load stepping: a step that cannot converge is halved until the reductions run out,
    then Verlet takes over from the last converged step to the final time."""
    solver = {
        "Initial Time": 0.0,
        "Final Time": 2.0e-6,
        "QuasiStatic": {
            "Number of Load Steps": 1,
            "Absolute Tolerance": 1e-30,  # unreachable: every attempt fails
            "Maximum Solver Iterations": 1,
            "Adaptive Load-Stepping": {
                "Maximum load step reductions in one step": 2,
                "Maximum total load step reductions": 2,
                "Switch to Verlet": {"Fixed dt": 1.0e-7},
            },
        },
    }
    sim = h.build(bar_deck(h, solver))
    run_sections(sim)
    methods = [st["method"] for st in sim.stats["solvers"]]
    assert methods == ["QuasiStatic", "Verlet"]
    assert sim.stats["solvers"][1]["steps"] == 20
    assert sim.clock.time == pytest.approx(2.0e-6)


NEWTON_MF = {"Method": "Newton", "Newton": {"Linear Solver": {"Jacobian Operator": "Matrix-Free", "Preconditioner": "None"}}}


@pytest.mark.parametrize(
    "preconditioner, direction, line_search",
    [
        (None, {"Method": "Newton"}, "Polynomial"),
        ("None", NEWTON_MF, "Polynomial"),
        ("Block 3x3", {"Method": "Newton", "Newton": {"Linear Solver": {"Jacobian Operator": "Matrix-Free", "Preconditioner": "User Defined"}}}, "Full Step"),
        (
            None,
            {"Method": "NonlinearCG", "Nonlinear CG": {"Precondition": "On", "Restart Frequency": 15, "Linear Solver": {"Preconditioner": "AztecOO", "Aztec Preconditioner": "Jacobi", "AztecOO Preconditioner Iterations": 15}}},
            "NonlinearCG",
        ),
    ],
)
def test_nox_variants_reach_the_quasistatic_equilibrium(h, preconditioner, direction, line_search):
    """Newton with the tangent, Jacobian-free Newton-Krylov (with or without Peridigm's block
    preconditioner) and preconditioned nonlinear CG all converge to QuasiStatic's equilibrium
    (both at 1e-10 of the reactions: displacements agree to ~1e-9 of the largest)."""
    nox = {"Number of Load Steps": 2, "Relative Tolerance": 1e-10, "Max Solver Iterations": 100, "Direction": direction, "Line Search": {"Method": line_search}}
    solver = {"Initial Time": 0.0, "Final Time": 1.0, "NOXQuasiStatic": nox}
    if preconditioner is not None:
        solver["Peridigm Preconditioner"] = preconditioner
    sim = h.build(bar_deck(h, solver))
    run_sections(sim)
    ref = h.build(bar_deck(h, QS))
    run_sections(ref)
    u, u_ref = sim.fields["Displacement"], ref.fields["Displacement"]
    np.testing.assert_allclose(u, u_ref, rtol=0, atol=1e-7 * np.abs(u_ref).max())
    np.testing.assert_allclose(sim.fields["Velocity"], ref.fields["Velocity"], rtol=0, atol=1e-7 * np.abs(ref.fields["Velocity"]).max())
    assert sim.clock.nonlinear_iterations >= 2


def test_nox_counts_one_step_when_the_initial_guess_has_converged(h):
    """Each NOX solver step counts one Nonlinear_Solver_Iterations, the first one also when it
    only finds the initial guess converged (here: nothing moves, F = 0)."""
    solver = {"Initial Time": 0.0, "Final Time": 1.0, "NOXQuasiStatic": {"Number of Load Steps": 3, "Absolute Tolerance": 1.0, "Direction": {"Method": "Newton"}}}
    sim = h.build(bar_deck(h, solver, pull=0.0))
    run_sections(sim)
    assert sim.clock.nonlinear_iterations == 3


def test_nox_failure_stops_the_run(h):
    from peridyn.solvers.implicit.nox import NOXConvergenceError

    solver = {"Initial Time": 0.0, "Final Time": 1.0, "NOXQuasiStatic": {"Number of Load Steps": 1, "Absolute Tolerance": 1e-30, "Max Solver Iterations": 2, "Direction": {"Method": "Newton"}}}
    sim = h.build(bar_deck(h, solver))
    with pytest.raises(NOXConvergenceError, match="did not converge in 2 NOX steps"):
        run_sections(sim)


@pytest.mark.parametrize(("preconditioner", "warned", "tangent"), [(None, True, "full"), ("None", False, "block diagonal")])
def test_matrix_free_without_peridigm_preconditioner_warns_of_the_full_tangent(h, caplog, preconditioner, warned, tangent):
    """Peridigm's default preconditioner is the full tangent: a 'Matrix-Free' deck without
    'Peridigm Preconditioner' assembles it (memory!), which the log says, with the fix."""
    solver = {"Initial Time": 0.0, "Final Time": 1.0, "NOXQuasiStatic": {
        "Number of Load Steps": 1, "Relative Tolerance": 1e-8,
        "Direction": {"Method": "Newton", "Newton": {"Linear Solver": {"Jacobian Operator": "Matrix-Free", "Preconditioner": "None"}}}}}
    if preconditioner is not None:
        solver["Peridigm Preconditioner"] = preconditioner
    sim = h.build(bar_deck(h, solver))
    with caplog.at_level("WARNING", logger="peridyn"):
        state = run_sections(sim)
    assert any("assembles the full tangent" in r.getMessage() for r in caplog.records) == warned
    assert list(state.solver_cache["implicit tangents"]) == [tangent]
