"""Pre-split Exodus meshes for tests: :func:`split_exodus` cuts a mesh ``NAME.g`` into the pieces
``NAME.g.N.r`` as SEACAS ``decomp`` does (each piece its elements with their global ids in
``elem_num_map``, the nodes they use with theirs in ``node_num_map``, every element block, and
each node set restricted to the piece's nodes, in the set's order), so the pre-split reading
(:mod:`peridyn.io.exodus_pieces`) can be tested without SEACAS."""
from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["split_exodus", "write_box_mesh"]

_COPIED_DIMS = ("len_string", "len_line", "four", "len_name", "num_dim", "time_step", "num_el_blk", "num_node_sets", "num_qa_rec")


def _ids(ds, name: str, count: int) -> np.ndarray:
    return np.asarray(ds.variables[name][:], dtype=np.int64) if name in ds.variables else np.arange(1, count + 1)


def split_exodus(path: Path | str, owner: np.ndarray, ranks: int) -> list[Path]:
    """Write the pieces ``path.N.r`` (N = ``ranks``) of the Exodus mesh ``path``; ``owner``
    (num_elem,) gives each element's piece in file order. Returns the piece paths."""
    import netCDF4

    path = Path(path)
    owner = np.asarray(owner, dtype=np.int64)
    out = []
    with netCDF4.Dataset(path) as src:
        src.set_auto_mask(False)
        num_nodes = len(src.dimensions["num_nodes"])
        num_elem = len(src.dimensions["num_elem"])
        num_blocks = len(src.dimensions["num_el_blk"])
        node_ids = _ids(src, "node_num_map", num_nodes)
        elem_ids = _ids(src, "elem_num_map", num_elem)
        conns = [np.asarray(src.variables[f"connect{k}"][:], dtype=np.int64) if f"connect{k}" in src.variables else np.zeros((0, 1), np.int64)
                 for k in range(1, num_blocks + 1)]
        first = np.concatenate([[0], np.cumsum([c.shape[0] for c in conns])])
        num_sets = len(src.dimensions["num_node_sets"]) if "num_node_sets" in src.dimensions else 0
        for r in range(ranks):
            mine = [owner[first[k]:first[k + 1]] == r for k in range(num_blocks)]
            used = np.unique(np.concatenate([conns[k][mine[k]].ravel() for k in range(num_blocks)] + [np.zeros(0, np.int64)]))
            local = np.zeros(num_nodes + 1, dtype=np.int64)
            local[used] = np.arange(1, used.size + 1)
            piece = path.with_name(f"{path.name}.{ranks}.{r}")
            with netCDF4.Dataset(piece, "w", format="NETCDF3_64BIT_OFFSET") as ds:
                for name in _COPIED_DIMS:
                    if name in src.dimensions:
                        d = src.dimensions[name]
                        ds.createDimension(name, None if d.isunlimited() else len(d))
                for name in src.ncattrs():
                    ds.setncattr(name, src.getncattr(name))
                for name in ("eb_prop1", "eb_status", "eb_names", "ns_prop1", "ns_status", "ns_names", "coor_names"):
                    if name in src.variables:
                        v = src.variables[name]
                        ds.createVariable(name, v.dtype, v.dimensions)[:] = v[:]
                if used.size:  # an empty piece has neither dimension (a netCDF-3 size 0 is unlimited)
                    ds.createDimension("num_nodes", used.size)
                    ds.createDimension("num_elem", int(sum(m.sum() for m in mine)))
                    for name in ("coordx", "coordy", "coordz"):
                        if name in src.variables:
                            ds.createVariable(name, "f8", ("num_nodes",))[:] = np.asarray(src.variables[name][:])[used - 1]
                    if "coord" in src.variables:
                        ds.createVariable("coord", "f8", ("num_dim", "num_nodes"))[:] = np.asarray(src.variables["coord"][:])[:, used - 1]
                    ds.createVariable("node_num_map", "i4", ("num_nodes",))[:] = node_ids[used - 1]
                    ds.createVariable("elem_num_map", "i4", ("num_elem",))[:] = np.concatenate(
                        [elem_ids[first[k]:first[k + 1]][mine[k]] for k in range(num_blocks)])
                for k in range(1, num_blocks + 1):  # an empty block or node set has no dimension (a netCDF-3 size 0 is unlimited)
                    conn = conns[k - 1][mine[k - 1]]
                    if not conn.shape[0] or f"connect{k}" not in src.variables:
                        continue
                    ds.createDimension(f"num_el_in_blk{k}", conn.shape[0])
                    ds.createDimension(f"num_nod_per_el{k}", conn.shape[1])
                    v = ds.createVariable(f"connect{k}", "i4", (f"num_el_in_blk{k}", f"num_nod_per_el{k}"))
                    v.elem_type = src.variables[f"connect{k}"].elem_type
                    v[:] = local[conn]
                    if f"attrib{k}" in src.variables:
                        a = src.variables[f"attrib{k}"]
                        ds.createDimension(f"num_att_in_blk{k}", a.shape[1])
                        ds.createVariable(f"attrib{k}", "f8", (f"num_el_in_blk{k}", f"num_att_in_blk{k}"))[:] = np.asarray(a[:])[mine[k - 1]]
                for k in range(1, num_sets + 1):
                    nodes = np.asarray(src.variables[f"node_ns{k}"][:], dtype=np.int64) if f"node_ns{k}" in src.variables else np.zeros(0, np.int64)
                    kept = local[nodes[local[nodes] > 0]]
                    if kept.size:
                        ds.createDimension(f"num_nod_ns{k}", kept.size)
                        ds.createVariable(f"node_ns{k}", "i4", (f"num_nod_ns{k}",))[:] = kept
            out.append(piece)
    return out


