"""Bond filters (peridyn.geometry.bond_filters): Peridigm's exact tests, deck validation, and the
neighbor counts of Peridigm's bond-filter conformance cases."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import netCDF4
import numpy as np
import pytest

from peridyn.geometry.bond_filters import (
    DiskFilter,
    ExodusMeshFilter,
    RectangularPlaneFilter,
    apply_bond_filters,
    flag_bonds,
    make_filter,
    make_filters,
)
from peridyn.geometry.neighbors import radius_search
from peridyn.core.errors import InputError

SHARED = Path(__file__).resolve().parents[3] / ".." / "shared"
CASES = SHARED.resolve() / "conformance" / "cases"

PLANE = {
    "Type": "Rectangular_Plane",
    "Normal_X": 0.0, "Normal_Y": 1.0, "Normal_Z": 0.0,
    "Lower_Left_Corner_X": 0.0, "Lower_Left_Corner_Y": 0.0, "Lower_Left_Corner_Z": 0.0,
    "Bottom_Unit_Vector_X": 1.0, "Bottom_Unit_Vector_Y": 0.0, "Bottom_Unit_Vector_Z": 0.0,
    "Bottom_Length": 2.0, "Side_Length": 1.0,
}  # rectangle 0 <= x <= 2 (bottom, u_b = e_x), 0 <= z <= 1 (side, u_a = u_b x n = e_z), y = 0

DISK = {
    "Type": "Disk", "Center_X": 0.0, "Center_Y": 0.0, "Center_Z": 0.0,
    "Normal_X": 0.0, "Normal_Y": 1.0, "Normal_Z": 0.0, "Radius": 1.0,
}


def seg(*pairs):
    p = np.array(pairs, dtype=float)
    return p[:, 0, :], p[:, 1, :]


def cuts(f, *pairs):
    return f.cuts(*seg(*pairs)).tolist()


# ------------------------------------------------------------------------------------------------
# Rectangular_Plane
# ------------------------------------------------------------------------------------------------
def test_plane_hits_misses_and_edges():
    f = make_filter(PLANE, deck_dir=Path("."), path=("F",))
    assert isinstance(f, RectangularPlaneFilter)
    assert np.array_equal(f.ua, [0.0, 0.0, 1.0])
    y = [-0.5, 0.5]
    assert cuts(
        f,
        [[1.0, y[0], 0.5], [1.0, y[1], 0.5]],  # through the middle
        [[1.0, y[1], 0.5], [1.0, y[0], 0.5]],  # other direction
        [[3.0, y[0], 0.5], [3.0, y[1], 0.5]],  # beyond the bottom length
        [[1.0, y[0], 1.5], [1.0, y[1], 1.5]],  # beyond the side length
        [[1.0, 0.1, 0.5], [1.0, 0.9, 0.5]],  # does not reach the plane
        [[0.0, y[0], 0.0], [0.0, y[1], 0.0]],  # exactly through the corner: -tol < 0
        [[2.0, y[0], 1.0], [2.0, y[1], 1.0]],  # exactly through the far corner: 1 < 1 + 1e-15
        [[1.0, 0.0, 0.5], [1.0, 1.0, 0.5]],  # starts on the plane: t = 0
        [[1.0, -1.0, 0.5], [1.0, 0.0, 0.5]],  # ends on the plane: t = 1
        [[0.5, 0.0, 0.5], [1.5, 0.0, 0.5]],  # lies in the plane: parallel, never cut
        [[0.5, -1.0, 0.5], [1.5, -1.0, 0.5]],  # parallel, off the plane
    ) == [True, True, False, False, False, True, True, True, True, False, False]


def test_plane_tolerances():
    f = make_filter(PLANE, deck_dir=Path("."))
    # edge slack: aa > -1e-15 and bb/b < 1 + 1e-15
    assert cuts(f, [[1.0, -1, -0.5e-15], [1.0, 1, -0.5e-15]]) == [True]
    assert cuts(f, [[1.0, -1, -2e-15], [1.0, 1, -2e-15]]) == [False]
    assert cuts(f, [[2.0 * (1 + 4e-16), -1, 0.5], [2.0 * (1 + 4e-16), 1, 0.5]]) == [True]
    assert cuts(f, [[2.0 * (1 + 4e-15), -1, 0.5], [2.0 * (1 + 4e-15), 1, 0.5]]) == [False]
    # parallel tolerance |den| < 1e-14: a start point on the plane is cut only if den >= 1e-14
    assert cuts(f, [[1.0, 0.0, 0.5], [1.1, 0.5e-14, 0.5]]) == [False]
    assert cuts(f, [[1.0, 0.0, 0.5], [1.1, 2e-14, 0.5]]) == [True]


def test_plane_normal_not_normalized():
    # Peridigm uses the deck's vectors as given: a normal of length 2 scales u_a by 2
    f = make_filter({**PLANE, "Normal_Y": 2.0}, deck_dir=Path("."))
    assert np.array_equal(f.ua, [0.0, 0.0, 2.0])
    assert cuts(f, [[1.0, -1, 0.4], [1.0, 1, 0.4]], [[1.0, -1, 0.6], [1.0, 1, 0.6]]) == [True, False]


# ------------------------------------------------------------------------------------------------
# Disk
# ------------------------------------------------------------------------------------------------
def test_disk():
    f = make_filter(DISK, deck_dir=Path("."))
    assert isinstance(f, DiskFilter)
    assert cuts(
        f,
        [[0.5, -1, 0.0], [0.5, 1, 0.0]],
        [[0.0, -1, 0.99], [0.0, 1, 0.99]],
        [[0.0, -1, 1.0], [0.0, 1, 1.0]],  # exactly at the radius: strict, not cut
        [[1.5, -1, 0.0], [1.5, 1, 0.0]],
        [[0.5, 0.1, 0.0], [0.5, 1, 0.0]],  # does not reach
        [[0.5, 0.0, 0.0], [0.5, 1, 0.0]],  # t = 0
        [[-0.5, 0.0, 0.0], [0.5, 0.0, 0.0]],  # in the plane: parallel
        [[0.5, 0.0, 0.0], [0.6, 0.5e-15, 0.0]],  # |den| < 1e-15
        [[0.5, 0.0, 0.0], [0.6, 2e-15, 0.0]],
        [[0.5, -1.0, 0.0], [0.3, 3.0, 0.1]],  # oblique
    ) == [True, True, False, False, False, True, False, False, True, True]


# ------------------------------------------------------------------------------------------------
# Exodus Mesh
# ------------------------------------------------------------------------------------------------
def write_exodus(path: Path, coords: np.ndarray, blocks: list[tuple[str, np.ndarray]], num_dim: int = 3) -> Path:
    """A minimal Exodus II file: node coordinates and element blocks (1-based connectivity)."""
    with netCDF4.Dataset(path, "w", format="NETCDF3_64BIT_OFFSET") as d:
        d.createDimension("len_string", 33)
        d.createDimension("num_dim", num_dim)
        d.createDimension("num_nodes", coords.shape[0])
        d.createDimension("num_elem", sum(c.shape[0] for _, c in blocks))
        d.createDimension("num_el_blk", len(blocks))
        for name, c in zip("xyz"[:num_dim], coords.T[:num_dim]):
            v = d.createVariable(f"coord{name}", "f8", ("num_nodes",))
            v[:] = c
        ids = d.createVariable("eb_prop1", "i4", ("num_el_blk",))
        ids[:] = np.arange(1, len(blocks) + 1) * 10
        for k, (etype, conn) in enumerate(blocks, start=1):
            d.createDimension(f"num_el_in_blk{k}", conn.shape[0])
            d.createDimension(f"num_nod_per_el{k}", conn.shape[1])
            v = d.createVariable(f"connect{k}", "i4", (f"num_el_in_blk{k}", f"num_nod_per_el{k}"))
            v.elem_type = etype
            v[:] = conn
    return path


UNIT_SQUARE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)  # z = 0


def mesh_filter(tmp_path, blocks, coords=UNIT_SQUARE, *, initial_damage=False, name="m.g"):
    write_exodus(tmp_path / name, coords, blocks)
    return make_filter({"Type": "Exodus Mesh", "File Name": name}, deck_dir=tmp_path, path=("F",),
                       for_initial_damage=initial_damage)


def test_triangle(tmp_path):
    f = mesh_filter(tmp_path, [("TRI3", np.array([[1, 2, 4]]))])  # (0,0) (1,0) (0,1)
    assert isinstance(f, ExodusMeshFilter) and f.num_polygons == 1
    assert cuts(
        f,
        [[0.2, 0.2, -1], [0.2, 0.2, 1]],  # inside
        [[0.6, 0.6, -1], [0.6, 0.6, 1]],  # beyond the hypotenuse
        [[0.5, 0.5, -1], [0.5, 0.5, 1]],  # on the hypotenuse: alpha + beta = 1 < 1 + 2e-14
        [[0.0, 0.5, -1], [0.0, 0.5, 1]],  # on an edge: alpha = 0 > -1e-14
        [[-1e-13, 0.5, -1], [-1e-13, 0.5, 1]],  # just outside the edge
        [[0.2, 0.2, 0.5], [0.2, 0.2, 1]],  # does not reach
        [[0.2, 0.2, 0.0], [0.3, 0.2, 0.0]],  # in the plane: parallel
        [[0.2, 0.2, 0.0], [0.2, 0.2, 1]],  # t = 0
    ) == [True, False, True, True, False, False, False, True]


def test_quad_and_initial_damage_triangles(tmp_path):
    blocks = [("QUAD4", np.array([[1, 2, 3, 4]]))]
    f = mesh_filter(tmp_path, blocks)
    lower = [[0.7, 0.2, -1], [0.7, 0.2, 1]]  # in triangle (v1, v2, v3)
    upper = [[0.2, 0.7, -1], [0.2, 0.7, 1]]  # in triangle (v1, v3, v4) only
    outside = [[1.2, 0.5, -1], [1.2, 0.5, 1]]
    assert cuts(f, lower, upper, outside) == [True, True, False]
    # Initial Damage: every polygon is the triangle of its first three vertices
    g = mesh_filter(tmp_path, blocks, initial_damage=True, name="m2.g")
    assert cuts(g, lower, upper, outside) == [True, False, False]


def test_mesh_file_errors(tmp_path):
    write_exodus(tmp_path / "hex.g", np.zeros((8, 3)), [("HEX8", np.arange(1, 9)[None, :])])
    with pytest.raises(InputError, match="HEX8"):
        make_filter({"Type": "Exodus Mesh", "File Name": "hex.g"}, deck_dir=tmp_path, path=("D", "BF", "F"))
    with pytest.raises(InputError, match="not found") as e:
        make_filter({"Type": "Exodus Mesh", "File Name": "nope.g"}, deck_dir=tmp_path, path=("D", "BF", "F"))
    assert e.value.path == ("D", "BF", "F", "File Name")
    write_exodus(tmp_path / "tri6.g", np.zeros((6, 3)), [("TRI", np.arange(1, 7)[None, :])])
    with pytest.raises(InputError, match="6 nodes"):
        make_filter({"Type": "Exodus Mesh", "File Name": "tri6.g"}, deck_dir=tmp_path)
    (tmp_path / "junk.g").write_text("not netcdf")
    with pytest.raises(InputError):
        make_filter({"Type": "Exodus Mesh", "File Name": "junk.g"}, deck_dir=tmp_path)


def test_two_dimensional_mesh(tmp_path):
    # a 2-D Exodus file (no coordz): polygons lie in z = 0
    f = mesh_filter(tmp_path, [("TRIANGLE", np.array([[1, 2, 4]]))], name="m.g")
    write_exodus(tmp_path / "m2d.g", UNIT_SQUARE, [("tri", np.array([[1, 2, 4]]))], num_dim=2)
    g = make_filter({"Type": "Exodus Mesh", "File Name": "m2d.g"}, deck_dir=tmp_path)
    np.testing.assert_array_equal(f.V, g.V)


def reference_polygon_cut(v, p0, p1, tol=1e-14):
    """Peridigm's Triangle/QuadFilter in plain Python floats (same operation order)."""
    v1, v2, v3 = v[0], v[1], v[2]
    w = v[3] if len(v) == 4 else v3
    a = [v2[i] - v1[i] for i in range(3)]
    b = [w[i] - v1[i] for i in range(3)]
    n = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    mag = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) ** 0.5
    n = [c / mag for c in n]
    num = (v1[0] - p0[0]) * n[0] + (v1[1] - p0[1]) * n[1] + (v1[2] - p0[2]) * n[2]
    den = (p1[0] - p0[0]) * n[0] + (p1[1] - p0[1]) * n[1] + (p1[2] - p0[2]) * n[2]
    if abs(den) < tol:
        return False
    t = num / den
    if t < 0.0 or t > 1.0:
        return False
    x = [p0[i] + t * (p1[i] - p0[i]) for i in range(3)]

    def inside(A, B, C):
        d00 = A[0] * A[0] + A[1] * A[1] + A[2] * A[2]
        d01 = A[0] * B[0] + A[1] * B[1] + A[2] * B[2]
        d02 = A[0] * C[0] + A[1] * C[1] + A[2] * C[2]
        d11 = B[0] * B[0] + B[1] * B[1] + B[2] * B[2]
        d12 = B[0] * C[0] + B[1] * C[1] + B[2] * C[2]
        al = (d11 * d02 - d01 * d12) / (d00 * d11 - d01 * d01)
        be = (d00 * d12 - d01 * d02) / (d00 * d11 - d01 * d01)
        return al > -tol and be > -tol and al + be < 1.0 + 2.0 * tol

    A = [v3[i] - v1[i] for i in range(3)]
    C = [x[i] - v1[i] for i in range(3)]
    if inside(A, [v2[i] - v1[i] for i in range(3)], C):
        return True
    return len(v) == 4 and inside(A, [v[3][i] - v1[i] for i in range(3)], C)


