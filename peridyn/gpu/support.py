"""What a run on the GPU supports, checked before anything runs (``peridyn run --device gpu``
and ``peridyn check --device gpu``): a deck that uses a model, solver or condition without a GPU
path gets one input error naming it and ``--device cpu``, never a silent fallback to the CPU."""
from __future__ import annotations

from typing import Any

from ..core.errors import InputError
from ..core.interfaces import Material

GPU_SOLVERS = frozenset({"Verlet"})


def gpu_problems(sim: Any) -> list[tuple[tuple[str, ...], str]]:
    """(deck path, what has no GPU path) for each part of ``sim`` the GPU backend cannot run."""
    out: list[tuple[tuple[str, ...], str]] = []
    for solver, _, _ in sim.plan_solvers():
        if solver.name not in GPU_SOLVERS:
            out.append(((solver.section,), f"the solver {solver.name!r} has no GPU path (explicit 'Verlet' has)"))
    out += model_problems(sim)
    for c in list(sim.kinematic) + list(sim.force_conditions):  # initial conditions are applied in set-up, on the CPU
        if "gpu" not in type(c).devices:
            out.append((("Boundary Conditions", c.entry_name), f"the condition {c.name!r} has no GPU path (its step hook writes "
                        "host arrays; a condition written with peridyn.kernels.scatter's laws declares devices = {'cpu', 'gpu'})"))
    if sim.comm.size > 1:
        out.append(((), "a run under MPI on GPUs (one GPU per rank) is not built yet"))
    return out


def model_problems(sim: Any) -> list[tuple[tuple[str, ...], str]]:
    """(deck path, what has no GPU path) for the materials, damage models, blocks and contact of
    ``sim`` (``gpu_problems`` without the solvers, conditions and ranks)."""
    out: list[tuple[tuple[str, ...], str]] = []
    seen: set[int] = set()
    for blk in sim.blocks:
        m = blk.material
        if id(m) not in seen and "gpu" not in type(m).devices:
            seen.add(id(m))
            out.append((blk.path or ("Blocks", blk.name), f"the material {m.name!r} (block {blk.name!r}) has no GPU kernels"))
        elif id(m) not in seen and type(m).force_fused is Material.force_fused:
            seen.add(id(m))
            out.append((blk.path or ("Blocks", blk.name), f"the material {m.name!r} (block {blk.name!r}) declares the GPU but has no "
                        "fused force (Material.force_fused), the only force the GPU step computes"))
        d = blk.damage
        if d is not None and id(d) not in seen and "gpu" not in type(d).devices:
            seen.add(id(d))
            out.append((("Damage Models",), f"the damage model {d.name!r} (block {blk.name!r}) has no GPU kernels"))
    covered = {b.index for blk in sim.blocks if blk.fused for b in blk.group}
    for blk in sim.blocks:
        if blk.index not in covered:
            out.append((blk.path or ("Blocks", blk.name),
                        f"block {blk.name!r}: bonds cross to a block of another material or damage model, or its horizon "
                        "varies, so its forces need the engine's bond-force gather, which has no GPU path yet"))
    if sim.contact is not None and "gpu" not in type(sim.contact.model).devices:
        out.append((("Contact",), f"the contact model {sim.contact.model.name!r} has no GPU kernels"))
    return out


def check_gpu(sim: Any) -> None:
    """InputError naming the first part of ``sim`` without a GPU path (and how many more)."""
    problems = gpu_problems(sim)
    if not problems:
        return
    path, what = problems[0]
    more = f" ({len(problems) - 1} more: {'; '.join(p[1] for p in problems[1:3])})" if len(problems) > 1 else ""
    raise InputError(f"--device gpu: {what}{more}", path=path, fix="run this deck on the CPU with --device cpu",
                     file=sim.deck.file)
