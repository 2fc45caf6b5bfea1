"""The same answer on one and on two MPI ranks (``mpi``): one deck, run by ``peridyn run`` serially
and under ``mpiexec``, compared point by point, with the wall time of each."""
from __future__ import annotations

import importlib.util
import os
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from .base import Check, Measurement, Problem
from .extreme import RunResult, impact_deck, run_deck

#: relative difference of the final displacements allowed between rank counts (round-off)
AGREEMENT = 1.0e-12
#: Peridigm's steel, as in the benchmark decks (SI)
STEEL = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 130.0e9, "Shear Modulus": 78.0e9}


def find_mpiexec() -> str | None:
    """``mpiexec`` beside this Python (a venv's mpich), else on PATH; None without one or mpi4py."""
    if importlib.util.find_spec("mpi4py") is None:
        return None
    here = Path(sys.executable).parent / "mpiexec"
    return str(here) if here.exists() and os.access(here, os.X_OK) else shutil.which("mpiexec")


class ParallelAgreement(Problem):
    name = "mpi"
    title = "The same answer on one and two MPI ranks, and its wall time"
    kind = "table"
    computes = (
        "A cube of n^3 points (n = 10 with --quick, 16 otherwise; spacing 1 mm, horizon 3.015 spacings, steel: "
        "K = 130 GPa, G = 78 GPa, rho = 7800 kg/m^3) whose x = max face starts at -20 m/s, run with velocity "
        "Verlet at half the set-up estimate for 120 steps, by `peridyn run` in a subprocess: serially, then under "
        "`mpiexec -n 2` (the command a user types; one output file either way). Methods: `Elastic` (LPS), the same "
        "with `Critical Stretch` damage (s_c = 1e-4: bonds break at the struck face), and `Elastic Bond Based`. "
        "Difference: max |u_2 - u_1| / max |u_1| over every point of the final frame. Wall time: the whole command "
        "(start-up, set-up, output)."
    )
    reference = (
        "The serial run. Each rank sums a point's bonds in the same order as the serial run does (rows sorted by "
        "global id) and exchanges the ghosts' values before they are read, so the answers agree to round-off "
        f"(band {AGREEMENT:g}) and, here, bit for bit; bond breaking, which a round-off difference could flip, is "
        "included. Without `mpiexec` and mpi4py (`pip install mpi4py mpich`) only the serial rows are run."
    )
    resolution_name = "ranks"
    size_name = "-"
    error_name = "relative difference to 1 rank"
    methods = ("Elastic", "Elastic, Critical Stretch", "Elastic Bond Based")

    def __init__(self) -> None:
        self._serial: dict[tuple[str, int], RunResult] = {}
        self._tmpdir: tempfile.TemporaryDirectory | None = None

    independent_points = False  # the two-rank point compares with the serial point of its method

    def ladder(self, method: str, quick: bool) -> list[float]:
        return [1.0, 2.0] if find_mpiexec() else [1.0]

    def deck(self, method: str, n: int) -> dict[str, Any]:
        material = dict(STEEL)
        if method == "Elastic Bond Based":
            material = {"Material Model": "Elastic Bond Based", "Density": 7800.0, "Bulk Modulus": 130.0e9}
        tree = impact_deck(material, n=n, spacing=1.0e-3, speed=20.0)
        if method.endswith("Critical Stretch"):
            tree["Damage Models"] = {"D": {"Damage Model": "Critical Stretch", "Critical Stretch": 1.0e-4}}
            for block in tree["Blocks"].values():
                block["Damage Model"] = "D"
        return tree

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        if self._tmpdir is None:
            self._tmpdir = tempfile.TemporaryDirectory(prefix="peridyn-verify-mpi-")
        ranks, n = int(resolution), (10 if quick else 16)
        launcher = [find_mpiexec() or "mpiexec", "-n", str(ranks)] if ranks > 1 else []
        folder = Path(self._tmpdir.name) / method.replace(" ", "_").replace(",", "") / f"{ranks}"
        res = run_deck(self.deck(method, n), folder, launcher=launcher, timeout=600.0)
        values: dict[str, Any] = {"exit": res.rc, "points": n**3, "wall (s)": res.wall}
        if res.rc != 0 or "DisplacementX" not in res.outputs:
            values["detail"] = (res.stderr.strip().splitlines() or ["(no output)"])[-1][:200]
            return Measurement(float("nan"), steps=res.steps, values=values)
        if ranks == 1:
            self._serial[(method, n)] = res
        serial = self._serial.get((method, n))
        u, u1 = res.vec("Displacement")[-1], serial.vec("Displacement")[-1] if serial else None
        diff = float(np.abs(u - u1).max() / np.abs(u1).max()) if u1 is not None else float("nan")
        values["speed-up"] = serial.wall / res.wall if serial else float("nan")
        return Measurement(diff, steps=res.steps, values=values)

    def checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        out = []
        for p in points:
            ok = p["values"].get("exit") == 0
            out.append(Check(self.name, method, f"exit status on {p['resolution']:g} rank(s)", 1.0 if ok else 0.0, low=1.0,
                             shown=str(p["values"].get("exit")), expect="0"))
            if p["resolution"] > 1:
                err = p["error"] if p["error"] is not None else float("nan")
                out.append(Check(self.name, method, f"{self.error_name} on {p['resolution']:g} ranks", err, high=AGREEMENT))
        return out
