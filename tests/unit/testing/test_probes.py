"""The measurements behind the kit's physics checks (peridyn.testing.probes, harness)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from peridyn.testing import build_simulation, cube_deck
from peridyn.testing.harness import scattered_deck
from peridyn.testing.probes import (
    energy_moduli,
    force_moduli,
    interior_points,
    stated_moduli,
)

H = 1e-3


def lattice(material: dict, shape=(15, 15, 15)):
    return build_simulation(cube_deck(material, shape=shape, spacing=H))


@pytest.mark.parametrize(
    "params, expected",
    [
        ({"Bulk Modulus": 3.0, "Shear Modulus": 2.0}, (3.0, 2.0)),
        ({"Young's Modulus": 2.5, "Poisson's Ratio": 0.25}, (2.5 / 1.5, 1.0)),
        ({"Bulk Modulus": 5.0}, (5.0, 3.0)),  # bond-based, 3D: nu = 1/4
        ({"Young's Modulus": 3.0}, (2.0, 1.2)),
        ({"Bulk Modulus": 4.0, "Plane Stress": True}, (4.0, 2.0)),  # bond-based, 2D: G = K / 2
        ({"Young's Modulus": 4.0, "Plane Stress": True}, (3.0, 1.5)),  # nu = 1/3
        ({"Young's Modulus": 5.0, "Plane Strain": True}, (4.0, 2.0)),  # nu = 1/4
        ({"Density": 1.0}, None),
    ],
)
def test_stated_moduli(params, expected):
    got = stated_moduli(params)
    if expected is None:
        assert got is None
    else:
        np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_interior_points_of_a_lattice():
    sim = lattice({"Material Model": "Elastic Bond Based", "Density": 1.0, "Bulk Modulus": 1.0}, shape=(15, 15, 15))
    assert interior_points(sim, 1).size == 9**3  # 3 spacings from every face
    inner = interior_points(sim, 2)
    assert inner.size == 3**3  # 6 spacings from every face
    x = sim.fields["Model_Coordinates"][inner] / H
    assert np.all((x > 6) & (x < 9))


@pytest.mark.parametrize("nu", [-0.5, 0.0, 0.3, 0.45])
def test_the_linear_peridynamic_solid_has_its_moduli_exactly(nu):
    """The isotropic averages of LPS's cubic constants on the lattice are the stated K and G
    (its anisotropy is large: C44 alone is 11 % stiff)."""
    sim = lattice({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0e9, "Poisson's Ratio": nu})
    K, G = stated_moduli({"Bulk Modulus": 1.0e9, "Poisson's Ratio": nu})
    for measured in (force_moduli(sim, H), energy_moduli(sim)):
        assert measured.bulk == pytest.approx(K, rel=1e-7)
        assert measured.shear == pytest.approx(G, rel=1e-7)
    assert force_moduli(sim, H).c44 == pytest.approx(1.1102 * G, rel=1e-3)


@pytest.mark.parametrize("shape, dimension, ratio", [((15, 15, 15), 3, 1.0987), ((15, 15, 1), 2, 1.0254)])
def test_the_bond_based_lattice_error(shape, dimension, ratio):
    """A bond-based micromodulus is the continuum integral's; the lattice sums make the model
    9.9 % stiff in 3D, 2.5 % on a plate (horizon 3.015 spacings): the kit's tolerance (25 %)
    leaves room for that and fails a factor 2."""
    params = {"Density": 1.0, "Bulk Modulus": 1.0e9}
    if dimension == 2:
        params.update({"Plane Stress": True, "Height": H})
    sim = lattice({"Material Model": "Elastic Bond Based", **params}, shape=shape)
    K, G = stated_moduli(params)
    f = force_moduli(sim, H, dimension=dimension)
    e = energy_moduli(sim, dimension=dimension)
    for measured in (f, e):
        assert measured.bulk / K == pytest.approx(ratio, abs=1e-4)
        assert measured.shear / G == pytest.approx(ratio, abs=1e-4)
    assert f.spread < 1e-4 and e.spread < 1e-6
    assert f.c12 == pytest.approx(f.c44, rel=1e-6)  # Cauchy relation of a pair potential


def test_scattered_deck_is_irregular_and_fused(tmp_path):
    tree = scattered_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 0.5}, tmp_path, n=5, spacing=H, seed=3)
    sim = build_simulation(tree, directory=tmp_path)
    x, vol = sim.fields["Model_Coordinates"], sim.fields["Volume"]
    assert sim.num_owned == 125 and sim.blocks[0].fused
    assert np.ptp(vol) > 0.5 * H**3 and vol.min() > 0
    offsets = x / H - np.round(x / H)
    assert np.abs(offsets).max() > 0.25
    assert math.isclose(sim.blocks[0].horizon, 3.015 * H)
