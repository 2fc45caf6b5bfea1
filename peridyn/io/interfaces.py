"""Element topology of an Exodus mesh, Peridigm's ``Construct Interfaces`` and the
``Interfaces.e`` file (PERIDIGM_MODELS.md §11.1-11.2).

Peridigm (``ExodusDiscretization::constructInterfaceData``, ``InterfaceData``) records, for every
pair of bonded elements that share a face, one interface element (QUAD4 between hexahedra,
TRI3 between tetrahedra), and writes them with a per-interface ``interface_aperture`` (change of
the distance between the two element centres) into a separate, single-precision Exodus file.
The rules reproduced here, quirks included:

* construction runs on the final neighbour lists (search, bond filters, ``Omit Bonds Between
  Blocks``); elements i in file order, neighbours j in list order (ascending file index);
* j's connectivity is read as **n_i consecutive entries** from j's first entry of the flat
  connectivity (file order), so a hexahedron i reads a tetrahedron j's 4 nodes plus 4 of the next
  element's; entries past the end of the mesh read as "no node" (Peridigm reads unowned memory);
* HEX8 i: faces {4,5,6,7}, {7,6,2,3}, {0,4,7,3}, {0,1,2,3}, {0,4,5,1}, {1,5,6,2} in that order;
  count the face's nodes among j's entries with multiplicity; at the first face with count > 2
  and GID_j > GID_i record (i, j, count, the face's nodes in listed order) and stop. A count of
  3 gives a TRI3 made of the face's first three nodes;
* other i: i's nodes found among j's entries (each match counted, in i's node order); more than
  two and GID_j > GID_i gives an interface of that many nodes;
* the file ``Interfaces.e`` (fixed name) holds the mesh nodes sorted by node id (float32
  coordinates, ``node_num_map`` = id + 1, coordinate names ``coordinates_x/_y/_x`` as Peridigm
  spells them), two blocks (id 1 QUAD4, id 2 TRI3, each in discovery order), ``elem_num_map`` =
  discovery index + 1, one element variable ``interface_aperture``; all values float32;
* every actual write of an Output section first writes, at that writer's Exodus step number,
  the time and the *stored* apertures, then recomputes the apertures |y_R - y_L| - |x_R - x_L|
  for the next write: the file lags one write behind (0 at the first).

Differences from Peridigm: under MPI peridyn writes one merged ``Interfaces.e`` (Peridigm writes
``Interfaces.e.<np>.<rank>`` pieces); a block with no interfaces gets truth-table entry 0 (as
every NULL block in peridyn's Exodus files) where Peridigm asks for 1.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError
from .exodus_elements import auxiliary_map
from .exodus_writer import EXODUS_API_VERSION, MAX_NAME_LENGTH, _char_array

log = logging.getLogger("peridyn.interfaces")

__all__ = [
    "INTERFACES_FILE",
    "InterfaceFile",
    "InterfaceSet",
    "Interfaces",
    "MeshTopology",
    "find_interfaces",
    "read_mesh_topology",
    "setup_interfaces",
]

#: the file name Peridigm uses, whatever the Output Filename
INTERFACES_FILE = "Interfaces.e"
#: HEX8 faces in Peridigm's scan order (local node indices)
HEX_FACES = ((4, 5, 6, 7), (7, 6, 2, 3), (0, 4, 7, 3), (0, 1, 2, 3), (0, 4, 5, 1), (1, 5, 6, 2))
_LEN_STRING = 33
_LEN_LINE = 81
_LEN_NAME = MAX_NAME_LENGTH + 1


# ------------------------------------------------------------------------------------------------
# mesh topology
# ------------------------------------------------------------------------------------------------
@dataclass
class MeshTopology:
    """The element connectivity of an Exodus mesh, elements in file (mothership) order.

    node_id: (num_nodes,) int64 0-based global node ids (``node_num_map`` - 1, or the auxiliary
        ``original_global_id_map``; 0..n-1 without a map), in file order.
    node_xyz: (num_nodes, 3) float64 node coordinates (L), file order.
    elem_offsets: (num_elem + 1,) int64; element e's nodes are
        ``elem_nodes[elem_offsets[e]:elem_offsets[e + 1]]``.
    elem_nodes: (total,) int64 **global node ids** of every element's nodes, concatenated.
    elem_types: (num_elem,) upper-case Exodus element type of every element.
    """

    node_id: np.ndarray
    node_xyz: np.ndarray
    elem_offsets: np.ndarray
    elem_nodes: np.ndarray
    elem_types: np.ndarray

    @property
    def num_elements(self) -> int:
        return int(self.elem_offsets.size - 1)

    def nodes_per_element(self) -> np.ndarray:
        """(num_elem,) int64 node count of every element."""
        return np.diff(self.elem_offsets)

    def node_position(self, ids: np.ndarray) -> np.ndarray:
        """File positions (int64) of global node ids ``ids`` (any shape)."""
        order = np.argsort(self.node_id, kind="stable")
        return order[np.searchsorted(self.node_id, ids, sorter=order)]

    def hex_nodes(self) -> np.ndarray:
        """(num_elem, 8, 3) node coordinates of every element, which must all be HEX8/HEX/HEX20
        (the first 8 nodes are used). Raises ValueError otherwise."""
        counts = self.nodes_per_element()
        bad = np.flatnonzero(counts < 8)
        if bad.size or np.any(~np.isin(self.elem_types, ("HEX", "HEX8", "HEX20"))):
            e = int(bad[0]) if bad.size else int(np.flatnonzero(~np.isin(self.elem_types, ("HEX", "HEX8", "HEX20")))[0])
            raise ValueError(f"element {e + 1} is a {self.elem_types[e]} with {counts[e]} nodes; only hexahedra are supported")
        first = self.elem_offsets[:-1, None] + np.arange(8)[None, :]
        return np.ascontiguousarray(self.node_xyz[self.node_position(self.elem_nodes[first])])


def _dim(ds, name: str) -> int:
    return len(ds.dimensions[name]) if name in ds.dimensions else 0


def read_mesh_topology(path: str | Path) -> MeshTopology:
    """Read the node ids, node coordinates and element connectivity of an Exodus II mesh, in the
    element order of :func:`peridyn.io.exodus_mesh.read_exodus_mesh` (blocks in file order, empty
    or inactive blocks skipped). Raises InputError for an unreadable file."""
    import netCDF4

    file = str(path)
    try:
        ds = netCDF4.Dataset(file, "r")
    except (OSError, RuntimeError, ValueError) as exc:
        raise InputError(f"mesh file {Path(file).name!r} is not a readable Exodus II file ({exc})", file=file) from None
    try:
        ds.set_auto_mask(False)
        num_nodes = _dim(ds, "num_nodes")
        num_blocks = _dim(ds, "num_el_blk")
        xyz = np.zeros((num_nodes, 3))
        for d, c in enumerate("xyz"):
            if f"coord{c}" in ds.variables:
                xyz[:, d] = np.asarray(ds.variables[f"coord{c}"][:], dtype=np.float64)
            elif "coord" in ds.variables and d < ds.variables["coord"].shape[0]:
                xyz[:, d] = np.asarray(ds.variables["coord"][d], dtype=np.float64)
        ids = auxiliary_map(ds, "node", num_nodes, file)
        if ids is None:
            ids = np.asarray(ds.variables["node_num_map"][:], dtype=np.int64) if "node_num_map" in ds.variables else np.arange(1, num_nodes + 1)
        node_id = ids - 1
        status = np.asarray(ds.variables["eb_status"][:], dtype=np.int64) if "eb_status" in ds.variables else np.ones(num_blocks, np.int64)
        conns, types = [], []
        for k in range(1, num_blocks + 1):
            count = _dim(ds, f"num_el_in_blk{k}")
            if count == 0 or status[k - 1] == 0:
                continue
            var = ds.variables[f"connect{k}"]
            conn = np.asarray(var[:], dtype=np.int64).reshape(count, -1) - 1  # file positions
            conns.append(conn)
            types.extend([str(getattr(var, "elem_type", "")).strip().upper()] * count)
    finally:
        ds.close()
    sizes = np.concatenate([np.full(c.shape[0], c.shape[1], dtype=np.int64) for c in conns]) if conns else np.zeros(0, np.int64)
    offsets = np.zeros(sizes.size + 1, dtype=np.int64)
    np.cumsum(sizes, out=offsets[1:])
    flat = np.concatenate([c.ravel() for c in conns]) if conns else np.zeros(0, np.int64)
    return MeshTopology(node_id, xyz, offsets, node_id[flat], np.array(types, dtype=object))


def read_piece_topology(base: Path, size: int):
    """The :class:`~peridyn.io.interfaces.MeshTopology` of the whole mesh from all ``size``
    pieces of ``base``, elements in the order of the whole mesh (:func:`mesh_order`), each node
    once (a node on a cut is in every piece that uses it)."""
    from ..core.discretization import mesh_order
    from .exodus_pieces import piece_path, read_exodus_piece

    tops, parts = [], []
    for r in range(size):
        path = piece_path(base, size, r)
        tops.append(read_mesh_topology(path))
        parts.append(read_exodus_piece(path).points)
    names: dict[int, str] = {}
    for p in parts:
        for bid, name in p.block_names.items():
            names.setdefault(bid, name)
    order = mesh_order(names, np.concatenate([p.block_id for p in parts]), np.concatenate([p.gid for p in parts]))
    node_id = np.concatenate([t.node_id for t in tops])
    node_id, first = np.unique(node_id, return_index=True)
    node_xyz = np.concatenate([t.node_xyz for t in tops])[first]
    sizes = np.concatenate([t.nodes_per_element() for t in tops])
    starts = np.concatenate([t.elem_offsets[:-1] + shift for t, shift in zip(tops, np.cumsum([0] + [t.elem_nodes.size for t in tops[:-1]]))])
    nodes = np.concatenate([t.elem_nodes for t in tops])
    sizes, starts = sizes[order], starts[order]
    offsets = np.zeros(order.size + 1, dtype=np.int64)
    np.cumsum(sizes, out=offsets[1:])
    take = np.repeat(starts, sizes) + (np.arange(int(offsets[-1])) - np.repeat(offsets[:-1], sizes))
    types = np.concatenate([t.elem_types for t in tops])[order] if order.size else np.zeros(0, dtype=object)
    return MeshTopology(node_id, node_xyz, offsets, nodes[take], types)


# ------------------------------------------------------------------------------------------------
# construction
# ------------------------------------------------------------------------------------------------
@dataclass
class InterfaceSet:
    """Interfaces in discovery order: ``left``/``right`` (k,) int64 mothership indices of the two
    elements, ``nodes`` (k, 4) int64 global node ids (-1 past ``num_nodes``), ``num_nodes`` (k,)."""

    left: np.ndarray
    right: np.ndarray
    nodes: np.ndarray
    num_nodes: np.ndarray

    @property
    def size(self) -> int:
        return int(self.left.size)


def _interfaces_of(i: int, row: np.ndarray, topo: MeshTopology, gid: np.ndarray, out: list) -> None:
    """Append (i, k, j, count, nodes) for the interfaces element i forms with its neighbours
    ``row`` (mothership indices in list order)."""
    flat, offs = topo.elem_nodes, topo.elem_offsets
    total = flat.size
    lo, hi = int(offs[i]), int(offs[i + 1])
    own = flat[lo:hi]
    n_i = hi - lo
    for k, j in enumerate(row):
        j = int(j)
        if not gid[j] > gid[i]:  # Peridigm checks this last; no interface either way
            continue
        s = int(offs[j])
        entries = flat[s : min(s + n_i, total)]
        if entries.size < n_i:  # over-read past the end of the mesh: no node there
            entries = np.concatenate([entries, np.full(n_i - entries.size, -1, dtype=np.int64)])
        if n_i == 8:
            for face in HEX_FACES:
                count = int(sum(int(np.count_nonzero(entries == own[f])) for f in face))
                if count > 2:
                    out.append((i, k, j, count, [int(own[f]) for f in face]))
                    break
        else:
            found = [int(a) for a in own for b in entries if a == b]
            if len(found) > 2:
                out.append((i, k, j, len(found), found))


def find_interfaces(topo: MeshTopology, gid: np.ndarray, rows: list[tuple[int, np.ndarray]]) -> list[tuple]:
    """Interfaces of the elements in ``rows`` as (i, k, j, count, nodes) records, sortable into
    discovery order. rows: (mothership index i, its neighbours as mothership indices in list
    order). gid: (num_elem,) element global ids (0-based). Raises InputError for a face of more
    than four matched nodes (Peridigm overruns a 4-entry buffer there)."""
    out: list[tuple] = []
    for i, row in rows:
        _interfaces_of(int(i), row, topo, gid, out)
    for rec in out:
        if rec[3] > 4:
            raise InputError(
                f"Construct Interfaces: element {int(gid[rec[0]]) + 1} and element {int(gid[rec[2]]) + 1} share {rec[3]} "
                "node matches; interfaces have 3 or 4 nodes",
                path=("Discretization", "Construct Interfaces"),
            )
    return out


def _as_set(records: list[tuple]) -> InterfaceSet:
    records = sorted(records, key=lambda r: (r[0], r[1]))
    k = len(records)
    nodes = np.full((k, 4), -1, dtype=np.int64)
    for q, r in enumerate(records):
        nodes[q, : r[3]] = r[4][: r[3]]
    return InterfaceSet(
        np.array([r[0] for r in records], dtype=np.int64),
        np.array([r[2] for r in records], dtype=np.int64),
        nodes,
        np.array([r[3] for r in records], dtype=np.int64),
    )


# ------------------------------------------------------------------------------------------------
# the Interfaces.e file
# ------------------------------------------------------------------------------------------------
class InterfaceFile:
    """``Interfaces.e`` (single precision, two blocks QUAD4/TRI3, one element variable).

    Created (clobbered) at construction; :meth:`write` puts one step at a 1-based Exodus step
    number, overwriting a step of that number already there."""

    def __init__(self, path: str | Path, topo: MeshTopology, ifaces: InterfaceSet) -> None:
        import netCDF4

        self.path = Path(path)
        order = np.argsort(topo.node_id, kind="stable")
        used = np.unique(topo.elem_nodes)  # nodes of the (overlap) elements, sorted by id
        keep = order[np.isin(topo.node_id[order], used)]
        ids = topo.node_id[keep]
        self.quads = np.flatnonzero(ifaces.num_nodes == 4)
        self.tris = np.flatnonzero(ifaces.num_nodes == 3)
        position = {int(g): p + 1 for p, g in enumerate(ids)}  # node id -> connectivity entry
        ds = netCDF4.Dataset(str(self.path), "w", format="NETCDF3_64BIT_OFFSET")
        self._ds = ds
        try:
            ds.set_auto_maskandscale(False)
            ds.set_fill_off()
            ds.setncattr("api_version", np.float32(EXODUS_API_VERSION))
            ds.setncattr("version", np.float32(EXODUS_API_VERSION))
            ds.setncattr("floating_point_word_size", np.int32(4))
            ds.setncattr("file_size", np.int32(1))
            ds.setncattr("maximum_name_length", np.int32(MAX_NAME_LENGTH))
            ds.setncattr("int64_status", np.int32(0))
            ds.setncattr("title", INTERFACES_FILE)
            for name, size in (("len_string", _LEN_STRING), ("len_line", _LEN_LINE), ("four", 4), ("len_name", _LEN_NAME)):
                ds.createDimension(name, size)
            ds.createDimension("time_step", None)
            ds.createDimension("num_dim", 3)
            ds.createDimension("num_nodes", max(int(ids.size), 1))
            if ifaces.size:
                ds.createDimension("num_elem", ifaces.size)
            ds.createDimension("num_el_blk", 2)
            blocks = [(self.quads, 4, "QUAD4"), (self.tris, 3, "TRI3")]
            for b, (members, width, _) in enumerate(blocks, start=1):
                if members.size:
                    ds.createDimension(f"num_el_in_blk{b}", members.size)
                    ds.createDimension(f"num_nod_per_el{b}", width)
            ds.createDimension("num_elem_var", 1)
            var = ds.createVariable
            self._time = var("time_whole", "f4", ("time_step",))
            var("eb_status", "i4", ("num_el_blk",))
            var("eb_prop1", "i4", ("num_el_blk",)).setncattr("name", "ID")
            for c in "xyz":
                var(f"coord{c}", "f4", ("num_nodes",))
            var("eb_names", "S1", ("num_el_blk", "len_name"))
            var("coor_names", "S1", ("num_dim", "len_name"))
            if ifaces.size:
                var("elem_num_map", "i4", ("num_elem",))
            var("node_num_map", "i4", ("num_nodes",))
            self._vals: list[Any] = []
            for b, (members, width, etype) in enumerate(blocks, start=1):
                if members.size:
                    var(f"connect{b}", "i4", (f"num_el_in_blk{b}", f"num_nod_per_el{b}")).setncattr("elem_type", etype)
            var("name_elem_var", "S1", ("num_elem_var", "len_name"))
            for b, (members, _, _) in enumerate(blocks, start=1):
                self._vals.append(var(f"vals_elem_var1eb{b}", "f4", ("time_step", f"num_el_in_blk{b}")) if members.size else None)
            var("elem_var_tab", "i4", ("num_el_blk", "num_elem_var"))

            ds["eb_status"][:] = np.array([1 if m.size else 0 for m, _, _ in blocks], dtype=np.int32)
            ds["eb_prop1"][:] = np.array([1, 2], dtype=np.int32)
            xyz = topo.node_xyz[keep] if ids.size else np.zeros((1, 3))
            for d, c in enumerate("xyz"):
                ds[f"coord{c}"][:] = xyz[:, d].astype(np.float32)
            ds["eb_names"][:] = _char_array(["", ""], _LEN_NAME)
            ds["coor_names"][:] = _char_array(["coordinates_x", "coordinates_y", "coordinates_x"], _LEN_NAME)
            if ifaces.size:
                ds["elem_num_map"][:] = np.arange(1, ifaces.size + 1, dtype=np.int32)
            ds["node_num_map"][:] = (ids + 1).astype(np.int32) if ids.size else np.array([1], np.int32)
            for b, (members, width, _) in enumerate(blocks, start=1):
                if members.size:
                    conn = np.array([[position[int(g)] for g in ifaces.nodes[q, :width]] for q in members], dtype=np.int32)
                    ds[f"connect{b}"][:] = conn
            ds["name_elem_var"][:] = _char_array(["interface_aperture"], _LEN_NAME)
            ds["elem_var_tab"][:] = np.array([[1 if m.size else 0] for m, _, _ in blocks], dtype=np.int32)
            ds.sync()
        except BaseException:
            ds.close()
            raise

    def write(self, step: int, time: float, aperture: np.ndarray) -> None:
        """Put the time (float32) and ``aperture`` ((k,) in discovery order, float32) at the
        1-based Exodus step ``step``."""
        k = int(step) - 1
        self._time[k] = np.float32(time)
        for members, v in zip((self.quads, self.tris), self._vals):
            if v is not None:
                v[k, :] = aperture[members].astype(np.float32)
        self._ds.sync()

    def close(self) -> None:
        if self._ds is not None:
            self._ds.close()
            self._ds = None


def apertures(x: np.ndarray, y: np.ndarray, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """|y_R - y_L| - |x_R - x_L| per interface, each norm sqrt((dx*dx + dy*dy) + dz*dz) as
    Peridigm evaluates it. x, y: (n, 3) mothership reference and current positions (L)."""
    dx = x[right] - x[left]
    dy = y[right] - y[left]
    X = np.sqrt((dx[:, 0] * dx[:, 0] + dx[:, 1] * dx[:, 1]) + dx[:, 2] * dx[:, 2])
    Y = np.sqrt((dy[:, 0] * dy[:, 0] + dy[:, 1] * dy[:, 1]) + dy[:, 2] * dy[:, 2])
    return Y - X


# ------------------------------------------------------------------------------------------------
# engine glue
# ------------------------------------------------------------------------------------------------
class Interfaces:
    """The interfaces of a simulation and their file; ``write`` is called by every Output
    section's actual write (collective under MPI; rank 0 owns the file)."""

    def __init__(self, sim: Any, ifaces: InterfaceSet, file: InterfaceFile | None) -> None:
        self.sim = sim
        self.set = ifaces
        self.file = file
        self.aperture = np.zeros(ifaces.size)

    def write(self, step: int, time: float) -> None:
        """Write the stored apertures at Exodus step ``step``, then recompute them."""
        sim = self.sim
        n = sim.num_owned
        y = sim.comm.gather_points(np.ascontiguousarray(sim.fields["Coordinates"][:n]), sim.mothership_of_local[:n], sim.num_global)
        if self.file is None:
            return
        self.file.write(step, time, self.aperture)
        self.aperture = apertures(sim.discretization.x, y, self.set.left, self.set.right)

    def close(self) -> None:
        if self.file is not None:
            self.file.close()


