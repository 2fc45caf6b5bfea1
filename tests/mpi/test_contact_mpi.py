"""Contact under MPI: the reference cases on 3 ranks, and results identical to the serial run
(every point gathers its contact terms in global-id order) even when a body crosses the ranks'
regions."""
import shlex
import subprocess
import sys
from pathlib import Path

import netCDF4
import numpy as np
import pytest

from peridyn.deck.files import dump_yaml
from peridyn.testing.mpi import MPIEXEC, mpirun, requires_mpi

HERE = Path(__file__).resolve().parent
RUNNER = HERE.parents[1].parent / "shared" / "conformance" / "run.py"
CASES = ["Contact_2x1x1", "Contact_Friction", "Contact_Cubes", "Contact_Perforation"]

pytestmark = [pytest.mark.mpi, requires_mpi]


@pytest.mark.conformance
@pytest.mark.skipif(not RUNNER.exists(), reason="../shared/conformance is not present")
def test_contact_cases_pass_on_three_ranks():
    cmd = f"{shlex.quote(sys.executable)} -m peridyn run"
    proc = subprocess.run(
        [sys.executable, str(RUNNER), "--cmd", cmd, "--np", "3", "--mpiexec", MPIEXEC, "--only", *CASES, "--timeout", "600"],
        capture_output=True, text=True, timeout=1200,
    )
    assert f"{len(CASES)} passed, 0 failed" in proc.stdout, proc.stdout[-3000:] + proc.stderr[-2000:]


def _flyby(path: Path) -> None:
    """A small box flying at high speed between two rows of boxes, grazing them: it leaves its
    rank's region long before the end, and friction is on."""
    shapes = {f"B{k}": {"Shape": "Box", "Block": "block_1", "Min": [4.0 * k, 0.0, 0.0], "Max": [4.0 * k + 3.0, 3.0, 3.0], "Spacing": 1.0} for k in range(4)}
    # the same row above, so the flyer is squeezed evenly and keeps its height
    shapes.update({f"T{k}": {"Shape": "Box", "Block": "block_1", "Min": [4.0 * k, 0.0, 4.6], "Max": [4.0 * k + 3.0, 3.0, 7.6], "Spacing": 1.0} for k in range(4)})
    shapes["Fly"] = {"Shape": "Box", "Block": "block_2", "Min": [-4.0, 0.4, 2.8], "Max": [-1.0, 2.4, 4.8], "Spacing": 1.0}
    tree = {
        "Discretization": {"Type": "Shapes", "Omit Bonds Between Blocks": "All", "Shapes": shapes},
        "Materials": {"M": {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1e9, "Shear Modulus": 6e8}},
        "Damage Models": {"D": {"Damage Model": "Critical Stretch", "Critical Stretch": 0.002}},
        "Blocks": {
            "Row": {"Block Names": "block_1", "Material": "M", "Damage Model": "D", "Horizon": 2.015},
            "Fly": {"Block Names": "block_2", "Material": "M", "Horizon": 2.015},
        },
        "Contact": {
            "Search Radius": 3.0,
            "Search Frequency": 10,
            "Models": {"C": {"Contact Model": "Short Range Force", "Contact Radius": 1.0, "Spring Constant": 1e9, "Friction Coefficient": 0.3}},
        },
        "Boundary Conditions": {"Go": {"Type": "Initial Velocity", "Node Set": "Fly", "Coordinate": "x", "Value": "800.0"}},
        "Solver": {"Final Time": 0.03, "Verlet": {"Safety Factor": 0.5}},
        "Output": {"Output Filename": "flyby", "Output Frequency": 1,
                   "Output Variables": {"Displacement": True, "Velocity": True, "Contact_Force_Density": True, "Damage": True}},
    }
    (path / "flyby.yaml").write_text(dump_yaml(tree))


def _values(path: Path) -> dict[str, np.ndarray]:
    with netCDF4.Dataset(path / "flyby.e") as ds:
        return {k: v[:].data for k, v in ds.variables.items() if k.startswith("vals_")}


@pytest.mark.parametrize("ranks", [2, 3])
def test_a_body_crossing_every_rank_gives_the_serial_result_bit_for_bit(tmp_path, ranks):
    serial, parallel = tmp_path / "s", tmp_path / "p"
    for d in (serial, parallel):
        d.mkdir()
        _flyby(d)
    one = mpirun(1, ["run", "flyby.yaml", "-q"], cwd=serial)
    many = mpirun(ranks, ["run", "flyby.yaml", "-q"], cwd=parallel)
    assert one.returncode == 0, one.stderr[-2000:]
    assert many.returncode == 0, many.stderr[-2000:]
    a, b = _values(serial), _values(parallel)
    assert a.keys() == b.keys()
    for k in a:
        assert np.array_equal(a[k], b[k]), k
    # the flyer touched the far boxes too: contact found across the ranks' regions
    with netCDF4.Dataset(serial / "flyby.e") as ds:
        x = ds["coordx"][:].data
        z = ds["coordz"][:].data
        names = ["".join(c.decode() for c in row if c) for row in ds["name_nod_var"][:].data]
        cx = ds[f"vals_nod_var{names.index('Contact_Force_DensityX') + 1}"][:].data
    far = (x > 12.0) & ((z < 2.7) | (z > 5.0))  # the last boxes of both rows
    assert np.abs(cx[:, far]).max() > 0
