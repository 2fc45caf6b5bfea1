"""examples/fatigue_notched_plate.yaml: a fatigue crack nucleates at the notch tip and grows
straight along the mid-line, as its header says (run for 800 of its 1,500 cycles)."""
import numpy as np
import pytest

from peridyn.io.exodus_reader import read_results

from .test_examples import header, run_example


def crack_tips(r: dict) -> tuple[np.ndarray, np.ndarray]:
    """(cycles, tip x in mm) of every frame: the largest x of the points just above the mid-line
    with Damage >= 0.3 (nan before any)."""
    x = r["coords"]
    row = np.abs(x[:, 1] - 0.0005) < 1e-9
    tips = np.array([1e3 * x[row & (d >= 0.3), 0].max() if np.any(row & (d >= 0.3)) else np.nan for d in r["element"]["Damage"]])
    return np.asarray(r["times"]) * 10.0, tips


def test_fatigue_crack_grows_from_the_notch_along_the_mid_line(tmp_path):
    assert "14.5 mm after 800 cycles" in header("fatigue_notched_plate")
    out = run_example("fatigue_notched_plate", tmp_path, **{"Solver/Final Time": 80.0, "Solver/QuasiStatic/Number of Load Steps": 16})
    r = read_results(out / "fatigue_notched_plate.e")
    cycles, tips = crack_tips(r)
    damage = r["element"]["Damage"]
    x = r["coords"]
    first = next(k for k, d in enumerate(damage) if d.max() > 0)
    assert cycles[first] == pytest.approx(200.0)  # nucleation: the first broken bonds after 200 cycles
    hit = damage[first] > 0
    assert np.all(np.abs(x[hit, 0] - 0.010) < 0.002)  # at the notch tip
    assert np.all(np.abs(x[damage[-1] > 0, 1]) < 0.004)  # a straight crack along the mid-line
    assert tips[-1] == pytest.approx(14.5)  # 800 cycles
    grown = tips[~np.isnan(tips)]
    assert np.all(np.diff(grown) >= 0)
