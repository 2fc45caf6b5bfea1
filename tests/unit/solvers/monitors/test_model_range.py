"""A run that leaves its models' range is told so (solvers/monitors/model_range.py): the largest bond
strain of a linear law's block and the largest family rotation of a law whose strain is not
rotation invariant, warned once per block; and a body that ends with a negative stored energy is
never reported as a balanced run (solvers/monitors/energy.py EnergyMonitor.created)."""
import logging
import math

import numpy as np
import pytest

from peridyn.kernels import mirror
from peridyn.solvers.monitors.model_range import bond_strain_kernel, mirrored_bond_strain_kernel, rotation_angles
from peridyn.testing import build_simulation, cube_deck
from peridyn.engine.session import run_sections

STEEL = {"Density": 7800.0, "Bulk Modulus": 130.0e9, "Shear Modulus": 78.0e9}
LPS = {"Material Model": "Elastic", **STEEL}
CORRESPONDENCE = {"Material Model": "Elastic Correspondence", "Hourglass Coefficient": 0.02, **STEEL}
N, H = 6, 1.0e-3
OMEGA = 2000.0  # rad/s: the rim at 8.5 m/s


def spun(material: dict, angle: float):
    """A free cube spun about z at OMEGA until it has turned by ``angle`` (radians)."""
    c = N * H / 2
    tree = cube_deck(dict(material), n=N, spacing=H)
    tree["Boundary Conditions"] = {
        "All Node Set": {"All": True},
        "VX": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "x", "Value": f"-{OMEGA}*(y-{c})"},
        "VY": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "y", "Value": f"{OMEGA}*(x-{c})"},
    }
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": angle / OMEGA, "Verlet": {"Safety Factor": 0.8}}
    sim = build_simulation(tree)
    run_sections(sim)
    return sim


def test_rotation_angles_of_known_rotations_and_stretches():
    angles = np.array([0.0, 0.3, 1.5, 3.0])
    F = np.zeros((4, 3, 3))
    for k, a in enumerate(angles):
        R = np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])
        F[k] = R @ np.diag([1.2, 0.9, 1.05])  # a stretch does not turn
    assert np.allclose(rotation_angles(F), angles, atol=1e-12)


def test_a_spun_correspondence_body_is_warned_about_once_and_its_created_energy_reported(caplog):
    with caplog.at_level(logging.WARNING, logger="peridyn"):
        sim = spun(CORRESPONDENCE, math.pi / 2)
    turned = [r.getMessage() for r in caplog.records if "have turned by" in r.getMessage()]
    assert len(turned) == 1 and "block block_1" in turned[0] and "Elastic Correspondence" in turned[0]
    assert sim.stats["range"]["block_1"]["rotation"] == pytest.approx(math.pi / 2, abs=0.05)
    energy = sim.stats["solvers"][-1]["energy"]
    assert energy["created"] > 0.0 and energy["stored_from_work"] < 0.0
    assert any("negative stored energy" in r.getMessage() for r in caplog.records)


def test_lps_turns_freely_without_a_warning(caplog):
    with caplog.at_level(logging.WARNING, logger="peridyn"):
        sim = spun(LPS, math.pi / 2)
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert sim.stats["range"]["block_1"]["strain"] < 1e-3
    assert sim.stats["solvers"][-1]["energy"]["created"] == 0.0


def test_a_small_rotation_of_a_correspondence_body_is_in_range(caplog):
    with caplog.at_level(logging.WARNING, logger="peridyn"):
        spun(CORRESPONDENCE, math.radians(5.0))
    assert not [r for r in caplog.records if "have turned by" in r.getMessage()]


@pytest.mark.parametrize("speed, warned", [(2000.0, True), (20.0, False)])
def test_an_impact_beyond_the_linear_range_is_warned_about_with_its_strain(caplog, speed, warned):
    """Two LPS layers driven into a block at ``speed``: 2,000 m/s crushes the struck families by tens
    of per cent within 1e-6 s (the audit saw 47 %), 20 m/s strains them by about 0.1 %."""
    tree = cube_deck(dict(LPS), shape=(10, 4, 4), spacing=H)
    tree["Boundary Conditions"] = {
        "Struck Node Set": {"Half Space": {"Point": [2 * H, 0.0, 0.0], "Normal": [-1.0, 0.0, 0.0]}},
        "Strike": {"Type": "Initial Velocity", "Node Set": "Struck Node Set", "Coordinate": "x", "Value": f"{speed}"},
    }
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0e-6, "Verlet": {"Safety Factor": 0.5}}
    with caplog.at_level(logging.WARNING, logger="peridyn"):
        sim = build_simulation(tree)
        try:
            run_sections(sim)
        except Exception:  # an impact this violent may also go unstable; the warning comes first
            pass
    strained = [r.getMessage() for r in caplog.records if "reach a strain of" in r.getMessage()]
    assert bool(strained) == warned, strained
    if warned:
        assert len(strained) == 1 and "block block_1" in strained[0] and "'Elastic'" in strained[0]
        assert sim.stats["range"]["block_1"]["strain"] > 0.1


def test_the_mirrored_strain_pass_gives_the_gathers_bits_with_damage_that_differs_between_ends():
    """One visit per bond (one thread) against the gather from both ends: each end keeps a bond by
    its own damage, so broken-at-one-end bonds and debris points must come out the same."""
    sim = build_simulation(cube_deck(dict(LPS), shape=(7, 5, 4), spacing=H))
    nl = sim.bonds
    plan = mirror.mirror_plan(nl, 0, nl.num_points)
    assert plan is not None
    rng = np.random.default_rng(3)
    n = nl.num_points
    x = sim.fields["Model_Coordinates"]
    y = x + rng.normal(scale=0.05 * H, size=x.shape)
    damage = (rng.random(nl.num_bonds) < 0.3).astype(np.uint8)  # not symmetric: j->i may be intact
    point_damage = np.where(rng.random(n) < 0.1, 0.75, 0.25)
    for d, p in ((damage, point_damage), (np.zeros(0, dtype=np.uint8), np.zeros(0))):
        gathered, mirrored = np.zeros(n), np.zeros(n)
        bond_strain_kernel(0, n, nl.offsets, nl.neighbors, x, y, d, p, gathered)
        mirrored_bond_strain_kernel(n, nl.offsets, nl.neighbors, x, y, d, p, *plan, np.empty(n), np.empty(n), mirrored)
        assert gathered.max() > 0.01
        assert np.array_equal(gathered, mirrored)
