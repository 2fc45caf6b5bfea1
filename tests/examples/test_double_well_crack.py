"""examples/double_well_crack.yaml as shipped (it is small): in the nonlocal double-well model the
notch opens first, the crack runs from its tip, and at the end the plate is cut through along
the ligament."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from peridyn.io.exodus_reader import read_results

from tests.examples.test_examples import header, run_example

NOTCH, BAND = 0.005, 0.00225  # notch length; half-height of the band the opening is measured over (m): a row of points


def openings(x: np.ndarray, uy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per column of points (x): the opening u_y(+BAND) - u_y(-BAND) over the grips' separation."""
    grips = uy[x[:, 1] > 0.0101].mean() - uy[x[:, 1] < -0.0101].mean()
    columns = np.unique(np.round(x[:, 0], 7))
    top, bottom = np.abs(x[:, 1] - BAND) < 1e-6, np.abs(x[:, 1] + BAND) < 1e-6
    out = []
    for c in columns:
        at = np.abs(x[:, 0] - c) < 1e-6
        out.append((uy[at & top].mean() - uy[at & bottom].mean()) / grips)
    return columns, np.array(out)


def test_the_plate_is_cut_from_the_notch_across_the_ligament(tmp_path: Path):
    assert "cut through" in header("double_well_crack")
    out = run_example("double_well_crack", tmp_path)
    r = read_results(out / "double_well_crack.e")
    x, uy = r["coords"], r["nodal"]["DisplacementY"]
    columns, first = openings(x, uy[1])
    assert np.all(first[columns < NOTCH - 1e-3] > 0.4), "the notch opens"
    # whole, the band stretches with the plate: 4.5 mm of the grips' 23 mm, 0.2
    assert np.all(first[columns > NOTCH + 3e-3] < 0.3), "the ligament is still whole at the first frame"
    _, last = openings(x, uy[-1])
    assert np.all(last > 0.7), "at the end the plate is apart at every column"
    assert np.median(last) > 0.9
