"""Output on several ranks: each rank writes its own points to its own piece of a file, as
Peridigm does (``NAME.e.N.r``), and no rank gathers a frame of the whole model.

A piece lists the rank's owned points block by block, each block's in mothership order, with
their global ids (``node_num_map``) and, for the merge, their mothership positions and the
places of its node-set entries (``exodus_merge``). By default (``Merge Rank Files: true``) the
pieces are joined into the one ``NAME.e`` when the run closes complete, by rank 0 reading them
chunk by chunk; otherwise they stay as Peridigm names them and ``peridyn merge NAME.e`` joins
them later. A run that stops on an error keeps its pieces as ``NAME.partial.e.N.r`` (with the
number of earlier frames they follow, for a restart to merge them first).
"""
from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import OutputWriteError
from ..io.exodus_merge import NODE_ORDER, merge_pieces, node_set_order_name
from ..io.exodus_pieces import numbered_files
from ..io.exodus_writer import ExodusBlock, ExodusWriter

log = logging.getLogger("peridyn.output")

#: a piece's global attribute: the frames of the merged file its own follow (a restarted run's)
APPEND_AFTER = "peridyn_append_after"


def rank_file(path: Path, size: int, rank: int) -> Path:
    """The name rank ``rank`` of ``size`` writes its piece of ``path`` under, as Peridigm names
    it (``NAME.e.N.r``)."""
    return path.with_name(f"{path.name}.{size}.{rank}")


def pieces_of(path: Path) -> tuple[int, list[Path]]:
    """(N, the pieces ``path.N.r`` beside ``path`` in rank order) for the largest N found
    (SEACAS's zero-padded ranks too); (0, []) when there are none."""
    found = {n: {r: p for r, p in ranks.items() if r < n} for n, ranks in numbered_files(path).items()}
    found = {n: ranks for n, ranks in found.items() if ranks}
    if not found:
        return 0, []
    size = max(found)
    return size, [found[size][r] for r in sorted(found[size])]


def drop_stale_pieces(partial: Path, size: int) -> None:
    """Remove the partial pieces ``partial.N.r`` an earlier stopped run left for another rank
    count (a run starting afresh replaces its partial output; a later restart must not take
    them for its own)."""
    for count, ranks in numbered_files(partial).items():
        if count != size:
            for p in ranks.values():
                p.unlink(missing_ok=True)


class RankPiece:
    """This rank's share of one output file: which owned points go where in its piece."""

    def __init__(self, sim: Any) -> None:
        n = sim.num_owned
        block = sim.block_index[:n]
        mothership = sim.mothership_of_local[:n]
        #: (n_owned,) local rows in piece order: by block, then mothership position
        self.order = np.lexsort((mothership, block))
        self.keys = mothership[self.order]
        #: (num_blocks + 1,) each block's first piece node
        self.starts = np.concatenate([[0], np.cumsum(np.bincount(block, minlength=len(sim.blocks)))]).astype(np.int64)
        self.sim = sim

    @property
    def num_nodes(self) -> int:
        return int(self.order.size)

    def node_sets(self) -> tuple[list[tuple[str, np.ndarray]], list[tuple[str, str, np.ndarray]]]:
        """(name, piece nodes) of every node set in file order, and the auxiliary variables of
        their entries' places in the whole set."""
        sorted_keys = np.sort(self.keys)
        node_of_sorted = np.argsort(self.keys, kind="stable")
        sets, places = [], []
        for k, (name, members) in enumerate(sorted(self.sim.node_sets.items())):
            members = np.asarray(members, dtype=np.int64)
            at = np.minimum(np.searchsorted(sorted_keys, members), max(sorted_keys.size - 1, 0))
            mine = sorted_keys[at] == members if sorted_keys.size else np.zeros(members.size, dtype=bool)
            sets.append((name, node_of_sorted[at[mine]]))
            if mine.any():
                places.append((node_set_order_name(k), f"num_nod_ns{k + 1}", np.flatnonzero(mine)))
        return sets, places

    def writer(self, path: Path, **variables: Any) -> ExodusWriter:
        """The Exodus writer of this piece at ``path`` (its mesh written); ``variables``: the
        writer's variable names and truth table."""
        sim = self.sim
        rows = self.order
        blocks = [ExodusBlock(blk.block_id, blk.name, np.arange(self.starts[b], self.starts[b + 1]))
                  for b, blk in enumerate(sim.blocks)]
        sets, places = self.node_sets()
        return ExodusWriter(path, coords=sim.fields["Model_Coordinates"][rows], node_num_map=sim.gid[rows] + 1,
                          blocks=blocks, node_sets=sets, auxiliary=[(NODE_ORDER, "num_nodes", self.keys)] + places,
                          **variables)

    def values(self, data: np.ndarray) -> np.ndarray:
        """The piece's rows of a local per-point array."""
        return data[self.order]

    def block_values(self, column: np.ndarray) -> list[np.ndarray]:
        """A piece-ordered column split into its blocks."""
        return [column[self.starts[b]:self.starts[b + 1]] for b in range(len(self.starts) - 1)]


