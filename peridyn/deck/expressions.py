"""Peridigm's function strings, compiled once into vectorized numpy evaluators.

Peridigm evaluates boundary-condition values, string horizons, user influence functions and the
time-dependent critical stretch with Trilinos pamgen's run-time compiler (RTCompiler, a small
C-like language). This module re-implements that language with its own tokenizer and
recursive-descent parser; user text is never handed to ``eval``, ``exec``, ``compile`` or ``ast``.

Language (PERIDIGM_SEMANTICS.md §1.5):

* Text without the substring ``value`` means ``value = <text>``; otherwise it is a statement
  list that must assign ``value``: ``value = e;``, ``double a = e;``, ``double a;``, ``a = e;``,
  ``if (c) {...} else if (c) {...} else {...}`` (a block may also be one statement without
  braces). ``;`` separates statements, a final one is optional. ``/* comments */`` are allowed
  and a backslash is ignored (RTCompiler's "aprepro-safe brace" ``\\{``).
* Precedence, low to high: ``||``; ``&&``; ``== !=``; ``< > <= >=``; ``+ -``; ``* / %``;
  ``^`` (right-associative); unary ``- + !`` (tightest: ``-2^2`` is 4).
  Comparisons and logical operators give 1.0 or 0.0; NaN counts as true, as in C.
* ``a % b`` is RTCompiler's ``(int)a % (int)b``: both operands truncated toward zero, the
  remainder has the dividend's sign (``-7 % 3`` is -1, ``7.9 % 2.5`` is 1). NaN if the
  truncated divisor is 0 or an operand is not finite (C leaves those undefined).
* Functions: sin cos tan asin acos atan atan2 sinh cosh tanh sqrt exp log log10 pow abs fabs
  floor ceil min max (C's fmin/fmax), and ``rnd(a)``, uniform in [-a, a) per point. Constant
  ``pi`` unless shadowed.

Random numbers. ``rnd(a)`` is a pure function, not a generator's next draw: a counter-based hash
(splitmix64) of the seed, the expression's stream (where it stands in the deck, e.g.
``Boundary Conditions > Initial Velocity X``; its text when not given), the call's position in
the text (the second ``rnd`` of an expression differs from the first) and the point's *global*
id (``expr(point_ids, x=...)``; without ids, the bits of the input values stand in for it).
Hence the same field on any number of MPI ranks, in any process, for any earlier history, and
at every time a condition is evaluated. The seed is the deck's top-level ``Random Seed``
(default 0), set for the expressions compiled inside :func:`random_seed`, or given to
:func:`compile_expression`.

Numerics. Every operation is done in double precision in the order written. Scalar inputs are
evaluated with Python floats and :mod:`math` (the C library, as Peridigm); C's inf/NaN results
replace Python's exceptions. On arrays, + - * / and sqrt, fabs, floor, ceil, fmin, fmax are
numpy's (exactly rounded, so identical); the transcendental functions and ``pow``/``^`` go through
a small numba kernel that calls the same C library per element, because numpy's SIMD versions
differ from it in the last bit. A point of an array therefore gets bit for bit the result of a
scalar evaluation (rnd aside). Without numba, numpy's functions are used.
"""
from __future__ import annotations

import contextlib
import contextvars
import difflib
import hashlib
import math
import operator
import re
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

__all__ = ["Expression", "ExpressionError", "compile_expression", "constant_not_finite", "random_seed", "set_random_seed"]

_NAN = math.nan
_PI = 3.141592653589793
_SHAPE = "#shape"  # env key of the evaluation shape (not an identifier, so no clash)
_VALUE = "value"
_OWN = "#own"  # env key: arrays made by masked assignments, each private to one slot


# --------------------------------------------------------------------------------------------
# errors


class ExpressionError(ValueError):
    """Bad expression text.

    Attributes: ``text`` (the text as given), ``position`` (0-based index into ``text``, or -1
    when no single place is at fault), ``reason`` (what is wrong) and ``hint`` (suggestions,
    may be empty). ``str(e)`` is one line, e.g.
    ``unknown name 'q' at column 1 in 'q*2'; known names: x, y, z, t``.
    """

    def __init__(self, text: str, position: int, reason: str, hint: str = "") -> None:
        self.text = text
        self.position = position
        self.reason = reason
        self.hint = hint
        super().__init__(self._message())

    def _message(self) -> str:
        where = f" at column {self.position + 1}" if self.position >= 0 else ""
        msg = f"{self.reason}{where} in {self._excerpt()!r}"
        return f"{msg}; {self.hint}" if self.hint else msg

    def _excerpt(self, width: int = 60) -> str:
        """The text, or for a long one the part around the position (``...`` marks cuts)."""
        text = self.text
        if len(text) <= width:
            return text
        at = self.position if self.position >= 0 else 0
        start = max(0, min(at - width // 2, len(text) - width))
        cut = text[start : start + width]
        return ("..." if start > 0 else "") + cut + ("..." if start + width < len(text) else "")

    def __str__(self) -> str:
        return self._message()

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self.text, self.position, self.reason, self.hint))


# --------------------------------------------------------------------------------------------
# random numbers for rnd()

_M64 = (1 << 64) - 1
_GOLDEN = 0x9E3779B97F4A7C15
_C1 = 0xBF58476D1CE4E5B9
_C2 = 0x94D049BB133111EB
_IDS = "#ids"  # env key: the uint64 point keys rnd() hashes (global ids, or the inputs' bits)
_KEY = "#key"  # env key: the expression's random key (seed and stream)
_SEED: contextvars.ContextVar[int] = contextvars.ContextVar("peridyn_random_seed", default=0)


def _mix_int(z: int) -> int:
    """splitmix64 of a Python int (0 <= z < 2**64)."""
    z = (z + _GOLDEN) & _M64
    z = ((z ^ (z >> 30)) * _C1) & _M64
    z = ((z ^ (z >> 27)) * _C2) & _M64
    return z ^ (z >> 31)


