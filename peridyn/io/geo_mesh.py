"""Meshing a gmsh ``.geo`` for the ``Mesh`` discretization, with gmsh kept on a leash.

gmsh runs in a child process (:mod:`peridyn.io.gmsh_worker`), so that nothing it does can end or
hang peridyn: a crash (gmsh segfaults on some option combinations) or a script's ``Exit;`` is an
input error naming the ``.geo``; Ctrl-C (SIGINT) and SIGTERM kill the child at once and stop
peridyn as usual (exit 130, 143), its output locks released; a mesh too large for the memory is
refused before it is made, from the element count estimated after gmsh has parsed the
geometry and applied the script's options, whatever sets the size (the deck's ``Mesh Size``,
the script's size options, the points' characteristic lengths, size fields), and the child is
killed if its memory grows past what is available all the same (transfinite or extruded
layers, ``Mesh 3;`` inside the script). ``PERIDYN_NO_LIMITS=1`` (``peridyn run --no-limits``)
turns both refusals into warnings. A ``.geo`` that merges or includes itself (directly or
through other files) is refused before gmsh reads it.
"""
from __future__ import annotations

import importlib.util
import json
import logging
import os
import re
import signal
import subprocess
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from ..core.resources import NO_LIMITS_ENV, available_memory, human_bytes, limits_off
from ..core.errors import InputError, PeridynError
from .gmsh_worker import ESTIMATE, RESULT

__all__ = ["mesh_geo", "check_includes", "MeshingInterrupted", "MAX_GEO_ELEMENTS", "GMSH_BYTES_PER_ELEMENT"]

_log = logging.getLogger(__name__)

INSTALL = 'pip install "peridyn[mesh]"'
_PATH = ("Discretization", "Input Mesh File")
#: the most tetrahedra a .geo may be meshed into (gmsh needs minutes and gigabytes for 1e7)
MAX_GEO_ELEMENTS = 1e7
#: gmsh's peak memory per tetrahedron while meshing, with headroom (measured with gmsh 4.15 on a
#: box: 600-770 bytes for 4e4-2e5 tetrahedra)
GMSH_BYTES_PER_ELEMENT = 1024.0
#: the share of the memory available at the start that gmsh may use
MEMORY_SHARE = 0.9
#: seconds between two looks at the child (its end, its memory)
POLL_SECONDS = 0.05
#: seconds between two "still meshing" notes
NOTE_SECONDS = 30.0
#: the same switch as peridyn.engine.limits.ENV (io may not import engine)
#: Merge and Include nested deeper than this are refused (gmsh runs out of file handles)
MAX_NESTING = 64
#: extensions gmsh merges as meshes, CAD or post-processing data, not as scripts
_DATA = {".msh", ".step", ".stp", ".iges", ".igs", ".brep", ".stl", ".vtk", ".pos", ".med", ".unv", ".mesh", ".bdf",
         ".nas", ".inp", ".p3d", ".ply", ".off", ".obj", ".xao", ".x_t", ".xmt_txt", ".sat", ".opt"}
_STATEMENT = re.compile(r'\b(Merge|MergeWithBoundingBox|Include)\s*"([^"]*)"')
_COMMENT = re.compile(r'"[^"\n]*"|//[^\n]*|/\*.*?\*/', re.DOTALL)


class MeshingInterrupted(PeridynError):
    """Meshing was stopped by SIGTERM (exit 128 + the signal, the shells' convention)."""

    def __init__(self, message: str, signum: int) -> None:
        super().__init__(message)
        self.exit_code = 128 + int(signum)  # type: ignore[assignment]


def _fail(message: str, path: Path, fix: str | None = None, line: int | None = None) -> InputError:
    return InputError(message, file=str(path), path=_PATH, fix=fix, line=line)


