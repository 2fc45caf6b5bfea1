"""Exodus discretization (§2.3): geometry, maps, blocks, node sets, errors, and gold files."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from pydantic import ValidationError

from peridyn.core.errors import InputError
from peridyn.io.exodus_mesh import (
    ExodusMesh,
    ExodusMeshParams,
    hex_centroid_and_volume,
    read_exodus_mesh,
    tet_centroid_and_volume,
)

netCDF4 = pytest.importorskip("netCDF4")

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
CASES = SHARED / "conformance" / "cases"
needs_cases = pytest.mark.skipif(not CASES.is_dir(), reason="conformance cases not available")

UNIT_CUBE = np.array(
    [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float
)
# outward faces of an Exodus HEX8 (counterclockwise seen from outside)
HEX_FACES_OUT = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))


# ------------------------------------------------------------------------------------------------
# A small Exodus II writer for test meshes
# ------------------------------------------------------------------------------------------------
def _put_names(ds, var: str, dim: str, names: list[str]) -> None:
    v = ds.createVariable(var, "S1", (dim, "len_name"))
    data = np.zeros((len(names), 33), dtype="S1")
    for i, name in enumerate(names):
        for j, ch in enumerate(name.encode()):
            data[i, j] = bytes([ch])
    v[:] = data


def write_exodus(
    path: Path,
    coords: np.ndarray,
    blocks: list[dict],
    node_sets: list[dict] = (),
    *,
    elem_num_map: np.ndarray | None = None,
    coord_style: str = "xyz",
    aux_elem_map: tuple[str, np.ndarray] | None = None,
    block_names: bool = True,
    fmt: str = "NETCDF3_64BIT_OFFSET",
) -> Path:
    """Write an Exodus II file. blocks: dicts with id, type, conn (1-based), optional attrib, name.
    node_sets: dicts with id, nodes (1-based), optional name."""
    coords = np.asarray(coords, dtype=float)
    num_nodes, num_dim = coords.shape
    num_elem = sum(len(b["conn"]) for b in blocks)
    ds = netCDF4.Dataset(path, "w", format=fmt)
    ds.createDimension("len_name", 33)
    ds.createDimension("num_dim", num_dim)
    ds.createDimension("num_nodes", num_nodes)
    ds.createDimension("num_elem", num_elem)
    ds.createDimension("num_el_blk", len(blocks))
    ds.api_version = np.float32(8.03)
    ds.version = np.float32(8.03)
    ds.floating_point_word_size = np.int32(8)
    if coord_style == "xyz":
        for d, name in enumerate(("coordx", "coordy", "coordz")[:num_dim]):
            ds.createVariable(name, "f8", ("num_nodes",))[:] = coords[:, d]
    else:
        ds.createVariable("coord", "f8", ("num_dim", "num_nodes"))[:] = coords.T
    ids = ds.createVariable("eb_prop1", "i4", ("num_el_blk",))
    ids.setncattr("name", "ID")
    ids[:] = [b["id"] for b in blocks]
    ds.createVariable("eb_status", "i4", ("num_el_blk",))[:] = 1
    if block_names:
        _put_names(ds, "eb_names", "num_el_blk", [b.get("name", "") for b in blocks])
    for k, b in enumerate(blocks, start=1):
        conn = np.asarray(b["conn"], dtype=np.int32)
        ds.createDimension(f"num_el_in_blk{k}", conn.shape[0])
        ds.createDimension(f"num_nod_per_el{k}", conn.shape[1])
        v = ds.createVariable(f"connect{k}", "i4", (f"num_el_in_blk{k}", f"num_nod_per_el{k}"))
        v.elem_type = b["type"]
        v[:] = conn
        if "attrib" in b:
            attrib = np.asarray(b["attrib"], dtype=float)
            ds.createDimension(f"num_att_in_blk{k}", attrib.shape[1])
            ds.createVariable(f"attrib{k}", "f8", (f"num_el_in_blk{k}", f"num_att_in_blk{k}"))[:] = attrib
    if elem_num_map is not None:
        ds.createVariable("elem_num_map", "i4", ("num_elem",))[:] = elem_num_map
    if aux_elem_map is not None:
        ds.createDimension("num_elem_maps", 1)
        _put_names(ds, "emap_names", "num_elem_maps", [aux_elem_map[0]])
        ds.createVariable("elem_map1", "i4", ("num_elem",))[:] = aux_elem_map[1]
    if node_sets:
        ds.createDimension("num_node_sets", len(node_sets))
        v = ds.createVariable("ns_prop1", "i4", ("num_node_sets",))
        v.setncattr("name", "ID")
        v[:] = [s["id"] for s in node_sets]
        ds.createVariable("ns_status", "i4", ("num_node_sets",))[:] = 1
        _put_names(ds, "ns_names", "num_node_sets", [s.get("name", "") for s in node_sets])
        for k, s in enumerate(node_sets, start=1):
            ds.createDimension(f"num_nod_ns{k}", len(s["nodes"]))
            ds.createVariable(f"node_ns{k}", "i4", (f"num_nod_ns{k}",))[:] = s["nodes"]
    ds.close()
    return path


def two_hex_mesh() -> tuple[np.ndarray, np.ndarray]:
    """Two unit hexes side by side along x: 12 nodes, connectivity (2, 8) 1-based."""
    coords = np.array(
        [[x, y, z] for z in (0.0, 1.0) for y in (0.0, 1.0) for x in (0.0, 1.0, 2.0)]
    )  # node n = x + 3 y + 6 z
    def node(x, y, z):
        return 1 + x + 3 * y + 6 * z
    conn = []
    for e in range(2):
        conn.append([node(e, 0, 0), node(e + 1, 0, 0), node(e + 1, 1, 0), node(e, 1, 0),
                     node(e, 0, 1), node(e + 1, 0, 1), node(e + 1, 1, 1), node(e, 1, 1)])
    return coords, np.array(conn)


# ------------------------------------------------------------------------------------------------
# Independent geometry: divergence theorem over the triangulated surface
# ------------------------------------------------------------------------------------------------
def surface_volume_and_centroid(nodes: np.ndarray) -> tuple[float, np.ndarray]:
    """Volume and centroid of the polyhedron bounded by the hex faces, each face split into four
    triangles at its node average (the surface Peridigm's 24 tetrahedra fill)."""
    volume = 0.0
    moment = np.zeros(3)
    for face in HEX_FACES_OUT:
        p = nodes[list(face)]
        center = p.mean(axis=0)
        for a in range(4):
            t0, t1, t2 = p[a], p[(a + 1) % 4], center
            normal = np.cross(t1 - t0, t2 - t0)
            volume += np.dot(t0, normal) / 6.0
            moment += normal * ((t0 + t1) ** 2 + (t1 + t2) ** 2 + (t2 + t0) ** 2) / 48.0
    return volume, moment / volume


def test_hex_unit_cube_and_affine_image_exact_values():
    centroid, volume, inverted = hex_centroid_and_volume(UNIT_CUBE[None])
    # 24 tetrahedra of volume 1/24 each, computed as triple product / 6: round-off only
    assert_allclose(volume, [1.0], rtol=1e-15)
    assert_allclose(centroid, [[0.5, 0.5, 0.5]], rtol=1e-15)
    assert not inverted.any()
    # a parallelepiped: volume det(A), centroid A (1/2, 1/2, 1/2) + b
    a = np.array([[2.0, 0.3, -0.2], [0.1, 1.5, 0.4], [0.0, -0.3, 0.8]])
    b = np.array([10.0, -3.0, 2.5])
    nodes = UNIT_CUBE @ a.T + b
    centroid, volume, inverted = hex_centroid_and_volume(nodes[None])
    assert_allclose(volume, [np.linalg.det(a)], rtol=1e-14)
    assert_allclose(centroid[0], a @ [0.5, 0.5, 0.5] + b, rtol=1e-14)
    assert not inverted.any()


def test_hex_frustum_against_convex_hull_and_closed_form():
    spatial = pytest.importorskip("scipy.spatial")
    bottom, top, height = 2.0, 1.0, 3.0
    nodes = np.array(
        [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0], [-0.5, -0.5, 1], [0.5, -0.5, 1], [0.5, 0.5, 1], [-0.5, 0.5, 1]]
    ) * [1.0, 1.0, height]
    centroid, volume, _ = hex_centroid_and_volume(nodes[None])
    exact = height / 3.0 * (bottom**2 + bottom * top + top**2)
    assert_allclose(volume, [exact], rtol=1e-14)
    assert_allclose(volume, [spatial.ConvexHull(nodes).volume], rtol=1e-13)
    z_bar = height * (bottom**2 + 2 * bottom * top + 3 * top**2) / (4 * (bottom**2 + bottom * top + top**2))
    assert_allclose(centroid[0], [0.0, 0.0, z_bar], atol=1e-15, rtol=1e-14)


