"""``peridyn fragments RESULT.e``: the distribution of a cut cube's two fragments, exact; bad input
(no file, no fragment outputs, a frame that is not there) is one line and exit 2."""
import numpy as np
import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.deck.files import dump_yaml
from peridyn.io.fragment_report import format_table, fragment_table
from peridyn.testing import cube_deck

RHO = 7800.0


def run_cut_cube(folder, variables=("Fragment_Id", "Fragment_Mass", "Fragment_Velocity")):
    plane = {"Type": "Rectangular_Plane", "Normal_X": 1.0, "Normal_Y": 0.0, "Normal_Z": 0.0,
             "Lower_Left_Corner_X": 2.0, "Lower_Left_Corner_Y": -1.0, "Lower_Left_Corner_Z": 20.0,
             "Bottom_Unit_Vector_X": 0.0, "Bottom_Unit_Vector_Y": 1.0, "Bottom_Unit_Vector_Z": 0.0,
             "Bottom_Length": 30.0, "Side_Length": 30.0}
    tree = cube_deck({"Material Model": "Elastic Bond Based", "Density": RHO, "Bulk Modulus": 130.0e9}, n=6,
                     damage={"Damage Model": "Initial Damage", "Bond Filters": {"Cut": plane}})
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 2.0e-7, "Verlet": {"Fixed dt": 1.0e-7}}
    tree["Output"] = {"Output Filename": "frag", "Output Frequency": 1, "Output Variables": {v: True for v in variables}}
    (folder / "deck.yaml").write_text(dump_yaml(tree))
    assert main(["run", str(folder / "deck.yaml"), "--output-dir", str(folder), "--no-progress"]) == 0
    return folder / "frag.e"


def test_the_distribution_of_a_cube_cut_one_third_across(tmp_path, capsys):
    result = run_cut_cube(tmp_path)
    t = fragment_table(result)
    # the plane x = 2 leaves 2 of 6 layers (72 points) on one side and 4 (144) on the other, volume 1 each
    assert list(t["points"]) == [144, 72] and t["mass"] == pytest.approx([144 * RHO, 72 * RHO], rel=1e-14)
    assert list(t["number"]) == [2, 1] and t["frame"] == 2 and t["speed"] is not None
    text = format_table(t)
    assert "2 fragment(s)" in text and "0.6667" in text and "0.3333" in text
    assert main(["fragments", str(result), "--frame", "0"]) == ExitCode.OK
    assert "frame 0 (t = 0)" in capsys.readouterr().out
    pytest.importorskip("matplotlib")
    assert main(["fragments", str(result), "--plot", str(tmp_path / "f.png")]) == ExitCode.OK
    assert (tmp_path / "f.png").stat().st_size > 1000


@pytest.mark.parametrize("case", ["missing", "no outputs", "frame"])
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, case):
    if case == "missing":
        args, words = ["fragments", str(tmp_path / "none.e")], ("no such result file",)
    elif case == "no outputs":
        result = run_cut_cube(tmp_path, variables=("Displacement",))
        capsys.readouterr()
        args, words = ["fragments", str(result)], ("Fragment_Id", "Output Variables")
    else:
        result = run_cut_cube(tmp_path)
        capsys.readouterr()
        args, words = ["fragments", str(result), "--frame", "7"], ("--frame 7", "0 .. 2")
    assert main(args) == ExitCode.INPUT_ERROR
    err = [line for line in capsys.readouterr().err.strip().splitlines() if line]
    assert len(err) == 1 and all(w in err[0] for w in words), err
