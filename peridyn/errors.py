"""Deprecated alias of :mod:`peridyn.core.errors` (moved with the layout of issue 10).

``from peridyn.errors import InputError`` keeps working with a DeprecationWarning; import from
``peridyn.core.errors`` instead.
"""
from __future__ import annotations

import warnings

from .core.errors import (  # noqa: F401
    ExitCode,
    InputError,
    InputErrors,
    InstabilityError,
    PeridynError,
    format_path,
    raise_collected,
)

warnings.warn(
    "peridyn.errors moved to peridyn.core.errors; import from there",
    DeprecationWarning,
    stacklevel=2,
)
