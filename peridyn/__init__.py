"""peridyn: peridynamics in Python, compatible with Peridigm's input decks.

``import peridyn`` is cheap: the Python API (``peridyn.Model``, ``peridyn.read``,
``peridyn.Study``; docs/python-api.md) is imported on first use.
"""
from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"
#: names of the Python API, imported from ``peridyn.api`` when first used
_API = ("Model", "Results", "RunEnded", "Study", "deck_tree", "read")
__all__ = ["__version__", *_API]


def __getattr__(name: str) -> Any:
    if name in _API:
        return getattr(importlib.import_module("peridyn.api"), name)
    raise AttributeError(f"module 'peridyn' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_API))