def _mix_array(z: np.ndarray) -> np.ndarray:
    """splitmix64 of every element of a uint64 array (wrapping arithmetic)."""
    z = z + np.uint64(_GOLDEN)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(_C1)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(_C2)
    return z ^ (z >> np.uint64(31))


def random_key(seed: int, stream: str) -> int:
    """The 64-bit key of an expression's random numbers: its seed and its stream name."""
    h = int.from_bytes(hashlib.blake2b(stream.encode("utf-8", "surrogatepass"), digest_size=8).digest(), "little")
    return _mix_int(_mix_int(int(seed) & _M64) ^ h)


def _float_bits(v: Any) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(v, dtype=np.float64)).view(np.uint64)


def _uniform(key: int, index: int, ids: np.ndarray) -> np.ndarray:
    """Uniform [0, 1) per element of the uint64 array ``ids``, for call ``index``."""
    k = np.uint64(_mix_int(key ^ _mix_int(index)))
    h = _mix_array(_mix_array(np.atleast_1d(ids) ^ k))
    return ((h >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)).reshape(np.shape(ids))


def set_random_seed(seed: int = 0) -> None:
    """Set the default seed of ``rnd(a)`` for expressions compiled from now on (default 0).
    A deck's ``Random Seed`` takes precedence inside a simulation (:func:`random_seed`)."""
    _SEED.set(int(seed))


@contextlib.contextmanager
def random_seed(seed: int):
    """Expressions compiled inside the block use ``seed`` unless given one."""
    token = _SEED.set(int(seed))
    try:
        yield
    finally:
        _SEED.reset(token)


# --------------------------------------------------------------------------------------------
# C-library math on arrays (numba kernels, compiled lazily and cached on disk)

_UNARY_CODES = {
    "sin": 0, "cos": 1, "tan": 2, "asin": 3, "acos": 4, "atan": 5,
    "sinh": 6, "cosh": 7, "tanh": 8, "exp": 9, "log": 10, "log10": 11,
}
_NUMPY_UNARY = {
    "sin": np.sin, "cos": np.cos, "tan": np.tan, "asin": np.arcsin, "acos": np.arccos,
    "atan": np.arctan, "sinh": np.sinh, "cosh": np.cosh, "tanh": np.tanh, "exp": np.exp,
    "log": np.log, "log10": np.log10,
}
_BINARY_CODES = {"pow": 0, "atan2": 1}
_NUMPY_BINARY = {"pow": np.power, "atan2": np.arctan2}


def _libm_unary_py(code, x, out):  # pragma: no cover - runs compiled
    n = x.size
    if code == 0:
        for i in range(n):
            out[i] = math.sin(x[i])
    elif code == 1:
        for i in range(n):
            out[i] = math.cos(x[i])
    elif code == 2:
        for i in range(n):
            out[i] = math.tan(x[i])
    elif code == 3:
        for i in range(n):
            out[i] = math.asin(x[i])
    elif code == 4:
        for i in range(n):
            out[i] = math.acos(x[i])
    elif code == 5:
        for i in range(n):
            out[i] = math.atan(x[i])
    elif code == 6:
        for i in range(n):
            out[i] = math.sinh(x[i])
    elif code == 7:
        for i in range(n):
            out[i] = math.cosh(x[i])
    elif code == 8:
        for i in range(n):
            out[i] = math.tanh(x[i])
    elif code == 9:
        for i in range(n):
            out[i] = math.exp(x[i])
    elif code == 10:
        for i in range(n):
            out[i] = math.log(x[i])
    else:
        for i in range(n):
            out[i] = math.log10(x[i])


def _libm_binary_py(code, a, b, out):  # pragma: no cover - runs compiled
    n = out.size
    if code == 0:
        for i in range(n):
            out[i] = math.pow(a[i], b[i])
    else:
        for i in range(n):
            out[i] = math.atan2(a[i], b[i])


_kernels: tuple[Callable[..., None], Callable[..., None]] | None = None
_kernels_failed = False


def _get_kernels() -> tuple[Callable[..., None], Callable[..., None]] | None:
    """The compiled C-library kernels, or None when numba is unavailable."""
    global _kernels, _kernels_failed
    if _kernels is None and not _kernels_failed:
        try:
            import numba
            from numba import types

            # inputs may be read-only (views made by np.broadcast_to, callers' arrays)
            ro = types.Array(types.float64, 1, "C", readonly=True)
            rw = types.float64[::1]
            sig1 = types.void(types.int64, ro, rw)
            sig2 = types.void(types.int64, ro, ro, rw)
            _kernels = (
                numba.njit(sig1, cache=True)(_libm_unary_py),
                numba.njit(sig2, cache=True)(_libm_binary_py),
            )
        except Exception:  # noqa: BLE001 - any numba problem: fall back to numpy
            _kernels_failed = True
    return _kernels


def _array_unary(name: str) -> Callable[[np.ndarray], np.ndarray]:
    code = _UNARY_CODES[name]
    fallback = _NUMPY_UNARY[name]

    def apply(x: np.ndarray) -> np.ndarray:
        kernels = _get_kernels()
        if kernels is None:
            return fallback(x)
        flat = np.ascontiguousarray(x, dtype=np.float64).reshape(-1)
        out = np.empty(flat.size, dtype=np.float64)
        kernels[0](code, flat, out)
        return out.reshape(np.shape(x))

    return apply


def _flat(a: Any, shape: tuple[int, ...]) -> np.ndarray:
    """``a`` broadcast to ``shape`` as a contiguous 1-D float64 array (no copy if possible)."""
    if np.shape(a) != shape:
        a = np.broadcast_to(a, shape)
    return np.ascontiguousarray(a, dtype=np.float64).reshape(-1)


