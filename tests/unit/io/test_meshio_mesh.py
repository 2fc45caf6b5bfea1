"""``Mesh`` discretization: exact element volumes and centroids, blocks and node sets from groups,
every format meshio writes, .geo meshing, bad input and a run."""
from __future__ import annotations

import sys
import textwrap
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from peridyn.cli import main
from peridyn.core.errors import ExitCode, InputError
from peridyn.deck.model import load_deck
from peridyn.io.element_geometry import bad_elements, element_centroids_and_volumes
from peridyn.io.exodus_mesh import hex_centroid_and_volume

meshio = pytest.importorskip("meshio")
from peridyn.io.meshio_mesh import _points, read_mesh  # noqa: E402

CUBE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float)
ROUND_OFF = 1e-14


def geometry(family: str, nodes, cells) -> tuple[np.ndarray, np.ndarray]:
    xyz = np.asarray(nodes, dtype=float)[np.asarray(cells)]
    return element_centroids_and_volumes(family, xyz)


# ------------------------------------------------------------------------------------------------
# Exact volumes and centroids
# ------------------------------------------------------------------------------------------------
# the unit cube split in several ways (node numbers of CUBE); each part numbered positively
SPLITS = {
    "1 hex": [("hexahedron", [[0, 1, 2, 3, 4, 5, 6, 7]])],
    "6 tets (Kuhn)": [("tetra", [[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]])],
    "5 tets": [("tetra", [[0, 1, 3, 4], [1, 2, 3, 6], [1, 6, 4, 5], [3, 4, 6, 7], [1, 3, 4, 6]])],
    "2 wedges": [("wedge", [[0, 1, 2, 4, 5, 6], [0, 2, 3, 4, 6, 7]])],
    "3 pyramids": [("pyramid", [[0, 1, 2, 3, 6], [0, 4, 5, 1, 6], [0, 3, 7, 4, 6]])],
}
SPLITS["wedge + pyramid + tet"] = [
    ("wedge", [[0, 1, 2, 4, 5, 6]]),       # half the cube, under the plane x = y
    ("pyramid", [[0, 3, 7, 4, 6]]),        # base on x = 0, apex at node 6: 1/3
    ("tetra", [[0, 2, 3, 6]]),             # the rest: 1/6
]


@pytest.mark.parametrize("split", list(SPLITS))
def test_cube_splits_sum_to_the_cube_with_its_centroid(split):
    volume, moment = 0.0, np.zeros(3)
    for family, cells in SPLITS[split]:
        c, v = geometry(family, CUBE, cells)
        assert np.all(v > 0) and bad_elements(family, CUBE[np.asarray(cells)], v).size == 0
        volume += v.sum()
        moment += (c * v[:, None]).sum(axis=0)
    assert abs(volume - 1.0) < ROUND_OFF
    assert_allclose(moment / volume, [0.5, 0.5, 0.5], rtol=0, atol=ROUND_OFF)


def test_known_volumes_and_centroids():
    # right pyramid on the unit square, height 1: V = 1/3, centroid at height 1/4
    c, v = geometry("pyramid", np.vstack([CUBE[:4], [[0.5, 0.5, 1.0]]]), [[0, 1, 2, 3, 4]])
    assert_allclose(v, [1 / 3], rtol=1e-15)
    assert_allclose(c, [[0.5, 0.5, 0.25]], atol=ROUND_OFF)
    # right wedge over the triangle (0,0) (2,0) (0,1), height 3: V = 3, centroid (2/3, 1/3, 3/2)
    tri = np.array([[0, 0, 0], [2, 0, 0], [0, 1, 0]], float)
    c, v = geometry("wedge", np.vstack([tri, tri + [0, 0, 3]]), [[0, 1, 2, 3, 4, 5]])
    assert_allclose(v, [3.0], rtol=1e-15)
    assert_allclose(c, [[2 / 3, 1 / 3, 1.5]], atol=ROUND_OFF)
    # a sheared, stretched box (parallelepiped): V = det of its edge vectors, centroid = corner mean
    a = np.array([[2.0, 0.1, 0.0], [0.3, 1.5, 0.2], [0.1, -0.4, 0.7]])
    par = CUBE @ a
    c, v = geometry("hexahedron", par, [list(range(8))])
    assert_allclose(v, [np.linalg.det(a)], rtol=1e-14)
    assert_allclose(c, [par.mean(axis=0)], atol=ROUND_OFF)


