"""``Linear LPS Partial Volume``: the linearised (small-displacement) peridynamic solid, with
optional partial volumes (PERIDIGM_MODELS.md §5.1; Peridigm's ``LinearLPSPVMaterial``,
``elastic_pv.cxx``), and ``Elastic Partial Volume`` (§5.2) without them.

Per bond i->j with reference bond xi = x_j - x_i, displacement difference du = u_j - u_i and
neighbour weight W_j (the bond's ``Neighbor_Volume`` with partial volumes, else V_j):

    m_i     = sum_j (omega zeta^2) W_j                   (or the deck's analytic value)
    theta_i = (3 / m_i) sum_j ((omega (1 - d)) (xi . du)) W_j      (only where i has bonds)
    T1_i    = (((9K - 15 mu) omega) theta_i) / (3 m_i),   T2_i = ((15 mu) omega) / (m_i |xi|^2)
    M_a     = ((xi_a xi_0) du_0 + (xi_a xi_1) du_1) + (xi_a xi_2) du_2
    T_i<xi> = (1 - d) (T1_i xi + T2_i M)      (a vector force state along the *reference* bond)

and f_i = sum_j (T_i<xi_ij> - T_j<xi_ji>) W_j. With partial volumes Peridigm weights the reaction
of bond j->i on i by that bond's ``Self_Volume``: the part of the bond owner's cell (j) inside
the other end's (i's) horizon, |cell_j ∩ B(x_i, delta_i)|, which is i's ``Neighbor_Volume`` of
bond i->j. So peridyn weights both terms with i's own ``Neighbor_Volume`` (one bond field, no
reverse lookup). The small-strain model is invariant under translations and infinitesimal
rotations only (a finite rotation strains it).

Differences from Peridigm: implicit solvers build this material's tangent by peridyn's finite
differences, which call ``precompute`` at every probe (Peridigm's freeze theta, so its tangent
lacks d theta / d y); ``Use Improved Quadrature`` is not available (an external library in
Peridigm too); with partial volumes the block must be computed by the fused kernel (a block
whose bonds stay inside it, symmetric families).

The stored energy density W_i = K theta_i^2 / 2 + (15 mu / (2 m_i)) sum_j (1-d) omega
(e - theta_i zeta / 3)^2 W_j with e = (xi . du) / zeta is the linearised LPS energy (Peridigm's
class defines none).
"""
from __future__ import annotations

import numpy as np
from pydantic import Field, model_validator

from ..core.errors import InputError
from ..core.fields import FieldSpec, Relation, Temporal
from ..core.influence import ONE, omega
from ..core.interfaces import SMALL_STRAIN, BlockView, ElasticModuli, Material
from ..core.params import UsedWhen
from ..core.traversal import BondMap, PointSum
from ..kernels import compiled
from .elastic import Elastic, ElasticParams
from .moduli import IsotropicElasticParams, isotropic_moduli

EMPTY = np.zeros(0)
EMPTY_INDEX = np.zeros(0, dtype=np.int32)


class LinearLPSPVParams(IsotropicElasticParams):
    verbose: bool = Field(False, alias="Verbose", description="accepted for compatibility")
    use_partial_volume: bool = Field(
        False, alias="Use Partial Volume",
        description="weight neighbours by the part of their cell inside the horizon (needs Discretization > "
        "Compute Element-Horizon Intersections: true, an Exodus HEX8 mesh)",
    )
    use_improved_quadrature: bool = Field(False, alias="Use Improved Quadrature", description="not available (Peridigm: an external library)")
    use_analytic_weighted_volume: bool = Field(False, alias="Use Analytic Weighted Volume", description="use 'Analytic Weighted Volume' for every m_i")
    analytic_weighted_volume: float | None = Field(None, alias="Analytic Weighted Volume", description="m (L^5), required with 'Use Analytic Weighted Volume'")
    used_when = {"analytic_weighted_volume": UsedWhen(lambda p: p.use_analytic_weighted_volume, "'Use Analytic Weighted Volume' is true", gt=0)}

    @model_validator(mode="after")
    def _options(self):
        if self.use_improved_quadrature:
            raise ValueError("'Use Improved Quadrature' is not available (Peridigm needs an external quadrature library for it)")
        if self.use_analytic_weighted_volume and self.analytic_weighted_volume is None:
            raise ValueError("'Use Analytic Weighted Volume' is true: give 'Analytic Weighted Volume' (L^5)")
        return self