def _array_binary(name: str) -> Callable[[Any, Any], np.ndarray]:
    code = _BINARY_CODES[name]
    fallback = _NUMPY_BINARY[name]

    def apply(a: Any, b: Any) -> np.ndarray:
        kernels = _get_kernels()
        if kernels is None:
            return fallback(a, b)
        shape = np.broadcast_shapes(np.shape(a), np.shape(b))
        fa = _flat(a, shape)
        fb = _flat(b, shape)
        out = np.empty(fa.size, dtype=np.float64)
        kernels[1](code, fa, fb, out)
        return out.reshape(shape)

    return apply


# --------------------------------------------------------------------------------------------
# scalar helpers with C semantics (inf/NaN instead of Python exceptions)


def _np_scalar(ufunc: Callable[..., Any], *args: float) -> float:
    with np.errstate(all="ignore"):
        return float(ufunc(*(np.float64(a) for a in args)))


def _scalar_unary(name: str) -> Callable[[float], float]:
    fn = getattr(math, name)
    fallback = _NUMPY_UNARY[name]

    def apply(v: float) -> float:
        try:
            return fn(v)
        except (ValueError, OverflowError):
            return _np_scalar(fallback, v)

    return apply


def _scalar_pow(a: float, b: float) -> float:
    try:
        return math.pow(a, b)
    except (ValueError, OverflowError, ZeroDivisionError):
        return _np_scalar(np.power, a, b)


def _scalar_sqrt(v: float) -> float:
    try:
        return math.sqrt(v)
    except ValueError:
        return _NAN


def _mod_array(a: Any, b: Any) -> Any:
    tb = np.trunc(b)
    r = np.fmod(np.trunc(a), tb) + 0.0  # + 0.0: an int remainder is never -0.0
    if np.isinf(tb).any():  # fmod(finite, inf) is finite; (int)inf is undefined in C
        r = np.where(np.isinf(tb), _NAN, r)
    return r


def _mod_scalar(a: float, b: float) -> float:
    if not (math.isfinite(a) and math.isfinite(b)):
        return _NAN
    tb = float(math.trunc(b))
    if tb == 0.0:
        return _NAN
    return math.fmod(float(math.trunc(a)), tb) + 0.0


# --------------------------------------------------------------------------------------------
# functions: name -> (argument count, builder(list of arg closures) -> closure)

Env = dict[str, Any]
Fn = Callable[[Env], Any]


def _make_unary_fn(scalar: Callable[[float], float], array: Callable[[Any], Any]) -> Callable:
    def build(args: list[Fn]) -> Fn:
        (a,) = args

        def f(env: Env) -> Any:
            v = a(env)
            if type(v) is float:
                return scalar(v)
            return array(v)

        return f

    return build


def _make_binary_fn(scalar: Callable[[float, float], float], array: Callable) -> Callable:
    def build(args: list[Fn]) -> Fn:
        a, b = args

        def f(env: Env) -> Any:
            x = a(env)
            y = b(env)
            if type(x) is float and type(y) is float:
                return scalar(x, y)
            return array(x, y)

        return f

    return build


def _build_rnd(args: list[Fn], index: int = 0) -> Fn:
    (a,) = args

    def f(env: Env) -> Any:
        amp = a(env)
        u = _uniform(env[_KEY], index, env[_IDS])
        if u.ndim == 0:
            return amp * (2.0 * float(u) - 1.0)
        return amp * (2.0 * u - 1.0)

    return f


def _floor_s(v: float) -> float:
    return float(np.floor(v))


def _ceil_s(v: float) -> float:
    return float(np.ceil(v))


def _fmin_s(a: float, b: float) -> float:
    return float(np.fmin(a, b))


def _fmax_s(a: float, b: float) -> float:
    return float(np.fmax(a, b))


_FUNCTIONS: dict[str, tuple[int, Callable[[list[Fn]], Fn]]] = {
    name: (1, _make_unary_fn(_scalar_unary(name), _array_unary(name))) for name in _UNARY_CODES
}
_FUNCTIONS.update(
    {
        "sqrt": (1, _make_unary_fn(_scalar_sqrt, np.sqrt)),
        "abs": (1, _make_unary_fn(math.fabs, np.abs)),
        "fabs": (1, _make_unary_fn(math.fabs, np.abs)),
        "floor": (1, _make_unary_fn(_floor_s, np.floor)),
        "ceil": (1, _make_unary_fn(_ceil_s, np.ceil)),
        "pow": (2, _make_binary_fn(_scalar_pow, _array_binary("pow"))),
        "atan2": (2, _make_binary_fn(math.atan2, _array_binary("atan2"))),
        "min": (2, _make_binary_fn(_fmin_s, np.fmin)),
        "max": (2, _make_binary_fn(_fmax_s, np.fmax)),
        "rnd": (1, _build_rnd),
    }
)

_KEYWORDS = {"if", "else", "double"}
_UNSUPPORTED_KEYWORDS = {"int", "long", "float", "char", "for", "while", "return"}


# --------------------------------------------------------------------------------------------
# tokenizer

_TOKEN_RE = re.compile(
    r"""
    (?P<ws>[ \t\r\n\f\v\\]+)                     # whitespace; a backslash is ignored (RTCompiler)
  | (?P<comment>/\*.*?\*/)
  | (?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z_0-9]*)
  | (?P<op>\|\||&&|==|!=|<=|>=|[-+*/%^!=<>(){},;])
    """,
    re.VERBOSE | re.DOTALL | re.ASCII,
)


class _Tok:
    __slots__ = ("kind", "text", "pos")

    def __init__(self, kind: str, text: str, pos: int) -> None:
        self.kind = kind  # "num", "name", "op", "end"
        self.text = text
        self.pos = pos

    def __repr__(self) -> str:
        return f"_Tok({self.kind}, {self.text!r}, {self.pos})"


# --------------------------------------------------------------------------------------------
# syntax tree


class _Node:
    __slots__ = ()


class _Num(_Node):
    __slots__ = ("value",)

    def __init__(self, value: float) -> None:
        self.value = value


class _Ref(_Node):
    """A read of an input variable (``kind='var'``), a local, or ``value``."""

    __slots__ = ("key", "kind")

    def __init__(self, key: str, kind: str) -> None:
        self.key = key
        self.kind = kind


