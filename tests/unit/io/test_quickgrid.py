"""PdQuickGrid (§2.1, §2.2): point placement, neighbor rules, parameters, and gold files."""
from __future__ import annotations

import itertools
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from pydantic import ValidationError

from peridyn.core.errors import InputError
from peridyn.io.quickgrid import (
    PdQuickGrid,
    PdQuickGridParams,
    TensorProduct3DParams,
    TensorProductCylinderParams,
    cell_neighborhood_size,
    cylinder_layout,
    running_sum_centers,
    tensor_product_3d,
    tensor_product_cylinder,
)

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
CASES = SHARED / "conformance" / "cases"
needs_cases = pytest.mark.skipif(not CASES.is_dir(), reason="conformance cases not available")


def box(nx, ny, nz, lengths=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0)) -> TensorProduct3DParams:
    return TensorProduct3DParams.model_validate(
        {
            "Type": "PdQuickGrid",
            "X Origin": origin[0], "Y Origin": origin[1], "Z Origin": origin[2],
            "X Length": lengths[0], "Y Length": lengths[1], "Z Length": lengths[2],
            "Number Points X": nx, "Number Points Y": ny, "Number Points Z": nz,
        }
    )


def cylinder(ri=0.020, ro=0.025, length=0.100, nr=5, z0=0.0) -> TensorProductCylinderParams:
    return TensorProductCylinderParams.model_validate(
        {
            "Type": "PdQuickGrid", "Inner Radius": ri, "Outer Radius": ro, "Cylinder Length": length,
            "Ring Center x": 0.0, "Ring Center y": 0.0, "Z Origin": z0, "Number Points Radius": nr,
        }
    )


def lists(offsets, neighbors):
    return [neighbors[offsets[i] : offsets[i + 1]] for i in range(len(offsets) - 1)]


def half_up(r: float) -> int:
    """Round half up, written independently of the implementation."""
    n = math.floor(r)
    return n + 1 if r - n >= 0.5 else n


# ------------------------------------------------------------------------------------------------
# Points
# ------------------------------------------------------------------------------------------------
def test_running_sums_not_closed_form():
    x0, length, n = 0.1, 1.0, 10
    h = length / n
    expected, p = [], x0 + h / 2.0
    for _ in range(n):
        expected.append(p)
        p += h
    got = running_sum_centers(n, x0, length)
    assert_array_equal(got, expected)
    closed = x0 + (np.arange(n) + 0.5) * h
    assert not np.array_equal(got, closed)  # the accumulation is visible in the last bits
    assert_allclose(got, closed, rtol=1e-14)


def test_box_points_gid_order_volume_and_radius():
    params = box(3, 2, 4, lengths=(3.0, 0.5, 2.2), origin=(-1.5, 0.25, 7.0))
    disc = tensor_product_3d(params)
    disc.validate()
    xs = running_sum_centers(3, -1.5, 3.0)
    ys = running_sum_centers(2, 0.25, 0.5)
    zs = running_sum_centers(4, 7.0, 2.2)
    for k, j, i in itertools.product(range(4), range(2), range(3)):
        g = i + 3 * j + 6 * k
        assert_array_equal(disc.x[g], [xs[i], ys[j], zs[k]])
    assert_array_equal(disc.gid, np.arange(24))
    hx, hy, hz = 3.0 / 3, 0.5 / 2, 2.2 / 4
    assert_array_equal(disc.volume, np.full(24, (hx * hy) * hz))
    assert_allclose(disc.volume.sum(), 3.0 * 0.5 * 2.2, rtol=1e-14)
    assert_array_equal(disc.block_id, np.ones(24))
    assert disc.block_names == {1: "block_1"}
    assert disc.node_sets == {}
    assert disc.min_element_radius == math.pow(((0.238732414637843 * hx) * hy) * hz, 0.33333333333333333)
    assert disc.min_element_radius == pytest.approx((3 * hx * hy * hz / (4 * math.pi)) ** (1 / 3), rel=1e-14)


