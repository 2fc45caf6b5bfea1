"""A non-ordinary (vector force state) material in full: correspondence with a St. Venant-Kirchhoff
solid, influence 1, no stabilization (a teaching example: it has zero-energy modes).

K_i = sum_j xi (x) xi V_j,  N_i = sum_j (1-d) eta (x) xi V_j,  F_i = N_i K_i^-1,  E = (F^T F - I)/2,
S = lam tr(E) I + 2 mu E,  P = F S,  T_ij = (1-d) P_i K_i^-1 xi (N/m^6),  W_i = lam/2 tr(E)^2 + mu E:E (J/m^3).
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


def outer(i, j, b, ex, ey, ez, L, z, p, args):
    """(1-d) (eta (x) xi) V_j as 9 numbers (row-major), xi from x = args[0]; V, d = args[1], args[-1]."""
    x, V, d = args[0], args[1], args[-1]
    a, c, e = x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2]
    v = (1.0 - d[b] if d.shape[0] > 0 else 1.0) * V[j]
    return (ex * a * v, ex * c * v, ex * e * v, ey * a * v, ey * c * v, ey * e * v, ez * a * v, ez * c * v, ez * e * v)


def inverse(M):
    a, b, c, d, e, f, g, h, k = M
    det = a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g)
    s = 1.0 / det if det != 0.0 else 0.0  # a point without a 3D family gets no stress
    return (s * (e * k - f * h), s * (c * h - b * k), s * (b * f - c * e), s * (f * g - d * k), s * (a * k - c * g),
            s * (c * d - a * f), s * (d * h - e * g), s * (b * g - a * h), s * (a * e - b * d))


def matmul(A, B):  # 3x3 row-major tuples
    return (A[0] * B[0] + A[1] * B[3] + A[2] * B[6], A[0] * B[1] + A[1] * B[4] + A[2] * B[7], A[0] * B[2] + A[1] * B[5] + A[2] * B[8],
            A[3] * B[0] + A[4] * B[3] + A[5] * B[6], A[3] * B[1] + A[4] * B[4] + A[5] * B[7], A[3] * B[2] + A[4] * B[5] + A[5] * B[8],
            A[6] * B[0] + A[7] * B[3] + A[8] * B[6], A[6] * B[1] + A[7] * B[4] + A[8] * B[7], A[6] * B[2] + A[7] * B[5] + A[8] * B[8])


def shape_inverse(i, acc, p, args):  # run on reference positions (y = x): acc = K_i
    return inverse(acc)


def piola_k(i, acc, p, args):
    """acc = N_i; returns A_i = P_i K_i^-1 and writes W_i (args[5])."""
    x, V, Kinv, lam, mu, W, d = args
    F = matmul(acc, (Kinv[i, 0], Kinv[i, 1], Kinv[i, 2], Kinv[i, 3], Kinv[i, 4], Kinv[i, 5], Kinv[i, 6], Kinv[i, 7], Kinv[i, 8]))
    C = matmul((F[0], F[3], F[6], F[1], F[4], F[7], F[2], F[5], F[8]), F)
    E = (0.5 * (C[0] - 1.0), 0.5 * C[1], 0.5 * C[2], 0.5 * C[3], 0.5 * (C[4] - 1.0), 0.5 * C[5], 0.5 * C[6], 0.5 * C[7], 0.5 * (C[8] - 1.0))
    tr = E[0] + E[4] + E[8]
    S = (2.0 * mu * E[0] + lam * tr, 2.0 * mu * E[1], 2.0 * mu * E[2], 2.0 * mu * E[3], 2.0 * mu * E[4] + lam * tr,
         2.0 * mu * E[5], 2.0 * mu * E[6], 2.0 * mu * E[7], 2.0 * mu * E[8] + lam * tr)
    W[i] = 0.5 * lam * tr * tr + mu * (E[0] ** 2 + E[1] ** 2 + E[2] ** 2 + E[3] ** 2 + E[4] ** 2 + E[5] ** 2 + E[6] ** 2 + E[7] ** 2 + E[8] ** 2)
    return matmul(matmul(F, S), (Kinv[i, 0], Kinv[i, 1], Kinv[i, 2], Kinv[i, 3], Kinv[i, 4], Kinv[i, 5], Kinv[i, 6], Kinv[i, 7], Kinv[i, 8]))


def force_state(i, j, b, ex, ey, ez, L, z, p, args):
    x, A, d = args
    a, c, e = x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2]
    k = 1.0 - d[b] if d.shape[0] > 0 else 1.0
    return (k * (A[i, 0] * a + A[i, 1] * c + A[i, 2] * e), k * (A[i, 3] * a + A[i, 4] * c + A[i, 5] * e),
            k * (A[i, 6] * a + A[i, 7] * c + A[i, 8] * e))


SHAPE = PointSum(outer, finish=shape_inverse, width=9)
STRESS = PointSum(outer, finish=piola_k, width=9)
FORCE_STATE = BondMap(force_state, width=3)


class DocCorrespondence(Material):
    name = "Doc Correspondence"
    Params = Params
    force_state_kind = "vector"

    @property
    def density(self) -> float:
        return self.params.density

    @property
    def bulk_modulus(self) -> float:
        return self.params.bulk_modulus

    def fields(self) -> list[FieldSpec]:
        return [FieldSpec("Shape_Tensor_Inverse", Relation.ELEMENT, 9, Temporal.CONSTANT),
                FieldSpec("Piola_K", Relation.ELEMENT, 9, Temporal.CONSTANT)]

    def _run(self, block: BlockView, law, y: str, args: tuple, out: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, s["Bond_Length"], s[y], args, out)

    def initialize(self, block: BlockView) -> None:
        s = block.fields
        self._run(block, SHAPE, "Model_Coordinates", (s["Model_Coordinates"], s["Volume"], NONE), s["Shape_Tensor_Inverse"])

    def _stress(self, block: BlockView, W: np.ndarray) -> None:
        s, p = block.fields, self.params
        lam = p.bulk_modulus - 2.0 * p.shear_modulus / 3.0
        d = s["Bond_Damage"] if "Bond_Damage" in s else NONE  # broken bonds leave the family of F
        args = (s["Model_Coordinates"], s["Volume"], s["Shape_Tensor_Inverse"], lam, p.shear_modulus, W, d)
        self._run(block, STRESS, "Coordinates", args, s["Piola_K"])

    def stored_energy_density(self, block: BlockView, out: np.ndarray) -> None:
        self._stress(block, out)

    def force_state(self, block: BlockView, T: np.ndarray) -> None:
        s = block.fields
        self._stress(block, np.empty(s.num_points))
        d = s["Bond_Damage"] if "Bond_Damage" in s else NONE
        self._run(block, FORCE_STATE, "Coordinates", (s["Model_Coordinates"], s["Piola_K"], d), T)