class _Unary(_Node):
    __slots__ = ("op", "arg")

    def __init__(self, op: str, arg: _Node) -> None:
        self.op = op
        self.arg = arg


class _Binary(_Node):
    __slots__ = ("op", "left", "right")

    def __init__(self, op: str, left: _Node, right: _Node) -> None:
        self.op = op
        self.left = left
        self.right = right


class _Call(_Node):
    __slots__ = ("name", "args", "index")

    def __init__(self, name: str, args: list[_Node], index: int = 0) -> None:
        self.name = name
        self.args = args
        self.index = index  #: rnd: its position among the text's rnd calls


class _Assign:
    __slots__ = ("targets", "expr", "declare")

    def __init__(self, targets: list[str], expr: _Node | None, declare: bool) -> None:
        self.targets = targets  # env keys, assigned right to left (all get the same value)
        self.expr = expr  # None: "double a;" (a = 0.0)
        self.declare = declare


class _If:
    __slots__ = ("branches",)

    def __init__(self, branches: list[tuple[_Node | None, list[Any]]]) -> None:
        self.branches = branches  # (condition or None for else, statements)


# --------------------------------------------------------------------------------------------
# parser

_BINARY_LEVELS: list[tuple[str, ...]] = [
    ("||",),
    ("&&",),
    ("==", "!="),
    ("<", ">", "<=", ">="),
    ("+", "-"),
    ("*", "/", "%"),
]