def _teuchos_to_dict(element) -> dict:
    out = {}
    for child in element:
        if child.tag == "ParameterList":
            out[child.get("name")] = _teuchos_to_dict(child)
        else:
            kind, value = child.get("type"), child.get("value")
            out[child.get("name")] = float(value) if kind == "double" else int(value) if kind == "int" else value
    return out


def _deck_discretization(deck: Path) -> dict:
    if deck.suffix == ".xml":
        section = _teuchos_to_dict(ET.parse(deck).getroot())["Discretization"]
    else:
        yaml = pytest.importorskip("yaml")
        top = yaml.safe_load(deck.read_text())
        section = top.get("Peridigm", top)["Discretization"]
    return {k: v for k, v in section.items() if k not in ("Type", "Influence Function")}


@needs_cases
@pytest.mark.parametrize(
    ("case", "deck", "spherical"),
    [
        ("Compression_2x1x1", "Compression_2x1x1.yaml", False),
        ("Compression_QS_3x2x2", "Compression_QS_3x2x2.xml", True),
        ("BondBreakingInitialVelocity", "BondBreakingInitialVelocity.xml", False),
        ("Compression_3x1x1_InfluenceFunction", "Compression_3x1x1_InfluenceFunction.xml", False),
        ("ep_cube", "ep_cube.xml", False),
    ],
)
def test_points_match_peridigm_gold(case, deck, spherical):
    netCDF4 = pytest.importorskip("netCDF4")
    params = PdQuickGridParams.model_validate(_deck_discretization(CASES / case / deck))
    assert params.spherical is spherical
    disc = PdQuickGrid(params, deck_dir=CASES / case).read()
    ds = netCDF4.Dataset(next((CASES / case).glob("*_gold.e")))
    ds.set_auto_mask(False)
    x_gold = np.stack([ds["coordx"][:], ds["coordy"][:], ds["coordz"][:]], axis=1)
    assert_array_equal(disc.x, x_gold)
    assert_array_equal(ds["node_num_map"][:], disc.gid + 1)
    ds.close()


@needs_cases
def test_neighbor_count_matches_gold_thermal_expansion():
    """2x2x1 box, hx = 1.05, hy = 1, horizon 0.51: n_x = 0, n_y = 1 -> one neighbor each."""
    netCDF4 = pytest.importorskip("netCDF4")
    case = CASES / "ThermalExpansionBondFailure"
    params = PdQuickGridParams.model_validate(_deck_discretization(case / "ThermalExpansionBondFailure.xml"))
    disc = PdQuickGrid(params, deck_dir=case).read()
    offsets, neighbors = disc.neighbor_rule(disc.gid, np.full(disc.num_points, 0.51))
    ds = netCDF4.Dataset(case / "ThermalExpansionBondFailure_gold.e")
    ds.set_auto_mask(False)
    names = [b"".join(r).split(b"\0")[0].decode() for r in ds["name_elem_var"][:]]
    count = ds[f"vals_elem_var{names.index('Number_Of_Neighbors') + 1}eb1"][0]
    points = ds["connect1"][:].ravel() - 1
    assert_array_equal(np.diff(offsets)[points], count)
    assert_array_equal(neighbors, [2, 3, 0, 1])
    ds.close()


