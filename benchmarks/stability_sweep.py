"""The largest stable Verlet safety factor per material (run on demand, not a test).

Peridigm's critical time step estimate is conservative; this sweeps the safety factor for each
material on an impact problem (a cube whose face is struck, which excites the highest modes)
and reports the largest factor whose run stays stable for 1,000 steps, i.e. how far the true
limit lies above the estimate.

    python benchmarks/stability_sweep.py
"""
from __future__ import annotations

import numpy as np

import logging

from peridyn.core.errors import InstabilityError
from peridyn.solvers.explicit.verlet import Verlet, VerletSection
from peridyn.engine.session import run_section
from peridyn.testing import build_simulation, cube_deck

MATERIALS = {
    "Elastic (K/G = 5/3)": {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 130.0e9, "Shear Modulus": 78.0e9},
    "Elastic (K/G = 1000)": {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1.0e12, "Shear Modulus": 1.0e9},
    "Elastic Bond Based": {"Material Model": "Elastic Bond Based", "Density": 7800.0, "Bulk Modulus": 130.0e9},
}


def stable(material: dict, factor: float, horizon_factor: float, steps: int = 1000) -> bool:
    sim = build_simulation(cube_deck(material, n=8, spacing=1e-3, horizon_factor=horizon_factor))
    x = sim.fields["Model_Coordinates"]
    face = x[:, 0] > x[:, 0].max() - 5e-4
    sim.fields["Velocity"][face, 0] = -1.0
    dt = sim.critical_time_step() * factor
    section = VerletSection.model_validate({"Initial Time": 0.0, "Final Time": steps * dt * (1 + 1e-9), "Verlet": {"Safety Factor": factor}})
    try:
        run_section(sim, Verlet(section))
    except InstabilityError:
        return False
    return bool(np.all(np.isfinite(sim.fields["Velocity"])))


def main() -> None:
    logging.getLogger("peridyn").setLevel(logging.ERROR)  # the sweep warns about factors > 1 by design
    factors = np.round(np.arange(1.0, 4.01, 0.1), 2)
    print(f"{'material':24s} {'horizon/spacing':>15s} {'largest stable safety factor':>30s}")
    for name, mat in MATERIALS.items():
        for hf in (1.5, 3.015, 5.0):
            best = None
            for f in factors:
                if stable(mat, float(f), hf):
                    best = float(f)
                else:
                    break
            print(f"{name:24s} {hf:15.3f} {best if best is not None else '< 1.0':>30}")


if __name__ == "__main__":
    main()
