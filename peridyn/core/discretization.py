"""The discretization: points, volumes, blocks and mesh node sets, as a reader produced them.

Everything here is in *mothership order* (Peridigm's word): the order of the mesh file or the
generator, which is also the node order of the output file. The engine later reorders points
for memory locality; that order never leaks into output.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np

from .params import ModelParams

#: builds candidate neighbor lists for a grid generator. Called as ``rule(points, horizon)`` with
#: ``points`` the mothership indices (int64, shape (k,)) whose lists are wanted and ``horizon``
#: the horizon of every point (float64, shape (n,), metres). Returns ``(offsets, neighbors)``:
#: CSR in the order of ``points``, ``offsets`` int64 of shape (k+1,), ``neighbors`` integer
#: (int32 where the indices fit) mothership indices, each list in ascending global-id order,
#: the point itself excluded.
NeighborRule = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass
class Discretization:
    """Points of a model in mothership order.

    Attributes
    ----------
    x: (n, 3) float64 reference positions (element centroids for meshes), length units of the deck.
    volume: (n,) float64 cell volumes.
    block_id: (n,) int64 block id of every point (the number in ``block_<id>``).
    gid: (n,) int64 0-based global ids (Peridigm's GIDs; Element_Id = gid + 1 in output).
    block_names: block id -> block name as the mesh names it (``block_<id>`` when unnamed).
    node_sets: node sets the mesh defines, by their raw names (``nodelist_1``), each an int64
        array of mothership indices in Peridigm's order, without duplicates.
    min_element_radius: min over points of (3 V / 4 pi)^(1/3), Peridigm's ``minElementRadius``
        (used for the default finite-difference probe length).
    neighbor_rule: a grid generator's own neighborhood rule (PdQuickGrid boxes); ``None`` means a
        Euclidean search within each point's horizon, inclusive (Exodus and Text File meshes).
    source: file name or generator name, for messages.
    construct_interfaces: the mesh's block interfaces are to be built and written (an Exodus
        mesh's ``Construct Interfaces``, PERIDIGM_MODELS.md §11).
    element_horizon_intersections: neighbors and partial volumes from the elements' overlap with
        each horizon (an Exodus mesh's ``Compute Element-Horizon Intersections``).
    element_nodes: (n, 8, 3) float64 node positions of every point's hexahedron, where the reader
        read them with the points (for element-horizon intersections), else None.
    """

    x: np.ndarray
    volume: np.ndarray
    block_id: np.ndarray
    gid: np.ndarray
    block_names: dict[int, str]
    node_sets: dict[str, np.ndarray] = field(default_factory=dict)
    min_element_radius: float = 1e50
    neighbor_rule: NeighborRule | None = None
    source: str = ""
    construct_interfaces: bool = False
    element_horizon_intersections: bool = False
    element_nodes: np.ndarray | None = None

    @property
    def num_points(self) -> int:
        return int(self.x.shape[0])

    def validate(self) -> None:
        """Check shapes and basic sanity; raise ValueError on a malformed discretization."""
        n = self.num_points
        if self.x.shape != (n, 3):
            raise ValueError(f"x has shape {self.x.shape}, expected ({n}, 3)")
        for name in ("volume", "block_id", "gid"):
            arr = getattr(self, name)
            if arr.shape != (n,):
                raise ValueError(f"{name} has shape {arr.shape}, expected ({n},)")
        ascending = n < 2 or bool(np.all(self.gid[1:] > self.gid[:-1]))  # a generator's ids: unique without a sort
        if n and not ascending and len(np.unique(self.gid)) != n:
            raise ValueError("global ids are not unique")


class DiscretizationReader(ABC):
    """Reads or generates the points of a model.

    ``name`` is the deck's ``Discretization > Type`` value. ``Params`` validates the
    ``Discretization`` section without the keys every discretization shares (``Type``,
    ``Influence Function``, ``Bond Filters``, ``Omit Bonds Between Blocks``).
    """

    name: ClassVar[str]
    Params: ClassVar[type[ModelParams]]
    #: whether ``Bond Filters`` and ``Omit Bonds Between Blocks`` may be used with this reader
    supports_bond_filters: ClassVar[bool] = True

    def __init__(self, params: ModelParams, *, deck_dir: Path) -> None:
        self.params = params
        self.deck_dir = deck_dir

    def estimate_points(self) -> int | None:
        """The number of points ``read`` would return, known before any is made (generators),
        or None; lets the engine refuse a model that cannot fit in memory before allocating it."""
        return None

    @abstractmethod
    def read(self) -> "Discretization":
        """Return the points in mothership order; raise InputError for unreadable input."""

    def read_part(self, rank: int, size: int) -> "DiscretizationPart | None":
        """Rank ``rank``'s part of the model when the input comes split into one piece per rank
        for ``size`` ranks (Peridigm's pre-split meshes), else None: the engine then calls
        :meth:`read`. Raise InputError for an unreadable piece. Every rank must give the same
        answer (a part or None) for the same input."""
        return None


def mesh_order(block_names: dict[int, str], block_id: np.ndarray, gid: np.ndarray) -> np.ndarray:
    """The permutation that puts points of pieces (block ids ``block_id``, global ids ``gid``,
    both (n,)) in the order of the whole mesh they were cut from: blocks in the order of
    ``block_names`` (the file's), each block's points in global-id order."""
    ids = np.array(list(block_names), dtype=np.int64)
    if not ids.size:
        return np.argsort(gid, kind="stable")
    by_id = np.argsort(ids)
    position = by_id[np.searchsorted(ids, block_id, sorter=by_id)]
    return np.lexsort((gid, position))


@dataclass
class DiscretizationPart:
    """One rank's piece of a model read in pieces.

    Attributes
    ----------
    points: the piece's points (``gid`` global, 0-based), ``node_sets`` left empty.
    node_set_pairs: node set name -> (key (k,) int64, gid (k,) int64): the set's points are the
        ``gid`` of all pieces' pairs ordered by (key, gid), each point once at its first place
        (an Exodus node set: key = the global node id, gid = a point containing that node).
    """

    points: Discretization
    node_set_pairs: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
