"""An ordinary state-based material in full: the linear peridynamic solid (LPS), influence 1.

m_i = sum_j |xi|^2 V_j,  theta_i = 3/m_i sum_j (1-d) |xi| e V_j,  e = |eta| - |xi|,
t_ij = (1-d) ((3K - 5mu) theta_i |xi| + 15 mu e) / m_i,  W_i = K theta_i^2 / 2 + 15 mu/(2 m_i) sum_j (1-d) e_d^2 V_j
with e_d = e - theta_i |xi| / 3. Units: K, mu in Pa; lengths in m; t in N/m^6; W in J/m^3.
"""
import numpy as np
from pydantic import Field

from peridyn.core.fields import FieldSpec, Relation, Temporal
from peridyn.core.interfaces import BlockView, Material
from peridyn.core.params import ModelParams
from peridyn.core.traversal import BondMap, PointSum
from peridyn.kernels import compiled

NONE = np.zeros(0)  # no Bond_Damage field: no damage model on the block


class Params(ModelParams):
    density: float = Field(alias="Density", gt=0, description="mass density (kg/m^3)")
    bulk_modulus: float = Field(alias="Bulk Modulus", gt=0, description="K (Pa)")
    shear_modulus: float = Field(alias="Shear Modulus", gt=0, description="mu (Pa)")


def keep(d, b):
    return 1.0 - d[b] if d.shape[0] > 0 else 1.0


def m_term(i, j, b, ex, ey, ez, L, z, p, args):  # run on reference positions: L = |xi|
    return L * L * args[0][j]


def theta_term(i, j, b, ex, ey, ez, L, z, p, args):
    V, m, d = args
    return 3.0 * keep(d, b) * z * (L - z) * V[j]


def theta_finish(i, acc, p, args):
    m = args[1][i]
    return acc / m if m > 0.0 else 0.0  # a point without bonds


def force_state(i, j, b, ex, ey, ez, L, z, p, args):
    m, theta, d, K, mu = args
    return keep(d, b) * ((3.0 * K - 5.0 * mu) * theta[i] * z + 15.0 * mu * (L - z)) / m[i]  # m > 0: i has a bond


def energy_term(i, j, b, ex, ey, ez, L, z, p, args):
    V, m, theta, d, K, mu = args
    e_d = (L - z) - theta[i] * z / 3.0
    return keep(d, b) * e_d * e_d * V[j]


def energy_finish(i, acc, p, args):
    V, m, theta, d, K, mu = args
    return 0.5 * K * theta[i] ** 2 + (7.5 * mu / m[i] * acc if m[i] > 0.0 else 0.0)


WEIGHTED_VOLUME = PointSum(m_term)
DILATATION = PointSum(theta_term, finish=theta_finish)
FORCE_STATE = BondMap(force_state)
ENERGY = PointSum(energy_term, finish=energy_finish)


class DocLPS(Material):
    name = "Doc LPS"
    Params = Params
    precompute_fields = ("Dilatation",)

    @property
    def density(self) -> float:
        return self.params.density

    @property
    def bulk_modulus(self) -> float:
        return self.params.bulk_modulus

    def fields(self) -> list[FieldSpec]:
        return [FieldSpec("Weighted_Volume", Relation.ELEMENT, 1, Temporal.CONSTANT, halo=True),
                FieldSpec("Dilatation", Relation.ELEMENT, 1, Temporal.CONSTANT, halo=True)]

    def _run(self, block: BlockView, law, y: str, args: tuple, out: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, s["Bond_Length"], s[y], args, out)

    def _d(self, block: BlockView) -> np.ndarray:
        return block.fields["Bond_Damage"] if "Bond_Damage" in block.fields else NONE

    def initialize(self, block: BlockView) -> None:
        s = block.fields
        self._run(block, WEIGHTED_VOLUME, "Model_Coordinates", (s["Volume"],), s["Weighted_Volume"])

    def precompute(self, block: BlockView) -> None:
        s = block.fields
        self._run(block, DILATATION, "Coordinates", (s["Volume"], s["Weighted_Volume"], self._d(block)), s["Dilatation"])

    def force_state(self, block: BlockView, t: np.ndarray) -> None:
        s, p = block.fields, self.params
        self._run(block, FORCE_STATE, "Coordinates", (s["Weighted_Volume"], s["Dilatation"], self._d(block), p.bulk_modulus, p.shear_modulus), t)

    def stored_energy_density(self, block: BlockView, out: np.ndarray) -> None:
        s, p = block.fields, self.params
        args = (s["Volume"], s["Weighted_Volume"], s["Dilatation"], self._d(block), p.bulk_modulus, p.shear_modulus)
        self._run(block, ENERGY, "Coordinates", args, out)
