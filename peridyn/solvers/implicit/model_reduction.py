"""``QuasiStatic > Model Reduction``: which points a QuasiStatic run condenses (PeriLab's
``Model Reduction`` with ``Type: Static Condensation``, its Guyan reduction), and the checks
that the condensation is well posed.

Deck keys (PeriLab's names; ``Reduction Node Set`` is peridyn's)::

    QuasiStatic:
      Model Reduction:
        Type: Static Condensation       # Guyan; the only type for QuasiStatic
        Reduction Blocks: "block_1 block_3"   # blocks condensed (names or ids, "1, 3")
        Reduction Node Set: Grips Node Set     # and/or the points of a node set

The displacement components of the named points are the slaves; every other component is a
master, and the prescribed ones (kinematic boundary conditions) are neither: their Newton
increment is known (zero), so they drop out of the linear system. The Newton step is then
solved by :class:`~peridyn.solvers.linalg.guyan.CondensedSolver`, which condenses the load on
the slaves with their stiffness and so gives the full system's solution to round-off: the run's
iterates are those of ``Linear Solver: Direct``, for non-linear materials too (the condensation
is formed again whenever the tangent is reassembled).

Refused at set-up (one-line input errors): an unknown block or node set, an empty region, a
region with no free component, a region that leaves no free master, a part of the region that
is bonded to no master and holds no prescribed component (its stiffness A_ss would be singular:
it could move as a rigid body with the masters held), Multiphysics decks and MPI runs.
"""
from __future__ import annotations

import re
from typing import TYPE_CHECKING, Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from ...core.errors import InputError
from ...core.params import ModelParams
from ...deck.model import tidy

if TYPE_CHECKING:
    from ..linalg.guyan import CondensedSolver


class ModelReductionParams(ModelParams):
    type: Literal["Static Condensation"] = Field(
        alias="Type", description="Static Condensation: Guyan reduction of the Newton systems onto the points not condensed (exact for the linear solve)"
    )
    reduction_blocks: str | int | None = Field(
        None, alias="Reduction Blocks", description="blocks whose points are condensed: names (block_1) or ids, separated by spaces or commas"
    )
    reduction_node_set: str | None = Field(None, alias="Reduction Node Set", description="a node set whose points are condensed")

    @field_validator("reduction_blocks")
    @classmethod
    def _blocks(cls, v):
        if v is not None and not block_tokens(v):
            raise ValueError("'Reduction Blocks' names no block: give block names or ids, e.g. \"block_1 block_3\" or \"1, 3\"")
        return v

    @model_validator(mode="after")
    def _region(self):
        if self.reduction_blocks is None and self.reduction_node_set is None:
            raise ValueError("'Model Reduction' needs the region to condense: 'Reduction Blocks' and/or 'Reduction Node Set'")
        return self


def block_tokens(value: str | int) -> list[str]:
    """The entries of ``Reduction Blocks`` (separated by spaces or commas)."""
    return [t for t in re.split(r"[,\s]+", str(value).strip()) if t]


def condensed_points(sim, params: ModelReductionParams, path: tuple[str, ...]) -> np.ndarray:
    """(num_owned,) bool: the points of the region to condense, local order; InputError for an
    unknown or empty block or node set (``path``: the Model Reduction sublist's deck path)."""
    n = sim.num_owned
    region = np.zeros(n, dtype=bool)
    file = sim.deck.file
    if params.reduction_blocks is not None:
        for token in block_tokens(params.reduction_blocks):
            match = [b for b in sim.blocks if (token.isdigit() and b.block_id == int(token)) or b.name.lower() == token.lower()]
            if not match:
                known = ", ".join(f"{b.name} (id {b.block_id})" for b in sim.blocks)
                raise InputError(f"'Reduction Blocks' names block {token!r}, which the model does not have", file=file,
                                 path=path + ("Reduction Blocks",), fix=f"blocks: {known}")
            for b in match:
                if b.stop <= b.start:
                    raise InputError(f"block {token!r} has no point: nothing to condense", file=file, path=path + ("Reduction Blocks",))
                region[b.start : min(b.stop, n)] = True
    if params.reduction_node_set is not None:
        name = tidy(params.reduction_node_set)
        if name not in sim.node_sets:
            raise InputError(f"unknown node set {params.reduction_node_set!r}", file=file, path=path + ("Reduction Node Set",),
                             fix=f"node sets: {', '.join(sorted(sim.node_sets)) or 'none'}")
        members = sim.local_of_mothership[sim.node_sets[name]]
        members = members[(members >= 0) & (members < n)]
        if members.size == 0:
            raise InputError(f"node set {params.reduction_node_set!r} is empty: nothing to condense", file=file,
                             path=path + ("Reduction Node Set",), fix="give the node set at least one point")
        region[members] = True
    return region


