"""Deformation gradient F = N K^-1 from the family (PERIDIGM_SEMANTICS.md §8.4): the shape
tensor K = sum_j omega V_j xi (x) xi and N = sum_j omega V_j eta (x) xi over all bonds (bond
damage ignored), with Peridigm's 3x3 inverse (K^-1 = 0 where det K = 0)."""
from __future__ import annotations

import logging

import numpy as np

from ..core.fields import FieldSpec, Relation
from ..core.influence import TABLE, omega
from ..core.interfaces import Compute
from ..core.traversal import PointSum


log = logging.getLogger("peridyn.computes")


# Loop law (peridyn.core.traversal), run on reference positions: the bond context's
# (ex, ey, ez) = xi = x_j - x_i and L = |xi| (L). args (y (n, 3) current positions L, V (n,) L^3,
# horizon (n,) L, omega_kind, omega_table (nb,) or empty, F (n, 9), Kinv (n, 9) L^-5, singular
# (n,) int8), F and Kinv row-major, written at [i].
def shape_tensors_point(i, args):
    """(K, N): point i's shape tensor sum_j omega V_j xi (x) xi (L^5) and
    sum_j omega V_j eta (x) xi (L^5), row-major (9,), summed into by its bonds."""
    return np.zeros(9), np.zeros(9)


def shape_tensors_term(i, j, b, ex, ey, ez, L, z, p, args):
    """Adds the bond's omega V_j xi (x) xi to K and omega V_j eta (x) xi to N (p = (K, N));
    contributes nothing to the law's own sum."""
    y, volume, horizon, omega_kind, omega_table, F, Kinv, singular = args
    return _add_bond(i, j, b, ex, ey, ez, L, p, y, volume, horizon, omega_kind, omega_table)


def intact_shape_tensors_term(i, j, b, ex, ey, ez, L, z, p, args):
    """``shape_tensors_term`` over the bonds whose damage (args' last entry, (num_bonds,); empty:
    every bond) is below 1: the deformation gradient that fits what holds a family together."""
    y, volume, horizon, omega_kind, omega_table, F, Kinv, singular, damage = args
    if damage.shape[0] > 0 and damage[b] >= 1:
        return 0.0
    return _add_bond(i, j, b, ex, ey, ez, L, p, y, volume, horizon, omega_kind, omega_table)


def _add_bond(i, j, b, ex, ey, ez, L, p, y, volume, horizon, omega_kind, omega_table):
    K, N = p
    e0 = y[j, 0] - y[i, 0]
    e1 = y[j, 1] - y[i, 1]
    e2 = y[j, 2] - y[i, 2]
    w = (1.0 * omega(omega_kind, L, horizon[i], omega_table, b)) * volume[j]
    xi = (ex, ey, ez)
    eta = (e0, e1, e2)
    for a in range(3):
        for c in range(3):
            K[3 * a + c] += (w * xi[a]) * xi[c]
            N[3 * a + c] += (w * eta[a]) * xi[c]
    return 0.0


def deformation_gradient_finish(i, acc, p, args):
    """K^-1 (Peridigm's 3x3 inverse; 0 and singular[i] = 1 where det K = 0) and F = N K^-1,
    written to Kinv[i] and F[i]; returns det K (L^15)."""
    y, volume, horizon, omega_kind, omega_table, F, Kinv, singular = args
    return _invert_and_fit(i, p, F, Kinv, singular)


def intact_deformation_gradient_finish(i, acc, p, args):
    """``deformation_gradient_finish`` for ``intact_shape_tensors_term``'s args."""
    y, volume, horizon, omega_kind, omega_table, F, Kinv, singular, damage = args
    return _invert_and_fit(i, p, F, Kinv, singular)


def _invert_and_fit(i, p, F, Kinv, singular):
    K, N = p
    m0 = K[4] * K[8] - K[5] * K[7]
    m1 = K[3] * K[8] - K[5] * K[6]
    m2 = K[3] * K[7] - K[4] * K[6]
    m3 = K[1] * K[8] - K[2] * K[7]
    m4 = K[0] * K[8] - K[6] * K[2]
    m5 = K[0] * K[7] - K[1] * K[6]
    m6 = K[1] * K[5] - K[2] * K[4]
    m7 = K[0] * K[5] - K[2] * K[3]
    m8 = K[0] * K[4] - K[1] * K[3]
    det = (K[0] * m0 - K[1] * m1) + K[2] * m2
    Ki = np.zeros(9)
    if det == 0.0:
        singular[i] = 1
    else:
        singular[i] = 0
        Ki[0] = m0 / det
        Ki[1] = (-1.0 * m3) / det
        Ki[2] = m6 / det
        Ki[3] = (-1.0 * m1) / det
        Ki[4] = m4 / det
        Ki[5] = (-1.0 * m7) / det
        Ki[6] = m2 / det
        Ki[7] = (-1.0 * m5) / det
        Ki[8] = m8 / det
    for a in range(3):
        for c in range(3):
            F[i, 3 * a + c] = (N[3 * a] * Ki[c] + N[3 * a + 1] * Ki[3 + c]) + N[3 * a + 2] * Ki[6 + c]
    for k in range(9):
        Kinv[i, k] = Ki[k]
    return det


DEFORMATION_GRADIENT = PointSum(shape_tensors_term, point=shape_tensors_point, finish=deformation_gradient_finish, allocates=True)
#: the same over intact bonds only; args as DEFORMATION_GRADIENT's with Bond_Damage (num_bonds,) last
INTACT_DEFORMATION_GRADIENT = PointSum(intact_shape_tensors_term, point=shape_tensors_point, finish=intact_deformation_gradient_finish,
                                       allocates=True)


class DeformationGradient(Compute):
    name = "Deformation_Gradient"

    def outputs(self, sim):
        return [FieldSpec("Deformation_Gradient", Relation.ELEMENT, 9)]

    def initialize(self, sim):
        nl = sim.bonds
        self.table = np.zeros(0)
        if sim.influence.kind == TABLE:
            owner = np.repeat(np.arange(nl.num_points), nl.counts())
            xs = sim.fields["Model_Coordinates"]
            d = xs[nl.neighbors] - xs[owner]
            zeta = np.sqrt((d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2])
            self.table = sim.influence.evaluate(zeta, sim.horizon_local[owner])
        self._warned = False

    def _run(self, sim):
        n = sim.num_owned
        F = np.zeros((sim.num_local, 9))
        Kinv = np.zeros((sim.num_local, 9))
        singular = np.zeros(sim.num_local, dtype=np.int8)
        s = sim.fields
        kernel = sim.backend.kernel(DEFORMATION_GRADIENT)
        args = (s["Coordinates"], s["Volume"], sim.horizon_local, sim.influence.kind, self.table, F, Kinv, singular)
        kernel(0, n, sim.bonds.offsets, sim.bonds.neighbors, s["Bond_Length"], s["Model_Coordinates"], args, np.zeros(sim.num_local))
        if singular[:n].any() and not self._warned:
            log.warning("shape tensor is singular at %d point(s) (too few neighbors); their deformation gradient is set to 0", int(singular[:n].sum()))
            self._warned = True
        return F, Kinv

    def compute(self, sim):
        F, _ = self._run(sim)
        sim.fields["Deformation_Gradient"][:] = F


class ShapeTensorInverse(DeformationGradient):
    name = "Shape_Tensor_Inverse"

    def outputs(self, sim):
        return [FieldSpec("Shape_Tensor_Inverse", Relation.ELEMENT, 9)]

    def compute(self, sim):
        _, Kinv = self._run(sim)
        sim.fields["Shape_Tensor_Inverse"][:] = Kinv
