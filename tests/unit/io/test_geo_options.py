"""gmsh options that multiply the work, tiny field sizes and a failing worker are input errors."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from peridyn.core.errors import InputError

pytest.importorskip("gmsh")

from peridyn.io import geo_mesh  # noqa: E402
from peridyn.io.meshio_mesh import read_mesh  # noqa: E402

BOX = 'SetFactory("OpenCASCADE");\nBox(1) = {0, 0, 0, 10, 4, 4};\nMesh.MeshSizeMax = 2;\n'


@pytest.mark.parametrize("option, value, words", [
    ("Mesh.Smoothing", "1e9", "0 to 100"),
    ("Mesh.Smoothing", "101", "0 to 100"),
    ("Mesh.Optimize", "50", "0 to 1"),
    ("Mesh.OptimizeNetgen", "1e6", "0 to 1"),
    ("Mesh.RefineSteps", "1e9", "0 to 100"),
    ("Mesh.Algorithm3D", "1e9", "one of 1, 3, 4, 7, 9, 10"),
])
def test_options_that_multiply_the_work_are_refused_before_meshing(tmp_path, option, value, words):
    geo = tmp_path / "part.geo"
    geo.write_text(BOX + f"{option} = {value};\n")
    with pytest.raises(InputError) as info:
        read_mesh(geo)
    line = info.value.one_line()
    assert option in line and words in line and "part.geo" in line, line
    assert not list(tmp_path.glob("*.msh"))


def test_sane_options_still_mesh(tmp_path):
    geo = tmp_path / "part.geo"
    geo.write_text(BOX + "Mesh.Smoothing = 5;\nMesh.Optimize = 1;\nMesh.Algorithm3D = 10;\n")
    assert abs(read_mesh(geo).volume.sum() - 160.0) < 1e-9


def test_a_field_size_whose_cube_underflows_is_too_large(tmp_path):
    geo = tmp_path / "part.geo"
    geo.write_text('SetFactory("OpenCASCADE");\nBox(1) = {0, 0, 0, 10, 4, 4};\nField[1] = Box; Field[1].VIn = 1e-300; '
                   "Field[1].VOut = 1e-300; Field[1].XMax = 10; Field[1].YMax = 4; Field[1].ZMax = 4; Background Field = 1;\n")
    with pytest.raises(InputError) as info:
        read_mesh(geo)
    line = info.value.one_line()
    assert "would give up to about 1e+300 tetrahedra" in line and "Field[1].VIn (Box)" in line, line


def test_any_failure_of_the_worker_is_the_input_s(tmp_path, monkeypatch):
    code = ("import json, sys, pathlib; p = pathlib.Path(sys.argv[1]).parent; "
            "json.dump({'status': 'bug', 'reason': 'Traceback (most recent call last):\\n  File x\\nValueError: odd field'}, "
            "open(p / 'result.json', 'w'))")
    monkeypatch.setattr(geo_mesh, "_worker_command", lambda request: [sys.executable, "-c", code, str(request)])
    geo = tmp_path / "part.geo"
    geo.write_text(BOX)
    with pytest.raises(InputError) as info:
        read_mesh(geo)
    line = info.value.one_line()
    assert "part.geo" in line and "ValueError: odd field" in line and "Traceback" not in line, line
    assert json.loads(json.dumps(line))  # one line
    assert "\n" not in line
