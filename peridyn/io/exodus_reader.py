"""Small Exodus II readers: one nodal variable (the Data Loader) and a whole result file (tests).

Both read any Exodus II netCDF file (classic or netCDF-4), with per-variable storage
(``vals_nod_var<i>``) or the older combined ``vals_nod_var`` array, and ``coord<x|y|z>`` or a
combined ``coord`` array.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import netCDF4
import numpy as np

from ..core.errors import InputError

__all__ = ["TENSOR_SUFFIXES", "combine_components", "component_groups", "read_nodal_variable", "read_results"]

#: a full tensor's components as the writer names them (peridyn.core.fields.component_names)
TENSOR_SUFFIXES = ("XX", "XY", "XZ", "YX", "YY", "YZ", "ZX", "ZY", "ZZ")
#: a symmetric tensor written by its six components (other Exodus writers), the lower triangle by
#: either of its names
_SYMMETRIC = (("XX", "XX"), ("YY", "YY"), ("ZZ", "ZZ"), ("XY", "YX"), ("YZ", "ZY"), ("XZ", "ZX"))
_VECTOR_SUFFIXES = ("X", "Y", "Z")


def component_groups(names: list[str]) -> dict[str, tuple[str, list[str]]]:
    """Variables written as components, by base name: ``base -> (kind, component names)``;
    ``kind`` is ``"tensor"`` (``NameXX``, ``NameXY``, ... ``NameZZ``, row-major: the writer's
    layout), ``"symmetric"`` (``NameXX``, ``NameYY``, ``NameZZ``, ``NameXY``, ``NameYZ``,
    ``NameXZ`` or ``NameZX``, without the other off-diagonal ones) or ``"vector"`` (``NameX``,
    ``NameY``, ``NameZ``). Tensors are found first, so ``StressXX`` is never the ``X`` of a
    vector ``StressX``; the names of a group are given in the order :func:`combine_components`
    reads them."""
    have = set(names)
    taken: set[str] = set()
    groups: dict[str, tuple[str, list[str]]] = {}
    for name in names:
        if not name.endswith("XX") or name in taken:
            continue
        base = name[:-2]
        full = [base + c for c in TENSOR_SUFFIXES]
        if all(f in have for f in full):
            groups[base] = ("tensor", full)
            taken.update(full)
            continue
        symmetric = []
        for first, second in _SYMMETRIC:
            pick = base + first if base + first in have else base + second if base + second in have else None
            if pick is None:
                break
            symmetric.append(pick)
        if len(symmetric) == 6:
            groups[base] = ("symmetric", symmetric)
            taken.update(symmetric)
    for name in names:
        if name.endswith("X") and name not in taken:
            base = name[:-1]
            vec = [base + c for c in _VECTOR_SUFFIXES]
            if all(v in have and v not in taken for v in vec):
                groups[base] = ("vector", vec)
                taken.update(vec)
    return groups


def combine_components(table: dict[str, np.ndarray], kind: str, names: list[str]) -> np.ndarray:
    """The components ``names`` of ``table`` (each (...,)) as one array: (..., 3) for a vector,
    (..., 3, 3) for a tensor (a symmetric one mirrored)."""
    parts = [np.asarray(table[n], dtype=np.float64) for n in names]
    if kind == "vector":
        return np.stack(parts, axis=-1)
    if kind == "tensor":
        return np.stack(parts, axis=-1).reshape(parts[0].shape + (3, 3))
    xx, yy, zz, xy, yz, xz = parts
    rows = [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def _names(ds: netCDF4.Dataset, var: str) -> list[str]:
    """The strings of a ``(count, len_name)`` char variable, NUL padding removed."""
    if var not in ds.variables:
        return []
    raw = np.asarray(ds.variables[var][:])
    if raw.ndim == 1:
        raw = raw[None]
    out = []
    for row in raw.reshape(-1, raw.shape[-1]):
        b = row.tobytes().split(b"\x00", 1)[0]
        out.append(b.decode("ascii", errors="replace").strip())
    return out


def _dim(ds: netCDF4.Dataset, name: str) -> int:
    return len(ds.dimensions[name]) if name in ds.dimensions else 0


#: netCDF-3 type sizes (nc_type 1..11: byte, char, short, int, float, double; CDF-5's unsigned and 64-bit ones)
_NC_SIZES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 4, 6: 8, 7: 1, 8: 2, 9: 4, 10: 8, 11: 8}
_STREAMING = 0xFFFFFFFF


class _Short(Exception):
    """The header itself ends early."""


def _classic_size(path: Path) -> int | None:
    """The bytes a netCDF-3 file's header promises (the end of its last fixed variable or
    record), None for any other format (netCDF-4/HDF5) or a streaming record count.
    :class:`_Short` when the header is cut."""
    with open(path, "rb") as f:
        data = f.read(1 << 20)
        while True:
            try:
                return _promised(data)
            except _Short:
                more = f.read(len(data))
                if not more:
                    raise
                data += more


def _promised(data: bytes) -> int | None:
    if data[:3] != b"CDF" or len(data) < 4 or data[3] not in (1, 2, 5):
        return None
    version = data[3]
    pos = 4
    count = 8 if version == 5 else 4  # NON_NEG and nelems widths
    offset = 4 if version == 1 else 8

    def number(width: int) -> int:
        nonlocal pos
        if pos + width > len(data):
            raise _Short
        value = int.from_bytes(data[pos:pos + width], "big")
        pos += width
        return value

    def name() -> None:
        nonlocal pos
        length = number(count)
        pos += -(-length // 4) * 4

    def attributes() -> None:
        nonlocal pos
        number(4)
        for _ in range(number(count)):
            name()
            kind = number(4)
            length = number(count) * _NC_SIZES.get(kind, 1)
            pos += -(-length // 4) * 4

    numrecs = number(count)
    number(4)
    dims = []
    for _ in range(number(count)):
        name()
        dims.append(number(count))
    attributes()
    number(4)
    fixed_end, records = 0, []
    for _ in range(number(count)):
        name()
        ids = [number(count) for _ in range(number(count))]
        attributes()
        kind = number(4)
        vsize = number(count)
        begin = number(offset)
        shape = [dims[i] if i < len(dims) else 0 for i in ids]
        is_record = bool(ids) and shape[0] == 0
        size = _NC_SIZES.get(kind, 1) * math.prod(shape[1:] if is_record else shape)
        if is_record:
            records.append((begin, size, vsize))
        else:
            fixed_end = max(fixed_end, begin + size)
    if pos > len(data):
        raise _Short
    if not records or numrecs == _STREAMING or numrecs == 0:
        return max(fixed_end, pos)
    recsize = records[0][1] if len(records) == 1 else sum(v for _, _, v in records)
    record_end = max(begin + (numrecs - 1) * recsize + size for begin, size, _ in records)
    return max(fixed_end, record_end)


def _check_length(path: str | Path) -> None:
    """InputError when a netCDF-3 file is shorter than its header says (a truncated copy)."""
    try:
        actual = Path(path).stat().st_size
        promised = _classic_size(Path(path))
    except _Short:
        raise InputError(f"truncated: {Path(path).stat().st_size} bytes end inside the netCDF header", file=str(path),
                         fix="copy or write the file again (it was cut short)") from None
    except OSError as e:
        raise InputError(f"cannot read Exodus file: {e}", file=str(path)) from None
    if promised is not None and actual < promised:
        raise InputError(f"truncated: {actual} bytes of the {promised} its header promises", file=str(path),
                         fix="copy or write the file again (it was cut short, as by a full disk or an interrupted copy)")


def _open(path: str | Path) -> netCDF4.Dataset:
    _check_length(path)
    try:
        ds = netCDF4.Dataset(str(path), "r")
    except (OSError, RuntimeError, ValueError, UnicodeError) as e:
        raise InputError(f"cannot read Exodus file: {e}", file=str(path)) from None
    ds.set_auto_maskandscale(False)
    return ds


def _times(ds: netCDF4.Dataset) -> np.ndarray:
    if "time_whole" not in ds.variables:
        return np.zeros(0)
    return np.asarray(ds.variables["time_whole"][:], dtype=np.float64).reshape(-1)


def _nodal(ds: netCDF4.Dataset, index: int) -> np.ndarray:
    """(nt, num_nodes) values of nodal variable ``index`` (0-based)."""
    nt, n = _dim(ds, "time_step"), _dim(ds, "num_nodes")
    v = ds.variables.get(f"vals_nod_var{index + 1}")
    if v is not None:
        return np.asarray(v[:], dtype=np.float64).reshape(nt, n)
    return np.asarray(ds.variables["vals_nod_var"][:, index, :], dtype=np.float64).reshape(nt, n)


def _node_num_map(ds: netCDF4.Dataset) -> np.ndarray:
    n = _dim(ds, "num_nodes")
    if "node_num_map" in ds.variables:
        return np.asarray(ds.variables["node_num_map"][:], dtype=np.int64)
    return np.arange(1, n + 1, dtype=np.int64)


def read_nodal_variable(path: str | Path, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read every step of one nodal variable.

    Returns
    -------
    times: (nt,) time values, float64 [time unit].
    values: (nt, num_nodes) the variable at each step, in file node order.
    node_num_map: (num_nodes,) 1-based node IDs in file node order (1..n when the file has no map).

    Raises :class:`~peridyn.core.errors.InputError` naming the available nodal variables when the file
    has none called ``name``, or when the file cannot be read.
    """
    ds = _open(path)
    try:
        names = _names(ds, "name_nod_var")
        if name not in names:
            avail = ", ".join(names) if names else "none"
            raise InputError(
                f"no nodal variable named {name!r} (available: {avail})", file=str(path)
            )
        return _times(ds), _nodal(ds, names.index(name)), _node_num_map(ds)
    finally:
        ds.close()


