"""Simulation: fusion of neighboring blocks that share their models."""
import numpy as np
import pytest

from peridyn.testing import build_simulation
from peridyn.testing.tensile import tensile_bar

LPS = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 80.0e9}
BOND = {"Material Model": "Elastic Bond Based", "Density": 7800.0, "Bulk Modulus": 160.0e9}


def bar(tmp_path, material, **changes):
    b = tensile_bar(material, tmp_path, ratio=3.015, horizon=1.0e-3, section=2.0)
    tree = b.tree
    tree.update(changes)
    return build_simulation(tree, directory=tmp_path)


def forces(sim, fused: bool) -> np.ndarray:
    if not fused:
        for blk in sim.blocks:
            blk.fused = False
    return sim.evaluate_forces().copy()


@pytest.mark.parametrize("material", [LPS, BOND], ids=["lps", "bond-based"])
def test_blocks_of_one_material_are_fused_as_one_group(tmp_path, material):
    sim = bar(tmp_path, material)
    lead = sim.blocks[0]
    assert lead.fused and [b.name for b in lead.group] == ["block_1", "block_2", "block_3"]
    assert lead.fused_view.start == 0 and lead.fused_view.stop == sim.num_owned
    assert not sim.generic_blocks
    rng = np.random.default_rng(1)
    sim.fields["Coordinates"][:] += 2.0e-5 * rng.standard_normal(sim.fields["Coordinates"].shape)
    fused = forces(sim, True)
    generic = forces(sim, False)  # every block's bonds, both ends gathered separately
    np.testing.assert_allclose(fused, generic, rtol=0, atol=1.0e-12 * np.abs(generic).max())


def test_blocks_with_different_parameters_are_not_grouped(tmp_path):
    soft = dict(LPS, **{"Bulk Modulus": 80.0e9})
    b = tensile_bar(LPS, tmp_path, ratio=3.015, horizon=1.0e-3, section=2.0)
    tree = b.tree
    tree["Materials"]["Soft"] = soft
    tree["Blocks"] = {
        "Grips": {"Block Names": "block_1 block_3", "Material": "Bar Material", "Horizon": 1.0e-3},
        "Gauge": {"Block Names": "block_2", "Material": "Soft", "Horizon": 1.0e-3},
    }
    sim = build_simulation(tree, directory=tmp_path)
    assert all(len(blk.group) == 1 and not blk.fused for blk in sim.blocks)  # bonds cross materials
    assert len(sim.generic_blocks) == 3
