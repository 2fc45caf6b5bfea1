"""``extreme-cases``: stiff and extreme decks run as ``peridyn run`` in a subprocess, each outcome
classified as converged (exit 0 and the answer checks out), diagnosed (exit 2 or 3 with one
clear message) or FAIL (exit 0 with a wrong or non-finite answer, NaN in the output, exit 1, a
crash or a hang)."""
from __future__ import annotations

import math
import os
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .base import Check, Measurement, Problem

CONVERGED, DIAGNOSED, FAIL = "converged", "diagnosed", "FAIL"
#: wall-time limit of one ``peridyn run`` (s): past it the case is a hang
TIMEOUT = 120.0
#: largest worst-time energy balance error (% of the run's energy scale) of the finer run of a
#: converged dynamic case. Velocity Verlet's error is bounded and O(dt^2): on these impacts it
#: is 6 .. 19 % at the set-up estimate (19 % at K/G = 1: the estimate ignores G), 1.3 .. 4 % at
#: half of it and 0.3 .. 1 % at a quarter, where the finer run is; 5 % leaves a factor of five
BALANCE_PCT = 5.0
#: largest relative difference of two runs that must agree to rounding (scaled geometry, units)
SCALE_RTOL = 1.0e-6

_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|[-+]?inf|nan"
_ENERGY = re.compile(rf"^\s+energy: .*?balance error (?P<err>{_NUM}) \((?P<pct>{_NUM})% of the energy scale, worst (?P<worst>{_NUM})%\)", re.M)
_STEPS = re.compile(r"^\S.*? \([\w ]+\): (?P<steps>\d+) steps in", re.M)


@dataclass
class RunResult:
    """What one ``peridyn run`` of a case did."""

    rc: int | None  #: exit status; None for a run stopped at the time limit
    stderr: str
    wall: float
    outputs: dict[str, np.ndarray] = field(default_factory=dict)  #: nodal variables, (frames, points) each
    times: np.ndarray | None = None
    coords: np.ndarray | None = None
    read_error: str = ""

    @property
    def steps(self) -> int:
        return sum(int(m["steps"]) for m in _STEPS.finditer(self.stderr))

    def balance_pct(self) -> float | None:
        """The largest "worst" energy balance error of the run's solvers (% of the energy
        scale), None when the summary has none (a quasi-static solver)."""
        found = [max(float(m["pct"]), float(m["worst"])) for m in _ENERGY.finditer(self.stderr)]
        return max(found) if found else None

    def vec(self, name: str) -> np.ndarray:
        """The vector field ``name`` at every frame, (frames, points, 3)."""
        return np.stack([self.outputs[name + c] for c in "XYZ"], axis=-1)


@dataclass
class Outcome:
    """The classification of one case."""

    outcome: str  #: CONVERGED, DIAGNOSED or FAIL
    why: str  #: one line: the answer and its bound, the diagnosis, or what is wrong
    answer: float | None = None


def error_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("error:")]


def nonfinite(outputs: dict[str, np.ndarray]) -> list[str]:
    return [name for name, v in outputs.items() if not np.all(np.isfinite(v))]


def classify_one(res: RunResult) -> Outcome | None:
    """The outcome of one run when it is not exit 0 with finite, readable output (a diagnosis or
    a failure); None when its answer is to be judged."""
    if res.rc is None:
        return Outcome(FAIL, f"hang: no exit within {TIMEOUT:g} s")
    bad = nonfinite(res.outputs)
    if "Traceback" in res.stderr:
        return Outcome(FAIL, f"exit {res.rc} with a traceback: {_last(res.stderr)}")
    if res.rc in (2, 3):
        lines = error_lines(res.stderr)
        if bad:
            return Outcome(FAIL, f"exit {res.rc}, but non-finite values in the output ({', '.join(bad[:3])})")
        if len(lines) != 1:
            return Outcome(FAIL, f"exit {res.rc} with {len(lines)} error lines instead of one: {_last(res.stderr)}")
        return Outcome(DIAGNOSED, f"exit {res.rc}: {lines[0][len('error:'):].strip()}")
    if res.rc != 0:
        return Outcome(FAIL, f"exit {res.rc}: {_last(res.stderr)}")
    if res.read_error:
        return Outcome(FAIL, f"exit 0, but the output cannot be read: {res.read_error}")
    if not res.outputs:
        return Outcome(FAIL, "exit 0, but no output was written")
    if bad:
        return Outcome(FAIL, f"exit 0 with non-finite values in the output ({', '.join(bad[:3])})")
    return None


