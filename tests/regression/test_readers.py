"""A run's output file is read by independent readers: VTK's Exodus reader (ParaView's) and the
shared exodiff.py comparator."""
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.io.exodus_reader import read_results

DATA = Path(__file__).resolve().parent / "data"
EXODIFF = Path(__file__).resolve().parents[2].parent / "shared" / "conformance" / "exodiff.py"


@pytest.fixture(scope="module")
def run_output(tmp_path_factory):
    folder = tmp_path_factory.mktemp("readers")
    for f in DATA.glob("two_materials*"):
        if "_gold" not in f.name:
            shutil.copy(f, folder / f.name)
    assert main(["run", str(folder / "two_materials.yaml"), "--output-dir", str(folder), "-q", "--no-progress"]) == ExitCode.OK
    return folder / "two_materials.e"


def test_vtk_reads_the_run_output(run_output):
    vtk = pytest.importorskip("vtkmodules.vtkIOExodus")
    from vtkmodules.util.numpy_support import vtk_to_numpy

    ours = read_results(run_output)
    reader = vtk.vtkExodusIIReader()
    reader.SetFileName(str(run_output))
    reader.UpdateInformation()
    assert reader.GetNumberOfTimeSteps() == len(ours["times"])
    reader.SetAllArrayStatus(vtk.vtkExodusIIReader.NODAL, 1)
    reader.SetAllArrayStatus(vtk.vtkExodusIIReader.ELEM_BLOCK, 1)
    reader.SetAllArrayStatus(vtk.vtkExodusIIReader.ELEM_BLOCK_ATTRIB, 1)
    reader.SetAllArrayStatus(vtk.vtkExodusIIReader.GLOBAL, 1)
    reader.SetGenerateGlobalNodeIdArray(True)
    reader.SetApplyDisplacements(False)
    last = len(ours["times"]) - 1
    reader.SetTimeStep(last)
    reader.Update()
    blocks = reader.GetOutput()
    assert blocks.GetNumberOfBlocks() >= 1
    seen = 0
    it = blocks.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        grid = it.GetCurrentDataObject()
        ids = vtk_to_numpy(grid.GetPointData().GetArray("PedigreeNodeId") or grid.GetPointData().GetArray("GlobalNodeId"))
        disp = vtk_to_numpy(grid.GetPointData().GetArray("Displacement"))
        order = ids.astype(int) - 1
        np.testing.assert_allclose(disp[:, 0], ours["nodal"]["DisplacementX"][last][order], rtol=1e-12, atol=0)
        seen += grid.GetNumberOfCells()
        it.GoToNextItem()
    assert seen == ours["coords"].shape[0]  # one SPHERE element per point, all blocks


@pytest.mark.skipif(not EXODIFF.exists(), reason="../shared/conformance is not present")
def test_exodiff_reads_the_run_output(run_output):
    sys.path.insert(0, str(EXODIFF.parent))
    try:
        import exodiff
    finally:
        sys.path.pop(0)
    assert exodiff.compare([str(run_output)], str(DATA / "two_materials_gold.e"), str(DATA / "two_materials.comp"), quiet=True) == []
    # the tolerances can fail: a displacement 1e-6 off at one point is caught
    from netCDF4 import Dataset

    moved = run_output.with_name("moved.e")
    shutil.copy(run_output, moved)
    with Dataset(moved, "a") as ds:
        names = [n.tobytes().decode().strip("\x00 ") if hasattr(n, "tobytes") else str(n) for n in ds.variables["name_nod_var"][:]]
        k = next(i for i, n in enumerate(names) if n.replace(" ", "") == "DisplacementY") + 1
        ds.variables[f"vals_nod_var{k}"][-1, 0] += 1e-6
    assert exodiff.compare([str(moved)], str(DATA / "two_materials_gold.e"), str(DATA / "two_materials.comp"), quiet=True) != []
