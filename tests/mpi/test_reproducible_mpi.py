"""Issue #19 under MPI: rnd() fields are the same on any number of ranks, MPI ends without
MPICH's "freeing inactive persistent request" lines, and the output lock is released."""
import textwrap
from pathlib import Path

import numpy as np
import pytest

from peridyn.io.exodus_reader import read_results
from peridyn.testing.mpi import mpirun, requires_mpi

pytestmark = [pytest.mark.mpi, requires_mpi]

DECK = textwrap.dedent(
    """
    Random Seed: 5
    Discretization:
      Type: "Text File"
      Input Mesh File: "points.txt"
    Materials:
      Steel:
        Material Model: "Elastic"
        Density: 7800.0
        Bulk Modulus: 130.0e9
        Shear Modulus: 78.0e9
    Blocks:
      All:
        Block Names: "block_1"
        Material: "Steel"
        Horizon: "1.6 + rnd(0.4)"
    Boundary Conditions:
      Kick Node Set: "{ids}"
      Kick X:
        Type: "Initial Velocity"
        Node Set: "Kick Node Set"
        Coordinate: "x"
        Value: "rnd(1.0) + rnd(0.5)"
      Kick Z:
        Type: "Initial Velocity"
        Node Set: "Kick Node Set"
        Coordinate: "z"
        Value: "rnd(1.0)"
    Solver:
      Initial Time: 0.0
      Final Time: 3.0e-4
      Verlet:
        Safety Factor: 0.5
    Output:
      Output Filename: "rand"
      Output Frequency: 1
      Output Variables:
        Velocity: true
        Displacement: true
        Horizon: true
    """
).format(ids=" ".join(str(i) for i in range(1, 217)))


def run(folder: Path, ranks: int):
    folder.mkdir()
    (folder / "deck.yaml").write_text(DECK)
    g = np.arange(6) + 0.5
    (folder / "points.txt").write_text("".join(f"{x} {y} {z} 1 1.0\n" for z in g for y in g for x in g))
    proc = mpirun(ranks, ["run", "deck.yaml", "-q"], folder)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc


def test_random_fields_are_the_same_on_one_and_two_ranks(tmp_path):
    run(tmp_path / "np1", 1)
    proc = run(tmp_path / "np2", 2)
    assert "freeing inactive persistent request" not in proc.stderr
    assert "persistent request" not in proc.stdout + proc.stderr
    a, b = read_results(tmp_path / "np1" / "rand.e"), read_results(tmp_path / "np2" / "rand.e")
    v0 = a["nodal"]["VelocityX"][0]
    assert len(a["times"]) > 2
    assert np.all(np.abs(v0) <= 1.5) and len(np.unique(v0)) == v0.size  # a random field
    for name in ("VelocityX", "VelocityZ"):
        np.testing.assert_array_equal(a["nodal"][name][0], b["nodal"][name][0], err_msg=name)
    ha, hb = (np.asarray(r["element"]["Horizon"])[0] for r in (a, b))
    assert len(np.unique(ha)) == ha.size and np.all((ha >= 1.2) & (ha < 2.0))
    np.testing.assert_array_equal(ha, hb)
    scale = float(np.max(np.abs(a["nodal"]["DisplacementX"][-1])))
    np.testing.assert_allclose(a["nodal"]["DisplacementX"][-1], b["nodal"]["DisplacementX"][-1], rtol=0, atol=1e-9 * scale)
    assert not (tmp_path / "np2" / "rand.lock").exists()
