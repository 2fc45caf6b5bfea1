"""The CLI-arguments and Python-API families, and the 2-rank sample."""
from __future__ import annotations

import os
import random
from pathlib import Path

import numpy as np

from .decks import XML_DECK, base, write_deck
from .engine import Case, Spec
from .families import INF, NAN, Fixtures, gen_region, gen_restart, gen_traction, random_region

LONG = "n" * 300
NON_UTF8 = os.fsdecode(b"d\xff\xfeck")


def _path_variants(kind: str) -> list[tuple[str, str]]:
    """(description, path) of bad paths; set-up materializes the folder/file ones."""
    return [("missing", "missing" + kind), ("folder", "adir" + kind), ("non-utf8", NON_UTF8 + kind),
            ("long name", LONG + kind), ("very long path", "/".join(["x" * 200] * 30) + kind), ("under a file", "afile/x" + kind),
            ("empty", ""), ("dev_full", "/dev/full"), ("dev_null", "/dev/null"), ("dash", "-")]


def gen_cli(rng: random.Random, fx: Fixtures) -> Case:
    cmd = rng.choice(("run", "check", "plugins", "schema", "fragments", "convert", "new-plugin", "verify", "plot"))
    expect = "invalid"
    if cmd in ("run", "check"):
        r = rng.random()
        if r < 0.5:
            what, p = rng.choice(_path_variants(".yaml"))
            argv = [cmd, p]
        else:
            what, p = "deck", "deck.yaml"
            flag = rng.choice((["--output-dir", "afile"], ["--output-dir", "afile/sub"], ["--output-dir", "/dev/null"],
                               ["--output-dir", LONG], ["--output-dir", NON_UTF8], ["--backend", "nope"], ["--device", "tpu"],
                               ["--restart", "adir"], ["--restart", "missing.npz"], ["--restart", "deck.yaml"], ["-v", "-v", "-v"],
                               ["--bogus"], ["--output-dir", ""], ["--device", "GPU"], ["--restart", ""], ["-q", "-q"],
                               ["--log-json"], ["--no-limits"], ["--output-dir", "newdir/sub"]))
            if cmd == "check":
                flag = [f for f in flag if not f.startswith("--output-dir") and not f.startswith("--restart")] or ["--device", "tpu"]
                if flag[0] in ("afile", "/dev/null", "adir"):
                    flag = ["--bogus"]
            argv = [cmd, p, *flag]
            what = " ".join(flag)
            if flag[0] in ("-v", "-q", "--log-json", "--no-limits") or flag == ["--output-dir", "newdir/sub"]:
                expect = "valid"
            if flag == ["--device", "GPU"]:
                expect = "any"
    elif cmd == "plugins":
        argv, what = rng.choice(((["plugins"], "plain"), (["plugins", "--brief"], "brief"), (["plugins", "extra"], "extra arg"),
                                 (["plugins", "--brief", "--brief"], "twice")))
        expect = "valid" if what in ("plain", "brief", "twice") else "invalid"
    elif cmd == "schema":
        opt = rng.choice(("-o", "--output", "--reference"))
        what, p = rng.choice(_path_variants(".json") + [("good", "out.json"), ("new dir", "newdir/out.json")])
        argv = ["schema", opt, p]
        expect = "valid" if what in ("good", "missing") else ("any" if what in ("new dir", "dash", "empty", "dev_null") else "invalid")
        what = f"{opt} {what}"
    elif cmd == "fragments":
        r = rng.random()
        if r < 0.5:
            what, p = rng.choice(_path_variants(".e") + [("garbage", "garbage.e"), ("deck", "deck.yaml"), ("zero", "zero.e")])
            argv = ["fragments", p]
        else:
            flag = rng.choice((["--frame", "abc"], ["--frame", "99999"], ["--top", "-1"], ["--top", "0"], ["--plot", "afile/x.png"],
                               ["--plot", "adir"], ["--frame", "nan"], ["--top", "1e9"], ["--plot", NON_UTF8 + ".png"]))
            argv = ["fragments", "base.e", *flag]
            what = "no fragment outputs + " + " ".join(flag)
    elif cmd == "convert":
        r = rng.random()
        if r < 0.5:
            what, p = rng.choice(_path_variants(".xml") + [("yaml in", "deck.yaml"), ("garbage", "garbage.e")])
            argv = ["convert", p, "out.yaml"]
            expect = "any" if what == "yaml in" else "invalid"
        else:
            what, p = rng.choice(_path_variants(".yaml") + [("good", "out.yaml"), ("same as input", "in.xml"), ("new dir", "nd/out.yaml")])
            argv = ["convert", "in.xml", p]
            expect = "valid" if what in ("good", "missing") else ("any" if what in ("new dir", "dash", "dev_null") else "invalid")
        what = f"{'in' if r < 0.5 else 'out'} {what}"
    elif cmd == "new-plugin":
        name = rng.choice(("good_name", "1abc", "", "a-b", "../escape", "import", "class", LONG, NON_UTF8, "a b", "existing",
                           "peridyn", "x" * 80))
        argv = ["new-plugin", name]
        what = f"name {name[:20]!r}"
        if rng.random() < 0.4:
            d = rng.choice(("afile", "missing/deep", "adir", "/dev/null", LONG, NON_UTF8))
            argv += ["--directory", d]
            what += f" --directory {d[:20]!r}"
        if rng.random() < 0.2:
            argv += ["--kind", rng.choice(("material", "stress-law", "bogus", ""))]
            what += " " + argv[-1]
        expect = "valid" if name in ("good_name", "x" * 80) and "--directory" not in argv[2:3] and "bogus" not in argv \
            and (len(argv) < 4 or argv[-1] in ("material", "stress-law")) else "any"
        if name in ("1abc", "", "a-b", "../escape", "import", "class", LONG, NON_UTF8, "a b", "existing"):
            expect = "invalid"
    elif cmd == "verify":
        argv, what = rng.choice(((["verify", "--help"], "--help"), (["verify", "--problems", "no-such-problem"], "unknown problem"),
                                 (["verify", "--problems"], "no names"), (["verify", "--quick", "--problems", "bogus", "wave-speed"], "bogus among"),
                                 (["verify", "--out", "afile", "--problems", "nope"], "out a file"), (["verify", "--device", "tpu"], "device")))
        expect = "valid" if what == "--help" else "invalid"
    else:  # plot
        r = rng.random()
        if r < 0.5:
            what, p = rng.choice(_path_variants(".e") + [("garbage", "garbage.e"), ("deck", "deck.yaml"), ("zero", "zero.e")])
            argv = ["plot", p]
        else:
            flag = rng.choice((["--frames", "999"], ["--frames", "x"], ["--field", "Nope"], ["--view", "xx"], ["--out", "afile/p"],
                               ["--out", "missing/p"], ["--out", NON_UTF8], ["--frames", "-999"], ["--field", ""], ["--out", LONG]))
            argv = ["plot", "base.e", *flag]
            what = " ".join(flag)
            expect = "any" if flag[0] == "--out" and flag[1] == "missing/p" else "invalid"
    if NON_UTF8 in " ".join(argv) and cmd in ("convert", "plot", "schema", "new-plugin", "fragments") and expect == "invalid" \
            and not argv[1].startswith(NON_UTF8):
        expect = "any"  # a name that is not UTF-8 is a legal Linux file name to write
    names = {a for a in argv if a} | {os.path.basename(a) for a in argv if a} | {cmd, "peridyn"}

    def setup(tmp: Path) -> Spec:
        write_deck(tmp, base())
        (tmp / "adir.yaml").mkdir()
        for n in ("adir", "adir.json", "adir.e", "adir.xml", "existing"):
            (tmp / n).mkdir(exist_ok=True)
        (tmp / "existing" / "keep.txt").write_text("mine")
        (tmp / "afile").write_text("a file")
        (tmp / "garbage.e").write_bytes(b"\x00garbage" * 100)
        (tmp / "zero.e").write_bytes(b"")
        (tmp / "in.xml").write_text(XML_DECK)
        (tmp / "base.e").write_bytes(fx.result.read_bytes())
        return Spec(argv=argv, names=names, sentinels=[tmp / "base.e", tmp / "existing" / "keep.txt", tmp / "afile", tmp / "in.xml"])
    # a run on the GPU path is, in CI, a run under numba-cuda's simulator, which interprets every
    # kernel thread in Python: 60 s is not a hang there on a cold, loaded 2-core machine
    return Case("cli", f"{cmd} {what}", expect, setup, timeout=180.0 if what == "--device GPU" else 60.0)


