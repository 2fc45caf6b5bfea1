"""A model read in pieces, one per rank (Peridigm's pre-split meshes), made into the
discretization the set-up works on.

Every rank reads only its own piece (:meth:`DiscretizationReader.read_part`); the pieces are then
put together in the order of the whole mesh they were cut from (blocks in file order, each in
element-id order: SEACAS ``decomp`` keeps the ids), so a run on pieces sees the same points, in the same order,
as a run on the whole mesh, and writes the same output. The model is still then held whole by
every rank, as a run on the whole mesh is.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from ..core.discretization import Discretization, DiscretizationPart, DiscretizationReader, mesh_order
from ..core.errors import InputError

T = TypeVar("T")


def read_in_parts(reader: DiscretizationReader, comm: Any) -> Discretization | None:
    """The discretization put together from every rank's part, where the reader reads the
    input in parts for this number of ranks; None where it does not (the caller reads it
    whole). Collective: an input error in any rank's piece is raised on every rank."""
    if comm.size == 1:
        return None
    parts = gather_pieces(comm, lambda: reader.read_part(comm.rank, comm.size))
    if all(p is None for p in parts):
        return None
    if any(p is None for p in parts):
        raise InputError("some ranks found their piece of the mesh and others did not", fix="give every rank its piece, or the whole mesh")
    return assemble(parts)


def gather_pieces(comm: Any, read: Callable[[], T]) -> list[T]:
    """Every rank's ``read()`` (its piece of some input), in rank order. Collective: an input
    error on any rank is raised on every rank, so none is left waiting."""
    value, error = None, None
    try:
        value = read()
    except InputError as exc:
        error = (exc.message, exc.file, exc.path, exc.fix, exc.line)
    answers = comm.allgather((error, value))
    for err, _ in answers:
        if err is not None:
            message, file, path, fix, line = err
            raise InputError(message, file=file, path=path, fix=fix, line=line)
    return [v for _, v in answers]


def assemble(parts: list[DiscretizationPart]) -> Discretization:
    """The discretization of all ``parts`` (rank order), points in the order of the whole mesh
    they were cut from (blocks in file order, each block's points in global-id order); a node set
    is the points of its pairs ordered by (key, gid), each point once."""
    first = parts[0].points
    block_names: dict[int, str] = {}
    for p in parts:
        for bid, name in p.points.block_names.items():
            if block_names.setdefault(bid, name) != name:
                raise InputError(f"block {bid} is named {block_names[bid]!r} in one piece and {name!r} in another", file=p.points.source,
                                 fix="regenerate the pieces from one mesh (SEACAS decomp)")
    gid = np.concatenate([p.points.gid for p in parts])
    block_id = np.concatenate([p.points.block_id for p in parts])
    order = mesh_order(block_names, block_id, gid)
    gid, block_id = gid[order], block_id[order]
    by_gid = np.argsort(gid, kind="stable")
    repeated = np.flatnonzero(gid[by_gid][1:] == gid[by_gid][:-1])
    if repeated.size:
        raise InputError(f"element {int(gid[by_gid][repeated[0]]) + 1} is in more than one piece of the mesh", file=first.source,
                         fix="regenerate the pieces from one mesh (SEACAS decomp)")
    volume = np.concatenate([p.points.volume for p in parts])[order]
    names = list(dict.fromkeys(name for p in parts for name in p.node_set_pairs))
    node_sets = {}
    for name in names:
        pairs = [p.node_set_pairs[name] for p in parts if name in p.node_set_pairs]
        key = np.concatenate([k for k, _ in pairs])
        members = np.concatenate([g for _, g in pairs])
        members = members[np.lexsort((members, key))]
        _, at = np.unique(members, return_index=True)
        node_sets[name] = by_gid[np.searchsorted(gid, members[np.sort(at)], sorter=by_gid)].astype(np.int64)
    return Discretization(
        x=np.ascontiguousarray(np.concatenate([p.points.x for p in parts])[order]),
        volume=np.ascontiguousarray(volume),
        block_id=block_id,
        gid=gid,
        block_names=block_names,
        node_sets=node_sets,
        min_element_radius=min(p.points.min_element_radius for p in parts),
        neighbor_rule=None,
        source=first.source,
        construct_interfaces=first.construct_interfaces,
        element_horizon_intersections=first.element_horizon_intersections,
        element_nodes=None if first.element_nodes is None else np.concatenate([p.points.element_nodes for p in parts])[order],
    )
