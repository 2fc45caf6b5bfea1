"""``static-modulus``: Young's modulus measured by Peridigm's tensile test
(:mod:`peridyn.testing.tensile`) for ``Elastic Correspondence`` and LPS ``Elastic``, against the
continuum modulus and, for LPS, against its known lattice and surface errors."""
from __future__ import annotations

import tempfile
import time
from typing import Any

from .base import Check, Measurement, Problem
from .lattice import interior_checks, interior_values
from ...engine.run_services import RunServices
from ...engine.session import run_sections

K, MU = 160.0e9, 80.0e9  # Pa
E0 = 9.0 * K * MU / (3.0 * K + MU)  # Pa, 205.7 GPa
HORIZON = 1.0e-3  # m
STRAIN = 0.005
MATERIALS: dict[str, dict[str, Any]] = {
    "Elastic Correspondence": {"Material Model": "Elastic Correspondence", "Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": MU,
                               "Hourglass Coefficient": 0.02},
    "Elastic": {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": MU},
}
#: Newton on the assembled tangent (correspondence) or Jacobian-free Newton-Krylov (LPS, whose
#: tangent couples points two horizons apart and grows fast with the ratio)
NEWTON = {"Initial Time": 0.0, "Final Time": 1.0,
          "QuasiStatic": {"Number of Load Steps": 1, "Relative Tolerance": 1.0e-8, "Maximum Solver Iterations": 10}}
MATRIX_FREE = {
    "Initial Time": 0.0, "Final Time": 1.0, "Peridigm Preconditioner": "None",
    "NOXQuasiStatic": {
        "Nonlinear Solver": "Line Search Based", "Number of Load Steps": 1, "Max Solver Iterations": 10, "Relative Tolerance": 1.0e-8,
        "Line Search": {"Method": "Full Step"},
        "Direction": {"Method": "Newton", "Newton": {"Linear Solver": {"Jacobian Operator": "Matrix-Free", "Preconditioner": "None"}}},
    },
}


def lps_prediction(ratio: float, points_across: int) -> float:
    """The LPS bar's modulus (Pa): the infinite prism of the same section (``points_across``
    squared points) from the bond sums of its truncated families
    (:func:`~peridyn.verify.problems.prism.prismatic_bar_modulus`): the lattice's error and the
    surface layer's, neither fitted to the model's runs."""
    from .prism import prismatic_bar_modulus

    return prismatic_bar_modulus(K, MU, ratio, points_across)


class StaticModulus(Problem):
    name = "static-modulus"
    title = "Young's modulus from a tensile test"
    peridigm = (
        {"method": "Elastic Correspondence", "error": 0.0082, "wall (s)": 362.7,
         "what": "Peridigm's own tensile_test example (dog-bone, 12,625 points, Elastic Correspondence, 4 load steps): "
                 "E = 178.5 GPa against the 180.0 GPa its moduli imply, one core of an AMD EPYC, 2026-11-27 "
                 "(../shared/benchmarks/README.md); peridyn ran that deck in 49.8 s on the same machine"},
    )
    computes = (
        "Peridigm's tensile test on a straight lattice bar (`peridyn.testing.tensile`): square section of about two "
        "horizons (n points across, n odd), gauge section 4 horizons, grips 2 horizons long pulled apart by "
        f"u_y = y * {STRAIN:g} * t, horizon 1 mm, K = 160 GPa, G = 80 GPa (E0 = {E0 / 1e9:.1f} GPa), one quasi-static load "
        "step (Newton on the assembled tangent for `Elastic Correspondence`, hourglass coefficient 0.02; "
        "Jacobian-free Newton-Krylov for `Elastic`). E = F / (A eps): F the mean of the grips' reactions "
        "(`Block_Data` sums of `Force`), A = (n h)^2, eps the strain between two `Nearest_Point_Data` gauges. "
        "Error: |E / E0 - 1|. Wall time: set-up, solve and outputs, in-process."
    )
    reference = (
        f"E0 = 9 K G / (3 K + G) = {E0 / 1e9:.2f} GPa, the continuum modulus. `Elastic Correspondence` reproduces the local "
        f"stress, so it must recover E0: Peridigm's own tensile example gives -0.83 %; here the error is -0.78 % at every ratio, "
        f"the geometric nonlinearity of the applied strain {STRAIN:g} (-0.079 % at a strain of 0.0005, measured), not the "
        "discretization: band |E / E0 - 1| <= 2 % at every point, so at the finest. No rate is fitted (the error does not "
        "fall with the ratio). `Elastic` (LPS) on a lattice has two known errors that do not vanish with the ratio at a fixed "
        "section in horizons: its bulk modulus along a lattice axis is `lattice_youngs_modulus` (closed-form bond sums: "
        "-14.5 % at 3.015 spacings, -2.5 % at 4.015) and its free faces and edges are stiffer (the truncated families). Both "
        "are in E_pred, the modulus of the infinite prism of the same n x n section of the same lattice, computed from the "
        "bond sums of every point's truncated family (`peridyn.verify.problems.prism`: the linearised LPS energy "
        "K/2 theta^2 + 15 G/(2 m) sum (e - theta |xi|/3)^2 V per point with its own m and theta, the section's 2 n^2 "
        "in-plane displacements minimised out, by direct summation: no force code, no fit): +25.6 %, +7.5 %, +19.0 %, "
        "+17.1 %, +15.6 % of E0 at 2.515 .. 6.015 spacings (n = 5, 7, 9, 11, 13), a surface term of 0.54 .. 0.45 E0 "
        "horizon / width over the lattice's (the coefficient 0.5 once fitted to the model's bars lies in that range). Band "
        "|E / E_pred - 1| <= 1 % at every point (measured +0.28 %, +0.30 %, +0.28 %, +0.29 %, +0.30 %: the grips and gauge "
        "of a finite bar and the strain's nonlinearity, -0.08 %). A shear modulus 10 % off moves E by 8.6 %: it fails. "
        "The interior reference of `Elastic` is exact too: "
        "the lattice's constants C11, C12, C44 read from the model's own forces of three quadratic fields at the points "
        "two horizons inside a cube (`peridyn.verify.problems.lattice`: a nonlocal linear force of a quadratic field is "
        "the local operator of the lattice's moduli, exactly) against the closed-form bond sums, band |C / C_lattice - 1| "
        "<= 1e-6 for each (measured 3e-8 or less). K = 2 G, so 3K - 5G = G: the dilatation term is in the force. The bar's E "
        "hardly sees it: the LPS dilatation factor 3 -> 2.9 moves the lattice's E by -0.07 % (closed form and measured), "
        "inside the bar's 3 %, but C11 by -0.34 % and C12 by -0.8 %, which the interior band fails."
    )
    resolution_name = "delta/h"
    size_name = "h/delta"
    error_name = "relative modulus error"
    methods = ("Elastic Correspondence", "Elastic")
    unfitted = {
        "Elastic Correspondence": "the error is the applied strain's geometric nonlinearity, the same at every ratio",
        "Elastic": "the lattice error moves up and down as shells of lattice vectors enter the horizon, and the surface "
                   "error is fixed by the section in horizons",
    }
    every_band = {"Elastic Correspondence": 0.02}
    PREDICTION_BAND = 0.01

    def ladder(self, method: str, quick: bool) -> list[float]:
        if method == "Elastic Correspondence":
            # its error is the strain's nonlinearity, the same at every ratio: --quick leaves out 3.015 (about 3 s)
            return [2.015, 2.515] if quick else [2.015, 2.515, 3.015, 4.015]
        return [2.515, 3.015] if quick else [2.515, 3.015, 4.015, 5.015, 6.015]  # no rate is fitted: two points with --quick

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        from ...testing import build_simulation
        from ...testing.tensile import lattice_youngs_modulus, tensile_bar

        t0 = time.perf_counter()
        with tempfile.TemporaryDirectory(prefix="peridyn-verify-tensile-") as d:
            solver = NEWTON if method == "Elastic Correspondence" else MATRIX_FREE
            bar = tensile_bar(MATERIALS[method], d, ratio=resolution, horizon=HORIZON, section=2.0, strain=STRAIN, solver=solver)
            sim = build_simulation(bar.tree, directory=d)
            run_sections(sim, run=RunServices.of(sim, write=False))  # the answer is read from the fields
            st = sim.stats["solvers"][-1]
            if not st.get("converged", True):
                raise RuntimeError(f"the load step did not converge ({st.get('nonlinear_iterations')} Newton iterations)")
            modulus = bar.youngs_modulus(sim)
        wall = time.perf_counter() - t0
        width = bar.points_across * bar.spacing / HORIZON
        values: dict[str, Any] = {"E (GPa)": modulus / 1e9, "E/E0 - 1": modulus / E0 - 1.0, "width (horizons)": width,
                                  "points": bar.num_points, "Newton iterations": st.get("nonlinear_iterations"), "wall (s)": wall}
        if method == "Elastic":
            pred = lps_prediction(resolution, bar.points_across)
            values.update({"lattice E/E0 - 1": lattice_youngs_modulus(K, MU, resolution) / E0 - 1.0, "E_pred/E0 - 1": pred / E0 - 1.0,
                           "E/E_pred - 1": modulus / pred - 1.0})
            values.update(interior_values(method, MATERIALS[method], K, MU, resolution, HORIZON))
        return Measurement(abs(modulus / E0 - 1.0), size=1.0 / resolution, steps=int(st.get("force_evaluations") or 1), values=values)

    def extra_checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        if method != "Elastic":
            return []
        return [Check(self.name, method, f"|E / E_pred - 1| at delta/h = {p['resolution']:g} (E_pred: the prism of the same "
                      "section from the bond sums of its truncated families)",
                      abs(p["values"]["E/E_pred - 1"]), high=self.PREDICTION_BAND) for p in points] + interior_checks(self.name, method, points)