class _Parser:
    def __init__(self, original: str, source: str, offset: int, variables: tuple[str, ...]):
        self.original = original
        self.source = source  # text actually parsed ("value = " + original, or original)
        self.offset = offset  # length of the added prefix
        self.variables = variables
        self.varset = frozenset(variables)
        self.tokens = self._tokenize()
        self.i = 0
        self.scopes: list[dict[str, str]] = []
        self.n_locals = 0
        self.used: set[str] = set()
        self.has_rnd = False
        self.n_rnd = 0
        self.assigns_value = False
        self.reads_value = False

    # -- errors
    def error(self, pos: int, reason: str, hint: str = "") -> ExpressionError:
        if pos >= 0:
            pos = max(pos - self.offset, 0)
        return ExpressionError(self.original, pos, reason, hint)

    # -- tokens
    def _tokenize(self) -> list[_Tok]:
        src = self.source
        toks: list[_Tok] = []
        pos = 0
        n = len(src)
        while pos < n:
            m = _TOKEN_RE.match(src, pos)
            if m is None:
                ch = src[pos]
                if src.startswith("/*", pos):
                    raise self.error(pos, "comment '/*' is never closed")
                if ch in "|&":
                    raise self.error(pos, f"unknown operator {ch!r}", f"did you mean '{ch * 2}'?")
                raise self.error(pos, f"unexpected character {ch!r}")
            kind = m.lastgroup
            text = m.group()
            if kind == "num":
                end = m.end()
                if end < n and (src[end].isalnum() or src[end] in "_."):
                    stop = end
                    while stop < n and (src[stop].isalnum() or src[stop] in "_."):
                        stop += 1
                    raise self.error(pos, f"malformed number {src[pos:stop]!r}")
                toks.append(_Tok("num", text, pos))
            elif kind == "name" or kind == "op":
                toks.append(_Tok(kind, text, pos))
            pos = m.end()
        toks.append(_Tok("end", "", n))
        return toks

    @property
    def tok(self) -> _Tok:
        return self.tokens[self.i]

    def peek(self, k: int = 1) -> _Tok:
        return self.tokens[min(self.i + k, len(self.tokens) - 1)]

    def advance(self) -> _Tok:
        t = self.tokens[self.i]
        if t.kind != "end":
            self.i += 1
        return t

    def at_op(self, *ops: str) -> bool:
        t = self.tok
        return t.kind == "op" and t.text in ops

    def describe(self, t: _Tok) -> str:
        return "end of text" if t.kind == "end" else repr(t.text)

    def expect_op(self, op: str, context: str) -> _Tok:
        if not self.at_op(op):
            t = self.tok
            raise self.error(t.pos, f"expected '{op}' {context}, found {self.describe(t)}")
        return self.advance()

    # -- names
    def lookup_local(self, name: str) -> str | None:
        for scope in reversed(self.scopes):
            if name in scope:
                return scope[name]
        return None

    def known_names(self) -> list[str]:
        names = list(self.variables)
        for scope in self.scopes:
            names.extend(n for n in scope if n not in names)
        return names

    def unknown_name(self, t: _Tok) -> ExpressionError:
        known = self.known_names()
        candidates = known + [_VALUE] + ([] if "pi" in known else ["pi"])
        close = difflib.get_close_matches(t.text, candidates, n=3)
        hint = f"did you mean {' or '.join(repr(c) for c in close)}? " if close else ""
        hint += f"known names: {', '.join(known) if known else '(none)'}"
        return self.error(t.pos, f"unknown name {t.text!r}", hint)

    # -- statements
    def parse_program(self) -> list[Any]:
        self.scopes.append({})
        stmts = self.parse_statements(top=True)
        t = self.tok
        if t.kind != "end":  # a stray '}'
            raise self.error(t.pos, "unbalanced braces: unmatched '}'")
        return stmts

    def parse_statements(self, top: bool) -> list[Any]:
        stmts: list[Any] = []
        while True:
            t = self.tok
            if t.kind == "end":
                if not top:
                    raise self.error(t.pos, "unbalanced braces: a '{' is never closed")
                return stmts
            if t.kind == "op" and t.text == "}":
                return stmts
            if t.kind == "op" and t.text == ";":
                self.advance()
                continue
            stmts.append(self.parse_statement())

    def parse_block(self) -> list[Any]:
        self.scopes.append({})
        try:
            if self.at_op("{"):
                open_tok = self.advance()
                stmts = self.parse_statements(top=False)
                if not self.at_op("}"):
                    raise self.error(open_tok.pos, "unbalanced braces: '{' is never closed")
                self.advance()
                return stmts
            return [self.parse_statement()]
        finally:
            self.scopes.pop()

    def end_simple_statement(self) -> None:
        t = self.tok
        if t.kind == "op" and t.text == ";":
            self.advance()
        elif t.kind == "end" or (t.kind == "op" and t.text == "}") or (
            t.kind == "name" and t.text == "else"
        ):
            pass
        elif t.kind == "op" and t.text == ")":
            raise self.error(t.pos, "unbalanced parentheses: unmatched ')'")
        elif t.kind == "op" and t.text == "=":
            raise self.error(t.pos, "'=' can only assign to a variable name")
        else:
            raise self.error(t.pos, f"unexpected {self.describe(t)}", "expected an operator or ';'")

    def parse_statement(self) -> Any:
        t = self.tok
        if t.kind == "op" and t.text == "{":
            return _If([(None, self.parse_block())])  # a bare block: always executed
        if t.kind != "name":
            if t.kind == "op" and t.text == "}":
                raise self.error(t.pos, "unbalanced braces: unmatched '}'")
            raise self.error(t.pos, f"expected a statement, found {self.describe(t)}")
        if t.text == "if":
            return self.parse_if()
        if t.text == "else":
            raise self.error(t.pos, "'else' without a matching 'if'")
        if t.text == "double":
            return self.parse_declaration()
        if t.text in _UNSUPPORTED_KEYWORDS:
            raise self.error(t.pos, f"{t.text!r} is not supported", "declare locals as 'double'")
        if self.peek().kind == "op" and self.peek().text == "=":
            stmt = self.parse_assignment()
            self.end_simple_statement()
            return stmt
        if self.lookup_local(t.text) or t.text in self.varset or t.text == _VALUE or (
            t.text in _FUNCTIONS
        ) or t.text == "pi":
            # a known name used as a statement: read the expression to report a useful error
            self.parse_expression()
            self.end_simple_statement()
            raise self.error(t.pos, "a statement must be an assignment", "write 'value = ...'")
        raise self.unknown_name(t)

    def assign_target(self, t: _Tok) -> str:
        name = t.text
        if name == _VALUE:
            self.assigns_value = True
            return _VALUE
        key = self.lookup_local(name)
        if key is not None:
            return key
        if name in self.varset:
            raise self.error(t.pos, f"cannot assign to input variable {name!r}")
        if name in _KEYWORDS or name in _FUNCTIONS:
            raise self.error(t.pos, f"cannot assign to {name!r}")
        raise self.error(
            t.pos,
            f"assignment to undeclared name {name!r}",
            f"assign 'value', or declare it first: 'double {name} = ...;'",
        )

    def parse_assignment(self) -> _Assign:
        targets = [self.assign_target(self.advance())]
        self.advance()  # '='
        while self.tok.kind == "name" and self.peek().kind == "op" and self.peek().text == "=":
            targets.append(self.assign_target(self.advance()))
            self.advance()
        return _Assign(targets, self.parse_expression(), declare=False)

    def parse_declaration(self) -> _Assign:
        self.advance()  # 'double'
        t = self.tok
        if t.kind != "name":
            raise self.error(t.pos, f"expected a name after 'double', found {self.describe(t)}")
        name = t.text
        if name in _KEYWORDS or name in _UNSUPPORTED_KEYWORDS or name in _FUNCTIONS:
            raise self.error(t.pos, f"{name!r} cannot be a variable name")
        if name == _VALUE or name in self.varset:
            raise self.error(t.pos, f"{name!r} is already a variable and cannot be declared")
        if name in self.scopes[-1]:
            raise self.error(t.pos, f"{name!r} is declared twice")
        self.advance()
        expr = None
        extra: list[str] = []
        if self.at_op("="):
            self.advance()
            # "double a = b = 1;" also assigns b
            while self.tok.kind == "name" and self.peek().kind == "op" and self.peek().text == "=":
                extra.append(self.assign_target(self.advance()))
                self.advance()
            expr = self.parse_expression()
        key = f"{name}#{self.n_locals}"
        self.n_locals += 1
        self.scopes[-1][name] = key  # visible only after its own initializer, as in C
        self.end_simple_statement()
        return _Assign([key, *extra], expr, declare=True)

    def parse_if(self) -> _If:
        branches: list[tuple[_Node | None, list[Any]]] = []
        self.advance()  # 'if'
        branches.append((self.parse_condition(), self.parse_block()))
        while self.tok.kind == "name" and self.tok.text == "else":
            self.advance()
            if self.tok.kind == "name" and self.tok.text == "if":
                self.advance()
                branches.append((self.parse_condition(), self.parse_block()))
            else:
                branches.append((None, self.parse_block()))
                break
        return _If(branches)

    def parse_condition(self) -> _Node:
        open_tok = self.expect_op("(", "after 'if'")
        cond = self.parse_expression()
        if not self.at_op(")"):
            t = self.tok
            if t.kind == "end":
                raise self.error(open_tok.pos, "unbalanced parentheses: '(' is never closed")
            raise self.error(t.pos, f"expected ')' after the condition, found {self.describe(t)}")
        self.advance()
        return cond

    # -- expressions
    def parse_expression(self) -> _Node:
        return self.parse_level(0)

    def parse_level(self, level: int) -> _Node:
        if level == len(_BINARY_LEVELS):
            return self.parse_power()
        ops = _BINARY_LEVELS[level]
        left = self.parse_level(level + 1)
        while self.at_op(*ops):
            op = self.advance().text
            left = _Binary(op, left, self.parse_level(level + 1))
        return left

    def parse_power(self) -> _Node:
        base = self.parse_unary()
        if self.at_op("^"):
            self.advance()
            return _Binary("^", base, self.parse_power())  # right-associative
        return base

    def parse_unary(self) -> _Node:
        if self.at_op("-", "+", "!"):
            op = self.advance().text
            return _Unary(op, self.parse_unary())
        return self.parse_primary()

    def parse_primary(self) -> _Node:
        t = self.tok
        if t.kind == "num":
            self.advance()
            return _Num(float(t.text))
        if t.kind == "op" and t.text == "(":
            self.advance()
            inner = self.parse_expression()
            if not self.at_op(")"):
                u = self.tok
                if u.kind == "end" or (u.kind == "op" and u.text in ";}"):
                    raise self.error(t.pos, "unbalanced parentheses: '(' is never closed")
                raise self.error(u.pos, f"expected ')', found {self.describe(u)}")
            self.advance()
            return inner
        if t.kind == "name":
            if self.peek().kind == "op" and self.peek().text == "(":
                return self.parse_call()
            return self.parse_name()
        if t.kind == "end":
            raise self.error(t.pos, "unexpected end of text", "expected a number, name or '('")
        if t.text == ")":
            raise self.error(t.pos, "unbalanced parentheses: unmatched ')'")
        if t.text == "=":
            raise self.error(t.pos, "'=' is only allowed in an assignment statement")
        raise self.error(t.pos, f"unexpected {t.text!r}", "expected a number, name or '('")

    def parse_name(self) -> _Node:
        t = self.advance()
        name = t.text
        key = self.lookup_local(name)
        if key is not None:
            return _Ref(key, "local")
        if name in self.varset:
            self.used.add(name)
            return _Ref(name, "var")
        if name == _VALUE:
            self.reads_value = True
            return _Ref(_VALUE, "value")
        if name == "pi":
            return _Num(_PI)
        if name in _FUNCTIONS:
            raise self.error(t.pos, f"function {name!r} needs arguments in parentheses")
        if name in _KEYWORDS or name in _UNSUPPORTED_KEYWORDS:
            raise self.error(t.pos, f"unexpected keyword {name!r}")
        raise self.unknown_name(t)

    def parse_call(self) -> _Node:
        t = self.advance()
        name = t.text
        if name not in _FUNCTIONS:
            if name in _KEYWORDS or name in _UNSUPPORTED_KEYWORDS:
                raise self.error(t.pos, f"unexpected keyword {name!r}")
            close = difflib.get_close_matches(name, list(_FUNCTIONS), n=3)
            hint = f"did you mean {' or '.join(repr(c) for c in close)}? " if close else ""
            hint += f"known functions: {', '.join(sorted(_FUNCTIONS))}"
            raise self.error(t.pos, f"unknown function {name!r}", hint)
        open_tok = self.advance()  # '('
        args: list[_Node] = []
        if not self.at_op(")"):
            while True:
                args.append(self.parse_expression())
                if self.at_op(","):
                    self.advance()
                    continue
                if self.at_op(")"):
                    break
                u = self.tok
                if u.kind == "end" or (u.kind == "op" and u.text in ";}"):
                    raise self.error(open_tok.pos, "unbalanced parentheses: '(' is never closed")
                raise self.error(u.pos, f"expected ',' or ')', found {self.describe(u)}")
        self.advance()  # ')'
        nargs = _FUNCTIONS[name][0]
        if len(args) != nargs:
            s = "" if nargs == 1 else "s"
            raise self.error(
                t.pos, f"function {name!r} takes {nargs} argument{s}, got {len(args)}"
            )
        if name == "rnd":
            self.has_rnd = True
            self.n_rnd += 1
            return _Call(name, args, self.n_rnd - 1)
        return _Call(name, args)


