"""The simulation is a typed model: what code outside the engine reads of it, or assigns, is
declared on ``peridyn.core.interfaces.Simulation``, and the engine provides every declared name.

Read through the syntax of the package: every ``sim.NAME``, ``self.sim.NAME`` or
``simulation.NAME`` outside ``engine/simulation.py`` (and the run session and the command line,
which drive the engine itself) must be declared; assignments only to ``Simulation.writable``; no ``getattr``,
``hasattr`` or ``setattr`` probing a simulation, no ``sim.__dict__``.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from peridyn.core.interfaces import Simulation
from peridyn.testing.harness import build_simulation, cube_deck

PACKAGE = Path(__file__).resolve().parents[3] / "peridyn"
OWN = {PACKAGE / "engine" / "simulation.py", PACKAGE / "engine" / "forces.py", PACKAGE / "engine" / "session.py", PACKAGE / "cli.py"}


def declared() -> set[str]:
    names = {n for n, a in Simulation.__annotations__.items() if not str(a).startswith("ClassVar")}
    names |= {n for n, v in vars(Simulation).items() if callable(v) and not n.startswith("_")}
    return names


def is_simulation(node: ast.AST) -> bool:
    if isinstance(node, ast.Name):
        return node.id in ("sim", "simulation")
    return isinstance(node, ast.Attribute) and node.attr in ("sim", "simulation") and isinstance(node.value, ast.Name) and node.value.id == "self"


def uses() -> list[tuple[str, int, str, str]]:
    """(file, line, 'read' | 'write' | 'probe', name) of every use of a simulation's attributes."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path in OWN:
            continue
        rel = str(path.relative_to(PACKAGE.parent))
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Attribute) and is_simulation(node.value):
                found.append((rel, node.lineno, "write" if isinstance(node.ctx, (ast.Store, ast.Del)) else "read", node.attr))
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("getattr", "hasattr", "setattr"):
                if node.args and is_simulation(node.args[0]):
                    found.append((rel, node.lineno, "probe", ast.unparse(node)))
    return found


def test_code_outside_the_engine_reads_only_declared_attributes():
    known = declared() | {"__class__"}
    bad = [f"{f}:{line}: {name}" for f, line, kind, name in uses() if kind == "read" and name not in known]
    assert not bad, "undeclared attributes of the simulation read (declare them on core.interfaces.Simulation):\n" + "\n".join(bad)


def test_code_outside_the_engine_assigns_only_writable_attributes():
    bad = [f"{f}:{line}: {name}" for f, line, kind, name in uses() if kind == "write" and name not in Simulation.writable]
    assert not bad, "attributes of the simulation assigned outside the engine (return values instead):\n" + "\n".join(bad)


def test_no_probing_of_the_simulation():
    bad = [f"{f}:{line}: {name}" for f, line, kind, name in uses() if kind == "probe" or name == "__dict__"]
    assert not bad, "getattr/hasattr/setattr on a simulation (declare the attribute instead):\n" + "\n".join(bad)


def test_the_check_sees_what_it_is_meant_to(tmp_path):
    """The scan is not vacuous: it finds reads, and flags an undeclared one."""
    found = uses()
    assert sum(kind == "read" for *_, kind, _ in found) > 200
    bad = tmp_path / "bad.py"
    bad.write_text("def f(sim):\n    return sim.undeclared_thing, getattr(sim, 'x', None)\n")
    tree = ast.parse(bad.read_text())
    names = {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute) and is_simulation(n.value)}
    assert names == {"undeclared_thing"} and "undeclared_thing" not in declared()


@pytest.mark.parametrize("damage", [None, {"Damage Model": "Critical Stretch", "Critical Stretch": 0.01}])
def test_the_engine_provides_every_declared_name(damage):
    sim = build_simulation(cube_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 0.5}, n=4, damage=damage))
    missing = sorted(name for name in declared() if not hasattr(sim, name))
    assert not missing, f"declared on the Simulation contract but absent from the engine's: {missing}"
    assert Simulation.writable <= declared()


