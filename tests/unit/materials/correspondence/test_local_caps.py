"""Every local iteration of the correspondence materials has a cap, and a point whose update
fails stops the run (exit 3) with one line naming the material and the point (issue #19).

The Needleman deck with ``Flaw Magnitude: 1e6`` used to run for minutes: the yield stress went
negative, the plastic multiplier bisection of every point ran Peridigm's 100000 iterations at
every step without a root, and the failure was dropped. Now the flaw magnitude has its range
(exit 2), the bisection stops after MAX_BISECTION iterations with the same result as after
100000, and a bisection that finds no root but returns the stress anyway stops the run.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.deck.files import dump_yaml
from peridyn.materials.correspondence import bond_associated_kernels as BK
from peridyn.materials.correspondence import stress as S

K, G = 175.8e9, 105.5e9
SY = 460e6
# n, m, reference rate, eps0, eps1 of the Peridigm Needleman deck
N_EXP, M_EXP, RATE0, EPS0, EPS1 = 0.1, 0.01, 0.001, 0.00218, 0.436
NOFLAW = (False, np.zeros((1, 3)), 0.0, 0.0, 0.0, 1.0, 0.0)
SQ = math.sqrt(2.0 / 3.0)


def _g(lam, e, sr, n, m, dt):
    q = e / EPS1
    return (sr * math.pow(1.0 + e / EPS0, n)) / (1.0 + q * q) * math.pow(((SQ * lam) / dt) / RATE0, m)


def bisection(ebar, mq, eqps_n, sr, n, m, dt, steps):
    """Python transcription of the §5.5 bisection, run ``steps`` times at most: (λ, a, b, its, converged)."""
    a, b = 0.0, 1.0
    c = (a + b) / 2.0
    lam = 1.0
    for k in range(steps):
        fb = (ebar - b) - ((1.0 / 2.0) / G) * (SQ * _g(b, eqps_n + b, sr, n, m, dt) - mq)
        fc = (ebar - c) - ((1.0 / 2.0) / G) * (SQ * _g(c, eqps_n + c, sr, n, m, dt) - mq)
        if (fb > 0.0 and fc > 0.0) or (fb < 0.0 and fc < 0.0):
            b = c
        else:
            a = c
        old = c
        c = (a + b) / 2.0
        lam = c
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.float64(abs(lam - old)) / np.float64(abs(lam))
        if rel < 1.0e-6:
            return lam, a, b, k + 1, True
    return lam, a, b, steps, False


def test_a_bisection_without_a_root_stops_at_the_cap_and_the_point_is_reported():
    """A yield stress of -4.6e14 (flaw magnitude 1e6): f(λ) > 0 on all of [0, 1]. The bisection
    stops after MAX_BISECTION iterations at λ = 0; through the kernel the point is reported
    (status NO_ROOT), not silently returned to the yield value of λ = 0."""
    sr = SY * (1.0 - 1.0e6)
    lam, its, converged = S.needleman_plastic_multiplier(1e-4, 0.0, 0.0, sr, G, N_EXP, M_EXP, RATE0, EPS0, EPS1, 5e-9)
    assert (lam, its, converged) == (0.0, S.MAX_BISECTION, False)
    d = np.zeros((2, 9))
    d[:, 4] = 1e-3 / 5e-9 * 50.0  # a 5 % strain increment in one step: plastic at both points
    out, e1, vm = np.zeros((2, 9)), np.zeros(2), np.zeros(2)
    x = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]])  # point 0 at the flaw centre, point 1 far from it
    bad, status, elastic = S.needleman_stress_kernel(0, 2, d, np.zeros((2, 9)), np.zeros(2), 5e-9, K, G, SY, N_EXP, M_EXP, RATE0, EPS0, EPS1,
                                                     True, x, 0.0, 0.0, 0.0, 0.75, 1.0e6, out, e1, vm)
    assert (bad, status, elastic) == (0, S.NEEDLEMAN_NO_ROOT, 0)
    assert e1[1] > 0.0 and np.isfinite(out).all()  # the sound point got its ordinary update


def test_the_cap_gives_what_100000_iterations_give():
    """On [0, 1] in doubles the bisection stops within about 1100 iterations or sits at λ = 0,
    [a, b] = [0, 0] or [0, 5e-324], for good: MAX_BISECTION (2000) gives Peridigm's λ and flag, and the iteration
    count of every converged case is far below it."""
    rng = np.random.default_rng(19)
    stuck = converged = 0
    for _ in range(150):
        sr = float(rng.choice([1.0, -1.0])) * 10.0 ** rng.uniform(6.0, 12.0)
        m = float(rng.choice([0.0, 10.0 ** rng.uniform(-3.0, 0.0)]))
        dt = 10.0 ** rng.uniform(-9.0, -3.0)
        eqps_n = float(rng.uniform(0.0, 0.3))
        ebar = float(rng.choice([1.0, -1.0])) * 10.0 ** rng.uniform(-10.0, 0.5)
        mq = float(rng.integers(0, 2)) * 10.0 ** rng.uniform(3.0, 10.0)
        lam, its, ok = S.needleman_plastic_multiplier(ebar, mq, eqps_n, sr, G, N_EXP, m, RATE0, EPS0, EPS1, dt)
        ref = bisection(ebar, mq, eqps_n, sr, N_EXP, m, dt, S.MAX_BISECTION)
        assert (lam, its, ok) == (ref[0], ref[3], ref[4])
        if ok:
            converged += 1
            assert its <= 1100
        else:
            stuck += 1
            # λ = 0 with [a, b] = [0, 0] or [0, 5e-324]: a fixed point, every further iteration repeats this one
            assert lam == 0.0 and ref[1] == 0.0 and ref[2] <= 5e-324
            assert bisection(ebar, mq, eqps_n, sr, N_EXP, m, dt, S.MAX_BISECTION + 3)[:3] == ref[:3]
    assert stuck > 10 and converged > 10


def test_no_root_but_elastic_is_no_error():
    """m = 0, a trial state between σ_y and the hardened curve: no root, the step stays elastic
    (Peridigm prints a message and goes on), so the kernel counts it and reports no failure."""
    eqps_n = 0.05
    tau = 1.1 * SY / math.sqrt(3.0)
    sN = np.zeros((1, 9))
    sN[0, 1] = sN[0, 3] = tau
    d = np.zeros((1, 9))
    d[0, 1] = d[0, 3] = 0.5
    out, e1, vm = np.zeros((1, 9)), np.zeros(1), np.zeros(1)
    assert S.needleman_stress_kernel(0, 1, d, sN, np.array([eqps_n]), 1e-9, K, G, SY, N_EXP, 0.0, RATE0, EPS0, EPS1, *NOFLAW,
                                     out, e1, vm) == (-1, 0, 1)


def test_a_non_finite_update_is_reported():
    d = np.zeros((3, 9))
    d[1, 4] = np.nan
    out, e1, vm = np.zeros((3, 9)), np.zeros(3), np.zeros(3)
    bad, status, _ = S.needleman_stress_kernel(0, 3, d, np.zeros((3, 9)), np.zeros(3), 1e-9, K, G, SY, N_EXP, M_EXP, RATE0, EPS0, EPS1,
                                               *NOFLAW, out, e1, vm)
    assert (bad, status) == (1, S.NEEDLEMAN_NON_FINITE)


def test_a_nan_residual_of_the_bond_associated_return_is_not_taken_as_converged():
    """``while abs(f) > tol`` ended at once on a NaN residual and passed the NaN on as converged;
    now it runs to the cap and is reported like any other failure."""
    d = np.zeros(9)
    d[4] = np.nan
    *_, its = BK.stress_update(BK.POWER_LAW, np.zeros(9), d, 0.0, 1e-6, K, G, 300e6, 0.002, 0.2, 0.0)
    assert its == BK.MAX_NEWTON + 1


# ------------------------------------------------------------------------------------------------
# through the command line
# ------------------------------------------------------------------------------------------------
def deck(material: dict, strain_per_step: float = 1e-4) -> dict:
    """A 4 x 4 x 4 lattice (spacing 1), every point prescribed u_y = strain y (t/dt), 3 steps."""
    dt = 5e-9
    return {
        "Discretization": {"Type": "Shapes", "Shapes": {"Bar": {"Shape": "Box", "Block": "block_1", "Min": [0.0, 0.0, 0.0],
                                                                  "Max": [4.0, 4.0, 4.0], "Spacing": 1.0}}},
        "Materials": {"My Needleman": {
            "Material Model": "Viscoplastic Needleman Correspondence", "Density": 7800.0, "Young's Modulus": 211e9,
            "Poisson's Ratio": 0.0, "Hourglass Coefficient": 0.0, "Yield Stress": SY, "Strain Hardening Exponent": N_EXP,
            "Rate Hardening Exponent": M_EXP, "Reference Strain Rate": RATE0, "Reference Strain 0": EPS0, "Reference Strain 1": EPS1,
            "Enable Flaw": True, "Flaw Location X": 2.0, "Flaw Location Y": 2.0, "Flaw Location Z": 2.0, "Flaw Size": 1.5,
            "Flaw Magnitude": 0.2, **material,
        }},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "My Needleman", "Horizon": 2.015}},
        "Boundary Conditions": {
            f"U{c}": {"Type": "Prescribed Displacement", "Node Set": "Bar", "Coordinate": c,
                      "Value": f"{strain_per_step!r}*y*t/{dt!r}" if c == "y" else "0.0"}
            for c in "xyz"
        },
        "Solver": {"Final Time": 3 * dt, "Verlet": {"Fixed dt": dt}},
        "Output": {"Output Filename": "run", "Output Frequency": 1, "Output Variables": {"Von_Mises_Stress": True}},
    }


def _run(tmp_path, tree, command="run") -> int:
    (tmp_path / "d.yaml").write_text(dump_yaml(tree))
    args = [command, str(tmp_path / "d.yaml")]
    if command == "run":
        args += ["--output-dir", str(tmp_path), "-q", "--no-progress"]
    return main(args)


def test_the_small_needleman_deck_runs(tmp_path):
    assert _run(tmp_path, deck({}, strain_per_step=2e-3)) == ExitCode.OK


@pytest.mark.parametrize(("key", "value"), [
    ("Flaw Magnitude", 1.0e6), ("Flaw Magnitude", -0.5), ("Rate Hardening Exponent", -0.01), ("Strain Hardening Exponent", -1.0),
])
def test_out_of_range_parameters_are_one_input_error(tmp_path, capsys, key, value):
    assert _run(tmp_path, deck({key: value}), "check") == ExitCode.INPUT_ERROR
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and key in err[0], err


def test_a_flaw_magnitude_is_not_read_without_the_flaw(tmp_path):
    assert _run(tmp_path, deck({"Enable Flaw": False, "Flaw Magnitude": 1.0e6}), "check") == ExitCode.OK


def test_a_point_without_a_plastic_solution_stops_the_run_naming_it(tmp_path, capsys):
    """90 % compression in one step (d dt = -9): f(1) > 0, the bisection on [0, 1] has no root;
    the run ends at the first step with exit 3 and one line naming the material and a point."""
    assert _run(tmp_path, deck({}, strain_per_step=-0.9)) == ExitCode.UNSTABLE
    err = capsys.readouterr().err
    line = next(ln for ln in err.splitlines() if "bisection" in ln)
    assert "Viscoplastic Needleman Correspondence 'My Needleman'" in line and "point " in line and "x = (" in line
