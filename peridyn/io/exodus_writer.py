"""Exodus II result files with Peridigm's layout, written through netCDF4.

Peridigm (``src/io/Peridigm_OutputManager_ExodusII.cpp``) writes every point as one ``SPHERE``
element with one node. This module reproduces the netCDF layout the SEACAS Exodus library 6.x
gives those files (the layout of most of Peridigm's gold files, e.g. ``Contact_Friction``):

* classic netCDF with 64-bit offsets (``NETCDF3_64BIT_OFFSET``), word size 8 (float64 values);
* global attributes ``api_version``, ``version`` (float32), ``floating_point_word_size`` (8),
  ``file_size`` (1), ``maximum_name_length`` (32), ``int64_status`` (0), ``title``;
* dimensions ``len_string`` 33, ``len_line`` 81, ``four`` 4, ``len_name`` 33, unlimited
  ``time_step``, ``num_dim`` 3, ``num_nodes``, ``num_elem``, ``num_el_blk``, ``num_node_sets``,
  ``num_qa_rec``, ``num_nod_ns<k>``, ``num_el_in_blk<b>``/``num_nod_per_el<b>``, ``num_glo_var``,
  ``num_nod_var``, ``num_elem_var``;
* one QA record ``(program, version, MM/DD/YY, HH:MM:SS)``;
* element blocks ``connect<b>`` (int32, ``elem_type = "SPHERE"``), ``eb_prop1`` (``name = "ID"``),
  ``eb_status``, ``eb_names``; node sets ``node_ns<k>``, ``ns_prop1``, ``ns_status``,
  ``ns_names`` and no distribution factors; ``node_num_map`` and ``elem_num_map`` (int32);
* per step: ``time_whole``, ``vals_nod_var<i>``, ``vals_elem_var<i>eb<b>``, ``vals_glo_var``.

Empty blocks and empty node sets are written as the Exodus library writes them ("NULL" entities):
netCDF-3 cannot hold a zero-length fixed dimension (length 0 means *unlimited*), so the entity
keeps its ID, name and place in the counts, gets status 0, and has no size dimension and no
connectivity / node list / result variables. An empty block's row of ``elem_var_tab`` is 0.

A file is made readable after every step: :meth:`ExodusWriter.write_step` ends with ``nc_sync``,
which writes the record count into the header and hands the data to the operating system. A
process killed between steps leaves a valid file holding every step written so far; one killed
inside a step leaves the previous header's step count, so the partial step is not seen.
"""
from __future__ import annotations

import datetime as _dt
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType

import netCDF4
import numpy as np

__all__ = ["ExodusBlock", "ExodusWriter", "MAX_NAME_LENGTH", "EXODUS_API_VERSION", "keep_steps"]

#: Longest name (variables, blocks, node sets, coordinates) an Exodus file of this layout holds.
MAX_NAME_LENGTH = 32
#: The Exodus API version written in ``api_version``/``version``: the 6.x layout reproduced here.
EXODUS_API_VERSION = 6.08
_LEN_STRING = 33  # QA and info strings: 32 characters + NUL
_LEN_LINE = 81  # info records (none written)
_LEN_NAME = MAX_NAME_LENGTH + 1


def _program_version() -> str:
    try:
        from importlib.metadata import version

        return version("peridyn")
    except Exception:  # pragma: no cover - not installed as a distribution
        return "0.0.0"


@dataclass
class ExodusBlock:
    """One element block of SPHERE elements (one node each).

    Attributes
    ----------
    block_id: the block's Exodus ID (the deck block ID), ``eb_prop1``.
    name: the block name, ``eb_names`` (at most 32 characters are kept).
    nodes: (num_el_in_blk,) 0-based node indices (mothership order positions) of this block's
        points, in block order; ``connect<b>`` holds ``nodes + 1``. A writer whose mesh data
        come later in slices (``ExodusWriter(coords=None, ...)``) takes the block's size instead.
    """

    block_id: int
    name: str
    nodes: np.ndarray | int

    @property
    def size(self) -> int:
        return _size(self.nodes)