def check_condensation(sim, region: np.ndarray, path: tuple[str, ...]) -> None:
    """InputError unless condensing ``region`` ((n,) bool) leaves a well-posed pair of systems:
    some free component condensed, some free component kept, and every bond-connected part of
    the region anchored (bonded to a kept point or holding a prescribed component), so that the
    slaves' stiffness A_ss is not singular for want of support."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    n = sim.num_owned
    file = sim.deck.file
    fixed = np.asarray(sim.prescribed_dofs[:n], dtype=bool)
    if not (~fixed[region]).any():
        raise InputError(f"every displacement component of the {int(region.sum())} condensed points is prescribed: nothing to condense",
                         file=file, path=path, fix="condense a region with free points")
    if not (~fixed[~region]).any():
        raise InputError("condensing this region leaves no free master: every point is condensed or prescribed", file=file, path=path,
                         fix="keep some free points out of 'Reduction Blocks' / 'Reduction Node Set' (the region of interest)")
    nl = sim.bonds
    bonds = csr_matrix((np.ones(nl.neighbors.size, dtype=np.int8), nl.neighbors, nl.offsets[: n + 1]), shape=(n, n))
    inside = np.flatnonzero(region)
    sub = bonds[inside]
    parts, label = connected_components(sub[:, inside], directed=False)
    anchored = (sub[:, ~region].getnnz(axis=1) > 0) | fixed[inside].any(axis=1)
    supported = np.zeros(parts, dtype=bool)
    supported[label[anchored]] = True
    if not supported.all():
        loose = np.isin(label, np.flatnonzero(~supported))
        gids = np.sort(np.asarray(sim.gid[inside[loose]]) + 1)
        raise InputError(
            f"{int(loose.sum())} condensed point(s) (ids {', '.join(map(str, gids[:5]))}{'...' if gids.size > 5 else ''}) are bonded to no "
            "master and hold no prescribed component: their condensed stiffness is singular (they would float with the masters held)",
            file=file, path=path, fix="keep a point bonded to them out of the condensed region, or condense them with what holds them",
        )


def condensed_solver(sim, tangent, params: ModelReductionParams, path: tuple[str, ...]) -> "CondensedSolver":
    """The :class:`CondensedSolver` of a QuasiStatic run: the region's free components condensed
    onto the others, the prescribed ones decoupled (row order of ``tangent``)."""
    from ..linalg.guyan import CondensedSolver

    refuse_unsupported(sim, path)
    region = condensed_points(sim, params, path)
    check_condensation(sim, region, path)
    n = sim.num_owned
    rows = tangent.local_of_row[:n]  # local point of each row
    condensed = np.repeat(region[rows], 3)
    fixed = np.asarray(sim.prescribed_dofs[:n], dtype=bool)[rows].reshape(-1)
    return CondensedSolver(condensed, fixed)


def validate(sim, params: ModelReductionParams, path: tuple[str, ...]) -> None:
    """The set-up checks of :func:`condensed_solver`, without building anything."""
    refuse_unsupported(sim, path)
    check_condensation(sim, condensed_points(sim, params, path), path)


def refuse_unsupported(sim, path: tuple[str, ...]) -> None:
    if sim.comm.size > 1:
        raise InputError("'Model Reduction' runs on one process", file=sim.deck.file, path=path,
                         fix="run without mpirun, or remove 'Model Reduction'")
    if sim.deck.multiphysics:
        raise InputError("'Model Reduction' condenses the displacement solve; a Multiphysics deck is not supported", file=sim.deck.file,
                         path=path, fix="remove 'Model Reduction'")
