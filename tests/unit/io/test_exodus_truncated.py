"""A truncated netCDF-3 Exodus file is an input error, not zeros and garbage."""
from __future__ import annotations

from pathlib import Path

import netCDF4
import numpy as np
import pytest

from peridyn.core.errors import InputError
from peridyn.io.exodus_reader import read_nodal_variable, read_results


def _write(path: Path, fmt: str) -> None:
    with netCDF4.Dataset(str(path), "w", format=fmt) as ds:
        ds.createDimension("num_nodes", 50)
        ds.createDimension("time_step", None)
        ds.createDimension("num_nod_var", 1)
        ds.createDimension("len_name", 33)
        for c in "xyz":
            ds.createVariable(f"coord{c}", "f8", ("num_nodes",))[:] = np.arange(50.0)
        names = ds.createVariable("name_nod_var", "S1", ("num_nod_var", "len_name"))
        names[0, :] = netCDF4.stringtochar(np.array(["Displacement"], dtype="S33"))
        times = ds.createVariable("time_whole", "f8", ("time_step",))
        values = ds.createVariable("vals_nod_var1", "f8", ("time_step", "num_nodes"))
        for k in range(3):
            times[k] = 0.1 * (k + 1)
            values[k, :] = np.full(50, float(k + 1))


@pytest.mark.parametrize("fmt", ["NETCDF3_CLASSIC", "NETCDF3_64BIT_OFFSET"])
def test_truncations_at_any_length_are_refused(tmp_path, fmt):
    whole = tmp_path / "base.e"
    _write(whole, fmt)
    assert read_results(whole)["times"].tolist() == pytest.approx([0.1, 0.2, 0.3])
    data = whole.read_bytes()
    for length in (len(data) - 1, len(data) - 8, (3 * len(data)) // 4, len(data) // 2, 600, 64, 10):
        cut = tmp_path / f"cut{length}.e"
        cut.write_bytes(data[:length])
        for reader in (read_results, lambda p: read_nodal_variable(p, "Displacement")):
            with pytest.raises(InputError) as info:
                reader(cut)
            text = str(info.value)
            assert "truncated" in text or "cannot read" in text, text
            assert str(cut) in text
    half = tmp_path / f"cut{len(data) // 2}.e"
    with pytest.raises(InputError, match=rf"truncated: {len(data) // 2} bytes of the {len(data)} its header promises"):
        read_results(half)


def test_a_netcdf4_file_is_not_measured(tmp_path):
    path = tmp_path / "base.e"
    _write(path, "NETCDF4")
    assert read_results(path)["nodal"]["Displacement"].shape == (3, 50)