def trilinear_gauss(nodes: np.ndarray) -> tuple[float, np.ndarray]:
    """Volume and centroid of a trilinear hex by 2x2x2 Gauss quadrature of det J and x det J
    over the reference cube: both are polynomials of degree <= 3 in each reference coordinate,
    so the rule is exact (an independent formula: a volume integral, not a surface one)."""
    ref = CUBE  # reference corner coordinates in [0, 1]^3, same node order
    g = (0.5 - 0.5 / np.sqrt(3.0), 0.5 + 0.5 / np.sqrt(3.0))
    volume, moment = 0.0, np.zeros(3)
    for r in g:
        for s in g:
            for t in g:
                p = np.array([r, s, t])
                # N_k = prod_d (ref_kd p_d + (1 - ref_kd)(1 - p_d)); dN_k/dp_d = prod over the others * (2 ref_kd - 1)
                f = ref * p + (1 - ref) * (1 - p)
                shape = f.prod(axis=1)
                grad = np.stack([(2 * ref[:, d] - 1) * np.prod(np.delete(f, d, axis=1), axis=1) for d in range(3)], axis=1)
                jac = nodes.T @ grad
                w = np.linalg.det(jac) / 8.0
                volume += w
                moment += w * (shape @ nodes)
    return volume, moment / volume


def test_warped_hex_matches_the_trilinear_volume_and_centroid():
    rng = np.random.default_rng(7)
    nodes = CUBE + 0.18 * rng.standard_normal((8, 3))  # non-planar faces
    c, v = geometry("hexahedron", nodes, [list(range(8))])
    exact_v, exact_c = trilinear_gauss(nodes)
    assert_allclose(v, [exact_v], rtol=1e-13)
    assert_allclose(c[0], exact_c, rtol=0, atol=1e-13)
    # Peridigm's 24-tetrahedra split (the Exodus reader) has the exact volume too, but its
    # centroid, like the mean of the nodes, is off for warped faces
    c24, v24, _ = hex_centroid_and_volume(nodes[None])
    assert_allclose(v24, [exact_v], rtol=1e-14)
    assert np.abs(c24[0] - exact_c).max() > 1e-4 and np.abs(nodes.mean(axis=0) - exact_c).max() > 1e-3
    # a pyramid is the hexahedron with its top face collapsed to the apex
    pyr = np.vstack([nodes[:4], [[0.4, 0.6, 1.1]]])
    c, v = geometry("pyramid", pyr, [[0, 1, 2, 3, 4]])
    exact_v, exact_c = trilinear_gauss(np.vstack([pyr[:4], np.repeat(pyr[4:], 4, axis=0)]))
    assert_allclose(v, [exact_v], rtol=1e-13)
    assert_allclose(c[0], exact_c, atol=1e-13)


def test_warped_hexes_tile_a_box_exactly():
    """A 2x2x2 grid of unit hexes whose inner nodes are moved at random: warped hexes, but their
    exact volumes still add up to the box, and their moments to its centroid."""
    rng = np.random.default_rng(3)
    grid = np.stack(np.meshgrid(*(np.arange(3.0),) * 3, indexing="ij"), axis=-1)  # (3, 3, 3, 3)
    grid[1, 1, 1] += 0.3 * rng.standard_normal(3)  # the inner node anywhere nearby
    for face in ((1, 1, 0), (1, 1, 2), (1, 0, 1), (1, 2, 1), (0, 1, 1), (2, 1, 1)):  # face centres within their face
        normal = [d for d in range(3) if face[d] != 1][0]
        grid[face] += 0.3 * rng.standard_normal(3) * (np.arange(3) != normal)
    ids = np.arange(27).reshape(3, 3, 3)
    cells = []
    for i in range(2):
        for j in range(2):
            for k in range(2):
                cells.append([ids[i, j, k], ids[i + 1, j, k], ids[i + 1, j + 1, k], ids[i, j + 1, k],
                              ids[i, j, k + 1], ids[i + 1, j, k + 1], ids[i + 1, j + 1, k + 1], ids[i, j + 1, k + 1]])
    c, v = geometry("hexahedron", grid.reshape(-1, 3), cells)
    assert abs(v.sum() - 8.0) < 1e-13
    assert_allclose((c * v[:, None]).sum(axis=0) / v.sum(), [1.0, 1.0, 1.0], atol=1e-13)


