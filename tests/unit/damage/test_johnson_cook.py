"""Johnson Cook damage: the damage parameter and the bond and point damage on hand-computed
bonds, parameters, and a run with a plastic bond-associated correspondence material."""
import math

import numpy as np
import pytest
from pydantic import ValidationError

from peridyn.core.errors import InputError
from peridyn.core.influence import ONE
from peridyn.damage.johnson_cook import JohnsonCookParams, johnson_cook_kernel
from peridyn.testing import build_simulation, cube_deck

NO_J = np.zeros(0)  # no Jacobian field: J = 1
OFFSETS = np.array([0, 1, 2])
NEIGHBORS = np.array([1, 0], dtype=np.int32)
Y = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
VOLUME = np.array([2.0, 3.0])
HORIZON = np.array([2.0, 2.0])
M_U = np.array([4.0, 5.0])
D1, D2, D3 = 0.1, 0.2, 1.5
D_TH = 0.4


def run_kernel(eqps_n, eqps_np1, triax, P_n, *, J=NO_J, neglect=0.95):
    out = {k: np.zeros(2) for k in ("P", "d", "damage", "bbva", "flag")}
    johnson_cook_kernel(0, 2, OFFSETS, NEIGHBORS, Y, VOLUME, J, HORIZON, ONE, M_U, np.asarray(eqps_n, float), np.asarray(eqps_np1, float),
                        np.asarray(triax, float), D1, D2, D3, D_TH, neglect, np.asarray(P_n, float), out["P"], out["d"], out["damage"],
                        out["bbva"], out["flag"])
    return out


def test_damage_parameter_and_bond_damage_by_hand():
    # bond 0: eqps grew by 0.05 over the previous step, triaxiality 0.5; bond 1: eqps fell (no increment)
    out = run_kernel([0.35, 0.1], [0.30, 0.2], [0.5, 1.0], [0.3, 0.6])
    eps_f = D1 + D2 * math.exp(-D3 * 0.5)
    P0 = 0.3 + (0.35 - 0.30) / eps_f
    np.testing.assert_allclose(out["P"], [P0, 0.6], rtol=1e-14)
    np.testing.assert_allclose(out["d"], [(P0 - D_TH) / (1 - D_TH), (0.6 - D_TH) / (1 - D_TH)], rtol=1e-14)
    # Damage weights the damage parameter, Broken_Bond_Volume_Averaged the bond damage
    np.testing.assert_allclose(out["damage"], [P0 / 4.0 * 3.0, 0.6 / 5.0 * 2.0], rtol=1e-14)
    np.testing.assert_allclose(out["bbva"], [out["d"][0] / 4.0 * 3.0, out["d"][1] / 5.0 * 2.0], rtol=1e-14)
    np.testing.assert_array_equal(out["flag"], [-1.0, -1.0])


def test_damage_parameter_saturates_and_threshold_holds_bonds():
    out = run_kernel([1.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.9, 0.35])
    np.testing.assert_array_equal(out["P"], [1.0, 0.35])  # clamped at 1; no increment
    np.testing.assert_array_equal(out["d"], [1.0, 0.0])  # 0.35 <= Threshold Damage: intact
    J = np.array([2.0, 0.5])  # J at N scales the neighbour's volume
    out = run_kernel([1.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.9, 0.35], J=J, neglect=0.3)
    np.testing.assert_allclose(out["bbva"], [1.0 / 4.0 * (0.5 * 3.0), 0.0], rtol=1e-15)
    np.testing.assert_array_equal(out["flag"], [1.0, -1.0])


def test_params():
    base = {"Damage Parameter 1": 0.05, "Damage Parameter 2": 3.44, "Damage Parameter 3": -2.12, "Critical Damage": 0.5, "Threshold Damage": 0.2}
    p = JohnsonCookParams.model_validate(base)
    assert p.critical_damage_to_neglect == 0.95
    with pytest.raises(ValidationError, match="less than 1"):
        JohnsonCookParams.model_validate({**base, "Critical Damage": 1.0})
    with pytest.raises(ValidationError, match="less than 'Critical Damage'"):
        JohnsonCookParams.model_validate({**base, "Threshold Damage": 0.5})
    with pytest.raises(ValidationError, match="strain to failure"):
        JohnsonCookParams.model_validate({**base, "Damage Parameter 1": 0.0, "Damage Parameter 2": 0.0})
    with pytest.raises(ValidationError):
        JohnsonCookParams.model_validate({k: v for k, v in base.items() if k != "Damage Parameter 3"})


