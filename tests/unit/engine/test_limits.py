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


def test_a_horizon_of_hundreds_of_spacings_is_refused_unless_no_limits(tmp_path, capsys, monkeypatch):
    """Issue #33: 400 spacings is no peridynamic model (a unit slip, as a rule); with the
    override every point is a neighbor of every other."""
    monkeypatch.delenv(limits.ENV, raising=False)
    deck = write(tmp_path, horizon="100.0")
    assert main(["check", str(deck)]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err
    assert "horizon 100 in block 'block_1' is 400 point spacings (spacing 0.25)" in err and "all 64 points bonded" in err
    monkeypatch.setenv(limits.ENV, "1")
    assert main(["check", str(deck)]) == ExitCode.OK
    assert "64 points, 4032 bonds" in capsys.readouterr().out


@pytest.mark.parametrize("material, coupling", [
    ({"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1.0e9, "Shear Modulus": 1.0e9}, "family"),
    ({"Material Model": "Elastic Bond Based", "Density": 1000.0, "Bulk Modulus": 1.0e9}, "pairs"),
])
def test_the_tangent_entries_are_counted_from_the_neighbor_lists(material, coupling):
    """The estimate of the implicit tangent's size against the tangent the solvers allocate: within
    2 % on a lattice (every point of the sample counted exactly; the rest scaled)."""
    from peridyn.solvers.linalg.tangent import TangentMatrix
    from peridyn.testing import build_simulation, cube_deck

    sim = build_simulation(cube_deck(material, n=9, spacing=1.0, horizon_factor=2.015))
    assert sim.blocks[0].material.tangent_coupling == coupling
    nl = sim.bonds
    estimate = limits.estimate_tangent_entries(nl.offsets, nl.neighbors, sim.num_owned, coupling)
    actual = TangentMatrix(sim, "full").nnz
    assert estimate == pytest.approx(actual, rel=0.02)
    other = limits.estimate_tangent_entries(nl.offsets, nl.neighbors, sim.num_owned, "pairs" if coupling == "family" else "family")
    assert abs(other / actual - 1.0) > 0.5  # the coupling matters


def test_an_implicit_estimate_counts_newton_iterations_of_the_tangent():
    explicit = limits.estimate_seconds(10, 1.0e4, 1.0e6)
    implicit = limits.estimate_seconds(10, 1.0e4, 1.0e6, tangent_entries=5.0e7)
    fd = limits.estimate_seconds(10, 1.0e4, 1.0e6, tangent_entries=5.0e7, finite_differences=True)
    assert explicit == pytest.approx(10 * 1.01e6 / limits.BOND_RATE)
    per_iteration = limits.ITERATION_OVERHEAD_SECONDS + 5.0e7 * limits.TANGENT_ENTRY_SECONDS["analytic"] + 3.0 * 1.01e6 / limits.BOND_RATE
    assert implicit == pytest.approx(limits.SECTION_OVERHEAD_SECONDS + 10 * limits.ITERATIONS_PER_STEP * per_iteration)
    assert fd > 3.0 * implicit > 30.0 * explicit


def test_check_estimates_a_quasistatic_run_from_its_tangent(tmp_path, capsys):
    text = write(tmp_path, n=8, horizon=0.4).read_text().replace("  Verlet:\n    Fixed dt: 1e-07", "  QuasiStatic:\n    Number of Load Steps: 20")
    deck = tmp_path / "qs.yaml"
    deck.write_text(text)
    assert main(["check", str(deck)]) == ExitCode.OK
    out = capsys.readouterr().out
    seconds = float(out.split("20 steps, estimated ")[1].split()[0])
    assert seconds > 20 * limits.ITERATIONS_PER_STEP * limits.ITERATION_OVERHEAD_SECONDS
