"""Output on several ranks without a gather (#35, engine/output_pieces.py): each rank writes its
own points to its own piece; by default the pieces are joined into the one NAME.e at the end
(the same values as one rank's file, within round-off), with ``Merge Rank Files: false`` they stay
as Peridigm names them (NAME.e.N.r, each holding only its rank's points) and ``peridyn merge``
joins them into the same bits."""
import netCDF4
import numpy as np
import pytest

from peridyn.deck.files import dump_yaml
from peridyn.io.exodus_reader import read_results
from peridyn.testing import cube_deck
from peridyn.testing.mpi import mpirun, requires_mpi

pytestmark = [pytest.mark.mpi, requires_mpi]

STEEL = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 130.0e9, "Shear Modulus": 78.0e9}


def _deck(folder, merge: bool = True):
    tree = cube_deck(dict(STEEL), shape=(12, 5, 4), spacing=1.0e-3, damage={"Damage Model": "Critical Stretch",
                                                                             "Critical Stretch": 0.002})
    tree["Boundary Conditions"] = {
        "Left Node Set": {"Half Space": {"Point": [1.5e-3, 0.0, 0.0], "Normal": [-1.0, 0.0, 0.0]}},
        "Pull": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": "x", "Value": "-50.0*t"},
        "Spin": {"Type": "Initial Velocity", "Node Set": "Left Node Set", "Coordinate": "y", "Value": "3.0*z"},
    }
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0e-5, "Verlet": {"Safety Factor": 0.5}}
    tree["Output"] = {"Output Filename": "bar", "Output Frequency": 8, "Merge Rank Files": merge,
                      "Output Variables": {"Displacement": True, "Velocity": True, "Damage": True, "Proc_Num": True,
                                           "Number_Of_Neighbors": True, "Global_Kinetic_Energy": True}}
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "bar.yaml").write_text(dump_yaml(tree))


def _run(ranks, folder):
    proc = mpirun(ranks, ["run", "bar.yaml", "-q"], folder, timeout=240)
    assert proc.returncode == 0, proc.stderr[-3000:]


def test_three_ranks_write_pieces_that_join_into_one_ranks_file(tmp_path):
    serial, merged, kept = tmp_path / "np1", tmp_path / "np3", tmp_path / "kept"
    _deck(serial)
    _deck(merged)
    _deck(kept, merge=False)
    _run(1, serial)
    _run(3, merged)
    _run(3, kept)
    assert sorted(p.name for p in merged.iterdir()) == ["bar.e", "bar.yaml"]  # the pieces joined and gone
    pieces = sorted(kept.glob("bar.e.3.*"))
    assert [p.name for p in pieces] == ["bar.e.3.0", "bar.e.3.1", "bar.e.3.2"] and not (kept / "bar.e").exists()
    gold = read_results(serial / "bar.e")
    n = len(gold["nodal"]["DisplacementX"][0])
    sizes = []
    for r, p in enumerate(pieces):  # each piece holds its rank's points only
        piece = read_results(p)
        sizes.append(len(piece["node_num_map"]))
        assert set(np.asarray(piece["element"]["Proc_Num"])[-1]) == {r}
    assert sum(sizes) == n and max(sizes) < n
    joined = mpirun(1, ["merge", "bar.e"], kept)
    assert joined.returncode == 0, joined.stderr
    a, b = netCDF4.Dataset(kept / "bar.e"), netCDF4.Dataset(merged / "bar.e")
    for name in a.variables:
        if name != "qa_records":
            np.testing.assert_array_equal(np.asarray(a[name][:]), np.asarray(b[name][:]), err_msg=name)
    got = read_results(merged / "bar.e")
    np.testing.assert_array_equal(got["times"], gold["times"])
    np.testing.assert_array_equal(got["node_num_map"], gold["node_num_map"])
    assert got["node_sets"].keys() == gold["node_sets"].keys()
    for name, members in gold["node_sets"].items():
        np.testing.assert_array_equal(got["node_sets"][name], members)
    for kind in ("nodal", "element", "global"):
        for name, values in gold[kind].items():
            if name.startswith("Proc_Num"):
                continue
            x, y = np.asarray(values), np.asarray(got[kind][name])
            scale = max(float(np.max(np.abs(x))), 1e-300)
            np.testing.assert_allclose(y, x, rtol=0, atol=1e-12 * scale, err_msg=name)
    assert float(np.max(np.asarray(gold["element"]["Damage"])[-1])) > 0.0  # bonds broke: the frames differ
    assert set(np.unique(np.asarray(got["element"]["Proc_Num"])[-1])) == {0, 1, 2}