# --------------------------------------------------------------------------------------------
# code generation: tree -> closures, with constant folding


def _const_fn(c: float) -> Fn:
    def f(env: Env) -> float:
        return c

    return f


def _cmp_fn(op: Callable[[Any, Any], Any], a: Fn, b: Fn) -> Fn:
    def f(env: Env) -> Any:
        x = a(env)
        y = b(env)
        if type(x) is float and type(y) is float:
            return 1.0 if op(x, y) else 0.0
        return op(x, y).astype(np.float64)

    return f


def _div_fn(a: Fn, b: Fn) -> Fn:
    def f(env: Env) -> Any:
        x = a(env)
        y = b(env)
        try:
            return x / y
        except ZeroDivisionError:
            return _np_scalar(np.divide, x, y)

    return f


def _logic_fn(is_and: bool, a: Fn, b: Fn) -> Fn:
    # both sides are evaluated (as RTCompiler does); NaN is true, as in C
    def f(env: Env) -> Any:
        x = a(env)
        y = b(env)
        if type(x) is float and type(y) is float:
            if is_and:
                return 1.0 if (x != 0.0 and y != 0.0) else 0.0
            return 1.0 if (x != 0.0 or y != 0.0) else 0.0
        logic = np.logical_and if is_and else np.logical_or
        return logic(x != 0.0, y != 0.0).astype(np.float64)

    return f


def _mod_fn(a: Fn, b: Fn) -> Fn:
    def f(env: Env) -> Any:
        x = a(env)
        y = b(env)
        if type(x) is float and type(y) is float:
            return _mod_scalar(x, y)
        return _mod_array(x, y)

    return f


_CMP_OPS = {
    "==": operator.eq, "!=": operator.ne, "<": operator.lt,
    ">": operator.gt, "<=": operator.le, ">=": operator.ge,
}


def _binary_fn(op: str, a: Fn, b: Fn) -> Fn:
    if op == "+":
        return lambda env: a(env) + b(env)
    if op == "-":
        return lambda env: a(env) - b(env)
    if op == "*":
        return lambda env: a(env) * b(env)
    if op == "/":
        return _div_fn(a, b)
    if op == "%":
        return _mod_fn(a, b)
    if op == "^":
        return _FUNCTIONS["pow"][1]([a, b])
    if op in ("&&", "||"):
        return _logic_fn(op == "&&", a, b)
    return _cmp_fn(_CMP_OPS[op], a, b)


def _unary_fn(op: str, a: Fn) -> Fn:
    if op == "-":
        return lambda env: -a(env)
    if op == "+":
        return a
    # '!'
    def f(env: Env) -> Any:
        v = a(env)
        if type(v) is float:
            return 1.0 if v == 0.0 else 0.0
        return (v == 0.0).astype(np.float64)

    return f


