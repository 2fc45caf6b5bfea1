"""The compiled finite-difference tangent of the classic correspondence materials
(``ClassicCorrespondence.tangent``, :mod:`peridyn.materials.correspondence.fd_tangent`) against
the implicit solvers' Python finite-difference path (``tangent`` returning False): the same
matrix bit for bit, and the same Newton iterations of a quasi-static run."""
from __future__ import annotations

import numpy as np
import pytest

from peridyn.materials.correspondence.classic import ClassicCorrespondence
from peridyn.solvers.linalg.tangent import TangentMatrix
from peridyn.testing import build_simulation
from peridyn.engine.session import run_sections

H = 1.0e-3
K, G = 160.0e9, 80.0e9


def tree(steps: int = 2, pull: float = 1.0e-3) -> dict:
    """A bar of two blocks (Elastic Correspondence on the left, Isotropic Hardening
    Correspondence yielding early on the right), pulled along x quasi-statically."""
    def box(block, x0, x1):
        return {"Shape": "Box", "Block": block, "Min": [x0 * H, 0.0, 0.0], "Max": [x1 * H, 3 * H, 3 * H], "Spacing": H}

    shapes = {"Fixed": box("block_1", 0, 1), "Left": box("block_1", 1, 4), "Right": box("block_2", 4, 7), "Pulled": box("block_2", 7, 8)}
    common = {"Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": G, "Hourglass Coefficient": 0.02}
    return {
        "Discretization": {"Type": "Shapes", "Shapes": shapes},
        "Materials": {
            "E": {"Material Model": "Elastic Correspondence", **common},
            "P": {"Material Model": "Isotropic Hardening Correspondence", **common, "Yield Stress": 50.0e6, "Hardening Modulus": 10.0e9},
        },
        "Blocks": {
            "B1": {"Block Names": "block_1", "Material": "E", "Horizon": 2.015 * H},
            "B2": {"Block Names": "block_2", "Material": "P", "Horizon": 2.015 * H},
        },
        "Boundary Conditions": {
            "Fix": {"Type": "Prescribed Displacement", "Node Set": "Fixed", "Coordinate": "x", "Value": "0.0"},
            "Pull": {"Type": "Prescribed Displacement", "Node Set": "Pulled", "Coordinate": "x", "Value": f"{pull * 8 * H!r}*t"},
        },
        "Solver": {"Initial Time": 0.0, "Final Time": 1.0,
                   "QuasiStatic": {"Number of Load Steps": steps, "Relative Tolerance": 1.0e-8, "Maximum Solver Iterations": 20}},
    }


@pytest.fixture
def python_fd(monkeypatch):
    """Force the solver's Python finite-difference path for the classic materials."""
    def use_python_path():
        monkeypatch.setattr(ClassicCorrespondence, "tangent", lambda self, block, target: False)
    return use_python_path


@pytest.fixture
def compiled_calls(monkeypatch):
    """The return values of ``ClassicCorrespondence.tangent`` (True: the compiled path ran)."""
    calls: list[bool] = []
    original = ClassicCorrespondence.tangent

    def spy(self, block, target):
        calls.append(original(self, block, target))
        return calls[-1]
    monkeypatch.setattr(ClassicCorrespondence, "tangent", spy)
    return calls


def _assemble(sim) -> np.ndarray:
    T = TangentMatrix(sim)
    T.assemble()
    return T.data.copy()


def test_the_compiled_tangent_is_the_python_finite_difference_bit_for_bit(tmp_path, compiled_calls, python_fd):
    sim = build_simulation(tree(steps=2, pull=2.0e-3), directory=tmp_path)
    run_sections(sim)  # plastic N state on the right, stress everywhere
    assert sim.fields.n("Equivalent_Plastic_Strain")[sim.blocks[1].start:sim.blocks[1].stop].max() > 0.0
    rng = np.random.default_rng(7)
    s = sim.fields
    n = sim.num_owned
    s["Coordinates"][:n] += 1.0e-3 * H * rng.standard_normal((n, 3))
    s["Velocity"][:n] = 1.0e-2 * rng.standard_normal((n, 3))
    sim.set_time_step(0.5)
    state = {k: s[k].copy() for k in ("Coordinates", "Velocity")}
    del compiled_calls[:]
    compiled = _assemble(sim)
    assert compiled_calls == [True, True]
    for k, a in state.items():  # positions and velocities are restored
        np.testing.assert_array_equal(s[k], a)
    assert np.abs(compiled).max() > 0.0
    python_fd()
    reference = _assemble(sim)
    np.testing.assert_array_equal(compiled, reference)


def test_a_quasi_static_run_takes_the_same_newton_iterations(tmp_path, compiled_calls, python_fd):
    t = tree(steps=2, pull=2.0e-3)
    sim = build_simulation(t, directory=tmp_path)
    run_sections(sim)
    compiled = (sim.clock.nonlinear_iterations, sim.fields["Coordinates"].copy())
    assert compiled_calls and all(compiled_calls)
    python_fd()
    sim = build_simulation(t, directory=tmp_path)
    run_sections(sim)
    assert compiled[0] > 0
    assert sim.clock.nonlinear_iterations == compiled[0]
    np.testing.assert_array_equal(sim.fields["Coordinates"], compiled[1])
