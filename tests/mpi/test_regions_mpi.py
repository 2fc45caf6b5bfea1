"""Node sets by geometry under MPI (docs/regions.md): a region is evaluated on every point's
reference coordinates, which every rank holds, so the node sets, the initial velocity on them
and a traction's and a pressure's loads are the same on one and two ranks."""
import textwrap
from pathlib import Path

import numpy as np
import pytest

from peridyn.io.exodus_reader import read_results
from peridyn.testing.mpi import mpirun, requires_mpi

pytestmark = [pytest.mark.mpi, requires_mpi]

DECK = textwrap.dedent(
    """
    Discretization:
      Type: "Shapes"
      Shapes:
        Rod: {Shape: "Cylinder", Block: "block_1", Center: [0.0, 0.0, 0.006], Radius: 0.004, Length: 0.012, Axis: "z", Spacing: 0.001}
    Materials:
      Steel: {Material Model: "Elastic", Density: 7800.0, Bulk Modulus: 130.0e9, Shear Modulus: 78.0e9}
    Blocks:
      All: {Block Names: "block_1", Material: "Steel", Horizon: 0.002015}
    Boundary Conditions:
      Skin Node Set: {Surface Layer: {Thickness: 0.002}}
      Top Node Set:
        Intersection:
          Skin: {Surface Layer: {Thickness: 0.001}}
          Top: {Half Space: {Point: [0.0, 0.0, 0.011], Normal: [0.0, 0.0, 1.0]}}
      Core Node Set:
        Difference:
          Tube: {Cylinder: {Center: [0.0, 0.0, 0.006], Axis: [0.0, 0.0, 1.0], Radius: 0.003, Inner Radius: 0.001, Min: -0.004, Max: 0.004}}
          Ball: {Sphere: {Center: [0.002, 0.0, 0.006], Radius: 0.0015}}
          Left: {Expression: "x < -0.0015 && y > 0"}
      Kick:
        Type: "Initial Velocity"
        Node Set: "Core Node Set"
        Coordinate: "x"
        Value: "1.0 + z"
      Press: {Type: "Surface Traction", Node Set: "Skin Node Set", Pressure: 1.0e6, Scale: "t/1.0e-6"}
      Pull: {Type: "Surface Traction", Node Set: "Top Node Set", Traction: [0.0, 2.0e6, 5.0e6]}
    Solver:
      Initial Time: 0.0
      Final Time: 2.0e-7
      Verlet: {Fixed dt: 5.0e-8}
    Output:
      Output Filename: "regions"
      Output Frequency: 1
      Output Variables: {Velocity: true, Displacement: true, External_Force_Density: true}
    """
)


def run(folder: Path, ranks: int):
    folder.mkdir()
    (folder / "deck.yaml").write_text(DECK)
    proc = mpirun(ranks, ["run", "deck.yaml", "-q"], folder)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return read_results(folder / "regions.e")


def test_geometric_node_sets_are_the_same_on_one_and_two_ranks(tmp_path):
    a, b = run(tmp_path / "np1", 1), run(tmp_path / "np2", 2)
    names = {"SKIN_NODE_SET", "TOP_NODE_SET", "CORE_NODE_SET"}
    assert names <= set(a["node_sets"])
    for name in names:
        assert a["node_sets"][name].size > 0
        np.testing.assert_array_equal(np.sort(a["node_sets"][name]), np.sort(b["node_sets"][name]), err_msg=name)
    v0 = a["nodal"]["VelocityX"][0]
    assert np.count_nonzero(v0) == a["node_sets"]["CORE_NODE_SET"].size
    for name in ("VelocityX", "External_Force_DensityX", "External_Force_DensityY", "External_Force_DensityZ"):
        for k in range(len(a["times"])):
            np.testing.assert_array_equal(a["nodal"][name][k], b["nodal"][name][k], err_msg=f"{name} frame {k}")
    scale = float(np.max(np.abs(a["nodal"]["DisplacementX"][-1])))
    assert scale > 0
    np.testing.assert_allclose(a["nodal"]["DisplacementX"][-1], b["nodal"]["DisplacementX"][-1], rtol=0, atol=1e-9 * scale)