def test_distorted_hexes_against_divergence_theorem():
    rng = np.random.default_rng(7)
    nodes = UNIT_CUBE[None] + rng.uniform(-0.15, 0.15, size=(20, 8, 3))
    centroid, volume, inverted = hex_centroid_and_volume(nodes)
    assert not inverted.any()
    for e in range(len(nodes)):
        v_ref, c_ref = surface_volume_and_centroid(nodes[e])
        assert volume[e] == pytest.approx(v_ref, rel=1e-13)
        assert_allclose(centroid[e], c_ref, rtol=1e-13, atol=1e-15)
    # warped faces: not the 8-node convex hull, but close to it
    spatial = pytest.importorskip("scipy.spatial")
    hull = spatial.ConvexHull(nodes[0]).volume
    assert volume[0] == pytest.approx(hull, rel=0.1)


def test_hex_operation_order_is_peridigm_sequential_sum():
    """Replays the sequential accumulation in plain Python floats for a skewed hex."""
    rng = np.random.default_rng(3)
    n = UNIT_CUBE * [0.31, 1.7, 0.013] + rng.uniform(-0.01, 0.01, size=(8, 3)) + 1234.5
    n = [list(map(float, p)) for p in n]

    def face(a, b, c, d):
        return [0.25 * (((n[a][i] + n[b][i]) + n[c][i]) + n[d][i]) for i in range(3)]

    f = [face(0, 1, 4, 5), face(1, 2, 5, 6), face(2, 3, 6, 7), face(0, 3, 4, 7), face(0, 1, 2, 3), face(4, 5, 6, 7)]
    c = [0.5 * (f[4][i] + f[5][i]) for i in range(3)]
    tets = [((1, 0), (5, 1), (4, 5), (0, 4)), ((2, 1), (6, 2), (5, 6), (1, 5)), ((3, 2), (7, 3), (6, 7), (2, 6)),
            ((0, 3), (3, 7), (7, 4), (4, 0)), ((0, 1), (1, 2), (2, 3), (3, 0)), ((5, 4), (4, 7), (7, 6), (6, 5))]
    vol, hc = 0.0, [0.0, 0.0, 0.0]
    for k, pairs in enumerate(tets):
        for a_i, b_i in pairs:
            p0, p1, p2, p3 = n[a_i], n[b_i], f[k], c
            a = [p1[i] - p0[i] for i in range(3)]
            b = [p2[i] - p0[i] for i in range(3)]
            cc = [p3[i] - p0[i] for i in range(3)]
            tv = (
                a[0] * (b[1] * cc[2] - b[2] * cc[1])
                + a[1] * (b[2] * cc[0] - b[0] * cc[2])
                + a[2] * (b[0] * cc[1] - b[1] * cc[0])
            ) / 6.0
            vol += tv
            for i in range(3):
                hc[i] += ((((p0[i] + p1[i]) + p2[i]) + p3[i]) * 0.25) * tv
    centroid, volume, _ = hex_centroid_and_volume(np.array(n)[None])
    assert volume[0] == vol
    assert_array_equal(centroid[0], [hc[i] / vol for i in range(3)])


