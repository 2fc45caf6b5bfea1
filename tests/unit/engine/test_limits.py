"""Size estimates before allocation and the limits that refuse absurd runs (exit 2)."""
import math
import textwrap

import numpy as np
import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.engine import limits

DECK = textwrap.dedent(
    """
    Discretization:
      Type: PdQuickGrid
      TensorProduct3DMeshGenerator:
        Type: PdQuickGrid
        X Origin: 0.0
        Y Origin: 0.0
        Z Origin: 0.0
        X Length: 1.0
        Y Length: 1.0
        Z Length: 1.0
        Number Points X: {n}
        Number Points Y: {n}
        Number Points Z: {n}
    Materials:
      M:
        Material Model: Elastic
        Density: 1000.0
        Bulk Modulus: 1.0e9
        Shear Modulus: 1.0e9
    Blocks:
      B:
        Block Names: block_1
        Material: M
        Horizon: {horizon}
    Solver:
      Final Time: {final}
      Verlet:
        Fixed dt: {dt}
    Output:
      Output Filename: out
      Output Frequency: 1
      Output Variables:
        Displacement: true
    """
)


def write(tmp_path, **kw):
    values = dict(n=4, horizon=0.8, final=1.0e-6, dt=1.0e-7) | kw
    path = tmp_path / "deck.yaml"
    path.write_text(DECK.format(**values))
    return path


def test_bond_estimate_is_close_on_a_lattice():
    n, h = 20, 1.0
    volume = np.full(n**3, h**3)
    horizon = np.full(n**3, 3.015 * h)
    estimate = limits.estimate_bonds(volume, horizon)
    interior = 4.0 / 3.0 * math.pi * 3.015**3  # ~115 neighbors for a full family
    assert estimate == pytest.approx(n**3 * interior)


def test_bond_estimate_survives_overflow():
    assert limits.estimate_bonds(np.ones(10), np.full(10, 1e308)) == 90.0
    assert limits.estimate_bonds(np.full(10, 1e-320), np.ones(10)) == 90.0


def test_a_mesh_too_large_for_memory_is_refused_before_it_is_made(tmp_path, capsys):
    deck = write(tmp_path, n=1000)
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err
    assert "1e+09 points" in err and "memory available" in err and "PERIDYN_NO_LIMITS" in err
    assert len(err.strip().splitlines()) == 1


def test_absurd_step_counts_are_refused(tmp_path, capsys):
    deck = write(tmp_path, dt=1.0e-300)
    (tmp_path / "out.e").write_bytes(b"earlier result")
    assert main(["run", str(deck), "--output-dir", str(tmp_path)]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err
    assert "1e+294 steps" in err and "limits" in err
    assert (tmp_path / "out.e").read_bytes() == b"earlier result"


def test_the_override_turns_the_refusal_into_a_warning(monkeypatch):
    monkeypatch.setenv(limits.ENV, "1")
    seconds = limits.check_steps(10**12, 10.0, 100.0, file=None, path=(), section="S")
    assert seconds > limits.MAX_SECONDS or 10**12 > limits.MAX_STEPS


def test_check_states_steps_and_time(tmp_path, capsys):
    deck = write(tmp_path)
    assert main(["check", str(deck)]) == ExitCode.OK
    out = capsys.readouterr().out
    assert "10 steps, estimated" in out


def test_a_tiny_horizon_neither_hangs_nor_crashes(tmp_path, capsys):
    deck = write(tmp_path, horizon="5.0e-324")
    assert main(["run", str(deck), "--output-dir", str(tmp_path)]) == ExitCode.INPUT_ERROR
    assert "its 4th power (micromodulus, stable time step) underflows" in capsys.readouterr().err


def test_a_huge_horizon_is_refused(tmp_path, capsys):
    """Issue #19: a horizon whose 4th power overflows (the micromodulus) is bad input."""
    deck = write(tmp_path, horizon="1.0e308")
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    assert "Horizon: horizon 1e+308" in capsys.readouterr().err


def test_a_horizon_of_many_model_sizes_makes_every_point_a_neighbor(tmp_path, capsys):
    deck = write(tmp_path, horizon="100.0")
    assert main(["check", str(deck)]) == ExitCode.OK
    assert "64 points, 4032 bonds" in capsys.readouterr().out
