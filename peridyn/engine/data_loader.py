"""``Data Loader``: a nodal field read from an Exodus file and interpolated linearly in time
(PERIDIGM_SEMANTICS.md §10). Verlet loads it before each force evaluation and each output."""
from __future__ import annotations

import numpy as np

from ..core.errors import InputError
from ..core.fields import FieldSpec, Relation, Temporal


class DataLoader:
    def __init__(self, sim, params) -> None:
        from ..io.exodus_reader import read_nodal_variable

        self.sim = sim
        path = sim.deck.directory / params.file_name
        where = ("Data Loader",)
        times, values, node_map = _read(sim, path, params, read_nodal_variable)
        if values.shape[1] != sim.num_global:
            raise InputError(
                f"{path.name} has {values.shape[1]} nodes but the model has {sim.num_global} points", file=sim.deck.file, path=where + ("File Name",)
            )
        if not np.array_equal(np.asarray(node_map, dtype=np.int64) - 1, sim.discretization.gid):
            raise InputError(f"the node numbering of {path.name} does not match the model's points", file=sim.deck.file, path=where + ("File Name",))
        if len(times) == 0:
            raise InputError(f"{path.name} has no time steps", file=sim.deck.file, path=where + ("File Name",))
        self.name = params.field_name
        self.times = np.asarray(times, dtype=float)
        self.values = np.asarray(values, dtype=float)[:, sim.mothership_of_local]
        sim.fields.declare(FieldSpec(self.name, Relation.NODE, 1, Temporal.TWO_STEP))
        self.t1 = self.t2 = -1.0
        self.d1 = self.d2 = None

    def load(self, t: float) -> None:
        if not (self.t1 <= t <= self.t2) or self.d1 is None:
            k = next((i for i in range(len(self.times) - 1) if self.times[i] <= t <= self.times[i + 1]), None)
            if k is None:
                if len(self.times) == 1 and t == self.times[0]:
                    k = 0
                else:
                    raise InputError(
                        f"time {t:.6g} is outside the times of the data file ({self.times[0]:.6g} to {self.times[-1]:.6g})",
                        file=self.sim.deck.file,
                        path=("Data Loader", "File Name"),
                    )
            k2 = min(k + 1, len(self.times) - 1)
            self.t1, self.t2 = float(self.times[k]), float(self.times[k2])
            self.d1, self.d2 = self.values[k], self.values[k2]
        c = (t - self.t1) / (self.t2 - self.t1) if self.t2 != self.t1 else 0.0
        self.sim.fields[self.name][:] = (1.0 - c) * self.d1 + c * self.d2


def _read(sim, path, params, read_nodal_variable):
    """(times, values (steps, points), node ids) of the deck's field: from the file, or, on N
    ranks with the pieces ``FILE.N.r`` of a pre-split run, each rank reading its own piece and
    the pieces put together (Peridigm's DataLoader reads rank r's piece alone)."""
    from ..io.exodus_pieces import find_pieces, piece_path
    from .mesh_parts import gather_pieces

    comm = sim.comm
    base = find_pieces(params.file_name, sim.deck.directory, comm.size) if not path.is_file() else None
    if base is None:
        return read_nodal_variable(path, params.field_name)
    pieces = gather_pieces(comm, lambda: read_nodal_variable(piece_path(base, comm.size, comm.rank), params.field_name))
    times = pieces[0][0]
    if any(not np.array_equal(p[0], times) for p in pieces):
        raise InputError(f"the pieces of {path.name} hold different time steps", file=sim.deck.file, path=("Data Loader", "File Name"))
    values = np.concatenate([p[1] for p in pieces], axis=1)
    ids = np.concatenate([np.asarray(p[2], dtype=np.int64) for p in pieces])
    wanted = sim.discretization.gid + 1  # the pieces' nodes in the model's point order
    by_id = np.argsort(ids, kind="stable")
    at = np.minimum(np.searchsorted(ids, wanted, sorter=by_id), max(ids.size - 1, 0))
    if ids.size == wanted.size and ids.size and np.array_equal(ids[by_id[at]], wanted):
        return times, values[:, by_id[at]], wanted
    return times, values, ids
