"""examples/penalty_contact.yaml at its own size (3,880 points, about 5 s): a steel ball bounces
off a free aluminium plate through PeriLab's ``Penalty Contact``, whose stiffness is each block's
bulk modulus times the Penalty Factor. The claims of its header: the ball rebounds (-20 m/s to
+7.2 m/s), the momentum it loses is the plate's gain (total conserved to round-off), 97 % of the
kinetic energy comes back, and the closest ball and plate points stay 0.89 contact radii apart."""
import numpy as np
import pytest
from scipy.spatial import cKDTree

from peridyn.io.exodus_reader import read_results
from tests.examples.test_examples import EXAMPLES, check, header, run_example

RHO_PLATE, RHO_BALL = 2700.0, 7800.0  # kg/m^3
RC = 0.001  # m, the contact radius


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    out = run_example("penalty_contact", tmp_path_factory.mktemp("penalty_contact"), **{"Output/Output Frequency": 10})
    return read_results(out / "penalty_contact.e")


def _state(r):
    ball, plate = r["node_sets"]["BALL"], r["node_sets"]["PLATE"]
    rho = np.full(r["coords"].shape[0], RHO_PLATE)
    rho[ball] = RHO_BALL
    mass = rho * r["element"]["Volume"][0]
    v = np.stack([r["nodal"][f"Velocity{c}"] for c in "XYZ"], axis=-1)
    u = np.stack([r["nodal"][f"Displacement{c}"] for c in "XYZ"], axis=-1)
    return ball, plate, mass, v, u


def test_the_ball_rebounds_and_the_momentum_goes_to_the_plate(result):
    ball, plate, mass, v, _ = _state(result)
    vz_ball = (mass[ball] * v[:, ball, 2]).sum(axis=1) / mass[ball].sum()
    vz_plate = (mass[plate] * v[:, plate, 2]).sum(axis=1) / mass[plate].sum()
    assert vz_ball[0] == pytest.approx(-20.0) and vz_plate[0] == 0.0
    assert 6.5 < vz_ball[-1] < 8.0  # rebounds (header: +7.2 m/s)
    assert -6.5 < vz_plate[-1] < -5.3  # header: -5.9 m/s
    momentum = (mass[None, :, None] * v).sum(axis=1)  # (frames, 3)
    scale = mass[ball].sum() * 20.0
    assert np.abs(momentum - momentum[0]).max() <= 1e-9 * scale  # what the ball loses the plate gains
    force = np.stack([result["nodal"][f"Contact_Force{c}"] for c in "XYZ"], axis=-1)
    assert np.abs(force[:, plate, 2]).sum(axis=1).max() > 0  # the contact acted ...
    assert np.abs(force.sum(axis=1)).max() <= 1e-9 * np.abs(force).sum(axis=1).max()  # ... in equal and opposite pairs
    ke = 0.5 * (mass[None, :] * (v**2).sum(axis=2)).sum(axis=1)
    assert 0.94 < ke[-1] / ke[0] <= 1.0  # header: 97 % comes back, the rest rings in the plate


def test_the_springs_hold_the_bodies_apart(result):
    ball, plate, _, _, u = _state(result)
    x = result["coords"]
    closest = min(cKDTree(x[plate] + u[k, plate]).query(x[ball] + u[k, ball])[0].min() for k in range(u.shape[0]))
    assert 0.85 * RC < closest < RC  # in contact, never through (header: 0.89 R_c)


def test_counts_in_the_header(capsys, monkeypatch):
    out = check(EXAMPLES / "penalty_contact.yaml", capsys, monkeypatch)
    assert "Shapes, 3880 points, 289520 bonds" in out and ", 791 steps," in out
    assert "contact: Penalty Contact" in out
    text = header("penalty_contact")
    assert "3,880 points (280 in the ball), 289,520 bonds, 791 steps" in text
