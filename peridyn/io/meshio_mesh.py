"""``Mesh`` discretization: one peridynamic point per volume element of any mesh meshio reads.

Gmsh ``.msh``, Abaqus ``.inp``, VTK ``.vtu``/``.vtk``, MED ``.med`` (needs h5py), Exodus, Nastran,
... and gmsh ``.geo`` geometry, meshed on the fly by the gmsh Python API in a child process
(:mod:`peridyn.io.geo_mesh`). meshio (and gmsh for
``.geo``) are optional: ``pip install "peridyn[mesh]"``; they are imported only when a deck uses
this discretization. docs/meshes.md is the user's guide.

* **Points**: the volume elements (tetra, hexahedron, wedge, pyramid, of any order: a quadratic
  element by its corner nodes), in file order (meshio's cell blocks, elements in order); gid
  0..n-1. x = exact volume centroid, volume = exact volume of the element through its corners
  (:mod:`peridyn.io.element_geometry`). Surface, line and vertex cells are not points.
* **Blocks**: with gmsh physical groups (cell data ``gmsh:physical``), each physical volume is a
  block: Block_Id = its tag, named by its physical name or ``block_<tag>``. Otherwise each cell
  set holding volume elements (Abaqus ``*ELSET``, ...) is a block, ids 1, 2, ... in file order,
  named by the set. Volume elements in no group form one more block, id one above the largest
  (``block_1`` for a mesh without groups).
* **Node sets**: each group of lower-dimensional cells (a physical surface, curve or point; a
  cell set without volume elements) and each point set (Abaqus ``*NSET``) is a node set: the
  points whose element has at least one node among the group's nodes (the Exodus rule), in
  ascending point order. Named by the group's name, else ``surface_<tag>``, ``curve_<tag>``,
  ``point_<tag>``. A named volume group is also the node set of its points (an initial velocity
  or a grip on a whole part).
"""
from __future__ import annotations

import contextlib
import importlib
import importlib.util
import io
import logging
import re
import tempfile
from pathlib import Path

import numpy as np
from pydantic import Field, field_validator, model_validator

from ..core.discretization import Discretization
from ..core.errors import InputError, is_file, missing_file
from ..core.discretization import DiscretizationReader
from ..core.params import ModelParams, ParamKeyError
from .element_geometry import CORNERS, bad_elements, element_centroids_and_volumes
from .geo_mesh import mesh_geo
from .nodesets import find_input_file
from .textfile import min_element_radius

__all__ = ["Mesh", "MeshParams", "read_mesh", "INSTALL"]

_log = logging.getLogger(__name__)

INSTALL = 'pip install "peridyn[mesh]"'
_PATH = ("Discretization", "Input Mesh File")
_VOLUME = re.compile(r"(tetra|hexahedron|wedge|pyramid)[0-9]*")
_LOWER = re.compile(r"(vertex|line[0-9]*|triangle[0-9]*|quad[0-9]*|polygon[0-9]*)")
_DIM_WORD = {0: "point", 1: "curve", 2: "surface"}


def _missing(module: str) -> bool:
    """Whether ``module`` cannot be imported (also when it is hidden as ``sys.modules[m] = None``)."""
    try:
        return importlib.util.find_spec(module) is None
    except (ImportError, ValueError):
        return True


class MeshParams(ModelParams):
    """``Discretization`` section of ``Type: Mesh`` (besides the shared keys)."""

    input_mesh_file: str = Field(
        alias="Input Mesh File",
        description="Volume mesh any meshio reads (.msh, .inp, .vtu, .vtk, .med, ...) or gmsh geometry (.geo), "
        "relative to the deck's folder; its coordinates times Length Scale are lengths in L.",
    )
    length_scale: float = Field(
        1.0, alias="Length Scale", gt=0,
        description="Factor from the file's length unit to the deck's length unit L, e.g. 0.001 for a mesh in mm in an "
        "SI deck (dimensionless).",
    )
    mesh_size: float | None = Field(
        None, alias="Mesh Size", gt=0,
        description=".geo input only: gmsh's largest element size, Mesh.MeshSizeMax (length unit of the .geo file); "
        "default: the sizes the .geo sets.",
    )

    @field_validator("input_mesh_file")
    @classmethod
    def _readers_installed(cls, value: str) -> str:
        needs = ["meshio"] + (["gmsh"] if value.lower().endswith(".geo") else [])
        absent = [m for m in needs if _missing(m)]
        if absent:
            raise ValueError(
                f"mesh {value!r} needs {' and '.join(absent)}, which {'is' if len(absent) == 1 else 'are'} not installed; "
                f"install with: {INSTALL}"
            )
        return value

    @model_validator(mode="after")
    def _size_for_geo(self) -> MeshParams:
        if self.mesh_size is not None and not self.input_mesh_file.lower().endswith(".geo"):
            raise ParamKeyError("Mesh Size", "'Mesh Size' applies only to .geo input (gmsh meshes it); remove it for a mesh file")
        return self


