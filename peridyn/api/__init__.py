"""The Python API: ``Model`` (build, run, step, fields, conditions and computes from Python),
``read`` (result files), ``Study`` (resumable parameter studies). See docs/python-api.md."""
from __future__ import annotations

from .checks import ArgumentError, ArgumentTypeError, UnknownNameError
from .decks import deck_tree
from .model import Model, RunEnded
from .results import Results, read
from .study import Study

__all__ = ["ArgumentError", "ArgumentTypeError", "Model", "Results", "RunEnded", "Study", "UnknownNameError", "deck_tree", "read"]
