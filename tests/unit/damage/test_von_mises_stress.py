"""Von Mises Stress damage: the bond rule and the volume-averaged outputs on hand-computed
bonds, the bond invariants, parameters, and a run with a bond-associated correspondence
material."""
import math

import numpy as np
import pytest
from pydantic import ValidationError

from peridyn.core.errors import InputError
from peridyn.core.influence import GAUSSIAN, ONE
from peridyn.damage.von_mises_stress import (
    VonMisesStressParams,
    bond_invariants_kernel,
    von_mises_damage_kernel,
)
from peridyn.testing import build_simulation, cube_deck

# two points, each with one bond to the other
NO_J = np.zeros(0)  # no Jacobian field: J = 1
OFFSETS = np.array([0, 1, 2])
NEIGHBORS = np.array([1, 0], dtype=np.int32)
Y = np.array([[0.0, 0.0, 0.0], [0.6, 0.8, 0.0]])  # deformed bond length 1
VOLUME = np.array([2.0, 3.0])
HORIZON = np.array([2.0, 2.5])
M_U = np.array([4.0, 5.0])


def run_kernel(vm, d_n, *, J=NO_J, kind=ONE, sigma_c=100.0, D_crit=1.0, D_th=0.5, neglect=0.95):
    d = np.zeros(2)
    bbva = np.zeros(2)
    flag = np.zeros(2)
    von_mises_damage_kernel(0, 2, OFFSETS, NEIGHBORS, Y, VOLUME, J, HORIZON, kind, M_U, np.asarray(vm, float), sigma_c, D_crit, D_th,
                            neglect, np.asarray(d_n, float), d, bbva, flag)
    return d, bbva, flag


def test_bond_damage_by_hand():
    # r = 0.4 <= D_th: 0; r = 0.75 between: (0.75 - 0.5)/(1 - 0.5) = 0.5
    d, _, _ = run_kernel([40.0, 75.0], [0.0, 0.0])
    np.testing.assert_allclose(d, [0.0, 0.5], rtol=1e-15)
    # r = 1.2 >= D_crit: 1; r = 0.6 -> trial 0.2, below the previous 0.3: damage never decreases
    d, _, _ = run_kernel([120.0, 60.0], [0.0, 0.3])
    np.testing.assert_allclose(d, [1.0, 0.3], rtol=1e-12)
    # the boundaries: r = D_th gives 0, r = D_crit gives 1
    d, _, _ = run_kernel([50.0, 100.0], [0.0, 0.0])
    np.testing.assert_array_equal(d, [0.0, 1.0])


def test_broken_bond_volume_average_by_hand():
    _, bbva, flag = run_kernel([75.0, 120.0], [0.0, 0.0])
    # point 0: d = 0.5, omega = 1, m_u = 4, neighbour volume 3 (J = 1)
    np.testing.assert_allclose(bbva, [0.5 * 3.0 / 4.0, 1.0 * 2.0 / 5.0], rtol=1e-15)
    np.testing.assert_array_equal(flag, [-1.0, -1.0])
    # with J at N scaling the neighbour's volume and a Gaussian of the deformed length (1)
    J = np.array([1.5, 0.5])
    _, bbva, flag = run_kernel([75.0, 120.0], [0.0, 0.0], J=J, kind=GAUSSIAN, neglect=0.2)
    w0 = math.exp(-1.0 / (2.0 * 2.0 * 0.16))
    w1 = math.exp(-1.0 / (2.5 * 2.5 * 0.16))
    np.testing.assert_allclose(bbva, [0.5 * w0 / 4.0 * (0.5 * 3.0), 1.0 * w1 / 5.0 * (1.5 * 2.0)], rtol=1e-14)
    np.testing.assert_array_equal(flag, [-1.0, 1.0])  # 0.039 < 0.2 < 0.221


