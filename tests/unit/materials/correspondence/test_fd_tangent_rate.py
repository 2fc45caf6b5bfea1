"""The compiled finite-difference tangent of the hypoelastic and bond-associated correspondence
materials (:mod:`peridyn.materials.correspondence.fd_tangent_rate`) against the implicit solvers'
Python finite-difference path (``tangent`` returning False): the same matrix bit for bit, the
probed state restored, and the same Newton iterations of a quasi-static run."""
from __future__ import annotations

import numpy as np
import pytest

from peridyn.materials.correspondence.bond_associated import BondAssociatedCorrespondence
from peridyn.materials.correspondence.hypoelastic import HypoelasticCorrespondence
from peridyn.solvers.linalg.tangent import TangentMatrix
from peridyn.testing import build_simulation
from peridyn.engine.session import run_sections

H = 1.0e-3
K, G = 160.0e9, 80.0e9
COMMON = {"Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": G}
HYPO = {
    "E": {"Material Model": "Elastic Hypoelastic Correspondence", **COMMON, "Actual Horizon": 2.015 * H},
    "P": {"Material Model": "Isotropic Hardening Hypoelastic Correspondence", **COMMON, "Actual Horizon": 2.015 * H,
          "Yield Stress": 50.0e6, "Hardening Characteristic Strain": 1.0e-3, "Hardening Exponent": 0.2},
}
BOND_ASSOCIATED = {
    "E": {"Material Model": "Elastic Bond Associated Correspondence", **COMMON},
    "P": {"Material Model": "Elastic Plastic Bond Associated Correspondence", **COMMON, "Yield Stress": 50.0e6},
}
#: (materials, family class, pull): the pull yields the plastic block and still converges in two load steps
FAMILIES = {"hypoelastic": (HYPO, HypoelasticCorrespondence, 5.0e-4), "bond-associated": (BOND_ASSOCIATED, BondAssociatedCorrespondence, 2.0e-3)}


def tree(materials: dict, steps: int = 2, pull: float = 2.0e-3) -> dict:
    """A bar of two blocks (elastic left, plastic yielding early right), pulled along x."""
    def box(block, x0, x1):
        return {"Shape": "Box", "Block": block, "Min": [x0 * H, 0.0, 0.0], "Max": [x1 * H, 3 * H, 3 * H], "Spacing": H}

    shapes = {"Fixed": box("block_1", 0, 1), "Left": box("block_1", 1, 4), "Right": box("block_2", 4, 7), "Pulled": box("block_2", 7, 8)}
    return {
        "Discretization": {"Type": "Shapes", "Shapes": shapes},
        "Materials": materials,
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


def _spy(monkeypatch, cls) -> list[bool]:
    calls: list[bool] = []
    original = cls.tangent

    def spy(self, block, target):
        calls.append(original(self, block, target))
        return calls[-1]
    monkeypatch.setattr(cls, "tangent", spy)
    return calls


def _assemble(sim) -> np.ndarray:
    T = TangentMatrix(sim)
    T.assemble()
    return T.data.copy()


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_the_compiled_tangent_is_the_python_finite_difference_bit_for_bit(tmp_path, monkeypatch, family):
    materials, cls, pull = FAMILIES[family]
    calls = _spy(monkeypatch, cls)
    sim = build_simulation(tree(materials, pull=pull), directory=tmp_path)
    run_sections(sim)  # plastic N state on the right, stress everywhere
    assert sim.fields.n("Equivalent_Plastic_Strain").max() > 0.0
    rng = np.random.default_rng(11)
    s = sim.fields
    n = sim.num_owned
    s["Coordinates"][:n] += 1.0e-3 * H * rng.standard_normal((n, 3))
    s["Velocity"][:n] = 1.0e-2 * rng.standard_normal((n, 3))
    sim.set_time_step(0.5)
    state = {k: s[k].copy() for k in ("Coordinates", "Velocity")}
    del calls[:]
    compiled = _assemble(sim)
    assert calls == [True, True]
    for k, a in state.items():  # positions and velocities are restored
        np.testing.assert_array_equal(s[k], a)
    assert np.abs(compiled).max() > 0.0
    monkeypatch.setattr(cls, "tangent", lambda self, block, target: False)
    reference = _assemble(sim)
    np.testing.assert_array_equal(compiled, reference)


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_a_quasi_static_run_takes_the_same_newton_iterations(tmp_path, monkeypatch, family):
    materials, cls, pull = FAMILIES[family]
    calls = _spy(monkeypatch, cls)
    t = tree(materials, pull=pull)
    sim = build_simulation(t, directory=tmp_path)
    run_sections(sim)
    compiled = (sim.clock.nonlinear_iterations, sim.fields["Coordinates"].copy())
    assert calls and all(calls)
    monkeypatch.setattr(cls, "tangent", lambda self, block, target: False)
    sim = build_simulation(t, directory=tmp_path)
    run_sections(sim)
    assert compiled[0] > 0
    assert sim.clock.nonlinear_iterations == compiled[0]
    np.testing.assert_array_equal(sim.fields["Coordinates"], compiled[1])