def mesh_file_of(deck: Any) -> Path:
    """The Exodus mesh file of a deck's ``Discretization`` (``Input Mesh File``)."""
    from .nodesets import find_input_file

    return Path(find_input_file(deck.discretization.params.input_mesh_file, deck.directory))


def element_hex_nodes(deck: Any, disc: Any) -> np.ndarray:
    """(n, 8, 3) node coordinates of the deck's mesh elements in mothership order, for
    element-horizon intersections; an InputError names the deck key when an element is not a
    hexahedron (Peridigm: intersections "currently enabled only for hexahedron elements")."""
    if disc.element_nodes is not None:  # read with the mesh (a pre-split mesh's pieces)
        return disc.element_nodes
    return hex_nodes_of(mesh_file_of(deck), disc.num_points)


def hex_nodes_of(path: Path, count: int) -> np.ndarray:
    """(count, 8, 3) node coordinates of the elements of the Exodus mesh ``path``, in the order
    of its points; InputError when an element is not a hexahedron or the count differs."""
    topo = read_mesh_topology(path)
    try:
        nodes = topo.hex_nodes()
    except ValueError as exc:
        raise InputError(f"Compute Element-Horizon Intersections: {exc}", file=str(path),
                         path=("Discretization", "Compute Element-Horizon Intersections"), fix="use a mesh of HEX8 elements") from None
    if nodes.shape[0] != count:
        raise InputError(f"{nodes.shape[0]} elements in the mesh, {count} points", file=str(path))
    return nodes


