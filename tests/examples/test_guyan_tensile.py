"""examples/guyan_tensile.yaml: QuasiStatic with static (Guyan) condensation of the bar's arms
gives the full solve's displacements to round-off, and the grips' reactions balance."""
import logging

import numpy as np

from peridyn.deck.files import load_deck_file
from peridyn.io.exodus_reader import read_results
from tests.examples.test_examples import EXAMPLES, header, run_example

QS = "Solver/QuasiStatic"


def test_condensed_bar_equals_the_full_solve(tmp_path, caplog):
    for sub in ("condensed", "full"):
        (tmp_path / sub).mkdir()
    solver_log = logging.getLogger("peridyn.solver")
    solver_log.addHandler(caplog.handler)  # the command line's -q keeps INFO from the root logger
    level = solver_log.level
    solver_log.setLevel(logging.INFO)
    try:
        condensed = read_results(run_example("guyan_tensile", tmp_path / "condensed") / "guyan_tensile.e")
    finally:
        solver_log.setLevel(level)
        solver_log.removeHandler(caplog.handler)
    # the arms' free components (2 x 64 points x 3) condensed onto the gauge section's (96 x 3)
    assert "Static condensation: 384 unknowns condensed onto 288 masters" in caplog.text
    qs = dict(load_deck_file(EXAMPLES / "guyan_tensile.yaml").tree["Solver"]["QuasiStatic"])
    del qs["Model Reduction"]
    qs["Linear Solver"] = "Direct"  # the full system, solved exactly
    full = read_results(run_example("guyan_tensile", tmp_path / "full", **{QS: qs}) / "guyan_tensile.e")
    u, u_full = (np.stack([r["nodal"][f"Displacement{c}"] for c in "XYZ"], axis=-1) for r in (condensed, full))
    assert u.shape == u_full.shape == (3, 320, 3)  # the initial state and 2 load steps
    assert np.abs(u_full[-1, :, 1]).max() > 1.9e-5  # the top grip moved its 0.02 mm
    assert np.max(np.abs(u - u_full)) <= 1.0e-10 * np.max(np.abs(u_full))
    g = condensed["global"]
    top, bottom = g["Top_ReactionY"][-1], g["Bottom_ReactionY"][-1]
    assert top != 0.0 and abs(top + bottom) <= 1.0e-6 * abs(top)  # equilibrium of the gauge section and arms
    assert "Guyan" in header("guyan_tensile")
