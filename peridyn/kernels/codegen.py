"""Loop laws to source: the kernel of a law is a small generated module that imports the law's
functions by name, so numba's on-disk cache works for it like for any module-level kernel.

Closures over jitted functions cannot be cached by numba (a dispatcher pickles with a per-process
id, so every process misses), and functions passed as arguments are typed by identity, with the
same result. A generated file keyed by the hash of its own text and of the source of every
function the law reaches is cached, and a change to the physics gives a new file.
"""
from __future__ import annotations

import hashlib
import importlib.util
import inspect
import os
import sys
import tempfile
import types
from pathlib import Path
from typing import Callable

from ..core.traversal import BondMap, Law, PairForce, PointMap, PointSum

ROLES = ("term", "bond", "pair", "point", "finish", "gate", "both", "update")


def plain_function(fn: Callable) -> Callable:
    """The Python function behind ``fn`` (a plain function or a numba dispatcher)."""
    return getattr(fn, "py_func", fn)


def function_path(fn: Callable) -> tuple[str, str]:
    """(module, name) of a module-level function; a law's functions must be importable."""
    py = plain_function(fn)
    module, name = py.__module__, py.__qualname__
    if "." in name or "<" in name or getattr(sys.modules.get(module), name, None) not in (fn, py):
        raise TypeError(f"loop law functions must be module-level functions; {module}.{name} is not")
    return module, name


def _dependencies(fn: Callable, seen: set[int]) -> list[str]:
    """Source of ``fn`` and of every Python function or dispatcher it reaches through its globals."""
    py = plain_function(fn)
    if id(py) in seen or not isinstance(py, types.FunctionType):
        return []
    seen.add(id(py))
    try:
        parts = [inspect.getsource(py)]
    except (OSError, TypeError):
        parts = [repr(py.__code__.co_code)]
    g = py.__globals__
    for name in py.__code__.co_names:
        target = g.get(name)
        if target is not None and isinstance(plain_function(target), types.FunctionType):
            parts += _dependencies(target, seen)
    return parts


def law_functions(law: Law) -> dict[str, Callable]:
    """The functions a law names, by role."""
    declared = vars(law)  # the law's dataclass fields
    return {role: declared[role] for role in ROLES if declared.get(role) is not None}


def law_digest(law: Law, template: str) -> str:
    seen: set[int] = set()
    h = hashlib.sha256(template.encode())
    for role, fn in sorted(law_functions(law).items()):
        h.update(role.encode())
        h.update(repr(function_path(fn)).encode())
        for part in _dependencies(fn, seen):
            h.update(part.encode())
    return h.hexdigest()[:20]


def cache_dir() -> Path:
    """Where generated kernel modules (and numba's cache of them) live: ``PERIDYN_KERNEL_CACHE``,
    else the user's cache folder, else a folder in the temporary directory."""
    candidates = []
    if os.environ.get("PERIDYN_KERNEL_CACHE"):
        candidates.append(Path(os.environ["PERIDYN_KERNEL_CACHE"]))
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    candidates.append(Path(base) / "peridyn" / "kernels")
    candidates.append(Path(tempfile.gettempdir()) / f"peridyn-kernels-{os.getuid() if hasattr(os, 'getuid') else 'user'}")
    for d in candidates:
        try:
            d.mkdir(parents=True, exist_ok=True)
            if os.access(d, os.W_OK):
                return d
        except OSError:
            continue
    raise OSError("no writable folder for compiled kernels; set PERIDYN_KERNEL_CACHE to one")