def test_tet_centroid_and_volume():
    nodes = np.array([[[0.0, 0, 0], [2, 0, 0], [0, 3, 0], [0, 0, 4]], [[1.0, 1, 1], [1, 2, 1], [2, 1, 1], [1, 1, 2]]])
    centroid, volume, inverted = tet_centroid_and_volume(nodes)
    assert_allclose(volume, [4.0, -1.0 / 6.0], rtol=1e-15)
    assert_array_equal(inverted, [False, True])
    assert_allclose(centroid, [[0.5, 0.75, 1.0], [1.25, 1.25, 1.25]], rtol=1e-15)


# ------------------------------------------------------------------------------------------------
# Reading files
# ------------------------------------------------------------------------------------------------
def test_two_hex_mesh_points_blocks_gids_and_radius(tmp_path):
    coords, conn = two_hex_mesh()
    path = write_exodus(
        tmp_path / "m.g", coords, [{"id": 10, "type": "hex8", "conn": conn[:1], "name": "left"},
                                   {"id": 3, "type": "HEX", "conn": conn[1:]}],
        elem_num_map=np.array([7, 2]),
    )
    disc = read_exodus_mesh(path)
    disc.validate()
    assert_allclose(disc.x, [[0.5, 0.5, 0.5], [1.5, 0.5, 0.5]], rtol=1e-15)
    assert_allclose(disc.volume, [1.0, 1.0], rtol=1e-15)
    centroid, volume, _ = hex_centroid_and_volume(np.asarray(coords)[conn - 1])
    assert_array_equal(disc.x, centroid)
    assert_array_equal(disc.volume, volume)
    assert_array_equal(disc.block_id, [10, 3])  # file block order, Exodus block ids
    assert disc.block_names == {10: "left", 3: "block_3"}
    assert_array_equal(disc.gid, [6, 1])
    assert disc.neighbor_rule is None
    assert disc.min_element_radius == math.pow(0.238732414637843 * volume.min(), 0.33333333333333333)


