"""Case generators of the surface campaign, one per family; each draws from a seeded random.Random."""
from __future__ import annotations

import copy
import os
import random
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .decks import RESTART, Raw, base, copy_into, mesh_deck, to_yaml, write_deck
from .engine import Case, Spec

NAN, INF = float("nan"), float("inf")


@dataclass
class Fixtures:
    meshes: dict  #: name -> path of a valid mesh
    geo: str  #: a valid .geo text
    run_dir: Path  #: a checkpointed run of the restart deck: deck.yaml, base.e, restart/*.npz
    other_dir: Path  #: the same with another Young's modulus (a checkpoint of another deck)
    result: Path  #: a valid result file (base.e)
    xml: str


def _run_argv(deck: str = "deck.yaml", *extra: str) -> list[str]:
    return ["run", deck, "--output-dir", ".", "--no-progress", *extra]


def _fork_run(tree: dict, names: set, sentinel_files: dict | None = None, extra: list[str] | None = None, allowance: float = 1.0):
    """A set-up that writes the deck (and files) and runs it."""
    def setup(tmp: Path) -> Spec:
        write_deck(tmp, tree)
        for name, data in (sentinel_files or {}).items():
            (tmp / name).write_bytes(data) if isinstance(data, bytes) else (tmp / name).write_text(data)
        return Spec(argv=_run_argv("deck.yaml", *(extra or [])), names={"deck.yaml", *names}, tree=tree, allowance=allowance)
    return setup


# ------------------------------------------------------------------------------------------------
# Meshes
# ------------------------------------------------------------------------------------------------
MESH_MUTATIONS = ("valid", "zero_bytes", "truncated", "flipped", "garbage", "wrong_extension", "folder", "missing",
                  "text_nan", "text_line_deleted", "symlink_loop")


def gen_mesh(rng: random.Random, fx: Fixtures) -> Case:
    name = rng.choice(sorted(fx.meshes))
    mut = rng.choice(MESH_MUTATIONS)
    src: Path = fx.meshes[name]
    data = src.read_bytes()
    ext = Path(name).suffix
    target = "part" + ext
    expect = "invalid"
    desc = f"{name} {mut}"
    content: bytes | None = data
    if mut == "valid":
        expect = "valid"
    elif mut == "zero_bytes":
        content = b""
    elif mut == "truncated":
        cut = rng.randrange(1, len(data))
        content, desc = data[:cut], f"{name} truncated at {cut}/{len(data)}"
        expect = "any"  # a cut after the last element of a text file is still a mesh
    elif mut == "flipped":
        b = bytearray(data)
        at = sorted(rng.randrange(len(b)) for _ in range(rng.choice((1, 2, 8, 64))))
        for k in at:
            b[k] ^= 1 << rng.randrange(8)
        content, desc, expect = bytes(b), f"{name} {len(at)} bytes flipped at {at[:4]}", "any"
    elif mut == "garbage":
        content = rng.randbytes(rng.choice((1, 100, 5000)))
    elif mut == "wrong_extension":
        target = "part" + rng.choice([e for e in (".msh", ".inp", ".vtu", ".vtk", ".med", ".stl", ".xyz", "") if e != ext])
        desc = f"{name} named {target}"
    elif mut == "folder":
        content = None
    elif mut == "missing":
        content = b"MISSING"
    elif mut in ("text_nan", "text_line_deleted"):
        lines = data.split(b"\n")
        if not all(32 <= c < 127 or c in (9, 10, 13) for c in data[:2000]):
            content, desc = data, f"{name} (binary) valid"
            expect = "valid"
        else:
            k = rng.randrange(len(lines))
            if mut == "text_nan":
                parts = lines[k].split(b" " if b" " in lines[k] else b",")
                parts[rng.randrange(len(parts))] = rng.choice((b"nan", b"inf", b"-1e400", b"x"))
                lines[k] = (b" " if b" " in lines[k] else b",").join(parts)
            else:
                del lines[k]
            content, desc, expect = b"\n".join(lines), f"{name} {mut} line {k}", "any"
    elif mut == "symlink_loop":
        content = b"LOOP"
    disc = {}
    if rng.random() < 0.1:
        disc["Mesh Size"] = rng.choice((1.0, -1.0, NAN))  # an error with a mesh file
        expect, desc = "invalid", desc + f" + Mesh Size {disc['Mesh Size']}"
    tree = mesh_deck(target, **disc)

    def setup(tmp: Path) -> Spec:
        write_deck(tmp, tree)
        p = tmp / target
        if content is None:
            p.mkdir()
        elif content == b"MISSING":
            pass
        elif content == b"LOOP":
            os.symlink(target, p)
        else:
            p.write_bytes(content)
        return Spec(argv=_run_argv(), names={"deck.yaml", target}, tree=tree)
    return Case("mesh", desc, expect, setup)


