"""Checks of the arguments of the Python API: one error naming the argument, what was given and
what is accepted.

:class:`ArgumentError` is an :class:`~peridyn.core.errors.InputError` (so ``Study`` and the
command line report it on one line) and a ``ValueError``; :class:`ArgumentTypeError` is also a
``TypeError``; :class:`UnknownNameError` (a field, node set, compute or output that does not
exist) is also a ``KeyError``.
"""
from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..core.errors import InputError


class ArgumentError(InputError, ValueError):
    """A bad argument of an API call: ``path`` is (call, argument), e.g. ``("Model.step", "n")``."""


class ArgumentTypeError(ArgumentError, TypeError):
    """An argument of the wrong type."""


class UnknownNameError(ArgumentError, KeyError):
    """A name (field, node set, compute, output section) the model does not have."""

    def __str__(self) -> str:  # KeyError would quote the message
        return self.one_line()


def whole_number(call: str, arg: str, value: Any, minimum: int) -> int:
    """``value`` as an int, when it is a whole number (int or numpy int, not bool) >= ``minimum``."""
    accepted = f"a whole number >= {minimum}"
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise ArgumentTypeError(f"{arg} must be {accepted}, not {type(value).__name__} {value!r}", path=(call, arg),
                                fix=f"give {arg} as an int (e.g. {max(minimum, 1)})")
    if int(value) < minimum:
        raise ArgumentError(f"{arg} must be {accepted}, got {int(value)}", path=(call, arg), fix=f"give {arg} >= {minimum}")
    return int(value)


def finite_number(call: str, arg: str, value: Any) -> float:
    """``value`` as a float, when it is a real number (not bool) that is finite."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ArgumentTypeError(f"{arg} must be a finite number, not {type(value).__name__} {value!r}", path=(call, arg),
                                fix=f"give {arg} as a float")
    if not math.isfinite(float(value)):
        raise ArgumentError(f"{arg} must be a finite number, got {float(value)!r}", path=(call, arg), fix=f"give a finite {arg}")
    return float(value)


def name_text(call: str, arg: str, value: Any) -> str:
    """``value`` when it is a non-empty str."""
    if not isinstance(value, str) or not value.strip():
        raise ArgumentTypeError(f"{arg} must be a non-empty str, not {type(value).__name__} {value!r}", path=(call, arg),
                                fix=f"give {arg} as text")
    return value


def a_callable(call: str, arg: str, value: Any, signature: str, nargs: int | None = None) -> Any:
    """``value`` when it can be called (with ``nargs`` positional arguments, when given and its
    signature is known)."""
    if not callable(value):
        raise ArgumentTypeError(f"{arg} must be a callable {signature}, not {type(value).__name__}", path=(call, arg),
                                fix=f"pass a function {signature}")
    if nargs is not None:
        import inspect

        try:
            sig = inspect.signature(value)
        except (TypeError, ValueError):  # a builtin without a signature: called as it is
            return value
        try:
            sig.bind(*range(nargs))
        except TypeError:
            raise ArgumentTypeError(f"{arg} is called with {nargs} argument(s) as {signature}, but it takes {sig}", path=(call, arg),
                                    fix=f"pass a function {signature}") from None
    return value


def as_array(call: str, arg: str, values: Any) -> np.ndarray:
    """``np.asarray(values)``; a ragged or odd object is an :class:`ArgumentTypeError`."""
    try:
        return np.asarray(values)
    except (ValueError, TypeError) as exc:
        raise ArgumentTypeError(f"{arg} is not an array ({exc})", path=(call, arg), fix="give a numpy array or a list of numbers") from None


def real_array(call: str, arg: str, values: Any, shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
    """``values`` as a (broadcast, read-only view) array of ``shape`` and ``dtype``: real numbers
    (bools, text, complex or objects refused), finite, whole numbers for an integer ``dtype``."""
    want = "x".join(map(str, shape))
    arr = as_array(call, arg, values)
    if arr.dtype.kind not in "iuf":
        raise ArgumentTypeError(f"{arg} holds {arr.dtype} values; expected real numbers", path=(call, arg),
                                fix=f"give a ({want}) array of numbers")
    try:
        arr = np.broadcast_to(arr, shape)
    except ValueError:
        raise ArgumentError(f"{arg} has shape {arr.shape}, which does not broadcast to {shape}", path=(call, arg),
                            fix=f"give a ({want}) array, or one that broadcasts to it (one value, one row)") from None
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise ArgumentError(f"{arg} holds {int(np.count_nonzero(~np.isfinite(arr)))} non-finite value(s)", path=(call, arg),
                            fix="give finite values")
    if np.dtype(dtype).kind in "iu" and arr.dtype.kind == "f" and not np.all(arr == np.round(arr)):
        raise ArgumentError(f"{arg} holds values that are not whole numbers; the field holds {np.dtype(dtype)}", path=(call, arg),
                            fix="give whole numbers")
    return arr.astype(dtype, copy=False)


def region_mapping(call: str, arg: str, region: Any):
    """A region mapping (``{"Half Space": {"Point": [...], "Normal": [...]}}``, docs/regions.md)
    validated as a deck's would be: a :class:`~peridyn.deck.regions.RegionSpec`."""
    from pydantic import ValidationError

    from ..deck.regions import REGION_KEYS, RegionSpec

    if not isinstance(region, Mapping):
        raise ArgumentTypeError(f"{arg} must be a region mapping, not {type(region).__name__}", path=(call, arg),
                                fix=f"give one of the keys {', '.join(REGION_KEYS)} (docs/regions.md)")
    try:
        return RegionSpec.model_validate(plain(region))
    except ValidationError as exc:
        first = exc.errors()[0]
        where = " > ".join(str(p) for p in first.get("loc", ()) if p != "__root__")
        message = str(first.get("msg", exc)).removeprefix("Value error, ")
        raise ArgumentError(f"{where + ': ' if where else ''}{message}", path=(call, arg),
                            fix="see docs/regions.md for the keys of each region") from None
    except (ValueError, TypeError, RecursionError) as exc:
        raise ArgumentError(f"not a region ({exc})", path=(call, arg), fix="see docs/regions.md") from None


def plain(value: Any) -> Any:
    """A dict deck's ``value`` as the same deck in a YAML file reads (``deck.source.typed_tree``:
    numpy values as Python ones, ints among floats as floats, numbers among strings as text)."""
    from ..deck.source import typed_tree

    return typed_tree(value)
