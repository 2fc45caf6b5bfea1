"""The campaign's judges on fabricated evidence: exit 0 of ``run`` with a blown-up or empty result
must be classified ``exit0_bad``; a clean result must not (issue 19).

Fast (no peridyn run): fake Exodus files written with netCDF4, fake run summaries on stderr.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cases import Case, Prepared  # noqa: E402
from mutations import DeckInfo, Mutation, family_of_case, mutations  # noqa: E402
from runner import (  # noqa: E402
    BAD_CLASSES,
    classify,
    exodus_growth,
    run_exit0_problems,
    run_summary,
    summary_problems,
)

netCDF4 = pytest.importorskip("netCDF4")

#: what ``peridyn run`` prints at its end for a healthy explicit run (quickstart.yaml)
CLEAN_STDERR = """quickstart.yaml: 5400 points in 1 block(s), 382612 bonds; set-up 4.18 s (mesh 0.01 s, neighbors 4.11 s)
Solver: Verlet, dt = 1.61681e-07 (critical estimate 2.02101e-07), 371 steps from t = 0 to 5.99835e-05
Solver (Verlet): 371 steps in 2.66 s, 53.3 M bond evaluations/s, 0.75 M point-steps/s
  energy: kinetic 0 -> 0.0604667, stored +0.135629, work by loads +0, by prescribed motion +0.195511; balance error 0.000585 (0.3% of the energy scale, worst 0.12%)