# ------------------------------------------------------------------------------------------------
# .geo scripts
# ------------------------------------------------------------------------------------------------
GEO_SIZES = ("Mesh.MeshSizeMax = SIZE;", "Mesh.CharacteristicLengthMax = SIZE;", "Mesh.MeshSizeFactor = SIZE;",
             "Mesh.CharacteristicLengthFactor = SIZE;",
             "Point(100) = {1, 1, 1, SIZE};\nCharacteristic Length{PointsOf{Volume{1};}} = SIZE;",
             "MeshSize{PointsOf{Volume{1};}} = SIZE;",
             'Field[1] = MathEval; Field[1].F = "SIZE"; Background Field = 1;',
             "Field[1] = Box; Field[1].VIn = SIZE; Field[1].VOut = SIZE; Field[1].XMax = 10; Field[1].YMax = 4; "
             "Field[1].ZMax = 4; Background Field = 1;",
             "Mesh.MeshSizeMin = SIZE; Mesh.MeshSizeMax = SIZE;")


def gen_geo(rng: random.Random, fx: Fixtures) -> Case:
    geo = fx.geo
    extra_files: dict[str, str] = {}
    kind = rng.choice(("valid", "exit", "self_merge", "include_loop", "tiny_size", "tiny_size", "syntax", "2d_only",
                       "no_volume", "algorithm3d", "crashy", "deck_mesh_size", "include_missing", "empty"))
    expect = "invalid"
    desc = kind
    if kind == "valid":
        expect = "valid"
    elif kind == "exit":
        at = rng.choice(("start", "end", "middle"))
        geo = {"start": "Exit;\n" + geo, "end": geo + "Exit;\n", "middle": geo.replace("Physical", "Exit;\nPhysical")}[at]
        desc = f"Exit; at the {at}"
        expect = "invalid" if at != "end" else "any"
    elif kind == "self_merge":
        geo = geo + rng.choice(('Merge "part.geo";\n', 'Include "part.geo";\n', 'Merge StrCat(CurrentDirectory, "part.geo");\n'))
        desc = "self " + geo.strip().splitlines()[-1]
    elif kind == "include_loop":
        extra_files["b.geo"] = 'Include "c.geo";\n'
        extra_files["c.geo"] = 'Include "b.geo";\n'
        geo = 'Include "b.geo";\n' + geo
    elif kind == "tiny_size":
        s = rng.choice((1e-3, 1e-5, 1e-9, 0.0, -1.0, 1e-300))
        opt = rng.choice(GEO_SIZES)
        geo = geo.replace("Mesh.MeshSizeMax = 2.0;\n", "") + opt.replace("SIZE", repr(s)) + "\n"
        desc = f"size {s}: {opt.split('=')[0].strip()}"
        expect = "invalid" if 1e-100 < s < 0.05 and "Factor" not in opt else "any"
    elif kind == "syntax":
        junk = rng.choice(("Box(1) = {0, 0, 0, 10, 4;\n", "Point(1) = ;\n", "}}}}\n", "Foo = Bar(;\n", '"unterminated\n',
                           "For i In {1:3}\n", "If (1)\n", "\xff\xfe garbage\n", "Physical Volume(\"X\") = {99};\n"))
        geo = geo + junk
        desc = f"syntax: {junk.strip()!r}"
        expect = "invalid" if "99" not in junk and "If" not in junk and "For" not in junk else "any"  # gmsh closes open blocks
    elif kind == "2d_only":
        geo = 'SetFactory("OpenCASCADE");\nRectangle(1) = {0, 0, 0, 10, 4};\nPhysical Surface("S") = {1};\nMesh.MeshSizeMax = 2;\n'
    elif kind == "no_volume":
        geo = "Point(1) = {0, 0, 0, 1};\nPoint(2) = {1, 0, 0, 1};\nLine(1) = {1, 2};\n"
    elif kind == "algorithm3d":
        a = rng.choice((1, 3, 4, 7, 9, 10, 2, 5, 99, -1, 0))
        geo = geo + f"Mesh.Algorithm3D = {a};\n"
        desc, expect = f"Mesh.Algorithm3D = {a}", "any"
    elif kind == "crashy":
        opt = rng.choice(("Abort;", "General.NumThreads = 64;", "Mesh.ElementOrder = 5;", "Mesh 3;", 'Save "x.msh";',
                          "Delete All;", "Sleep 1;", "Mesh.RecombineAll = 1;", "Mesh.SubdivisionAlgorithm = 2;",
                          "OptimizeMesh \"Netgen\";", "Mesh.Algorithm = 99;", "Error(\"boom\");", "General.AbortOnError = 2; Error(\"x\");",
                          "Geometry.Tolerance = -1;", "Mesh.ElementOrder = 2; Mesh.HighOrderOptimize = 2;",
                          "For i In {1:1e12} EndFor", 'SystemCall "touch PWNED";', "Mesh.MeshSizeFromCurvature = 1e9;",
                          "Mesh.Smoothing = 1e9;", "Mesh.Optimize = 1; Mesh.OptimizeThreshold = 1;"))
        geo = geo + opt + "\n"
        desc, expect = f"crashy: {opt}", "any"
    elif kind == "deck_mesh_size":
        s = rng.choice((NAN, INF, -2.0, 0.0, 1e-6, "big", 1e300, 3.0))
        desc = f"deck Mesh Size {s}"
        expect = "any" if s in (3.0, 1e300) else "invalid"
    elif kind == "include_missing":
        geo = 'Include "nowhere.geo";\n' + geo
    elif kind == "empty":
        geo = rng.choice(("", "// nothing\n", "\n\n"))
    disc = {"Mesh Size": s} if kind == "deck_mesh_size" else {}
    tree = mesh_deck("part.geo", **disc)

    def setup(tmp: Path) -> Spec:
        write_deck(tmp, tree)
        (tmp / "part.geo").write_bytes(geo.encode("utf-8", "surrogateescape") if "\xff" not in geo else geo.encode("latin-1"))
        for k, v in extra_files.items():
            (tmp / k).write_text(v)
        return Spec(argv=_run_argv(), names={"deck.yaml", "part.geo", *extra_files}, tree=tree)
    return Case("geo", desc, expect, setup, timeout=90.0)


