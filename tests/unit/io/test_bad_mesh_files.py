"""Empty, truncated and garbage mesh files, in every format meshio reads, are input errors
naming the file (peridyn/io/meshio_mesh.py), never an internal error; so are meshes whose
parts do not fit together."""
from __future__ import annotations

import textwrap
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from peridyn.cli import main
from peridyn.core.errors import ExitCode, InputError

meshio = pytest.importorskip("meshio")
from peridyn.io.meshio_mesh import _points, read_mesh  # noqa: E402

#: every extension meshio reads (.geo is gmsh's, tests/unit/io/test_geo_mesh.py)
EXTENSIONS = sorted(meshio.extension_to_filetypes)
#: formats meshio writes the test mesh in: (extension, meshio format or None for the default)
WRITTEN = [(".msh", "gmsh22"), (".msh", "gmsh"), (".vtu", None), (".vtk", None), (".inp", None), (".med", None),
           (".e", None), (".xdmf", None), (".mesh", None), (".bdf", None), (".vtk", "vtk42")]
CUBE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float)


def two_cubes() -> "meshio.Mesh":
    """Two unit hexes along x with a physical volume and a physical surface."""
    pts = np.vstack([CUBE, CUBE[[1, 2, 5, 6]] + [1, 0, 0]])
    cells = [("hexahedron", [list(range(8)), [1, 8, 9, 2, 5, 10, 11, 6]]), ("quad", [[8, 9, 11, 10]])]
    tags = [[1, 1], [2]]
    return meshio.Mesh(pts, cells, cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags},
                       field_data={"Body": np.array([1, 3]), "End": np.array([2, 2])})


def reads_or_refuses(path: Path) -> None:
    """read_mesh either returns points or raises an InputError naming the file: nothing else."""
    try:
        disc = read_mesh(path)
    except InputError as exc:
        assert exc.file == str(path) and exc.path == ("Discretization", "Input Mesh File"), exc.one_line()
        assert path.name in exc.message, exc.message
    else:
        assert disc.num_points > 0 and np.all(disc.volume > 0)


@pytest.mark.parametrize("content", [b"", b"\n  \t\n# only a comment\n"])
@pytest.mark.parametrize("suffix", EXTENSIONS)
def test_an_empty_file_of_every_format_is_an_input_error(tmp_path, suffix, content):
    """Also the formats whose readers skip blank and comment lines forever (tetgen's .node)."""
    path = tmp_path / f"empty{suffix}"
    path.write_bytes(content)
    with pytest.raises(InputError) as info:
        read_mesh(path)
    assert info.value.file == str(path) and path.name in info.value.message, info.value.one_line()


def test_tetgen_s_element_file_is_checked_with_its_node_file(tmp_path):
    (tmp_path / "part.node").write_text("8 3 0 0\n" + "".join(f"{i} {x} {y} {z}\n" for i, (x, y, z) in enumerate(CUBE)))
    (tmp_path / "part.ele").write_text("# nothing but a comment\n")
    with pytest.raises(InputError, match=r"mesh file 'part.ele' is empty"):
        read_mesh(tmp_path / "part.node")


@pytest.mark.parametrize("suffix, fmt", WRITTEN)
def test_a_truncated_file_of_every_written_format_reads_or_is_an_input_error(tmp_path, suffix, fmt):
    if suffix == ".med":
        pytest.importorskip("h5py")
    full = tmp_path / f"full{suffix}"
    mesh = two_cubes()
    if fmt == "gmsh":  # meshio writes gmsh 4.1 of one cell type only without entity information
        mesh = meshio.Mesh(mesh.points, mesh.cells[:1])
    mesh.write(full, file_format=fmt)
    data = full.read_bytes()
    for cut in sorted(set(np.linspace(0, len(data) - 1, 25).astype(int))):
        part = tmp_path / f"cut{suffix}"
        part.write_bytes(data[:cut])
        reads_or_refuses(part)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(suffix=st.sampled_from([".inp", ".msh", ".vtu", ".vtk", ".med", ".e", ".obj", ".stl", ".f3grid", ".bdf"]),
       data=st.binary(max_size=200))
def test_garbage_bytes_are_an_input_error(tmp_path, suffix, data):
    path = tmp_path / f"garbage{suffix}"
    path.write_bytes(data)
    reads_or_refuses(path)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(fmt=st.sampled_from([(".msh", "gmsh22"), (".vtk", None), (".inp", None)]),
       edits=st.lists(st.tuples(st.floats(0, 1, exclude_max=True), st.sampled_from(list(b"0123456789-.eE \n\x00"))),
                      min_size=1, max_size=4))