@pytest.mark.parametrize(
    "family, nodes, reason",
    [
        ("hexahedron", CUBE[[4, 5, 6, 7, 0, 1, 2, 3]], "inside out"),
        ("tetra", CUBE[[0, 2, 1, 4]], "inside out"),
        ("tetra", np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float), "flat"),
        ("hexahedron", CUBE[[0, 1, 2, 3, 4, 5, 7, 6]], "twisted"),
        ("wedge", CUBE[[0, 2, 1, 4, 6, 5]], "inside out"),
        ("pyramid", np.vstack([CUBE[:4], [[0.5, 0.5, -1.0]]]), "apex below"),
    ],
)
def test_inverted_and_degenerate_elements_are_found(family, nodes, reason):
    _, v = element_centroids_and_volumes(family, nodes[None])
    assert_array_equal(bad_elements(family, nodes[None], v), [0]), reason


# ------------------------------------------------------------------------------------------------
# A small mesh with groups, in every format
# ------------------------------------------------------------------------------------------------
def small_mesh():
    """Three unit cubes along x: a hex (physical volume 1 'Left'), two wedges and six tets
    (physical volume 2, unnamed); a quad on x = 0 (physical surface 5 'Fixed') and a triangle on
    x = 3 (physical surface 6, unnamed)."""
    pts = np.vstack([CUBE + [i, 0, 0] for i in range(3)])
    pts, inverse = np.unique(pts, axis=0, return_inverse=True)
    node = lambda cube, k: int(inverse.ravel()[8 * cube + k])  # noqa: E731
    hexes = [[node(0, k) for k in range(8)]]
    wedges = [[node(1, k) for k in w] for w in ([0, 1, 2, 4, 5, 6], [0, 2, 3, 4, 6, 7])]
    tets = [[node(2, k) for k in t] for t in SPLITS["6 tets (Kuhn)"][0][1]]
    quad = [[node(0, k) for k in (0, 3, 7, 4)]]
    tri = [[node(2, k) for k in (1, 2, 6)]]
    cells = [("hexahedron", hexes), ("wedge", wedges), ("tetra", tets), ("quad", quad), ("triangle", tri)]
    physical = [[1], [2, 2], [2] * 6, [5], [6]]
    return meshio.Mesh(
        pts, cells,
        cell_data={"gmsh:physical": physical, "gmsh:geometrical": physical},
        field_data={"Left": np.array([1, 3]), "Fixed": np.array([5, 2])},
    )


def check_small(disc, names: dict[str, str]) -> None:
    """The small mesh's points whatever the format; ``names``: expected name -> role."""
    assert disc.num_points == 9
    assert_allclose(disc.volume.sum(), 3.0, rtol=1e-15)
    assert_allclose(disc.volume[:3], [1.0, 0.5, 0.5], rtol=1e-15)
    assert_allclose(disc.volume[3:], 1 / 6, rtol=1e-14)
    assert_allclose(disc.x[0], [0.5, 0.5, 0.5], atol=ROUND_OFF)
    assert_allclose(disc.x[1], [1 + 2 / 3, 1 / 3, 0.5], atol=ROUND_OFF)
    assert_array_equal(disc.gid, np.arange(9))
    assert_array_equal(disc.block_id, [1, 2, 2, 2, 2, 2, 2, 2, 2])
    assert disc.block_names == {1: names["left block"], 2: names["right block"]}
    fixed = disc.node_sets[names["fixed"]]
    assert_array_equal(fixed, [0])  # only the hex has nodes on x = 0
    # the triangle (1,0,0) (1,1,0) (1,1,1) of the third cube: every tet has a node on it
    # (the Kuhn tets share the diagonal 0-6), as does the wedge whose face x = 2 holds them
    assert set(disc.node_sets[names["tri"]].tolist()) >= set(range(3, 9))


GMSH_NAMES = {"left block": "Left", "right block": "block_2", "fixed": "Fixed", "tri": "surface_6"}
VTK_NAMES = {"left block": "block_1", "right block": "block_2", "fixed": "surface_5", "tri": "surface_6"}