# ------------------------------------------------------------------------------------------------
# Regions
# ------------------------------------------------------------------------------------------------
BAD_NUMBERS = (NAN, INF, -INF, 1e308, -1e308, 0.0, -1.0, "abc", None, True, [1.0], 1e-300)


def _vec(rng: random.Random, good: list[float], bad: float) -> tuple[list, bool]:
    r = rng.random()
    if r < bad:
        choice = rng.randrange(5)
        if choice == 0:
            v = list(good)
            v[rng.randrange(3)] = rng.choice((NAN, INF, -INF, "x", None))
            return v, True
        if choice == 1:
            return good[:2], True
        if choice == 2:
            return good + [0.0], True
        if choice == 3:
            return rng.choice(("0 0 0", 3.0, [], [[0, 0, 0]])), True
        return [0.0, 0.0, 0.0], None  # zero: bad as a normal/axis only
    return list(good), False


def random_region(rng: random.Random, depth: int = 0, bad: float = 0.3) -> tuple[dict | object, bool]:
    """(region, surely_invalid)."""
    kinds = ["All", "Box", "Sphere", "Cylinder", "Half Space", "Expression", "Surface Layer"]
    if depth < 3:
        kinds += ["Union", "Intersection", "Difference"] * 2
    k = rng.choice(kinds)
    inv = False
    c = [rng.uniform(0, 0.01), rng.uniform(0, 0.004), rng.uniform(0, 0.004)]
    if k == "All":
        v = rng.choice((True, True, False, "yes", 1, NAN, None)) if rng.random() < bad else True
        inv = v is not True
        return {"All": v}, inv
    if k == "Box":
        lo, hi = [0.0, 0.0, 0.0], [0.005, 0.004, 0.004]
        lo, b1 = _vec(rng, lo, bad)
        hi, b2 = _vec(rng, hi, bad)
        if rng.random() < bad / 3:
            lo, hi, inv = hi, lo, True
        inv = inv or bool(b1) or bool(b2)
        return {"Box": {"Min": lo, "Max": hi}}, inv
    if k == "Sphere":
        r = rng.choice(BAD_NUMBERS) if rng.random() < bad else rng.choice((0.002, 0.004, 1e-6, 1.0))
        ctr, b = _vec(rng, c, bad)
        inv = bool(b) or not (isinstance(r, float) and np.isfinite(r) and r > 0) or r is True
        return {"Sphere": {"Center": ctr, "Radius": r}}, inv
    if k == "Cylinder":
        d = {"Center": c, "Axis": rng.choice(("x", "y", "z", [1.0, 0.0, 0.0], "w", [0.0, 0.0, 0.0], [NAN, 0, 1])),
             "Radius": rng.choice((0.002, 0.01)) if rng.random() > bad else rng.choice(BAD_NUMBERS)}
        inv = d["Axis"] in ("w", [0.0, 0.0, 0.0]) or isinstance(d["Axis"], list) and any(x != x for x in d["Axis"])
        inv = inv or not (isinstance(d["Radius"], float) and np.isfinite(d["Radius"]) and d["Radius"] > 0)
        r = rng.random()
        if r < 0.2:
            d["Inner Radius"] = rng.choice((0.001, 0.02, -1.0, NAN))
            inv = inv or not (isinstance(d["Radius"], float) and d["Inner Radius"] == d["Inner Radius"] and 0 <= d["Inner Radius"] < d["Radius"])
        elif r < 0.4:
            d["Length"] = rng.choice((0.004, 0.0, -1.0, INF))
            inv = inv or not (0 < d["Length"] < INF)
        elif r < 0.6:
            d["Min"], d["Max"] = rng.choice(((0.0, 0.01), (0.01, 0.0), (NAN, 1.0), (-INF, INF)))
            inv = inv or not (d["Min"] <= d["Max"])
            if rng.random() < 0.2:
                d["Length"] = 0.01
                inv = True
        return {"Cylinder": d}, inv
    if k == "Half Space":
        p, b1 = _vec(rng, c, bad)
        n, b2 = _vec(rng, rng.choice(([1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [1.0, 1.0, 1.0])), bad)
        return {"Half Space": {"Point": p, "Normal": n}}, bool(b1) or b2 is not False
    if k == "Expression":
        if rng.random() < bad:
            e = rng.choice(("x >", "nan", "0/0", "x/0 > 1", "sqrt(-1) > 0", "log(0) < 0", "1e400 > x", "(((x", "",
                            "__import__('os').system('touch PWNED')", "y && ", "z ? 1 : 0", "x > 0 &", "foo(x)",
                            "x > 0.001 && nan", "exp(1e5) > 0", "acos(2) > 0", "x > 0.005 and y > 0", "t > 0", "rnd() > 0.5",
                            "\u00e9 > 0", "x" * 5000 + " > 0"))
            inv = e not in ("t > 0", "rnd() > 0.5", "exp(1e5) > 0", "log(0) < 0", "x/0 > 1", "1e400 > x", "z ? 1 : 0")
        else:
            e = rng.choice(("x > 0.005", "x < 0.003 && y > 0.001", "fabs(y - 0.002) < 0.0015 || z > 0.003", "!(x > 0.002)",
                            "x*x + y*y < 1e-5", "x >= 0.0095"))
        return {"Expression": e}, inv
    if k == "Surface Layer":
        t = rng.choice(BAD_NUMBERS) if rng.random() < bad else rng.choice((0.001, 0.002, 0.0004, 1.0))
        inv = not (isinstance(t, float) and np.isfinite(t) and t > 0)
        return {"Surface Layer": {"Thickness": t}}, inv
    # boolean
    n = rng.choice((0, 1, 2, 2, 3)) if rng.random() < bad else rng.choice((2, 3))
    subs, inv = {}, (n == 0) or (k == "Difference" and n < 2)
    for j in range(n):
        r, b = random_region(rng, depth + 1, bad)
        subs[f"R{j}"] = r
        inv = inv or b
    return {k: subs}, inv


def region_mutation(rng: random.Random) -> tuple[object, str, str]:
    """(region, description, expect)."""
    r = rng.random()
    if r < 0.08:
        depth = rng.choice((20, 100, 400, 2000))
        kind = rng.choice(("Union", "Intersection", "Difference"))
        reg: object = {"All": True}
        for _ in range(depth):
            reg = {kind: {"A": reg, "B": {"Half Space": {"Point": [0.003, 0, 0], "Normal": [-1.0, 0, 0]}}}}
        return reg, f"{kind} nested {depth} deep", "any"
    if r < 0.16:
        extra = rng.choice(({"Box": {"Min": [0, 0, 0], "Max": [1, 1, 1]}, "Sphere": {"Center": [0, 0, 0], "Radius": 1.0}},
                            {"Cube": {"Side": 1.0}}, {}, {"Box": {"Min": [0, 0, 0], "Max": [1, 1, 1], "Colour": "red"}},
                            {"Sphere": {"Center": [0, 0, 0], "Radius": 0.1, "Radius ": 0.2}}, {"Half Space": None},
                            {"Expression": ["x > 0"]}, {"Union": []}, {"Union": {"A": 3}}, "Box", 42))
        return extra, f"malformed {str(extra)[:60]}", "invalid"
    if r < 0.22:
        far = rng.choice(({"Box": {"Min": [1.0, 1.0, 1.0], "Max": [2.0, 2.0, 2.0]}}, {"Expression": "x > 1"},
                          {"Sphere": {"Center": [5.0, 5.0, 5.0], "Radius": 0.1}},
                          {"Intersection": {"A": {"Expression": "x < 0.002"}, "B": {"Expression": "x > 0.008"}}},
                          {"Surface Layer": {"Thickness": 0.0001}}))
        return far, f"empty {str(far)[:60]}", "invalid"
    reg, inv = random_region(rng)
    return reg, str(reg)[:100], "invalid" if inv else "any"


def gen_region(rng: random.Random, fx: Fixtures) -> Case:
    reg, desc, expect = region_mutation(rng)
    tree = base()
    bc = tree["Boundary Conditions"]
    use = rng.choice(("hold", "velocity", "traction"))
    if use == "hold":
        bc["R Node Set"] = reg
        bc["Hold"]["Node Set"] = "R Node Set"
    elif use == "velocity":
        bc["R Node Set"] = reg
        bc["Kick"] = {"Type": "Initial Velocity", "Node Set": "R Node Set", "Coordinate": "y", "Value": "0.01"}
    else:
        bc["Right Node Set"] = reg
        if expect == "any":
            expect = "any"
    tree["Solver"]["Final Time"] = 1.0e-6
    return Case("regions", f"{use}: {desc}", expect, _fork_run(tree, {"R Node Set", "Right Node Set"}), timeout=60.0)


# ------------------------------------------------------------------------------------------------
# Surface Traction
# ------------------------------------------------------------------------------------------------
def traction_mutation(rng: random.Random) -> tuple[dict, dict, str, str]:
    """(Pull entry, extra node sets, description, expect)."""
    pull = {"Type": "Surface Traction", "Node Set": "Right Node Set", "Traction": [1.0e6, 0.0, 0.0], "Scale": "min(t/1.0e-6, 1.0)"}
    sets: dict = {}
    k = rng.choice(("valid", "traction_value", "pressure_value", "both", "neither", "scale", "scale", "no_surface",
                    "missing_set", "thickness", "area", "huge_tiny", "pressure_valid", "extra_key"))
    expect = "invalid"
    if k == "valid":
        expect = "valid"
    elif k == "traction_value":
        v = rng.choice(([NAN, 0.0, 0.0], [INF, 0.0, 0.0], [0.0, -INF, 0.0], [1.0, 2.0], [1.0, 2.0, 3.0, 4.0], "1e6 0 0", 1e6,
                        None, [], [[1e6, 0, 0]], ["a", 0, 0], [True, 0, 0]))
        pull["Traction"] = v
        expect = "invalid" if not (v == 1e6) else "any"
    elif k in ("pressure_value", "pressure_valid"):
        del pull["Traction"]
        pull["Pressure"] = rng.choice((NAN, INF, -INF, "p", None, [1.0], True)) if k == "pressure_value" else rng.choice((1e6, -1e6, 0.0))
        pull["Node Set"] = rng.choice(("Right Node Set", "Skin Node Set"))
        sets["Skin Node Set"] = {"Surface Layer": {"Thickness": 0.001}}
        expect = "invalid" if k == "pressure_value" else "valid"
    elif k == "both":
        pull["Pressure"] = 1.0e6
    elif k == "neither":
        del pull["Traction"]
    elif k == "scale":
        s = rng.choice(("nan", "inf", "1/0", "t/0", "(((t", "", "foo(t)", "t >", "sqrt(-1)", "log(0)", "1e400",
                        "t*1e30", "min(t/1e-7, 1e12)", "sin(1e7*t)", "t < 1e-6 ? 1 : nan", "exp(t*1e9)", "x", "1e308*1e308*t",
                        "-1", "0", "t*0", "1e-300", "__import__('os')", "t/1e-6", "cos(t)"))
        pull["Scale"] = s
        legal = {"-1", "0", "t*0", "1e-300", "t/1e-6", "cos(t)", "sin(1e7*t)"}
        expect = "valid" if s in legal else ("any" if s in ("t*1e30", "min(t/1e-7, 1e12)", "exp(t*1e9)", "1e308*1e308*t", "x",
                                                            "t < 1e-6 ? 1 : nan", "log(0)") else "invalid")
        if s == "x":
            expect = "any"
    elif k == "no_surface":
        sets["Core Node Set"] = {"Box": {"Min": [0.004, 0.0015, 0.0015], "Max": [0.006, 0.0025, 0.0025]}}
        pull["Node Set"] = "Core Node Set"
        if rng.random() < 0.5:
            del pull["Traction"]
            pull["Pressure"] = 1e6
            expect = "any"  # an inner point carries the faces of its nearest surface point (docs/regions.md)
        else:
            expect = "any" if rng.random() < 0.5 else "invalid"
            if expect == "any":
                pull["Thickness"] = 0.001
    elif k == "missing_set":
        pull["Node Set"] = rng.choice(("Nowhere Node Set", "", 3, None))
    elif k == "thickness":
        pull["Thickness"] = rng.choice((NAN, -1.0, 0.0, INF, "t", 0.001, 1e-300, 1e300))
        expect = "any" if pull["Thickness"] in (0.001, 1e300) else "invalid"
        if rng.random() < 0.3:
            del pull["Traction"]
            pull["Pressure"] = 1e6
            expect = "invalid"
    elif k == "area":
        pull["Area"] = rng.choice((NAN, -1.0, 0.0, INF, "a", 1.6e-5, 1e-300))
        expect = "any" if pull["Area"] in (1.6e-5, 1e-300) else "invalid"
    elif k == "huge_tiny":
        v = rng.choice((1e300, 1e200, 1e30, 1e15, 1e-300, 1e-30, 5e-324))
        pull["Traction"] = [v, 0.0, -v]
        expect = "valid" if v < 1e16 else "any"
    elif k == "extra_key":
        pull[rng.choice(("Tractoin", "Value", "Coordinate", "Direction"))] = rng.choice(("x", 1.0))
        expect = "any"
    return pull, sets, f"{k}: {({a: b for a, b in pull.items() if a not in ('Type',)})}"[:140], expect


def gen_traction(rng: random.Random, fx: Fixtures) -> Case:
    pull, sets, desc, expect = traction_mutation(rng)
    tree = base()
    tree["Boundary Conditions"]["Pull"] = pull
    tree["Boundary Conditions"].update(sets)
    scale = str(pull.get("Scale", ""))
    allowance = 1e3 if "sin" in scale else 1.0
    allowance = 1e30 if "1e30" in scale or "1e12" in scale or "exp" in scale or "1e308" in scale else allowance
    t = pull.get("Traction")
    if isinstance(t, list) and t and isinstance(t[0], float) and abs(t[0]) > 1e7:
        allowance = abs(t[0]) / 1e6
    return Case("traction", desc, expect, _fork_run(tree, {"Pull", "Right Node Set", "Core Node Set", "Skin Node Set"}, allowance=allowance))


# ------------------------------------------------------------------------------------------------
# Restart files
# ------------------------------------------------------------------------------------------------
RESTART_MUTATIONS = ("valid", "latest", "flipped", "truncated", "deleted_array", "renamed_array", "reshaped", "retyped",
                     "meta_edit", "meta_garbage", "other_deck", "folder", "missing", "zero_bytes", "text", "pickled",
                     "nan_array", "extra_array", "no_checkpoints", "deck_changed", "symlink_dir")


def _npz_edit(path: Path, rng: random.Random, how: str) -> str:
    import json

    z = dict(np.load(path, allow_pickle=False))
    keys = [k for k in z if k != "meta"]
    k = rng.choice(keys)
    if how == "deleted_array":
        k = rng.choice(keys + ["meta"])
        del z[k]
        what = f"deleted {k}"
    elif how == "renamed_array":
        z[k + "_x"] = z.pop(k)
        what = f"renamed {k}"
    elif how == "reshaped":
        a = z[k]
        shapes = [b for b in (a.reshape(-1), a[:-1], np.concatenate([a, a[:1]]), a.reshape(-1)[:, None], np.zeros((0,)))
                  if b.shape != a.shape]
        z[k] = rng.choice(shapes)
        what = f"reshaped {k} to {z[k].shape}"
    elif how == "retyped":
        dt = rng.choice((np.float32, np.int64, np.int8, np.complex128, np.bool_, "U3"))
        z[k] = z[k].astype(dt)
        what = f"{k} as {np.dtype(dt)}"
    elif how == "nan_array":
        a = z[k].astype(float) if z[k].dtype.kind == "f" else z[k]
        if a.dtype.kind == "f" and a.size:
            a.reshape(-1)[rng.randrange(a.size)] = rng.choice((NAN, INF, 1e308))
        z[k] = a
        what = f"non-finite in {k}"
    elif how == "extra_array":
        z["np1/Bogus"] = np.zeros(3)
        what = "extra array np1/Bogus"
    else:  # meta edits
        meta = json.loads(str(z["meta"]))
        field_ = rng.choice(("format", "deck_hash", "ranks", "num_global", "num_bonds_global", "section", "step", "sections",
                             "dt", "time", "final_time", "fields", "writers", "monitor", "relations", "two_step", "deck"))
        val = rng.choice((NAN, -1, 10**12, "x", None, [], {}, 0, 1e308, True))
        meta[field_] = val
        txt = json.dumps(meta) if how == "meta_edit" else str(z["meta"])[: rng.randrange(1, 200)]
        z["meta"] = np.array(txt)
        what = f"meta {field_} = {val!r}" if how == "meta_edit" else "meta cut"
    np.savez(path, **z)
    return what


def gen_restart(rng: random.Random, fx: Fixtures) -> Case:
    mut = rng.choice(RESTART_MUTATIONS)
    ckpts = sorted((fx.run_dir / "restart").glob("*.npz"))
    pick = rng.choice(ckpts).name
    expect, desc = "invalid", mut

    def setup(tmp: Path) -> Spec:
        nonlocal desc
        copy_into(fx.run_dir, tmp)
        ck = tmp / "restart" / pick
        arg = f"restart/{pick}"
        if mut == "flipped":
            b = bytearray(ck.read_bytes())
            at = [rng.randrange(len(b)) for _ in range(rng.choice((1, 4, 32)))]
            for k in at:
                b[k] ^= 1 << rng.randrange(8)
            ck.write_bytes(bytes(b))
            desc = f"flipped {len(at)} bytes at {at[:3]}"
        elif mut == "truncated":
            b = ck.read_bytes()
            ck.write_bytes(b[: rng.randrange(len(b))])
        elif mut in ("deleted_array", "renamed_array", "reshaped", "retyped", "meta_edit", "meta_garbage", "nan_array", "extra_array"):
            desc = f"{mut}: {_npz_edit(ck, rng, mut)}"
        elif mut == "other_deck":
            ck.unlink()
            shutil.copy2(sorted((fx.other_dir / "restart").glob("*.npz"))[-1], ck)
        elif mut == "folder":
            ck.unlink()
            ck.mkdir()
        elif mut == "missing":
            ck.unlink()
        elif mut == "zero_bytes":
            ck.write_bytes(b"")
        elif mut == "text":
            ck.write_text("not a checkpoint\n")
        elif mut == "pickled":
            np.savez(ck, meta=np.array([{"a": 1}], dtype=object), bond_keys=np.zeros(3, dtype=np.int64))
        elif mut == "no_checkpoints":
            shutil.rmtree(tmp / "restart")
            arg = None
        elif mut == "latest":
            arg = None
        elif mut == "deck_changed":
            tree = copy.deepcopy(fx_tree(fx))
            tree["Materials"]["Steel"]["Density"] = 7900.0
            write_deck(tmp, tree)
        elif mut == "symlink_dir":
            shutil.rmtree(tmp / "restart")
            os.symlink("/nonexistent-dir", tmp / "restart")
            arg = None
        argv = _run_argv("deck.yaml", "--restart", *([arg] if arg else []))
        return Spec(argv=argv, names={"deck.yaml", pick, "--restart", "restart"}, sentinels=[tmp / "base.e"], tree=fx_tree(fx),
                    detail=desc if desc != mut else "")
    if mut in ("valid", "latest"):
        expect = "valid"
    elif mut in ("flipped", "extra_array"):
        expect = "any"
    return Case("restart", f"{desc} ({pick})", expect, setup)


def fx_tree(fx: Fixtures) -> dict:
    t = base()
    t["Restart"] = dict(RESTART)
    return t


# ------------------------------------------------------------------------------------------------
# Stress-law modules
# ------------------------------------------------------------------------------------------------
LAW_HEAD = "import numpy as np\nimport numba\n"
GOOD_LAW = """
@numba.njit
def law(F_old, F_new, state, dt, params):
    E = 0.5 * (F_new.T @ F_new - np.eye(3))
    tr = E[0, 0] + E[1, 1] + E[2, 2]
    S = params[1] * tr * np.eye(3) + 2.0 * params[0] * E
    J = np.linalg.det(F_new)
    return F_new @ S @ F_new.T / J, state
"""
LAW_VARIANTS = {
    "valid": (GOOD_LAW, "law", "valid"),
    "raise_on_import": ("raise RuntimeError('broken at import')\n" + GOOD_LAW, "law", "invalid"),
    "syntax_error": ("def law(:\n", "law", "invalid"),
    "sys_exit_0": ("import sys\nsys.exit(0)\n", "law", "invalid"),
    "sys_exit_1": ("import sys\nsys.exit(1)\n", "law", "invalid"),
    "os_exit_0": ("import os\nos._exit(0)\n", "law", "invalid"),
    "os_exit_3": ("import os\nos._exit(3)\n", "law", "invalid"),
    "keyboard_interrupt": ("raise KeyboardInterrupt\n", "law", "any"),
    "returns_float": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    return 1.0\n", "law", "invalid"),
    "returns_stress_only": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3))\n", "law", "invalid"),
    "shape_2x2": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    return np.zeros((2, 2)), state\n", "law", "invalid"),
    "shape_3x3x3": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3, 3)), state\n", "law", "invalid"),
    "state_too_long": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3)), np.zeros(12)\n", "law", "invalid"),
    "nan_stress": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    return np.full((3, 3), np.nan), state\n", "law", "invalid"),
    "nan_later": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    s = np.zeros((3, 3))\n"
                  "    if abs(F_new[0, 0] - 1.0) > 1e-12:\n        s[0, 0] = np.nan\n    return s, state\n", "law", "any"),
    "inf_stress": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    return np.full((3, 3), np.inf), state\n", "law", "invalid"),
    "plain_python": ("def law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3)), state\n", "law", "invalid"),
    "object_mode": ("@numba.jit(forceobj=True)\ndef law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3)), state\n", "law", "invalid"),
    "missing_function": (GOOD_LAW, "nolaw", "invalid"),
    "not_callable": ("law = 3\n", "law", "invalid"),
    "wrong_signature": ("@numba.njit\ndef law(F, state):\n    return np.zeros((3, 3)), state\n", "law", "invalid"),
    "raises_inside": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    raise ValueError('no')\n", "law", "invalid"),
    "reads_missing_param": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    return params[5] * np.eye(3), state\n", "law", "any"),
    "int_stress": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3), dtype=np.int64), state\n", "law", "any"),
    "tuple_of_three": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3)), state, 1.0\n", "law", "invalid"),
    "huge_stress": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    return 1e300 * (F_new - F_old), state\n", "law", "any"),
    "module_is_package_dir": (None, "law", "invalid"),
    "spec_no_colon": (GOOD_LAW, None, "invalid"),
    "spec_relative": (GOOD_LAW, ".", "invalid"),
    "compile_error": ("@numba.njit\ndef law(F_old, F_new, state, dt, params):\n    return undefined_name, state\n", "law", "invalid"),
    "nan_params": (GOOD_LAW, "law", "invalid"),
}


def gen_law(rng: random.Random, fx: Fixtures) -> Case:
    variant = rng.choice(sorted(LAW_VARIANTS))
    src, fn, expect = LAW_VARIANTS[variant]
    mod = f"userlaw_{rng.randrange(10**6)}"
    spec = {None: mod, ".": f".{mod}:law"}.get(fn, f"{mod}:{fn}")
    tree = base()
    tree["Materials"] = {"Steel": {"Material Model": "Stress Law Correspondence", "Density": 7800.0, "Shear Modulus": 76.9e9,
                                   "Bulk Modulus": 166.7e9, "Hourglass Coefficient": 0.02, "Stress Law": spec,
                                   "Law Parameters": [NAN, 115.4e9] if variant == "nan_params" else [76.9e9, 115.4e9]}}
    tree["Output"]["Output Variables"]["Cauchy_Stress"] = True

    def setup(tmp: Path) -> Spec:
        write_deck(tmp, tree)
        if src is None:
            (tmp / mod).mkdir()
        else:
            (tmp / f"{mod}.py").write_text(LAW_HEAD + src)
        return Spec(argv=_run_argv(), names={"deck.yaml", mod, "Stress Law"}, tree=tree)
    return Case("stress_law", variant, expect, setup, timeout=120.0)