def load_module(source: str, key: str) -> types.ModuleType:
    """Write ``source`` to ``<cache>/<key>.py`` once (atomically) and import it as ``key``."""
    module = sys.modules.get(key)
    if module is not None:
        return module
    path = cache_dir() / f"{key}.py"
    if not path.exists() or path.read_text() != source:
        tmp = path.with_name(f"{key}.{os.getpid()}.tmp")
        tmp.write_text(source)
        os.replace(tmp, path)
    spec = importlib.util.spec_from_file_location(key, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[key] = module  # numba's cache finds the module of a cached kernel by name
    spec.loader.exec_module(module)
    return module


def compile_function(fn: Callable, compiler: Callable[[Callable], Callable], retarget: bool = False) -> Callable:
    """``compiler`` applied to ``fn`` after the plain Python functions it calls (helpers of the
    physics, at any depth) are rebound to ``compiler``'s versions of them, so a law's functions
    and their helpers are ordinary Python that each backend compiles for its own target.
    Already-compiled helpers (``@njit`` functions) are kept, or with ``retarget`` (a backend
    for another target, e.g. a GPU) compiled again from their Python source."""
    return compiler(_rebound(plain_function(fn), compiler, {}, retarget))


def _rebound(py: types.FunctionType, compiler: Callable, memo: dict[int, Callable], retarget: bool = False) -> types.FunctionType:
    g = py.__globals__
    new = {}
    for name in py.__code__.co_names:
        target = g.get(name)
        if retarget and not isinstance(target, types.FunctionType) and isinstance(getattr(target, "py_func", None), types.FunctionType):
            target = target.py_func
        if isinstance(target, types.FunctionType):
            if id(target) not in memo:
                memo[id(target)] = compiler(_rebound(target, compiler, memo, retarget))
            new[name] = memo[id(target)]
    if not new:
        return py
    f = types.FunctionType(py.__code__, {**g, **new}, py.__name__, py.__defaults__, py.__closure__)
    f.__module__, f.__qualname__, f.__doc__ = py.__module__, py.__qualname__, py.__doc__
    return f


def imports(law: Law, compiler: str, retarget: bool = False) -> str:
    """Import lines binding each of the law's functions, compiled by the expression ``compiler``
    (e.g. ``njit(error_model="numpy")``), to its role name (``retarget``: see
    ``compile_function``)."""
    lines = ["from peridyn.kernels.codegen import compile_function"]
    extra = ", retarget=True" if retarget else ""
    for role, fn in law_functions(law).items():
        module, name = function_path(fn)
        lines.append(f"from {module} import {name} as _{role}_source")
        lines.append(f"{role} = compile_function(_{role}_source, {compiler}{extra})")
    return "\n".join(lines)


def loop_body(law: Law, indent: str, unsigned: bool = False) -> str:
    """The statements of the loop over point i's bonds, as text (shared by every CPU-like backend).

    The prelude reads positions through ``y`` and writes ``ex, ey, ez, L, z``; the law's function
    is then applied and accumulated by kind. With ``unsigned`` (the CPU backends) the bond index
    ``b`` is a uint64 and ``j`` is masked to its non-negative int32 range, so numba emits no
    negative-index wraparound for any array the law indexes with them (one cube40 force pass:
    33 -> 27 ms, one thread); the values are the same."""
    gate = isinstance(law, (PointSum, PairForce)) and law.gate is not None
    if unsigned:
        lines = ["for b in range(uint64(offsets[i]), uint64(offsets[i + 1])):"]
    else:
        lines = ["for b in range(offsets[i], offsets[i + 1]):"]
    if gate:
        lines.append("    if not gate(i, b, p, args):")
        lines.append("        continue")
    lines.append("    j = neighbors[b] & 0x7FFFFFFF" if unsigned else "    j = neighbors[b]")
    lines += ["    " + s for s in _reference_length(law)]
    lines += ["    " + s for s in _geometry()]
    lines += ["    " + s for s in _accumulate(law, "i", "j", "b", "ex", "ey", "ez", "z", "p", _own(law))]
    return "\n".join(indent + line for line in lines)


def _reference_length(law: Law) -> list[str]:
    """``z`` = |xi| of bond ``b`` (from i to j) as the law reads it."""
    if law.z_from_positions:  # |x_j - x_i| with the engine's Bond_Length arithmetic
        return [
            "dx = zeta[j, 0] - xi0",
            "dy = zeta[j, 1] - xi1",
            "dz = zeta[j, 2] - xi2",
            "z = math.sqrt(dx * dx + dy * dy + dz * dz)",
        ]
    if law.z_from_codes:
        return ["z = ztable[zcodes[b]]"]
    return ["z = zeta[b]"]


def _geometry() -> list[str]:
    return [
        "ex = y[j, 0] - yi0",
        "ey = y[j, 1] - yi1",
        "ez = y[j, 2] - yi2",
        "L = math.sqrt(ex * ex + ey * ey + ez * ez)",
    ]


def _own(law: Law) -> list[str]:
    """Where point i's own sum lives in the row: local accumulators."""
    if isinstance(law, PairForce):
        return ["fx", "fy", "fz"]
    if isinstance(law, PointSum) and law.width > 1:
        return [f"acc{k}" for k in range(law.width)]
    return ["acc"]


def _accumulate(law: Law, i: str, j: str, b: str, ex: str, ey: str, ez: str, z: str, p: str, into: list[str],
                value: str | None = None) -> list[str]:
    """The law applied to bond ``b`` seen from ``i`` (neighbor ``j``, eta = (ex, ey, ez)) and added
    to the accumulators ``into`` (names or array elements); ``value``: the law's value already
    computed (a name), for a width-1 sum or a pair force."""
    ctx = f"{i}, {j}, {b}, {ex}, {ey}, {ez}, L, {z}, {p}, args"
    if isinstance(law, PointSum) and law.width == 1:
        return [f"{into[0]} += {value or f'term({ctx})'}"]
    if isinstance(law, PointSum):
        return [f"t = term({ctx})"] + [f"{into[k]} += t[{k}]" for k in range(law.width)]
    if isinstance(law, BondMap) and law.width == 1:
        return [f"out[{b}] = bond({ctx})"]
    if isinstance(law, BondMap):
        return [f"t = bond({ctx})"] + [f"out[{b}, {k}] = t[{k}]" for k in range(law.width)]
    if isinstance(law, PairForce):
        return [
            f"s = {value or f'pair({ctx})'}",
            "if L > 0.0:",
            "    s = s / L",
            f"    {into[0]} += s * {ex}",
            f"    {into[1]} += s * {ey}",
            f"    {into[2]} += s * {ez}",
        ]
    raise TypeError(f"not a loop law: {law!r}")


def point_loop(law: Law, loop: str, unsigned: bool = False, mirror: bool = False) -> str:
    """The body of one point's row under the statement ``loop`` (a point loop header such as
    ``for i in prange(start, stop):``, or ``if True:`` for a row function of ``i``).

    ``unsigned``: see :func:`loop_body`. ``mirror``: the row of a mirrored traversal
    (:func:`mirror_body`), for a row function of ``(i, ..., out, upper, cursor)``."""
    if isinstance(law, PointMap):
        if law.width == 1:
            body = ["out[i] = point(i, args)"]
        else:
            body = ["r = point(i, args)"] + [f"out[i, {k}] = r[{k}]" for k in range(law.width)]
        return f"    {loop}\n" + "\n".join("        " + s for s in body) + "\n"
    pre = ["i = i & 0x7FFFFFFFFFFFFFFF"] if unsigned or mirror else []
    pre.append("p = point(i, args)" if law.point is not None else "p = 0.0")
    own = _own(law)
    slots = sum_slots(law, "i")
    # a mirrored row's sums start from what its lower neighbors' rows already added
    pre += [f"{a} = {slot if mirror else '0.0'}" for a, slot in zip(own, slots)] if not isinstance(law, BondMap) else []
    if isinstance(law, PointSum) and law.width == 1:
        post = ["out[i] = finish(i, acc, p, args)" if law.finish is not None else "out[i] = acc"]
    elif isinstance(law, PointSum):
        acc = "(" + ", ".join(own) + ")"
        post = [f"r = finish(i, {acc}, p, args)"] if law.finish is not None else [f"r = {acc}"]
        post += [f"out[i, {k}] = r[{k}]" for k in range(law.width)]
    elif isinstance(law, PairForce):
        post = [f"{slot} = {a}" for a, slot in zip(own, slots)]
    else:
        post = []
    pre += ["yi0 = y[i, 0]", "yi1 = y[i, 1]", "yi2 = y[i, 2]"]
    if law.z_from_positions:
        pre += ["xi0 = zeta[i, 0]", "xi1 = zeta[i, 1]", "xi2 = zeta[i, 2]"]
    elif law.z_from_codes:
        pre += ["zcodes = zeta[0]", "ztable = zeta[1]"]
    loop_text = mirror_body(law, "        ") if mirror else loop_body(law, "        ", unsigned)
    body = "\n".join("        " + s for s in pre) + "\n" + loop_text + "\n"
    body += "\n".join("        " + s for s in post)
    return f"    {loop}\n{body}\n"


def sum_slots(law: Law, i: str) -> list[str]:
    """The elements of ``out`` that hold point ``i``'s sums."""
    if isinstance(law, PairForce):
        return [f"out[{i}, {k}]" for k in range(3)]
    if isinstance(law, PointSum) and law.width > 1:
        return [f"out[{i}, {k}]" for k in range(law.width)]
    return [f"out[{i}]"]


def mirrorable(law: Law) -> bool:
    """Whether ``law`` has a mirrored kernel (:func:`mirror_body`): sums over bonds."""
    return isinstance(law, (PointSum, PairForce)) and law.mirror


def mirror_body(law: Law, indent: str) -> str:
    """The loop of a mirrored traversal over point i's *upper* bonds (neighbors after i in the
    rows' order, from ``upper[i]``; ``peridyn.kernels.mirror``): each bond's geometry is
    computed once and the law applied from both ends, i's term added to i's sum and j's term
    (bond ``rb`` = j's bond back to i, found by j's ``cursor``) to ``out[j]``. Rows run in their
    order, so every point receives its terms in the order of its own row, the order the gather
    kernel sums them in: the same bits, with half the square roots and neighbor reads."""
    gate = isinstance(law, (PointSum, PairForce)) and law.gate is not None
    lines = [
        "for b in range(uint64(upper[i]), uint64(offsets[i + 1])):",
        "    j = neighbors[b] & 0x7FFFFFFF",
        "    rb = uint64(offsets[j] + cursor[j])",
        "    cursor[j] += 1",
    ]
    lines.append("    pj = point(j, args)" if law.point is not None else "    pj = 0.0")
    if gate:
        lines += [
            "    gi = gate(i, b, p, args)",
            "    gj = gate(j, rb, pj, args)",
            "    if not gi and not gj:",
            "        continue",
        ]
    lines += ["    " + s for s in _reference_length(law)]
    if law.z_from_positions or law.z_from_codes:  # |x_i - x_j| = |x_j - x_i|: the same bits
        lines.append("    zj = z")
    else:
        lines.append("    zj = zeta[rb]")
    lines += ["    " + s for s in _geometry()]
    lines += ["    nx = -ex", "    ny = -ey", "    nz = -ez"]  # y_i - y_j, exactly
    mine = _accumulate(law, "i", "j", "b", "ex", "ey", "ez", "z", "p", _own(law))
    theirs = _accumulate(law, "j", "i", "rb", "nx", "ny", "nz", "zj", "pj", sum_slots(law, "j"))
    apart = ["if gi:"] + ["    " + s for s in mine] + ["if gj:"] + ["    " + s for s in theirs] if gate else mine + theirs
    if law.both is not None:
        if isinstance(law, PointSum) and law.width != 1:
            raise TypeError(f"a law's 'both' function is for sums of width 1 and pair forces: {law!r}")
        together = ["ti, tj = both(i, j, b, rb, ex, ey, ez, L, z, p, pj, args)"]
        together += _accumulate(law, "i", "j", "b", "ex", "ey", "ez", "z", "p", _own(law), value="ti")
        together += _accumulate(law, "j", "i", "rb", "nx", "ny", "nz", "zj", "pj", sum_slots(law, "j"), value="tj")
        conditions = (["gi", "gj"] if gate else []) + ([] if law.z_from_positions or law.z_from_codes else ["zj == z"])
        if conditions:
            lines += ["    if " + " and ".join(conditions) + ":"] + ["        " + s for s in together]
            lines += ["    else:"] + ["        " + s for s in apart]
        else:
            lines += ["    " + s for s in together]
    else:
        lines += ["    " + s for s in apart]
    return "\n".join(indent + line for line in lines)