@pytest.mark.parametrize("suffix, fmt, names", [
    (".msh", "gmsh22", GMSH_NAMES),  # gmsh's own 4.1 files: the .geo tests and the example
    (".vtu", None, VTK_NAMES), (".vtk", None, VTK_NAMES),
])
def test_physical_groups_become_blocks_and_node_sets(tmp_path, suffix, fmt, names):
    path = tmp_path / f"small{suffix}"
    small_mesh().write(path, file_format=fmt)
    check_small(read_mesh(path), names)


def test_abaqus_element_and_node_sets(tmp_path):
    """Abaqus .inp keeps element sets (blocks, in file order) and node sets, not gmsh tags."""
    m = small_mesh()
    vol = meshio.Mesh(m.points, m.cells[:3],
                      cell_sets={"LEFT": [np.array([0]), np.array([], int), np.array([], int)],
                                 "MIDDLE": [np.array([], int), np.array([0, 1]), np.array([], int)],
                                 "RIGHT": [np.array([], int), np.array([], int), np.arange(6)]},
                      point_sets={"FIXED": np.flatnonzero(m.points[:, 0] == 0.0)})
    path = tmp_path / "small.inp"
    vol.write(path)
    disc = read_mesh(path)
    assert disc.block_names == {1: "LEFT", 2: "MIDDLE", 3: "RIGHT"}
    assert_array_equal(disc.block_id, [1, 2, 2] + [3] * 6)
    assert_array_equal(disc.node_sets["FIXED"], [0])
    assert_array_equal(disc.node_sets["LEFT"], [0])  # a named volume group is a node set too
    assert_allclose(disc.volume.sum(), 3.0, rtol=1e-15)


def test_med(tmp_path):
    pytest.importorskip("h5py", reason="meshio writes and reads MED with h5py, which is not installed")
    path = tmp_path / "small.med"
    small_mesh().write(path)
    check_small(read_mesh(path), VTK_NAMES)  # meshio keeps gmsh:physical as MED fields, not the names


def test_quadratic_elements_equal_their_linear_corners(tmp_path):
    rng = np.random.default_rng(11)
    linear = {"tetra": 4, "hexahedron": 8, "wedge": 6, "pyramid": 5}
    quadratic = {"tetra10": "tetra", "hexahedron20": "hexahedron", "hexahedron27": "hexahedron",
                 "wedge18": "wedge", "pyramid14": "pyramid"}
    for kind, family in quadratic.items():
        k = int(kind.removeprefix(family))
        corners = {"tetra": CUBE[[0, 1, 3, 4]], "hexahedron": CUBE, "wedge": CUBE[[0, 1, 3, 4, 5, 7]],
                   "pyramid": np.vstack([CUBE[:4], [[0.5, 0.5, 1.0]]])}[family] + 0.1 * rng.standard_normal((linear[family], 3))
        extra = rng.random((k - linear[family], 3))  # mid-side nodes anywhere: they are not used
        path = tmp_path / f"{kind}.msh"
        meshio.Mesh(np.vstack([corners, extra]), [(kind, [list(range(k))])]).write(path, file_format="gmsh")
        disc = read_mesh(path)
        c, v = element_centroids_and_volumes(family, corners[None])
        assert_allclose(disc.volume, v, rtol=1e-15, err_msg=kind)
        assert_allclose(disc.x, c, atol=ROUND_OFF, err_msg=kind)


@pytest.mark.parametrize("kind, family", [("wedge15", "wedge"), ("pyramid13", "pyramid"), ("tetra20", "tetra")])
def test_types_meshio_cannot_build_still_read_by_corners(kind, family):
    """meshio 5.3 has no Mesh of wedge15 or pyramid13 (its readers may still return them): the
    reader takes any order of a family by its corners."""
    corners = {"wedge": CUBE[[0, 1, 3, 4, 5, 7]], "pyramid": np.vstack([CUBE[:4], [[0.5, 0.5, 1.0]]]), "tetra": CUBE[[0, 1, 3, 4]]}[family]
    n = int(kind.removeprefix(family))
    pts = np.vstack([corners, np.full((n - len(corners), 3), 9.0)])
    mesh = SimpleNamespace(points=pts, cells=[SimpleNamespace(type=kind, data=np.arange(n)[None])],
                           cell_data={}, cell_sets={}, point_sets={}, field_data={})
    disc = _points(mesh, Path("x.vtu"), 1.0)
    _, v = element_centroids_and_volumes(family, corners[None])
    assert_allclose(disc.volume, v, rtol=1e-15)


