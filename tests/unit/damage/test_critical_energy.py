"""Critical Energy damage: the G0 -> critical stretch conversions (closed forms and an
independent quadrature of the crossing-bond energy), parameters, material binding, and the
bond rule through the engine."""
import math
from typing import ClassVar

import numpy as np
import pytest
from pydantic import ValidationError

from peridyn.core.errors import InputError
from peridyn.damage.critical_energy import (
    CriticalEnergyParams,
    bond_based_critical_stretch,
    lps_critical_stretch,
    lps_energy_coefficients,
)
from peridyn.testing import DamageConformance, build_simulation, cube_deck

G0, K, DELTA = 250.0, 40e9, 3.015e-3


def crossing_energy(energy_of_point, delta: float, n: int = 28) -> float:
    """2 int_0^delta W_cross(z) dz with W_cross(z) from the bonds xi (a lattice of spacing
    delta/n filling the ball) whose xi_z > z: the bonds a plane at distance z crosses."""
    h = delta / n
    g = (np.arange(-n, n + 1) * h)
    X, Y, Z = np.meshgrid(g, g, g, indexing="ij")
    r = np.sqrt(X**2 + Y**2 + Z**2)
    inside = (r <= delta) & (r > 0)
    xi_z, r = Z[inside], r[inside]
    zs = (np.arange(n) + 0.5) * h
    return 2.0 * h * sum(energy_of_point(r[xi_z > z], h**3) for z in zs)


def test_bond_based_3d_is_silling_askari():
    c = 18.0 * K / (math.pi * DELTA**4)
    s0 = bond_based_critical_stretch(G0, c, DELTA)
    assert s0 == pytest.approx(math.sqrt(5.0 * G0 / (9.0 * K * DELTA)), rel=1e-14)
    # W_cross of a point: half the pair energies c s0^2 |xi| / 2 of its crossing bonds
    G = crossing_energy(lambda r, dV: 0.5 * np.sum(0.5 * c * s0**2 * r) * dV, DELTA)
    assert G == pytest.approx(G0, rel=0.01)


def test_bond_based_2d_is_ha_bobaru():
    E, h = 70e9, 1e-3
    # the plane models' micromodulus c = 12 K / (pi h delta^3), K = E / (2 (1 - nu))
    K_stress, K_strain = E / (2 * (1 - 1 / 3)), E / (2 * (1 - 0.25 - 2 * 0.0625))
    s_stress = bond_based_critical_stretch(G0, 12 * K_stress / (math.pi * h * DELTA**3), DELTA, h)
    s_strain = bond_based_critical_stretch(G0, 12 * K_strain / (math.pi * h * DELTA**3), DELTA, h)
    assert s_stress == pytest.approx(math.sqrt(4 * math.pi * G0 / (9 * E * DELTA)), rel=1e-14)
    assert s_strain == pytest.approx(math.sqrt(5 * math.pi * G0 / (12 * E * DELTA)), rel=1e-14)


def test_lps_coefficients_closed_forms():
    A, B = lps_energy_coefficients(lambda r: np.ones_like(r))
    assert (A, B) == pytest.approx((25 / 8, 375 / 616), rel=1e-9)
    A, B = lps_energy_coefficients(lambda r: 1.0 / r)  # Madenci & Oterkus' omega = delta/|xi|
    assert (A, B) == pytest.approx((3.0, 26 / 45), rel=1e-9)
    # with omega = delta/|xi| and K = 5 mu / 3 (nu = 1/4) the LPS value is the bond-based one
    mu = 3 * K / 5
    assert lps_critical_stretch(G0, K, mu, DELTA, A, B) == pytest.approx(math.sqrt(5 * G0 / (9 * K * DELTA)), rel=1e-9)


@pytest.mark.parametrize("nu", [0.1, 0.25, 0.4])
def test_lps_conversion_is_the_crossing_bond_energy(nu):
    """Independent quadrature of the LPS crossing-bond energy (omega = 1): per point at
    distance z, W = (K - 5mu/3) theta^2/2 + (15 mu / 2m) sum omega e^2 V with e = s0 |xi| and
    theta = (3/m) sum omega |xi| e V over the crossing bonds."""
    mu = 3 * K * (1 - 2 * nu) / (2 * (1 + nu))
    A, B = lps_energy_coefficients(lambda r: np.ones_like(r))
    s0 = lps_critical_stretch(G0, K, mu, DELTA, A, B)
    m = 4 * math.pi * DELTA**5 / 5

    def W(r, dV):
        theta = 3.0 / m * np.sum(r * (s0 * r)) * dV
        return 0.5 * (K - 5 * mu / 3) * theta**2 + 7.5 * mu / m * np.sum((s0 * r) ** 2) * dV

    assert crossing_energy(W, DELTA) == pytest.approx(G0, rel=0.015)


def test_lps_rejects_a_non_positive_fracture_stiffness():
    with pytest.raises(ValueError, match="not positive"):
        lps_critical_stretch(G0, 1.0, 1.0, DELTA, 0.1, 1.0)


