"""A user's Stress Law that cannot work is one input error at Materials > NAME > Stress Law, found
at set-up: a module that fails on import (any exception, SyntaxError, sys.exit with any code),
a name that is not a numba function, a law numba cannot compile, one that raises, returns the
wrong thing or a non-finite stress at the reference state. Never does the user's module end the
process."""
from __future__ import annotations

import itertools
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings, strategies as st

from peridyn.core.errors import InputError
from peridyn.deck.model import parse_deck
from peridyn.deck.source import DeckSource
from peridyn.testing import cube_deck

_names = itertools.count()
HEADER = "import numpy as np\nfrom numba import njit, jit, vectorize\n\n\n"


def deck(law: str, parameters=(80.0e9, 50.0e9)) -> dict:
    material = {"Material Model": "Stress Law Correspondence", "Density": 7800.0, "Shear Modulus": 80.0e9, "Bulk Modulus": 1.0e11,
                "Hourglass Coefficient": 0.0, "Stress Law": law, "Law Parameters": list(parameters)}
    tree = cube_deck(material, n=3, spacing=1.0e-3)
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0e-8, "Verlet": {"Fixed dt": 1.0e-8}}
    return tree


def module(tmp_path, monkeypatch, source: str) -> str:
    """A uniquely named module holding ``source`` on sys.path; its name."""
    name = f"peridyn_test_law_{next(_names)}"
    (tmp_path / f"{name}.py").write_text(source)
    monkeypatch.syspath_prepend(str(tmp_path))
    return name


def problems(tree: dict, tmp_path) -> list[InputError]:
    with pytest.raises(InputError) as info:
        parse_deck(DeckSource(tree, tmp_path / "deck.yaml", "yaml", {}))
    found = list(getattr(info.value, "errors", None) or [info.value])
    return [e for e in found if isinstance(e, InputError)]


def law_problem(tree: dict, tmp_path) -> InputError:
    found = problems(tree, tmp_path)
    assert len(found) == 1, [e.one_line() for e in found]
    err = found[0]
    assert err.path == ("Materials", "M", "Stress Law"), err.one_line()
    assert err.fix, err.one_line()
    assert "\n" not in err.one_line()
    return err


IMPORT_FAILURES = {
    "exit0": ("import sys\nsys.exit(0)\n", "SystemExit"),
    "exit1": ("import sys\nsys.exit(1)\n", "SystemExit"),
    "exit text": ("raise SystemExit('bye')\n", "SystemExit"),
    "syntax": ("def law(:\n", "SyntaxError"),
    "runtime": ("raise RuntimeError('boom')\n", "RuntimeError: boom"),
    "import of a missing module": ("import peridyn_no_such_dependency\n", "peridyn_no_such_dependency"),
    "base exception": ("class Odd(BaseException):\n    pass\nraise Odd()\n", "Odd"),
}


@pytest.mark.parametrize("case", sorted(IMPORT_FAILURES))
def test_a_module_that_fails_on_import_is_an_input_error(case, tmp_path, monkeypatch):
    source, words = IMPORT_FAILURES[case]
    name = module(tmp_path, monkeypatch, source)
    err = law_problem(deck(f"{name}:law"), tmp_path)
    assert name in err.message and words in err.message and "import" in err.message


LAWS = {
    "a float": ("NOT_A_FUNCTION = 3.5\n", "NOT_A_FUNCTION", "is a float, not a numba-compiled function"),
    "a class": ("class Law:\n    pass\n", "Law", "is a class"),
    "missing": ("X = 1\n", "law", "has no 'law'"),
    "plain python": ("def law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3)), state.copy()\n", "law", "plain Python function"),
    "object mode": ("@jit(forceobj=True)\ndef law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3)), state.copy()\n", "law", "object mode"),
    "ufunc": ("@vectorize(['float64(float64)'])\ndef law(x):\n    return x\n", "law", "not a numba-compiled function"),
    "untypable": ("@njit\ndef law(F_old, F_new, state, dt, params):\n    return F_new.no_such_attribute, state\n", "law", "cannot be compiled by numba"),
    "wrong arity": ("@njit\ndef law(F):\n    return F, F\n", "law", "calls it with 5 arguments"),
    "raises": ("@njit\ndef law(F_old, F_new, state, dt, params):\n    raise ValueError('bad law')\n", "law", "raised at the reference state"),
    "float": ("@njit\ndef law(F_old, F_new, state, dt, params):\n    return 1.0\n", "law", "returned a float"),
    "stress only": ("@njit\ndef law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3))\n", "law", "not the pair"),
    "triple": ("@njit\ndef law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3)), state.copy(), 1.0\n", "law", "a tuple of 3"),
    "swapped": ("@njit\ndef law(F_old, F_new, state, dt, params):\n    return state.copy(), np.zeros((3, 3))\n", "law", "shape (9,)"),
    "int stress": ("@njit\ndef law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3), dtype=np.int64), state.copy()\n", "law", "dtype int64"),
    "2-D state": ("@njit\ndef law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3)), np.zeros((3, 3))\n", "law", "not a 1-D array"),
    "nan": ("@njit\ndef law(F_old, F_new, state, dt, params):\n    return np.full((3, 3), np.nan), state.copy()\n", "law", "non-finite stress at the reference state"),
    "divides by dt": ("@njit\ndef law(F_old, F_new, state, dt, params):\n    return (F_new - F_old) / dt, state.copy()\n", "law", "non-finite stress"),
    "nan state": ("@njit\ndef law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3)), state / 0.0\n", "law", "non-finite state"),
    "fails when strained": ("@njit\ndef law(F_old, F_new, state, dt, params):\n    if F_new[0, 0] != 1.0:\n"
                            "        raise ValueError('strained')\n    return np.zeros((3, 3)), state.copy()\n", "law", "raised at a small strain"),
}


