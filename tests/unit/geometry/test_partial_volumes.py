"""Element-horizon intersections and partial volumes (peridyn.geometry.partial_volumes).

Measured accuracy of the quadrature (effective resolution n = 2^level x samples per direction):

* one unit cube cut by a ball centred at its corner (radius 0.7, exact = 1/8 of the ball):
  relative error 2.1e-2 (n = 8, the default level 2 / 2 samples), 3.2e-3 (n = 16), 6.7e-4
  (n = 32); level 2 with 4 samples equals level 3 with 2 samples bit for bit;
* the neighbourhood volume sum_j |cell_j ∩ B(c, delta)| of a cubic grid, RMS over 12 random
  centres, relative to 4/3 pi delta^3 (n = 8): 8.0e-4 (delta/h = 2), 2.4e-4 (4), 5.6e-5 (8),
  order 1.9 (1.9-2.4 over other draws of centres); the plain sum of the cells whose centres lie
  in the ball: 3.9e-2, 9.5e-3, 2.6e-3.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from peridyn.geometry.partial_volumes import (
    INSIDE,
    INTERSECTS,
    OUTSIDE,
    hexahedron_sphere_intersection,
    intersecting_neighbors,
    max_element_dimension,
    partial_volume,
    partial_volumes_kernel,
    triangle_sphere_intersection,
)

CUBE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float)


def grid(m: int, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(2m+1)^3 cubic cells of side h centred on the origin: centres (n, 3), nodes (n, 8, 3)."""
    c = np.arange(-m, m + 1) * h
    X = np.stack(np.meshgrid(c, c, c, indexing="ij"), -1).reshape(-1, 3)
    return X, X[:, None, :] + h * (CUBE - 0.5)[None]


def ball_volume(center, X, nodes, h, delta, level=2, samples=2) -> tuple[float, float]:
    """(sum of partial volumes, sum of the volumes of cells whose centre is in the ball)."""
    total = plain = 0.0
    for j in np.nonzero(np.linalg.norm(X - center, axis=1) <= delta + h)[0]:
        where = hexahedron_sphere_intersection(nodes[j], center, delta)
        if where == INSIDE:
            total += h**3
        elif where == INTERSECTS:
            total += partial_volume(nodes[j], center, delta, level, samples)
        if np.sum((X[j] - center) ** 2) <= delta * delta:
            plain += h**3
    return total, plain


# ------------------------------------------------------------------------------------------------
# classification (Peridigm's hexahedronSphereIntersection)
# ------------------------------------------------------------------------------------------------
def test_hexahedron_sphere_classification():
    c = np.array([0.5, 0.5, 0.5])
    assert hexahedron_sphere_intersection(CUBE, c, 0.9) == INSIDE  # corners at 0.866
    assert hexahedron_sphere_intersection(CUBE, c, 0.6) == INTERSECTS  # no node inside, faces cut
    assert hexahedron_sphere_intersection(CUBE, np.array([3.0, 0.5, 0.5]), 1.5) == OUTSIDE
    # all nodes outside, the sphere pokes through the middle of face x = 1 only
    assert hexahedron_sphere_intersection(CUBE, np.array([1.3, 0.5, 0.5]), 0.35) == INTERSECTS
    assert hexahedron_sphere_intersection(CUBE, np.array([1.3, 0.5, 0.5]), 0.29) == OUTSIDE
    # an edge: the ball's centre beyond the edge x = 1, y = 1
    assert hexahedron_sphere_intersection(CUBE, np.array([1.2, 1.2, 0.5]), 0.3) == INTERSECTS
    assert hexahedron_sphere_intersection(CUBE, np.array([1.2, 1.2, 0.5]), 0.28) == OUTSIDE