def read_results(path: str | Path) -> dict[str, Any]:
    """Read a whole Exodus result file into plain numpy arrays (meant for tests and tools).

    Returned keys:

    * ``title`` (str), ``coords`` (num_nodes, 3) reference coordinates, ``times`` (nt,),
      ``node_num_map`` (num_nodes,), ``elem_num_map`` (num_elem,), both 1-based;
    * ``blocks``: list of dicts ``{"id", "name", "status", "elem_type", "nodes"}`` in file
      order, ``nodes`` the 0-based node of each element (first node of its connectivity);
    * ``node_sets``: dict name -> (k,) 0-based node indices in stored order (empty for a NULL
      set), in file order;
    * ``nodal``: dict name -> (nt, num_nodes);
    * ``element``: dict name -> (nt, num_nodes), each element's value put on its node (sphere
      meshes, one node per element), NaN where no block carries the variable;
    * ``element_blocks``: dict name -> list per block of (nt, num_el_in_blk) arrays or None;
    * ``global``: dict name -> (nt,);
    * ``truth_table``: (num_blocks, num_element_vars) bool;
    * ``qa_records``: list of 4-tuples of str.
    """
    ds = _open(path)
    try:
        n = _dim(ds, "num_nodes")
        nt = _dim(ds, "time_step")
        if "coord" in ds.variables:
            coords = np.asarray(ds.variables["coord"][:], dtype=np.float64).T
        else:
            cols = [
                np.asarray(ds.variables[f"coord{c}"][:], dtype=np.float64) if f"coord{c}" in ds.variables else np.zeros(n)
                for c in "xyz"
            ]
            coords = np.stack(cols, axis=1) if n else np.zeros((0, 3))
        nb = _dim(ds, "num_el_blk")
        eb_names = _names(ds, "eb_names") or [""] * nb
        ids = np.asarray(ds.variables["eb_prop1"][:]) if "eb_prop1" in ds.variables else np.arange(1, nb + 1)
        status = np.asarray(ds.variables["eb_status"][:]) if "eb_status" in ds.variables else np.ones(nb, int)
        blocks = []
        for b in range(1, nb + 1):
            conn = ds.variables.get(f"connect{b}")
            nodes = np.asarray(conn[:])[:, 0].astype(np.int64) - 1 if conn is not None else np.zeros(0, np.int64)
            etype = conn.getncattr("elem_type") if conn is not None and "elem_type" in conn.ncattrs() else ""
            blocks.append(
                {"id": int(ids[b - 1]), "name": eb_names[b - 1], "status": int(status[b - 1]), "elem_type": etype, "nodes": nodes}
            )
        nns = _dim(ds, "num_node_sets")
        ns_names = _names(ds, "ns_names") or [f"nodelist_{k}" for k in range(1, nns + 1)]
        node_sets = {}
        for k in range(1, nns + 1):
            v = ds.variables.get(f"node_ns{k}")
            node_sets[ns_names[k - 1]] = np.asarray(v[:], dtype=np.int64) - 1 if v is not None else np.zeros(0, np.int64)

        nodal = {name: _nodal(ds, i) for i, name in enumerate(_names(ds, "name_nod_var"))}
        elem_names = _names(ds, "name_elem_var")
        if "elem_var_tab" in ds.variables:
            tab = np.asarray(ds.variables["elem_var_tab"][:]).astype(bool).reshape(nb, len(elem_names))
        else:
            tab = np.ones((nb, len(elem_names)), dtype=bool)
        element, element_blocks = {}, {}
        for i, name in enumerate(elem_names):
            per_node = np.full((nt, n), np.nan)
            per_block: list[np.ndarray | None] = []
            for b, blk in enumerate(blocks, start=1):
                v = ds.variables.get(f"vals_elem_var{i + 1}eb{b}")
                if v is None:
                    per_block.append(None)
                    continue
                vals = np.asarray(v[:], dtype=np.float64).reshape(nt, blk["nodes"].size)
                per_block.append(vals)
                per_node[:, blk["nodes"]] = vals
            element[name] = per_node
            element_blocks[name] = per_block
        glob = {}
        glo_names = _names(ds, "name_glo_var")
        if glo_names:
            vals = np.asarray(ds.variables["vals_glo_var"][:], dtype=np.float64).reshape(nt, len(glo_names))
            glob = {name: vals[:, i].copy() for i, name in enumerate(glo_names)}
        qa = []
        if "qa_records" in ds.variables:
            flat = _names(ds, "qa_records")
            qa = [tuple(flat[4 * r : 4 * r + 4]) for r in range(len(flat) // 4)]
        title = ds.getncattr("title") if "title" in ds.ncattrs() else ""
        return {
            "title": str(title),
            "coords": coords,
            "times": _times(ds),
            "node_num_map": _node_num_map(ds),
            "elem_num_map": np.asarray(ds.variables["elem_num_map"][:], dtype=np.int64)
            if "elem_num_map" in ds.variables
            else np.arange(1, _dim(ds, "num_elem") + 1, dtype=np.int64),
            "blocks": blocks,
            "node_sets": node_sets,
            "nodal": nodal,
            "element": element,
            "element_blocks": element_blocks,
            "global": glob,
            "truth_table": tab,
            "qa_records": qa,
        }
    finally:
        ds.close()