def clock_stores(tree: ast.AST) -> list[ast.Attribute]:
    """Every assignment to ``sim.clock.NAME`` (or ``self.sim.clock.NAME``) in ``tree``."""
    return [node for node in ast.walk(tree)
            if isinstance(node, ast.Attribute) and isinstance(node.ctx, (ast.Store, ast.Del))
            and isinstance(node.value, ast.Attribute) and node.value.attr == "clock" and is_simulation(node.value.value)]


def clock_writes() -> list[tuple[str, int, str]]:
    """(file, line, name) of every assignment to the clock in the package."""
    return [(str(path.relative_to(PACKAGE.parent)), node.lineno, node.attr)
            for path in sorted(PACKAGE.rglob("*.py")) for node in clock_stores(ast.parse(path.read_text()))]


def test_the_solver_state_is_handed_on_not_held_by_the_simulation():
    """The solver state (time, acceleration, increments, iterations, shared tangents) is what a
    section is handed and returns (``Solver.run(sim, state, run) -> SolverState``); the simulation
    shows only its clock, read-only, and holds no acceleration or increments of its own."""
    import inspect

    from peridyn.core.interfaces import Solver
    from peridyn.core.state import Clock, SolverState

    assert "state" not in declared()
    assert Simulation.__annotations__["clock"] in (Clock, "Clock")
    clock_members = {n for n in vars(Clock) if not n.startswith("_")}
    assert clock_members and clock_members <= set(SolverState.__dataclass_fields__)
    assert not {"acceleration", "delta_u", "delta_p", "solver_cache"} & clock_members
    assert list(inspect.signature(Solver.run).parameters) == ["self", "sim", "state", "run"]
    sim = build_simulation(cube_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 0.5}, n=4))
    assert not [k for k, v in vars(sim).items() if isinstance(v, SolverState) and k != "clock"]
    writes = clock_writes()
    assert not writes, "the clock written (write the state the solver was handed):\n" + "\n".join(f"{f}:{line}: {n}" for f, line, n in writes)


def test_the_run_services_are_handed_to_solvers_not_held_by_the_simulation(tmp_path):
    """The output files, checkpoints and progress are the run's (``RunServices``, handed to
    ``Solver.run``): the contract declares none of them, and a simulation set up for a deck
    with an output and a Restart section holds no output file, writer or checkpoints, nor does
    what its outputs compute (``sim.outputs``)."""
    from peridyn.core.services import RunServices
    from peridyn.engine.output import OutputFiles, OutputWriter
    from peridyn.engine.restart import Checkpoints
    from peridyn.engine.session import RunSession

    assert not {"restart", "checkpoints", "progress", "write_output", "writers", "files"} & declared()
    assert set(RunServices.__annotations__) == {"files", "checkpoints", "progress"}
    tree = cube_deck({"Material Model": "Elastic", "Density": 1.0, "Bulk Modulus": 1.0, "Shear Modulus": 0.5}, n=3)
    tree["Output"] = {"Output Filename": "cube", "Output Frequency": 1, "Output Variables": {"Displacement": True}}
    tree["Restart"] = {"Restart Frequency": 1}
    (tmp_path / "cube.yaml").write_text(__import__("yaml").safe_dump(tree))
    session = RunSession(tmp_path / "cube.yaml", output_dir=tmp_path, progress=False)
    sim = session.open()
    try:
        assert session.services is not None and isinstance(session.services.checkpoints, Checkpoints)
        assert len(session.services.files.writers) == 1
        held = (OutputFiles, OutputWriter, Checkpoints)
        for owner in (sim, sim.outputs):
            assert not [k for k, v in vars(owner).items() if isinstance(v, held)
                        or (isinstance(v, list) and any(isinstance(x, held) for x in v))], type(owner).__name__
    finally:
        session.close(complete=False)


def test_the_clock_check_sees_a_write():
    hits = clock_stores(ast.parse("def f(sim):\n    sim.clock.time = 1.0\n    return sim.clock.time\n"))
    assert [(n.lineno, n.attr) for n in hits] == [(2, "time")]


def test_the_contract_types_every_member():
    """No member of the Simulation contract is typed ``Any`` (a dict of run statistics may hold anything)."""
    loose = [n for n, a in Simulation.__annotations__.items() if str(a) in ("Any", "Any | None") or str(a).startswith("list[Any")]
    assert not loose, f"members of the Simulation contract typed Any (declare a protocol in core/services.py): {loose}"
