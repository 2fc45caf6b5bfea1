"""J_Integral on prescribed (not solved) displacement fields: Williams' K field gives K^2/E on
every ring and for either crack direction, fields without a crack give 0; the Hooke laws and
elastic constants; parameters; Peridigm's JIntegral key."""
import logging
import math

import numpy as np
import pytest
from pydantic import ValidationError

from peridyn.computes.j_integral import JIntegralParams, elastic_constants, hooke
from peridyn.core.errors import InputError
from peridyn.testing import build_simulation, cube_deck

E, NU, DX, K_I = 3.0e9, 1.0 / 3.0, 1.0e-3, 1.0e6


def williams(x, y):
    mu = E / (2 * (1 + NU))
    kappa = (3 - NU) / (1 + NU)
    r, th = np.hypot(x, y), np.arctan2(y, x)
    f = K_I / (2 * mu) * np.sqrt(r / (2 * math.pi))
    return f * np.cos(th / 2) * (kappa - 1 + 2 * np.sin(th / 2) ** 2), f * np.sin(th / 2) * (kappa + 1 - 2 * np.cos(th / 2) ** 2)


def square(n=30, crack_from=None, direction=1.0, rings=((3, 8), (5, 12), (4, 14))):
    """A plane-stress bond-based square of n x n points around the origin, optionally cut along
    y = 0 from x = crack_from to the tip at 0 (crack_from < 0: crack on the left)."""
    L, h = n * DX, DX
    tree = {
        "Discretization": {"Type": "Shapes", "Shapes": {"Body": {"Shape": "Box", "Block": "block_1", "Min": [-L / 2, -L / 2, 0.0], "Max": [L / 2, L / 2, h], "Spacing": DX}}},
        "Materials": {"M": {"Material Model": "Elastic Bond Based", "Density": 1200.0, "Young's Modulus": E, "Plane Stress": True, "Height": h}},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": 3.0 * DX * (1 + 1e-9)}},
        "Compute Class Parameters": {
            f"J{ri}_{ro}": {"Compute Class": "J_Integral", "Crack Tip X": 0.0, "Crack Tip Y": 0.0, "Crack Direction X": direction,
                            "Inner Radius": ri * DX, "Outer Radius": ro * DX, "Thickness": h}
            for ri, ro in rings
        },
    }
    if crack_from is not None:
        lo = min(crack_from, 0.0)
        tree["Discretization"]["Bond Filters"] = {"Crack": {
            "Type": "Rectangular_Plane", "Normal_X": 0.0, "Normal_Y": 1.0, "Normal_Z": 0.0,
            "Lower_Left_Corner_X": lo, "Lower_Left_Corner_Y": 0.0, "Lower_Left_Corner_Z": -h,
            "Bottom_Unit_Vector_X": 1.0, "Bottom_Unit_Vector_Y": 0.0, "Bottom_Unit_Vector_Z": 0.0,
            "Bottom_Length": abs(crack_from), "Side_Length": 3 * h,
        }}
    return build_simulation(tree)


def displace(sim, ux, uy):
    x = sim.fields["Model_Coordinates"]
    sim.fields["Coordinates"][:, 0] = x[:, 0] + ux
    sim.fields["Coordinates"][:, 1] = x[:, 1] + uy
    sim.fields["Coordinates"][:, 2] = x[:, 2]


def values(sim):
    return {name: c.value(sim) for name, c in sim.outputs.computes.items()}


def test_williams_field_gives_k_squared_over_e_on_every_ring():
    sim = square(crack_from=-1.0)
    x = sim.fields["Model_Coordinates"]
    displace(sim, *williams(x[:, 0], x[:, 1]))
    for name, J in values(sim).items():
        assert J / (K_I**2 / E) == pytest.approx(1.0, abs=0.02), name


def test_crack_direction_minus_x():
    """The mirrored field (crack on the positive x axis, growing towards -x)."""
    sim = square(crack_from=1.0, direction=-1.0)
    x = sim.fields["Model_Coordinates"]
    ux, uy = williams(-x[:, 0], x[:, 1])
    displace(sim, -ux, uy)
    for name, J in values(sim).items():
        assert J / (K_I**2 / E) == pytest.approx(1.0, abs=0.02), name


def test_no_crack_no_energy_release():
    sim = square()
    x = sim.fields["Model_Coordinates"]
    eps = 1e-3
    displace(sim, -NU * eps * x[:, 0] + 2e-4, eps * x[:, 1] + 0.3e-3 * x[:, 0])  # uniform strain + translation
    W = 0.5 * E * eps**2
    for name, J in values(sim).items():
        assert abs(J) < 1e-9 * W * DX, name  # uniform fields: the domain integral vanishes
    displace(sim, 1e-4, -2e-4)  # rigid translation
    assert all(abs(J) < 1e-20 for J in values(sim).values())


def test_global_output_is_filled():
    sim = square(crack_from=-1.0, rings=((3, 8),))
    x = sim.fields["Model_Coordinates"]
    displace(sim, *williams(x[:, 0], x[:, 1]))
    var = sim.outputs.variables["J3_8"]
    assert var.kind == "global"
    sim.outputs.run_computes(["J3_8"])
    assert sim.fields["J3_8"][0] == pytest.approx(K_I**2 / E, rel=0.02)


