"""``peridyn verify``: verification problems, each run at a ladder of resolutions, their error
against wall time, fitted convergence rates and stability limits, checked against stated bands.

- :mod:`.problems`: the problems (``PROBLEMS``, by name), each with what it computes, its exact or
  reference answer and its bands;
- :mod:`.runner`: runs the points serially, times them, rewrites ``results.json`` after each;
- :mod:`.report`: ``report.md`` and the figures (``peridyn[plot]``: matplotlib);
- :mod:`.fit`: fitted rates;
- :mod:`.listing`: the problem list of ``peridyn verify --help``;
- :mod:`.mutation` and :mod:`.mutations`: physics errors put into a copy of the package, and the
  problems that must catch each (docs/verify.md).
"""
from __future__ import annotations

import importlib
from typing import Any

#: the public names, and the submodule each is read from on first use (the problems take about a
#: second to import: ``peridyn --help`` and ``peridyn verify --help`` import only :mod:`.listing`)
_EXPORTS = {"PROBLEMS": "problems", "Check": "problems", "Measurement": "problems", "Problem": "problems",
            "Run": "runner", "run_verify": "runner", "select_problems": "runner", "fit_rate": "fit"}

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    globals()[name] = value
    return value