def classify(runs: list[RunResult], judge: Callable[[list[RunResult]], tuple[bool, float | None, str]] | None) -> Outcome:
    """The outcome of a case's ``runs``: the first FAIL among them, else the first diagnosis,
    else ``judge(runs) -> (right, answer, why)`` on their (finite) outputs."""
    single = [classify_one(r) for r in runs]
    for o in single:
        if o is not None and o.outcome == FAIL:
            return o
    for o in single:
        if o is not None:
            return o
    if judge is None:
        return Outcome(CONVERGED, "exit 0, finite output")
    right, answer, why = judge(runs)
    return Outcome(CONVERGED if right else FAIL, f"exit 0; {why}" if right else f"exit 0 with a wrong answer: {why}", answer)


def _last(text: str) -> str:
    lines = [line for line in text.strip().splitlines() if line.strip()]
    return lines[-1][:300] if lines else "(no output)"


def run_deck(tree: dict[str, Any], directory: Path, files: dict[str, str] | None = None, timeout: float = TIMEOUT,
             launcher: Sequence[str] = ()) -> RunResult:
    """Write ``tree`` (and ``files``) into ``directory`` and run ``peridyn run`` on it in a
    subprocess (after ``launcher``, e.g. ``mpiexec -n 2``); read the Exodus output ``out.e``
    when there is one."""
    from ...deck.files import dump_yaml

    directory.mkdir(parents=True, exist_ok=True)
    for name, text in (files or {}).items():
        (directory / name).write_text(text, encoding="utf-8")
    deck = directory / "deck.yaml"
    deck.write_text(dump_yaml(tree), encoding="utf-8")
    from ...parallel.comm import without_launcher

    env = dict(without_launcher(dict(os.environ)), PERIDYN_NO_PROGRESS="1")  # under `mpiexec peridyn verify` too
    t0 = time.perf_counter()
    try:
        p = subprocess.run([*launcher, sys.executable, "-m", "peridyn", "run", str(deck), "--output-dir", str(directory), "--no-progress"],
                           capture_output=True, text=True, timeout=timeout, cwd=directory, env=env)
        rc, stderr = p.returncode, p.stderr
    except subprocess.TimeoutExpired as exc:
        rc, stderr = None, (exc.stderr or b"").decode("utf-8", "replace") if isinstance(exc.stderr, bytes) else (exc.stderr or "")
    res = RunResult(rc, stderr, time.perf_counter() - t0)
    out = directory / "out.e"
    if out.exists():
        try:
            from ...io.exodus_reader import read_results

            r = read_results(out)
            res.outputs, res.times, res.coords = dict(r["nodal"]), np.asarray(r["times"]), np.asarray(r["coords"])
        except Exception as exc:  # noqa: BLE001 - an unreadable output is the case's failure
            res.read_error = f"{type(exc).__name__}: {exc}"
    return res


# -- decks -----------------------------------------------------------------------------------
def _output(frequency: int, extra: dict[str, bool] | None = None) -> dict[str, Any]:
    return {"Output File Type": "ExodusII", "Output Filename": "out", "Output Frequency": int(frequency),
            "Output Variables": {"Displacement": True, "Velocity": True, **(extra or {})}}


