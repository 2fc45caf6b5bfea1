"""Where a run executes: the device (CPU threads or one GPU) a deck and the command line choose."""
from __future__ import annotations

from ..core.errors import InputError
from ..deck.model import Deck


def resolve_device(deck: Deck, device: str | None, backend: str | None) -> tuple[str, str | None]:
    """("cpu" or "gpu", the GPU backend's name or None): ``--device`` wins over the solver
    sections' ``Device``; a ``--backend`` whose arrays live on a GPU means ``--device gpu``."""
    gpu_backend = None
    if backend is not None:
        from ..plugins.manager import get_registry

        cls = get_registry().get("backend", backend, path=("--backend",))
        if cls.device == "gpu":
            gpu_backend = backend
    if device is not None:
        device = device.lower()
        if device not in ("cpu", "gpu"):
            raise InputError(f"--device {device!r} is not a device", file=deck.file, path=("--device",), fix="give --device cpu or --device gpu")
        if device == "cpu" and gpu_backend:
            raise InputError(f"--backend {backend} runs on a GPU, but --device cpu was given", file=deck.file, path=("--backend",),
                             fix="leave out --device, or give a CPU backend (numba)")
    if device is None:
        asked = {entry.params.device.lower() for entry in deck.solvers if entry.params.device}
        if len(asked) > 1:
            raise InputError("the solver sections ask for different devices (Device: CPU and GPU)", file=deck.file, path=("Solver", "Device"),
                             fix="give every solver section the same Device, or choose one with --device")
        device = asked.pop() if asked else ("gpu" if gpu_backend else "cpu")
    if device == "gpu" and backend is not None and not gpu_backend:
        raise InputError(f"--backend {backend} runs on the CPU, but the run is on the GPU", file=deck.file, path=("--backend",),
                         fix="leave out --backend (the GPU backend is cuda), or run with --device cpu")
    return device, gpu_backend