def _char_array(strings: Sequence[str], width: int) -> np.ndarray:
    """(len(strings), width) ``S1`` array, NUL padded (strings must be ASCII, < width chars)."""
    out = np.zeros((len(strings), width), dtype="S1")
    for i, s in enumerate(strings):
        b = s.encode("ascii", errors="replace")[: width - 1]
        if b:
            out[i, : len(b)] = np.frombuffer(b, dtype="S1")
    return out


def _check_var_names(kind: str, names: Sequence[str]) -> list[str]:
    names = [str(n) for n in names]
    for n in names:
        if not n:
            raise ValueError(f"empty {kind} variable name")
        if len(n) > MAX_NAME_LENGTH:
            raise ValueError(
                f"{kind} variable name {n!r} has {len(n)} characters; Exodus names hold at most {MAX_NAME_LENGTH}"
            )
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"duplicate {kind} variable names: {', '.join(dup)}")
    return names


def _size(entries: np.ndarray | int) -> int:
    """A node set's or block's size, given as its indices or (a deferred writer's) as a count."""
    return int(entries) if isinstance(entries, (int, np.integer)) else int(np.size(entries))


def _check_int32(what: str, values: np.ndarray) -> None:
    if values.size and (values.min() < np.iinfo(np.int32).min or values.max() > np.iinfo(np.int32).max):
        raise ValueError(f"{what} do not fit the file's 32-bit integers")


def _entity_name(kind: str, name: str) -> str:
    name = str(name)
    if len(name) > MAX_NAME_LENGTH:
        warnings.warn(
            f"{kind} name {name!r} is longer than {MAX_NAME_LENGTH} characters; Exodus keeps "
            f"{name[:MAX_NAME_LENGTH]!r}",
            stacklevel=3,
        )
        name = name[:MAX_NAME_LENGTH]
    return name