def _ids(n: tuple[int, int, int], where) -> str:
    """Inline node set (1-based) of a PdQuickGrid box of ``n`` points per direction whose
    lattice index (i, j, k) satisfies ``where``; PdQuickGrid numbers x fastest."""
    nx, ny, nz = n
    k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    i, j, k = i.ravel(), j.ravel(), k.ravel()
    return " ".join(str(g + 1) for g in np.nonzero(where(i, j, k))[0])


Deck = tuple[dict[str, Any], "dict[str, str] | None"]
Judge = Callable[[list[RunResult]], tuple[bool, "float | None", str]]


@dataclass
class Case:
    """The decks one case runs (in order) and the check of their answer."""

    decks: list[Deck]
    judge: Judge | None


def impact_deck(material: dict[str, Any], *, n: int, spacing: float, ratio: float = 3.015, speed: float = 1.0,
                steps: int = 120, safety: float = 0.5, final_steps: float | None = None) -> dict[str, Any]:
    """A cube of n^3 points whose x = max face starts at -``speed``, run with a fixed step of
    ``safety`` times the set-up estimate (computed here) to ``final_steps`` (default ``steps``
    + 0.25) such steps: floor() gives ``steps`` exactly."""
    from ...testing import build_simulation, cube_deck

    tree = cube_deck(material, n=n, spacing=spacing, horizon_factor=ratio)
    dt = build_simulation(tree).critical_time_step() * safety
    tree["Boundary Conditions"] = {
        "Impact Node Set": _ids((n, n, n), lambda i, j, k: i == n - 1),
        "Impact": {"Type": "Initial Velocity", "Node Set": "Impact Node Set", "Coordinate": "x", "Value": repr(-speed)},
    }
    final = ((steps + 0.25) if final_steps is None else final_steps) * dt
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": final, "Verlet": {"Fixed dt": dt}}
    tree["Output"] = _output(steps)
    return tree


#: the two steps of a dynamic case (times the set-up estimate) and the steps of the first
SAFETY = (0.5, 0.25)
STEPS = 120
#: the energy error of velocity Verlet is O(dt^2): halving the step must divide it by at least
#: this (4 for a converged O(dt^2) error; measured 3.9 .. 4.3 on these impacts)
HALVING_GAIN = 2.5
#: below this balance error (% of the energy scale) the account is exact to rounding: no ratio asked
FLOOR_PCT = 1.0e-6


def impact_pair(material: dict[str, Any], n: int, ratio: float = 3.015) -> list[Deck]:
    return [(impact_deck(material, n=n, spacing=H, ratio=ratio, steps=STEPS * k, safety=s, final_steps=STEPS * k + 0.25 * k), None)
            for k, s in ((1, SAFETY[0]), (2, SAFETY[1]))]


def balance_judge(runs: list[RunResult]) -> tuple[bool, float | None, str]:
    """Two runs of the same motion at dt and dt/2: both moved, the finer one's energy account
    closes within BALANCE_PCT and the error falls by HALVING_GAIN or more (it is velocity
    Verlet's O(dt^2) error, not a force that does work it should not)."""
    coarse, fine = runs
    p1, p2 = coarse.balance_pct(), fine.balance_pct()
    if p1 is None or p2 is None:
        return False, None, "no energy account in the run summary"
    if not np.abs(fine.vec("Displacement")[-1]).max() > 0:
        return False, p2, "nothing moved"
    gain = p1 / p2 if p2 > 0 else math.inf
    ok = p2 <= BALANCE_PCT and (p2 <= FLOOR_PCT or gain >= HALVING_GAIN)
    return ok, p2, (f"energy balance error (worst, % of the energy scale) {p1:.2g} % at dt = {SAFETY[0]:g} x the estimate, "
                    f"{p2:.2g} % at dt/2 (bound {BALANCE_PCT:g} %), falling {gain:.3g} times (bound >= {HALVING_GAIN:g}); "
                    f"{coarse.steps} + {fine.steps} steps")