# ------------------------------------------------------------------------------------------------
# Loop laws (peridyn.core.traversal), compiled into each loop by the run's backend. The model's
# sums run over *reference* bonds: kernels are given y = x (Model_Coordinates, (n, 3) L), so the
# bond context's (ex, ey, ez) = xi = x_j - x_i and L = |xi| (L); the current positions come in
# args. Common args (x, y, V, W, m, theta, K, mu, omega_kind, delta, table, d, offsets): x, y
# (n, 3) reference and current positions (L); V (n,) volumes (L^3); W (nb,) neighbour weights
# (L^3) or empty (then V_j); m (n,) weighted volumes (L^5); theta (n,) dilatations; K, mu (stress);
# omega_kind / delta / table as in peridyn.core.influence; d (nb,) bond damage or empty;
# offsets (n+1,) the CSR offsets. An optional array is read only inside the helpers below, never
# under a branch of a law function itself: a compiled law counts references to an array it
# holds across such a branch at every bond (several times slower).
# ------------------------------------------------------------------------------------------------
def neighbor_weight(j, b, W, volume):
    """W_j of bond b: its ``Neighbor_Volume`` with partial volumes, else V_j (L^3). (Laws run at
    every step pick their weight by law instead: a per-bond choice is slower.)"""
    return W[b] if W.shape[0] > 0 else volume[j]


def influence(omega_kind, zeta, delta, table, b):
    """omega of bond b (:func:`peridyn.core.influence.omega`)."""
    return omega(omega_kind, zeta, delta, table, b)


def intact(bond_damage, b):
    """1 - d of bond b, 1 without damage."""
    return 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0


def reverse_intact(bond_damage, reverse, b, k):
    """1 - d of the reverse bond j->i where ``reverse`` gives it, else ``k`` (1 - d_ij)."""
    if bond_damage.shape[0] > 0 and reverse.shape[0] > 0 and reverse[b] >= 0:
        return 1.0 - bond_damage[reverse[b]]
    return k


def displacement_point(i, args):
    """u_i = y_i - x_i (L) of the owner point."""
    x, y = args[0], args[1]
    return y[i, 0] - x[i, 0], y[i, 1] - x[i, 1], y[i, 2] - x[i, 2]


def dyad(j, ex, ey, ez, u, x, y):
    """M = xi (xi . du) component by component, du = u_j - u_i (L^3; Peridigm's products)."""
    u0, u1, u2 = u
    d0 = (y[j, 0] - x[j, 0]) - u0
    d1 = (y[j, 1] - x[j, 1]) - u1
    d2 = (y[j, 2] - x[j, 2]) - u2
    M0 = ((ex * ex) * d0 + (ex * ey) * d1) + (ex * ez) * d2
    M1 = ((ey * ex) * d0 + (ey * ey) * d1) + (ey * ez) * d2
    M2 = ((ez * ex) * d0 + (ez * ey) * d1) + (ez * ez) * d2
    return M0, M1, M2


def weighted_volume_term(i, j, b, ex, ey, ez, L, z, p, args):
    """(omega |xi|^2) W_j (L^5); args as above (only x, V, W, omega_kind, delta, table read)."""
    volume, W, omega_kind, delta, table = args[2], args[3], args[8], args[9], args[10]
    z2 = (ex * ex + ey * ey) + ez * ez
    w = influence(omega_kind, L, delta, table, b)
    return (w * z2) * neighbor_weight(j, b, W, volume)


def dilatation_share(j, b, ex, ey, ez, L, u, args):
    """(omega (1-d)) (xi . du) of bond b (L^2); u = u_i."""
    x, y, volume, W, m, theta, K, mu, omega_kind, delta, table, bond_damage, offsets = args
    u0, u1, u2 = u
    s = (ex * ((y[j, 0] - x[j, 0]) - u0) + ey * ((y[j, 1] - x[j, 1]) - u1)) + ez * ((y[j, 2] - x[j, 2]) - u2)
    w = influence(omega_kind, L, delta, table, b)
    keep = intact(bond_damage, b)
    return (w * keep) * s


def dilatation_term(i, j, b, ex, ey, ez, L, z, u, args):
    """((omega (1-d)) (xi . du)) V_j (L^5), without partial volumes."""
    return dilatation_share(j, b, ex, ey, ez, L, u, args) * args[2][j]


def dilatation_partial_term(i, j, b, ex, ey, ez, L, z, u, args):
    """((omega (1-d)) (xi . du)) W_b (L^5), with partial volumes (the weight is chosen by the
    law, not per bond)."""
    return dilatation_share(j, b, ex, ey, ez, L, u, args) * args[3][b]


