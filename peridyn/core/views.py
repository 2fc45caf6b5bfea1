"""What a model sees of its block: the arrays of one block's points and bonds (``BlockView``)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .bonds import NeighborList
from .fields import FieldStore
from .services import Influence
from .traversal import Backend


@dataclass
class BlockView:
    """The arrays one block's models work on.

    Local point indices run over owned points first, then ghosts; the block owns the contiguous
    range ``start:stop`` of owned points. Neighbor lists (``bonds``) are CSR over local points:
    the bonds of point ``i`` are ``bonds.neighbors[bonds.offsets[i]:bonds.offsets[i+1]]``, and a
    bond field's row ``b`` belongs to the bond at position ``b`` of that array.

    ``closed`` is true when every neighbor of every point of the block belongs to the block and
    is owned locally, so a material may compute both ends of each bond itself (a fused kernel).
    """

    name: str
    block_id: int
    start: int
    stop: int
    horizon: float  #: the block's horizon (constant horizons); per point: fields["Horizon"]
    density: float
    fields: FieldStore
    bonds: "NeighborList"
    num_owned: int
    closed: bool = False
    damage_symmetric: bool = False  #: the block's damage model gives both bond ends equal damage
    influence: Influence | None = None  #: the discretization's influence function
    time: float = 0.0
    time_step: float = 0.0
    extras: dict[str, Any] = field(default_factory=dict)
    backend: Backend | None = None  #: where the block's arrays live and its loops run (None: numba on CPU threads)

    @property
    def num_points(self) -> int:
        return self.stop - self.start
