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

from ..core.discretization import Discretization, DiscretizationPart, DiscretizationReader
from ..core.params import ModelParams
from ..core.errors import InputError, is_file, missing_file
from .exodus_elements import (
    SUPPORTED_ELEMENT_TYPES,
    first_occurrences,
    hex_centroid_and_volume,
    node_set_pairs,
    read_elements,
    tet_centroid_and_volume,
)
from .exodus_pieces import find_pieces, piece_counts, piece_path, read_exodus_piece
from .nodesets import find_input_file

__all__ = [
    "ExodusMesh",
    "ExodusMeshParams",
    "read_exodus_mesh",
    "hex_centroid_and_volume",
    "tet_centroid_and_volume",
    "SUPPORTED_ELEMENT_TYPES",
]


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


def _read_dataset(ds, file: str) -> Discretization:
    disc, conn_parts, num_nodes = read_elements(ds, file)
    disc.node_sets = _node_sets(ds, file, num_nodes, conn_parts)
    return disc


def _node_sets(ds, file: str, num_nodes: int, conn_parts: list[np.ndarray]) -> dict[str, np.ndarray]:
    """Exodus node sets -> point sets (mothership indices, Peridigm's order, no duplicates)."""
    return {name: first_occurrences(elements) for name, (_, elements) in node_set_pairs(ds, file, num_nodes, conn_parts).items()}


class ExodusMesh(DiscretizationReader):
    """Points from the elements of an Exodus II mesh (``Type: Exodus``)."""

    name = "Exodus"
    Params = ExodusMeshParams
    supports_bond_filters = True

    def read(self) -> Discretization:
        params: ExodusMeshParams = self.params  # type: ignore[assignment]
        path = find_input_file(params.input_mesh_file, self.deck_dir)
        if not is_file(path):
            counts = piece_counts(params.input_mesh_file, self.deck_dir)
            if counts:
                raise InputError(
                    f"mesh file {path.name!r} not found; there are pieces of it for {' or '.join(map(str, counts))} ranks",
                    path=("Discretization", "Input Mesh File"),
                    fix=f"run on that many ranks (mpiexec -n {counts[0]} peridyn run ...), or give the whole mesh")
        return self._flags(read_exodus_mesh(path))

    def read_part(self, rank: int, size: int) -> DiscretizationPart | None:
        """Rank ``rank``'s piece ``NAME.N.r`` of a pre-split mesh, where all ``size`` pieces
        exist (see :mod:`peridyn.io.exodus_pieces`); else None."""
        params: ExodusMeshParams = self.params  # type: ignore[assignment]
        base = find_pieces(params.input_mesh_file, self.deck_dir, size)
        if base is None:
            return None
        path = piece_path(base, size, rank)
        part = read_exodus_piece(path)
        self._flags(part.points)
        if params.compute_element_horizon_intersections:
            from .interfaces import hex_nodes_of

            part.points.element_nodes = hex_nodes_of(path, part.points.num_points)
        return part

    def _flags(self, disc: Discretization) -> Discretization:
        params: ExodusMeshParams = self.params  # type: ignore[assignment]
        disc.construct_interfaces = params.construct_interfaces
        disc.element_horizon_intersections = params.compute_element_horizon_intersections
        return disc