class ExodusWriter:
    """Writes one Exodus II result file, step by step.

    Parameters
    ----------
    path: the file to write; an existing file is overwritten (here, at construction).
    coords: (num_nodes, 3) reference coordinates **x** in mothership order [length unit]; None
        for a file whose mesh data are written later in slices (:meth:`write_nodes`,
        :meth:`write_block`, :meth:`write_node_set`): ``num_nodes`` is then given, node_num_map
        is None, and blocks and node sets carry their sizes instead of their indices.
    node_num_map: (num_nodes,) 1-based node IDs (GID + 1) in mothership order.
    blocks: the element blocks, in block order; together they list each node once.
    node_sets: (name, node indices) pairs in the order to write (IDs 1, 2, ...); indices are
        0-based node positions, in stored order, duplicates kept.
    nodal_vars, element_vars, global_vars: variable names, already expanded (``DisplacementX``),
        at most 32 characters each, in output order.
    truth_table: (num_blocks, num_element_vars) bool, which block carries which element variable;
        default all True. Rows of empty blocks are written as 0.
    title: the ``title`` attribute.
    auxiliary: (variable name, dimension name, values) of int32 variables outside Exodus's own
        (a piece's node order, ``exodus_merge``), over one of the file's dimensions.
    program: the QA record's program name; the QA version is peridyn's version.

    The file is complete and readable after construction (0 steps) and after each
    :meth:`write_step`. Use as a context manager or call :meth:`close`.
    """

    def __init__(
        self,
        path: str | Path,
        *,
        coords: np.ndarray,
        node_num_map: np.ndarray,
        blocks: Sequence[ExodusBlock],
        node_sets: Sequence[tuple[str, np.ndarray]] = (),
        nodal_vars: Sequence[str] = (),
        element_vars: Sequence[str] = (),
        global_vars: Sequence[str] = (),
        truth_table: np.ndarray | None = None,
        title: str = "Peridigm",
        program: str = "peridyn",
        append_after: int | None = None,
        num_nodes: int | None = None,
        auxiliary: Sequence[tuple[str, str, np.ndarray]] = (),
    ) -> None:
        self.path = Path(path)
        self.auxiliary = [(name, dim, np.asarray(values)) for name, dim, values in auxiliary]
        #: the mesh data (coordinates, maps, connectivity, node sets) come later, in slices
        self.deferred = coords is None
        if self.deferred:
            if num_nodes is None:
                raise ValueError("a writer without coords needs num_nodes")
            n = int(num_nodes)
        else:
            coords = np.asarray(coords, dtype=np.float64)
            if coords.ndim != 2 or coords.shape[1] != 3:
                raise ValueError(f"coords must have shape (n, 3), got {coords.shape}")
            n = coords.shape[0]
            node_num_map = np.asarray(node_num_map)
            if node_num_map.shape != (n,):
                raise ValueError(f"node_num_map must have shape ({n},), got {node_num_map.shape}")
            _check_int32("node_num_map", node_num_map)
        if n == 0:
            raise ValueError("an Exodus file needs at least one node")
        if not blocks:
            raise ValueError("an Exodus file needs at least one element block")
        self.num_nodes = n

        def entries(given) -> np.ndarray | int:
            if self.deferred:
                return int(given)
            idx = np.asarray(given, dtype=np.int64).reshape(-1)
            return idx

        self.blocks = [ExodusBlock(int(b.block_id), _entity_name("block", b.name), entries(b.nodes)) for b in blocks]
        _check_int32("block IDs", np.array([b.block_id for b in self.blocks]))
        if not self.deferred:
            for b in self.blocks:
                if b.size and (b.nodes.min() < 0 or b.nodes.max() >= n):
                    raise ValueError(f"block {b.block_id}: node index out of range [0, {n})")
        ids = [b.block_id for b in self.blocks]
        if len(set(ids)) != len(ids):
            raise ValueError(f"duplicate block IDs: {ids}")
        sets = []
        for name, idx in node_sets:
            idx = entries(idx)
            if not self.deferred and idx.size and (idx.min() < 0 or idx.max() >= n):
                raise ValueError(f"node set {name!r}: node index out of range [0, {n})")
            sets.append((_entity_name("node set", name), idx))
        self.node_sets = sets
        #: each block's first position in elem_num_map
        self.block_starts = np.concatenate([[0], np.cumsum([b.size for b in self.blocks])]).astype(np.int64)
        self.nodal_vars = _check_var_names("nodal", nodal_vars)
        self.element_vars = _check_var_names("element", element_vars)
        self.global_vars = _check_var_names("global", global_vars)
        nb, ne = len(self.blocks), len(self.element_vars)
        if truth_table is None:
            tab = np.ones((nb, ne), dtype=bool)
        else:
            tab = np.asarray(truth_table, dtype=bool)
            if tab.shape != (nb, ne):
                raise ValueError(f"truth_table must have shape ({nb}, {ne}), got {tab.shape}")
            tab = tab.copy()
        for bi, b in enumerate(self.blocks):
            if b.size == 0:
                tab[bi, :] = False  # NULL block: no result variables
        self.truth_table = tab
        self._num_steps = 0
        self._ds: netCDF4.Dataset | None = None
        if append_after is None:
            self._define(coords, node_num_map, title, program)
        else:
            self._reopen(int(append_after))

    # ------------------------------------------------------------------ construction
    @classmethod
    def global_only(
        cls, path: str | Path, global_vars: Sequence[str], title: str = "Peridigm", program: str = "peridyn",
        append_after: int | None = None,
    ) -> "ExodusWriter":
        """Peridigm's ``.h`` layout (``initializeExodusDatabaseWithOnlyGlobalData``): one dummy node
        at the origin, one SPHERE block with ID 1 (no name) holding one element, node and element
        maps ``[1]``, no node sets, only global variables."""
        return cls(
            path,
            coords=np.zeros((1, 3)),
            node_num_map=np.array([1]),
            blocks=[ExodusBlock(1, "", np.array([0]))],
            global_vars=global_vars,
            title=title,
            program=program,
            append_after=append_after,
        )

    def _define(self, coords: np.ndarray, node_num_map: np.ndarray, title: str, program: str) -> None:
        ds = netCDF4.Dataset(str(self.path), "w", format="NETCDF3_64BIT_OFFSET")
        self._ds = ds
        try:
            ds.set_auto_maskandscale(False)
            ds.set_fill_off()  # every record variable is written in full each step
            ds.setncattr("api_version", np.float32(EXODUS_API_VERSION))
            ds.setncattr("version", np.float32(EXODUS_API_VERSION))
            ds.setncattr("floating_point_word_size", np.int32(8))
            ds.setncattr("file_size", np.int32(1))
            ds.setncattr("maximum_name_length", np.int32(MAX_NAME_LENGTH))
            ds.setncattr("int64_status", np.int32(0))
            ds.setncattr("title", str(title)[: _LEN_LINE - 1])

            blocks, sets = self.blocks, self.node_sets
            num_elem = int(self.block_starts[-1])
            ds.createDimension("len_string", _LEN_STRING)
            ds.createDimension("len_line", _LEN_LINE)
            ds.createDimension("four", 4)
            ds.createDimension("len_name", _LEN_NAME)
            ds.createDimension("time_step", None)
            ds.createDimension("num_dim", 3)
            ds.createDimension("num_nodes", self.num_nodes)
            if num_elem:
                ds.createDimension("num_elem", num_elem)
            ds.createDimension("num_el_blk", len(blocks))
            if sets:
                ds.createDimension("num_node_sets", len(sets))
            ds.createDimension("num_qa_rec", 1)
            for k, (_, idx) in enumerate(sets, start=1):
                if _size(idx):
                    ds.createDimension(f"num_nod_ns{k}", _size(idx))
            for b, blk in enumerate(blocks, start=1):
                if blk.size:
                    ds.createDimension(f"num_el_in_blk{b}", blk.size)
                    ds.createDimension(f"num_nod_per_el{b}", 1)
            if self.global_vars:
                ds.createDimension("num_glo_var", len(self.global_vars))
            if self.nodal_vars:
                ds.createDimension("num_nod_var", len(self.nodal_vars))
            if self.element_vars:
                ds.createDimension("num_elem_var", len(self.element_vars))

            f8, i4 = "f8", "i4"
            var = ds.createVariable
            self._time = var("time_whole", f8, ("time_step",))
            var("eb_status", i4, ("num_el_blk",))
            var("eb_prop1", i4, ("num_el_blk",)).setncattr("name", "ID")
            if sets:
                var("ns_status", i4, ("num_node_sets",))
                var("ns_prop1", i4, ("num_node_sets",)).setncattr("name", "ID")
            for c in "xyz":
                var(f"coord{c}", f8, ("num_nodes",))
            var("eb_names", "S1", ("num_el_blk", "len_name"))
            if sets:
                var("ns_names", "S1", ("num_node_sets", "len_name"))
            var("coor_names", "S1", ("num_dim", "len_name"))
            var("qa_records", "S1", ("num_qa_rec", "four", "len_string"))
            for k, (_, idx) in enumerate(sets, start=1):
                if _size(idx):
                    var(f"node_ns{k}", i4, (f"num_nod_ns{k}",))
            for b, blk in enumerate(blocks, start=1):
                if blk.size:
                    conn = var(f"connect{b}", i4, (f"num_el_in_blk{b}", f"num_nod_per_el{b}"))
                    conn.setncattr("elem_type", "SPHERE")
            var("node_num_map", i4, ("num_nodes",))
            if num_elem:
                var("elem_num_map", i4, ("num_elem",))
            if self.global_vars:
                var("name_glo_var", "S1", ("num_glo_var", "len_name"))
                self._glo = var("vals_glo_var", f8, ("time_step", "num_glo_var"))
            self._nod = []
            if self.nodal_vars:
                var("name_nod_var", "S1", ("num_nod_var", "len_name"))
                self._nod = [
                    var(f"vals_nod_var{i}", f8, ("time_step", "num_nodes")) for i in range(1, len(self.nodal_vars) + 1)
                ]
            self._elem: list[list[netCDF4.Variable | None]] = [[None] * len(blocks) for _ in self.element_vars]
            if self.element_vars:
                var("name_elem_var", "S1", ("num_elem_var", "len_name"))
                for b in range(len(blocks)):
                    for i in range(len(self.element_vars)):
                        if self.truth_table[b, i]:
                            dims = ("time_step", f"num_el_in_blk{b + 1}")
                            self._elem[i][b] = var(f"vals_elem_var{i + 1}eb{b + 1}", f8, dims)
                var("elem_var_tab", i4, ("num_el_blk", "num_elem_var"))

            for name, dim, _ in self.auxiliary:
                var(name, i4, (dim,))

            # ---- data (leaves define mode on the first write)
            ds["eb_status"][:] = np.array([1 if b.size else 0 for b in blocks], dtype=np.int32)
            ds["eb_prop1"][:] = np.array([b.block_id for b in blocks], dtype=np.int32)
            if sets:
                ds["ns_status"][:] = np.array([1 if _size(idx) else 0 for _, idx in sets], dtype=np.int32)
                ds["ns_prop1"][:] = np.arange(1, len(sets) + 1, dtype=np.int32)
                ds["ns_names"][:] = _char_array([s for s, _ in sets], _LEN_NAME)
            if not self.deferred:
                for j, c in enumerate("xyz"):
                    ds[f"coord{c}"][:] = coords[:, j]
            ds["eb_names"][:] = _char_array([b.name for b in blocks], _LEN_NAME)
            ds["coor_names"][:] = _char_array(["x", "y", "z"], _LEN_NAME)
            now = _dt.datetime.now()
            qa = [program, _program_version(), now.strftime("%m/%d/%y"), now.strftime("%H:%M:%S")]
            ds["qa_records"][:] = _char_array(qa, _LEN_STRING)[None]
            if not self.deferred:
                for k, (_, idx) in enumerate(sets, start=1):
                    if idx.size:
                        ds[f"node_ns{k}"][:] = (idx + 1).astype(np.int32)
                for b, blk in enumerate(blocks, start=1):
                    if blk.size:
                        ds[f"connect{b}"][:] = (blk.nodes + 1).astype(np.int32)[:, None]
                ds["node_num_map"][:] = node_num_map.astype(np.int32)
                if num_elem:
                    ds["elem_num_map"][:] = np.concatenate([node_num_map[b.nodes] for b in blocks]).astype(np.int32)
            for name, _, values in self.auxiliary:
                _check_int32(name, values)
                ds[name][:] = values.astype(np.int32)
            if self.global_vars:
                ds["name_glo_var"][:] = _char_array(self.global_vars, _LEN_NAME)
            if self.nodal_vars:
                ds["name_nod_var"][:] = _char_array(self.nodal_vars, _LEN_NAME)
            if self.element_vars:
                ds["name_elem_var"][:] = _char_array(self.element_vars, _LEN_NAME)
                ds["elem_var_tab"][:] = self.truth_table.astype(np.int32)
            ds.sync()
        except BaseException:
            ds.close()
            self._ds = None
            raise

    def _reopen(self, steps: int) -> None:
        """Open the existing file to append after its first ``steps`` steps (a restarted run,
        docs/restart.md): its steps beyond them are dropped by :func:`keep_steps` before.
        ValueError when the file does not hold the variables this writer would write."""
        ds = netCDF4.Dataset(str(self.path), "a")
        try:
            ds.set_auto_maskandscale(False)
            ds.set_fill_off()
            have = len(ds.dimensions["time_step"])
            if have != steps:
                raise ValueError(f"{self.path.name} holds {have} steps, not the {steps} to append after")

            def names(var: str) -> list[str]:
                if var not in ds.variables:
                    return []
                return [bytes(row).rstrip(b"\0").decode("ascii", "replace") for row in ds[var][:]]

            for kind, var, declared in (("nodal", "name_nod_var", self.nodal_vars), ("element", "name_elem_var", self.element_vars),
                                        ("global", "name_glo_var", self.global_vars)):
                found = names(var)
                if found != list(declared):
                    raise ValueError(f"{self.path.name} holds the {kind} variables {found}, not {list(declared)}")
            if int(ds.dimensions["num_nodes"].size) != self.num_nodes:
                raise ValueError(f"{self.path.name} has {ds.dimensions['num_nodes'].size} nodes, not {self.num_nodes}")
            self._time = ds["time_whole"]
            self._glo = ds["vals_glo_var"] if self.global_vars else None
            self._nod = [ds[f"vals_nod_var{i}"] for i in range(1, len(self.nodal_vars) + 1)]
            self._elem = [[ds[f"vals_elem_var{i + 1}eb{b + 1}"] if self.truth_table[b, i] else None for b in range(len(self.blocks))]
                          for i in range(len(self.element_vars))]
        except BaseException:
            ds.close()
            raise
        self._ds = ds
        self._num_steps = steps

    # ------------------------------------------------------------------ writing
    @property
    def num_steps(self) -> int:
        """Number of time steps written so far."""
        return self._num_steps

    def write_step(
        self,
        time: float,
        nodal: Mapping[str, np.ndarray] = {},  # noqa: B006 - read only
        element: Mapping[str, Sequence[np.ndarray | None]] = {},  # noqa: B006
        glob: Mapping[str, float] = {},  # noqa: B006
    ) -> None:
        """Append one time step and make the file readable.

        Parameters
        ----------
        time: the step's time value [time unit].
        nodal: every declared nodal variable -> (num_nodes,) values in node (mothership) order.
        element: every declared element variable -> one entry per block, in block order: a
            (num_el_in_blk,) array in block order, or None where the truth table is 0.
        glob: every declared global variable -> its scalar value.

        All values are stored as float64. Missing or unknown names raise ``ValueError`` before
        anything is written.
        """
        ds = self._ds
        if ds is None:
            raise ValueError(f"{self.path}: the Exodus writer is closed")
        n = self.num_nodes
        for kind, given, declared in (
            ("nodal", nodal, self.nodal_vars),
            ("element", element, self.element_vars),
            ("global", glob, self.global_vars),
        ):
            missing = [v for v in declared if v not in given]
            unknown = [v for v in given if v not in declared]
            if missing or unknown:
                what = [f"missing {missing}"] if missing else []
                what += [f"not declared {unknown}"] if unknown else []
                raise ValueError(f"{self.path}: {kind} variables " + "; ".join(what))
        nod_vals = []
        for name in self.nodal_vars:
            a = np.asarray(nodal[name], dtype=np.float64)
            if a.shape != (n,):
                raise ValueError(f"nodal variable {name}: expected shape ({n},), got {a.shape}")
            nod_vals.append(a)
        elem_vals = []
        for i, name in enumerate(self.element_vars):
            per_block = element[name]
            if len(per_block) != len(self.blocks):
                raise ValueError(
                    f"element variable {name}: expected {len(self.blocks)} block entries, got {len(per_block)}"
                )
            row = []
            for b, (blk, a) in enumerate(zip(self.blocks, per_block)):
                if not self.truth_table[b, i]:
                    if a is not None and np.size(a) != 0:
                        raise ValueError(
                            f"element variable {name}: block {blk.block_id} has truth-table 0 but values were given"
                        )
                    row.append(None)
                    continue
                if a is None:
                    raise ValueError(f"element variable {name}: no values for block {blk.block_id}")
                a = np.asarray(a, dtype=np.float64)
                if a.shape != (blk.size,):
                    raise ValueError(
                        f"element variable {name}, block {blk.block_id}: expected shape ({blk.size},), got {a.shape}"
                    )
                row.append(a)
            elem_vals.append(row)
        glo_vals = np.array([float(glob[g]) for g in self.global_vars], dtype=np.float64)

        k = self._num_steps
        for v, a in zip(self._nod, nod_vals):
            v[k, :] = a
        for i, row in enumerate(elem_vals):
            for b, a in enumerate(row):
                if a is not None:
                    self._elem[i][b][k, :] = a
        if self.global_vars:
            self._glo[k, :] = glo_vals
        self._time[k] = float(time)
        ds.sync()
        self._num_steps = k + 1

    # ------------------------------------------------------------------ slices (a deferred writer's)
    def write_nodes(self, start: int, coords: np.ndarray, node_num_map: np.ndarray) -> None:
        """Nodes start..start + len(coords): their (m, 3) coordinates and 1-based IDs."""
        ds = self._open_ds()
        stop = start + len(coords)
        for j, c in enumerate("xyz"):
            ds[f"coord{c}"][start:stop] = coords[:, j]
        _check_int32("node_num_map", node_num_map)
        ds["node_num_map"][start:stop] = np.asarray(node_num_map).astype(np.int32)

    def write_block(self, b: int, start: int, nodes: np.ndarray, node_num_map: np.ndarray) -> None:
        """Elements start..start + len(nodes) of block ``b`` (0-based): their 0-based nodes and
        the 1-based IDs of those nodes (``elem_num_map``)."""
        ds = self._open_ds()
        stop = start + len(nodes)
        ds[f"connect{b + 1}"][start:stop] = (np.asarray(nodes) + 1).astype(np.int32)[:, None]
        at = int(self.block_starts[b])
        ds["elem_num_map"][at + start:at + stop] = np.asarray(node_num_map).astype(np.int32)

    def write_node_set(self, k: int, start: int, nodes: np.ndarray) -> None:
        """Entries start..start + len(nodes) of node set ``k`` (0-based): 0-based nodes."""
        self._open_ds()[f"node_ns{k + 1}"][start:start + len(nodes)] = (np.asarray(nodes) + 1).astype(np.int32)

    def write_nodal_slice(self, step: int, i: int, start: int, values: np.ndarray) -> None:
        """Nodes start..start + len(values) of nodal variable ``i`` at ``step`` (0-based)."""
        self._nod[i][step, start:start + len(values)] = values

    def write_element_slice(self, step: int, i: int, b: int, start: int, values: np.ndarray) -> None:
        """Elements start..start + len(values) of element variable ``i`` in block ``b``."""
        self._elem[i][b][step, start:start + len(values)] = values

    def end_step(self, step: int, time: float, glob: Sequence[float]) -> None:
        """Finish step ``step`` (the next one, its slices written): its time and global values;
        the file is readable with it."""
        if step != self._num_steps:
            raise ValueError(f"{self.path}: step {step} ended after {self._num_steps}")
        if self.global_vars:
            self._glo[step, :] = np.asarray(glob, dtype=np.float64)
        self._time[step] = float(time)
        self._open_ds().sync()
        self._num_steps = step + 1

    def set_attribute(self, name: str, value: int) -> None:
        """A global int32 attribute outside Exodus's own (a piece's frames to follow)."""
        ds = self._open_ds()
        ds.setncattr(name, np.int32(value))
        ds.sync()

    def _open_ds(self) -> netCDF4.Dataset:
        if self._ds is None:
            raise ValueError(f"{self.path}: the Exodus writer is closed")
        return self._ds

    def close(self) -> None:
        """Close the file (idempotent)."""
        if self._ds is not None:
            self._ds.close()
            self._ds = None

    def __enter__(self) -> "ExodusWriter":
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def __del__(self) -> None:  # pragma: no cover - best effort
        try:
            self.close()
        except Exception:
            pass


