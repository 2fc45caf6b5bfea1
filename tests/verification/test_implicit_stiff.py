"""QuasiStatic on stiff cases (issue #5): a nearly incompressible solid (K/G = 1000) and a 100x
stiffness jump between two blocks converge to the right solution; a load step that cannot
converge stops the run with a one-line error naming the load step and the residual, or, with
``Adaptive Load-Stepping``, is cut back; it is never accepted unconverged.

* Nearly incompressible bar "in the bulk" (Peridigm's defaults: CG, line search, predictor): a
  boundary layer two horizons thick is driven by the uniaxial-stress solution
  u = eps (x, -nu y, -nu z) with nu = 0.49967; a homogeneous deformation makes every force vanish
  where all neighbors have complete families, so the interior must come out exactly affine and
  its dilatation is the tiny volumetric strain (1 - 2 nu) eps ~ 1e-3 eps (plus the geometric
  term below).
* Pure Newton with the analytic tangent and a direct solver converges quadratically at
  K/G = 1000 too (an inexact shear part of the tangent would make it linear).
* Two blocks in series, the right one 100x stiffer (K and G), same horizon: the same axial force
  crosses both, so away from the interface and the loaded ends the axial strains are in the
  ratio 100.
* A load step too large for the allowed Newton iterations: exit status 3, one error line, the
  output of the converged steps kept; with Adaptive Load-Stepping it is halved until it converges.
"""
import math

import numpy as np
import pytest
import yaml

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.io.exodus_reader import read_results
from peridyn.solvers.implicit.quasistatic import LoadStepError
from peridyn.testing import build_simulation, cube_deck, node_set_ids
from peridyn.engine.session import run_sections