done in 10.08 s; wrote quickstart.e
"""
BLOWUP_STDERR = CLEAN_STDERR.replace("kinetic 0 -> 0.0604667", "kinetic 0 -> 6.1e+41").replace(
    "balance error 0.000585 (0.3% of the energy scale, worst 0.12%)", "balance error 6.1e+41 (1e+02% of the energy scale, worst 1e+02%)")
WARNING_STDERR = CLEAN_STDERR.replace(
    "done in", "Solver: the energy of the run was off by up to 62.5% (velocity Verlet's energy error, bounded in a stable "
    "run: the vibrations that carry the energy are resolved by few steps per period; accurate runs stay below 1%): a smaller "
    "'Safety Factor' gives a more accurate answer\ndone in")
ZERO_STEPS_STDERR = CLEAN_STDERR.replace("Solver (Verlet): 371 steps", "Solver (Verlet): 0 steps")
NO_SOLVER_STDERR = "quickstart.yaml: 5400 points in 1 block(s), 382612 bonds; set-up 4.18 s\ndone in 4.20 s; wrote no output\n"
TREE = {"Solver": {"Initial Time": 0.0, "Final Time": 6e-5, "Verlet": {"Safety Factor": 0.8}},
        "Output": {"Output Filename": "out", "Output Frequency": 5, "Output Variables": {"Displacement": True}}}


def fake_exodus(path: Path, times, u=None, v=None, ke=None, extent: float = 1.0, nodes: int = 8) -> Path:
    """A minimal Exodus II file: a cube of ``nodes`` points, ``extent`` wide; u, v: (frames,) values
    of the X components (others 0); ke: (frames,) Global_Kinetic_Energy."""
    frames = len(times)
    with netCDF4.Dataset(str(path), "w", format="NETCDF3_64BIT_OFFSET") as ds:
        ds.createDimension("time_step", None)
        ds.createDimension("num_nodes", nodes)
        ds.createDimension("len_name", 33)
        ds.createVariable("time_whole", "f8", ("time_step",))[:] = np.asarray(times, float)
        rng = np.linspace(0.0, extent, nodes)
        for c in ("coordx", "coordy", "coordz"):
            ds.createVariable(c, "f8", ("num_nodes",))[:] = rng
        names, values = [], []
        for stem, series in (("Displacement", u), ("Velocity", v)):
            if series is not None:
                for a in "XYZ":
                    names.append(f"{stem}{a}")
                    vals = np.zeros((frames, nodes))
                    if a == "X":
                        vals[:] = np.asarray(series, float)[:, None]
                    values.append(vals)
        if names:
            ds.createDimension("num_nod_var", len(names))
            nv = ds.createVariable("name_nod_var", "S1", ("num_nod_var", "len_name"))
            nv[:] = netCDF4.stringtochar(np.array(names, dtype="S33"))
            for i, vals in enumerate(values, 1):
                ds.createVariable(f"vals_nod_var{i}", "f8", ("time_step", "num_nodes"))[:] = vals
        if ke is not None:
            ds.createDimension("num_glo_var", 1)
            gv = ds.createVariable("name_glo_var", "S1", ("num_glo_var", "len_name"))
            gv[:] = netCDF4.stringtochar(np.array(["Global_Kinetic_Energy"], dtype="S33"))
            ds.createVariable("vals_glo_var", "f8", ("time_step", "num_glo_var"))[:] = np.asarray(ke, float)[:, None]
    return path


# ------------------------------------------------------------------------------------------------
# The run summary
# ------------------------------------------------------------------------------------------------
def test_summary_of_a_clean_run_is_parsed_and_not_flagged():
    s = run_summary(CLEAN_STDERR)
    assert s.solvers == [("Solver", "Verlet", 371)] and s.done and s.wrote == ["quickstart.e"]
    assert s.energy[0]["pct"] == pytest.approx(0.3)
    assert summary_problems(s) == []


@pytest.mark.parametrize("stderr, cause", [(BLOWUP_STDERR, "blow_up"), (WARNING_STDERR, "blow_up"),
                                            (ZERO_STEPS_STDERR, "empty_run"), (NO_SOLVER_STDERR, "empty_run")])
def test_summary_of_a_bad_run_is_flagged(stderr, cause):
    flags = summary_problems(run_summary(stderr))
    assert flags and all(f.startswith("exit0_bad(") for f in flags)
    assert any(cause in f for f in flags), flags


# ------------------------------------------------------------------------------------------------
# The written Exodus file
# ------------------------------------------------------------------------------------------------
def test_small_displacements_and_velocities_are_clean(tmp_path):
    t = np.linspace(0.0, 1e-3, 5)
    path = fake_exodus(tmp_path / "out.e", t, u=1e-3 * t / t[-1], v=np.full(5, 1.0), ke=[0, 1e-3, 4e-3, 9e-3, 1.6e-2])
    assert exodus_growth(path) == []


@pytest.mark.parametrize("kind", ["u", "v", "ke"])
def test_explosive_growth_is_a_blow_up(tmp_path, kind):
    t = np.linspace(0.0, 1e-3, 5)
    data = {"u": {"u": [0, 1e-3, 1e2, 1e8, 1e30]}, "v": {"v": [0, 1.0, 1e6, 1e9, 1e12]},
            "ke": {"ke": [0, 1e-3, 1.0, 1e6, 1e12]}}[kind]
    flags = exodus_growth(fake_exodus(tmp_path / "out.e", t, **data))
    assert flags and all(f.startswith("exit0_bad(blow_up") for f in flags), flags


def test_a_load_the_mutation_scaled_up_widens_the_bounds(tmp_path):
    t = np.linspace(0.0, 1e-3, 5)
    path = fake_exodus(tmp_path / "out.e", t, u=[0, 1.0, 10.0, 100.0, 1e3])  # 1000 extents
    assert exodus_growth(path)
    assert exodus_growth(path, allowance=1e6) == []


def test_a_short_run_or_a_fallback_that_took_over_is_not_flagged():
    short = BLOWUP_STDERR.replace("371 steps", "2 steps")  # one step's energy off: no judgement
    assert summary_problems(run_summary(short)) == []
    fallback = ZERO_STEPS_STDERR.replace("Solver (Verlet): 0 steps", "Solver (QuasiStatic): 0 steps in 0.5 s\n"
                                         "Solver > Switch to Verlet (Verlet): 116 steps")
    assert summary_problems(run_summary(fallback)) == []


def test_only_the_first_frame_after_enough_steps_is_an_empty_run(tmp_path):
    path = fake_exodus(tmp_path / "out.e", [0.0], u=[0.0])
    flags, _ = run_exit0_problems(CLEAN_STDERR, [path], TREE)  # 371 steps, frequency 5: ~75 frames expected
    assert any("empty_run" in f for f in flags), flags
    rare = {**TREE, "Output": {**TREE["Output"], "Output Frequency": 1000}}  # 371 steps < 1000: one frame is right
    assert run_exit0_problems(CLEAN_STDERR, [path], rare)[0] == []


# ------------------------------------------------------------------------------------------------
# classify end to end on a fabricated case
# ------------------------------------------------------------------------------------------------
def _case(tmp_path: Path, kind: str = "none") -> tuple[Case, Prepared]:
    deck_path = tmp_path / "case" / "deck" / "d.yaml"
    deck_path.parent.mkdir(parents=True)
    deck_path.write_text("x: 1\n")
    out = tmp_path / "out"
    out.mkdir()
    deck = DeckInfo("examples/d.yaml", deck_path, "yaml", TREE, baseline=0)
    return Case(deck, Mutation(kind), "run"), Prepared(tmp_path, deck_path, out, {}, {"d.yaml"})


def test_classify_flags_a_blow_up_reported_as_success(tmp_path):
    case, prep = _case(tmp_path)
    t = np.linspace(0.0, 6e-5, 5)
    fake_exodus(prep.out / "out.e", t, u=[0, 1.0, 1e3, 1e9, 1e20])
    outcome = classify(case, prep, 0, BLOWUP_STDERR, 1.0, TREE)
    assert outcome.klass == "exit0_bad" and outcome.bad, outcome.flags
    assert any("blow_up" in f for f in outcome.flags)


def test_classify_flags_an_empty_run_reported_as_success(tmp_path):
    case, prep = _case(tmp_path)
    fake_exodus(prep.out / "out.e", np.linspace(0.0, 6e-5, 5), u=np.zeros(5))
    outcome = classify(case, prep, 0, NO_SOLVER_STDERR, 1.0, TREE)
    assert outcome.klass == "exit0_bad", outcome.flags


def test_classify_leaves_a_clean_run_clean(tmp_path):
    case, prep = _case(tmp_path)
    t = np.linspace(0.0, 6e-5, 5)
    fake_exodus(prep.out / "out.e", t, u=1e-4 * t / t[-1], v=np.full(5, 0.5), ke=[0, 1e-4, 4e-4, 9e-4, 1.6e-3])
    outcome = classify(case, prep, 0, CLEAN_STDERR, 1.0, TREE)
    assert outcome.klass == "exit0" and not outcome.bad, outcome.flags


def test_classify_flags_a_refused_unmutated_deck(tmp_path):
    case, prep = _case(tmp_path)
    outcome = classify(case, prep, 2, "error: d.yaml: Output: something\n", 1.0, TREE)
    assert outcome.klass == "refused_valid" and "refused_valid" in BAD_CLASSES


# ------------------------------------------------------------------------------------------------
# The new mutation classes are drawn
# ------------------------------------------------------------------------------------------------
def test_new_mutation_classes_reach_fallback_steps_and_families():
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    tree = {"Materials": {"M": {"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1e9, "Shear Modulus": 5e8}},
            "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": 1.0}},
            "Discretization": {"Type": "Exodus", "Input Mesh File": "m.g"},
            "Solver": {"Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": 2,
                                                           "Adaptive Load-Stepping": {"Switch to Verlet": {"Safety Factor": 0.6}}}},
            "Contact": {"Models": {"C": {"Contact Model": "Short Range Force", "Contact Radius": 0.1, "Spring Constant": 1e9}}}}
    deck = DeckInfo("examples/t.yaml", Path("/nonexistent/t.yaml"), "yaml", tree)
    seen_kinds, seen_paths, seen_families = set(), set(), set()

    @settings(max_examples=400, database=None, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
    @given(st.data())
    def draw(data):
        m = data.draw(mutations(deck, focus="run"))
        seen_kinds.add(m.kind)
        seen_paths.add(m.path)
        seen_families.add(family_of_case(tree, m))

    draw()
    assert {"delete_section", "nonfinite_anywhere", "long_string", "family_number", "step_size", "model_swap",
            "solver_choice"} <= seen_kinds, seen_kinds
    assert ("Solver", "QuasiStatic", "Adaptive Load-Stepping", "Switch to Verlet", "Fixed dt") in seen_paths
    assert ("Solver",) in seen_paths  # the whole Solver section removed
    assert {"contact", "adaptive_load_stepping", "viscoelastic", "pals", "plasticity", "correspondence"} <= seen_families