def test_bond_invariants_by_hand():
    s = 7.0
    S = np.zeros((3, 9))
    S[0, 0] = s  # uniaxial: vm = s, triaxiality 1/3
    S[1, 1] = S[1, 3] = s  # shear: vm = sqrt(3) s, triaxiality 0
    S[2, [0, 4, 8]] = -s  # hydrostatic: vm = 0
    vm = np.zeros(3)
    tri = np.zeros(3)
    bond_invariants_kernel(0, 1, np.array([0, 3]), S, vm, tri)
    np.testing.assert_allclose(vm[:2], [s, math.sqrt(3.0) * s], rtol=1e-15)
    assert vm[2] == 0.0
    np.testing.assert_allclose(tri[:2], [1.0 / 3.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(tri[2], -s / 1e-20, rtol=1e-15)  # the 1e-20 floor of the von Mises stress


def test_params():
    p = VonMisesStressParams.model_validate({"Critical Von Mises Stress": 1e8})
    assert (p.critical_damage, p.threshold_damage, p.critical_damage_to_neglect) == (1.0, 0.99, 0.95)
    with pytest.raises(ValidationError, match="cannot be greater"):
        VonMisesStressParams.model_validate({"Critical Von Mises Stress": 1e8, "Threshold Damage": 0.9, "Critical Damage": 0.8})
    with pytest.raises(ValidationError):
        VonMisesStressParams.model_validate({"Threshold Damage": 0.5})
    with pytest.raises(ValidationError):
        VonMisesStressParams.model_validate({"Critical Von Mises Stress": -1.0})


# -- through the engine ---------------------------------------------------------------------------
BA = {"Material Model": "Elastic Bond Associated Correspondence", "Density": 7800.0, "Young's Modulus": 200e9, "Poisson's Ratio": 0.3}
DAMAGE = {"Damage Model": "Von Mises Stress", "Critical Von Mises Stress": 300e6, "Threshold Damage": 0.5, "Critical Damage": 1.0}


def pull(sim, strain, dt):
    """Set a homogeneous uniaxial stretch (and the velocity that reaches it in one step dt)."""
    x = sim.fields["Model_Coordinates"]
    u = np.zeros_like(x)
    u[:, 0] = strain * x[:, 0]
    sim.fields["Velocity"][:] = (u - sim.fields["Displacement"]) / dt
    sim.fields["Displacement"][:] = u
    sim.fields["Coordinates"][:] = x + u
    return sim.evaluate_forces().copy()


def test_bond_associated_material_breaks_bonds_above_the_critical_stress():
    """Uniaxial strain eps of an elastic bond-associated body: the bond stresses are about
    those of the continuum, von Mises stress vm = 2 G eps. Bonds take damage once vm exceeds
    D_th sigma_c and are broken for good above sigma_c."""
    sim = build_simulation(cube_deck(BA, n=4, spacing=1e-3, damage=DAMAGE))
    dt = 1e-7
    sim.set_time_step(dt)
    G = 200e9 / 2.6
    history = []
    for step, eps in enumerate((0.5e-3, 1.0e-3, 1.5e-3, 2.5e-3, 3.5e-3), start=1):
        f = pull(sim, eps, dt)
        vm = sim.fields["Bond_Von_Mises_Stress"]
        history.append((float(vm.max()), float(np.max(sim.fields["Bond_Damage"])), float(np.abs(f).max())))
        sim.advance()
    # the damage model reads the stress of the previous evaluation (the material runs after it)
    np.testing.assert_allclose(history[1][0], 2 * G * 0.5e-3, rtol=0.05)
    # vm = 2 G eps of the previous strain: 0, 77, 154, 231, 385 MPa; r = vm / 300 MPa
    assert history[0][1] == 0.0 and history[1][1] == 0.0
    assert 0.0 < history[2][1] < 0.1  # r = 0.513: (0.513 - 0.5)/0.5 = 0.026
    assert 0.4 < history[3][1] < 0.7  # r = 0.769: 0.54
    assert history[4][1] == 1.0  # r = 1.28
    d = sim.fields["Bond_Damage"]
    assert d.min() >= 0.0 and d.max() <= 1.0
    damage = sim.fields["Damage"]
    np.testing.assert_array_equal(damage, sim.fields["Broken_Bond_Volume_Averaged"])
    assert 0.0 < damage.max() <= 1.0 + 1e-12
    flags = sim.fields["Flying_Point_Flag"]
    assert set(np.unique(flags)) <= {-1.0, 1.0}


def test_needs_a_material_with_bond_stresses():
    mat = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 1e9, "Shear Modulus": 1e9}
    with pytest.raises(InputError, match="no stress per bond"):
        build_simulation(cube_deck(mat, n=3, damage=DAMAGE))