def stand_in(cells, cell_sets=None, point_sets=None):
    """A meshio-like mesh of two unit cubes along x (CUBE and CUBE + x) without gmsh tags."""
    pts = np.vstack([CUBE, CUBE[[1, 2, 5, 6]] + [1, 0, 0]])
    return SimpleNamespace(points=pts, cells=[SimpleNamespace(type=t, data=np.asarray(d)) for t, d in cells],
                           cell_data={}, cell_sets=cell_sets or {}, point_sets=point_sets or {}, field_data={})


TWO_HEXES = [("hexahedron", [list(range(8)), [1, 8, 9, 2, 5, 10, 11, 6]]), ("quad", [[8, 9, 11, 10]])]


def test_cell_sets_of_surfaces_are_node_sets_and_unassigned_elements_a_block():
    mesh = stand_in(TWO_HEXES, cell_sets={"BODY": [np.array([0]), np.array([], int)], "END": [np.array([], int), np.array([0])]})
    disc = _points(mesh, Path("x.inp"), 1.0)
    assert_allclose(disc.volume, [1.0, 1.0], rtol=1e-15)
    assert disc.block_names == {1: "BODY", 2: "block_2"}  # the second hex is in no set
    assert_array_equal(disc.block_id, [1, 2])
    assert {k: v.tolist() for k, v in disc.node_sets.items()} == {"END": [1], "BODY": [0]}


@pytest.mark.parametrize(
    "cell_sets, point_sets, words",
    [
        ({"A": [np.array([0, 1]), np.array([], int)], "B": [np.array([1]), np.array([], int)]}, {}, "cell sets 'A' and 'B' share"),
        ({"END": [np.array([], int), np.array([0])]}, {"END": np.array([0])}, "names both a cell group and a point set 'END'"),
        ({"A": [np.array([0, 1]), np.array([], int)]}, {"A": np.array([3])}, "names both a volume group and a surface, curve or point group 'A'"),
    ],
)
def test_clashing_groups_are_an_input_error(cell_sets, point_sets, words):
    with pytest.raises(InputError, match=words):
        _points(stand_in(TWO_HEXES, cell_sets, point_sets), Path("x.inp"), 1.0)


def test_length_scale(tmp_path):
    path = tmp_path / "small.msh"
    small_mesh().write(path, file_format="gmsh22")
    disc = read_mesh(path, length_scale=1e-3)
    assert_allclose(disc.volume.sum(), 3e-9, rtol=1e-14)
    assert_allclose(disc.x[0], [5e-4] * 3, rtol=1e-14)


GEO = """SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 2, 1, 1};
Physical Volume("Body") = {1};
Physical Surface("Bottom") = Surface In BoundingBox{-1, -1, -0.1, 3, 2, 0.1};
"""


def test_geo_is_meshed_by_gmsh_at_the_deck_size(tmp_path):
    pytest.importorskip("gmsh")
    path = tmp_path / "box.geo"
    path.write_text(GEO)
    coarse, fine = read_mesh(path, mesh_size=0.3), read_mesh(path, mesh_size=0.15)
    for disc in (coarse, fine):
        assert abs(disc.volume.sum() - 2.0) < 1e-13  # tets tile the box
        assert disc.block_names == {1: "Body"}
        bottom = disc.node_sets["Bottom"]
        assert bottom.size and disc.x[bottom, 2].max() < disc.x[:, 2].max()
    assert fine.num_points > 2 * coarse.num_points
    with pytest.raises(InputError, match=r"would give up to about 1.7e\+10 tetrahedra"):  # refused before meshing
        read_mesh(path, mesh_size=1e-3)
    assert_array_equal(read_mesh(path, mesh_size=0.3).x, coarse.x)  # the same mesh every time


