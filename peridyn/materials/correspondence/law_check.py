"""Loading and checking a user's ``Stress Law`` (``module:function``) before a run starts.

:func:`load_law` imports the module and finds the function; whatever the import raises
(``SyntaxError``, ``sys.exit()``'s ``SystemExit``, any other exception; Ctrl-C aside) becomes an
:class:`LawError`, so a user module can never end the process. :func:`check_law` calls the law
once at the reference state (F = I, dt = 0, as the run's first evaluation calls it) and once at a
small strain, with the argument types the material's point loop passes, so that a law numba cannot
compile, a law that raises, returns something other than ``(stress (3, 3), state (<= 9,))`` or a
non-finite stress is bad input, found at set-up.
"""
from __future__ import annotations

import importlib
import inspect
import json
import re
import signal
import subprocess
import sys
import types
from typing import Any, Callable

import numpy as np

from ...core.fields import Length

#: the law's state variables per point (the columns of Stress_Law_State, a tensor-sized field)
STATE_SIZE = int(Length.TENSOR)
#: how a law is named, and what a working one looks like
EXAMPLE = "peridyn.materials.correspondence.laws:neo_hookean"
SIGNATURE = "law(F_old, F_new, state, dt, params) -> (Cauchy stress (3, 3) float64 array, state (at most 9,) array)"
#: the small strain of the second call: not symmetric, so a law that reads only part of F still sees it
SMALL_STRAIN = 1.0e-4 * np.array([[1.0, 0.3, 0.0], [0.2, -0.5, 0.1], [0.0, 0.1, 0.4]])
#: the step of the second call (T); the first uses 0, as the run's first force evaluation does
SMALL_STEP = 1.0e-6
_MISSING = object()
#: seconds the child that first imports a law and calls it once may take
PROBE_SECONDS = 60.0
_PROBE_DONE = "peridyn-law-probe-done"
#: the child: import the module, call the law once (zero parameters), report that it came back;
#: Python errors are left to the in-process checks, which word them
_PROBE = f"""
import json, os, sys
sys.path[:] = json.loads(sys.argv[1])
try:
    import importlib
    import numpy as np
    law = getattr(importlib.import_module(sys.argv[2]), sys.argv[3])
    law(np.eye(3), np.eye(3), np.zeros({STATE_SIZE}), 0.0, np.zeros(32))
except BaseException:
    pass
sys.stdout.write("{_PROBE_DONE}")
sys.stdout.flush()
os._exit(0)
"""
_PROBED: set[str] = set()


def _probe(spec: str, module_name: str, function: str) -> None:
    """Import ``module_name`` and call the law once in a child process (once per module:function),
    so that a module that ends the process, crashes or hangs is a :class:`LawError`."""
    if spec in _PROBED or module_name in sys.modules:
        return
    fix = "fix the module so that it imports and runs without ending the process (no os._exit, no crash, no endless loop)"
    try:
        done = subprocess.run([sys.executable, "-c", _PROBE, json.dumps(sys.path), module_name, function],
                              stdin=subprocess.DEVNULL, capture_output=True, timeout=PROBE_SECONDS)
    except subprocess.TimeoutExpired:
        raise LawError(f"module {module_name!r} of Stress Law {spec!r} did not finish importing and its first call "
                       f"in {PROBE_SECONDS:g} s (it hangs)", fix) from None
    if _PROBE_DONE.encode() not in done.stdout:
        code = done.returncode
        if code < 0:
            name = signal.Signals(-code).name if -code in signal.Signals._value2member_map_ else "unknown"
            what = f"crashed (signal {-code}, {name})"
        else:
            what = f"ended the process (exit status {code})"
        raise LawError(f"module {module_name!r} of Stress Law {spec!r} {what} on import or its first call", fix)
    _PROBED.add(spec)


class LawError(ValueError):
    """What is wrong with a Stress Law (``message``) and how to fix it (``fix``); deck validation
    reports it at the deck path ``Materials > NAME > Stress Law``."""

    def __init__(self, message: str, fix: str, key: str | None = None) -> None:
        super().__init__(f"{message}; {fix}")
        self.message = message
        self.fix = fix
        self.key = key


def _what(obj: Any) -> str:
    if isinstance(obj, types.ModuleType):
        return "a module"
    if inspect.isclass(obj):
        return f"a class ({obj.__name__})"
    if isinstance(obj, (types.BuiltinFunctionType, np.ufunc)):
        return "a built-in function"
    if inspect.isfunction(obj):
        return "a plain Python function"
    return f"a {type(obj).__name__}"


def _exception_text(exc: BaseException) -> str:
    """One line for an exception: numba's compile errors (many lines, colour codes) give their
    first statement and the place in the law's file."""
    text = re.sub(r"\x1b\[[0-9;]*m", "", str(exc))
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    if type(exc).__module__.startswith("numba"):
        body = [ln for ln in lines if not ln.startswith(("Failed in ", "File ", "During:", "- ", "^", "def ", "return "))]
        where = re.search(r'File "([^"]+)", line (\d+)', text)
        head = body[0] if body else (lines[0] if lines else "")
        place = f" ({where.group(1).rsplit('/', 1)[-1]}, line {where.group(2)})" if where else ""
        return f"{type(exc).__name__}: {head}{place}"
    if isinstance(exc, SystemExit):
        return f"SystemExit (sys.exit({exc.code!r}))"
    if isinstance(exc, SyntaxError) and exc.lineno:
        return f"SyntaxError: {exc.msg} ({(exc.filename or '?').rsplit('/', 1)[-1]}, line {exc.lineno})"
    return f"{type(exc).__name__}: {lines[0] if lines else ''}".rstrip(": ")