def _gen(node: _Node) -> tuple[Fn, bool]:
    """Closure for an expression node, and whether it is constant (then already folded)."""
    if isinstance(node, _Num):
        return _const_fn(node.value), True
    if isinstance(node, _Ref):
        key = node.key
        return (lambda env: env[key]), False
    if isinstance(node, _Unary):
        a, const = _gen(node.arg)
        fn = _unary_fn(node.op, a)
    elif isinstance(node, _Binary):
        a, ca = _gen(node.left)
        b, cb = _gen(node.right)
        fn, const = _binary_fn(node.op, a, b), ca and cb
    elif isinstance(node, _Call):
        gens = [_gen(arg) for arg in node.args]
        if node.name == "rnd":
            fn = _build_rnd([g for g, _ in gens], node.index)
        else:
            fn = _FUNCTIONS[node.name][1]([g for g, _ in gens])
        const = node.name != "rnd" and all(c for _, c in gens)
    else:  # pragma: no cover
        raise TypeError(node)
    if const:
        return _const_fn(float(fn({}))), True
    return fn, False


def _gen_truth(node: _Node) -> Fn:
    """Closure giving a condition's truth as a bool or a bool array (NaN is true, as in C)."""
    if isinstance(node, _Binary) and node.op in _CMP_OPS:
        a = _gen(node.left)[0]
        b = _gen(node.right)[0]
        op = _CMP_OPS[node.op]
        return lambda env: op(a(env), b(env))
    if isinstance(node, _Binary) and node.op in ("&&", "||"):
        ta = _gen_truth(node.left)
        tb = _gen_truth(node.right)
        logic = np.logical_and if node.op == "&&" else np.logical_or
        return lambda env: logic(ta(env), tb(env))
    if isinstance(node, _Unary) and node.op == "!":
        t = _gen_truth(node.arg)
        return lambda env: np.logical_not(t(env))
    fn = _gen(node)[0]
    return lambda env: fn(env) != 0.0


Stmt = Callable[[Env, Any], None]


def _gen_assign(stmt: _Assign) -> Stmt:
    targets = stmt.targets
    expr = _gen(stmt.expr)[0] if stmt.expr is not None else _const_fn(0.0)
    declare = stmt.declare

    def run(env: Env, mask: Any) -> None:
        v = expr(env)
        own = env.get(_OWN)
        if mask is None:
            if own and type(v) is np.ndarray:  # v now has two names: no longer private
                for k in [k for k, arr in own.items() if arr is v]:
                    del own[k]
            for key in targets:
                env[key] = v
            return
        if own is None:
            own = env[_OWN] = {}
        for i, key in enumerate(targets):
            old = 0.0 if (declare and i == 0) else env[key]
            if own.get(key) is old and old.shape == env[_SHAPE]:
                np.copyto(old, v, where=mask)  # a private full-size array: update in place
            else:
                env[key] = own[key] = np.where(mask, v, old)

    return run


def _gen_block(stmts: list[Any]) -> Stmt:
    parts = [_gen_stmt(s) for s in stmts]
    if len(parts) == 1:
        return parts[0]

    def run(env: Env, mask: Any) -> None:
        for p in parts:
            p(env, mask)

    return run


def _gen_if(stmt: _If) -> Stmt:
    branches = [
        (None if cond is None else _gen_truth(cond), _gen_block(body))
        for cond, body in stmt.branches
    ]

    def run(env: Env, mask: Any) -> None:
        remaining = mask  # points not yet claimed by a branch; None means all
        for cond, body in branches:
            if cond is None:
                body(env, remaining)
                return
            truth = cond(env)
            if not isinstance(truth, np.ndarray):  # a scalar condition
                if truth:
                    body(env, remaining)
                    return
                continue
            take = truth if remaining is None else (remaining & truth)
            if take.any():
                body(env, take)
            remaining = ~truth if remaining is None else (remaining & ~truth)
            if not remaining.any():
                return

    return run


def _gen_stmt(stmt: Any) -> Stmt:
    if isinstance(stmt, _Assign):
        return _gen_assign(stmt)
    return _gen_if(stmt)


# --------------------------------------------------------------------------------------------
# public API