def test_netcdf4_format_file(tmp_path):
    coords, conn = two_hex_mesh()
    path = write_exodus(tmp_path / "m.g", coords, [{"id": 1, "type": "HEX8", "conn": conn}],
                        [{"id": 2, "nodes": [3]}], fmt="NETCDF4")
    disc = read_exodus_mesh(path)
    assert disc.num_points == 2
    assert_array_equal(disc.node_sets["nodelist_2"], [1])


def test_relative_path_through_reader_class(tmp_path):
    coords, conn = two_hex_mesh()
    write_exodus(tmp_path / "m.g", coords, [{"id": 1, "type": "HEX8", "conn": conn}])
    params = ExodusMeshParams.model_validate({"Input Mesh File": "m.g", "Store Exodus Mesh": True})
    disc = ExodusMesh(params, deck_dir=tmp_path).read()
    assert disc.num_points == 2
    assert_array_equal(disc.gid, [0, 1])  # no id map: 0..n-1
    assert ExodusMesh.name == "Exodus"


def test_params():
    with pytest.raises(ValidationError):
        ExodusMeshParams.model_validate({})
    with pytest.raises(ValidationError):
        ExodusMeshParams.model_validate({"Input Mesh File": "a.g", "Not A Key": True})
    assert ExodusMeshParams.model_validate({"Input Mesh File": "a.g", "Construct Interfaces": True}).construct_interfaces
    p = ExodusMeshParams.model_validate({"Input Mesh File": "a.g"})
    assert p.store_exodus_mesh is False


def test_node_sets_follow_peridigm_order(tmp_path):
    coords, conn = two_hex_mesh()
    # node 2 (x=1, y=0, z=0) is shared by both elements; node 3 only by the second; node 1 by the first
    node_sets = [
        {"id": 4, "nodes": [3, 2, 1]},  # elem 1 (node 3); then 0, 1 (node 2; 1 already there); node 1 -> 0 again
        {"id": 9, "nodes": [1, 7], "name": "left_face"},
        {"id": 5, "nodes": []},
    ]
    path = write_exodus(tmp_path / "m.g", coords, [{"id": 1, "type": "HEX8", "conn": conn}], node_sets)
    disc = read_exodus_mesh(path)
    assert set(disc.node_sets) == {"nodelist_4", "left_face", "nodelist_5"}
    assert_array_equal(disc.node_sets["nodelist_4"], [1, 0])
    assert_array_equal(disc.node_sets["left_face"], [0])
    assert disc.node_sets["nodelist_5"].shape == (0,)
    assert disc.node_sets["nodelist_4"].dtype == np.int64