def test_triangle_sphere_strict_node_test():
    p, q, r = np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0])
    assert triangle_sphere_intersection(p, q, r, np.zeros(3), 1.0) == INTERSECTS  # nodes on the sphere: not inside
    assert triangle_sphere_intersection(p, q, r, np.zeros(3), 1.01) == INSIDE
    assert triangle_sphere_intersection(p, q, r, np.zeros(3), 0.5) == OUTSIDE  # plane at 0.577


def test_intersecting_neighbors_keeps_cut_cells_in_index_order():
    h = 1.0
    X, nodes = grid(3, h)
    horizon = np.full(len(X), 1.6)
    c = len(X) // 2
    assert max_element_dimension(nodes) == pytest.approx(math.sqrt(3.0))
    off, nb = intersecting_neighbors(X, horizon, np.array([c]), nodes)
    row = nb[off[0] : off[1]]
    assert np.all(np.diff(row) > 0) and c not in row
    expected = [j for j in range(len(X)) if j != c and hexahedron_sphere_intersection(nodes[j], X[c], 1.6) != OUTSIDE]
    assert row.tolist() == expected
    # more than the centroid search (cells whose centres lie outside but which are cut)
    assert len(row) > np.sum(np.sum((X - X[c]) ** 2, axis=1) <= 1.6**2) - 1


# ------------------------------------------------------------------------------------------------
# quadrature accuracy
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("level, samples, bound", [(2, 2, 3e-2), (3, 2, 5e-3), (4, 2, 1e-3)])
def test_single_cell_accuracy(level, samples, bound):
    exact = math.pi * 4.0 / 3.0 * 0.7**3 / 8.0  # ball centred at a corner
    err = abs(partial_volume(CUBE, np.zeros(3), 0.7, level, samples) - exact) / exact
    assert err < bound


def test_whole_empty_and_scaled_cells():
    assert partial_volume(CUBE, np.full(3, 0.5), 5.0, 2, 2) == pytest.approx(1.0, rel=1e-14)
    assert partial_volume(CUBE, np.array([5.0, 0, 0]), 1.0, 2, 2) == 0.0
    # scaling the cell and the ball by 2 scales the partial volume by 8 (same samples inside)
    c = np.array([0.2, 0.1, 0.3])
    ref = partial_volume(CUBE, c, 0.6, 2, 2)
    assert 0.0 < ref < 1.0
    assert partial_volume(2.0 * CUBE, 2.0 * c, 1.2, 2, 2) == pytest.approx(8.0 * ref, rel=1e-12)


def test_neighbourhood_volume_converges_to_the_ball_volume():
    """Partial volumes: RMS error (random centres) of the neighbourhood volume against
    4/3 pi delta^3 falls with order > 1.6 under grid refinement and is at least 10x below the
    plain centroid sum's."""
    rng = np.random.default_rng(1)
    exact = 4.0 / 3.0 * math.pi
    errs, plains = [], []
    for r in (2.0, 4.0, 8.0):
        h = 1.0 / r
        X, nodes = grid(math.ceil(r) + 2, h)
        e, p = [], []
        for _ in range(12):
            total, plain = ball_volume(rng.uniform(-0.5, 0.5, 3) * h, X, nodes, h, 1.0)
            e.append((total - exact) / exact)
            p.append((plain - exact) / exact)
        errs.append(math.sqrt(np.mean(np.square(e))))
        plains.append(math.sqrt(np.mean(np.square(p))))
    rate = math.log(errs[0] / errs[-1]) / math.log(4.0)
    assert rate > 1.6, (errs, rate)
    assert errs[-1] < 1e-4
    for e, p in zip(errs, plains):
        assert e < 0.1 * p, (errs, plains)