def dilatation_finish(i, acc, u, args):
    """theta_i = (3 / m_i) acc; acc (0) for a point without bonds."""
    m, offsets = args[4], args[12]
    return acc * (3.0 / m[i]) if offsets[i + 1] > offsets[i] else acc


def dilatation_plain_term(i, j, b, ex, ey, ez, L, z, u, args):
    """``dilatation_term`` for omega = 1, no damage, W_j = V_j (the same products): branch-free."""
    x, y, volume = args[0], args[1], args[2]
    u0, u1, u2 = u
    s = (ex * ((y[j, 0] - x[j, 0]) - u0) + ey * ((y[j, 1] - x[j, 1]) - u1)) + ez * ((y[j, 2] - x[j, 2]) - u2)
    return s * volume[j]


def force_state_bond(i, j, b, ex, ey, ez, L, z, u, args):
    """T_i<xi> = (1-d) (T1_i xi + T2_i M) (force per volume squared), as a (3,) row."""
    x, y, volume, W, m, theta, K, mu, omega_kind, delta, table, bond_damage, offsets = args
    M0, M1, M2 = dyad(j, ex, ey, ez, u, x, y)
    z2 = (ex * ex + ey * ey) + ez * ez
    w = influence(omega_kind, L, delta, table, b)
    T1 = (((9.0 * K - 15.0 * mu) * w) * theta[i]) / (3.0 * m[i])
    T2 = ((15.0 * mu) * w) / (m[i] * z2)
    keep = intact(bond_damage, b)
    return keep * (T1 * ex + T2 * M0), keep * (T1 * ey + T2 * M1), keep * (T1 * ez + T2 * M2)


def plain_point(i, args):
    """(u_i, T1_i, m_i) for omega = 1: T1_i = ((9K - 15 mu) theta_i) / (3 m_i)."""
    m, theta, K, mu = args[4], args[5], args[6], args[7]
    return displacement_point(i, args), ((9.0 * K - 15.0 * mu) * theta[i]) / (3.0 * m[i]), m[i]


def force_state_plain_bond(i, j, b, ex, ey, ez, L, z, p, args):
    """``force_state_bond`` for omega = 1 and no damage (the same products): branch-free."""
    x, y, mu = args[0], args[1], args[7]
    u, T1, mi = p
    M0, M1, M2 = dyad(j, ex, ey, ez, u, x, y)
    z2 = (ex * ex + ey * ey) + ez * ez
    T2 = (15.0 * mu) / (mi * z2)
    return T1 * ex + T2 * M0, T1 * ey + T2 * M1, T1 * ez + T2 * M2


def fused_force_point(i, args):
    """u_i; clears the y and z sums of f_i (args[-1], written by ``fused_force_term``)."""
    f = args[14]
    f[i, 1] = 0.0
    f[i, 2] = 0.0
    return displacement_point(i, args)


def fused_force_term(i, j, b, ex, ey, ez, L, z, u, args):
    """(T_i<xi_ij> - T_j<xi_ji>) W_ij, both ends from point quantities: xi and M change sign
    with the bond's direction, so T_j<xi_ji> = -(1-d_ji) (T1_j xi + T2_j M); ``reverse`` gives
    d_ji (empty: d_ji = d_ij). The x component is returned (the law's sum is f_i's x, out =
    f[:, 0]); y and z are added to f[i, 1], f[i, 2] in the same bond order. args: the common ones,
    then (reverse, f)."""
    x, y, volume, W, m, theta, K, mu, omega_kind, delta, table, bond_damage, offsets, reverse, f = args
    M0, M1, M2 = dyad(j, ex, ey, ez, u, x, y)
    z2 = (ex * ex + ey * ey) + ez * ez
    w = influence(omega_kind, L, delta, table, b)
    c1 = (9.0 * K - 15.0 * mu) * w
    c2 = (15.0 * mu) * w
    T1i = (c1 * theta[i]) / (3.0 * m[i])
    T2i = c2 / (m[i] * z2)
    T1j = (c1 * theta[j]) / (3.0 * m[j])
    T2j = c2 / (m[j] * z2)
    ki = intact(bond_damage, b)
    kj = reverse_intact(bond_damage, reverse, b, ki)
    f[i, 1] += (ki * (T1i * ey + T2i * M1) + kj * (T1j * ey + T2j * M1)) * W[b]
    f[i, 2] += (ki * (T1i * ez + T2i * M2) + kj * (T1j * ez + T2j * M2)) * W[b]
    return (ki * (T1i * ex + T2i * M0) + kj * (T1j * ex + T2j * M0)) * W[b]


