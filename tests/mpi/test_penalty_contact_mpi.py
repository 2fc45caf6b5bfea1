"""``Penalty Contact`` under MPI: examples/penalty_contact.yaml (two blocks of different bulk
moduli, so the ghosts carry the partner block's stiffness) on 2 ranks gives the serial result bit
for bit (every point gathers its pair terms in global-id order)."""
from pathlib import Path

import netCDF4
import numpy as np
import pytest

from peridyn.deck.files import dump_yaml, load_deck_file
from peridyn.testing.mpi import mpirun, requires_mpi

DECK = Path(__file__).resolve().parents[2] / "examples" / "penalty_contact.yaml"

pytestmark = [pytest.mark.mpi, requires_mpi]


def _values(path: Path) -> dict[str, np.ndarray]:
    with netCDF4.Dataset(path / "penalty_contact.e") as ds:
        names = ["".join(c.decode() for c in row if c) for row in ds["name_nod_var"][:].data]
        out = {k: v[:].data for k, v in ds.variables.items() if k.startswith("vals_")}
        out["contact z"] = out[f"vals_nod_var{names.index('Contact_ForceZ') + 1}"]
        return out


def test_the_bouncing_ball_on_two_ranks_is_the_serial_run(tmp_path):
    tree = load_deck_file(DECK).tree
    tree["Solver"]["Final Time"] = 5.0e-5  # through the first half of the contact
    tree["Contact"]["Models"]["Penalty"]["Friction Coefficient"] = 0.3
    serial, parallel = tmp_path / "s", tmp_path / "p"
    for d in (serial, parallel):
        d.mkdir()
        (d / "penalty_contact.yaml").write_text(dump_yaml(tree))
    one = mpirun(1, ["run", "penalty_contact.yaml", "-q"], cwd=serial)
    many = mpirun(2, ["run", "penalty_contact.yaml", "-q"], cwd=parallel)
    assert one.returncode == 0, one.stderr[-2000:]
    assert many.returncode == 0, many.stderr[-2000:]
    a, b = _values(serial), _values(parallel)
    assert a.keys() == b.keys()
    assert np.abs(a["contact z"]).max() > 0  # the ball touched the plate
    for k in a:
        assert np.array_equal(a[k], b[k]), k