def test_kernel_fills_both_directions_and_is_thread_independent():
    import numba

    h = 1.0
    X, nodes = grid(2, h)
    n = len(X)
    horizon = np.linspace(1.2, 1.7, n)  # variable horizons: Self_Volume differs from the reverse bond's weight
    off, nb = intersecting_neighbors(X, horizon, np.arange(n), nodes)
    vol = np.full(n, h**3)
    runs = []
    old = numba.get_num_threads()
    try:
        for threads in (1, max(2, min(old, numba.config.NUMBA_NUM_THREADS))):
            numba.set_num_threads(threads)
            nv, sv = np.zeros(nb.size), np.zeros(nb.size)
            partial_volumes_kernel(0, n, off, nb, X, horizon, nodes, vol, 2, 2, nv, sv)
            runs.append((nv, sv))
    finally:
        numba.set_num_threads(old)
    np.testing.assert_array_equal(runs[0][0], runs[1][0])
    np.testing.assert_array_equal(runs[0][1], runs[1][1])
    nv, sv = runs[0]
    i = n // 2
    for b in range(off[i], off[i + 1]):
        j = nb[b]
        assert nv[b] == pytest.approx(partial_volume(nodes[j], X[i], horizon[i], 2, 2) if hexahedron_sphere_intersection(nodes[j], X[i], horizon[i]) == INTERSECTS else vol[j])
        assert sv[b] == pytest.approx(partial_volume(nodes[i], X[j], horizon[j], 2, 2) if hexahedron_sphere_intersection(nodes[i], X[j], horizon[j]) == INTERSECTS else vol[i])


# ------------------------------------------------------------------------------------------------
# through the engine: Number_Of_Neighbors and Neighborhood_Volume
# ------------------------------------------------------------------------------------------------
def write_hex_mesh(path: Path, n: int, h: float) -> Path:
    netCDF4 = pytest.importorskip("netCDF4")
    node = lambda i, j, k: i + (n + 1) * (j + (n + 1) * k)
    xyz = np.array([[i * h, j * h, k * h] for k in range(n + 1) for j in range(n + 1) for i in range(n + 1)])
    conn = [[node(i, j, k), node(i + 1, j, k), node(i + 1, j + 1, k), node(i, j + 1, k),
             node(i, j, k + 1), node(i + 1, j, k + 1), node(i + 1, j + 1, k + 1), node(i, j + 1, k + 1)]
            for k in range(n) for j in range(n) for i in range(n)]
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


def test_engine_neighborhood_volume_uses_partial_volumes(tmp_path: Path):
    from peridyn.testing.harness import build_simulation

    h, n, delta = 0.5, 7, 1.2
    write_hex_mesh(tmp_path / "m.g", n, h)

    def run(intersections: bool):
        tree = {
            "Discretization": {"Type": "Exodus", "Input Mesh File": "m.g", "Compute Element-Horizon Intersections": intersections},
            "Materials": {"M": {"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 1.0}},
            "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": delta}},
            "Output": {"Output Filename": "o", "Output Frequency": 1,
                       "Output Variables": {"Neighborhood_Volume": True, "Number_Of_Neighbors": True}},
        }
        sim = build_simulation(tree, directory=tmp_path)
        sim.outputs.run_computes(["Neighborhood_Volume", "Number_Of_Neighbors"])
        x = sim.fields["Model_Coordinates"][: sim.num_owned]
        c = int(np.argmin(np.linalg.norm(x - x.mean(axis=0), axis=1)))
        assert "Neighbor_Volume" not in sim.fields  # no model asked for the bond field
        return sim.fields["Neighborhood_Volume"][c], sim.fields["Number_Of_Neighbors"][c], x[c]

    nv, count, _centre = run(True)
    X, nodes = grid(3, h)
    expected, _ = ball_volume(np.zeros(3), X, nodes, h, delta)
    assert nv == pytest.approx(expected, rel=1e-12)
    assert count == sum(1 for j in range(len(X)) if j != len(X) // 2 and hexahedron_sphere_intersection(nodes[j], np.zeros(3), delta) != OUTSIDE)
    assert abs(nv / (4.0 / 3.0 * math.pi * delta**3) - 1.0) < 1e-2  # 6.2e-3 at delta/h = 2.4
    plain, plain_count, _ = run(False)
    ball = 4.0 / 3.0 * math.pi * delta**3
    assert plain_count < count and abs(plain / ball - 1.0) > 2.0 * abs(nv / ball - 1.0)  # 1.6e-2 against 6.2e-3


def test_intersections_need_hexahedra(tmp_path: Path):
    from peridyn.core.errors import InputError
    from peridyn.testing.harness import build_simulation

    netCDF4 = pytest.importorskip("netCDF4")
    ds = netCDF4.Dataset(tmp_path / "t.g", "w", format="NETCDF3_64BIT_OFFSET")
    for name, size in (("len_name", 33), ("num_dim", 3), ("num_nodes", 5), ("num_elem", 2), ("num_el_blk", 1),
                       ("num_el_in_blk1", 2), ("num_nod_per_el1", 4)):
        ds.createDimension(name, size)
    xyz = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float)
    for d, c in enumerate("xyz"):
        ds.createVariable(f"coord{c}", "f8", ("num_nodes",))[:] = xyz[:, d]
    ds.createVariable("eb_prop1", "i4", ("num_el_blk",))[:] = [1]
    v = ds.createVariable("connect1", "i4", ("num_el_in_blk1", "num_nod_per_el1"))
    v.elem_type = "TETRA"
    v[:] = np.array([[1, 2, 3, 4], [2, 3, 4, 5]])
    ds.close()
    tree = {
        "Discretization": {"Type": "Exodus", "Input Mesh File": "t.g", "Compute Element-Horizon Intersections": True},
        "Materials": {"M": {"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 1.0}},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": 2.0}},
    }
    with pytest.raises(InputError, match="hexahedra"):
        build_simulation(tree, directory=tmp_path)


