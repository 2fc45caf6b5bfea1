"""Small models for the implicit-solver tests (helpers exposed through the ``h`` fixture)."""
from __future__ import annotations

import types

import numpy as np
import pytest

from peridyn.testing import build_simulation, cube_deck

K, MU = 160.0e9, 80.0e9
LPS = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": K, "Shear Modulus": MU}
BOND_BASED = {"Material Model": "Elastic Bond Based", "Density": 7800.0, "Bulk Modulus": K}


def box_deck(material, shape=(4, 4, 4), horizon=2.015, **kw):
    """A PdQuickGrid box of unit spacing (shape = points per direction), one block."""
    return cube_deck(material, shape=shape, horizon_factor=horizon, **kw)


def two_block_text_deck(tmp_path, material, shape=(6, 4, 4), horizons=(1.515, 2.015)):
    """A Text File box of unit spacing split at x = 3 into block_1 and block_2 with different
    horizons: bonds from block_2 points of length 2 into block_1 are one-sided."""
    g = np.stack(np.meshgrid(*[np.arange(n) + 0.5 for n in shape], indexing="ij"), axis=-1).reshape(-1, 3)
    block = np.where(g[:, 0] < shape[0] / 2, 1, 2)
    lines = [f"{x:.1f} {y:.1f} {z:.1f} {b} 1.0" for (x, y, z), b in zip(g, block)]
    (tmp_path / "two_blocks.txt").write_text("# x y z block volume\n" + "\n".join(lines) + "\n")
    return {
        "Discretization": {"Type": "Text File", "Input Mesh File": "two_blocks.txt"},
        "Materials": {"M": dict(material)},
        "Blocks": {
            "Left": {"Block Names": "block_1", "Material": "M", "Horizon": horizons[0]},
            "Right": {"Block Names": "block_2", "Material": "M", "Horizon": horizons[1]},
        },
    }


def perturb(sim, scale=1.0e-3, seed=0):
    """Move the points randomly (a general, non-affine configuration)."""
    rng = np.random.default_rng(seed)
    y = sim.fields["Coordinates"]
    y += scale * rng.standard_normal(y.shape)
    sim.fields["Displacement"][:] = y - sim.fields["Model_Coordinates"]


def force_jacobian_fd(sim, tangent, h=1.0e-7):
    """Central differences of the whole assembled internal force (f V, engine path, damage as
    it stands) with respect to every coordinate: the reference for analytic tangents. Rows and
    columns in the tangent's (global-id) order."""
    import numba

    n = sim.num_owned
    y = sim.fields["Coordinates"]
    V = sim.fields["Volume"][:n, None]
    Kfd = np.zeros((3 * n, 3 * n))
    before = numba.get_num_threads()
    numba.set_num_threads(1)  # hundreds of tiny evaluations: parallel launches would dominate
    try:
        for q in range(n):
            col = 3 * tangent.row_of_local[q]
            for c in range(3):
                orig = y[q, c]
                y[q, c] = orig + h
                fp = tangent.to_rows(sim.evaluate_forces()[:n] * V)
                y[q, c] = orig - h
                fm = tangent.to_rows(sim.evaluate_forces()[:n] * V)
                y[q, c] = orig
                Kfd[:, col + c] = (fp - fm) / (2.0 * h)
        sim.evaluate_forces()
    finally:
        numba.set_num_threads(before)
    return Kfd


def build(tree, **kw):
    return build_simulation(tree, **kw)


@pytest.fixture
def h():
    """The helpers above, for test modules (conftest modules are not importable)."""
    return types.SimpleNamespace(
        K=K, MU=MU, LPS=LPS, BOND_BASED=BOND_BASED, box_deck=box_deck, two_block_text_deck=two_block_text_deck,
        perturb=perturb, force_jacobian_fd=force_jacobian_fd, build=build,
    )
