"""examples/disk_impact.yaml at a small size: the ball is stopped by contact, not by bonds.

The deck is run with a point spacing of 0.8 mm (3 layers through the disk, horizon 2.4 mm, about
21,000 points) to 14 us, a few seconds. The two bodies are not bonded (``Omit Bonds Between
Blocks: All``), so everything below happens through contact only: without it the ball would fly
through the disk at 100 m/s.
"""
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