# ------------------------------------------------------------------------------------------------
# Decks: bad input and a run
# ------------------------------------------------------------------------------------------------
DECK = textwrap.dedent(
    """\
    Peridigm:
      Discretization:
        Type: "Mesh"
        Input Mesh File: "small.msh"
      Materials:
        Steel:
          Material Model: "Elastic"
          Density: 7800.0
          Bulk Modulus: 130.0e9
          Shear Modulus: 78.0e9
      Blocks:
        All:
          Block Names: "Left block_2"
          Material: "Steel"
          Horizon: 1.5
      Boundary Conditions:
        Kick:
          Type: "Initial Velocity"
          Node Set: "Fixed"
          Coordinate: "x"
          Value: "1.0"
      Solver:
        Initial Time: 0.0
        Final Time: 2.0e-3
        Verlet:
          Safety Factor: 0.5
      Output:
        Output Filename: "run"
        Output Frequency: 1
        Output Variables:
          Displacement: true
          Velocity: true
          Block_Id: true
    """
)


def write_case(folder: Path, text: str = DECK, mesh=None, name: str = "small.msh") -> Path:
    (mesh or small_mesh()).write(folder / name, file_format="gmsh22" if name.endswith(".msh") else None)
    deck = folder / "deck.yaml"
    deck.write_text(text)
    return deck


def run(deck: Path) -> int:
    return main(["run", str(deck), "--output-dir", str(deck.parent), "-q", "--no-progress"])


def hex_grid(n: tuple[int, int, int], h: float) -> "meshio.Mesh":
    """A box of n[0] x n[1] x n[2] cubic hexes of side h: physical volume 1 'Left' (x below the
    middle) and 2 'Right', physical surface 5 'End' (quads on x = 0)."""
    ijk = np.stack(np.meshgrid(*(np.arange(m + 1) for m in n), indexing="ij"), axis=-1).reshape(-1, 3)
    index = lambda i, j, k: (i * (n[1] + 1) + j) * (n[2] + 1) + k  # noqa: E731
    cells, tags = [], []
    for i in range(n[0]):
        for j in range(n[1]):
            for k in range(n[2]):
                cells.append([index(i + a, j + b, k + c) for a, b, c in
                              ((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1))])
                tags.append(1 if 2 * i < n[0] else 2)
    quads = [[index(0, j, k), index(0, j, k + 1), index(0, j + 1, k + 1), index(0, j + 1, k)]
             for j in range(n[1]) for k in range(n[2])]
    return meshio.Mesh(ijk * h, [("hexahedron", cells), ("quad", quads)],
                       cell_data={"gmsh:physical": [tags, [5] * len(quads)], "gmsh:geometrical": [tags, [5] * len(quads)]},
                       field_data={"Left": np.array([1, 3]), "Right": np.array([2, 3]), "End": np.array([5, 2])})


RUN_DECK = (
    DECK.replace('Block Names: "Left block_2"', 'Block Names: "Left Right"').replace("Horizon: 1.5", "Horizon: 0.003015")
    .replace('Node Set: "Fixed"', 'Node Set: "Left"').replace("Final Time: 2.0e-3", "Final Time: 4.0e-6")
)


def test_a_mesh_runs_end_to_end(tmp_path):
    """8 x 3 x 3 hexes of 1 mm; the left half is thrown at 1 m/s and drags the right half along."""
    from peridyn.io.exodus_reader import read_results

    assert run(write_case(tmp_path, RUN_DECK, hex_grid((8, 3, 3), 0.001))) == ExitCode.OK
    r = read_results(tmp_path / "run.e")
    assert r["coords"].shape == (72, 3) and len(r["times"]) > 2
    assert [(b["name"], len(b["nodes"])) for b in r["blocks"]] == [("Left", 36), ("Right", 36)]
    assert {"END", "LEFT", "RIGHT"} <= set(r["node_sets"])
    assert_allclose(r["coords"][r["node_sets"]["END"], 0], 0.0005)  # the hexes on x = 0
    v = r["nodal"]["VelocityX"][-1]
    right = r["node_sets"]["RIGHT"]
    assert np.all(r["coords"][right, 0] > 0.004) and v[right].max() > 0.05  # set in motion through the bonds
    # momentum: 7800 kg/m^3 x 36 mm^3 x 1 m/s, conserved by the pairwise internal forces
    assert_allclose(7800.0 * 1e-9 * v.sum(), 7800.0 * 36e-9, rtol=1e-9)


def one_line_error(deck: Path, capsys) -> str:
    capsys.readouterr()
    assert run(deck) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def inverted() -> "meshio.Mesh":
    return meshio.Mesh(CUBE, [("hexahedron", [[4, 5, 6, 7, 0, 1, 2, 3]])])