def test_hooke_laws():
    H = np.zeros((1, 3, 3))
    H[0, 0, 0] = 1e-3
    H[0, 1, 1] = -NU * 1e-3
    sig, W = hooke(H, E, NU, "plane stress")  # uniaxial stress
    assert sig[0, 0, 0] == pytest.approx(E * 1e-3, rel=1e-12)
    assert abs(sig[0, 1, 1]) < 1e-6 * E * 1e-3
    assert W[0] == pytest.approx(0.5 * E * 1e-6, rel=1e-12)
    H = np.zeros((1, 3, 3))
    H[0, 0, 0] = 1e-3
    sig, _ = hooke(H, E, 0.25, "plane strain")  # uniaxial strain, eps_zz = 0
    lam, mu = E * 0.25 / (1.25 * 0.5), E / 2.5
    assert sig[0, 0, 0] == pytest.approx((lam + 2 * mu) * 1e-3, rel=1e-12)
    H[0, 2, 2] = 0.0
    sig3, _ = hooke(H, E, 0.25, "3d")
    assert sig3[0, 0, 0] == pytest.approx((lam + 2 * mu) * 1e-3, rel=1e-12)
    assert sig3[0, 2, 2] == pytest.approx(lam * 1e-3, rel=1e-12)


@pytest.mark.parametrize(
    "material, expected",
    [
        ({"Material Model": "Elastic", "Density": 1.0, "Young's Modulus": 200e9, "Poisson's Ratio": 0.3}, (200e9, 0.3, "3d")),
        ({"Material Model": "Elastic Bond Based", "Density": 1.0, "Young's Modulus": 90e9}, (90e9, 0.25, "3d")),
        ({"Material Model": "Elastic Bond Based", "Density": 1.0, "Young's Modulus": 90e9, "Plane Strain": True, "Height": 1.0}, (90e9, 0.25, "plane strain")),
        ({"Material Model": "Elastic", "Density": 1.0, "Young's Modulus": 70e9, "Poisson's Ratio": 0.2, "Plane Stress": True}, (70e9, 0.2, "plane stress")),
        ({"Material Model": "Elastic", "Density": 1.0, "Young's Modulus": 70e9, "Poisson's Ratio": 0.2, "Plane Strain": True}, (70e9, 0.2, "plane strain")),
    ],
)
def test_elastic_constants_of_the_materials(material, expected):
    sim = build_simulation(cube_deck(material, n=3))
    E_, nu, mode = elastic_constants(sim.blocks[0].material)
    assert (E_, nu) == pytest.approx(expected[:2], rel=1e-12)
    assert mode == expected[2]


def test_params():
    base = {"Crack Tip X": 0.0, "Crack Tip Y": 0.0, "Inner Radius": 1.0, "Outer Radius": 2.0, "Thickness": 0.1}
    p = JIntegralParams.model_validate(base)
    assert (p.crack_direction_x, p.front_direction_z, p.block, p.output_label) == (1.0, 1.0, None, None)
    for change in ({"Outer Radius": 1.0}, {"Inner Radius": -1.0}, {"Thickness": 0.0}, {"Crack Direction X": 0.0},
                   {"Crack Direction X": 0.0, "Crack Direction Z": 1.0}, {"Crack Tip X": float("nan")}, {"Radius": 1.0}):
        with pytest.raises(ValidationError):
            JIntegralParams.model_validate({**base, **change})
    with pytest.raises(ValidationError):
        JIntegralParams.model_validate({k: v for k, v in base.items() if k != "Thickness"})


def test_unknown_block_and_unsupported_material_are_input_errors():
    comp = {"Compute Class": "J_Integral", "Crack Tip X": 0.0, "Crack Tip Y": 0.0, "Inner Radius": 1.0, "Outer Radius": 2.0, "Thickness": 1.0}
    mat = {"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1e9, "Shear Modulus": 1e9}
    with pytest.raises(InputError, match="not a block"):
        build_simulation(cube_deck(mat, n=3, extra={"Compute Class Parameters": {"J": {**comp, "Block": "nope"}}}))
    visco = {"Material Model": "Viscoelastic", "Density": 1.0, "Bulk Modulus": 1e9, "Shear Modulus": 1e9, "lambda_i": 0.5, "tau b": 1.0}
    with pytest.raises(InputError, match="supports blocks"):
        build_simulation(cube_deck(visco, n=3, extra={"Compute Class Parameters": {"J": comp}}))


def test_peridigm_jintegral_is_accepted_and_computes_nothing(caplog):
    mat = {"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1e9, "Shear Modulus": 1e9}
    deck = cube_deck(mat, n=3, extra={"Compute Class Parameters": {"JI": {"Compute Class": "JIntegral", "Block ID": 1, "dt": 1e-6}}})
    with caplog.at_level(logging.WARNING, logger="peridyn.computes"):
        sim = build_simulation(deck)
    assert "computes nothing" in caplog.text
    assert sim.outputs.computes["JI"].outputs(sim) == []
    deck["Compute Class Parameters"]["JI"]["Block ID"] = 7
    with pytest.raises(InputError, match="Block ID 7"):
        build_simulation(deck)
