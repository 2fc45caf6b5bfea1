"""Fragments under MPI: a bar cut by two planes into three fragments, the middle one across the
ranks' boundaries and longer than a horizon on each side of them (its smallest global id is no
ghost of the other ranks: the labels must travel through the halo), gives on 2 and 3 ranks the serial run's fragment numbers, masses and velocities
(the numbers follow the smallest global id, so they are equal, not equal up to renumbering)."""
import numpy as np
import pytest

from peridyn.deck.files import dump_yaml
from peridyn.io.exodus_reader import read_results
from peridyn.testing import cube_deck
from peridyn.testing.mpi import mpirun, requires_mpi

pytestmark = [pytest.mark.mpi, requires_mpi]


def plane(x0: float) -> dict:
    return {"Type": "Rectangular_Plane", "Normal_X": 1.0, "Normal_Y": 0.0, "Normal_Z": 0.0,
            "Lower_Left_Corner_X": x0, "Lower_Left_Corner_Y": -1.0, "Lower_Left_Corner_Z": 20.0,
            "Bottom_Unit_Vector_X": 0.0, "Bottom_Unit_Vector_Y": 1.0, "Bottom_Unit_Vector_Z": 0.0,
            "Bottom_Length": 30.0, "Side_Length": 30.0}


def deck() -> dict:
    tree = cube_deck({"Material Model": "Elastic Bond Based", "Density": 7800.0, "Bulk Modulus": 130.0e9}, shape=(30, 3, 3),
                     damage={"Damage Model": "Initial Damage", "Bond Filters": {"A": plane(5.0), "B": plane(25.0)}})
    tree["Boundary Conditions"] = {
        "All Node Set": " ".join(str(k + 1) for k in range(30 * 9)),
        "Spin": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "y", "Value": "x - 15.0"},
    }
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 3.0e-7, "Verlet": {"Fixed dt": 1.0e-7}}
    tree["Output"] = {"Output Filename": "frag", "Output Frequency": 3,
                      "Output Variables": {"Fragment_Id": True, "Fragment_Mass": True, "Fragment_Velocity": True,
                                           "Number_Of_Fragments": True}}
    return tree


@pytest.mark.parametrize("ranks", [2, 3])
def test_fragments_on_several_ranks_are_the_serial_ones(tmp_path, ranks):
    out = {}
    for n in (1, ranks):
        folder = tmp_path / str(n)
        folder.mkdir()
        (folder / "deck.yaml").write_text(dump_yaml(deck()))
        p = mpirun(n, ["run", "deck.yaml", "--no-progress"], cwd=folder)
        assert p.returncode == 0, p.stderr[-3000:]
        out[n] = read_results(folder / "frag.e")
    a, b = out[1], out[ranks]
    assert list(a["global"]["Number_Of_Fragments"]) == list(b["global"]["Number_Of_Fragments"]) == [3.0, 3.0]
    for name in ("Fragment_Id", "Fragment_Mass"):
        assert np.array_equal(a["element"][name], b["element"][name]), name
    assert np.allclose(a["nodal"]["Fragment_VelocityY"], b["nodal"]["Fragment_VelocityY"], rtol=1e-13, atol=1e-13)
    assert set(np.unique(a["element"]["Fragment_Id"])) == {1.0, 2.0, 3.0}
