"""Construct Interfaces and the Interfaces.e file (PERIDIGM_MODELS.md §11.1): face detection in
Peridigm's order with its quirks, the single-precision two-block file, apertures lagged by one
write, and an end-to-end run through the engine."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from peridyn.engine.run_services import RunServices
from peridyn.core.errors import InputError
from peridyn.io.interfaces import (
    InterfaceFile,
    MeshTopology,
    _as_set,
    apertures,
    find_interfaces,
    read_mesh_topology,
)
from peridyn.engine.session import run_sections

netCDF4 = pytest.importorskip("netCDF4")

CUBE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float)


def topology(elements: list[list[int]], xyz: np.ndarray, node_id: np.ndarray | None = None, types=None) -> MeshTopology:
    """A MeshTopology from element node lists (global node ids)."""
    sizes = np.array([len(e) for e in elements])
    offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    node_id = np.arange(len(xyz)) if node_id is None else np.asarray(node_id)
    types = types or ["HEX8" if len(e) == 8 else "TETRA" for e in elements]
    return MeshTopology(node_id.astype(np.int64), np.asarray(xyz, float), offsets, np.concatenate(elements).astype(np.int64), np.array(types, dtype=object))


def two_hexes() -> MeshTopology:
    """Unit hexes along x; nodes n = x + 3 y + 6 z."""
    xyz = np.array([[x, y, z] for z in (0.0, 1.0) for y in (0.0, 1.0) for x in (0.0, 1.0, 2.0)])

    def n(x, y, z):
        return x + 3 * y + 6 * z

    elems = [[n(e, 0, 0), n(e + 1, 0, 0), n(e + 1, 1, 0), n(e, 1, 0), n(e, 0, 1), n(e + 1, 0, 1), n(e + 1, 1, 1), n(e, 1, 1)] for e in range(2)]
    return topology(elems, xyz)


def test_two_hexes_share_one_quad_from_the_lower_gid():
    topo = two_hexes()
    gid = np.array([0, 1])
    recs = find_interfaces(topo, gid, [(0, np.array([1])), (1, np.array([0]))])
    assert len(recs) == 1
    i, _k, j, count, nodes = recs[0]
    assert (i, j, count) == (0, 1, 4)
    # the first face of Peridigm's list with more than two shared nodes: {1,5,6,2} of element 0
    assert nodes == [1, 7, 10, 4]
    # with the ids the other way round the interface is element 1's face {0,4,7,3}
    recs = find_interfaces(topo, np.array([5, 2]), [(0, np.array([1])), (1, np.array([0]))])
    assert [(r[0], r[2], r[4]) for r in recs] == [(1, 0, [1, 7, 10, 4])]


def test_tets_sharing_a_face_give_a_triangle_in_own_node_order():
    xyz = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float)
    topo = topology([[0, 1, 2, 3], [3, 2, 1, 4]], xyz)
    recs = find_interfaces(topo, np.array([0, 1]), [(0, np.array([1])), (1, np.array([0]))])
    assert [(r[0], r[2], r[3], r[4]) for r in recs] == [(0, 1, 3, [1, 2, 3])]


def test_hex_reads_a_tet_neighbour_as_eight_entries():
    """A hex i reads n_i = 8 entries from a tet's first one: the tet's 4 nodes and the next
    element's 4 (Peridigm's over-read). Counting with those entries decides the face."""
    extra = np.array([[1.5, 0.5, 0.5], [3, 0, 0], [3, 1, 0], [3, 1, 1]], float)
    xyz = np.vstack([CUBE, extra])  # nodes 8..11
    # tet 1 shares nodes 1, 2, 5 of the hex face {1,5,6,2}; tet 2 (next element) holds node 6
    topo = topology([list(range(8)), [1, 2, 5, 8], [9, 10, 6, 11]], xyz)
    recs = find_interfaces(topo, np.arange(3), [(0, np.array([1]))])
    assert [(r[2], r[3], r[4]) for r in recs] == [(1, 4, [1, 5, 6, 2])]
    # without node 6 in the next element: three matches, a TRI3 of the face's first three nodes
    topo = topology([list(range(8)), [1, 2, 5, 8], [9, 10, 11, 8]], xyz)
    recs = find_interfaces(topo, np.arange(3), [(0, np.array([1]))])
    assert [(r[3], r[4]) for r in recs] == [(3, [1, 5, 6, 2])]
    assert _as_set(recs).nodes[0, :3].tolist() == [1, 5, 6]
    # past the end of the mesh nothing matches (Peridigm reads unowned memory there)
    topo = topology([list(range(8)), [1, 2, 5, 8]], xyz[:9])
    assert [(r[3]) for r in find_interfaces(topo, np.arange(2), [(0, np.array([1]))])] == [3]


def test_more_than_four_matches_is_an_error():
    xyz = np.vstack([CUBE, [[1.5, 0.5, 0.5], [3, 0, 0]]])
    topo = topology([list(range(8)), [4, 5, 6, 8], [4, 5, 6, 9]], xyz)  # face {4,5,6,7} matched 6 times
    with pytest.raises(InputError, match="node matches"):
        find_interfaces(topo, np.arange(3), [(0, np.array([1]))])


def test_file_layout_is_single_precision_with_two_fixed_blocks(tmp_path: Path):
    topo = two_hexes()
    topo.node_id = np.array([11, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10])  # node ids not in file order
    topo.elem_nodes = topo.node_id[topo.elem_nodes]
    recs = find_interfaces(topo, np.array([0, 1]), [(0, np.array([1])), (1, np.array([0]))])
    ifaces = _as_set(recs)
    f = InterfaceFile(tmp_path / "Interfaces.e", topo, ifaces)
    f.write(1, 0.1, np.array([0.25]))
    f.close()
    ds = netCDF4.Dataset(tmp_path / "Interfaces.e")
    ds.set_auto_mask(False)
    assert ds.floating_point_word_size == 4 and ds.title == "Interfaces.e"
    for v in ("coordx", "coordy", "coordz", "time_whole", "vals_elem_var1eb1"):
        assert ds[v].dtype == np.float32
    # nodes sorted by id: positions in that order, node_num_map = id + 1
    np.testing.assert_array_equal(ds["node_num_map"][:], np.arange(1, 13))
    np.testing.assert_array_equal(ds["coordx"][:], topo.node_xyz[np.argsort(topo.node_id), 0].astype(np.float32))
    assert ds["connect1"].elem_type == "QUAD4"
    np.testing.assert_array_equal(ds["connect1"][:], ifaces.nodes[:, :4] + 1)
    assert "connect2" not in ds.variables and ds["eb_status"][:].tolist() == [1, 0]  # NULL TRI3 block
    assert ds["eb_prop1"][:].tolist() == [1, 2] and ds["elem_num_map"][:].tolist() == [1]
    names = [b"".join(r).decode() for r in ds["coor_names"][:]]
    assert names == ["coordinates_x", "coordinates_y", "coordinates_x"]
    assert ds["time_whole"][0] == np.float32(0.1) and ds["vals_elem_var1eb1"][0, 0] == np.float32(0.25)
    ds.close()


def test_aperture_is_the_change_of_the_centre_distance():
    x = np.array([[0.0, 0, 0], [1.0, 0, 0], [0, 2.0, 0]])
    y = x + np.array([[0.0, 0, 0], [0.5, 0, 0], [0, 0, 0]])
    np.testing.assert_allclose(apertures(x, y, np.array([0, 0]), np.array([1, 2])), [0.5, 0.0])


# ------------------------------------------------------------------------------------------------
# end to end: Exodus mesh -> engine -> Interfaces.e
# ------------------------------------------------------------------------------------------------
def write_hex_mesh(path: Path, nx: int, ny: int = 1, nz: int = 1, h: float = 1.0) -> Path:
    """A structured nx x ny x nz HEX8 Exodus mesh of spacing h, one block."""
    node = lambda i, j, k: i + (nx + 1) * (j + (ny + 1) * k)
    xyz = np.array([[i * h, j * h, k * h] for k in range(nz + 1) for j in range(ny + 1) for i in range(nx + 1)])
    conn = [[node(i, j, k), node(i + 1, j, k), node(i + 1, j + 1, k), node(i, j + 1, k),
             node(i, j, k + 1), node(i + 1, j, k + 1), node(i + 1, j + 1, k + 1), node(i, j + 1, k + 1)]
            for k in range(nz) for j in range(ny) for i in range(nx)]
    ds = netCDF4.Dataset(path, "w", format="NETCDF3_64BIT_OFFSET")
    for name, size in (("len_name", 33), ("num_dim", 3), ("num_nodes", len(xyz)), ("num_elem", len(conn)), ("num_el_blk", 1),
                       ("num_el_in_blk1", len(conn)), ("num_nod_per_el1", 8)):
        ds.createDimension(name, size)
    for d, c in enumerate("xyz"):
        ds.createVariable(f"coord{c}", "f8", ("num_nodes",))[:] = xyz[:, d]
    ds.createVariable("eb_prop1", "i4", ("num_el_blk",))[:] = [1]
    ds.createVariable("eb_status", "i4", ("num_el_blk",))[:] = [1]
    v = ds.createVariable("connect1", "i4", ("num_el_in_blk1", "num_nod_per_el1"))
    v.elem_type = "HEX8"
    v[:] = np.array(conn) + 1
    ds.close()
    return path


def test_engine_writes_apertures_lagged_by_one_write(tmp_path: Path):
    from peridyn.testing.harness import build_simulation

    write_hex_mesh(tmp_path / "bar.g", 2)
    tree = {
        "Discretization": {"Type": "Exodus", "Input Mesh File": "bar.g", "Construct Interfaces": True},
        "Materials": {"M": {"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 1.0}},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": 1.5}},
        "Output": {"Output Filename": "out", "Output Frequency": 1, "Output Variables": {"Displacement": True}},
    }
    sim = build_simulation(tree, directory=tmp_path)
    assert (tmp_path / "Interfaces.e").exists()  # created at construction
    y = sim.fields["Coordinates"]
    right = int(np.argmax(sim.fields["Model_Coordinates"][:, 0]))
    run = RunServices.of(sim)
    run.write_output(0.0)
    y[right, 0] += 0.1
    run.write_output(1.0)
    run.write_output(2.0)
    run.close()
    ds = netCDF4.Dataset(tmp_path / "Interfaces.e")
    ds.set_auto_mask(False)
    np.testing.assert_array_equal(ds["time_whole"][:], np.float32([0.0, 1.0, 2.0]))
    np.testing.assert_allclose(ds["vals_elem_var1eb1"][:, 0], [0.0, 0.0, 0.1], rtol=1e-6)  # one write behind
    ds.close()


def test_read_mesh_topology_uses_node_ids(tmp_path: Path):
    write_hex_mesh(tmp_path / "m.g", 2)
    ds = netCDF4.Dataset(tmp_path / "m.g", "a")
    ds.createVariable("node_num_map", "i4", ("num_nodes",))[:] = np.arange(12, 0, -1)
    ds.close()
    topo = read_mesh_topology(tmp_path / "m.g")
    assert topo.num_elements == 2 and topo.node_id.tolist() == list(range(11, -1, -1))
    assert topo.elem_nodes[:8].tolist() == [11 - n for n in (0, 1, 4, 3, 6, 7, 10, 9)]
    assert topo.hex_nodes().shape == (2, 8, 3)
    np.testing.assert_array_equal(topo.hex_nodes()[0], CUBE)


CASE = Path(__file__).resolve().parents[3].parent / "shared" / "conformance" / "cases" / "Interfaces"


@pytest.mark.skipif(not (CASE / "Interfaces_gold.e").is_file(), reason="the Interfaces reference case is not available")
def test_reference_case_is_reproduced_bit_for_bit(tmp_path: Path):
    """Peridigm's regression case (hexahedra and tetrahedra, one QuasiStatic step): every
    variable of Interfaces.e equals the gold file's, dtype included (the case's comparator
    checks only the times). The case is read from the shared folder, not copied."""
    import shutil

    from peridyn.deck.model import load_deck
    from peridyn.engine.simulation import Simulation

    for name in ("Interfaces.xml", "Interfaces.g"):
        shutil.copy(CASE / name, tmp_path / name)
    sim = Simulation(load_deck(tmp_path / "Interfaces.xml"), output_dir=tmp_path)
    run = RunServices.of(sim)
    run_sections(sim, run=run)
    run.close()
    sim.interfaces.close()
    ours = netCDF4.Dataset(tmp_path / "Interfaces.e")
    gold = netCDF4.Dataset(CASE / "Interfaces_gold.e")
    try:
        for ds in (ours, gold):
            ds.set_auto_mask(False)
        assert {k: len(v) for k, v in ours.dimensions.items() if k != "time_step"} == {
            k: len(v) for k, v in gold.dimensions.items() if k != "time_step"
        }
        for name, var in gold.variables.items():
            assert ours[name].dtype == var.dtype, name
            np.testing.assert_array_equal(ours[name][:], var[:], err_msg=name)
        assert ours["connect1"].elem_type == "QUAD4" and ours["connect2"].elem_type == "TRI3"
    finally:
        ours.close()
        gold.close()