def write_box_mesh(path: Path | str, shape: tuple[int, int, int], spacing: float, *, blocks: int = 1,
                   node_sets: dict[str, tuple[int, float]] | None = None) -> Path:
    """Write an Exodus mesh of shape[0] x shape[1] x shape[2] HEX8 cubes of side ``spacing`` (L),
    element ids in x-fastest order, cut along x into ``blocks`` element blocks of about equal
    length (ids 1, 2, ...; block k holds its elements in id order) and with node sets
    ``{name: (axis, coordinate)}`` of the nodes on a plane (nodes in id order)."""
    import netCDF4

    path = Path(path)
    nx, ny, nz = shape
    g = [np.arange(m + 1) * spacing for m in shape]
    X, Y, Z = np.meshgrid(*g, indexing="ij")
    node = lambda i, j, k: 1 + i + (nx + 1) * (j + (ny + 1) * k)  # noqa: E731
    coords = np.zeros(((nx + 1) * (ny + 1) * (nz + 1), 3))
    for i in range(nx + 1):
        for j in range(ny + 1):
            for k in range(nz + 1):
                coords[node(i, j, k) - 1] = (X[i, j, k], Y[i, j, k], Z[i, j, k])
    elems = [(i, j, k) for k in range(nz) for j in range(ny) for i in range(nx)]
    block_of = [min(blocks - 1, i * blocks // nx) for i, _, _ in elems]
    with netCDF4.Dataset(path, "w", format="NETCDF3_64BIT_OFFSET") as ds:
        ds.api_version = ds.version = np.float32(8.03)
        ds.floating_point_word_size = np.int32(8)
        for name, size in (("len_name", 33), ("num_dim", 3), ("num_nodes", coords.shape[0]), ("num_elem", len(elems)), ("num_el_blk", blocks)):
            ds.createDimension(name, size)
        for d, name in enumerate(("coordx", "coordy", "coordz")):
            ds.createVariable(name, "f8", ("num_nodes",))[:] = coords[:, d]
        ds.createVariable("eb_prop1", "i4", ("num_el_blk",))[:] = np.arange(1, blocks + 1)
        ds.createVariable("eb_status", "i4", ("num_el_blk",))[:] = 1
        ids = []
        for b in range(blocks):
            mine = [e for e, blk in zip(elems, block_of) if blk == b]
            ids += [1 + i + nx * (j + ny * k) for i, j, k in mine]
            conn = [[node(i, j, k), node(i + 1, j, k), node(i + 1, j + 1, k), node(i, j + 1, k),
                     node(i, j, k + 1), node(i + 1, j, k + 1), node(i + 1, j + 1, k + 1), node(i, j + 1, k + 1)] for i, j, k in mine]
            ds.createDimension(f"num_el_in_blk{b + 1}", len(conn))
            ds.createDimension(f"num_nod_per_el{b + 1}", 8)
            v = ds.createVariable(f"connect{b + 1}", "i4", (f"num_el_in_blk{b + 1}", f"num_nod_per_el{b + 1}"))
            v.elem_type = "HEX8"
            v[:] = np.array(conn)
        ds.createVariable("elem_num_map", "i4", ("num_elem",))[:] = np.array(ids)
        sets = list((node_sets or {}).items())
        if sets:
            ds.createDimension("num_node_sets", len(sets))
            ds.createVariable("ns_prop1", "i4", ("num_node_sets",))[:] = np.arange(1, len(sets) + 1)
            ds.createVariable("ns_status", "i4", ("num_node_sets",))[:] = 1
            names = ds.createVariable("ns_names", "S1", ("num_node_sets", "len_name"))
            for k, (name, (axis, value)) in enumerate(sets, start=1):
                names[k - 1] = netCDF4.stringtochar(np.array([name.ljust(33, "\0")[:33]], dtype="S33"))[0]
                nodes = np.flatnonzero(np.isclose(coords[:, axis], value)) + 1
                ds.createDimension(f"num_nod_ns{k}", nodes.size)
                ds.createVariable(f"node_ns{k}", "i4", (f"num_nod_ns{k}",))[:] = nodes
    return path