def test_node_set_entries_are_mothership_indices_not_gids(tmp_path):
    coords, conn = two_hex_mesh()
    path = write_exodus(tmp_path / "m.g", coords, [{"id": 1, "type": "HEX8", "conn": conn}],
                        [{"id": 1, "nodes": [3]}], elem_num_map=np.array([50, 40]))
    disc = read_exodus_mesh(path)
    assert_array_equal(disc.node_sets["nodelist_1"], [1])
    assert disc.gid[1] == 39


def test_original_global_id_map_overrides_the_id_map(tmp_path):
    coords, conn = two_hex_mesh()
    path = write_exodus(tmp_path / "m.g", coords, [{"id": 1, "type": "HEX8", "conn": conn}],
                        elem_num_map=np.array([1, 2]), aux_elem_map=("original_global_id_map", np.array([12, 11])))
    assert_array_equal(read_exodus_mesh(path).gid, [11, 10])
    path = write_exodus(tmp_path / "n.g", coords, [{"id": 1, "type": "HEX8", "conn": conn}],
                        aux_elem_map=("my_map", np.array([12, 11])))
    with pytest.raises(InputError, match="unknown auxiliary element map 'my_map'"):
        read_exodus_mesh(path)


def test_tet_mesh_and_coord_storage(tmp_path):
    coords = np.array([[0.0, 0, 0], [2, 0, 0], [0, 3, 0], [0, 0, 4], [2, 3, 4]])
    conn = np.array([[1, 2, 3, 4], [2, 3, 4, 5]])
    # second tet: orient it positively
    nodes = coords[conn - 1]
    _, v, _ = tet_centroid_and_volume(nodes)
    if v[1] < 0:
        conn[1] = conn[1][[1, 0, 2, 3]]
    path = write_exodus(tmp_path / "t.g", coords, [{"id": 2, "type": "TETRA", "conn": conn}], coord_style="coord")
    disc = read_exodus_mesh(path)
    assert_allclose(disc.x[0], [0.5, 0.75, 1.0], rtol=1e-15)
    assert disc.volume[0] == 4.0
    assert_allclose(disc.volume.sum(), 4.0 + abs(np.linalg.det(coords[[2, 3, 4]] - coords[1])) / 6, rtol=1e-14)


def test_tet10_uses_first_four_nodes(tmp_path):
    coords = np.array([[0.0, 0, 0], [2, 0, 0], [0, 3, 0], [0, 0, 4]] + [[9.0, 9, 9]] * 6)
    path = write_exodus(tmp_path / "t.g", coords, [{"id": 1, "type": "TET10", "conn": [list(range(1, 11))]}])
    disc = read_exodus_mesh(path)
    assert_allclose(disc.x, [[0.5, 0.75, 1.0]], rtol=1e-15)
    assert disc.volume[0] == 4.0


def test_sphere_elements_in_2d(tmp_path):
    coords = np.array([[0.0, 1.0], [2.0, 3.0]])
    path = write_exodus(tmp_path / "s.g", coords,
                        [{"id": 1, "type": "sphere", "conn": [[2], [1]], "attrib": [[0.1, 0.25], [0.2, 0.5]]}])
    disc = read_exodus_mesh(path)
    assert_array_equal(disc.x, [[2.0, 3.0, 0.0], [0.0, 1.0, 0.0]])
    assert_array_equal(disc.volume, [0.25, 0.5])
    assert disc.min_element_radius == math.pow(0.238732414637843 * 0.25, 0.33333333333333333)


