"""The package's layout (issue 10, docs/architecture.md): ``peridyn.core`` is the contract and
imports nothing else of peridyn; imports between packages point one way; no two modules import
each other, directly or around a longer circle.

The graph is read from the source with :mod:`ast`: every ``import`` and ``from ... import``
anywhere in a module (top level, inside functions, under ``if TYPE_CHECKING``) is an edge.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

import peridyn

PACKAGE = Path(peridyn.__file__).parent

#: the one-way order of the packages: a package may import only packages listed after it
#: (top-level modules such as cli.py count as packages of their own)
LAYERS = [
    ["__main__"],
    ["cli", "api"],  # the command and the Python API: two front doors, neither imports the other
    ["verify"],
    ["testing"],
    ["engine"],
    ["solvers"],
    ["gpu"],
    ["materials", "damage", "contact", "computes"],
    ["kernels"],
    ["io"],
    ["geometry"],
    ["parallel"],
    ["deck"],
    ["plugins"],
    ["errors"],  # the deprecated alias of core.errors
    ["core"],
]


def module_name(path: Path, root: Path = PACKAGE) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def import_graph(root: Path = PACKAGE) -> dict[str, list[str]]:
    """module -> the peridyn modules it imports, by dotted name."""
    modules = {module_name(f, root): f for f in root.rglob("*.py")}
    graph: dict[str, list[tuple[str, bool]]] = {}
    for mod, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        is_package = path.name == "__init__.py"
        edges: list[str] = []
        for node in ast.walk(tree):
            targets: list[str] = []
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = mod.split(".")
                    if not is_package:
                        base = base[:-1]
                    base = base[: len(base) - (node.level - 1)]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                # "from peridyn.x import y" where y is a module imports peridyn.x.y
                for alias in node.names:
                    sub = f"{target}.{alias.name}"
                    targets.append(sub if sub in modules else target)
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            for target in targets:
                if target.split(".")[0] == root.name and target != mod:
                    edges.append(target)
        graph[mod] = edges
    return graph


def package_of(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """A cycle in a directed graph as a list of nodes, or None."""
    WHITE, GREY, BLACK = 0, 1, 2
    colour = {n: WHITE for n in edges}
    stack: list[str] = []

    def visit(n: str) -> list[str] | None:
        colour[n] = GREY
        stack.append(n)
        for m in sorted(edges.get(n, ())):
            if colour.get(m, WHITE) == GREY:
                return stack[stack.index(m):] + [m]
            if colour.get(m, WHITE) == WHITE:
                found = visit(m)
                if found:
                    return found
        stack.pop()
        colour[n] = BLACK
        return None

    for n in sorted(edges):
        if colour[n] == WHITE:
            found = visit(n)
            if found:
                return found
    return None


def layer_violations(graph: dict[str, list[str]]) -> list[str]:
    rank = {pkg: i for i, layer in enumerate(LAYERS) for pkg in layer}
    bad = []
    for mod, edges in graph.items():
        src = package_of(mod)
        for target in edges:
            dst = package_of(target)
            if dst == src or dst == "":
                continue
            if src not in rank or dst not in rank:
                bad.append(f"{mod} -> {target}: package not placed in LAYERS")
            elif rank[dst] <= rank[src]:
                bad.append(f"{mod} -> {target}: {src} may not import {dst}")
    return bad


def test_core_imports_nothing_else_of_peridyn() -> None:
    graph = import_graph()
    outside = [
        f"{mod} -> {target}"
        for mod, edges in graph.items()
        if package_of(mod) == "core"
        for target in edges
        if package_of(target) != "core"
    ]
    assert outside == []


def test_packages_import_one_way() -> None:
    assert layer_violations(import_graph()) == []


def test_no_two_packages_import_each_other() -> None:
    graph = import_graph()
    edges: dict[str, set[str]] = {}
    for mod, targets in graph.items():
        src = package_of(mod)
        edges.setdefault(src, set())
        for target in targets:
            dst = package_of(target)
            if dst != src:
                edges[src].add(dst)
    assert find_cycle(edges) is None


def test_no_module_cycles() -> None:
    graph = import_graph()
    edges = {mod: set(targets) for mod, targets in graph.items()}
    assert find_cycle(edges) is None


def test_solvers_import_no_material() -> None:
    """Solvers get what they need of a material through the Material contract (its declared
    attributes) and the shared kernels of ``core``, never from a material module (issue 20)."""
    graph = import_graph()
    reach = [
        f"{mod} -> {target}"
        for mod, edges in graph.items()
        if package_of(mod) == "solvers"
        for target in edges
        if package_of(target) == "materials"
    ]
    assert reach == []


def test_linalg_holds_machinery_not_solvers() -> None:
    """``peridyn.solvers.linalg`` (tangents, Krylov, ILU, AMG) imports no solver module, and no
    solver plugin lives there: the built-in solvers are registered from ``peridyn.solvers``."""
    graph = import_graph()
    up = [
        f"{mod} -> {target}"
        for mod, edges in graph.items()
        if mod.startswith("peridyn.solvers.linalg")
        for target in edges
        if package_of(target) == "solvers" and not target.startswith("peridyn.solvers.linalg")
    ]
    assert up == []
    from peridyn.plugins.builtins import peridyn_solvers

    paths = [path for _, path in peridyn_solvers()]
    assert paths and all(p.startswith("peridyn.solvers.") and ".linalg." not in p for p in paths)
    for name in ("tangent", "coupled_tangent", "linear", "aztecoo", "ilu", "amg"):
        assert f"peridyn.solvers.linalg.{name}" in graph
        assert f"peridyn.solvers.{name}" not in graph


# -- the checks fail when they should --------------------------------------------------------------
def _write(root: Path, files: dict[str, str]) -> Path:
    pkg = root / "peridyn"
    for name, text in files.items():
        path = pkg / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    for folder in [pkg, *[p for p in pkg.rglob("*") if p.is_dir()]]:
        (folder / "__init__.py").touch()
    return pkg


def test_checks_catch_core_reaching_out_and_circles(tmp_path: Path) -> None:
    pkg = _write(
        tmp_path / "a",
        {"core/interfaces.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..engine.simulation import Simulation\n"},
    )
    graph = import_graph(pkg)
    core_out = [t for t in graph["peridyn.core.interfaces"] if package_of(t) != "core"]
    assert core_out == ["peridyn.engine.simulation"]  # a type-only import counts too

    pkg = _write(
        tmp_path / "c",
        {
            "engine/simulation.py": "from ..core import interfaces\nfrom . import output\n",
            "engine/output.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .simulation import Simulation\n",
        },
    )
    graph = import_graph(pkg)
    module_edges = {m: set(ts) for m, ts in graph.items()}
    assert set(find_cycle(module_edges) or ()) == {"peridyn.engine.simulation", "peridyn.engine.output"}

    pkg = _write(
        tmp_path / "b",
        {
            "deck/model.py": "from ..geometry import influence\n",
            "geometry/influence.py": "from peridyn.deck.model import Deck\n",
        },
    )
    graph = import_graph(pkg)
    assert "peridyn.deck.model -> peridyn.geometry.influence: deck may not import geometry" in layer_violations(graph)


@pytest.mark.parametrize("name", ["peridyn.core.interfaces", "peridyn.testing", "peridyn.plugins"])
def test_plugin_api_stays(name: str) -> None:
    import importlib

    module = importlib.import_module(name)
    if name == "peridyn.plugins":
        assert module.hookimpl is importlib.import_module("peridyn.plugins.hookspecs").hookimpl
    if name == "peridyn.core.interfaces":
        for cls in ("Material", "DamageModel", "ContactModel", "Compute", "Solver", "BlockView"):
            assert hasattr(module, cls)


def test_old_errors_module_is_a_deprecated_alias() -> None:
    import importlib
    import sys

    sys.modules.pop("peridyn.errors", None)
    with pytest.warns(DeprecationWarning, match="peridyn.core.errors"):
        old = importlib.import_module("peridyn.errors")
    from peridyn.core import errors

    assert old.InputError is errors.InputError and old.ExitCode is errors.ExitCode