def scale_judge(reference: Callable[[], RunResult], scale: float, what: str) -> Judge:
    """The run's final displacements divided by ``scale`` must be the reference run's."""

    def judge(runs: list[RunResult]) -> tuple[bool, float | None, str]:
        res, ref_run = runs[0], reference()
        if ref_run.rc != 0 or not ref_run.outputs:
            return False, None, "the reference run did not finish"
        u, ref = res.vec("Displacement")[-1] / scale, ref_run.vec("Displacement")[-1]
        if u.shape != ref.shape or len(res.times) != len(ref_run.times):
            return False, None, f"{u.shape[0]} points, {len(res.times)} frames against the reference's {ref.shape[0]}, {len(ref_run.times)}"
        err = float(np.abs(u - ref).max() / max(np.abs(ref).max(), 1e-300))
        return err <= SCALE_RTOL, err, f"max |u/{what} - u_ref| / max |u_ref| = {err:.2g} (bound {SCALE_RTOL:g}), {res.steps} steps"

    return judge


# -- the problem -----------------------------------------------------------------------------
G = 1.0e9  # Pa, shear modulus of the K/G ladder
RHO = 1000.0  # kg/m^3
H = 1.0e-3  # m, spacing of the small cubes
LPS = {"Material Model": "Elastic", "Density": RHO, "Bulk Modulus": 1.0e9, "Shear Modulus": 0.6e9}
REFERENCE = "impact, horizon 3.015 mm (reference)"
PLATE = "brittle plate (quickstart), Safety Factor 1.5"


