"""The child process that meshes a gmsh ``.geo`` (``python -m peridyn.io.gmsh_worker REQUEST``).

gmsh runs here, not in peridyn's process, so that its crashes (a segfault on some option
combinations), a script's ``Exit;``, and runaway meshing cannot take peridyn down or hold it:
:mod:`peridyn.io.geo_mesh` starts this process, watches its memory, kills it on Ctrl-C or
SIGTERM, and turns whatever happened into a one-line input error.

REQUEST is a JSON file: ``geo`` (path), ``out`` (the ``.msh`` to write), ``mesh_size`` (the
deck's Mesh Size or null), ``max_elements`` (refuse above this many estimated tetrahedra; null:
no refusal). The worker writes, atomically, ``estimate.json`` once the geometry is parsed (before
meshing) and ``result.json`` at the end, both next to REQUEST; ``status`` in the result is one of
``ok``, ``gmsh error``, ``bad option``, ``no volumes``, ``too large``, ``bad elements``, ``no gmsh``, ``bug``.
Only the standard library and gmsh are imported.
"""
from __future__ import annotations

import json
import math
import os
import signal
import sys
import threading
import time
import traceback
from pathlib import Path

ESTIMATE = "estimate.json"
RESULT = "result.json"
#: gmsh's size options at their defaults mean "no size set" (1e22)
UNSET = 1e20
#: field options that are element sizes (Box, Ball, Cylinder, Constant: VIn/VOut; Threshold:
#: SizeMin/SizeMax, which LcMin/LcMax alias; BoundaryLayer: Size/SizeFar; Frustum: V1/V2)
FIELD_SIZES = ("VIn", "VOut", "SizeMin", "SizeMax", "Size", "SizeFar",
               "V1_inner", "V1_outer", "V2_inner", "V2_outer")
#: gmsh's volume element families that become points (gmsh's names; "Prism" is meshio's wedge)
VOLUME_FAMILIES = ("Tetrahedron", "Hexahedron", "Prism", "Pyramid")
#: options that multiply gmsh's work, each with the range peridyn accepts (passes, steps,
#: algorithm numbers): beyond it meshing takes minutes to hours or gmsh misbehaves
WORK_OPTIONS = {
    "Mesh.Smoothing": (0, 100),
    "Mesh.SmoothNormals": (0, 100),
    "Mesh.SmoothCrossField": (0, 100),
    "Mesh.Optimize": (0, 1),
    "Mesh.OptimizeNetgen": (0, 1),
    "Mesh.RefineSteps": (0, 100),
    "Mesh.HighOrderIterMax": (0, 1000),
    "Mesh.HighOrderPassMax": (0, 100),
    "Mesh.AnisoMax": (0, 1e33),
    "Mesh.MaxNumThreads3D": (0, 256),
    "Mesh.ElementOrder": (1, 4),
    "Mesh.Algorithm": ({1, 2, 3, 5, 6, 7, 8, 9, 11}, None),
    "Mesh.Algorithm3D": ({1, 3, 4, 7, 9, 10}, None),
}
#: the largest element count reported (a size whose cube underflows gives this, not a division by zero)
MAX_REPORTED = 1e300
#: regular tetrahedra of edge h per volume h^3 (an upper bound for a mesh of size h)
TETS_PER_CUBE = 6.0 * math.sqrt(2.0)


class Report:
    """``NAME.json`` written atomically (the parent never reads half a file) through a file
    opened at the start: a script that exhausts the file handles (a Merge loop gmsh follows)
    cannot keep the worker from reporting."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.part = path.with_suffix(".part")
        self.handle = open(self.part, "w", encoding="utf-8")  # noqa: SIM115 - held until written

    def write(self, data: dict) -> None:
        with self.handle:
            self.handle.write(json.dumps(data))
        os.replace(self.part, self.path)


def effective_size(gmsh, mesh_size: float | None) -> tuple[float, str] | None:
    """The smallest element size the parsed model asks for and where it comes from, or None
    when nothing sets one (gmsh then sizes by the bounding box: a coarse mesh).

    The minimum over Mesh.MeshSizeMax, the points' characteristic lengths (when
    Mesh.MeshSizeFromPoints), the size options of every field; clamped by Mesh.MeshSizeMin and
    Mesh.MeshSizeMax and times Mesh.MeshSizeFactor, as gmsh applies them. Lengths in the .geo's unit."""
    size_max = gmsh.option.getNumber("Mesh.MeshSizeMax")
    has_max = 0.0 < size_max < UNSET
    candidates: list[tuple[float, str]] = []
    if has_max:
        candidates.append((size_max, "'Mesh Size'" if mesh_size is not None else "Mesh.MeshSizeMax"))
    if gmsh.option.getNumber("Mesh.MeshSizeFromPoints"):
        points = gmsh.model.getEntities(0)
        for (_, tag), lc in zip(points, gmsh.model.mesh.getSizes(points) if points else ()):
            if 0.0 < lc < UNSET:
                candidates.append((float(lc), f"the characteristic length of point {tag}"))
    for field in gmsh.model.mesh.field.list():
        kind = gmsh.model.mesh.field.getType(field)
        for option in FIELD_SIZES:
            try:
                value = gmsh.model.mesh.field.getNumber(field, option)
            except Exception:  # gmsh: the field has no such option
                continue
            if 0.0 < value < UNSET:
                candidates.append((value, f"Field[{field}].{option} ({kind})"))
    if not candidates:
        return None
    size, source = min(candidates)
    size_min = gmsh.option.getNumber("Mesh.MeshSizeMin")
    if size_min > size:
        size, source = min(size_min, size_max) if has_max else size_min, "Mesh.MeshSizeMin"
    factor = gmsh.option.getNumber("Mesh.MeshSizeFactor")
    if 0.0 < factor != 1.0:
        size, source = size * factor, f"{source} times Mesh.MeshSizeFactor {factor:g}"
    return size, source