def keep_steps(path: str | Path, steps: int) -> int:
    """Drop the steps of an Exodus file beyond its first ``steps`` (a restarted run appends after
    them): the record count in the classic netCDF header (bytes 4-7, big endian, of a CDF-1 or
    CDF-2 file) is set to ``steps`` and the file is flushed to disk; the data of the dropped
    steps stays in the file until overwritten, unseen by any reader. Returns the number of steps
    the file held. ValueError for a file that is not classic netCDF or holds fewer steps."""
    import os

    path = Path(path)
    with open(path, "r+b") as fh:
        head = fh.read(8)
        if len(head) < 8 or head[:3] != b"CDF" or head[3] not in (1, 2):
            raise ValueError(f"{path.name} is not a classic netCDF (Exodus) file")
        held = int.from_bytes(head[4:8], "big")
        if held == 0xFFFFFFFF:  # "streaming": the count was never written
            with netCDF4.Dataset(str(path)) as ds:
                held = len(ds.dimensions["time_step"])
        if held < steps:
            raise ValueError(f"{path.name} holds {held} steps, fewer than the {steps} the checkpoint wrote")
        if held != steps:
            fh.seek(4)
            fh.write(int(steps).to_bytes(4, "big"))
            fh.flush()
            os.fsync(fh.fileno())
    return held