def test_params():
    assert CriticalEnergyParams.model_validate({"Critical Energy": 10.0}).G0 == 10.0
    assert CriticalEnergyParams.model_validate({"Critical Value": 12.0}).G0 == 12.0  # PeriLab's key
    for bad in ({}, {"Critical Energy": 1.0, "Critical Value": 1.0}, {"Critical Energy": 0.0}, {"Critical Energy": -3.0},
                {"Critical Energy": float("nan")}, {"Critical Energy": float("inf")}, {"Critical Energy": 1.0, "Critical Stretch": 0.1},
                {"Critical Energy": 1.0, "Thermal Expansion Coefficient": float("inf")}):
        with pytest.raises(ValidationError):
            CriticalEnergyParams.model_validate(bad)


class TestCriticalEnergyWithElastic(DamageConformance):
    damage = "Critical Energy"
    params: ClassVar[dict] = {"Critical Energy": 4.4e5}  # s0 = 0.01 for the kit's LPS (K = 1e9, mu = 0.4e9, delta = 3.015)


class TestCriticalEnergyWithBondBased(DamageConformance):
    damage = "Critical Energy"
    params: ClassVar[dict] = {"Critical Energy": 5.0e5}
    material = "Elastic Bond Based"
    material_params: ClassVar[dict] = {"Density": 1000.0, "Bulk Modulus": 1.0e9}


# -- through the engine -----------------------------------------------------------------------------
BB = {"Material Model": "Elastic Bond Based", "Density": 2000.0, "Bulk Modulus": K}
LPS = {"Material Model": "Elastic", "Density": 2000.0, "Bulk Modulus": K, "Shear Modulus": 0.6 * K}
DAMAGE = {"Damage Model": "Critical Energy", "Critical Energy": G0}


def stretch_all(sim, s):
    x = sim.fields["Model_Coordinates"]
    sim.fields["Coordinates"][:] = x * (1.0 + s)
    sim.evaluate_forces()
    return sim.fields["Bond_Damage"][: sim.bonds.offsets[sim.num_owned]]


def test_bond_based_block_breaks_bonds_above_s0_only():
    sim = build_simulation(cube_deck(BB, n=5, spacing=1e-3, damage=DAMAGE))
    s0 = sim.blocks[0].damage.s_c
    delta = 3.015e-3
    assert s0 == pytest.approx(math.sqrt(5 * G0 / (9 * K * delta)), rel=1e-12)
    assert not np.any(stretch_all(sim, 0.999 * s0))
    assert np.all(stretch_all(sim, 1.001 * s0) == 1)
    assert np.all(sim.fields["Damage"][: sim.num_owned] == 1.0)


def test_lps_block_uses_the_lps_conversion_and_the_fused_rule():
    sim = build_simulation(cube_deck(LPS, n=5, spacing=1e-3, damage=DAMAGE))
    blk = sim.blocks[0]
    expected = lps_critical_stretch(G0, K, 0.6 * K, 3.015e-3, 25 / 8, 375 / 616)
    assert blk.damage.s_c == pytest.approx(expected, rel=1e-12)
    assert blk.damage_adopted  # the LPS material applies the rule in its own bond loop
    assert not np.any(stretch_all(sim, 0.999 * expected))
    assert np.all(stretch_all(sim, 1.001 * expected) == 1)


def test_lps_with_another_influence_function():
    tree = cube_deck(LPS, n=4, spacing=1e-3, damage=DAMAGE)
    tree["Discretization"]["Influence Function"] = "Parabolic Decay"
    sim = build_simulation(tree)
    omega = sim.influence
    A, B = lps_energy_coefficients(lambda r: omega.evaluate(np.asarray(r) * 3.015e-3, 3.015e-3))
    assert A != pytest.approx(25 / 8)
    assert sim.blocks[0].damage.s_c == pytest.approx(lps_critical_stretch(G0, K, 0.6 * K, 3.015e-3, A, B), rel=1e-12)


def test_unsupported_material_is_an_input_error_at_the_damage_model():
    pals = {"Material Model": "Viscoelastic", "Density": 2000.0, "Bulk Modulus": K, "Shear Modulus": 0.6 * K,
            "lambda_i": 0.5, "tau b": 1.0}
    with pytest.raises(InputError, match="supports the materials") as info:
        build_simulation(cube_deck(pals, n=3, damage=DAMAGE))
    assert "Damage Models" in str(info.value)


def test_thermal_strain_is_subtracted():
    tree = cube_deck(BB, n=4, spacing=1e-3, damage={**DAMAGE, "Thermal Expansion Coefficient": 1e-3})
    sim = build_simulation(tree)
    s0 = sim.blocks[0].damage.s_c
    sim.fields["Temperature_Change"][:] = 2.0  # thermal strain 2e-3
    assert not np.any(stretch_all(sim, s0 + 1.9e-3))
    assert np.all(stretch_all(sim, s0 + 2.1e-3) == 1)