def test_a_file_with_a_few_bytes_changed_reads_or_is_an_input_error(tmp_path, fmt, edits):
    suffix, name = fmt
    path = tmp_path / f"edited{suffix}"
    two_cubes().write(path, file_format=name)
    data = bytearray(path.read_bytes())
    for where, byte in edits:
        data[int(where * len(data))] = byte
    path.write_bytes(bytes(data))
    reads_or_refuses(path)


def stand_in(points, cells, cell_data=None, cell_sets=None):
    return SimpleNamespace(points=points, cells=[SimpleNamespace(type=t, data=d) for t, d in cells], cell_data=cell_data or {},
                           cell_sets=cell_sets or {}, point_sets={}, field_data={})


HEX = [list(range(8))]


@pytest.mark.parametrize(
    "mesh, words",
    [
        (stand_in(np.zeros((0, 3)), []), "has no nodes (an empty or truncated file?)"),
        (stand_in(np.zeros((0, 3)), [("hexahedron", np.zeros((0, 8), int))]), "has no nodes"),
        (stand_in([["a", "b", "c"]] * 8, [("hexahedron", HEX)]), "its node coordinates are not numbers"),
        (stand_in(np.zeros((8, 3, 2)), [("hexahedron", HEX)]), "its node coordinates have the shape (8, 3, 2)"),
        (stand_in(CUBE, [("hexahedron", np.arange(8))]), "its hexahedron cells have the shape (8,)"),
        (stand_in(CUBE, [("polyhedron", [[0, 1, 2, 3], [4, 5, 6]])]), "unsupported cell type 'polyhedron'"),
        (stand_in(CUBE, [("hexahedron", HEX)], {"gmsh:physical": []}), "gmsh:physical tags are given for 0 of 1 cell blocks"),
        (stand_in(CUBE, [("hexahedron", HEX)], {"gmsh:physical": [[1, 1]]}), "has 1 hexahedron cells but 2 gmsh:physical tags"),
        (stand_in(CUBE, [("hexahedron", HEX)], cell_sets={"A": [np.array([3])]}), "cell set 'A' refers to a cell that block 1"),
        (stand_in(CUBE, [("hexahedron", HEX)], cell_sets={"A": [np.array([-1])]}), "cell set 'A' refers to a cell"),
        (stand_in(CUBE, [("hexahedron", HEX)], cell_sets={"A": [np.array([0.5])]}), "cell set 'A' refers to a cell"),
    ],
)
def test_parts_that_do_not_fit_together_are_an_input_error(mesh, words):
    with pytest.raises(InputError) as info:
        _points(mesh, Path("x.vtu"), 1.0)
    assert words in info.value.message and info.value.file == "x.vtu", info.value.one_line()


def test_a_good_stand_in_still_reads():
    disc = _points(stand_in(CUBE, [("hexahedron", HEX)], {"gmsh:physical": [[4]]}), Path("x.msh"), 1.0)
    assert disc.block_names == {4: "block_4"} and disc.volume.tolist() == [1.0]


DECK = textwrap.dedent(
    """\
    Discretization:
      Type: "Mesh"
      Input Mesh File: "part.inp"
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
        Horizon: 1.5
    Solver:
      Initial Time: 0.0
      Final Time: 1.0e-6
      Verlet: {}
    Output:
      Output Filename: "run"
      Output Variables:
        Displacement: true
    """
)


@pytest.mark.parametrize("suffix", [".inp", ".msh", ".vtu", ".vtk", ".med"])
def test_a_deck_with_an_empty_mesh_file_is_exit_2_with_one_line(tmp_path, capsys, suffix):
    (tmp_path / f"part{suffix}").write_bytes(b"")
    (tmp_path / "deck.yaml").write_text(DECK.replace("part.inp", f"part{suffix}"))
    capsys.readouterr()
    assert main(["run", str(tmp_path / "deck.yaml"), "--output-dir", str(tmp_path), "-q", "--no-progress"]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert f"part{suffix}: Discretization > Input Mesh File: mesh file 'part{suffix}'" in err[0], err[0]
    assert "regenerate or re-export the mesh" in err[0], err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["deck.yaml", f"part{suffix}"]  # no lock, no output