# ------------------------------------------------------------------------------------------------
# Neighbor rules against brute force
# ------------------------------------------------------------------------------------------------
def brute_box(shape, n):
    nx, ny, nz = shape
    ijk = [(g % nx, (g // nx) % ny, g // (nx * ny)) for g in range(nx * ny * nz)]
    out = []
    for p, (i, j, k) in enumerate(ijk):
        out.append([q for q, (a, b, c) in enumerate(ijk)
                    if q != p and abs(a - i) <= n[0] and abs(b - j) <= n[1] and abs(c - k) <= n[2]])
    return out


@pytest.mark.parametrize(
    ("shape", "lengths", "delta"),
    [
        ((5, 4, 3), (5.0, 2.0, 6.0), 1.5),  # n = (2 (exact half rounds up), 3 capped, 1)
        ((5, 4, 3), (5.0, 2.0, 6.0), 1.49),
        ((6, 1, 2), (1.2, 0.2, 0.4), 10.0),  # horizon larger than the box: capped at the cell count
        ((4, 4, 4), (1.0, 1.0, 1.0), 0.1),  # below half a cell: no neighbors
    ],
)
def test_box_rule_is_the_clipped_box(shape, lengths, delta):
    disc = tensor_product_3d(box(*shape, lengths=lengths))
    h = [L / n for L, n in zip(lengths, shape)]
    n = [min(half_up(delta / hh), nn) for hh, nn in zip(h, shape)]
    assert disc.neighbor_rule.sizes(delta) == tuple(n)
    offsets, neighbors = disc.neighbor_rule(disc.gid, np.full(disc.num_points, delta))
    assert offsets.dtype == np.int64 and neighbors.dtype == np.int32
    got = lists(offsets, neighbors)
    expected = brute_box(shape, n)
    assert len(got) == len(expected)
    for g, e in zip(got, expected):
        assert_array_equal(g, e)


def test_cell_neighborhood_size_rounds_half_up_and_caps():
    assert cell_neighborhood_size(1.5, 1.0, 10) == 2
    assert cell_neighborhood_size(1.4999, 1.0, 10) == 1
    assert cell_neighborhood_size(3.015, 1.0, 10) == 3
    assert cell_neighborhood_size(7.0, 1.0, 4) == 4
    assert cell_neighborhood_size(0.375, 0.125, 10, ring_radius=2.0) == 2  # 0.375/(0.125*2) = 1.5
    assert cell_neighborhood_size(0.3749, 0.125, 10, ring_radius=2.0) == 1


@pytest.mark.parametrize("delta", [2.0, 1.5, 2.4, 1.0])
def test_spherical_rule_is_strictly_inside_the_horizon(delta):
    shape = (6, 5, 4)
    disc = tensor_product_3d(box(*shape, lengths=shape), spherical=True)  # unit cells at half-integers
    x = disc.x
    offsets, neighbors = disc.neighbor_rule(disc.gid, np.full(disc.num_points, delta))
    got = lists(offsets, neighbors)
    for p in range(disc.num_points):
        d = x[p] - x
        d2 = (d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2]
        expected = np.flatnonzero(d2 - delta * delta < 0.0)
        assert_array_equal(got[p], expected[expected != p])
    if delta == 2.0:  # points at exactly the horizon are excluded
        assert 2 not in got[0] and 1 in got[0]
        assert 12 not in got[0]  # (0, 2, 0): distance exactly 2


def test_spherical_excludes_box_corners_box_keeps_them():
    params = box(7, 7, 7, lengths=(7.0, 7.0, 7.0))
    centre = 3 + 7 * 3 + 49 * 3
    corner = 0
    delta = np.full(343, 3.0)
    off_b, nb_b = tensor_product_3d(params).neighbor_rule(np.array([centre]), delta)
    off_s, nb_s = tensor_product_3d(params, spherical=True).neighbor_rule(np.array([centre]), delta)
    assert corner in nb_b and corner not in nb_s
    assert off_b[-1] == 342


def test_subset_of_points_matches_the_full_lists():
    disc = tensor_product_3d(box(5, 4, 3, lengths=(1.0, 0.8, 0.6)), spherical=True)
    horizon = np.full(disc.num_points, 0.41)
    full = lists(*disc.neighbor_rule(disc.gid, horizon))
    points = np.array([17, 0, 59, 17, 30])
    part = lists(*disc.neighbor_rule(points, horizon))
    for p, got in zip(points, part):
        assert_array_equal(got, full[p])


def test_rule_requires_one_positive_horizon():
    disc = tensor_product_3d(box(3, 3, 3))
    horizon = np.full(27, 0.5)
    horizon[4] = 0.6
    with pytest.raises(InputError, match="constant horizon"):
        disc.neighbor_rule(disc.gid, horizon)
    with pytest.raises(InputError, match="positive"):
        disc.neighbor_rule(disc.gid, np.zeros(27))


def test_box_rule_64000_point_counts():
    disc = tensor_product_3d(box(40, 40, 40))
    horizon = np.full(disc.num_points, 3.015 / 40)
    offsets, neighbors = disc.neighbor_rule(disc.gid, horizon)
    per_axis = np.array([min(i, 3) + min(39 - i, 3) + 1 for i in range(40)])
    assert offsets[-1] == per_axis.sum() ** 3 - 64000
    assert np.diff(offsets).max() == 7**3 - 1


# ------------------------------------------------------------------------------------------------
# Cylinder
# ------------------------------------------------------------------------------------------------
def test_cylinder_users_guide_ring():
    params = cylinder()
    nr, num_rays, nz, dr, dtheta, dz, mean_radius = cylinder_layout(params)
    # 2 pi R / dr rays (R = 0.0225, dr = 0.001), and nz = int(L/dr) + 1 with dr a hair above 1e-3
    assert (nr, num_rays, nz) == (5, 142, 100)
    disc = tensor_product_cylinder(params)
    disc.validate()
    assert disc.num_points == 5 * 142 * 100
    annulus = math.pi * (0.025**2 - 0.020**2) * 0.100
    assert_allclose(disc.volume.sum(), annulus, rtol=1e-12)
    r = np.hypot(disc.x[:, 0], disc.x[:, 1])
    assert r.min() > 0.020 and r.max() < 0.025
    assert disc.x[:, 2].min() > 0.0 and disc.x[:, 2].max() < 0.100
    # GID = ir + jt nr + kz nr numRays: radius fastest
    radii = running_sum_centers(5, 0.020, 0.005)
    thetas = running_sum_centers(142, 0.0, 2 * math.pi)
    zs = running_sum_centers(100, 0.0, 0.100)
    for g in (0, 3, 5 * 7 + 2, 5 * 142 * 37 + 5 * 141 + 4):
        i, j, k = g % 5, (g // 5) % 142, g // (5 * 142)
        assert_array_equal(disc.x[g], [radii[i] * math.cos(thetas[j]), radii[i] * math.sin(thetas[j]), zs[k]])
        assert disc.volume[g] == ((radii[i] * dr) * dtheta) * dz
    assert disc.min_element_radius == pytest.approx((3 * disc.volume.min() / (4 * math.pi)) ** (1 / 3), rel=1e-14)


def brute_cylinder(shape, n):
    nr, nrays, nz = shape
    out = []
    for p in range(nr * nrays * nz):
        i, j, k = p % nr, (p // nr) % nrays, p // (nr * nrays)
        found = []
        for q in range(nr * nrays * nz):
            a, b, c = q % nr, (q // nr) % nrays, q // (nr * nrays)
            ring = min((b - j) % nrays, (j - b) % nrays)
            if q != p and abs(a - i) <= n[0] and ring <= n[1] and abs(c - k) <= n[2]:
                found.append(q)
        out.append(found)
    return out


@pytest.mark.parametrize(("delta", "spherical"), [(0.0021, False), (0.0021, True), (0.0035, True), (0.5, False)])
def test_cylinder_rule_window_wraps_and_is_symmetric(delta, spherical):
    params = cylinder(ri=0.004, ro=0.006, length=0.004, nr=2)  # 2 x 32 x 5 cells
    disc = tensor_product_cylinder(params, spherical=spherical)
    rule = disc.neighbor_rule
    n = rule.sizes(delta)
    offsets, neighbors = rule(disc.gid, np.full(disc.num_points, delta))
    got = lists(offsets, neighbors)
    expected = brute_cylinder(rule.shape, n)
    x = disc.x
    pairs = set()
    for p, (g, e) in enumerate(zip(got, expected)):
        assert np.all(np.diff(g) > 0), "lists must be ascending without duplicates"
        if spherical:
            d = x[p] - x[e]
            d2 = (d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2]
            e = np.asarray(e)[d2 - delta * delta < 0.0]
        assert_array_equal(g, e)
        pairs.update((p, int(q)) for q in g)
    assert all((q, p) in pairs for p, q in pairs)
    # point 0 (ray 0) sees the last rays through the wrap-around
    nr, nrays, _ = rule.shape
    assert any((q // nr) % nrays == nrays - 1 for q in got[0])


# ------------------------------------------------------------------------------------------------
# Parameters and reader
# ------------------------------------------------------------------------------------------------
def test_params_neighborhood_type_and_generators():
    sub = {"X Origin": 0.0, "Y Origin": 0.0, "Z Origin": 0.0, "X Length": 1.0, "Y Length": 1.0, "Z Length": 1.0,
           "Number Points X": 2, "Number Points Y": 2, "Number Points Z": 2}
    def spherical(kind):
        given = {} if kind is None else {"NeighborhoodType": kind}
        return PdQuickGridParams.model_validate({**given, "TensorProduct3DMeshGenerator": sub}).spherical

    assert spherical("Spherical")
    # absent, or anything but exactly "Spherical", is a box, as in Peridigm
    assert not spherical(None)
    assert not spherical("spherical")
    assert not spherical("Box")
    cyl = {"Inner Radius": 1.0, "Outer Radius": 2.0, "Cylinder Length": 1.0, "Number Points Radius": 2, "Z Origin": 0.0}
    with pytest.raises(ValidationError, match="exactly one"):
        PdQuickGridParams.model_validate({})
    with pytest.raises(ValidationError, match="exactly one"):
        PdQuickGridParams.model_validate(
            {"TensorProduct3DMeshGenerator": sub, "TensorProductCylinderMeshGenerator": cyl}
        )
    with pytest.raises(ValidationError):
        PdQuickGridParams.model_validate({"TensorProduct3DMeshGenerator": {**sub, "Number Points X": 0}})
    with pytest.raises(ValidationError):
        PdQuickGridParams.model_validate({"TensorProduct3DMeshGenerator": {**sub, "Bogus": 1}})
    with pytest.raises(ValidationError):
        PdQuickGridParams.model_validate({"TensorProduct3DMeshGenerator": sub, "Bond Filters": {}})
    with pytest.raises(ValidationError, match="Outer Radius"):
        PdQuickGridParams.model_validate({"TensorProductCylinderMeshGenerator": {**cyl, "Outer Radius": 0.5}})
    p = PdQuickGridParams.model_validate({"TensorProductCylinderMeshGenerator": cyl})
    disc = PdQuickGrid(p, deck_dir=Path(".")).read()
    nr, num_rays, nz = cylinder_layout(p.tensor_product_cylinder)[:3]
    assert disc.num_points == nr * num_rays * nz
    assert PdQuickGrid.name == "PdQuickGrid" and PdQuickGrid.supports_bond_filters is False


@pytest.mark.parametrize("shape, window", [((5, 40, 6), (2, 3, 2)), ((4, 9, 3), (1, 4, 1)), ((3, 10, 3), (1, 5, 1)), ((2, 7, 2), (1, 1, 1))])
@pytest.mark.parametrize("spherical", [True, False])
def test_the_ring_window_is_every_cell_within_circular_distance_in_ascending_id(shape, window, spherical):
    from peridyn.io.quickgrid import _grid_neighbors

    n0, n1, n2 = shape
    w0, w1, w2 = window
    n = n0 * n1 * n2
    x = np.random.default_rng(1).random((n, 3))
    points = np.arange(n, dtype=np.int64)
    empty = np.zeros(1, dtype=np.int64)
    counts = _grid_neighbors(points, x, n0, n1, n2, w0, w1, w2, True, spherical, 0.7, empty, empty, False)
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    got = np.zeros(offsets[-1], dtype=np.int64)
    _grid_neighbors(points, x, n0, n1, n2, w0, w1, w2, True, spherical, 0.7, offsets, got, True)
    for p in range(n):
        i, j, k = p % n0, (p // n0) % n1, p // (n0 * n1)
        want = []
        for g in range(n):
            gi, gj, gk = g % n0, (g // n0) % n1, g // (n0 * n1)
            dj = abs(gj - j)
            if g == p or abs(gi - i) > w0 or abs(gk - k) > w2 or min(dj, n1 - dj) > w1:
                continue
            d = x[p] - x[g]
            if spherical and not ((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2]) - 0.7 * 0.7 < 0.0:
                continue
            want.append(g)
        assert got[offsets[p]:offsets[p + 1]].tolist() == want
