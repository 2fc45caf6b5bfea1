"""peridyn: peridynamics in Python, compatible with Peridigm's input decks."""
from __future__ import annotations

__version__ = "0.1.0"
__all__ = ["__version__"]
