"""examples/disk_impact.yaml at a small size: the ball is stopped by contact, not by bonds.

The deck is run with a point spacing of 0.8 mm (3 layers through the disk, horizon 2.4 mm, about
21,000 points) to 14 us. The two bodies are not bonded (``Omit Bonds Between
Blocks: All``), so everything below happens through contact only: without it the ball would fly
through the disk at 100 m/s.
"""
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.deck.files import dump_yaml, load_deck_file
from peridyn.io.exodus_reader import read_results

DECK = Path(__file__).resolve().parents[2] / "examples" / "disk_impact.yaml"
SPACING = 0.0008  # m
FINAL_TIME = 1.4e-5  # s
SPEED = 100.0  # m/s, the ball's initial speed (along -z)
RHO_DISK, RHO_BALL = 2200.0, 7700.0  # kg/m^3


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The small run: (Exodus results, contact radius)."""
    folder = tmp_path_factory.mktemp("disk_impact")
    tree = load_deck_file(DECK).tree
    shapes = tree["Discretization"]["Shapes"]
    shapes["Disk"]["Spacing"] = SPACING
    shapes["Ball"]["Spacing"] = SPACING
    for block in tree["Blocks"].values():
        block["Horizon"] = 3.0 * SPACING
    tree["Solver"]["Final Time"] = FINAL_TIME
    tree["Output"]["Output Frequency"] = 10
    tree["Output"]["Output Variables"]["Volume"] = True
    deck = folder / "disk_impact.yaml"
    deck.write_text(dump_yaml(tree))
    assert main(["run", str(deck), "--output-dir", str(folder), "-q", "--no-progress"]) == ExitCode.OK
    rc = float(tree["Contact"]["Models"]["My Contact Model"]["Contact Radius"])
    return read_results(folder / "disk_impact.e"), rc


def _parts(r):
    disk, ball = r["node_sets"]["DISK"], r["node_sets"]["BALL"]
    rho = np.full(r["coords"].shape[0], RHO_DISK)
    rho[ball] = RHO_BALL
    mass = rho * r["element"]["Volume"][0]
    velocity = np.stack([r["nodal"][f"Velocity{c}"] for c in "XYZ"], axis=-1)  # (frames, points, 3)
    momentum = mass[None, :, None] * velocity
    return disk, ball, mass, momentum


def test_the_ball_slows_down_only_once_it_touches_the_disk(run):
    r, rc = run
    disk, ball, mass, p = _parts(r)
    t, x = r["times"], r["coords"]
    p_ball = p[:, ball, 2].sum(axis=1)
    p0 = -SPEED * mass[ball].sum()
    # before the nearest ball and disk points come within the contact radius, nothing acts on
    # the ball (the bodies are not bonded): it keeps its speed exactly
    gap = cKDTree(x[disk]).query(x[ball])[0].min()
    first_touch = (gap - rc) / SPEED
    assert 0.0 < first_touch < FINAL_TIME - 5.0e-6  # at least 5 us of contact
    before = t < first_touch
    assert before.sum() >= 3
    np.testing.assert_allclose(p_ball[before], p0, rtol=1e-12)
    # then contact pushes it back: |p_z| never grows and has dropped by more than 5 % at the end
    assert np.all(np.abs(p_ball) <= abs(p0) * (1.0 + 1e-12))
    assert abs(p_ball[-1]) < 0.95 * abs(p0), p_ball[-1] / p0
    assert np.all(np.diff(np.abs(p_ball)) <= 1e-12 * abs(p0))  # the disk is only ever pushed away


def test_the_disk_is_pushed_along_minus_z_and_momentum_is_conserved(run):
    r, _ = run
    disk, ball, mass, p = _parts(r)
    p_disk = p[:, disk, 2].sum(axis=1)
    p_ball = p[:, ball, 2].sum(axis=1)
    p0 = -SPEED * mass[ball].sum()
    assert p_disk[-1] < 0.04 * p0  # the disk gains more than 4 % of the ball's momentum, along -z
    # what the ball loses the disk gains: total linear momentum is conserved to 1e-10 of the
    # initial momentum (contact and bond forces are equal and opposite pairs; only round-off)
    total = p.sum(axis=1)
    np.testing.assert_allclose(total[:, 2], p0, rtol=1e-10)
    assert np.abs(total[:, :2]).max() < 1e-10 * abs(p0)
    np.testing.assert_allclose(p_disk - p_disk[0], -(p_ball - p_ball[0]), atol=1e-10 * abs(p0))


def test_contact_forces_are_equal_and_opposite_and_the_ball_does_not_pass_through(run):
    r, rc = run
    disk, ball, _, _ = _parts(r)
    fz = r["nodal"]["Contact_ForceZ"]
    on_ball, on_disk = fz[:, ball].sum(axis=1), fz[:, disk].sum(axis=1)
    assert on_ball.max() > 0.0  # the disk pushes the ball up (+z)
    np.testing.assert_allclose(on_disk, -on_ball, atol=1e-9 * np.abs(on_ball).max())
    # no point of the ball gets much closer to a point of the disk than the contact radius
    y = r["coords"][None] + np.stack([r["nodal"][f"Displacement{c}"] for c in "XYZ"], axis=-1)
    closest = min(cKDTree(y[k, disk]).query(y[k, ball])[0].min() for k in range(len(r["times"])))
    assert closest > 0.8 * rc, closest / rc


def test_the_disk_breaks_under_the_ball_and_nowhere_far_from_it(run):
    r, _ = run
    disk, ball, _, _ = _parts(r)
    x = r["coords"]
    damage = r["element"]["Damage"][-1]
    radius = np.hypot(x[disk, 0], x[disk, 1])
    assert damage[disk][radius < 0.005].max() > 0.9  # bonds broken under the impact point
    assert np.all(damage[disk][radius > 0.030] == 0.0)  # the damage has not reached the rim
    assert np.all(r["element"]["Damage"][:, ball] == 0.0)  # the ball has no damage model


def test_the_counts_in_the_header_are_those_of_the_full_size_deck(capsys, monkeypatch):
    """The header's points, layers, bonds, steps and time step, and the Safety Factor comment,
    against `peridyn check` on the example as it is (set-up only, no run)."""
    from peridyn.deck.model import load_deck

    monkeypatch.chdir(DECK.parent)
    capsys.readouterr()
    assert main(["check", str(DECK)]) == ExitCode.OK
    out = capsys.readouterr().out
    assert "Shapes, 90224 points, 7246300 bonds" in out
    assert "block block_1 (id 1): 86000 points" in out and "block block_2 (id 2): 4224 points" in out
    assert ", 1850 steps," in out
    bond_dt = float(re.search(r"stable time step \(Verlet\): (\S+)", out).group(1))
    contact_dt = float(re.search(r"with the contact springs (\S+)", out).group(1))
    safety = float(load_deck_file(DECK).tree["Solver"]["Verlet"]["Safety Factor"])
    dt = safety * bond_dt
    frequency = int(load_deck_file(DECK).tree["Output"]["Output Frequency"])
    text = " ".join(line.lstrip("# ").rstrip() for line in DECK.read_text().splitlines())
    assert "90,224 points (86,000 in the disk: 5 layers of 0.5 mm; 4,224 in the ball)" in text
    assert "7.2 million bonds, 1,850 steps of 4.32e-8 s" in text
    assert f"{dt:.3g}" == "4.32e-08" and f"{contact_dt / bond_dt:.3g}" == "0.554"
    assert "to 0.554 times the bond estimate, so 0.55: dt = 4.32e-8 s" in text
    assert f"{frequency * dt:.2g}" == "2e-05" and f"{1850 // frequency * frequency * dt:.3g}" == "7.99e-05"
    # the Contact section's arithmetic: 1.7 mm in 50 steps of 2.2 us is about 800 m/s, eight times
    # the ball's speed, 0.22 mm of the ball's travel between searches; 2.5 mm is 8 element radii
    tree = load_deck_file(DECK).tree
    search, every = float(tree["Contact"]["Search Radius"]), int(tree["Contact"]["Search Frequency"])
    rc = float(tree["Contact"]["Models"]["My Contact Model"]["Contact Radius"])
    assert f"{(search - rc) * 1e3:.2g}" == "1.7" and f"{every * dt * 1e6:.2g}" == "2.2"
    closing = (search - rc) / (every * dt)
    assert abs(closing - 800.0) < 10.0 and round(closing / SPEED) == 8
    assert f"{SPEED * every * dt * 1e3:.2g}" == "0.22"
    element_radius = (3.0 * 0.0005**3 / (4.0 * np.pi)) ** (1.0 / 3.0)
    assert round(search / element_radius) == 8
    k_contact = float(tree["Contact"]["Models"]["My Contact Model"]["Spring Constant"])
    assert round(k_contact / float(tree["Materials"]["Disk Material"]["Bulk Modulus"])) == 67
    for words in ("at about 800 m/s to be missed: eight times the ball's speed", "100 m/s x 2.2 us = 0.22 mm",
                  "2.5 mm is 8 element radii", "(1e12 Pa, 67 times the disk's bulk modulus)"):
        assert words in text, words
    # the disk's 5 layers of 0.5 mm
    deck = load_deck(DECK)
    disc = deck.discretization.cls(deck.discretization.params, deck_dir=deck.directory).read()
    z = np.unique(np.round(disc.x[disc.block_id == 1, 2], 9))
    np.testing.assert_allclose(z, 0.00025 + 0.0005 * np.arange(5), atol=1e-9)
    # the Discretization comment: the nearest disk and ball points are 1 mm apart, less than the horizon
    gap = cKDTree(disc.x[disc.block_id == 1]).query(disc.x[disc.block_id == 2])[0].min()
    assert abs(gap - 0.001) < 1e-9 and gap < float(tree["Blocks"]["Disk Block"]["Horizon"])
    assert "(their nearest points are 1 mm apart, less than the horizon)" in text
