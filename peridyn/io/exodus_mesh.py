"""``Exodus`` discretization: one peridynamic point per element of an Exodus II mesh.

Follows Peridigm's ``ExodusDiscretization::loadData`` and ``Peridigm_GeometryUtils.cpp``
(PERIDIGM_SEMANTICS.md §2.3), with the same floating-point operation order, so the points and
volumes are bit-identical to Peridigm's:

* point order = element file order: blocks in ``eb_prop1`` order, elements in connectivity order;
* global ids = element id map (``elem_num_map``) minus 1, or the single auxiliary element map
  ``original_global_id_map`` when the file has one; 0..n-1 when the file has no id map;
* element types, matched case-insensitively:

  - ``SPHERE``: the point is the node, the volume is attribute #2 (attribute #1 is a radius);
  - ``TET``, ``TETRA``, ``TET4``, ``TET10``: first 4 nodes; centroid ((n0 + n1 + n2 + n3) 0.25),
    volume = a.(b x c)/6 with a = n1 - n0, b = n2 - n0, c = n3 - n0 (must not be negative);
  - ``HEX``, ``HEX8``, ``HEX20``: first 8 nodes, split into 24 tetrahedra around the 6 face
    centers and the center (:func:`hex_centroid_and_volume`);

* block ``<id>`` is named by ``eb_names`` or ``block_<id>`` when blank; Block_Id = the Exodus
  element-block id;
* each Exodus node set becomes a point set: for each node in file order, the points (elements)
  that contain it, in ascending element order, without duplicates; named by ``ns_names`` or
  ``nodelist_<id>`` when blank;
* neighbors: a Euclidean search within each point's horizon, inclusive (§2.5).

Coordinates may be stored as ``coordx/coordy/coordz`` or as one ``coord`` (num_dim, num_nodes)
array; 2-D meshes get z = 0 (Peridigm's zero-initialised z).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from pydantic import Field

from ..core.discretization import Discretization
from ..core.discretization import DiscretizationReader
from ..core.params import ModelParams
from ..core.errors import InputError, is_file, missing_file
from .nodesets import find_input_file
from .textfile import min_element_radius

__all__ = [
    "ExodusMesh",
    "ExodusMeshParams",
    "read_exodus_mesh",
    "hex_centroid_and_volume",
    "tet_centroid_and_volume",
    "SUPPORTED_ELEMENT_TYPES",
]

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


class ExodusMeshParams(ModelParams):
    """``Discretization`` section of an ``Exodus`` mesh (besides the keys the core handles)."""

    input_mesh_file: str = Field(
        alias="Input Mesh File",
        description="Exodus II mesh (genesis) file, relative to the deck's folder. Lengths in the "
        "deck's length unit L.",
    )
    store_exodus_mesh: bool = Field(
        False,
        alias="Store Exodus Mesh",
        description="Peridigm keeps the element connectivity for interface and partial-volume "
        "calculations; accepted for compatibility, it changes nothing here.",
    )
    verbose: bool = Field(
        False,
        alias="Verbose",
        description="Peridigm prints a summary of the mesh file; accepted for compatibility.",
    )
    construct_interfaces: bool = Field(
        False,
        alias="Construct Interfaces",
        description="Find the faces shared by bonded elements and write them, with their apertures, to "
        "Interfaces.e (peridyn.io.interfaces).",
    )
    compute_element_horizon_intersections: bool = Field(
        False,
        alias="Compute Element-Horizon Intersections",
        description="HEX8 meshes: neighbours are the elements that intersect the horizon sphere, and each "
        "bond gets the partial volume of its element inside the sphere (peridyn.geometry.partial_volumes).",
    )
    intersection_recursion_level: int = Field(
        2, ge=0, le=8, alias="Element-Horizon Intersection Recursion Level",
        description="partial volumes: levels of octree refinement of elements cut by the sphere surface",
    )
    intersection_number_of_samples: int = Field(
        2, ge=1, le=16, alias="Element-Horizon Intersection Number Of Samples",
        description="partial volumes: midpoint samples per direction in each finest cut sub-cell",
    )
    intersection_partial_volume_scheme: str = Field(
        "PV", alias="Element-Horizon Intersection Partial Volume Scheme",
        description="accepted for compatibility (PV, FV, PDLAMMPS, HHB); peridyn has one quadrature",
    )
    intersection_characteristic_element_length: float = Field(
        0.0, alias="Element-Horizon Intersection Characteristic Element Length", description="accepted for compatibility (L)",
    )
    intersection_use_lookup_table: bool = Field(
        True, alias="Element-Horizon Intersection Use Lookup Table", description="accepted for compatibility",
    )


# ------------------------------------------------------------------------------------------------
# Geometry (vectorized over elements; elementwise operations in Peridigm's order, no FMA)
# ------------------------------------------------------------------------------------------------
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


def read_exodus_mesh(path: Path | str) -> Discretization:
    """Read an Exodus II mesh into points, one per element.

    Returns a :class:`Discretization` in element file order: x (n, 3) centroids (L), volume (n,)
    (L^3), block_id (n,) Exodus block ids, gid (n,) 0-based global ids, block names, node sets
    as mothership indices, and min_element_radius.

    Raises
    ------
    InputError: missing, unreadable or non-Exodus file; unsupported element type; inverted
        element (negative volume); inconsistent connectivity, maps or node sets.
    """
    import netCDF4  # local import: only Exodus decks need it

    path = Path(path)
    file = str(path)
    if not is_file(path):
        raise InputError(
            missing_file(path, "mesh file"),
            path=("Discretization", "Input Mesh File"),
            fix="check the file name; relative names are relative to the deck's folder",
        )
    try:
        ds = netCDF4.Dataset(file, "r")
    except (OSError, RuntimeError, ValueError, UnicodeError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc).split(": '")[0]
        raise InputError(
            f"mesh file {path.name!r} is not a readable Exodus II (netCDF) file ({reason})",
            file=file,
            fix="give an Exodus II mesh (genesis file, usually .g or .e)",
        ) from None
    try:
        ds.set_auto_mask(False)
        return _read_dataset(ds, file)
    except (ValueError, IndexError, KeyError, UnicodeError, OverflowError, RuntimeError, OSError) as exc:
        # past the checks _read_dataset makes, anything else is a damaged file
        raise InputError(
            f"mesh file {path.name!r} is damaged or not laid out as Exodus II ({type(exc).__name__}: {str(exc)[:80]})",
            file=file, fix="regenerate or re-export the mesh",
        ) from None
    finally:
        ds.close()


def _read_dataset(ds, file: str) -> Discretization:  # noqa: C901 - one linear pass over the file
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
    if num_elem == 0:
        raise InputError("the mesh has no elements", file=file)
    x = np.ascontiguousarray(np.concatenate(x_parts))
    volume = np.ascontiguousarray(np.concatenate(v_parts))
    block_id = np.concatenate(b_parts)

    node_sets = _node_sets(ds, file, num_nodes, conn_parts)
    return Discretization(
        x=x,
        volume=volume,
        block_id=block_id,
        gid=gids,
        block_names=block_names,
        node_sets=node_sets,
        min_element_radius=min_element_radius(volume),
        neighbor_rule=None,
        source=file,
    )


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


def _node_sets(ds, file: str, num_nodes: int, conn_parts: list[np.ndarray]) -> dict[str, np.ndarray]:
    """Exodus node sets -> point sets (mothership indices, Peridigm's order, no duplicates)."""
    count = _dim(ds, "num_node_sets")
    if count == 0:
        return {}
    ids = _int_var(ds, "ns_prop1", np.arange(1, count + 1))
    names = _names(ds, "ns_names", count)
    offsets, elements = _node_to_elements(num_nodes, conn_parts)
    result: dict[str, np.ndarray] = {}
    for index in range(count):
        name = names[index] or f"nodelist_{int(ids[index])}"
        if name in result:
            raise InputError(f"duplicate node set name {name!r}", file=file, fix="give every node set its own name")
        size = _dim(ds, f"num_nod_ns{index + 1}")
        var = ds.variables.get(f"node_ns{index + 1}")
        if size == 0 or var is None:
            result[name] = np.zeros(0, dtype=np.int64)
            continue
        nodes = np.asarray(var[:], dtype=np.int64) - 1
        if nodes.size and (nodes.min() < 0 or nodes.max() >= num_nodes):
            raise InputError(f"node set {name!r} refers to a node outside 1..{num_nodes}", file=file)
        # the elements of each node, nodes in set order, each node's elements ascending
        starts, stops = offsets[nodes], offsets[nodes + 1]
        lengths = stops - starts
        total = int(lengths.sum())
        if total == 0:
            result[name] = np.zeros(0, dtype=np.int64)
            continue
        position = np.arange(total, dtype=np.int64) - np.repeat(np.cumsum(lengths) - lengths, lengths)
        candidates = elements[np.repeat(starts, lengths) + position]
        _, first = np.unique(candidates, return_index=True)
        result[name] = candidates[np.sort(first)]
    return result


class ExodusMesh(DiscretizationReader):
    """Points from the elements of an Exodus II mesh (``Type: Exodus``)."""

    name = "Exodus"
    Params = ExodusMeshParams
    supports_bond_filters = True

    def read(self) -> Discretization:
        params: ExodusMeshParams = self.params  # type: ignore[assignment]
        disc = read_exodus_mesh(find_input_file(params.input_mesh_file, self.deck_dir))
        disc.construct_interfaces = params.construct_interfaces
        disc.element_horizon_intersections = params.compute_element_horizon_intersections
        return disc