# ------------------------------------------------------------------------------------------------
# Python API
# ------------------------------------------------------------------------------------------------
def _deck() -> dict:
    d = base()
    d["Solver"]["Final Time"] = 1.0e-6
    return d


BAD_VALUES = [-1, 2.5, NAN, INF, -INF, "3", None, True, 1e20, np.array([1, 2]), [1], {}, 1j, object(), np.float64(NAN), -0.0,
              np.int64(2), 2**70]


def gen_api(rng: random.Random, fx: Fixtures) -> Case:
    import peridyn

    call = rng.choice(("Model", "Model_opts", "step", "run_until", "get", "set", "add_condition", "add_compute", "select",
                       "results", "read", "Study", "grid", "from_points", "node_set", "history"))
    v = rng.choice(BAD_VALUES)
    arg, expect = "", "invalid"
    passthrough: tuple = ()
    desc = f"{call}({_r(v)})"

    def model(tmp, **kw):
        return peridyn.Model(_deck(), output_dir=str(tmp / "out"), **kw)

    if call == "Model":
        v = rng.choice([3, None, [], "missing.yaml", "adir", b"bytes", {"bad": 1}, {"Discretization": NAN}, 1.5, "deck.yaml",
                        {"Peridigm": {}}, {"Materials": {"Steel": {"Density": NAN}}}])
        arg = ""
        desc = f"Model({_r(v)})"
        expect = "valid" if v == "deck.yaml" else "invalid"
        fn = lambda tmp: peridyn.Model(v, output_dir=str(tmp / "out")).close()  # noqa: E731
    elif call == "Model_opts":
        opt = rng.choice(("output_dir", "write_files", "progress", "backend", "device", "directory"))
        v = rng.choice([3, "afile", "afile/x", "", None, "nope", "tpu", NAN, [], True, "/dev/null"])
        arg, desc = ("folder" if opt in ("output_dir", "directory") and isinstance(v, str) else opt), f"Model({opt}={_r(v)})"
        expect = "any"

        def fn(tmp, opt=opt, v=v):
            kw = {"output_dir": str(tmp / "out")}
            kw[opt] = str(tmp / v) if opt in ("output_dir", "directory") and isinstance(v, str) and v and not v.startswith("/") else v
            peridyn.Model(_deck(), **kw).close()
    elif call == "step":
        arg = "n"
        expect = "valid" if isinstance(v, np.int64) else ("any" if v in (1e20, 2**70) and isinstance(v, int) else "invalid")
        from peridyn import RunEnded
        passthrough = (RunEnded,)  # stepping past the end: documented

        def fn(tmp):
            with model(tmp, write_files=False) as m:
                m.step(v)
    elif call == "run_until":
        arg = "until"
        v = rng.choice([NAN, INF, -1.0, "x", [1.0], 1j, -INF, 5e-7, 1e-30, np.array([1e-7]), True, 1e300])
        desc = f"run(until={_r(v)})"
        expect = "valid" if v == 5e-7 and not isinstance(v, bool) else ("any" if v is True or v == 1e300 else "invalid")

        def fn(tmp):
            with model(tmp, write_files=False) as m:
                m.step(2)
                m.run(until=v)
    elif call in ("get", "set"):
        name = rng.choice(["Displacement", "Nope", 3, None, "", "Velocity", "displacement", ("a",)])
        if call == "get":
            arg, desc = "name", f"model[{_r(name)}]"
            expect = "valid" if name in ("Displacement", "Velocity") else ("any" if name == "displacement" else "invalid")

            def fn(tmp):
                with model(tmp, write_files=False) as m:
                    m.step(1)
                    m[name]
        else:
            val = rng.choice([np.zeros((3, 3)), np.full((160, 3), NAN), "x", np.zeros((160, 3), dtype=complex), [[1, 2]], 1.0,
                              np.zeros((160, 3)), np.array([object()] * 3), np.zeros((160, 2)), INF, np.zeros(0)])
            arg = "name" if name not in ("Displacement", "Velocity") else name
            desc = f"model[{_r(name)}] = {_r(val)}"
            valid = name in ("Displacement", "Velocity") and (isinstance(val, float) and np.isfinite(val) or
                                                              isinstance(val, np.ndarray) and val.shape == (160, 3) and val.dtype == float and np.isfinite(val).all())
            expect = "valid" if valid else "invalid"
            if name == "displacement":
                expect = "any"

            def fn(tmp):
                with model(tmp, write_files=False) as m:
                    m[name] = val
                    m.step(1)
    elif call == "add_condition":
        which = rng.choice(("type", "nodes", "value", "coordinate", "name"))
        good = {"type": "Body Force", "nodes": "Left Node Set", "value": lambda t, x: 1.0e3, "coordinate": "x", "name": None}
        bad = {"type": ["Nope", 3, None, ""],
               "nodes": [[-1], [10**9], [0.5], [], np.zeros(5, bool), np.zeros(160, bool), lambda x: 3, lambda x: 1 / 0,
                         {"Sphere": {"Center": [0, 0, 0], "Radius": NAN}}, "Nope Node Set", np.array([[0, 1]]), [True, 2],
                         lambda x: x[:, 0] < 0.003, {"Box": {"Min": [0, 0, 0], "Max": [0.003, 1, 1]}}],
               "value": ["x", NAN, None, lambda t, x: np.zeros(7), lambda t, x: NAN, lambda: 1.0, lambda t, x: "s", lambda t, x: 1 / 0, INF],
               "coordinate": ["w", 3, None, "X", ""],
               "name": [3, "", "Hold", ["x"]]}
        v = rng.choice(bad[which])
        arg = {"type": "type", "nodes": "nodes", "value": "value", "coordinate": "coordinate", "name": "name"}[which]
        desc = f"add_condition({which}={_r(v)})"
        kw = dict(good, **{which: v})
        expect = "invalid"
        if which == "nodes" and (callable(v) and v.__code__.co_consts[-1:] != (0,) and "0.003" in str(v.__code__.co_consts) or isinstance(v, dict) and "Box" in v):
            expect = "valid"
        if which == "coordinate" and v == "X" or which == "name" and v == "Hold":
            expect = "any"
        if which == "value" and getattr(v, "__code__", None) is not None and "ZeroDivisionError" and (1 / 1) and v.__code__.co_names == ():
            pass
        if which in ("value", "nodes") and callable(v):
            passthrough = (ZeroDivisionError,) if "1 / 0" in _src(v) else ()

        def fn(tmp):
            with model(tmp, write_files=False) as m:
                m.add_condition(kw["type"], kw["nodes"], kw["value"], coordinate=kw["coordinate"], name=kw["name"])
                m.step(3)
    elif call == "add_compute":
        which = rng.choice(("name", "fn", "every", "fn_raises"))
        name, f, every = "c", (lambda m: 1.0), 1
        if which == "name":
            name = rng.choice([3, "", None, ["c"]])
            v = name
        elif which == "fn":
            f = rng.choice([3, None, "len", lambda: 1, lambda m: "text", lambda m: {"a": 1}, lambda m: object()])
            v = f
            expect = "any"
        elif which == "every":
            every = v
            expect = "valid" if isinstance(v, np.int64) or (v == 1e20 and isinstance(v, float) and False) else "invalid"
        else:
            f = lambda m: 1 / 0  # noqa: E731
            passthrough, expect, v = (ZeroDivisionError,), "any", "raises"
        arg = {"name": "name", "fn": "fn", "every": "every", "fn_raises": ""}[which]
        desc = f"add_compute({which}={_r(v)})"

        def fn(tmp):
            with model(tmp, write_files=False) as m:
                m.add_compute(name, f, every=every)
                m.step(2)
    elif call == "select":
        reg, inv = random_region(rng, bad=0.5)
        if rng.random() < 0.2:
            reg = rng.choice((3, None, "Box", [], {"Cube": {}}, {}))
            inv = True
        arg, desc, expect = "region", f"select({str(reg)[:80]})", "invalid" if inv else "any"

        def fn(tmp):
            with model(tmp, write_files=False) as m:
                m.select(reg)
    elif call == "results":
        v = rng.choice(["Nope", 3, None, "Output", ""])
        arg, desc = "section", f"results({_r(v)})"
        expect = "valid" if v in ("Output", None) else "invalid"

        def fn(tmp):
            with model(tmp) as m:
                m.run()
                m.results(v) if v is not None else m.results()
    elif call == "read":
        v = rng.choice(["missing.e", "adir", "garbage.e", "zero.e", 3, None, "deck.yaml", "base.e", "trunc.e", b"base.e"])
        arg, desc = ("path" if not isinstance(v, str) else Path(v).name), f"read({_r(v)})"
        expect = "valid" if v == "base.e" else ("any" if v == b"base.e" else "invalid")
        fn = lambda tmp: peridyn.read(str(tmp / v) if isinstance(v, str) else v)  # noqa: E731
    elif call == "node_set":
        v = rng.choice(["Nope", 3, None, "left node set", "Left Node Set", ""])
        arg, desc = "name", f"node_set({_r(v)})"
        expect = "valid" if v == "Left Node Set" else ("any" if v == "left node set" else "invalid")

        def fn(tmp):
            with model(tmp, write_files=False) as m:
                m.node_set(v)
    elif call == "history":
        v = rng.choice(["Nope", 3, None, ""])
        arg, desc = "name", f"history({_r(v)})"

        def fn(tmp):
            with model(tmp, write_files=False) as m:
                m.history(v)
    elif call in ("Study", "grid"):
        which = rng.choice(("parameters", "extract", "processes", "folder", "deck")) if call == "Study" else "axes"
        params = [{"Materials/Steel/Density": 7800.0}]
        extract, processes, folder, deck = None, 1, "study", _deck()
        bad = {"parameters": [[], 3, None, [3], [{"No/Such/Path": 1.0}], [{"Materials/Steel/Density": NAN}], [{"Materials/Steel/Density": {1}}], "x"],
               "extract": [3, "f"], "processes": [0, -1, 2.5, "2", NAN, None], "folder": ["afile", "/dev/null", 3, ""],
               "deck": [3, None, "missing.yaml"], "axes": [[], 3, None, "ab", {1}]}
        v = rng.choice(bad[which])
        arg = {"parameters": "parameters", "extract": "extract", "processes": "processes", "folder": "folder", "deck": "deck",
               "axes": "x"}[which]
        desc = f"{call}({which}={_r(v)})"
        expect = "any" if which in ("folder", "deck") or (which == "processes" and v is None) else "invalid"

        def fn(tmp):
            os.chdir(tmp)
            if call == "grid":
                peridyn.Study.grid(x=v)
                return
            kw = {"parameters": params, "extract": extract, "processes": processes, "folder": folder, "deck": deck, which: v}
            s = peridyn.Study(kw["deck"], kw["parameters"], kw["folder"], extract=kw["extract"])
            s.run(processes=kw["processes"])
    else:  # from_points
        which = rng.choice(("x", "volume", "block_id", "node_sets", "deck"))
        n = 64
        g = np.stack(np.meshgrid(*[np.arange(4) * 1e-3] * 3, indexing="ij"), -1).reshape(-1, 3)
        x, vol, bid, ns = g, 1e-9, 1, None
        d = _deck()
        del d["Discretization"]
        d["Boundary Conditions"] = {}
        bad = {"x": [g[:, :2], g[:, 0], np.full((n, 3), NAN), "x", np.zeros((0, 3)), g.astype(complex), g.tolist(), g[None]],
               "volume": [-1e-9, 0.0, NAN, np.ones(n - 1), "v", np.full(n, INF), np.ones((n, 1))],
               "block_id": [0, 1.5, np.ones(n - 1, int), -1, np.full(n, 2.5), "1", np.full(n, 2)],
               "node_sets": [{"A": [-1]}, {"A": [n]}, {"A": np.zeros(3, bool)}, {"A": [0.5]}, {3: [0]}, [1, 2], {"A": {"Cube": {}}},
                             {"A": {"Box": {"Min": [0, 0, 0], "Max": [NAN, 1, 1]}}}],
               "deck": [{**d, "Discretization": {"Type": "PdQuickGrid"}}, 3, {}, None]}
        v = rng.choice(bad[which])
        arg, desc = (which if which != "block_id" or not isinstance(v, np.ndarray) or v.shape != (n,) or not (v == 2).all() else ""), \
            f"from_points({which}={_r(v)})"
        expect = "any" if which == "block_id" and isinstance(v, np.ndarray) and v.shape == (n,) and (v == 2).all() else "invalid"
        if which == "x" and isinstance(v, list):
            expect = "any"

        def fn(tmp):
            kw = {"x": x, "volume": vol, "block_id": bid, "node_sets": ns, "deck": d, which: v}
            m = peridyn.Model.from_points(kw["x"], kw["volume"], kw["deck"], block_id=kw["block_id"], node_sets=kw["node_sets"],
                                          output_dir=str(tmp / "out"), write_files=False)
            m.close()

    def setup(tmp: Path) -> Spec:
        write_deck(tmp, _deck())
        (tmp / "adir").mkdir()
        (tmp / "afile").write_text("a file")
        (tmp / "garbage.e").write_bytes(b"\x00garbage" * 100)
        (tmp / "zero.e").write_bytes(b"")
        b = fx.result.read_bytes()
        (tmp / "base.e").write_bytes(b)
        (tmp / "trunc.e").write_bytes(b[: len(b) // 2])
        return Spec(fn=fn, arg=arg, passthrough=passthrough)
    return Case("api", desc, expect, setup, mode="api", timeout=60.0)


def _src(f) -> str:
    try:
        import inspect

        return inspect.getsource(f)
    except (OSError, TypeError):
        return ""


def _r(v) -> str:
    if isinstance(v, np.ndarray):
        return f"array{v.shape}:{v.dtype}"
    if callable(v) and getattr(v, "__name__", "") == "<lambda>":
        s = _src(v).strip()
        i = s.find("lambda")
        return s[i:i + 40] if i >= 0 else "lambda"
    return repr(v)[:40]


# ------------------------------------------------------------------------------------------------
# 2 ranks
# ------------------------------------------------------------------------------------------------
def gen_mpi(rng: random.Random, fx: Fixtures) -> Case:
    pick = rng.random()
    inner = gen_restart(rng, fx) if pick < 0.5 else (gen_region(rng, fx) if pick < 0.75 else gen_traction(rng, fx))
    inner.family = "mpi"
    inner.name = f"[{'restart' if pick < 0.5 else 'regions' if pick < 0.75 else 'traction'}] {inner.name}"
    inner.mode = "mpi"
    inner.timeout = 180.0
    return inner
