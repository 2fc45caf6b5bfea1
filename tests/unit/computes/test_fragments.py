"""Fragments: a body cut in two by an Initial Damage plane is two fragments with exactly the masses
and centre-of-mass velocities of its halves; an intact body is one; points with no bond are their
own; the numbering follows the smallest global id; and the outputs reach the Exodus file."""
import numpy as np
import pytest

from peridyn.computes.fragments import component_labels, label_fragments
from peridyn.testing import build_simulation, cube_deck

RHO = 7800.0
BOND_BASED = {"Material Model": "Elastic Bond Based", "Density": RHO, "Bulk Modulus": 130.0e9}


def plane_x(x0: float) -> dict:
    """A plane x = x0 across the whole unit-spacing cube (Peridigm's Rectangular_Plane filter)."""
    return {"Type": "Rectangular_Plane", "Normal_X": 1.0, "Normal_Y": 0.0, "Normal_Z": 0.0,
            "Lower_Left_Corner_X": x0, "Lower_Left_Corner_Y": -1.0, "Lower_Left_Corner_Z": 20.0,
            "Bottom_Unit_Vector_X": 0.0, "Bottom_Unit_Vector_Y": 1.0, "Bottom_Unit_Vector_Z": 0.0,
            "Bottom_Length": 30.0, "Side_Length": 30.0}


def cut_cube(x0: float = 3.0, n: int = 6):
    tree = cube_deck(BOND_BASED, n=n, damage={"Damage Model": "Initial Damage", "Bond Filters": {"Cut": plane_x(x0)}})
    sim = build_simulation(tree)
    x = sim.fields["Model_Coordinates"][: sim.num_owned]
    sim.fields["Velocity"][: sim.num_owned] = np.column_stack([x[:, 0] - 3.0, np.ones(len(x)), x[:, 2] ** 2])
    return sim, x


def test_a_cube_cut_by_a_plane_is_two_fragments_with_exact_masses_and_velocities():
    sim, x = cut_cube()
    s = label_fragments(sim)
    assert s.count == 2
    left = x[:, 0] < 3.0
    vol = sim.fields["Volume"][: sim.num_owned]
    v = sim.fields["Velocity"][: sim.num_owned]
    first = int(s.number[np.argmin(sim.gid[: sim.num_owned])])  # the fragment of global point 0 is number 1
    assert first == 1 and np.all(s.number[left] == s.number[left][0]) and np.all(s.number[~left] != s.number[left][0])
    for side in (left, ~left):
        k = int(s.number[side][0]) - 1
        m = RHO * vol[side]
        assert s.mass[k] == pytest.approx(m.sum(), rel=1e-14)
        assert s.velocity[k] == pytest.approx((m[:, None] * v[side]).sum(axis=0) / m.sum(), rel=1e-13, abs=1e-13)
        assert s.kinetic[k] == pytest.approx(0.5 * (m * np.einsum("ij,ij->i", v[side], v[side])).sum(), rel=1e-13)
    assert s.mass.sum() == pytest.approx(RHO * vol.sum(), rel=1e-14)


def test_an_intact_body_is_one_fragment_and_a_bondless_point_its_own():
    sim = build_simulation(cube_deck(BOND_BASED, n=4))
    assert label_fragments(sim).count == 1
    # labels: three chains 0-1, 2, 3-4-5 (bond 4-5 broken in the second call)
    offsets = np.array([0, 1, 2, 2, 3, 5, 6])
    neighbors = np.array([1, 0, 4, 3, 5, 4], dtype=np.int32)
    gid = np.array([5.0, 4.0, 3.0, 2.0, 1.0, 0.0])
    assert list(component_labels(6, offsets, neighbors, np.zeros(0, np.uint8), gid)) == [4.0, 4.0, 3.0, 0.0, 0.0, 0.0]
    intact = np.array([1, 1, 1, 1, 0, 0], dtype=np.uint8)
    assert list(component_labels(6, offsets, neighbors, intact, gid)) == [4.0, 4.0, 3.0, 1.0, 1.0, 0.0]


def test_the_outputs_reach_the_exodus_file(tmp_path):
    netCDF4 = pytest.importorskip("netCDF4")
    from peridyn.cli import main
    from peridyn.deck.files import dump_yaml

    tree = cube_deck(BOND_BASED, n=6, damage={"Damage Model": "Initial Damage", "Bond Filters": {"Cut": plane_x(3.0)}})
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 2.0e-7, "Verlet": {"Fixed dt": 1.0e-7}}
    tree["Output"] = {"Output Filename": "frag", "Output Frequency": 1,
                      "Output Variables": {"Fragment_Id": True, "Fragment_Mass": True, "Fragment_Velocity": True,
                                           "Fragment_Kinetic_Energy": True, "Number_Of_Fragments": True}}
    (tmp_path / "deck.yaml").write_text(dump_yaml(tree))
    assert main(["run", str(tmp_path / "deck.yaml"), "--output-dir", str(tmp_path), "--no-progress"]) == 0
    with netCDF4.Dataset(tmp_path / "frag.e") as ds:
        names = [str(n) for n in netCDF4.chartostring(ds["name_glo_var"][:])]
        count = np.array(ds["vals_glo_var"][:])[:, names.index("Number_Of_Fragments")]
        elem = [str(n) for n in netCDF4.chartostring(ds["name_elem_var"][:])]
        ids = np.array(ds[f"vals_elem_var{elem.index('Fragment_Id') + 1}eb1"][:])
    assert list(count) == [2.0, 2.0, 2.0] and set(np.unique(ids)) == {1.0, 2.0}