@pytest.mark.parametrize("case", sorted(LAWS))
def test_a_law_that_cannot_work_is_an_input_error_at_its_deck_path(case, tmp_path, monkeypatch):
    source, function, words = LAWS[case]
    name = module(tmp_path, monkeypatch, HEADER + source)
    err = law_problem(deck(f"{name}:{function}"), tmp_path)
    assert words in err.message and name in err.message, err.one_line()


@pytest.mark.parametrize("spec, words", [("no_colon", "not module:function"), (":law", "not module:function"), ("m:", "not module:function"),
                                          (".relative:law", "relative"), ("peridyn_no_such_module:law", "cannot be imported"),
                                          ("math:sqrt", "built-in function"), ("math:pi", "is a float")])
def test_a_law_name_that_names_no_law_is_an_input_error(spec, words, tmp_path):
    assert words in law_problem(deck(spec), tmp_path).message


def test_a_working_law_passes(tmp_path):
    tree = deck("peridyn.materials.correspondence.laws:neo_hookean")
    assert parse_deck(DeckSource(tree, tmp_path / "deck.yaml", "yaml", {})).materials["M"].model == "Stress Law Correspondence"


SHAPED = HEADER + textwrap.dedent('''
    @njit
    def law(F_old, F_new, state, dt, params):
        """Returns what params say: a (rows, cols) stress of 1 / params[3] and a state of params[2]."""
        return np.ones((int(params[0]), int(params[1]))) / params[3], np.zeros(int(params[2]))
''')


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(rows=st.integers(0, 4), cols=st.integers(0, 4), state=st.integers(0, 12), divisor=st.sampled_from([0.0, 1.0, -2.5]))
def test_the_returned_shapes_are_checked_whatever_they_are(rows, cols, state, divisor, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("shaped")
    (tmp / "peridyn_test_shaped_law.py").write_text(SHAPED)
    sys.path.insert(0, str(tmp))
    try:
        tree = deck("peridyn_test_shaped_law:law", (rows, cols, state, divisor))
        ok = (rows, cols) == (3, 3) and state <= 9 and divisor != 0.0
        if ok:
            parse_deck(DeckSource(tree, tmp / "deck.yaml", "yaml", {}))
        else:
            err = law_problem(tree, tmp)
            expected = "stress" if (rows, cols) != (3, 3) else "state" if state > 9 else "non-finite stress"
            assert expected in err.message, err.one_line()
    finally:
        sys.path.remove(str(tmp))


@pytest.mark.parametrize("source", ["import sys\nsys.exit(0)\n", "import sys\nsys.exit(1)\n", "import os\nraise SystemExit(7)\n"])
def test_the_command_exits_2_and_runs_nothing_when_the_law_module_exits(source, tmp_path):
    (tmp_path / "peridyn_test_exiting_law.py").write_text(source)
    tree = deck("peridyn_test_exiting_law:law")
    tree["Output"] = {"Output Filename": "out", "Output Frequency": 1, "Output Variables": {"Displacement": True}}
    (tmp_path / "deck.yaml").write_text(yaml.safe_dump(tree))
    env = {**__import__("os").environ, "PYTHONPATH": str(tmp_path), "PERIDYN_NO_PROGRESS": "1"}
    for command in ("run", "check"):
        proc = subprocess.run([sys.executable, "-m", "peridyn", command, "deck.yaml"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
        assert proc.returncode == 2, (command, proc.stdout, proc.stderr)
        errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error")]
        assert len(errors) == 1 and "Materials > M > Stress Law" in errors[0] and "peridyn_test_exiting_law" in errors[0], proc.stderr
        assert "SystemExit" in errors[0] and "Traceback" not in proc.stderr
        assert not (tmp_path / "out.e").exists()
