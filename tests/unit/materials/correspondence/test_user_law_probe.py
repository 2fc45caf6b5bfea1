"""A Stress Law module that ends the process, crashes or hangs is refused from a child process."""
from __future__ import annotations

import itertools

import pytest

from peridyn.materials.correspondence import law_check
from peridyn.materials.correspondence.law_check import LawError, load_law

_names = itertools.count()


def module(tmp_path, monkeypatch, source: str) -> str:
    name = f"peridyn_test_probe_law_{next(_names)}"
    (tmp_path / f"{name}.py").write_text(source)
    monkeypatch.syspath_prepend(str(tmp_path))
    return name


@pytest.mark.parametrize("source, words", [
    ("import os\nos._exit(0)\n", "ended the process (exit status 0) on import"),
    ("import os\nos._exit(3)\n", "ended the process (exit status 3)"),
    ("import ctypes\nctypes.string_at(0)\n", "crashed (signal 11, SIGSEGV)"),
    ("while True:\n    pass\n", "did not finish importing and its first call in 2 s"),
])
def test_a_module_that_ends_crashes_or_hangs_is_a_law_error(tmp_path, monkeypatch, source, words):
    monkeypatch.setattr(law_check, "PROBE_SECONDS", 2.0)
    name = module(tmp_path, monkeypatch, source)
    with pytest.raises(LawError) as info:
        load_law(f"{name}:law")
    assert words in str(info.value) and name in str(info.value), str(info.value)


def test_a_law_that_ends_the_process_when_called_is_a_law_error(tmp_path, monkeypatch):
    name = module(tmp_path, monkeypatch, "import os\ndef law(F_old, F_new, state, dt, params):\n    os._exit(0)\n")
    with pytest.raises(LawError, match="ended the process"):
        load_law(f"{name}:law")


def test_a_clean_module_is_probed_once_and_imported(tmp_path, monkeypatch):
    name = module(tmp_path, monkeypatch, "from numba import njit\nimport numpy as np\n@njit\n"
                  "def law(F_old, F_new, state, dt, params):\n    return np.zeros((3, 3)), state.copy()\n")
    assert load_law(f"{name}:law") is not None
    assert f"{name}:law" in law_check._PROBED