class ExtremeCases(Problem):
    name = "extreme-cases"
    title = "Stiff and extreme decks: a converged answer or a clear diagnosis"
    kind = "table"
    plotted = False  # an outcome per case, no error
    computes = (
        "Each case is a small deck written here and run as `peridyn run` in a subprocess (time limit "
        f"{TIMEOUT:g} s); its outcome is classified. Cubes of n^3 points (n = 5 with --quick, 7 otherwise), "
        "spacing 1 mm, horizon 3.015 spacings, LPS `Elastic` (rho = 1000 kg/m^3; K = 1 GPa, G = 0.6 GPa unless "
        f"the case says), the x = max face started at -1 m/s (an impact: every mode excited), velocity Verlet with "
        f"a fixed step of {SAFETY[0]:g} times the set-up estimate for {STEPS} steps, then again at half that step "
        f"for {2 * STEPS} steps (the dynamic cases run twice). Cases: K/G = 1, 10, 100, 1000 (G = 1 GPa); contact: "
        "two such boxes (spacing 1 mm, 0.2 mm apart, offset 0.5 mm sideways, no bonds between them) closing at "
        "2 x 5 m/s with `Short Range Force` springs (contact radius 0.8 mm) of 1, 100 and 1000 times K, "
        f"`Safety Factor` {SAFETY[0]:g} then {SAFETY[1]:g} of Peridigm's estimate (which ignores contact); "
        "horizon/spacing 1.01 and 6 (on a cube of at least 7^3 points, the horizon inside the body); the quickstart's brittle plate at `Safety Factor` 1.5 (it once "
        "finished with a 6.6 % energy error and more damage than at 1.0: its stable limit, measured on the model, is "
        "1.49 times the estimate, so it must be refused); 50 % compression: a bar of 3n x n x n points whose end grips (one horizon "
        "thick) are moved together by 50 % of its length by prescribed displacement in 20 quasi-static load "
        "steps; an isolated point (one point 10 horizons from a cube, the whole model given 1 m/s along x); "
        "the impact (one run) with every length and time scaled to a horizon of 1e-6 m and 1e3 m; the impact "
        "written in mm-tonne-s (lengths in mm, density in t/mm^3, moduli in MPa, velocity in mm/s)."
    )
    reference = (
        "Outcomes: `converged` (exit 0, every output value finite, and the case's answer checks out), "
        "`diagnosed` (exit 2 for bad input or 3 for a run stopped as unstable or unconverged, exactly one "
        "`error:` line, no traceback, nothing non-finite written), `FAIL` otherwise (exit 0 with a wrong or "
        f"non-finite answer, exit 1, a crash, a hang past {TIMEOUT:g} s); any FAIL row fails the command. "
        "Answers: a dynamic case's energy account (kinetic + stored against the work done; exact for the "
        "continuous motion) carries velocity Verlet's bounded O(dt^2) error, so the finer run's worst error must "
        f"be below {BALANCE_PCT:g} % of the energy scale and halving the step must divide it by {HALVING_GAIN:g} "
        "or more (4 in theory; a force that does spurious work, or a blow-up, gives an error that does not fall); "
        "the contact cases must also touch and keep their total x-momentum (1e-6); the scaled decks: "
        "peridynamics has no length scale of its own, so x -> s x, t -> s t (same K, G, rho, velocity) maps a "
        f"solution to one with u -> s u: the final displacements / s must match the reference run's (the "
        f"first run of `{REFERENCE}`) to {SCALE_RTOL:g} (rounding); mm-tonne-s: the same displacements "
        "times 1000 (1 N = 1 t mm/s^2, 1 MPa = 1 N/mm^2), same bound; the isolated point: a rigid "
        "translation, u = v t at every point to 1e-9; 50 % compression: the gauge section between the grips "
        "shortened by 50 % +- 10 % with the points keeping their order along x (no interpenetration)."
    )
    resolution_name = "n"
    size_name = "-"
    error_name = "-"
    KG = (1, 10, 100, 1000)
    CONTACT = (1, 100, 1000)
    methods = (*(f"K/G = {r}" for r in KG), *(f"contact k = {r} K" for r in CONTACT), "horizon/spacing 1.01", "horizon/spacing 6",
               PLATE, "50 % compression", "isolated point", REFERENCE, "impact, horizon 1e-6 m", "impact, horizon 1e3 m", "impact in mm-tonne-s")

    def __init__(self) -> None:
        self._reference: dict[int, RunResult] = {}
        self._tmpdir: tempfile.TemporaryDirectory | None = None

    @property
    def _tmp(self) -> tempfile.TemporaryDirectory:
        """The folder the cases run in (made on first use, removed with the problem)."""
        if self._tmpdir is None:
            self._tmpdir = tempfile.TemporaryDirectory(prefix="peridyn-verify-extreme-")
        return self._tmpdir

    def ladder(self, method: str, quick: bool) -> list[float]:
        return [5.0] if quick else [7.0]

    def run_case(self, method: str, n: int) -> tuple[Outcome, list[RunResult]]:
        case = self.case(method, n)
        directory = Path(self._tmp.name) / re.sub(r"[^\w.]+", "_", method) / str(n)
        runs = []
        for i, (tree, files) in enumerate(case.decks):
            runs.append(run_deck(tree, directory / str(i), files))
            if classify_one(runs[-1]) is not None:  # diagnosed or failed: the rest would say no more
                break
        if method == REFERENCE:
            self._reference[n] = runs[0]
        return classify(runs, case.judge), runs

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        out, runs = self.run_case(method, int(resolution))
        values = {"outcome": out.outcome, "exit": ", ".join(str(r.rc) for r in runs), "answer": out.answer, "detail": out.why,
                  "wall (s)": sum(r.wall for r in runs)}
        return Measurement(None, steps=sum(r.steps for r in runs), values=values)

    def reference_run(self, n: int) -> RunResult:
        if n not in self._reference:
            tree, files = self.case(REFERENCE, n).decks[0]
            self._reference[n] = run_deck(tree, Path(self._tmp.name) / "reference" / str(n), files)
        return self._reference[n]

    def case(self, method: str, n: int) -> Case:
        """The decks and answer check of the case ``method`` at size ``n``."""
        if method.startswith("K/G = "):
            mat = {"Material Model": "Elastic", "Density": RHO, "Bulk Modulus": float(method.split("= ")[1]) * G, "Shear Modulus": G}
            return Case(impact_pair(mat, n), balance_judge)
        if method.startswith("contact k = "):
            k = float(method.split("= ")[1].split()[0]) * LPS["Bulk Modulus"]
            return Case([(contact_deck(k, n, s), None) for s in SAFETY], contact_judge)
        if method.startswith("horizon/spacing "):
            ratio = float(method.split()[-1])
            # the horizon inside the body: a 5^3 cube within 6 spacings of every point has its
            # stable limit at 0.97 times the estimate (surface-stiffened modes), and Verlet's
            # energy error at half the estimate reaches 53 % (a warning names the step that gives 1 %)
            return Case(impact_pair(LPS, max(n, int(math.ceil(ratio)) + 1), ratio), balance_judge)
        if method == PLATE:
            return Case([(brittle_plate(1.5), None)], lambda runs: (False, None, "finished above the plate's measured stable limit"))
        if method == "50 % compression":
            return compression_case(n)
        if method == "isolated point":
            return isolated_case(n)
        if method == REFERENCE:
            return Case(impact_pair(LPS, n), balance_judge)
        if method.startswith("impact, horizon "):
            scale = float(method.split()[-2]) / (3.015 * H)
            return Case([(scaled_impact(n, scale), None)], scale_judge(lambda: self.reference_run(n), scale, "s"))
        if method == "impact in mm-tonne-s":
            return Case([(mm_impact(n), None)], scale_judge(lambda: self.reference_run(n), 1.0e3, "1000"))
        raise KeyError(method)

    def checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        out = []
        for p in points:
            o = p["values"].get("outcome", FAIL)
            ok = o in (CONVERGED, DIAGNOSED)
            what = f"outcome at n = {p['resolution']:g}" + ("" if ok else f" ({p['values'].get('detail', 'no detail')})")
            out.append(Check(self.name, method, what, 1.0 if ok else 0.0, low=1.0, shown=o, expect="converged or diagnosed"))
        return out