def test_sphere_without_volume_attribute(tmp_path):
    path = write_exodus(tmp_path / "s.g", np.zeros((1, 3)),
                        [{"id": 1, "type": "SPHERE", "conn": [[1]], "attrib": [[0.1]]}])
    with pytest.raises(InputError, match="2 attributes"):
        read_exodus_mesh(path)


def test_inverted_tet_names_the_element(tmp_path):
    coords = np.array([[0.0, 0, 0], [2, 0, 0], [0, 3, 0], [0, 0, 4]])
    blocks = [{"id": 7, "type": "TET4", "conn": [[1, 2, 3, 4], [2, 1, 3, 4]]}]
    path = write_exodus(tmp_path / "t.g", coords, blocks, elem_num_map=np.array([5, 6]))
    with pytest.raises(InputError) as info:
        read_exodus_mesh(path)
    text = str(info.value)
    assert "element block 7" in text and "element 2 of the block (id 6)" in text and "inverted" in text
    assert str(tmp_path / "t.g") in text


def test_inverted_hex_is_an_error(tmp_path):
    coords, conn = two_hex_mesh()
    conn[1] = conn[1][[4, 5, 6, 7, 0, 1, 2, 3]]  # top and bottom swapped
    path = write_exodus(tmp_path / "m.g", coords, [{"id": 1, "type": "HEX8", "conn": conn}])
    with pytest.raises(InputError, match="element 2 of the block"):
        read_exodus_mesh(path)


def test_unsupported_element_type_lists_supported_types(tmp_path):
    coords = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
    path = write_exodus(tmp_path / "q.g", coords, [{"id": 1, "type": "QUAD4", "conn": [[1, 2, 3, 4]]}])
    with pytest.raises(InputError, match="unsupported element type 'QUAD4'") as info:
        read_exodus_mesh(path)
    for name in ("SPHERE", "TET", "TETRA", "TET4", "TET10", "HEX", "HEX8", "HEX20"):
        assert name in str(info.value)


def test_connectivity_out_of_range(tmp_path):
    coords, conn = two_hex_mesh()
    conn[0, 0] = 99
    path = write_exodus(tmp_path / "m.g", coords, [{"id": 1, "type": "HEX8", "conn": conn}])
    with pytest.raises(InputError, match="outside 1..12"):
        read_exodus_mesh(path)


def test_duplicate_block_names(tmp_path):
    coords, conn = two_hex_mesh()
    path = write_exodus(tmp_path / "m.g", coords, [{"id": 1, "type": "HEX8", "conn": conn[:1], "name": "a"},
                                                   {"id": 2, "type": "HEX8", "conn": conn[1:], "name": "a"}])
    with pytest.raises(InputError, match="duplicate element block name 'a'"):
        read_exodus_mesh(path)


