"""Elastic constants from any two (materials/moduli.py): Peridigm's conversions, and a pair on the
edge of the admissible range refused as bad input, not a ZeroDivisionError."""
import math

import pytest

from peridyn.materials.moduli import bulk_and_shear


E, NU = 9.0 * 160e9 * 80e9 / (3.0 * 160e9 + 80e9), 320.0 / 1120.0  # of K = 160 GPa, G = 80 GPa


@pytest.mark.parametrize("given", [dict(K=160e9, G=80e9), dict(K=160e9, E=E), dict(E=E, G=80e9),
                                   dict(E=E, nu=NU), dict(G=80e9, nu=NU), dict(K=160e9, nu=NU)])
def test_every_pair_gives_the_same_material(given):
    K, G = bulk_and_shear(**given)
    assert math.isclose(K, 160e9, rel_tol=1e-12) and math.isclose(G, 80e9, rel_tol=1e-12)


@pytest.mark.parametrize("given", [dict(K=1.0, E=9.0), dict(E=3.0, G=1.0), dict(G=1.0, nu=0.5), dict(E=1.0, nu=0.5)])
def test_a_pair_on_the_edge_is_a_value_error(given):
    with pytest.raises(ValueError, match="no finite bulk and shear modulus"):
        bulk_and_shear(**given)