# -- through the engine ---------------------------------------------------------------------------
PLASTIC = {"Material Model": "Elastic Plastic Bond Associated Correspondence", "Density": 7800.0, "Young's Modulus": 200e9,
           "Poisson's Ratio": 0.3, "Yield Stress": 200e6}
DAMAGE = {"Damage Model": "Johnson Cook", "Damage Parameter 1": 0.02, "Damage Parameter 2": 0.01, "Damage Parameter 3": 1.0,
          "Critical Damage": 0.5, "Threshold Damage": 0.2}


def test_plastic_flow_of_a_bond_associated_material_accumulates_damage():
    """Uniaxial strain in steps of 1 %: the bonds flow plastically; the damage parameter grows by
    the previous step's plastic strain increment over eps_f, the forces fall as bonds break and a
    point whose bonds are all broken is flagged."""
    sim = build_simulation(cube_deck(PLASTIC, n=4, spacing=1e-3, damage=DAMAGE))
    dt = 1e-7
    sim.set_time_step(dt)
    x = sim.fields["Model_Coordinates"]
    s = sim.fields
    forces, params = [], []
    for step in range(1, 9):
        u = np.zeros_like(x)
        u[:, 0] = 0.01 * step * x[:, 0]
        s["Velocity"][:] = (u - s["Displacement"]) / dt
        s["Displacement"][:] = u
        s["Coordinates"][:] = x + u
        P_n = s.n("Bond_Damage_Parameter").copy()
        deqps = s.n("Bond_Equivalent_Plastic_Strain") - s.np1("Bond_Equivalent_Plastic_Strain")  # as the model reads them
        f = sim.evaluate_forces()
        eps_f = 0.02 + 0.01 * np.exp(-1.0 * s["Bond_Stress_Triaxiality"])
        want = np.minimum(1.0, P_n + np.maximum(0.0, deqps / eps_f))
        np.testing.assert_allclose(s["Bond_Damage_Parameter"], want, rtol=1e-12, atol=1e-15)
        forces.append(float(np.abs(f).max()))
        params.append(float(s["Bond_Damage_Parameter"].max()))
        sim.advance()
    assert params[0] == 0.0 and 0.0 < params[2] < params[4] and params[-1] == 1.0
    assert forces[-1] < 0.5 * max(forces)  # broken bonds carry less force
    assert np.all(s.n("Flying_Point_Flag") == 1.0)  # every bond broken: every point flagged


def test_needs_bond_plastic_strains():
    elastic = {**PLASTIC, "Material Model": "Elastic Bond Associated Correspondence"}
    del elastic["Yield Stress"]
    with pytest.raises(InputError, match="no equivalent plastic strain per bond"):
        build_simulation(cube_deck(elastic, n=3, spacing=1e-3, damage=DAMAGE))


def test_hypoelastic_material_gives_its_jacobian_and_weighted_volume():
    """With a hypoelastic material the point sums use its Jacobian_Determinant at N and its
    Undamaged_Weighted_Volume (0 at the first evaluation, before its first precompute: no NaN)."""
    hypo = {**PLASTIC, "Material Model": "Elastic Plastic Hypoelastic Correspondence", "Hourglass Coefficient": 0.0,
            "Actual Horizon": 3.015e-3}
    sim = build_simulation(cube_deck(hypo, n=4, spacing=1e-3, damage=DAMAGE))
    dt = 1e-7
    sim.set_time_step(dt)
    x = sim.fields["Model_Coordinates"]
    s = sim.fields
    nl = sim.bonds
    for step in range(1, 5):
        u = np.zeros_like(x)
        u[:, 0] = 0.01 * step * x[:, 0]
        s["Velocity"][:] = (u - s["Displacement"]) / dt
        s["Displacement"][:] = u
        s["Coordinates"][:] = x + u
        J, m_u = s.n("Jacobian_Determinant").copy(), s["Undamaged_Weighted_Volume"].copy()
        sim.evaluate_forces()
        assert np.all(np.isfinite(s["Damage"]))
        i = 0
        js = nl.neighbors[nl.offsets[i] : nl.offsets[i + 1]]
        P = s["Bond_Damage_Parameter"][nl.offsets[i] : nl.offsets[i + 1]]
        want = float(np.sum(P / m_u[i] * (J[js] * s["Volume"][js]))) if m_u[i] > 0 else 0.0
        np.testing.assert_allclose(s["Damage"][i], want, rtol=1e-12)
        sim.advance()
    assert s.n("Damage").max() > 0.0
    assert not np.all(s.n("Jacobian_Determinant") == 1.0)