def energy_point(i, args):
    """(theta_i, u_i)."""
    return args[5][i], displacement_point(i, args)


def energy_share(j, b, ex, ey, ez, L, p, args):
    """(1-d) omega (e - theta_i |xi| / 3)^2 of bond b with e = (xi . du) / |xi|."""
    x, y, volume, W, m, theta, K, mu, omega_kind, delta, table, bond_damage, offsets = args
    th, u = p
    M0, M1, M2 = dyad(j, ex, ey, ez, u, x, y)
    z2 = (ex * ex + ey * ey) + ez * ez
    s = (M0 * ex + M1 * ey + M2 * ez) / z2  # xi . du
    ed = s / L - th * L / 3.0
    keep = intact(bond_damage, b)
    return (keep * influence(omega_kind, L, delta, table, b)) * ed * ed


def stored_energy_term(i, j, b, ex, ey, ez, L, z, p, args):
    """(1-d) omega (e - theta_i |xi| / 3)^2 V_j (L^5), without partial volumes."""
    return energy_share(j, b, ex, ey, ez, L, p, args) * args[2][j]


def stored_energy_partial_term(i, j, b, ex, ey, ez, L, z, p, args):
    """(1-d) omega (e - theta_i |xi| / 3)^2 W_b (L^5), with partial volumes."""
    return energy_share(j, b, ex, ey, ez, L, p, args) * args[3][b]


def stored_energy_finish(i, acc, p, args):
    """W_i = K theta^2 / 2 + (15 mu / (2 m_i)) acc (energy per volume; K theta^2 / 2 alone for a
    point without bonds)."""
    m, K, mu, offsets = args[4], args[6], args[7], args[12]
    th = p[0]
    return 0.5 * K * th * th + (0.5 * (15.0 * mu) / m[i]) * acc if offsets[i + 1] > offsets[i] else 0.5 * K * th * th


# every law runs on the reference bonds and takes |xi| from the positions (no Bond_Length field)
REF = {"z_from_positions": True}
WEIGHTED_VOLUME = PointSum(weighted_volume_term, **REF)
DILATATION = PointSum(dilatation_term, point=displacement_point, finish=dilatation_finish, **REF)
DILATATION_PARTIAL = PointSum(dilatation_partial_term, point=displacement_point, finish=dilatation_finish, **REF)
FORCE_STATE = BondMap(force_state_bond, point=displacement_point, **REF)  # out: T (nb, 3)
#: omega = 1, no damage, no partial volumes: laws without the optional arrays
DILATATION_PLAIN = PointSum(dilatation_plain_term, point=displacement_point, finish=dilatation_finish, **REF)
FORCE_STATE_PLAIN = BondMap(force_state_plain_bond, point=plain_point, **REF)
FUSED_FORCE = PointSum(fused_force_term, point=fused_force_point, mirror=False, **REF)  # out: f[:, 0], f (n, 3) in args; point writes
STORED_ENERGY = PointSum(stored_energy_term, point=energy_point, finish=stored_energy_finish, **REF)
STORED_ENERGY_PARTIAL = PointSum(stored_energy_partial_term, point=energy_point, finish=stored_energy_finish, **REF)