class Expression:
    """A compiled Peridigm function string; call it with the variables as keywords.

    Attributes: ``text`` (original text), ``variables`` (allowed input variables), ``used``
    (input variables the expression reads), ``is_constant`` (reads no variable, no ``rnd``),
    ``has_rnd``, ``seed`` and ``stream`` (what its random numbers depend on, with the point ids).
    """

    __slots__ = ("text", "variables", "used", "is_constant", "has_rnd", "seed", "stream", "_key",
                 "_varset", "_root", "_program", "_const")

    text: str
    variables: tuple[str, ...]
    used: frozenset[str]
    is_constant: bool

    def __init__(self, text: str, variables: tuple[str, ...], used: frozenset[str],
                 is_constant: bool, root: Fn | None, program: Stmt | None,
                 has_rnd: bool = False, seed: int = 0, stream: str | None = None) -> None:
        self.text = text
        self.variables = variables
        self.used = used
        self.is_constant = is_constant
        self.has_rnd = has_rnd
        self.seed = int(seed)
        self.stream = text if stream is None else stream
        self._key = random_key(self.seed, self.stream)
        self._varset = frozenset(variables)
        self._root = root  # a plain expression ("value = <expr>")
        self._program = program  # a statement list
        self._const: float | None = None
        if is_constant:
            self._const = float(self._run({}))

    def _run(self, env: Env) -> Any:
        if self._root is not None:
            return self._root(env)
        env[_VALUE] = 0.0
        self._program(env, None)  # type: ignore[misc]
        return env[_VALUE]

    def __call__(self, point_ids: Any = None, /, **values: Any) -> np.ndarray | float:
        """Evaluate with each variable given as a float or a numpy array.

        Arrays broadcast together (with every given value, used or not, and ``point_ids``).
        Variables the expression does not read may be omitted; a missing one it reads raises
        TypeError. ``point_ids``: the points' global ids (non-negative integers), which
        ``rnd()`` hashes; without them it hashes the input values. Returns a new float64 array
        of the broadcast shape, or a Python float when every input is a scalar (or there is
        none).
        """
        env: Env = {}
        arrays: list[np.ndarray] = []
        if point_ids is not None:
            ids = np.asarray(point_ids)
            if ids.dtype.kind not in "iu":
                raise TypeError(f"point ids must be integers, got {ids.dtype}")
            if ids.ndim:
                arrays.append(ids)
        varset = self._varset
        for name, v in values.items():
            if name not in varset:
                raise TypeError(
                    f"unexpected variable {name!r} for expression {self.text!r}; "
                    f"allowed: {', '.join(self.variables) or '(none)'}"
                )
            if type(v) is float:
                env[name] = v
                continue
            a = np.asarray(v, dtype=np.float64)
            if a.ndim == 0:
                env[name] = float(a)
            else:
                env[name] = a
                arrays.append(a)
        if not self.used.issubset(env):
            missing = sorted(self.used - env.keys())
            raise TypeError(f"expression {self.text!r} needs variable(s) {', '.join(missing)}")
        if not arrays:
            if self._const is not None:
                return self._const
            if self.has_rnd:
                self._random_inputs(env, values, point_ids, ())
            return float(self._run(env))
        shape = arrays[0].shape if len(arrays) == 1 else np.broadcast_shapes(
            *(a.shape for a in arrays)
        )
        if self._const is not None:
            return np.full(shape, self._const)
        env[_SHAPE] = shape
        if self.has_rnd:
            self._random_inputs(env, values, point_ids, shape)
        with np.errstate(all="ignore"):
            r = self._run(env)
        if type(r) is float:
            return np.full(shape, r)
        if r.shape != shape:
            return np.array(np.broadcast_to(r, shape), dtype=np.float64)
        if r.dtype != np.float64:
            return r.astype(np.float64)
        for a in arrays:
            if r is a:  # never hand back the caller's array
                return r.copy()
        return r

    def _random_inputs(self, env: Env, values: dict[str, Any], point_ids: Any, shape: tuple[int, ...]) -> None:
        """What rnd() hashes: the key, and per point the global id (or the inputs' bits)."""
        env[_KEY] = self._key
        if point_ids is not None:
            ids = np.asarray(point_ids).astype(np.uint64)
        else:  # no ids: the bits of every input value, in name order
            ids = np.zeros((), np.uint64)
            for name in sorted(values):
                ids = _mix_array(np.atleast_1d(ids ^ _float_bits(values[name]))).reshape(np.broadcast_shapes(ids.shape, np.shape(values[name])))
        env[_IDS] = np.broadcast_to(ids, shape) if shape else ids.reshape(())

    def constant_value(self) -> float:
        """The value of a constant expression; ExpressionError if it is not constant."""
        if self._const is None:
            reads = ", ".join(sorted(self.used)) or "rnd()"
            raise ExpressionError(self.text, -1, f"expression is not constant (it reads {reads})")
        return self._const

    def __repr__(self) -> str:
        return f"Expression({self.text!r}, variables={self.variables!r})"


_IDENT_RE = re.compile(r"[A-Za-z_][A-Za-z_0-9]*\Z")


def constant_not_finite(expr: Expression) -> str | None:
    """For a constant expression whose value is NaN or inf, what is wrong with it; else None."""
    if expr.is_constant:
        value = float(expr())
        if not math.isfinite(value):
            return f"the expression {expr.text!r} evaluates to {value!r}"
    return None


def compile_expression(text: str, variables: Sequence[str], *, seed: int | None = None,
                       stream: str | None = None) -> Expression:
    """Compile a Peridigm function string once; the result evaluates it on floats or arrays.

    ``variables`` are the names the text may read (e.g. ``("x", "y", "z", "t")``); ``value``
    is the result and is ignored if listed. Raises :class:`ExpressionError` for bad text.
    ``seed`` (default: the one :func:`random_seed` sets, else 0) and ``stream`` (where the
    expression stands, e.g. ``"Boundary Conditions > Initial Velocity X"``; default its text)
    choose the numbers of ``rnd()``.
    """
    if not isinstance(text, str):
        raise TypeError(f"expression text must be a str, got {type(text).__name__}")
    if isinstance(variables, str):
        raise TypeError("variables must be a sequence of names, not a str")
    names: list[str] = []
    for v in variables:
        if not isinstance(v, str) or not _IDENT_RE.match(v):
            raise ValueError(f"invalid variable name {v!r}")
        if v in _KEYWORDS or v in _UNSUPPORTED_KEYWORDS:
            raise ValueError(f"variable name {v!r} is a keyword")
        if v != _VALUE and v not in names:
            names.append(v)
    var_tuple = tuple(names)

    if _VALUE in text:
        source, offset = text, 0
    else:
        source, offset = "value = " + text, len("value = ")
    try:
        parser = _Parser(text, source, offset, var_tuple)
        stmts = parser.parse_program()
        if not parser.assigns_value:
            raise ExpressionError(text, -1, "the expression never assigns 'value'",
                                  "write e.g. 'value = 2*x;'")
        is_constant = not parser.used and not parser.has_rnd
        root: Fn | None = None
        program: Stmt | None = None
        first = stmts[0] if len(stmts) == 1 else None
        if (isinstance(first, _Assign) and first.targets == [_VALUE]
                and first.expr is not None and not parser.reads_value):
            root = _gen(first.expr)[0]
        else:
            program = _gen_block(stmts)
        return Expression(text, var_tuple, frozenset(parser.used), is_constant, root, program,
                          has_rnd=parser.has_rnd, seed=_SEED.get() if seed is None else seed, stream=stream)
    except RecursionError:
        raise ExpressionError(text, -1, "expression is nested too deeply") from None
