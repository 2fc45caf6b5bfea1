"""NLMech's materials on the GPU (``peridyn run --device gpu``) against the same deck on the CPU,
as the built-in materials in tests/unit/solvers/explicit/test_verlet_gpu.py, stretched far past the
inflection stretch by the initial velocity: ``Regularized Nonlinear Bond`` reversible (with its
Softened_Bond_Fraction output) and with irreversible bond fracture (its two-step Bond_Fracture
field), and ``Nonlocal Double Well State`` (its Dilatation, a precompute field)."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba.cuda")
pytest.importorskip("netCDF4")

from ..solvers.explicit.test_verlet_gpu import RTOL, frames, lattice_deck, quantity_scale, run  # noqa: E402

RNP = {"Material Model": "Regularized Nonlinear Bond", "Density": 7800.0, "Bulk Modulus": 130.0e9, "Gc": 5.0}
DOUBLE_WELL = {"Material Model": "Nonlocal Double Well State", "Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 70.0e9, "Gc": 5.0}
VARIABLES = ("Displacement", "Velocity", "Stored_Elastic_Energy_Density")
CASES = {
    "rnp": ({**RNP}, VARIABLES + ("Softened_Bond_Fraction",)),
    "rnp_irreversible": ({**RNP, "Irreversible Bond Fracture": True, "Check Sc Factor": 1.5}, VARIABLES + ("Softened_Bond_Fraction",)),
    "double_well": (DOUBLE_WELL, VARIABLES + ("Dilatation",)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_gpu_run_gives_the_cpu_run_fields(tmp_path, case):
    material, variables = CASES[case]
    deck = lattice_deck(material, variables=variables)
    cpu = run(tmp_path / "cpu", deck)
    assert cpu.returncode == 0, cpu.stderr
    gpu = run(tmp_path / "gpu", deck, "--device", "gpu")
    assert gpu.returncode == 0, gpu.stderr
    assert "Verlet on the GPU" in gpu.stderr
    a, b = frames(tmp_path / "cpu" / "run.e"), frames(tmp_path / "gpu" / "run.e")
    assert a.keys() == b.keys() and len(a["time"]) >= 4
    if "Softened_Bond_Fraction@eb1" in a:
        soft = a["Softened_Bond_Fraction@eb1"]
        assert 0.0 < soft[-1].max() and soft[-1].min() < 1.0, "some bonds, not all, past their inflection stretch"
    for k in a:
        np.testing.assert_allclose(b[k], a[k], rtol=RTOL, atol=RTOL * quantity_scale(a, k), err_msg=k)