def test_missing_corrupt_and_non_exodus_files(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_exodus_mesh(tmp_path / "none.g")
    (tmp_path / "junk.g").write_bytes(b"this is not a netCDF file\n" * 10)
    with pytest.raises(InputError, match="not a readable Exodus") as info:
        read_exodus_mesh(tmp_path / "junk.g")
    assert "junk.g" in str(info.value)
    ds = netCDF4.Dataset(tmp_path / "other.nc", "w", format="NETCDF3_CLASSIC")
    ds.createDimension("t", 2)
    ds.createVariable("a", "f8", ("t",))[:] = [1.0, 2.0]
    ds.close()
    with pytest.raises(InputError, match="not an Exodus II file"):
        read_exodus_mesh(tmp_path / "other.nc")


# ------------------------------------------------------------------------------------------------
# Conformance meshes against Peridigm's gold outputs
# ------------------------------------------------------------------------------------------------
# gold files written by Peridigm builds with the current geometry code: exact equality
EXACT = [
    ("ElasticBondBased3D", "ElasticBondBased3D.g", "ElasticBondBased3D_gold.e"),
    ("ElasticBondBased2DPlaneStrain", "ElasticBondBased2D.g", "ElasticBondBased2DPlaneStrain_gold.e"),
    ("InitialDamage", "InitialDamage.g", "InitialDamage_gold.e"),
    ("DeformationGradient_NoLoad", "DeformationGradient.g", "DeformationGradient_NoLoad_gold.e"),
    ("DiskFilter", "DiskFilter.g", "DiskFilter_gold.e"),
    ("CentrifugalLoad", "CentrifugalLoad.g", "CentrifugalLoad_gold.e"),
    ("LinearLPSBar", "LinearLPSBar.g", "LinearLPSBar_gold.e"),
    ("Pals_Simple_Shear", "cube_7x7x7.g", "Pals_Simple_Shear_gold.e"),
]
# gold files from old Peridigm builds (api 5.x) whose hex centroids differ by an ulp or two
ROUNDOFF = [
    ("WaveInBar", "WaveInBar.g", "WaveInBar_gold.e"),
    ("PrecrackedPlate", "Plate.g", "PrecrackedPlate_gold.e"),
    ("Bar_OneBlock_OneMaterial_QS", "Bar.g", "Bar_gold.e"),
]


def _gold(path: Path):
    ds = netCDF4.Dataset(path)
    ds.set_auto_mask(False)
    return ds


def _names(ds, var: str) -> list[str]:
    return [b"".join(row).split(b"\0")[0].decode() for row in ds[var][:]]


def _element_var(ds, name: str) -> np.ndarray | None:
    """A step-0 element variable in point order, or None."""
    if "name_elem_var" not in ds.variables or name not in _names(ds, "name_elem_var"):
        return None
    index = _names(ds, "name_elem_var").index(name) + 1
    out = np.full(len(ds.dimensions["num_nodes"]), np.nan)
    for b in range(len(ds["eb_prop1"][:])):
        points = ds[f"connect{b + 1}"][:].ravel() - 1
        out[points] = ds[f"vals_elem_var{index}eb{b + 1}"][0]
    return out


@needs_cases
@pytest.mark.parametrize(("case", "mesh", "output"), EXACT + ROUNDOFF)
def test_points_blocks_and_node_sets_match_gold(case, mesh, output):
    disc = ExodusMesh(ExodusMeshParams.model_validate({"Input Mesh File": mesh}), deck_dir=CASES / case).read()
    disc.validate()
    ds = _gold(CASES / case / output)
    x_gold = np.stack([ds["coordx"][:], ds["coordy"][:], ds["coordz"][:]], axis=1)
    if (case, mesh, output) in EXACT:
        assert_array_equal(disc.x, x_gold)
    else:
        assert_allclose(disc.x, x_gold, rtol=0, atol=1e-12)  # the cases' COORDINATES tolerance
    assert_array_equal(disc.gid, ds["node_num_map"][:] - 1)
    for b, block in enumerate(ds["eb_prop1"][:]):
        points = ds[f"connect{b + 1}"][:].ravel() - 1
        assert np.all(disc.block_id[points] == block)
    assert set(disc.block_id.tolist()) == {int(b) for b in ds["eb_prop1"][:]}
    volume = _element_var(ds, "Volume")
    if volume is not None:
        if (case, mesh, output) in EXACT:
            assert_array_equal(disc.volume, volume)
        else:
            assert_allclose(disc.volume, volume, rtol=1e-14)
    # node sets: the gold lists Peridigm's point sets under tidied names, in Peridigm's order
    if "num_node_sets" in ds.dimensions and (case, mesh, output) in EXACT:
        gold_sets = dict(zip(_names(ds, "ns_names"), range(len(ds["ns_prop1"][:]))))
        ours = {name.upper().replace(" ", "_"): ids for name, ids in disc.node_sets.items()}
        assert set(ours) <= set(gold_sets)
        for name, ids in ours.items():
            assert_array_equal(ids, ds[f"node_ns{gold_sets[name] + 1}"][:] - 1, err_msg=name)
    ds.close()


@needs_cases
def test_first_block_gids_start_at_288():
    """ElasticBondBased3D's first block holds elements 289.. (GIDs need not be sorted)."""
    disc = read_exodus_mesh(CASES / "ElasticBondBased3D" / "ElasticBondBased3D.g")
    assert disc.gid[0] == 288
    assert disc.block_id[0] == 1