NV_CASE = Path(__file__).resolve().parents[3].parent / "shared" / "conformance" / "cases" / "NeighborhoodVolume"


@pytest.mark.skipif(not (NV_CASE / "NeighborhoodVolume_gold.e").is_file(), reason="the NeighborhoodVolume reference case is not available")
def test_reference_neighborhood_volumes_to_round_off(tmp_path: Path):
    """Peridigm's NeighborhoodVolume case (three blocks of distorted hexahedra, one with a
    variable horizon): Number_Of_Neighbors exactly and Neighborhood_Volume to 1e-15 (measured
    8.3e-17; the case's tolerance is 1e-12). Read from the shared folder, not copied."""
    import shutil

    netCDF4 = pytest.importorskip("netCDF4")
    from peridyn.deck.model import load_deck
    from peridyn.engine.simulation import Simulation

    for name in ("NeighborhoodVolume.xml", "NeighborhoodVolume.g"):
        shutil.copy(NV_CASE / name, tmp_path / name)
    sim = Simulation(load_deck(tmp_path / "NeighborhoodVolume.xml"), output_dir=tmp_path)
    sim.outputs.run_computes(["Neighborhood_Volume", "Number_Of_Neighbors"])
    n = sim.num_owned
    order = sim.mothership_of_local[:n]
    gold = netCDF4.Dataset(NV_CASE / "NeighborhoodVolume_gold.e")
    gold.set_auto_mask(False)
    names = [b"".join(r).decode().rstrip("\x00") for r in gold["name_elem_var"][:]]

    def gold_values(name):
        k = names.index(name) + 1
        out = np.empty(sim.num_global)  # gold nodes are in mothership (element file) order
        for b in range(1, len(gold.dimensions["num_el_blk"]) + 1):
            out[gold[f"connect{b}"][:, 0] - 1] = gold[f"vals_elem_var{k}eb{b}"][0]
        return out

    try:
        for name, tol in (("Number_Of_Neighbors", 0.0), ("Neighborhood_Volume", 1e-15)):
            ours = np.empty(sim.num_global)
            ours[order] = sim.fields[name][:n]
            np.testing.assert_allclose(ours, gold_values(name), rtol=0, atol=tol, err_msg=name)
    finally:
        gold.close()