def setup_interfaces(sim: Any) -> Interfaces:
    """Construct the interfaces of ``sim`` (neighbour lists final) and create ``Interfaces.e``
    in its output folder. Collective under MPI: each rank scans its own elements, rank 0 merges
    the records in discovery order and writes the file."""
    from .exodus_pieces import find_pieces

    mesh_file = mesh_file_of(sim.deck)
    pieces = find_pieces(sim.deck.discretization.params.input_mesh_file, sim.deck.directory, sim.comm.size) if not mesh_file.is_file() else None
    topo = read_mesh_topology(mesh_file) if pieces is None else read_piece_topology(pieces, sim.comm.size)
    disc = sim.discretization
    if topo.num_elements != disc.num_points:
        raise InputError(f"Construct Interfaces: {topo.num_elements} elements in the mesh, {disc.num_points} points", file=str(mesh_file))
    nl = sim.bonds
    moth = sim.mothership_of_local
    rows = []
    for local in range(sim.num_owned):
        row = moth[nl.neighbors[nl.offsets[local] : nl.offsets[local + 1]]]
        rows.append((int(moth[local]), np.sort(row)))  # Peridigm's list order: ascending file index
    records = find_interfaces(topo, disc.gid, rows)
    gathered = sim.comm.gather(records)
    if not sim.comm.is_root:
        return Interfaces(sim, _as_set([]), None)
    ifaces = _as_set([r for part in gathered for r in part])
    log.info("Construct Interfaces: %d interfaces (%d quadrilaterals, %d triangles)", ifaces.size,
             int(np.sum(ifaces.num_nodes == 4)), int(np.sum(ifaces.num_nodes == 3)))
    if not sim.write_files:  # peridyn check: the interfaces, no file
        return Interfaces(sim, ifaces, None)
    return Interfaces(sim, ifaces, InterfaceFile(Path(sim.output_dir) / INTERFACES_FILE, topo, ifaces))