def continue_pieces(writer: Any) -> None:
    """Before a restart keeps an output's frames (rank 0): join the pieces a stopped run left;
    refuse kept pieces (``Merge Rank Files: false``), whose frames a continued run cannot append
    to on another layout."""
    from ..core.errors import InputError

    sim = writer.sim
    if not writer.entry.params.merge_rank_files and sim.comm.size > 1:
        raise InputError(f"{writer.entry.section} keeps its ranks' pieces (Merge Rank Files: false), which a continued run "
                         "cannot append to", file=sim.deck.file, path=writer.entry.path + ("Merge Rank Files",),
                         fix="continue with Merge Rank Files: true (the pieces written so far are joined first)")
    for path, final in ((writer.partial_path, False), (writer.path, True)):
        try:
            recover_pieces(path, final=final)
        except (OSError, RuntimeError, ValueError) as exc:
            raise InputError(f"cannot join the pieces {path.name}.N.r the run left: {exc}", file=sim.deck.file,
                             path=("--restart",), fix=f"join them with 'peridyn merge {path.name}', or remove them") from None


def close_pieces(writer: Any, complete: bool) -> None:
    """Close an OutputWriter's pieces: complete, join them into its file on rank 0 (or, kept,
    give each its final name); otherwise leave them under their partial names. Collective when
    ``complete``."""
    sim = writer.sim
    comm = sim.comm
    size, rank = comm.size, comm.rank
    partial = rank_file(writer.partial_path, size, rank)
    if not complete:
        log.warning("the frames of this run are in the pieces %s.%d.*; %s is left as it was", writer.partial_path.name,
                    size, writer.path.name)
        return
    wrote = comm.allgather(writer.piece is not None and writer.piece.num_nodes > 0)
    if not writer.entry.params.merge_rank_files:
        if wrote[rank]:
            os.replace(partial, rank_file(writer.path, size, rank))
        return
    failure = None
    if comm.is_root:
        pieces = [rank_file(writer.partial_path, size, r) for r in range(size) if wrote[r]]
        try:
            merge_pieces(pieces, writer.partial_path, append_after=writer.resume_frames or None)
            os.replace(writer.partial_path, writer.path)
        except (OSError, RuntimeError, ValueError) as exc:
            failure = f"{writer.entry.section}: joining the ranks' pieces into {writer.path.name} failed ({exc}); the pieces are kept"
        else:
            for p in pieces:
                p.unlink(missing_ok=True)
    failure = comm.bcast(failure)
    if failure is not None:
        raise OutputWriteError(failure)


def recover_pieces(partial: Path, *, final: bool = False) -> int | None:
    """Join the pieces a stopped run left (``NAME.partial.e.N.r``) into ``partial`` after the
    frames they follow, and delete them; the number of frames ``partial`` then holds (None when
    there were no pieces). ``final``: ``partial`` is ``NAME.e`` and its pieces the kept ones of a
    finished run (joined only where ``NAME.e`` is missing). Rank 0, before a restart keeps the
    checkpoint's frames."""
    _, pieces = pieces_of(partial)
    if not pieces or (final and partial.is_file()):
        return None
    import netCDF4

    with netCDF4.Dataset(str(pieces[0])) as ds:
        after = int(ds.getncattr(APPEND_AFTER)) if APPEND_AFTER in ds.ncattrs() else 0
    if after:
        from ..io.exodus_writer import keep_steps

        keep_steps(partial, after)
    steps = merge_pieces(pieces, partial, append_after=after or None, common_steps=True)
    for p in pieces:
        p.unlink(missing_ok=True)
    return after + steps
