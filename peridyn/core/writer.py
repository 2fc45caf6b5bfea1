"""One ``Output`` section: its write counter, frequency window and Exodus file."""
from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np

from .fields import Relation
from .output import component_names

if TYPE_CHECKING:  # pragma: no cover
    from .deck import OutputEntry
    from .engine import Simulation
    from .output import OutputManager

log = logging.getLogger("peridyn.output")


class OutputWriter:
    """Writes the variables of one Output section when its counter says so (§9.2): call k
    writes iff frequency > 0, (k - 1) % frequency == 0 and initial <= k <= final + 1."""

    def __init__(self, sim: "Simulation", manager: "OutputManager", entry: "OutputEntry") -> None:
        self.sim = sim
        self.manager = manager
        self.entry = entry
        p = entry.params
        self.frequency = p.output_frequency
        self.initial = p.initial_output_step
        self.final = p.final_output_step
        self.count = 0
        self.names = list(dict.fromkeys(entry.variables))  # a name listed twice is written once
        self.vars = [manager.variables[n] for n in self.names]
        self.global_only = bool(self.vars) and all(v.kind == "global" for v in self.vars)
        suffix = ".h" if self.global_only else ".e"
        self.path = sim.output_dir / f"{entry.filename}{suffix}"
        self._writer = None
        self.frames = 0
        # Exodus variable lists, in Output Variables order per kind
        self.nodal = [(v, c, k) for v in self.vars if v.kind == "nodal" for k, c in enumerate(component_names(v.spec, v.name))]
        self.element = [(v, c, k) for v in self.vars if v.kind == "element" for k, c in enumerate(component_names(v.spec, v.name))]
        self.glob = [(v, c, k) for v in self.vars if v.kind == "global" for k, c in enumerate(component_names(v.spec, v.name))]

    def due(self) -> bool:
        k = self.count
        return self.frequency > 0 and (k - 1) % self.frequency == 0 and self.initial <= k <= self.final + 1

    def write(self, t: float) -> None:
        self.count += 1
        if not self.due():
            return
        sim = self.sim
        self.manager.run_computes(self.names)
        if self._writer is None:
            self._open()
        nodal = {}
        element = {}
        glob = {}
        n_owned = sim.num_owned
        index = sim.mothership_of_local[:n_owned]
        comm = sim.comm
        cache: dict[str, np.ndarray | None] = {}

        def mothership(v) -> np.ndarray | None:
            if v.name not in cache:
                data = sim.fields[v.name][:n_owned]
                cache[v.name] = comm.gather_points(np.ascontiguousarray(data), index, sim.num_global)
            return cache[v.name]

        for v, cname, k in self.nodal:
            data = mothership(v)
            if data is not None:
                nodal[cname] = data if data.ndim == 1 else data[:, k]
        for v, cname, k in self.element:
            data = mothership(v)
            if data is None:
                continue
            col = data if data.ndim == 1 else data[:, k]
            rows = self.manager.blocks_with(v.name)
            element[cname] = [col[nodes] if has else None for nodes, has in zip(self._block_nodes, rows)]
        for v, cname, k in self.glob:
            arr = sim.fields[v.name]
            glob[cname] = float(arr[k])
        if comm.is_root:
            self._writer.write_step(t, nodal=nodal, element=element, glob=glob)
        self.frames += 1

    def _open(self) -> None:
        from ..io.exodus_writer import ExodusBlock, ExodusWriter

        sim = self.sim
        comm = sim.comm
        disc = sim.discretization
        # element blocks in block order, each block's points in mothership order
        self._block_nodes = []
        blocks = []
        for blk in sim.blocks:
            nodes = np.sort(np.nonzero(sim.block_index_mothership == blk.index)[0])
            self._block_nodes.append(nodes)
            blocks.append(ExodusBlock(blk.block_id, blk.name, nodes))
        if not comm.is_root:
            self._writer = _NullWriter()
            return
        if self.global_only:
            self._writer = ExodusWriter.global_only(self.path, [c for _, c, _ in self.glob])
            return
        truth = np.array([[has for has in self.manager.blocks_with(v.name)] for v, _, _ in self.element], dtype=bool).T.reshape(len(blocks), len(self.element))
        node_sets = [(name, members) for name, members in sorted(sim.node_sets.items())]
        self._writer = ExodusWriter(
            self.path,
            coords=disc.x,
            node_num_map=disc.gid + 1,
            blocks=blocks,
            node_sets=node_sets,
            nodal_vars=[c for _, c, _ in self.nodal],
            element_vars=[c for _, c, _ in self.element],
            global_vars=[c for _, c, _ in self.glob],
            truth_table=truth,
        )

    def close(self) -> None:
        if self._writer is not None:
            self._writer.close()


class _NullWriter:
    def write_step(self, *a, **k) -> None:
        pass

    def close(self) -> None:
        pass
