"""Peridigm's parallel tests as Peridigm runs them (#35): ``cd npN; mpiexec -n N peridyn run
../DECK`` with only the pre-split pieces ``NAME.g.N.r`` there; the answer is the serial run's on
the whole mesh. Two blocks with no bond between them, one Elastic (computed fused on every rank)
and one Elastic Plastic (gathered where its bonds reach ghosts): a rank holding only the first
block still takes part in the ghost-force sums of the others (3 ranks once hung there)."""
import textwrap

import numpy as np
import pytest

from peridyn.io.exodus_mesh import read_exodus_mesh
from peridyn.io.exodus_reader import read_results
from peridyn.testing.exodus_pieces import split_exodus, write_box_mesh
from peridyn.testing.mpi import mpirun, requires_mpi

pytestmark = [pytest.mark.mpi, requires_mpi]

DECK = textwrap.dedent(
    """
    Discretization:
      Type: "Exodus"
      Input Mesh File: "bar.g"
      Omit Bonds Between Blocks: "All"
    Materials:
      Soft:
        Material Model: "Elastic"
        Density: 7800.0
        Bulk Modulus: 130.0e9
        Shear Modulus: 78.0e9
      Plastic:
        Material Model: "Elastic Plastic"
        Density: 7800.0
        Bulk Modulus: 160.0e9
        Shear Modulus: 80.0e9
        Yield Stress: 1.0e6
    Blocks:
      Left:
        Block Names: "block_1"
        Material: "Soft"
        Horizon: 2.01
      Right:
        Block Names: "block_2"
        Material: "Plastic"
        Horizon: 2.01
    Boundary Conditions:
      Pull Left:
        Type: "Prescribed Displacement"
        Node Set: "Left"
        Coordinate: "x"
        Value: "-0.1*t"
      Pull Right:
        Type: "Prescribed Displacement"
        Node Set: "Right"
        Coordinate: "x"
        Value: "0.1*t"
      Swirl:
        Type: "Initial Velocity"
        Node Set: "Middle"
        Coordinate: "y"
        Value: "3.0*z"
    Solver:
      Initial Time: 0.0
      Final Time: 4.0e-3
      Verlet:
        Safety Factor: 0.5
    Output:
      Output Filename: "bar"
      Output Frequency: 10
      Output Variables:
        Displacement: true
        Velocity: true
        Force: true
        Element_Id: true
        Proc_Num: true
        Number_Of_Neighbors: true
    """
)


def mesh(folder):
    """A 12 x 3 x 3 bar of unit cubes in two blocks; node sets on its ends and its middle."""
    write_box_mesh(folder / "bar.g", (12, 3, 3), 1.0, blocks=2, node_sets={"Left": (0, 0.0), "Right": (0, 12.0), "Middle": (0, 6.0)})
    return read_exodus_mesh(folder / "bar.g").num_points


INTERSECTIONS = '''  Compute Element-Horizon Intersections: true
  Element-Horizon Intersection Recursion Level: 1
  Element-Horizon Intersection Number Of Samples: 1
'''


@pytest.mark.parametrize("extra", ["", INTERSECTIONS], ids=["points", "element-horizon intersections"])
def test_pieces_on_2_and_3_ranks_give_the_serial_answer(tmp_path, extra):
    """The intersections read each piece's hexahedra: their partial volumes are the whole
    mesh's. (Their sums follow the ranks' order: 2 ranks on the whole mesh differ from one by
    2e-12 of the force's scale as well.)"""
    tolerance = 1e-10 if extra else 1e-12
    deck = DECK.replace('  Omit Bonds Between Blocks: "All"\n', '  Omit Bonds Between Blocks: "All"\n' + extra)
    assert extra in deck
    serial = tmp_path / "np1"
    serial.mkdir()
    n = mesh(serial)
    (serial / "deck.yaml").write_text(deck)
    proc = mpirun(1, ["run", "deck.yaml", "-q"], serial)
    assert proc.returncode == 0, proc.stderr[-3000:]
    gold = read_results(serial / "bar.e")
    for ranks in (2, 3):
        case = tmp_path / f"case{ranks}"
        here = case / f"np{ranks}"
        here.mkdir(parents=True)
        mesh(here)
        rng = np.random.default_rng(ranks)
        split_exodus(here / "bar.g", rng.integers(0, ranks, n), ranks)  # pieces unlike the run's own partition
        (here / "bar.g").unlink()
        (case / "deck.yaml").write_text(deck)
        proc = mpirun(ranks, ["run", "../deck.yaml", "-q"], here, timeout=240)
        assert proc.returncode == 0, proc.stderr[-3000:]
        got = read_results(here / "bar.e")
        np.testing.assert_array_equal(got["times"], gold["times"])
        assert len(gold["times"]) >= 3
        for kind in ("nodal", "element"):
            for name, values in gold[kind].items():
                if name.startswith("Proc_Num"):
                    continue
                a, b = np.asarray(values), np.asarray(got[kind][name])
                scale = max(float(np.max(np.abs(a))), 1e-300)
                np.testing.assert_allclose(b, a, rtol=0, atol=tolerance * scale, err_msg=f"{name} on {ranks} ranks")
        assert set(np.unique(np.asarray(got["element"]["Proc_Num"])[-1])) == set(range(ranks))
        assert float(np.max(np.abs(np.asarray(gold["nodal"]["VelocityY"])[-1]))) > 0.0
