"""The elements of an Exodus II mesh as peridynamic points, one per element: centroids and
volumes with Peridigm's floating-point operation order (``Peridigm_GeometryUtils.cpp``), global
ids, blocks and node sets (see :mod:`peridyn.io.exodus_mesh` for the rules), read from an open
netCDF dataset: the whole mesh, or one piece of a pre-split mesh (:mod:`peridyn.io.exodus_pieces`).
"""
from __future__ import annotations

import numpy as np

from ..core.discretization import Discretization
from ..core.errors import InputError
from .textfile import min_element_radius


SPHERE_TYPES = ("SPHERE",)
TET_TYPES = ("TET", "TETRA", "TET4", "TET10")
HEX_TYPES = ("HEX", "HEX8", "HEX20")
SUPPORTED_ELEMENT_TYPES = SPHERE_TYPES + TET_TYPES + HEX_TYPES

# The 24 tetrahedra (A, B, face center, hex center) of Peridigm's hexCentroidAndVolume, in order.
_HEX_FACES = ((0, 1, 4, 5), (1, 2, 5, 6), (2, 3, 6, 7), (0, 3, 4, 7), (0, 1, 2, 3), (4, 5, 6, 7))
_HEX_TETS = (
    ((1, 0), (5, 1), (4, 5), (0, 4)),  # face 0
    ((2, 1), (6, 2), (5, 6), (1, 5)),  # face 1
    ((3, 2), (7, 3), (6, 7), (2, 6)),  # face 2
    ((0, 3), (3, 7), (7, 4), (4, 0)),  # face 3
    ((0, 1), (1, 2), (2, 3), (3, 0)),  # face 4
    ((5, 4), (4, 7), (7, 6), (6, 5)),  # face 5
)


def _tet_volume(n0: np.ndarray, n1: np.ndarray, n2: np.ndarray, n3: np.ndarray) -> np.ndarray:
    """Signed volume a.(b x c)/6 of tetrahedra; each argument (m, 3), result (m,) (L^3)."""
    a = n1 - n0
    b = n2 - n0
    c = n3 - n0
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    c0, c1, c2 = c[:, 0], c[:, 1], c[:, 2]
    triple = (a0 * (b1 * c2 - b2 * c1) + a1 * (b2 * c0 - b0 * c2)) + a2 * (b0 * c1 - b1 * c0)
    return triple / 6.0


def _tet_centroid(n0: np.ndarray, n1: np.ndarray, n2: np.ndarray, n3: np.ndarray) -> np.ndarray:
    """(((n0 + n1) + n2) + n3) * 0.25; arguments and result (m, 3)."""
    return (((n0 + n1) + n2) + n3) * 0.25


