"""``peridyn verify``: verification problems, each run at a ladder of resolutions, their error
against wall time, fitted convergence rates and stability limits, checked against stated bands.

- :mod:`.problems`: the problems (``PROBLEMS``, by name), each with what it computes, its exact or
  reference answer and its bands;
- :mod:`.runner`: runs the points serially, times them, rewrites ``results.json`` after each;
- :mod:`.report`: ``report.md`` and the figures (``peridyn[plot]``: matplotlib);
- :mod:`.fit`: fitted rates;
- :mod:`.mutation` and :mod:`.mutations`: physics errors put into a copy of the package, and the
  problems that must catch each (docs/verify.md).
"""
from __future__ import annotations

from .fit import fit_rate
from .problems import PROBLEMS, Check, Measurement, Problem
from .runner import Run, run_verify, select_problems

__all__ = ["PROBLEMS", "Check", "Measurement", "Problem", "Run", "fit_rate", "run_verify", "select_problems"]