def test_mesh_grid_matches_reference(tmp_path):
    # a wavy surface of quads and triangles; random bonds; the grid-accelerated kernel must agree
    # with a plain loop over every polygon
    rng = np.random.default_rng(4)
    m = 8
    u = np.linspace(0.0, 1.0, m + 1)
    X, Y = np.meshgrid(u, u, indexing="ij")
    Z = 0.1 * np.sin(3 * X) * np.cos(2 * Y) + 0.5
    coords = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    node = lambda i, j: i * (m + 1) + j + 1  # noqa: E731
    quads = np.array([[node(i, j), node(i + 1, j), node(i + 1, j + 1), node(i, j + 1)]
                      for i in range(m // 2) for j in range(m)])
    tris = np.array([t for i in range(m // 2, m) for j in range(m)
                     for t in ([node(i, j), node(i + 1, j), node(i + 1, j + 1)],
                               [node(i, j), node(i + 1, j + 1), node(i, j + 1)])])
    f = mesh_filter(tmp_path, [("QUAD", quads), ("TRI3", tris)], coords=coords)
    p0 = rng.random((3000, 3)) * [1.2, 1.2, 1.0] - [0.1, 0.1, 0.0]
    p1 = p0 + rng.normal(scale=0.15, size=p0.shape)
    # include bonds through vertices and along shared edges
    p0[:50] = coords[rng.integers(0, len(coords), 50)] + [0, 0, -0.2]
    p1[:50] = p0[:50] + [0, 0, 0.4]
    got = f.cuts(p0, p1)
    polys = [coords[q - 1] for q in quads] + [coords[t - 1] for t in tris]
    ref = np.array([any(reference_polygon_cut(v.tolist(), a.tolist(), b.tolist()) for v in polys)
                    for a, b in zip(p0, p1)])
    np.testing.assert_array_equal(got, ref)
    assert 100 < ref.sum() < 2900


# ------------------------------------------------------------------------------------------------
# CSR application
# ------------------------------------------------------------------------------------------------
def test_apply_and_flag_on_neighbor_lists():
    g = np.arange(6, dtype=float) - 2.5
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3) * 0.5
    off, nb = radius_search(x, np.full(len(x), 1.01), dtype=np.int32)
    f = make_filter({**PLANE, "Lower_Left_Corner_X": -5.0, "Lower_Left_Corner_Z": -5.0,
                     "Bottom_Length": 10.0, "Side_Length": 10.0}, deck_dir=Path("."))
    o2, n2 = apply_bond_filters(x, off, nb, [f])
    assert n2.dtype == np.int32
    src = np.repeat(np.arange(len(x)), np.diff(off))
    crossing = np.sign(x[src, 1]) != np.sign(x[nb, 1])  # y = 0 separates the halves
    assert np.array_equal(np.diff(o2), np.diff(off) - np.bincount(src[crossing], minlength=len(x)))
    d = flag_bonds(x, off, nb, [f])
    assert d.dtype == np.float64 and np.array_equal(d == 1.0, crossing)
    # rows: a subset of points as CSR rows
    pts = np.array([0, 100, 215])
    o3, n3 = radius_search(x, np.full(len(x), 1.01), pts, dtype=np.int32)
    o4, n4 = apply_bond_filters(x, o3, n3, [f], rows=pts)
    for r, p in enumerate(pts):
        assert n4[o4[r]:o4[r + 1]].tolist() == n2[o2[p]:o2[p + 1]].tolist()
    # no filters: unchanged
    o5, n5 = apply_bond_filters(x, off, nb, [])
    assert n5 is nb or np.array_equal(n5, nb)


# ------------------------------------------------------------------------------------------------
# Deck validation
# ------------------------------------------------------------------------------------------------
def test_deck_errors(tmp_path):
    with pytest.raises(InputError, match="Disk") as e:
        make_filter({**DISK, "Type": "Disc"}, deck_dir=tmp_path, path=("Discretization", "Bond Filters", "F"))
    assert e.value.path[-1] == "Type"
    with pytest.raises(InputError, match="Initial Damage"):
        make_filter(DISK, deck_dir=tmp_path, for_initial_damage=True)
    with pytest.raises(InputError, match="Normal_X"):
        make_filter({**DISK, "Normal_x": 1.0}, deck_dir=tmp_path)  # unknown key, close match
    bad = dict(PLANE)
    del bad["Side_Length"]
    with pytest.raises(InputError) as e:
        make_filter(bad, deck_dir=tmp_path, path=("BF", "P"))
    assert e.value.path == ("BF", "P", "Side_Length")
    with pytest.raises(InputError, match="zero vector"):
        make_filter({**DISK, "Normal_Y": 0.0}, deck_dir=tmp_path)
    with pytest.raises(InputError):
        make_filter({**DISK, "Radius": -1.0}, deck_dir=tmp_path)
    with pytest.raises(InputError, match="Type"):
        make_filter({"Radius": 1.0}, deck_dir=tmp_path)
    # errors of several filters are collected
    with pytest.raises(InputError) as e:
        make_filters({"A": {**DISK, "Radius": "x"}, "B": {"Type": "Plane"}}, deck_dir=tmp_path, path=("BF",))
    text = str(e.value)
    assert "BF > A > Radius" in text and "BF > B > Type" in text
    fs = make_filters({"A": DISK, "B": PLANE}, deck_dir=tmp_path)
    assert [type(f) for f in fs] == [DiskFilter, RectangularPlaneFilter]


# ------------------------------------------------------------------------------------------------
# Conformance: Number_Of_Neighbors (and Initial Damage's Damage) of Peridigm's gold files
# ------------------------------------------------------------------------------------------------
def _xml_to_dict(el):
    out = {}
    for ch in el:
        if ch.tag == "ParameterList":
            out[ch.get("name")] = _xml_to_dict(ch)
        elif ch.tag == "Parameter":
            t, v = ch.get("type"), ch.get("value")
            out[ch.get("name")] = float(v) if t == "double" else int(v) if t == "int" else v
    return out


def _read_deck(path: Path) -> dict:
    if path.suffix == ".xml":
        return _xml_to_dict(ET.parse(path).getroot())
    import yaml

    d = yaml.safe_load(path.read_text())
    return d.get("Peridigm", d)


def _read_gold(path: Path):
    """Point coordinates (per element, via the connectivity) and step-0 element variables."""
    with netCDF4.Dataset(path) as d:
        d.set_auto_mask(False)
        x = np.stack([d["coordx"][:], d["coordy"][:], d["coordz"][:]], axis=1)
        conn = np.asarray(d["connect1"][:]).ravel() - 1
        names = [str(s) for s in netCDF4.chartostring(d["name_elem_var"][:])]
        values = {n: np.asarray(d[f"vals_elem_var{k + 1}eb1"][0]) for k, n in enumerate(names)}
    return x[conn], values


@pytest.mark.conformance
@pytest.mark.parametrize("case, deck", [
    ("TriBondFilter", "TriBondFilter.yaml"),
    ("DiskFilter", "DiskFilter.xml"),
    ("PrecrackedPlate", "PrecrackedPlate.xml"),
    ("InitialDamage", "InitialDamage.xml"),
])
def test_conformance_neighbor_counts(case, deck):
    folder = CASES / case
    if not folder.is_dir():
        pytest.skip("conformance cases (../shared) not available")
    d = _read_deck(folder / deck)
    (block,) = d["Blocks"].values()
    x, gold = _read_gold(folder / f"{case}_gold.e")
    off, nb = radius_search(x, np.full(len(x), float(block["Horizon"])), dtype=np.int32)
    section = d["Discretization"].get("Bond Filters")
    if section:
        filters = make_filters(section, deck_dir=folder, path=("Discretization", "Bond Filters"))
        off, nb = apply_bond_filters(x, off, nb, filters)
    counts = np.diff(off)
    np.testing.assert_array_equal(counts, gold["Number_Of_Neighbors"])
    if "Damage Models" in d:
        name, model = next(iter(d["Damage Models"].items()))
        filters = make_filters(model["Bond Filters"], deck_dir=folder,
                               path=("Damage Models", name, "Bond Filters"), for_initial_damage=True)
        broken = flag_bonds(x, off, nb, filters)
        damage = np.array([broken[off[i]:off[i + 1]].sum() / counts[i] for i in range(len(x))])
        assert broken.sum() > 0
        np.testing.assert_array_equal(damage, gold["Damage"])
