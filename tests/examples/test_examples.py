"""Every example in examples/ runs, at a small size, and does what its comments say."""
import shutil
from pathlib import Path

import numpy as np
import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.deck.files import dump_yaml, load_deck_file
from peridyn.io.exodus_reader import read_results

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def run_example(name: str, tmp_path: Path, **changes) -> Path:
    """Copy the example (and its data files) to tmp_path, apply ``changes`` (deck path tuple ->
    value), run it there, return the folder."""
    tree = load_deck_file(EXAMPLES / f"{name}.yaml").tree
    for path, value in changes.items():
        node = tree
        keys = path.split("/")
        for k in keys[:-1]:
            node = node[k]
        node[keys[-1]] = value
    for f in EXAMPLES.glob(f"{name.split('.')[0]}*"):
        if f.suffix != ".yaml":
            shutil.copy(f, tmp_path / f.name)
    for f in EXAMPLES.glob("*.txt"):
        shutil.copy(f, tmp_path / f.name)
    deck = tmp_path / f"{name}.yaml"
    deck.write_text(dump_yaml(tree))
    assert main(["run", str(deck), "--output-dir", str(tmp_path), "-q", "--no-progress"]) == ExitCode.OK
    return tmp_path


def test_every_example_has_a_test():
    decks = sorted(p.stem for p in EXAMPLES.glob("*.yaml"))
    assert decks == ["disk_impact", "fragmenting_cylinder", "quickstart", "wave_in_bar"]


def test_quickstart_plate_cracks_in_the_middle(tmp_path):
    out = run_example("quickstart", tmp_path)
    r = read_results(out / "quickstart.e")
    damage = r["element"]["Damage"][-1]
    x = r["coords"][:, 0]
    assert damage.max() > 0.5  # a crack
    cracked = x[damage > 0.3]
    assert np.all(np.abs(cracked - 0.030) < 0.005)  # across the middle, where the pull waves meet
    assert damage[np.abs(x - 0.030) > 0.01].max() < 0.3


def test_fragmenting_cylinder_expands_and_breaks(tmp_path):
    out = run_example("fragmenting_cylinder", tmp_path, **{"Solver/Final Time": 3.0e-5})
    r = read_results(out / "fragmenting_cylinder.e")
    x, u = r["coords"], np.stack([r["nodal"][f"Displacement{c}"][-1] for c in "XYZ"], axis=1)
    radial = (x[:, 0] * u[:, 0] + x[:, 1] * u[:, 1]) / np.hypot(x[:, 0], x[:, 1])
    assert np.median(radial) > 0  # thrown outward
    h = read_results(out / "fragmenting_cylinder_history.h")
    ke = h["global"]["Global_Kinetic_Energy"]
    assert ke[-1] < ke[0]  # kinetic energy goes into stretching (and breaking) the ring
    assert 0.0 <= r["element"]["Damage"][-1].min() and r["element"]["Damage"][-1].max() <= 1.0


def test_wave_in_bar_travels_at_the_elastic_wave_speed(tmp_path):
    out = run_example("wave_in_bar", tmp_path, **{"Solver/Final Time": 1.5e-5})
    h = read_results(out / "wave_in_bar_history.h")
    t, v = h["times"], h["global"]["Middle_VelocityX"]
    arrival = t[np.argmax(v > 2.5)]  # half the particle velocity behind the front
    speed = (0.050 - 0.0015) / arrival
    E, rho, nu = 200.0e9, 7800.0, 0.29
    bar = np.sqrt(E / rho)
    p_wave = np.sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho)
    assert bar * 0.97 < speed < p_wave * 1.03, (speed, bar, p_wave)
    assert h["global"]["End_VelocityX"][t < 0.9 * 0.1 / p_wave].max() < 0.1  # nothing arrives early