# -- the cases' decks ------------------------------------------------------------------------
def contact_deck(k: float, n: int, safety: float) -> dict[str, Any]:
    """Two boxes of n^3 points (spacing 1 mm, LPS) 0.2 mm apart along x closing at 2 x 5 m/s,
    `Short Range Force` springs of constant ``k`` (contact radius 0.8 mm), Verlet at ``safety``
    times Peridigm's estimate."""
    from ...testing import build_simulation

    L, gap = n * H, 0.2 * H
    tree = {
        "Discretization": {
            "Type": "Shapes", "Omit Bonds Between Blocks": "All",
            "Shapes": {
                "Left": {"Shape": "Box", "Block": "block_1", "Min": [0.0, 0.0, 0.0], "Max": [L, L, L], "Spacing": H},
                "Right": {"Shape": "Box", "Block": "block_2", "Min": [L + gap, 0.5 * H, 0.0], "Max": [2 * L + gap, L + 0.5 * H, L], "Spacing": H},
            },
        },
        "Materials": {"M": dict(LPS)},
        "Blocks": {"All": {"Block Names": "block_1 block_2", "Material": "M", "Horizon": 3.015 * H}},
    }
    dt = build_simulation(tree).critical_time_step() * safety
    tree["Contact"] = {"Search Radius": 2.0 * H, "Search Frequency": 5,
                       "Models": {"Springs": {"Contact Model": "Short Range Force", "Contact Radius": 0.8 * H, "Spring Constant": k,
                                              "Friction Coefficient": 0.0}}}
    tree["Boundary Conditions"] = {
        "Push": {"Type": "Initial Velocity", "Node Set": "Left", "Coordinate": "x", "Value": "5.0"},
        "Pull": {"Type": "Initial Velocity", "Node Set": "Right", "Coordinate": "x", "Value": "-5.0"},
    }
    # the nearest points (1.3 mm apart) reach the contact radius after 0.5 mm / 10 m/s; then
    # four P-wave crossings of a box (c_P about 1.34 km/s) to push them apart
    c_p = math.sqrt((LPS["Bulk Modulus"] + 4 * LPS["Shear Modulus"] / 3) / RHO)
    final = 0.6 * H / 10.0 + 4.0 * L / c_p
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": final, "Verlet": {"Safety Factor": safety}}
    tree["Output"] = _output(max(1, int(final / dt) // 20), {"Contact_Force_Density": True})
    return tree


def contact_judge(runs: list[RunResult]) -> tuple[bool, float | None, str]:
    ok, pct, why = balance_judge(runs)
    if pct is None:
        return ok, pct, why
    fine = runs[-1]
    if "Contact_Force_DensityX" not in fine.outputs or not np.abs(fine.vec("Contact_Force_Density")).max() > 0:
        return False, pct, f"the boxes never touched; {why}"
    v = fine.vec("Velocity")[-1][:, 0]
    p = abs(float(v.sum())) / max(float(np.abs(v).sum()), 1e-300)
    if p > 1e-6:
        return False, pct, f"x-momentum not kept ({p:.2g} of sum |v|); {why}"
    return ok, pct, f"touched, momentum kept ({p:.1g}); {why}"


def compression_case(n: int) -> Case:
    """A bar of 3n x n x n points (LPS, spacing 1 mm) whose grips (one horizon thick at both x
    ends) are moved together by half the bar's length, quasi-statically in 20 load steps."""
    from ...testing import cube_deck

    nx, ratio = 3 * n, 3.015
    grip = int(math.ceil(ratio))
    tree = cube_deck(LPS, shape=(nx, n, n), spacing=H, horizon_factor=ratio)
    x0, x1 = 0.5 * H, (nx - 0.5) * H  # first and last point planes
    xc = 0.5 * (x0 + x1)
    tree["Boundary Conditions"] = {
        "Grips Node Set": _ids((nx, n, n), lambda i, j, k: (i < grip) | (i >= nx - grip)),
        "Squeeze": {"Type": "Prescribed Displacement", "Node Set": "Grips Node Set", "Coordinate": "x", "Value": f"-0.5*(x-{xc!r})*t"},
    }
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0,
                      "QuasiStatic": {"Number of Load Steps": 20, "Relative Tolerance": 1.0e-8, "Maximum Solver Iterations": 30}}
    tree["Output"] = _output(20)

    def judge(runs: list[RunResult]) -> tuple[bool, float | None, str]:
        res = runs[0]
        X = res.coords[:, 0]
        x = X + res.vec("Displacement")[-1][:, 0]
        inner = (X > x0 + (grip - 0.5) * H) & (X < x1 - (grip - 0.5) * H)  # the gauge: between the grips
        lo, hi = X[inner].min(), X[inner].max()
        strain = float((x[X == hi].mean() - x[X == lo].mean()) / (hi - lo) - 1.0)
        order = np.lexsort((X, res.coords[:, 2], res.coords[:, 1]))  # lattice lines along x
        ordered = bool(np.all(np.diff(x[order].reshape(-1, nx), axis=1) > 0))
        ok = ordered and abs(strain + 0.5) <= 0.1
        return ok, strain, (f"gauge strain {strain:.3f} (bound -0.5 +- 0.1), the points {'keep' if ordered else 'do NOT keep'} their "
                            "order along x")

    return Case([(tree, None)], judge)


def isolated_case(n: int) -> Case:
    """A Text File mesh: a cube of n^3 points (spacing 1 mm) and one point 10 horizons away; the
    whole model starts at 1 m/s along x (a rigid translation): u = v t everywhere."""
    from ...testing import build_simulation, cube_deck

    g = (np.arange(n) + 0.5) * H
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    x = np.vstack([x, [[n * H + 10 * 3.015 * H, 0.5 * H, 0.5 * H]]])
    text = "# x y z block volume\n" + "\n".join(f"{a!r} {b!r} {c!r} 1 {H**3!r}" for a, b, c in x.tolist()) + "\n"
    tree: dict[str, Any] = {
        "Discretization": {"Type": "Text File", "Input Mesh File": "points.txt"},
        "Materials": {"M": dict(LPS)},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": 3.015 * H}},
        "Boundary Conditions": {"All Node Set": " ".join(str(i + 1) for i in range(len(x))),
                                "Move": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "x", "Value": "1.0"}},
    }
    dt = build_simulation(cube_deck(LPS, n=n, spacing=H)).critical_time_step()  # the lone point sets no limit
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": (STEPS + 0.25) * dt, "Verlet": {"Fixed dt": dt}}
    tree["Output"] = _output(STEPS)

    def judge(runs: list[RunResult]) -> tuple[bool, float | None, str]:
        res = runs[0]
        u = res.vec("Displacement")[-1]
        expect = np.zeros_like(u)
        expect[:, 0] = 1.0 * res.times[-1]
        err = float(np.abs(u - expect).max() / max(abs(res.times[-1]), 1e-300))
        return err <= 1e-9, err, f"max |u - v t| / (v t) = {err:.2g} (bound 1e-9) over {len(u)} points, {res.steps} steps"

    return Case([(tree, {"points.txt": text})], judge)