def _rss(pid: int) -> float:
    """Resident memory of process ``pid`` in bytes (0 where /proc cannot tell)."""
    try:
        with open(f"/proc/{pid}/statm", encoding="ascii") as handle:
            return float(handle.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0.0


# ------------------------------------------------------------------------------------------------
# Merge and Include loops, before gmsh
# ------------------------------------------------------------------------------------------------
def _statements(path: Path) -> list[tuple[int, str, str]]:
    """(line, keyword, file name) of every literal Merge/Include of a gmsh script, comments skipped."""
    try:
        text = path.read_bytes()[: 1 << 24].decode("utf-8", errors="replace")
    except OSError:
        return []  # gmsh says why it cannot read it
    blanked = _COMMENT.sub(lambda m: m.group(0) if m.group(0).startswith('"') else re.sub(r"[^\n]", " ", m.group(0)), text)
    return [(blanked.count("\n", 0, m.start()) + 1, m.group(1), m.group(2)) for m in _STATEMENT.finditer(blanked)]


def check_includes(path: Path) -> None:
    """InputError when ``path`` merges or includes itself, directly or through other scripts,
    or nests them deeper than MAX_NESTING. gmsh resolves a relative name against the folder of
    the file that names it; names built by expressions (StrCat) are gmsh's to follow."""
    top = path.resolve()

    def visit(current: Path, chain: list[Path]) -> None:
        named = path if current == top else current  # the file as the user gave it, where we can
        for line, keyword, name in _statements(current):
            target = (current.parent / name).resolve()
            if keyword != "Include" and target.suffix.lower() in _DATA:
                continue
            verb = "merges" if keyword.startswith("Merge") else "includes"
            if target in chain:
                through = "" if target == current else " through " + ", ".join(repr(p.name) for p in chain[chain.index(target) + 1:])
                raise _fail(f"{top.name!r} {verb} itself{through} ({keyword} \"{name}\"): gmsh would read it until it runs out "
                            "of file handles", named, f"remove the {keyword} that leads back to {target.name!r}", line)
            if len(chain) >= MAX_NESTING:
                raise _fail(f"{top.name!r} nests Merge and Include more than {MAX_NESTING} deep ({keyword} \"{name}\")", named,
                            "merge the files into fewer levels", line)
            if target.is_file():
                visit(target, chain + [target])

    visit(top, [top])


# ------------------------------------------------------------------------------------------------
# The child
# ------------------------------------------------------------------------------------------------
def _worker_command(request: Path) -> list[str]:
    """The command line of the child that meshes ``request`` (tests replace it)."""
    return [sys.executable, "-m", "peridyn.io.gmsh_worker", str(request)]


@contextmanager
def _sigterm_stops_meshing(path: Path) -> Iterator[None]:
    """While meshing, SIGTERM raises MeshingInterrupted (so the child is killed and the locks are
    released) where it would otherwise end the process on the spot; a handler someone else
    installed is left alone, as is any thread but the main one."""
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        yield
        return

    def stop(signum, frame) -> None:
        raise MeshingInterrupted(f"meshing {path.name!r} was stopped by {signal.Signals(signum).name}", signum)

    signal.signal(signal.SIGTERM, stop)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _kill(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.kill()
    proc.wait()


def _too_large(estimate: dict, limit: float, memory: float, path: Path) -> str:
    words = f"a mesh size of {estimate['size']:g} ({estimate['source']}) would give up to about {estimate['elements']:.3g} tetrahedra in {path.name!r}"
    if limit < MAX_GEO_ELEMENTS:
        return f"{words}, about {human_bytes(estimate['elements'] * GMSH_BYTES_PER_ELEMENT)} for gmsh, more than the {human_bytes(memory)} of memory available"
    return f"{words} (the limit is {MAX_GEO_ELEMENTS:.0e})"


def _size_fix(source: str) -> str:
    where = "increase 'Mesh Size'" if source.startswith("'Mesh Size'") else f"increase {source} in the .geo (or set a larger 'Mesh Size')"
    if source.startswith(("the characteristic length", "Field", "Mesh.MeshSizeMin")):
        where = f"increase {source} in the .geo ('Mesh Size' only caps the size)"
    return f"{where}, or set {NO_LIMITS_ENV}=1 (peridyn run --no-limits) if you mean it"


def mesh_geo(path: Path, mesh_size: float | None, folder: Path) -> Path:
    """Mesh the gmsh script ``path`` in 3-D in a child process; returns the ``.msh`` written to
    ``folder`` (module docstring). ``mesh_size``: the deck's Mesh Size, Mesh.MeshSizeMax in the
    .geo's length unit, or None. InputError for every way the .geo can fail."""
    if importlib.util.find_spec("gmsh") is None:
        raise _fail(f"mesh {path.name!r} needs gmsh, which cannot be imported (it is not installed)", path, INSTALL)
    if path.stat().st_size == 0:
        raise _fail(f"the gmsh script {path.name!r} is empty (0 bytes)", path, "write the geometry into it, or give the right file")
    check_includes(path)
    out = folder / (path.stem + ".msh")
    refuse = not limits_off()
    memory = available_memory()
    limit = min(MAX_GEO_ELEMENTS, MEMORY_SHARE * memory / GMSH_BYTES_PER_ELEMENT)
    request = folder / "request.json"
    request.write_text(json.dumps({"geo": str(path), "out": str(out), "mesh_size": mesh_size,
                                   "max_elements": limit if refuse else None}))
    with open(folder / "gmsh.log", "wb") as chatter, _sigterm_stops_meshing(path):
        start = time.monotonic()
        proc = subprocess.Popen(_worker_command(request), stdin=subprocess.DEVNULL, stdout=chatter, stderr=chatter,
                                cwd=str(path.parent))
        try:
            killed_for_memory = _watch(proc, path, folder, memory, limit, refuse, start)
        finally:
            _kill(proc)
    said = (folder / "gmsh.log").read_bytes().decode("utf-8", errors="replace").strip()
    if said:
        _log.debug("gmsh on %s said: %s", path.name, said[-4000:])
    _log.debug("gmsh meshed %s in %.2f s", path.name, time.monotonic() - start)
    if killed_for_memory:
        raise _fail(
            f"gmsh used more than {human_bytes(MEMORY_SHARE * memory)} meshing {path.name!r} (of the {human_bytes(memory)} "
            "available) and was stopped", path,
            "use a larger element size (transfinite or extruded layer counts and a 'Mesh 3;' in the script count too), "
            f"or set {NO_LIMITS_ENV}=1 (peridyn run --no-limits) if you mean it")
    return _outcome(proc.returncode, folder, path, said, limit, memory, out)


def _note_estimate(folder: Path, path: Path, limit: float, memory: float) -> None:
    """Log the child's element estimate, with a warning when it is past the limit (only with the
    limits off: the child refuses otherwise)."""
    if not (folder / ESTIMATE).exists():
        return
    estimate = json.loads((folder / ESTIMATE).read_text())
    if "elements" in estimate:
        _log.debug("%s: size %g (%s), up to about %.3g tetrahedra", path.name, estimate["size"], estimate["source"], estimate["elements"])
        if estimate["elements"] > limit:
            _log.warning("%s (%s is set: meshing anyway)", _too_large(estimate, limit, memory, path), NO_LIMITS_ENV)


def _watch(proc: subprocess.Popen, path: Path, folder: Path, memory: float, limit: float, refuse: bool, start: float) -> bool:
    """Wait for the child; True when it was killed for using too much memory."""
    estimated, noted = False, start
    while True:
        try:
            proc.wait(timeout=POLL_SECONDS)
        except subprocess.TimeoutExpired:
            pass
        else:
            if not estimated:  # a small mesh can finish before the first poll sees its estimate
                _note_estimate(folder, path, limit, memory)
            return False
        if not estimated and (folder / ESTIMATE).exists():
            estimated = True
            _note_estimate(folder, path, limit, memory)
        if refuse and _rss(proc.pid) > MEMORY_SHARE * memory:
            proc.kill()
            proc.wait()
            return True
        now = time.monotonic()
        if now - noted > NOTE_SECONDS:
            noted = now
            _log.info("gmsh is still meshing %s (%.0f s so far; Ctrl-C stops it)", path.name, now - start)


def _outcome(returncode: int, folder: Path, path: Path, said: str, limit: float, memory: float, out: Path) -> Path:
    """The .msh the child wrote, or the InputError that says why there is none."""
    result_file = folder / RESULT
    if not result_file.exists():
        last = said.splitlines()[-1][:100] if said else ""
        if returncode < 0:
            signum = -returncode
            if signum == signal.SIGINT:
                raise KeyboardInterrupt
            name = signal.Signals(signum).name if signum in signal.Signals._value2member_map_ else f"signal {signum}"
            cause = "killed" if signum == signal.SIGKILL else "crashed"
            hint = " (by the system: out of memory?)" if signum == signal.SIGKILL else ""
            raise _fail(f"gmsh {cause}{hint} (signal {signum}, {name}) meshing {path.name!r}" + (f"; it said: {last}" if last else ""),
                        path, "mesh the .geo in gmsh to find the cause; another Mesh.Algorithm, Mesh.Algorithm3D or no Recombine "
                        "often avoids it")
        raise _fail(f"gmsh ended (exit status {returncode}) before meshing {path.name!r}, as an Exit or Abort in the script "
                    "makes it", path, "remove Exit; (and Abort;) from the .geo: peridyn meshes it after reading")
    result = json.loads(result_file.read_text())
    status = result["status"]
    if status == "ok":
        return out
    if status == "gmsh error":
        reason = result["reason"]
        fix = "check the .geo file with gmsh"
        if "open" in reason.lower() and "file" in reason.lower():
            fix += " (a Merge or Include that leads back to a file being read?)"
        raise _fail(f"gmsh could not mesh {path.name!r} ({reason[:120]})", path, fix)
    if status == "no volumes":
        raise _fail(f"{path.name!r} has no volume elements (tetra, hexahedron, wedge, pyramid): the script defines no "
                    "volume", path, "define a Volume in the .geo (peridyn meshes it in 3-D), not only surfaces or curves")
    if status == "too large":
        raise _fail(_too_large(result, limit, memory, path), path, _size_fix(result["source"]))
    if status == "bad elements":
        raise _fail(f"gmsh meshed {path.name!r} into {', '.join(sorted(set(result['kinds'])))} elements, which are not points",
                    path, "mesh into tetrahedra, hexahedra, prisms or pyramids (e.g. drop Mesh.Recombine3DAll)")
    if status == "no gmsh":
        raise _fail(f"mesh {path.name!r} needs gmsh, which cannot be loaded ({result['reason'][:120]})", path, INSTALL)
    if status == "bad option":
        raise _fail(f"{result['option']} = {result['value']:g} in {path.name!r} is outside {result['range']} (it multiplies "
                    "gmsh's work or is no valid choice)", path, f"set {result['option']} within {result['range']} or drop it")
    lines = [ln.strip() for ln in str(result.get("reason", status)).splitlines() if ln.strip()]
    raise _fail(f"gmsh failed meshing {path.name!r}: {(lines[-1] if lines else status)[:200]}", path,
                "check the .geo file with gmsh (its options and fields)")