def geometry_volume(gmsh, volumes: list[tuple[int, int]]) -> float:
    """Volume of the model's volumes: OpenCASCADE's exact mass where it knows the entity, else
    the entity's bounding box; at most the model's bounding box (overlaps are counted once)."""
    def box_volume(dim: int, tag: int) -> float:
        box = gmsh.model.getBoundingBox(dim, tag)
        return math.prod(max(box[3 + d] - box[d], 0.0) for d in range(3))

    total = 0.0
    for dim, tag in volumes:
        try:
            total += abs(gmsh.model.occ.getMass(dim, tag))
        except Exception:  # a built-in kernel or discrete entity
            total += box_volume(dim, tag)
    return min(total, box_volume(-1, -1))


def bad_option(gmsh) -> dict | None:
    """The first option of WORK_OPTIONS outside its range, as the result's dict, or None."""
    for option, (low, high) in WORK_OPTIONS.items():
        try:
            value = gmsh.option.getNumber(option)
        except Exception:  # gmsh: an option this version does not have
            continue
        if isinstance(low, set):
            if value not in low:
                return {"status": "bad option", "option": option, "value": value,
                        "range": "one of " + ", ".join(str(v) for v in sorted(low))}
        elif not (math.isfinite(value) and low <= value <= high):
            return {"status": "bad option", "option": option, "value": value, "range": f"{low:g} to {high:g}"}
    return None


def element_count(volume: float, size: float) -> float:
    """Tetrahedra of edge ``size`` in ``volume``, at most MAX_REPORTED."""
    try:
        cube = size ** 3
        return min(TETS_PER_CUBE * volume / cube, MAX_REPORTED) if cube > 0.0 else MAX_REPORTED
    except OverflowError:
        return MAX_REPORTED


def first_error(gmsh, exc: Exception, geo: str) -> str:
    errors = [m for m in gmsh.logger.get() if m.startswith("Error")]
    return (errors[0] if errors else str(exc)).replace(geo, Path(geo).name)


def mesh(request: dict, estimate_report: Report) -> dict:
    """Mesh ``request['geo']`` in 3-D into ``request['out']``; the result's dict (module docstring)."""
    try:
        import gmsh
    except (ImportError, OSError) as exc:  # OSError: gmsh's shared library or one it links
        return {"status": "no gmsh", "reason": f"{type(exc).__name__}: {exc}"}
    geo, mesh_size, max_elements = request["geo"], request["mesh_size"], request["max_elements"]
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)  # the same mesh on every machine and rank
        gmsh.logger.start()
        try:
            gmsh.model.add(f"peridyn {Path(geo).stem}")
            gmsh.merge(geo)
            if mesh_size is not None:
                gmsh.option.setNumber("Mesh.MeshSizeMax", mesh_size)
            refused = bad_option(gmsh)
            if refused is not None:
                return refused
            volumes = gmsh.model.getEntities(3)
            if not volumes:
                return {"status": "no volumes"}
            sized = effective_size(gmsh, mesh_size)
            estimate = {"status": "estimate", "volume": geometry_volume(gmsh, volumes)}
            if sized is not None:
                estimate.update(size=sized[0], source=sized[1], elements=element_count(estimate["volume"], sized[0]))
            if max_elements is not None and estimate.get("elements", 0.0) > max_elements:
                return dict(estimate, status="too large")
            estimate_report.write(estimate)
            gmsh.model.mesh.generate(3)
            kinds = [gmsh.model.mesh.getElementProperties(t)[0] for t in gmsh.model.mesh.getElementTypes(3)]
            unknown = [k for k in kinds if not k.startswith(VOLUME_FAMILIES)]
            if unknown:
                return {"status": "bad elements", "kinds": unknown}
            if not kinds:
                return {"status": "no volumes"}
            gmsh.write(request["out"])
        except Exception as exc:  # gmsh raises plain Exceptions; its log says why
            if type(exc) is not Exception:
                raise
            return {"status": "gmsh error", "reason": first_error(gmsh, exc, geo)}
        finally:
            gmsh.logger.stop()
    finally:
        gmsh.finalize()
    return {"status": "ok"}


def _die_with_parent() -> None:
    """End this process when the parent ends, however it ends (Linux: at once, by the kernel;
    elsewhere a thread that watches the parent's id)."""
    parent = os.getppid()
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    if os.getppid() != parent:  # pragma: no cover - the parent ended before prctl
        os._exit(1)
    threading.Thread(target=watch, daemon=True).start()


def main(argv: list[str]) -> int:
    """Run one request (module docstring); exit status 0 once ``result.json`` is written."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle: it kills us
    _die_with_parent()
    request_path = Path(argv[0])
    result_report = Report(request_path.parent / RESULT)
    try:
        result = mesh(json.loads(request_path.read_text()), Report(request_path.parent / ESTIMATE))
    except BaseException:  # a bug of this module, not the user's input
        result = {"status": "bug", "reason": traceback.format_exc()[-2000:]}
    result_report.write(result)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