def load_law(spec: str) -> Callable[..., Any]:
    """The numba function named ``module:function``; :class:`LawError` naming what is wrong."""
    module_name, colon, function = spec.partition(":")
    if not colon or not module_name.strip() or not function.strip():
        raise LawError(f"{spec!r} is not module:function", f"name the law as module:function, e.g. {EXAMPLE}")
    if module_name.strip().startswith("."):
        raise LawError(f"module {module_name!r} of Stress Law {spec!r} is a relative name", "give the module's absolute name, e.g. mypackage.laws")
    _probe(spec, module_name.strip(), function.strip())
    try:
        module = importlib.import_module(module_name.strip())
    except KeyboardInterrupt:
        raise
    except ModuleNotFoundError as exc:
        raise LawError(f"module {module_name!r} of Stress Law {spec!r} cannot be imported: {_exception_text(exc)}",
                       "give an importable module (on sys.path or installed) and its function") from None
    except BaseException as exc:  # noqa: BLE001 - the user's module must never end the run (sys.exit included)
        raise LawError(f"module {module_name!r} of Stress Law {spec!r} failed on import: {_exception_text(exc)}",
                       "fix the module so that it imports cleanly (no sys.exit, no errors at import)") from None
    law = getattr(module, function.strip(), _MISSING)
    if law is _MISSING:
        close = [n for n in dir(module) if not n.startswith("_") and callable(getattr(module, n, None))][:5]
        known = f" (it has {', '.join(close)})" if close else ""
        raise LawError(f"module {module_name!r} has no {function!r}{known}", f"give module:function of a numba function in it, e.g. {EXAMPLE}")
    from numba.core.registry import CPUDispatcher

    if not isinstance(law, CPUDispatcher):
        raise LawError(f"Stress Law {spec!r} is {_what(law)}, not a numba-compiled function",
                       "decorate the law with @numba.njit (nopython mode) and name that function")
    options = getattr(law, "targetoptions", {})
    if options.get("forceobj") or options.get("nopython") is False:
        raise LawError(f"Stress Law {spec!r} is compiled in numba's object mode, which the material's point loop cannot call",
                       "decorate the law with @numba.njit (nopython mode)")
    try:
        inspect.signature(law.py_func).bind(*range(5))
    except TypeError:
        raise LawError(f"Stress Law {spec!r} takes {inspect.signature(law.py_func)}, but the material calls it with 5 arguments",
                       f"the law must be {SIGNATURE}") from None
    return law


def _checked_call(spec: str, law: Callable[..., Any], F_old: np.ndarray, F_new: np.ndarray, dt: float,
                  params: np.ndarray, where: str) -> None:
    try:
        result = law(F_old, F_new, np.zeros(STATE_SIZE), dt, params)
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 - numba TypingError, the law's own raise, ...
        compile_error = type(exc).__module__.startswith("numba")
        verb = "cannot be compiled by numba for the material's arguments" if compile_error else f"raised at {where}"
        raise LawError(f"Stress Law {spec!r} {verb}: {_exception_text(exc)}",
                       f"the law must be {SIGNATURE}" if compile_error else "make the law work there (check Law Parameters)") from None
    if not isinstance(result, tuple) or len(result) != 2:
        got = f"a tuple of {len(result)}" if isinstance(result, tuple) else _returned(result)
        raise LawError(f"Stress Law {spec!r} returned {got} at {where}, not the pair (stress, state)", f"return sigma, state: {SIGNATURE}")
    sigma, state = result
    if not isinstance(sigma, np.ndarray) or sigma.shape != (3, 3) or sigma.dtype != np.float64:
        raise LawError(f"Stress Law {spec!r} returned a stress that is {_returned(sigma)}, not a (3, 3) float64 array, at {where}",
                       "return the Cauchy stress as a (3, 3) float64 array first, e.g. np.zeros((3, 3))")
    if not isinstance(state, np.ndarray) or state.ndim != 1 or state.shape[0] > STATE_SIZE or state.dtype.kind not in "fiub":
        raise LawError(f"Stress Law {spec!r} returned a state that is {_returned(state)}, not a 1-D array of at most {STATE_SIZE} "
                       f"numbers, at {where}", f"return the law's state as a 1-D float array of at most {STATE_SIZE} values, e.g. state.copy()")
    for name, values in (("stress", sigma), ("state", state)):
        if not np.all(np.isfinite(values)):
            raise LawError(f"Stress Law {spec!r} returned a non-finite {name} at {where}",
                           "make the law finite there (check Law Parameters and divisions by J or dt)")


def _returned(value: Any) -> str:
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    if isinstance(value, bool):
        return "a bool"
    if isinstance(value, (int, float, complex, np.number)):
        return f"a {'float' if isinstance(value, (float, np.floating)) else type(value).__name__} ({value!r})"
    return f"a {type(value).__name__}"


def check_law(spec: str, parameters: list[float]) -> Callable[..., Any]:
    """The law of ``spec``, called at F = I (dt = 0) and at a small strain with the deck's
    ``parameters``; :class:`LawError` if it cannot be loaded or compiled, raises, or returns
    anything but a (3, 3) float64 stress and a state of at most 9 numbers, all finite."""
    law = load_law(spec)
    params = np.asarray(parameters, dtype=np.float64)
    eye = np.eye(3)
    _checked_call(spec, law, eye, eye.copy(), 0.0, params, "the reference state (F = I, dt = 0)")
    _checked_call(spec, law, eye, eye + SMALL_STRAIN, SMALL_STEP, params, "a small strain (F = I + 1e-4 G)")
    return law