def tet_centroid_and_volume(nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centroids and signed volumes of tetrahedra, as Peridigm computes them.

    Parameters
    ----------
    nodes: (m, k, 3) node coordinates with k >= 4; only the first 4 nodes are used.

    Returns
    -------
    centroid (m, 3), volume (m,) (L^3, negative for inverted elements), and a boolean (m,)
    array that is True where the volume is negative.
    """
    n0, n1, n2, n3 = (np.ascontiguousarray(nodes[:, k, :]) for k in range(4))
    volume = _tet_volume(n0, n1, n2, n3)
    return _tet_centroid(n0, n1, n2, n3), volume, volume < 0.0


def hex_centroid_and_volume(nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centroids and volumes of hexahedra by Peridigm's 24-tetrahedra decomposition.

    Each face center is 0.25 (((a + b) + c) + d), the center is 0.5 (f4 + f5); the volume is the
    sequential sum of the 24 signed tetrahedron volumes and the centroid the sequential sum of
    tetrahedron centroid times volume, divided by the volume. Exact for hexahedra with planar
    faces; for warped faces it is Peridigm's approximation.

    Parameters
    ----------
    nodes: (m, k, 3) node coordinates in Exodus HEX order, k >= 8; only the first 8 are used.

    Returns
    -------
    centroid (m, 3), volume (m,) (L^3), and a boolean (m,) array that is True where one of the
    24 tetrahedra has a negative volume (an inverted or badly numbered element).
    """
    n = [np.ascontiguousarray(nodes[:, k, :]) for k in range(8)]
    faces = [0.25 * (((n[a] + n[b]) + n[c]) + n[d]) for a, b, c, d in _HEX_FACES]
    center = 0.5 * (faces[4] + faces[5])
    m = nodes.shape[0]
    volume = np.zeros(m)
    weighted = np.zeros((m, 3))
    inverted = np.zeros(m, dtype=bool)
    for face, tets in enumerate(_HEX_TETS):
        f = faces[face]
        for a, b in tets:
            tet_v = _tet_volume(n[a], n[b], f, center)
            inverted |= tet_v < 0.0
            volume = volume + tet_v
            weighted = weighted + _tet_centroid(n[a], n[b], f, center) * tet_v[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        centroid = weighted / volume[:, None]
    return centroid, volume, inverted


# ------------------------------------------------------------------------------------------------
# Exodus file access
# ------------------------------------------------------------------------------------------------
def _chars_to_str(row: np.ndarray) -> str:
    """A netCDF char row (|S1 array) -> str without NULs and trailing blanks."""
    raw = b"".join(bytes(c) for c in np.asarray(row).ravel())
    return raw.split(b"\0", 1)[0].decode("utf-8", errors="replace").rstrip()


def _names(ds, var: str, count: int) -> list[str]:
    if var not in ds.variables or count == 0:
        return [""] * count
    data = ds.variables[var][:]
    return [_chars_to_str(data[i]) for i in range(count)]


def _int_var(ds, name: str, default: np.ndarray) -> np.ndarray:
    """An integer variable as int64, or ``default`` when the file does not have it."""
    if name not in ds.variables:
        return default
    return np.asarray(ds.variables[name][:], dtype=np.int64)


def _dim(ds, name: str) -> int:
    return len(ds.dimensions[name]) if name in ds.dimensions else 0


def _coordinates(ds, num_dim: int, num_nodes: int, file: str) -> np.ndarray:
    """(num_nodes, 3) node coordinates; missing dimensions are zero."""
    xyz = np.zeros((num_nodes, 3))
    if num_nodes == 0:
        return xyz
    names = ("coordx", "coordy", "coordz")
    if all(names[d] in ds.variables for d in range(num_dim)):
        for d in range(num_dim):
            xyz[:, d] = np.asarray(ds.variables[names[d]][:], dtype=np.float64)
    elif "coord" in ds.variables:
        coord = np.asarray(ds.variables["coord"][:], dtype=np.float64)
        if coord.shape != (num_dim, num_nodes):
            raise InputError(f"variable 'coord' has shape {coord.shape}, expected {(num_dim, num_nodes)}", file=file)
        xyz[:, :num_dim] = coord.T
    else:
        raise InputError("the file has no node coordinates (coordx/coordy/coordz or coord)", file=file)
    return xyz


def auxiliary_map(ds, kind: str, count: int, file: str) -> np.ndarray | None:
    """The single auxiliary map ``original_global_id_map`` of nodes ("node") or elements."""
    dim, _names_var, var = (("num_node_maps", "nmap_names", "node_map1") if kind == "node" else ("num_elem_maps", "emap_names", "elem_map1"))
    n = _dim(ds, dim)
    if n == 0:
        return None
    if n > 1 or var not in ds.variables:
        raise InputError(f"the file has {n} auxiliary {kind} maps; Peridigm accepts one, named original_global_id_map", file=file)
    ids = np.asarray(ds.variables[var][:], dtype=np.int64)
    if ids.shape != (count,):
        raise InputError(f"auxiliary {kind} map has {ids.size} entries for {count} {kind}s", file=file)
    return ids


def _element_gids(ds, num_elem: int, file: str) -> np.ndarray:
    """0-based element global ids: original_global_id_map, else elem_num_map, else 0..n-1."""
    num_maps = _dim(ds, "num_elem_maps")
    if num_maps > 1:
        raise InputError(
            f"the file has {num_maps} auxiliary element maps; Peridigm accepts at most one, "
            "named original_global_id_map",
            file=file,
        )
    if num_maps == 1:
        name = _names(ds, "emap_names", 1)[0]
        if name != "original_global_id_map":
            raise InputError(
                f"unknown auxiliary element map {name!r}",
                file=file,
                fix="the only auxiliary element map Peridigm understands is original_global_id_map",
            )
        ids = np.asarray(ds.variables["elem_map1"][:], dtype=np.int64)
    elif "elem_num_map" in ds.variables:
        ids = np.asarray(ds.variables["elem_num_map"][:], dtype=np.int64)
    else:
        return np.arange(num_elem, dtype=np.int64)
    if ids.shape != (num_elem,):
        raise InputError(f"element id map has {ids.size} entries for {num_elem} elements", file=file)
    gids = ids - 1
    if num_elem and gids.min() < 0:
        raise InputError("element id map holds an id below 1", file=file)
    if len(np.unique(gids)) != num_elem:
        raise InputError("element id map holds duplicate ids", file=file, fix="element ids must be unique")
    return gids


def read_elements(ds, file: str, *, piece: bool = False) -> tuple[Discretization, list[np.ndarray], int]:  # noqa: C901 - one linear pass over the file
    """(the points of an open Exodus dataset ``ds`` without node sets, the 0-based node numbers
    of every block's elements (count, nodes per element), the number of nodes). ``piece``: one
    rank's piece of a pre-split mesh, which may hold no elements."""
    if "num_dim" not in ds.dimensions:
        raise InputError(
            "not an Exodus II file (no num_dim dimension)",
            file=file,
            fix="give an Exodus II mesh (genesis file, usually .g or .e)",
        )
    num_dim = _dim(ds, "num_dim")
    if not 1 <= num_dim <= 3:
        raise InputError(f"num_dim is {num_dim}; expected 1, 2 or 3", file=file)
    num_nodes = _dim(ds, "num_nodes")
    num_elem = _dim(ds, "num_elem")
    num_blocks = _dim(ds, "num_el_blk")
    coords = _coordinates(ds, num_dim, num_nodes, file)
    gids = _element_gids(ds, num_elem, file)

    block_ids = _int_var(ds, "eb_prop1", np.arange(1, num_blocks + 1))
    if block_ids.shape != (num_blocks,):
        raise InputError("eb_prop1 does not list one id per element block", file=file)
    if len(np.unique(block_ids)) != num_blocks:
        raise InputError("element block ids (eb_prop1) are not unique", file=file)
    block_status = _int_var(ds, "eb_status", np.ones(num_blocks, dtype=np.int64))
    raw_block_names = _names(ds, "eb_names", num_blocks)

    x_parts: list[np.ndarray] = []
    v_parts: list[np.ndarray] = []
    b_parts: list[np.ndarray] = []
    conn_parts: list[np.ndarray] = []  # 0-based node ids of every element, all its nodes
    block_names: dict[int, str] = {}
    seen_names: set[str] = set()
    first_elem = 0
    for index in range(num_blocks):
        k = index + 1
        block_id = int(block_ids[index])
        name = raw_block_names[index] or f"block_{block_id}"
        if name in seen_names:
            raise InputError(
                f"duplicate element block name {name!r}", file=file, fix="give every element block its own name"
            )
        seen_names.add(name)
        block_names[block_id] = name
        count = _dim(ds, f"num_el_in_blk{k}")
        if count == 0 or block_status[index] == 0:
            continue
        var = ds.variables.get(f"connect{k}")
        if var is None:
            raise InputError(f"element block {block_id} has no connectivity (connect{k})", file=file)
        elem_type = str(getattr(var, "elem_type", "")).strip().upper()
        conn = np.asarray(var[:], dtype=np.int64).reshape(count, -1) - 1
        nodes_per_elem = conn.shape[1]
        if conn.size and (conn.min() < 0 or conn.max() >= num_nodes):
            raise InputError(f"element block {block_id} refers to a node outside 1..{num_nodes}", file=file)
        where = f"element block {block_id} ({name!r}, type {elem_type or '?'})"
        if elem_type in SPHERE_TYPES:
            attr = ds.variables.get(f"attrib{k}")
            if attr is None or attr.ndim != 2 or attr.shape[1] < 2:
                raise InputError(
                    f"{where}: SPHERE elements need 2 attributes (radius, volume)",
                    file=file,
                    fix="write the sphere volume as the second element attribute",
                )
            attributes = np.asarray(attr[:], dtype=np.float64)
            x_block = coords[conn[:, 0]]
            v_block = np.ascontiguousarray(attributes[:, 1])
            bad = np.flatnonzero(~(v_block > 0.0) | ~np.isfinite(v_block))
            if bad.size:
                e = int(bad[0])
                raise InputError(
                    f"{where}: element {e + 1} of the block (id {int(gids[first_elem + e]) + 1}) "
                    f"has volume {v_block[e]!r}; volumes must be positive",
                    file=file,
                )
        elif elem_type in TET_TYPES or elem_type in HEX_TYPES:
            needed = 4 if elem_type in TET_TYPES else 8
            if nodes_per_elem < needed:
                raise InputError(f"{where}: {nodes_per_elem} nodes per element, need at least {needed}", file=file)
            node_xyz = coords[conn[:, :needed]]
            if elem_type in TET_TYPES:
                x_block, v_block, inverted = tet_centroid_and_volume(node_xyz)
            else:
                x_block, v_block, inverted = hex_centroid_and_volume(node_xyz)
            bad = np.flatnonzero(inverted | ~(v_block > 0.0))
            if bad.size:
                e = int(bad[0])
                raise InputError(
                    f"{where}: element {e + 1} of the block (id {int(gids[first_elem + e]) + 1}) is "
                    f"inverted or degenerate (volume {v_block[e]:.6g})",
                    file=file,
                    fix="check the element's node numbering (Exodus order) and that it is not flat",
                )
        else:
            raise InputError(
                f"{where}: unsupported element type {elem_type!r}",
                file=file,
                fix="supported types: " + ", ".join(SUPPORTED_ELEMENT_TYPES),
            )
        x_parts.append(np.asarray(x_block, dtype=np.float64))
        v_parts.append(np.asarray(v_block, dtype=np.float64))
        b_parts.append(np.full(count, block_id, dtype=np.int64))
        conn_parts.append(conn)
        first_elem += count

    if first_elem != num_elem:
        raise InputError(f"element blocks hold {first_elem} elements, num_elem says {num_elem}", file=file)
    if num_elem == 0 and not piece:
        raise InputError("the mesh has no elements", file=file)
    x = np.ascontiguousarray(np.concatenate(x_parts)) if x_parts else np.zeros((0, 3))
    volume = np.ascontiguousarray(np.concatenate(v_parts)) if v_parts else np.zeros(0)
    block_id = np.concatenate(b_parts) if b_parts else np.zeros(0, dtype=np.int64)
    disc = Discretization(x=x, volume=volume, block_id=block_id, gid=gids, block_names=block_names,
                          min_element_radius=min_element_radius(volume) if volume.size else 1e50, neighbor_rule=None, source=file)
    return disc, conn_parts, num_nodes


def _node_to_elements(num_nodes: int, conn_parts: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """CSR (offsets (num_nodes+1,), elements) of the elements containing each node, ascending."""
    elem_of_entry = []
    node_of_entry = []
    first = 0
    for conn in conn_parts:
        m, k = conn.shape
        elem_of_entry.append(np.repeat(np.arange(first, first + m, dtype=np.int64), k))
        node_of_entry.append(conn.ravel())
        first += m
    if not node_of_entry:
        return np.zeros(num_nodes + 1, dtype=np.int64), np.zeros(0, dtype=np.int64)
    nodes = np.concatenate(node_of_entry)
    elems = np.concatenate(elem_of_entry)
    order = np.lexsort((elems, nodes))  # by node, then ascending element
    counts = np.bincount(nodes, minlength=num_nodes)
    offsets = np.zeros(num_nodes + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    return offsets, elems[order]


def node_set_pairs(ds, file: str, num_nodes: int, conn_parts: list[np.ndarray]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Every Exodus node set as (node, element) pairs, 0-based file positions: for each node in
    the set's order, the elements that contain it, ascending; named by ``ns_names`` or
    ``nodelist_<id>``."""
    count = _dim(ds, "num_node_sets")
    if count == 0:
        return {}
    ids = _int_var(ds, "ns_prop1", np.arange(1, count + 1))
    names = _names(ds, "ns_names", count)
    offsets, elements = _node_to_elements(num_nodes, conn_parts)
    result: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    empty = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    for index in range(count):
        name = names[index] or f"nodelist_{int(ids[index])}"
        if name in result:
            raise InputError(f"duplicate node set name {name!r}", file=file, fix="give every node set its own name")
        size = _dim(ds, f"num_nod_ns{index + 1}")
        var = ds.variables.get(f"node_ns{index + 1}")
        if size == 0 or var is None:
            result[name] = empty
            continue
        nodes = np.asarray(var[:], dtype=np.int64) - 1
        if nodes.size and (nodes.min() < 0 or nodes.max() >= num_nodes):
            raise InputError(f"node set {name!r} refers to a node outside 1..{num_nodes}", file=file)
        starts, stops = offsets[nodes], offsets[nodes + 1]
        lengths = stops - starts
        total = int(lengths.sum())
        position = np.arange(total, dtype=np.int64) - np.repeat(np.cumsum(lengths) - lengths, lengths)
        result[name] = (np.repeat(nodes, lengths), elements[np.repeat(starts, lengths) + position])
    return result


def first_occurrences(values: np.ndarray) -> np.ndarray:
    """``values`` without repeats, each at its first place."""
    _, first = np.unique(values, return_index=True)
    return values[np.sort(first)]