def brittle_plate(safety: float) -> dict[str, Any]:
    """The quickstart (examples/quickstart.yaml): a 60 x 30 x 3 mm glass plate (60 x 30 x 3 points,
    LPS, critical stretch 0.0015) whose three end columns are pulled apart at 5 m/s each, to
    60 us, at ``safety`` times the set-up estimate."""
    from ...testing import cube_deck

    glass = {"Material Model": "Elastic", "Density": 2440.0, "Young's Modulus": 72.0e9, "Poisson's Ratio": 0.22}
    tree = cube_deck(glass, shape=(60, 30, 3), spacing=1.0e-3, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 0.0015})
    shape = (60, 30, 3)
    tree["Boundary Conditions"] = {
        "Left Node Set": _ids(shape, lambda i, j, k: i < 3),
        "Right Node Set": _ids(shape, lambda i, j, k: i > 56),
        "Pull Left": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": "x", "Value": "-5.0*t"},
        "Pull Right": {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "x", "Value": "5.0*t"},
    }
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 6.0e-5, "Verlet": {"Safety Factor": safety}}
    tree["Output"] = _output(50)
    return tree


def scaled_impact(n: int, scale: float) -> dict[str, Any]:
    """The reference run's impact with every length and time multiplied by ``scale``."""
    ref = impact_pair(LPS, n)[0][0]
    tree = impact_deck(LPS, n=n, spacing=H * scale, steps=STEPS)
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": ref["Solver"]["Final Time"] * scale,
                      "Verlet": {"Fixed dt": ref["Solver"]["Verlet"]["Fixed dt"] * scale}}
    return tree


def mm_impact(n: int) -> dict[str, Any]:
    """The reference run's impact in mm-tonne-s: lengths in mm, density in t/mm^3 (1 kg/m^3 =
    1e-12 t/mm^3), moduli in MPa, velocity in mm/s; times unchanged."""
    ref = impact_pair(LPS, n)[0][0]
    mat = {"Material Model": "Elastic", "Density": RHO * 1e-12, "Bulk Modulus": LPS["Bulk Modulus"] * 1e-6,
           "Shear Modulus": LPS["Shear Modulus"] * 1e-6}
    tree = impact_deck(mat, n=n, spacing=H * 1e3, speed=1.0e3, steps=STEPS)
    tree["Solver"] = dict(ref["Solver"])
    return tree
