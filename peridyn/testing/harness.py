"""Small in-memory models for tests."""
from __future__ import annotations

import contextlib
import copy
from pathlib import Path
from typing import Any

import numpy as np

from ..plugins import manager


def cube_deck(
    material: dict[str, Any],
    *,
    n: int = 6,
    spacing: float = 1.0,
    horizon_factor: float = 3.015,
    damage: dict[str, Any] | None = None,
    spherical: bool = True,
    extra: dict[str, Any] | None = None,
    shape: tuple[int, int, int] | None = None,
) -> dict[str, Any]:
    """A deck tree: an n^3 PdQuickGrid cube (or a box of ``shape`` points per direction) of
    the given spacing from the origin, one block of ``material`` (a Materials entry,
    ``Material Model`` included), optional damage model, no solver."""
    nx, ny, nz = shape if shape is not None else (n, n, n)
    tree: dict[str, Any] = {
        "Discretization": {
            "Type": "PdQuickGrid",
            "TensorProduct3DMeshGenerator": {
                "Type": "PdQuickGrid",
                "X Origin": 0.0,
                "Y Origin": 0.0,
                "Z Origin": 0.0,
                "X Length": nx * spacing,
                "Y Length": ny * spacing,
                "Z Length": nz * spacing,
                "Number Points X": nx,
                "Number Points Y": ny,
                "Number Points Z": nz,
            },
        },
        "Materials": {"M": dict(material)},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": horizon_factor * spacing}},
    }
    if spherical:
        tree["Discretization"]["NeighborhoodType"] = "Spherical"
    if damage is not None:
        tree["Damage Models"] = {"D": dict(damage)}
        tree["Blocks"]["B"]["Damage Model"] = "D"
    if extra:
        tree.update(copy.deepcopy(extra))
    return tree


def scattered_deck(
    material: dict[str, Any],
    directory: str | Path,
    *,
    n: int = 6,
    spacing: float = 1.0,
    horizon_factor: float = 3.015,
    jitter: float = 0.35,
    volume_spread: float = 0.5,
    seed: int = 0,
    damage: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """A deck tree of an irregular point cloud: the n^3 lattice of ``spacing`` (L) with every
    point moved by up to ``jitter`` spacings in each direction and given a random volume
    ``spacing^3 (1 + volume_spread U(-1, 1))`` (L^3). Writes ``scattered_points.txt`` (a
    ``Text File`` mesh, block 1) into ``directory``, which :func:`build_simulation` must be
    given. One block of ``material``, horizon ``horizon_factor * spacing``, optional damage."""
    rng = np.random.default_rng(seed)
    g = np.arange(n, dtype=float)
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    x = spacing * (x + jitter * rng.uniform(-1.0, 1.0, x.shape))
    volume = spacing**3 * (1.0 + volume_spread * rng.uniform(-1.0, 1.0, len(x)))
    lines = [f"{a!r} {b!r} {c!r} 1 {v!r}" for (a, b, c), v in zip(x.tolist(), volume.tolist())]
    Path(directory, "scattered_points.txt").write_text("# x y z block volume\n" + "\n".join(lines) + "\n")
    tree: dict[str, Any] = {
        "Discretization": {"Type": "Text File", "Input Mesh File": "scattered_points.txt"},
        "Materials": {"M": dict(material)},
        "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": horizon_factor * spacing}},
    }
    if damage is not None:
        tree["Damage Models"] = {"D": dict(damage)}
        tree["Blocks"]["B"]["Damage Model"] = "D"
    return tree


def build_simulation(tree: dict[str, Any], *, directory: str | Path = ".", registry=None, output_dir: str | Path | None = None,
                     backend: str | None = None):
    """Validate a deck tree (as loaded from YAML, without the ``Peridigm`` key) and build the
    model, ready for solvers, on ``backend`` (a ``peridyn_backends`` name; None: the default).
    File names in the deck are relative to ``directory``."""
    from ..deck.model import parse_deck
    from ..engine.simulation import Simulation
    from ..deck.source import DeckSource, typed_tree

    directory = Path(directory)
    source = DeckSource(typed_tree(tree), directory / "<memory>.yaml", "yaml", {})
    deck = parse_deck(source, registry)
    return Simulation(deck, output_dir=output_dir or directory, backend=backend)


def node_set_ids(tree: dict[str, Any], where, *, directory: str | Path = ".") -> str:
    """An inline node set (1-based point numbers) of the points of ``tree``'s mesh whose
    reference positions satisfy ``where(x)`` (x: (n, 3) array; returns an (n,) bool mask)."""
    sim = build_simulation(tree, directory=directory)
    x, gid = sim.discretization.x, sim.discretization.gid
    return " ".join(str(g + 1) for g in gid[where(x)])


@contextlib.contextmanager
def isolated_registry(*plugins: Any, autoload: bool = False):
    """Within the block, the process-wide registry holds the built-ins plus ``plugins`` (and
    installed third-party plugins only when ``autoload``)."""
    old = manager._REGISTRY
    reg = manager.build_registry(autoload=autoload, extra_plugins=plugins)
    manager.reset_registry(reg)
    try:
        yield reg
    finally:
        manager.reset_registry(old)
