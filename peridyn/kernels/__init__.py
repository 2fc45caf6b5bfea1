"""The bond-loop layer: backends that compile loop laws (``peridyn.core.traversal``) into kernels,
and the shared gathers and packing every model's loops use."""
from __future__ import annotations

import os
from typing import Any, Callable

from ..core.traversal import Backend, BondMap, Law, PairForce, PointMap, PointSum

__all__ = ["Backend", "BondMap", "Law", "PairForce", "PointMap", "PointSum", "compiled", "default_backend", "empty", "on_host", "resident", "select_backend"]

_default: Backend | None = None


def default_backend() -> Backend:
    """The backend of views that name none: numba on CPU threads."""
    global _default
    if _default is None:
        from .numba_cpu import NumbaBackend

        _default = NumbaBackend()
    return _default


def select_backend(name: str | None = None) -> Backend:
    """A new backend called ``name`` (``peridyn run --backend``), else ``PERIDYN_BACKEND``, else
    the default (numba on CPU threads); backends come from the ``peridyn_backends`` hook, and
    an unknown name is an InputError naming where it was given."""
    if name is None and not os.environ.get("PERIDYN_BACKEND"):
        return default_backend()
    from ..plugins.manager import get_registry

    path = ("--backend",) if name is not None else ("PERIDYN_BACKEND",)
    return get_registry().get("backend", name if name is not None else os.environ["PERIDYN_BACKEND"], path=path)()


def compiled(block, law: Law) -> Callable[..., Any]:
    """The kernel of ``law`` on the backend of ``block`` (a ``BlockView``; the default backend
    when the view names none). On one CPU thread, the sums of a closed block run mirrored
    (``peridyn.kernels.mirror``: each bond once, the same bits)."""
    backend = block.backend or default_backend()
    kernel = backend.kernel(law)
    if block.closed and backend.one_thread():
        from . import mirror

        if mirror.enabled():
            k = backend.mirror_kernel(law)
            if k is not None:
                return mirror.mirrored(block, kernel, k)
    return kernel


def on_host(block) -> bool:
    """Whether the arrays of ``block`` are numpy arrays host-side helpers may read (the CPU
    backends), not device arrays only the backend's kernels touch."""
    return block.backend is None or block.backend.device == "cpu"


def empty(block, dtype: Any = float) -> Any:
    """A zero-length array ("feature off" in a law's args) on the backend of ``block``."""
    return (block.backend or default_backend()).empty(dtype)


def resident(block, array: Any) -> Any:
    """A model's constant ``array`` where the kernels of ``block``'s backend read it."""
    return array if on_host(block) else block.backend.resident(array)