# ------------------------------------------------------------------------------------------------
class LinearLPSPartialVolume(Material):
    """Linearised LPS with optional partial volumes (Peridigm's ``Linear LPS Partial Volume``)."""
    small_strain_limit = SMALL_STRAIN  # a linear law

    name = "Linear LPS Partial Volume"
    Params = LinearLPSPVParams
    force_state_kind = "vector"
    precompute_fields = ("Dilatation",)

    def __init__(self, params: LinearLPSPVParams, *, horizon: float | None, options=None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        self.K, self.mu = params.moduli()
        self.omega_table = EMPTY

    @property
    def density(self) -> float:
        return self.params.density

    @property
    def bulk_modulus(self) -> float:
        return self.K

    def elastic_moduli(self) -> ElasticModuli:
        return isotropic_moduli(self.params, self.K, self.mu, hookean=True)

    @property
    def partial(self) -> bool:
        return bool(self.params.use_partial_volume)

    def _common(self, block: BlockView):
        return block.influence.kind, block.horizon, self.omega_table

    def _damage(self, block: BlockView) -> np.ndarray:
        return block.fields.get("Bond_Damage", EMPTY)

    def fields(self) -> list[FieldSpec]:
        specs = [
            FieldSpec("Weighted_Volume", Relation.ELEMENT, 1, Temporal.CONSTANT, halo=True, units="L^5"),
            FieldSpec("Dilatation", Relation.ELEMENT, 1, Temporal.CONSTANT, halo=True),
        ]
        if self.partial:
            specs.append(FieldSpec("Neighbor_Volume", Relation.BOND, 1, Temporal.CONSTANT, units="L^3"))
        return specs

    def _weights(self, block: BlockView) -> np.ndarray:
        return block.fields["Neighbor_Volume"] if self.partial else EMPTY

    def _args(self, block: BlockView) -> tuple:
        """The laws' common args (x, y, V, W, m, theta, K, mu, omega_kind, delta, table, d, offsets)."""
        s = block.fields
        kind, delta, table = self._common(block)
        return (s["Model_Coordinates"], s["Coordinates"], s["Volume"], self._weights(block), s["Weighted_Volume"], s["Dilatation"],
                self.K, self.mu, kind, delta, table, self._damage(block), block.bonds.offsets)

    def _run(self, block: BlockView, law, args: tuple, out: np.ndarray) -> None:
        """``law`` over the block's points on the reference bonds (the kernel's y is x, and so are
        the positions its |xi| comes from)."""
        s, nl = block.fields, block.bonds
        x = s["Model_Coordinates"]
        compiled(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, x, x, args, out)

    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        if block.influence.needs_table:
            self.omega_table = block.influence.table_for(nl.offsets, nl.neighbors, s["Model_Coordinates"], np.arange(block.start, block.stop), block.horizon)
        W = self._weights(block)
        lo, hi = int(nl.offsets[block.start]), int(nl.offsets[block.stop])
        if self.partial and hi > lo and not np.any(W[lo:hi] > 0.0):
            raise InputError(
                "'Use Partial Volume' is true but the discretization computes no partial volumes",
                path=tuple(self.options.get("path", ())) + ("Use Partial Volume",),
                fix="set Discretization > 'Compute Element-Horizon Intersections: true' (an Exodus HEX8 mesh)",
            )
        m = s["Weighted_Volume"]
        if self.params.use_analytic_weighted_volume:
            m[block.start : block.stop] = float(self.params.analytic_weighted_volume)
            return
        self._run(block, WEIGHTED_VOLUME, self._args(block), m)

    def _plain(self, block: BlockView) -> bool:
        """omega = 1, no damage, no partial volumes: the branch-free laws apply."""
        return block.influence.kind == ONE and not self._damage(block).shape[0] and not self.partial

    def precompute(self, block: BlockView) -> None:
        law = DILATATION_PARTIAL if self.partial else DILATATION_PLAIN if self._plain(block) else DILATATION
        self._run(block, law, self._args(block), block.fields["Dilatation"])

    def force_state(self, block: BlockView, T: np.ndarray) -> None:
        if self.partial:
            raise InputError(
                f"block {block.name!r}: 'Use Partial Volume' needs the block's bonds to stay inside the block (one material, "
                "no implicit finite-difference tangent)",
                path=tuple(self.options.get("path", ())) + ("Use Partial Volume",),
            )
        self._run(block, FORCE_STATE_PLAIN if self._plain(block) else FORCE_STATE, self._args(block), T)

    def force_fused(self, block: BlockView, force_density: np.ndarray) -> bool:
        if not self.partial:
            return False  # the engine's gather of the vector force states
        nl = block.bonds
        reverse = nl.reverse() if self._damage(block).shape[0] and not block.damage_symmetric else EMPTY_INDEX
        self._run(block, FUSED_FORCE, self._args(block) + (reverse, force_density), force_density[:, 0])
        return True

    def tangent(self, block: BlockView, target) -> bool:
        return False  # finite differences (Peridigm: the base class's)

    def stored_energy_density(self, block: BlockView, out: np.ndarray) -> None:
        self._run(block, STORED_ENERGY_PARTIAL if self.partial else STORED_ENERGY, self._args(block), out)


class ElasticPVParams(ElasticParams):
    """Peridigm's ``Elastic Partial Volume`` parameters as far as its kernels show them."""


class ElasticPartialVolume(Elastic):
    """``Elastic Partial Volume`` (PERIDIGM_MODELS.md §5.2). Peridigm's class is not public; its
    kernels are the Elastic LPS with W_j = Neighbor_Volume when partial volumes exist, else
    exactly ``Elastic``. peridyn runs it as ``Elastic`` (partial volumes are not applied)."""

    name = "Elastic Partial Volume"
    Params = ElasticPVParams
