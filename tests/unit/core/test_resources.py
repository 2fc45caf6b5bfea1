"""The machine's resources as a run reads them (peridyn.core.resources)."""
import os

import pytest

from peridyn.core import resources


def test_usable_cores_is_the_affinity_not_the_machine(monkeypatch):
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 3, 5}, raising=False)
    monkeypatch.setattr(os, "cpu_count", lambda: 64)
    assert resources.usable_cores() == 3


def test_usable_cores_without_affinity_counts_the_machine_and_never_zero(monkeypatch):
    monkeypatch.delattr(os, "sched_getaffinity", raising=False)
    monkeypatch.setattr(os, "cpu_count", lambda: 12)
    assert resources.usable_cores() == 12
    monkeypatch.setattr(os, "cpu_count", lambda: None)
    assert resources.usable_cores() == 1


@pytest.mark.parametrize("value, off", [("", False), ("0", False), ("no", False), ("1", True), ("yes", True)])
def test_limits_off_reads_the_environment(monkeypatch, value, off):
    monkeypatch.setenv(resources.NO_LIMITS_ENV, value)
    assert resources.limits_off() is off