def degenerate() -> "meshio.Mesh":
    return meshio.Mesh(np.vstack([CUBE, [[0.5, 0.5, 0.0]]]), [("tetra", [[0, 1, 2, 8]]), ("hexahedron", [list(range(8))])])


def surface_only() -> "meshio.Mesh":
    return meshio.Mesh(CUBE, [("quad", [[0, 1, 2, 3]])])


@pytest.mark.parametrize(
    "change, mesh, name, words",
    [
        (("small.msh", "nothere.msh"), None, "small.msh", "mesh file"),
        ((), surface_only(), "small.msh", "no volume elements"),
        ((), inverted(), "small.msh", "is inverted"),
        ((), degenerate(), "small.msh", "is degenerate"),
        (("small.msh", "small.xyz"), None, "small.msh", "unknown mesh format '.xyz'"),
        (("small.msh", "garbage.vtu"), None, "small.msh", "is not a readable .vtu file"),
        (("Input Mesh File: \"small.msh\"", "Input Mesh File: \"small.msh\"\n    Mesh Size: 0.1"), None, "small.msh",
         "'Mesh Size' applies only to .geo input"),
        (("Input Mesh File: \"small.msh\"", "Input Mesh File: \"small.msh\"\n    Length Scale: 0.0"), None, "small.msh",
         "greater than 0"),
        (("Input Mesh File: \"small.msh\"", "Input Mesh File: \"small.msh\"\n    Length Scale: 1.0e999"), None, "small.msh",
         "'Length Scale' must be finite"),
    ],
)
def test_bad_input_is_one_line(tmp_path, capsys, change, mesh, name, words):
    text = DECK.replace(*change, 1) if change else DECK
    (tmp_path / "small.xyz").write_text("1 2 3\n")
    (tmp_path / "garbage.vtu").write_text("<VTKFile> not really\n")
    line = one_line_error(write_case(tmp_path, text, mesh, name), capsys)
    assert words in line, line
    if "must be finite" in words:  # the deck loader's own check, before the key's
        assert "deck.yaml:2: Discretization:" in line, line
        return
    key = next((k for k in ("Mesh Size", "Length Scale") if k in change[-1]), "Input Mesh File") if change else "Input Mesh File"
    where = "deck.yaml:5" if key != "Input Mesh File" else (change[-1] if change else name)  # read errors name the mesh
    assert f"{where}: Discretization > {key}:" in line, line


@pytest.mark.parametrize(
    "geo, words",
    [
        ('SetFactory("OpenCASCADE");\nBox(1) = {0, 0, 0, 1, 1;\n', "gmsh could not mesh 'part.geo' (Error: 'part.geo', line 2: syntax error"),
        ("Point(1) = {0, 0, 0};\nPoint(2) = {1, 0, 0};\nLine(1) = {1, 2};\n", "has no volume elements"),
    ],
)
def test_bad_geo_is_one_line(tmp_path, capsys, geo, words):
    pytest.importorskip("gmsh")
    (tmp_path / "part.geo").write_text(geo)
    line = one_line_error(write_case(tmp_path, DECK.replace("small.msh", "part.geo")), capsys)
    assert "part.geo: Discretization > Input Mesh File:" in line and words in line, line


@pytest.mark.parametrize("module, mesh_file", [("meshio", "small.msh"), ("gmsh", "part.geo")])
def test_without_the_extra_a_deck_gets_the_install_command(tmp_path, capsys, monkeypatch, module, mesh_file):
    deck = write_case(tmp_path, DECK.replace("small.msh", mesh_file))
    monkeypatch.setitem(sys.modules, module, None)
    line = one_line_error(deck, capsys)
    assert "deck.yaml" in line and "Discretization > Input Mesh File" in line, line
    assert f"needs {module}" in line and 'pip install "peridyn[mesh]"' in line and mesh_file in line, line
    with pytest.raises(InputError, match=f"needs {module}"):
        load_deck(deck)
    (tmp_path / "part.geo").write_text(GEO)
    with pytest.raises(InputError, match=f"needs {module}, which cannot be imported.*pip install"):  # reading, too
        read_mesh(tmp_path / mesh_file)


def test_the_deck_does_not_import_meshio_before_it_reads_the_mesh(tmp_path, monkeypatch):
    monkeypatch.delitem(sys.modules, "meshio", raising=False)
    load_deck(write_case(tmp_path))
    assert "meshio" not in sys.modules
