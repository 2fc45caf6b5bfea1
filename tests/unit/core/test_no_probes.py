"""No code probes a model, a deck section or the simulation for a member its contract does not
declare: ``getattr(x, "name", default)`` and ``hasattr(x, "name")`` are left only for members of
other libraries' objects (exceptions, YAML nodes, netCDF variables, numba dispatchers, argparse
namespaces, the platform), listed here by name. A probe of one of ours fails this test: declare
the member on its contract (with a default) and read it.

Lookups by a computed name (``getattr(self, name)`` over a model's declared fields) are not
probes and are not listed.
"""
from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[3] / "peridyn"

#: members of objects peridyn does not define, by where they come from
FOREIGN = {
    # OSError, YAML and pydantic errors, our InputErrors' causes
    "strerror", "problem_mark", "context_mark", "problem", "context", "errors", "key", "fix", "message",
    # PyYAML events and nodes
    "anchor", "tag", "explicit_tag",
    # netCDF4 variables
    "elem_type",
    # numba dispatchers and numba-cuda arrays; numpy
    "py_func", "targetoptions", "copy_to_host", "row_stack", "nbytes", "item", "tolist",
    # scipy matrices and pyamg levels
    "toarray", "R",
    # the platform, streams, logging records, tqdm, typing
    "O_CLOEXEC", "sched_getaffinity", "getuid", "isatty", "fields", "tqdm", "_instances", "__name__", "__args__",
    # argparse namespaces (each subcommand defines its own options)
    "debug", "verbose", "log_json", "no_limits", "deck",
    # mappings handed in by a user (duck-typed, like dict)
    "items", "keys",
}


def probes() -> list[tuple[str, int, str]]:
    """(file, line, name) of every getattr/hasattr with a literal member name."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = str(path.relative_to(PACKAGE.parent))
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("getattr", "hasattr")
                    and len(node.args) >= 2 and isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str)):
                found.append((rel, node.lineno, node.args[1].value))
    return found


def test_no_probe_of_an_undeclared_member():
    bad = [f"{f}:{line}: {name!r}" for f, line, name in probes() if name not in FOREIGN]
    assert not bad, ("getattr/hasattr of a member no contract declares (declare it on the contract, "
                     "or list another library's member in FOREIGN):\n" + "\n".join(bad))


def test_the_scan_sees_probes():
    """The scan is not vacuous: it reads the package's probes, and the kind this test forbids
    (a model's parameter probed by name) is not in the list."""
    assert len(probes()) > 30
    assert not {"planar_problem", "finite_difference_probe_length", "probe_length", "node_set", "verlet", "Params",
                "output_label", "gate", "mirror", "ignored_keys", "device"} & FOREIGN