# ------------------------------------------------------------------------------------------------
# Reading
# ------------------------------------------------------------------------------------------------
def _fail(message: str, path: Path, fix: str | None = None) -> InputError:
    return InputError(message, file=str(path), path=_PATH, fix=fix)


def _import(module: str, path: Path):
    """``module``, or InputError with the install command when it (or a library it needs) is missing."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise _fail(f"mesh {path.name!r} needs {module}, which cannot be imported ({exc})", path, INSTALL) from None
    except OSError as exc:  # gmsh's shared library or one it links
        raise _fail(f"mesh {path.name!r} needs {module}, which cannot be loaded ({exc})", path, INSTALL) from None


def _has_content(path: Path) -> bool:
    """Whether the file holds a line that is neither blank nor a ``#`` comment (meshio's text
    readers skip such lines and never stop at the end of a file that has nothing else)."""
    comment = False  # the line running on from the previous block is a comment
    with open(path, "rb") as handle:
        while block := handle.read(1 << 16):  # blocks, not lines: a binary file may have no newline
            for k, line in enumerate(block.split(b"\n")):
                comment = comment and k == 0
                text = line.lstrip()
                if comment or not text:
                    continue
                if not text.startswith(b"#"):
                    return True
                comment = True
    return False


def _read_meshio(path: Path):
    meshio = _import("meshio", path)

    suffix = "".join(path.suffixes[-2:]) if path.name.lower().endswith(".gz") else path.suffix
    if suffix.lower() not in meshio.extension_to_filetypes:
        known = ", ".join(sorted(set(meshio.extension_to_filetypes) | {".geo"}))
        raise _fail(f"unknown mesh format {suffix or '(no extension)'!r} of {path.name!r}", path, f"give one of: {known}")
    companions = [path.with_suffix(s) for s in (".node", ".ele")] if suffix.lower() in (".node", ".ele") else [path]  # tetgen's pair
    for part in companions:
        if is_file(part) and not _has_content(part):
            raise _fail(f"mesh file {part.name!r} is empty (no line but blank lines and # comments)", path,
                        "regenerate or re-export the mesh")
    failure = ""
    for fmt in meshio.extension_to_filetypes[suffix.lower()]:  # e.g. .msh: ansys, then gmsh
        chatter = io.StringIO()
        try:
            with contextlib.redirect_stdout(chatter), contextlib.redirect_stderr(chatter):
                mesh = meshio.read(str(path), file_format=fmt)
        except ModuleNotFoundError as exc:
            raise _fail(f"reading {path.name!r} needs the Python package {exc.name!r}", path, f"pip install {exc.name}") from None
        except (Exception, SystemExit) as exc:  # meshio's readers fail with anything on a bad file
            said = [line for line in chatter.getvalue().splitlines() if line.strip()]
            failure = f"{type(exc).__name__}: {str(exc)[:80]}" if not isinstance(exc, SystemExit) or not said else said[-1][:80]
            continue
        finally:
            if chatter.getvalue().strip():
                _log.debug("meshio (%s) on %s: %s", fmt, path.name, chatter.getvalue().strip())
        return mesh
    raise _fail(f"mesh file {path.name!r} is not a readable {suffix} file ({failure})", path, "regenerate or re-export the mesh")


def read_mesh(path: Path | str, *, length_scale: float = 1.0, mesh_size: float | None = None) -> Discretization:
    """Read a mesh (or mesh a ``.geo``) into points, one per volume element (module docstring).

    Returns a :class:`Discretization`: x (n, 3) centroids (L), volume (n,) (L^3), block ids and
    names, gid 0..n-1, node sets (int64 point indices, ascending).

    Raises
    ------
    InputError: missing file, unknown format, an empty, unreadable or malformed file, no volume
        elements, an unsupported cell type, an inverted or degenerate element, clashing group
        names; for a .geo, everything :func:`peridyn.io.geo_mesh.mesh_geo` refuses.
    """
    path = Path(path)
    if not is_file(path):
        raise _fail(missing_file(path, "mesh file"), path, "check the file name; relative names are relative to the deck's folder")
    if path.suffix.lower() == ".geo":
        with tempfile.TemporaryDirectory(prefix="peridyn-geo-") as folder:
            made = mesh_geo(path, mesh_size, Path(folder))
            try:
                mesh = _read_meshio(made)
            except InputError as exc:  # name the .geo, not a temporary file
                raise _fail(f"the mesh gmsh made of {path.name!r} cannot be read ({exc.message})", path,
                            "mesh into tetrahedra, hexahedra, prisms or pyramids of an order meshio knows") from None
    else:
        mesh = _read_meshio(path)
    return _points(mesh, path, length_scale)


def _check_structure(mesh, path: Path) -> list[np.ndarray]:
    """The connectivity of each cell block as an (n, k) int64 array; InputError for what a
    reader returns from an empty, truncated or garbled file: no nodes, coordinates that are not
    numbers, cell blocks or cell data that do not fit together."""
    def malformed(what: str) -> InputError:
        return _fail(f"mesh file {path.name!r} is malformed: {what}", path, "regenerate or re-export the mesh")

    try:
        pts = np.asarray(mesh.points, dtype=np.float64)
    except (TypeError, ValueError):
        raise malformed("its node coordinates are not numbers") from None
    if pts.size == 0:
        raise _fail(f"mesh file {path.name!r} has no nodes (an empty or truncated file?)", path, "regenerate or re-export the mesh")
    if pts.ndim not in (1, 2) or (pts.ndim == 2 and pts.shape[1] == 0):
        raise malformed(f"its node coordinates have the shape {pts.shape}")
    conns = []
    physical = mesh.cell_data.get("gmsh:physical")
    if physical is not None and len(physical) != len(mesh.cells):
        raise malformed(f"its gmsh:physical tags are given for {len(physical)} of {len(mesh.cells)} cell blocks")
    for b, block in enumerate(mesh.cells):
        try:
            conn = np.asarray(block.data, dtype=np.int64)
        except (TypeError, ValueError, OverflowError):
            raise _fail(f"unsupported cell type {block.type!r} in {path.name!r} (cells of varying size)", path,
                        "use tetra, hexahedron, wedge or pyramid elements (any order)") from None
        if conn.size and (conn.ndim != 2 or conn.shape[1] == 0):
            raise malformed(f"its {block.type} cells have the shape {conn.shape}")
        conn = conn.reshape(len(conn), -1) if conn.size else conn.reshape(0, 1)
        if physical is not None and np.asarray(physical[b]).size != len(conn):
            raise malformed(f"cell block {b + 1} has {len(conn)} {block.type} cells but {np.asarray(physical[b]).size} gmsh:physical tags")
        for name, rows in mesh.cell_sets.items() if physical is None else ():
            if name.startswith("gmsh:"):
                continue
            if b < len(rows) and rows[b] is not None and len(rows[b]):
                r = np.asarray(rows[b])
                if not np.issubdtype(r.dtype, np.integer) or r.min() < 0 or r.max() >= len(conn):
                    raise malformed(f"cell set {name!r} refers to a cell that block {b + 1} does not have")
        conns.append(conn)
    return conns


def _points(mesh, path: Path, scale: float) -> Discretization:  # noqa: C901 - one pass over the cell blocks
    block_conns = _check_structure(mesh, path)
    coords = np.zeros((len(mesh.points), 3))
    pts = np.asarray(mesh.points, dtype=np.float64).reshape(len(mesh.points), -1)
    coords[:, : min(3, pts.shape[1])] = pts[:, :3] * scale
    if not np.all(np.isfinite(coords)):
        raise _fail(f"mesh file {path.name!r} has non-finite node coordinates", path)
    physical = mesh.cell_data.get("gmsh:physical")
    names = {(int(dim), int(tag)): name for name, (tag, dim, *_) in _field_data(mesh).items()}
    cell_sets = {k: v for k, v in mesh.cell_sets.items() if not k.startswith("gmsh:")} if physical is None else {}

    xs, vols, conns, tags, set_rows = [], [], [], [], []  # per volume cell block
    lower_groups: dict[str, list[np.ndarray]] = {}  # node set name -> node index arrays
    first = 0
    for b, block in enumerate(mesh.cells):
        kind = block.type
        conn = block_conns[b]
        if len(conn) == 0:
            continue
        if conn.min() < 0 or conn.max() >= len(coords):
            raise _fail(f"{kind} cells of {path.name!r} refer to a node that does not exist", path)
        tag = None if physical is None else np.asarray(physical[b], dtype=np.int64).ravel()
        match = _VOLUME.fullmatch(kind)
        if match is None:
            if _LOWER.fullmatch(kind) is None:
                raise _fail(f"unsupported cell type {kind!r} in {path.name!r}", path,
                            "use tetra, hexahedron, wedge or pyramid elements (any order)")
            dim = 0 if kind == "vertex" else 1 if kind.startswith("line") else 2
            if tag is not None:
                for t in np.unique(tag[tag > 0]):
                    name = names.get((dim, int(t)), f"{_DIM_WORD[dim]}_{int(t)}")
                    lower_groups.setdefault(name, []).append(conn[tag == t].ravel())
            for name, rows in cell_sets.items():
                if b < len(rows) and rows[b] is not None and len(rows[b]):
                    lower_groups.setdefault(name, []).append(conn[np.asarray(rows[b], dtype=np.int64)].ravel())
            continue
        family = match.group(1)
        corners = conn[:, : CORNERS[family]]
        if conn.shape[1] < CORNERS[family]:
            raise _fail(f"{kind} cells of {path.name!r} have {conn.shape[1]} nodes, fewer than the {CORNERS[family]} corners", path)
        xyz = coords[corners]
        x, v = element_centroids_and_volumes(family, xyz)
        if not np.all(np.isfinite(v)):
            raise _fail(f"the {kind} elements of {path.name!r} have volumes too large for double precision", path,
                        "check 'Length Scale' and the file's coordinates")
        bad = bad_elements(family, xyz, v)
        if bad.size:
            e = int(bad[0])
            raise _fail(
                f"{kind} element {e + 1} of cell block {b + 1} (point {first + e + 1}) in {path.name!r} is "
                f"{'inverted' if v[e] < 0 else 'degenerate'} (volume {v[e]:.4g}); {bad.size} bad element(s) in the block",
                path, "check the element's node order and that it is not flat",
            )
        xs.append(x)
        vols.append(v)
        conns.append(conn)
        tags.append(tag)
        set_rows.append({name: rows[b] for name, rows in cell_sets.items() if b < len(rows) and rows[b] is not None and len(rows[b])})
        first += len(conn)
    if first == 0:
        raise _fail(f"mesh file {path.name!r} has no volume elements (tetra, hexahedron, wedge, pyramid)", path,
                    "mesh the volume (in gmsh: Mesh > 3D, or generate(3)), not only its surface")

    block_id, block_names = _blocks(tags, set_rows, [len(c) for c in conns], names, path)
    node_sets = _node_sets(lower_groups, mesh.point_sets, conns, len(coords), path)
    for bid, name in block_names.items():
        if name != f"block_{bid}":  # a named volume group is also the node set of its points
            if name in node_sets:
                raise _fail(f"{path.name!r} names both a volume group and a surface, curve or point group {name!r}", path,
                            "rename one of them")
            node_sets[name] = np.flatnonzero(block_id == bid).astype(np.int64)
    volume = np.concatenate(vols)
    return Discretization(
        x=np.ascontiguousarray(np.concatenate(xs)),
        volume=volume,
        block_id=block_id,
        gid=np.arange(first, dtype=np.int64),
        block_names=block_names,
        node_sets=node_sets,
        min_element_radius=min_element_radius(volume),
        neighbor_rule=None,
        source=str(path),
    )


def _field_data(mesh) -> dict:
    """gmsh physical names: name -> (tag, dim); other field data is skipped."""
    out = {}
    for name, value in mesh.field_data.items():
        arr = np.asarray(value).ravel()
        if arr.size == 2 and np.issubdtype(arr.dtype, np.integer):
            out[name] = (int(arr[0]), int(arr[1]))
    return out


def _blocks(tags, set_rows, sizes, names, path) -> tuple[np.ndarray, dict[int, str]]:
    """Block id of every point and the block names (module docstring)."""
    n = sum(sizes)
    block_id = np.zeros(n, dtype=np.int64)  # 0: in no group yet
    block_names: dict[int, str] = {}
    if tags[0] is not None:
        tag = np.concatenate(tags)
        if tag.min() < 0:
            raise _fail(f"a volume element of {path.name!r} has the negative physical tag {int(tag.min())}", path)
        for t in np.unique(tag[tag > 0]):
            block_names[int(t)] = names.get((3, int(t)), f"block_{int(t)}")
        block_id[:] = tag
    else:
        order = [name for rows in set_rows for name in rows]
        set_names = list(dict.fromkeys(order))  # file order of the sets with volume elements
        owner = np.full(n, "", dtype=object)
        for k, name in enumerate(set_names, start=1):
            start = 0
            for rows, size in zip(set_rows, sizes):
                members = np.asarray(rows.get(name, ()), dtype=np.int64) + start
                clash = members[owner[members] != ""]
                if clash.size:
                    raise _fail(
                        f"cell sets {owner[clash[0]]!r} and {name!r} share element(s), e.g. point {int(clash[0]) + 1}; "
                        "each volume element must be in one block", path, "remove overlapping element sets from the mesh",
                    )
                owner[members] = name
                block_id[members] = k
                start += size
            block_names[k] = name
    if np.any(block_id == 0):
        extra = max(block_names, default=0) + 1
        block_id[block_id == 0] = extra
        block_names[extra] = f"block_{extra}"
        if len(block_names) > 1:
            _log.info("%s: %d volume element(s) in no group form block_%d", path.name, int(np.sum(block_id == extra)), extra)
    if len(set(block_names.values())) != len(block_names):
        raise _fail(f"two blocks of {path.name!r} have the same name", path, "give every volume group its own name")
    return block_id, dict(sorted(block_names.items()))


def _node_sets(lower_groups, point_sets, conns, num_nodes, path) -> dict[str, np.ndarray]:
    """Points whose element has a node in each group (ascending point indices)."""
    groups = {name: np.concatenate(parts) for name, parts in lower_groups.items()}
    for name, nodes in point_sets.items():
        if name in groups:
            raise _fail(f"{path.name!r} names both a cell group and a point set {name!r}", path, "rename one of them")
        groups[name] = np.asarray(nodes, dtype=np.int64).ravel()
    result: dict[str, np.ndarray] = {}
    for name, nodes in groups.items():
        if nodes.size and (nodes.min() < 0 or nodes.max() >= num_nodes):
            raise _fail(f"group {name!r} of {path.name!r} refers to a node that does not exist", path)
        marked = np.zeros(num_nodes, dtype=bool)
        marked[nodes] = True
        hit = np.concatenate([marked[conn].any(axis=1) for conn in conns])
        result[name] = np.flatnonzero(hit).astype(np.int64)
    return result


class Mesh(DiscretizationReader):
    """Points from the volume elements of a mesh meshio reads, or of a gmsh .geo (``Type: Mesh``)."""

    name = "Mesh"
    Params = MeshParams
    supports_bond_filters = True

    def read(self) -> Discretization:
        params: MeshParams = self.params  # type: ignore[assignment]
        path = find_input_file(params.input_mesh_file, self.deck_dir)
        return read_mesh(path, length_scale=params.length_scale, mesh_size=params.mesh_size)
