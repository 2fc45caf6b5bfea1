"""The verification problems ``peridyn verify`` runs, by name, in the order they run."""
from __future__ import annotations

from .bar import ForceConvergence, WaveSpeed
from .base import Check, Measurement, Problem
from .dynamics import Stability, VerletEnergy
from .extreme import ExtremeCases
from .griffith import Griffith
from .static import StaticModulus

#: name -> class, in the order ``peridyn verify`` runs them
PROBLEMS: dict[str, type[Problem]] = {
    cls.name: cls for cls in (WaveSpeed, ForceConvergence, VerletEnergy, Stability, ExtremeCases, StaticModulus, Griffith)
}

__all__ = ["PROBLEMS", "Check", "Measurement", "Problem"]