G = 1.0e9
K = 1000.0 * G  # K/G = 1000
NU = (3.0 * K - 2.0 * G) / (2.0 * (3.0 * K + G))  # 0.49967
STIFF = {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": K, "Shear Modulus": G}


def check_every_accepted_step_converged(st, max_iterations):
    """Each load step attempt either met its tolerance within the allowed iterations or was not
    accepted; the residual history of an accepted step ends at or below the tolerance."""
    assert len(st["load_steps"]) == len(st["residuals"])
    for attempt, history in zip(st["load_steps"], st["residuals"]):
        assert history[-1] == attempt["residual"]
        assert attempt["iterations"] == len(history) - 1 <= max_iterations
        if attempt["outcome"] == "converged":
            assert attempt["residual"] <= attempt["tolerance"], attempt
        else:
            assert attempt["outcome"] == "cut back", attempt  # never "accepted" above the tolerance here
            assert attempt["residual"] > 100.0 * attempt["tolerance"], attempt  # not within Peridigm's 100x acceptance


# ------------------------------------------------------------------------------------------------
# K/G = 1000
# ------------------------------------------------------------------------------------------------
def test_nearly_incompressible_bar_in_the_bulk_converges_to_the_affine_solution():
    eps = 1.0e-4
    shape, horizon, layer = (10, 8, 7), 1.515, 3.0  # layer >= 2 horizons; 560 points, 8 free
    L = np.array(shape, dtype=float)
    tree = cube_deck(STIFF, shape=shape, horizon_factor=horizon)
    tree["Boundary Conditions"] = {"Layer Node Set": node_set_ids(tree, lambda x: np.any((x < layer) | (x > L - layer), axis=1))}
    for c, f in zip("xyz", (1.0, -NU, -NU)):
        tree["Boundary Conditions"][f"U{c}"] = {"Type": "Prescribed Displacement", "Node Set": "Layer Node Set", "Coordinate": c, "Value": f"{f * eps!r}*{c}*t"}
    max_iterations = 10  # Peridigm's default
    tree["Solver"] = {
        "Initial Time": 0.0, "Final Time": 1.0,
        "QuasiStatic": {"Number of Load Steps": 2, "Relative Tolerance": 1.0e-10, "Maximum Solver Iterations": max_iterations},
    }
    sim = build_simulation(tree)
    run_sections(sim)
    st = sim.stats["solvers"][-1]
    assert st["converged"] and st["steps"] == 2 and st["load_step_reductions"] == 0
    check_every_accepted_step_converged(st, max_iterations)
    assert [a["outcome"] for a in st["load_steps"]] == ["converged", "converged"]
    # the residual falls at every iteration by at least 100x (CG stops at 1e-4 of the right-hand
    # side, so each inexact Newton step gains about 1e-4 until round-off): a few iterations,
    # far below the allowed 10
    for history in st["residuals"]:
        r = np.array(history)
        assert np.all(r[1:] < 1.0e-2 * r[:-1]), r
    assert len(st["residuals"][0]) - 1 <= 4

    x = sim.fields["Model_Coordinates"]
    u = sim.fields["Displacement"]
    interior = np.all((x > layer) & (x < L - layer), axis=1)
    assert interior.sum() == 8
    H = eps * np.array([1.0, -NU, -NU])
    # Newton stops at 1e-10 of the reactions (~K eps); the softest (shear) modes are K/G = 1000
    # times more compliant than the volumetric ones: the displacement error is below 1e-7 eps L
    np.testing.assert_allclose(u[interior], (x * H)[interior], rtol=0, atol=1.0e-7 * eps * L.max())
    # the dilatation is the volumetric strain, set by K (a residual of 1e-10 K eps moves it by
    # ~1e-10 eps, 1e-7 of it). Linear part tr(H) = (1 - 2 nu) eps ~ 1e-3 eps; the bond stretch
    # |F n| - 1 = n.Hn + (|Hn|^2 - (n.Hn)^2)/2 + O(eps^3) adds (3 tr(H^2) - tr(H)^2)/10
    # = 0.45 eps^2 (4.5 % here) averaged over an isotropic family. The family (horizon 1.515:
    # 6 neighbors at 1, 12 at sqrt 2; weights omega |xi|^2 V = 1 and 2) has isotropic second
    # and fourth moments (sum w n_x^4 = 6 = 3 sum w n_x^2 n_y^2), so the average is exact; the
    # third-order terms are O(eps^2 / (1 - 2 nu)) ~ 1e-5 relative
    tr, tr2 = H.sum(), (H * H).sum()
    theta = tr + (3.0 * tr2 - tr * tr) / 10.0
    np.testing.assert_allclose(sim.fields["Dilatation"][interior], theta, rtol=1.0e-4)
    assert abs(theta / tr - 1.0) > 0.04  # the check above resolves the geometric term


def stretch_and_shear_deck(solver, shape=(5, 5, 5)):
    """A K/G = 1000 bar clamped at x < 1 and moved at x > n - 1 by (0.2 t, 0.3 t): 5 % stretch
    and 7.5 % shear at t = 1, far into the geometrically nonlinear range."""
    tree = cube_deck(STIFF, shape=shape, horizon_factor=2.015)
    n = shape[0]
    tree["Boundary Conditions"] = {
        "Left Node Set": node_set_ids(tree, lambda x: x[:, 0] < 1.0),
        "Right Node Set": node_set_ids(tree, lambda x: x[:, 0] > n - 1.0),
        **{f"L{c}": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": c, "Value": "0.0"} for c in "xyz"},
        "RX": {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "x", "Value": "0.2*t"},
        "RY": {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "y", "Value": "0.3*t"},
    }
    tree["Solver"] = solver
    return tree


def test_newton_converges_quadratically_at_k_over_g_1000():
    """Pure Newton (Disable Heuristics) with the analytic tangent and a direct solver, one load
    step: after a pre-asymptotic phase (nearly incompressible, large deformation), each residual
    is about the square of the previous one until round-off."""
    max_iterations = 12
    solver = {
        "Initial Time": 0.0, "Final Time": 1.0, "Disable Heuristics": True,
        "QuasiStatic": {"Number of Load Steps": 1, "Relative Tolerance": 1.0e-12, "Maximum Solver Iterations": max_iterations, "Linear Solver": "Direct"},
    }
    sim = build_simulation(stretch_and_shear_deck(solver))
    run_sections(sim)
    st = sim.stats["solvers"][-1]
    assert st["converged"]
    check_every_accepted_step_converged(st, max_iterations)
    r = np.array(st["residuals"][0])
    assert r[-1] < 1.0e-12 * r[0]
    floor = 1.0e-14 * r[0]  # round-off of the force evaluation
    orders = [math.log(r[k + 1] / r[k]) / math.log(r[k] / r[k - 1]) for k in range(1, len(r) - 1) if r[k + 1] > floor]
    # the last three orders above round-off: ~2 (measured 2.06, 1.82, 2.11); estimates from a
    # norm that is not the error norm scatter by ~0.2; a tangent off by O(1) in its shear part
    # converges linearly (order ~1)
    assert len(orders) >= 3
    assert min(orders[-3:]) > 1.6, (r, orders)


# ------------------------------------------------------------------------------------------------
# 100x stiffness jump
# ------------------------------------------------------------------------------------------------
def test_two_blocks_with_a_100x_stiffness_jump_strain_inversely_to_their_moduli(tmp_path):
    """A 24 x 3 x 3 bar of unit spacing: block_1 (x < 12) soft, block_2 100x stiffer (K and G,
    same Poisson ratio, same horizon), clamped over two planes at each end (x displacement 0 and
    d t, y and z held), lateral faces free. The force operator of block_2 is exactly 100 times
    block_1's, so the translation-invariant states in the interiors of the blocks carry the same
    axial force with axial strains in the ratio 100."""
    nx, ny, nz, horizon, layer, d = 24, 3, 3, 1.515, 2.0, 1.0e-3
    k_soft, g_soft, jump = 1.0e9, 0.5e9, 100.0
    grid = np.stack(np.meshgrid(*[np.arange(n) + 0.5 for n in (nx, ny, nz)], indexing="ij"), axis=-1).reshape(-1, 3)
    block = np.where(grid[:, 0] < nx / 2, 1, 2)
    (tmp_path / "bar.txt").write_text("# x y z block volume\n" + "\n".join(f"{x} {y} {z} {b} 1.0" for (x, y, z), b in zip(grid, block)) + "\n")
    ids = lambda mask: " ".join(str(i + 1) for i in np.flatnonzero(mask))  # noqa: E731 - Text File ids are line numbers
    bc = {"Left Node Set": ids(grid[:, 0] < layer), "Right Node Set": ids(grid[:, 0] > nx - layer)}
    for side, ux in (("Left", "0.0"), ("Right", f"{d!r}*t")):
        for c, value in zip("xyz", (ux, "0.0", "0.0")):
            bc[f"{side} {c}"] = {"Type": "Prescribed Displacement", "Node Set": f"{side} Node Set", "Coordinate": c, "Value": value}
    max_iterations = 10
    tree = {
        "Discretization": {"Type": "Text File", "Input Mesh File": "bar.txt"},
        "Materials": {
            "Soft": {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": k_soft, "Shear Modulus": g_soft},
            "Hard": {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": jump * k_soft, "Shear Modulus": jump * g_soft},
        },
        "Blocks": {
            "Left": {"Block Names": "block_1", "Material": "Soft", "Horizon": horizon},
            "Right": {"Block Names": "block_2", "Material": "Hard", "Horizon": horizon},
        },
        "Boundary Conditions": bc,
        "Solver": {
            "Initial Time": 0.0, "Final Time": 1.0,
            "QuasiStatic": {"Number of Load Steps": 1, "Relative Tolerance": 1.0e-10, "Maximum Solver Iterations": max_iterations},
        },
    }
    sim = build_simulation(tree, directory=tmp_path)
    run_sections(sim)
    st = sim.stats["solvers"][-1]
    assert st["converged"]
    check_every_accepted_step_converged(st, max_iterations)
    r = np.array(st["residuals"][0])
    assert np.all(r[1:] < 1.0e-2 * r[:-1]), r

    x = sim.fields["Model_Coordinates"]
    u = sim.fields["Displacement"]
    planes = np.unique(x[:, 0])
    mean_ux = np.array([u[x[:, 0] == p, 0].mean() for p in planes])

    def interior_strain(lo, hi):
        """Axial strain of the cross-section means, fitted over the planes in (lo, hi)."""
        sel = (planes > lo) & (planes < hi)
        assert sel.sum() == 4
        slope, _ = np.polyfit(planes[sel], mean_ux[sel], 1)
        # translation invariance: every plane-to-plane strain there is the fitted one (measured
        # within 1e-3; the interface and the clamps disturb the strain by up to 10x within one
        # horizon and by 1e-2 at 1.5 horizons)
        np.testing.assert_allclose(np.diff(mean_ux[sel]), slope, rtol=3.0e-3)
        return slope

    # the planes two horizons or more from the interface and from the clamped layers
    margin = 2.0 * horizon
    soft = interior_strain(layer + margin, nx / 2 - margin)
    hard = interior_strain(nx / 2 + margin, nx - layer - margin)
    assert soft > 0 and hard > 0
    # what is left of the interface and clamp disturbances two horizons away is ~1e-4 of the
    # strain (measured ratio 100.018), the geometric nonlinearity O(eps) = 1e-4: 2e-3 allows
    # for both with a margin and still fails for any other modulus ratio
    np.testing.assert_allclose(soft / hard, jump, rtol=2.0e-3)
    # series springs: the end displacement d is taken up over the free length between the
    # clamps (1.5 < x < 22.5), half soft, half hard: soft strain d / (10.5 (1 + 1/100)). The
    # disturbed zones at the clamps and the interface (about a horizon each) strain less, the
    # interiors more: measured +6.6 %
    np.testing.assert_allclose(soft, d / (0.5 * (nx - 2 * layer + 1.0) * (1.0 + 1.0 / jump)), rtol=0.1)
    # the bond forces are pairwise (also across the interface): the reactions at the two ends
    # balance up to the residual left on the free points
    V = sim.fields["Volume"]
    f = sim.fields["Force_Density"] * V[:, None]
    left, right = x[:, 0] < layer, x[:, 0] > nx - layer
    R = abs(f[left, 0].sum())
    assert R > 0
    assert abs(f[left, 0].sum() + f[right, 0].sum()) < 1.0e-8 * R


# ------------------------------------------------------------------------------------------------
# a load step that cannot converge
# ------------------------------------------------------------------------------------------------
# Pure Newton (no predictor, no line search) on the stretch-and-shear bar needs 9 iterations for
# the whole load in one step, 7 for half of it and 5 for a quarter: with 6 allowed, steps of 1 and
# 0.5 cannot converge (their residual after 6 iterations is 3e6 and 270-630 times the tolerance,
# beyond Peridigm's 100x acceptance) and steps of 0.25 converge (to 1e-3 of the tolerance)
PURE_NEWTON = {"Relative Tolerance": 1.0e-10, "Maximum Solver Iterations": 6, "Linear Solver": "Direct"}


def test_unconverged_load_step_stops_the_run_with_one_line_naming_it(tmp_path, capsys):
    solver = {"Initial Time": 0.0, "Final Time": 1.0, "Disable Heuristics": True, "QuasiStatic": dict(PURE_NEWTON, **{"Time Steps": "0.0 0.25 0.5 1.0"})}
    tree = stretch_and_shear_deck(solver)
    tree["Output"] = {"Output Filename": "bar", "Output Frequency": 1, "Output Variables": {"Displacement": True, "Force_Density": True}}
    deck = tmp_path / "bar.yaml"
    deck.write_text(yaml.safe_dump({"Peridigm": tree}, sort_keys=False))

    code = main(["run", str(deck), "--no-progress", "--output-dir", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == ExitCode.UNSTABLE, err
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, err
    line = errors[0]
    assert "load step 3 (t = 1, step size 0.5) did not converge" in line, line
    residual = float(line.split("residual ")[1].split()[0])
    tolerance = float(line.split("(tolerance ")[1].split(",")[0])
    assert residual > 100.0 * tolerance > 0, line
    assert "after 6 iteration(s)" in line and "last converged load step (t = 0.5)" in line and "Adaptive Load-Stepping" in line, line
    assert "output written so far is kept" in err

    # the output of the converged steps is readable; the failed step was not written
    out = read_results(tmp_path / "bar.e")
    np.testing.assert_allclose(out["times"], [0.0, 0.25, 0.5])
    right = out["coords"][:, 0] > 4.0
    np.testing.assert_allclose(out["nodal"]["DisplacementX"][-1, right], 0.2 * 0.5, rtol=1.0e-12)

    # the same through the Python API: the exception is an InstabilityError (exit status 3) and
    # the solver statistics say which attempt failed
    sim = build_simulation(stretch_and_shear_deck(solver))
    with pytest.raises(LoadStepError, match=r"load step 3 \(t = 1, step size 0\.5\) did not converge: residual"):
        run_sections(sim)
    st = sim.stats["solvers"][-1]
    assert not st["converged"] and st["steps"] == 2
    assert [a["outcome"] for a in st["load_steps"]] == ["converged", "converged", "failed"]
    assert st["load_steps"][-1]["residual"] > 100.0 * st["load_steps"][-1]["tolerance"]
    right = sim.fields["Model_Coordinates"][:, 0] > 4.0
    np.testing.assert_allclose(sim.fields["Displacement"][right, 0], 0.2 * 0.5, rtol=1.0e-12)  # the last converged state


def test_adaptive_load_stepping_halves_the_step_until_it_converges(caplog):
    adaptive = {"Maximum load step reductions in one step": 4, "Maximum total load step reductions": 8}
    qs = dict(PURE_NEWTON, **{"Number of Load Steps": 1, "Adaptive Load-Stepping": adaptive})
    solver = {"Initial Time": 0.0, "Final Time": 1.0, "Disable Heuristics": True, "QuasiStatic": qs}
    sim = build_simulation(stretch_and_shear_deck(solver))
    with caplog.at_level("WARNING", logger="peridyn.solver"):
        run_sections(sim)
    st = sim.stats["solvers"][-1]
    assert st["converged"]
    attempts = st["load_steps"]
    check_every_accepted_step_converged(st, PURE_NEWTON["Maximum Solver Iterations"])
    cut = [a for a in attempts if a["outcome"] == "cut back"]
    accepted = [a for a in attempts if a["outcome"] == "converged"]
    assert attempts[0]["outcome"] == "cut back" and attempts[0]["dt"] == 1.0  # the whole load at once
    assert st["load_step_reductions"] == len(cut) >= 2  # 1 -> 0.5 -> 0.25 at least
    # each cut-back attempt is retried from the same start with half the step
    for a, b in zip(attempts, attempts[1:]):
        if a["outcome"] == "cut back":
            assert b["step"] == a["step"] and b["dt"] == pytest.approx(a["dt"] / 2.0)
            assert b["time"] - b["dt"] == pytest.approx(a["time"] - a["dt"])
    # the accepted steps tile [0, 1], are the steps counted, and none is larger than 0.25
    times = [a["time"] for a in accepted]
    assert times[-1] == pytest.approx(1.0) and np.all(np.diff(times) > 0)
    np.testing.assert_allclose(np.cumsum([a["dt"] for a in accepted]), times, rtol=1e-12)
    assert st["steps"] == len(accepted) and max(a["dt"] for a in accepted) <= 0.25
    # every halving is logged on one line naming the load step and its residual
    halvings = [r.getMessage() for r in caplog.records if "halving it" in r.getMessage()]
    assert len(halvings) == len(cut)
    for msg, a in zip(halvings, cut):
        assert f"load step {a['step']} (t = {a['time']:.6g}, step size {a['dt']:.4g}) did not converge: residual {a['residual']:.4g}" in msg
        assert "\n" not in msg

    # the same equilibrium as four fixed load steps (elastic: path-independent); both meet 1e-10
    # of the reactions, the K/G = 1000 shear modes amplify that to < 1e-7 of the displacements
    ref = build_simulation(stretch_and_shear_deck({"Initial Time": 0.0, "Final Time": 1.0, "Disable Heuristics": True, "QuasiStatic": dict(PURE_NEWTON, **{"Number of Load Steps": 4})}))
    run_sections(ref)
    assert ref.stats["solvers"][-1]["converged"]
    u, u_ref = sim.fields["Displacement"], ref.fields["Displacement"]
    np.testing.assert_allclose(u, u_ref, rtol=0, atol=1.0e-7 * np.abs(u_ref).max())


def test_stiff_step_the_default_cg_cannot_solve_fails_clearly_then_is_cut_back():
    """Peridigm's defaults (CG, line search) on the whole stretch-and-shear load at once: the
    tangent after the first iteration is indefinite and CG (also on the damped tangent) breaks
    down. The step must not be accepted: the run stops naming the load step, the residual and
    the failed linear solve; with adaptive stepping the halves converge."""
    qs = {"Number of Load Steps": 1, "Relative Tolerance": 1.0e-10}
    sim = build_simulation(stretch_and_shear_deck({"Initial Time": 0.0, "Final Time": 1.0, "QuasiStatic": qs}))
    with pytest.raises(LoadStepError) as info:
        run_sections(sim)
    msg = str(info.value)
    assert "\n" not in msg
    assert "load step 1 (t = 1, step size 1) did not converge: residual" in msg and "the linear solve of iteration" in msg, msg
    a = sim.stats["solvers"][-1]["load_steps"][-1]
    assert a["outcome"] == "failed" and f"residual {a['residual']:.4g} " in msg  # the last computed residual, not a sentinel
    assert sim.stats["solvers"][-1]["steps"] == 0

    adaptive = {"Maximum load step reductions in one step": 2, "Maximum total load step reductions": 2}
    sim = build_simulation(stretch_and_shear_deck({"Initial Time": 0.0, "Final Time": 1.0, "QuasiStatic": dict(qs, **{"Adaptive Load-Stepping": adaptive})}))
    run_sections(sim)
    st = sim.stats["solvers"][-1]
    assert st["converged"] and st["load_step_reductions"] >= 1
    check_every_accepted_step_converged(st, 10)
