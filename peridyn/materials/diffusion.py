"""``Diffusion``: Peridigm's peridynamic (nonlocal) diffusion material (PERIDIGM_MODELS.md §6.1).

For every point i of the block and every neighbor j of its family, with L = |x_j - x_i| the
reference bond length, delta the horizon and kappa the ``Coefficient``,

    k_ij = 6 / (pi delta^4 L),     Q_i = sum_j kappa k_ij (T_j - T_i) w_ij,

where w_ij = V_j (the neighbor's volume) or, with ``Use Improved Quadrature``, a per-bond
quadrature weight. Q is the ``Flux_Divergence`` (temperature per time: the nonlocal counterpart
of kappa Laplacian(T)); it is a *gather*, nothing is added to j. The evaluation order is
Peridigm's: ``k = 6.0/(((((pi delta) delta) delta) delta) L)``, ``q = ((kappa k) (T_j - T_i)) w``,
summed bond by bond from 0.0. For a quadratic field T the continuum integral over the ball of
radius delta gives exactly kappa Laplacian(T) (the second moment of 1/L over the ball is
pi delta^4 / 3), so the model is a nonlocal heat-conduction operator with diffusivity kappa.

There is no density or elastic constant: ``density`` is 1 (Peridigm's ``Density()``) and the
bulk modulus does not exist (Peridigm throws), so explicit dynamics (Verlet, whose stable time
step needs it) cannot run with this material. The material produces no force; only the
``ImplicitDiffusion`` solver (:mod:`peridyn.solvers.implicit.diffusion`) advances the
temperature. Its Jacobian dQ_i V_i / dT is exact (the flux is linear in T):
d(Q_i V_i)/dT_j = (kappa k_ij w_ij) V_i and d(Q_i V_i)/dT_i = -sum_j of those.

Improved quadrature: Peridigm takes the weights from an external library that is not public
(``nonlocalDiffusionQuad``, order 2). peridyn computes its own: for every point the weights
closest to the volumes (min sum_j (w_j - V_j)^2 / V_j) for which the sum is exact for every
polynomial of degree <= 2, i.e. sum_j k_ij xi_a w_j = 0 and sum_j k_ij xi_a xi_b w_j = 2 delta_ab
(xi = x_j - x_i). Linear temperature fields then give Q = 0 at every point, even at points whose
family is cut by a free surface, and quadratic ones Q = kappa Laplacian(T) (asymptotic
compatibility). Where a family cannot satisfy every condition (a flat layer of points has no
z moments) the conditions it can satisfy are met in the least-squares sense.

Fields: ``Temperature`` and ``Flux_Divergence`` (node scalars), ``Quadrature_Weights`` (bond)
only with improved quadrature. Under MPI the ghosts' temperatures are exchanged before every
evaluation (``ghost_inputs``).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from pydantic import Field

from ..core.errors import InputError, InstabilityError
from ..core.fields import FieldSpec, Relation
from ..core.interfaces import BlockView, Material
from ..core.params import ModelParams
from ..core.traversal import PointSum
from ..kernels.lengths import compiled_with_lengths

EMPTY = np.zeros(0)


class DiffusionParams(ModelParams):
    coefficient: float = Field(
        alias="Coefficient", gt=0, description="diffusivity kappa (L^2/T): Flux_Divergence = kappa x the nonlocal Laplacian of Temperature"
    )
    use_improved_quadrature: bool = Field(
        False, alias="Use Improved Quadrature",
        description="per-bond quadrature weights exact for quadratic fields instead of the neighbor volumes (peridyn's own weights, see docs/diffusion.md)",
    )
    finite_difference_probe_length: float | None = Field(
        None, alias="Finite Difference Probe Length", gt=0,
        description="accepted for compatibility: the flux is linear in the temperature and peridyn's Jacobian is exact",
    )


# ------------------------------------------------------------------------------------------------
# Loop laws (peridyn.core.traversal), compiled into each loop by the run's backend. Bond context
# (i, j, b, ex, ey, ez, L, z, p, args): z = zeta[b] the reference bond length (L); the positions
# are not read. Arrays: V (n,) L^3; T (n,) temperature; w (nb,) quadrature weights (L^3), empty
# for w_ij = V_j.
# ------------------------------------------------------------------------------------------------
def pi_delta4(delta):
    """pi delta^4 (L^4) in Peridigm's order."""
    return (((math.pi * delta) * delta) * delta) * delta


def bond_weight(j, b, w, volume):
    """w_ij: the bond's quadrature weight, else V_j (L^3)."""
    return w[b] if w.shape[0] > 0 else volume[j]


def flux_point(i, args):
    """(T_i, pi delta^4); args (V, T, w, kappa, delta)."""
    return args[1][i], pi_delta4(args[4])


def flux_term(i, j, b, ex, ey, ez, L, z, p, args):
    """((kappa k_ij) (T_j - T_i)) w_ij, k_ij = 6 / (pi delta^4 zeta_ij) (temperature per time)."""
    volume, T, w, kappa, delta = args
    Ti, d4 = p
    k = 6.0 / (d4 * z)
    return ((kappa * k) * (T[j] - Ti)) * bond_weight(j, b, w, volume)


def jacobian_point(i, args):
    """(V_i, pi delta^4); args (V, w, kappa, delta, bond_pos, data)."""
    return args[0][i], pi_delta4(args[3])


def jacobian_term(i, j, b, ex, ey, ez, L, z, p, args):
    """Writes J_ij = ((kappa k_ij) V_j) V_i at data[bond_pos[b]] (bond b's own entry of row i)
    and returns -J_ij: the law's sum is the diagonal J_ii = -sum_j J_ij."""
    volume, w, kappa, delta, bond_pos, data = args
    Vi, d4 = p
    k = 6.0 / (d4 * z)
    c = ((kappa * k) * volume[j]) * Vi
    data[bond_pos[b]] = c
    return -c


def jacobian_weighted_term(i, j, b, ex, ey, ez, L, z, p, args):
    """``jacobian_term`` with the quadrature weight w_ij in place of V_j (the weight is chosen by
    the law, not per bond: a per-bond choice next to the matrix write is much slower)."""
    volume, w, kappa, delta, bond_pos, data = args
    Vi, d4 = p
    k = 6.0 / (d4 * z)
    c = ((kappa * k) * w[b]) * Vi
    data[bond_pos[b]] = c
    return -c


FLUX_DIVERGENCE = PointSum(flux_term, point=flux_point)
FLUX_JACOBIAN = PointSum(jacobian_term, point=jacobian_point)
FLUX_JACOBIAN_WEIGHTED = PointSum(jacobian_weighted_term, point=jacobian_point)


# not a loop law: one least-squares solve per point (a 9 x nb moment matrix) gives all of its bonds' weights at once
@njit(cache=True, parallel=True)
def quadrature_weights_kernel(start, stop, offsets, neighbors, x, zeta, volume, delta, w):
    """Per-bond weights w (nb,) closest to the volumes V_j (min sum (w - V)^2 / V) with
    sum_j k_ij xi_a w_j = 0 and sum_j k_ij xi_a xi_b w_j = 2 delta_ab for the points
    [start, stop) (k_ij = 6 / (pi delta^4 |xi|)); conditions a family cannot meet are met in
    the least-squares sense. In scaled form (xi / delta) the 9 x 9 normal matrix is O(1)."""
    d4 = (((math.pi * delta) * delta) * delta) * delta
    for i in prange(start, stop):
        lo = offsets[i]
        nb = offsets[i + 1] - lo
        if nb == 0:
            continue
        R = np.zeros((9, nb))
        Vn = np.zeros(nb)
        vbar = 0.0
        for m in range(nb):
            vbar += volume[neighbors[lo + m]]
        vbar = vbar / nb
        for m in range(nb):
            b = lo + m
            j = neighbors[b]
            # k xi xi w = (k delta^2 vbar) (xi/delta)(xi/delta) (w/vbar): O(1) entries and targets
            s = (6.0 / (d4 * zeta[b])) * delta * delta * vbar
            ex = (x[j, 0] - x[i, 0]) / delta
            ey = (x[j, 1] - x[i, 1]) / delta
            ez = (x[j, 2] - x[i, 2]) / delta
            R[0, m] = s * ex
            R[1, m] = s * ey
            R[2, m] = s * ez
            R[3, m] = s * ex * ex
            R[4, m] = s * ey * ey
            R[5, m] = s * ez * ez
            R[6, m] = s * ex * ey
            R[7, m] = s * ex * ez
            R[8, m] = s * ey * ez
            Vn[m] = volume[j] / vbar
        target = np.zeros(9)
        target[3] = 2.0
        target[4] = 2.0
        target[5] = 2.0
        rhs = target - R @ Vn
        G = (R * Vn) @ R.T
        lam = np.linalg.lstsq(G, rhs, 1e-12)[0]
        wn = Vn + Vn * (R.T @ lam)
        for m in range(nb):
            w[lo + m] = wn[m] * vbar


class Diffusion(Material):
    """Peridigm's ``Diffusion`` material: the flux divergence Q of the nonlocal heat equation."""

    diffusion = True

    name = "Diffusion"
    Params = DiffusionParams
    ghost_inputs = ("Temperature",)
    #: the solver that advances the temperature asks for ``flux_divergence`` / ``flux_jacobian``
    solves_for = "temperature"

    def __init__(self, params: DiffusionParams, *, horizon: float | None, options=None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        if horizon is None:
            raise InputError(
                "the Diffusion material needs a constant horizon (its kernel 6/(pi delta^4 L) uses the block's horizon)",
                path=tuple((options or {}).get("path", ())),
                fix="give the block's Horizon as a number",
            )
        self.kappa = float(params.coefficient)
        self.improved = bool(params.use_improved_quadrature)
        self._weights_ready: set[tuple[int, int]] = set()

    def finite_difference_probe_length(self) -> float | None:
        return self.params.finite_difference_probe_length

    @property
    def density(self) -> float:
        return 1.0  # Peridigm's DiffusionMaterial::Density()

    @property
    def bulk_modulus(self) -> float:
        raise InputError(
            "the Diffusion material has no elastic constants, so explicit dynamics cannot run with it (Peridigm stops there too)",
            path=tuple(self.options.get("path", ())),
            fix="solve for the temperature with the ImplicitDiffusion solver",
        )

    def fields(self) -> list[FieldSpec]:
        specs = [
            FieldSpec("Temperature", Relation.NODE, units="temperature"),
            FieldSpec("Flux_Divergence", Relation.NODE, units="temperature/T"),
        ]
        if self.improved:
            specs.append(FieldSpec("Quadrature_Weights", Relation.BOND, units="L^3"))
        return specs

    def initialize(self, block: BlockView) -> None:
        if self.improved:
            s = block.fields
            nl = block.bonds
            quadrature_weights_kernel(
                block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Bond_Length"], s["Volume"],
                float(self.horizon), s["Quadrature_Weights"],
            )

    def _weights(self, block: BlockView) -> np.ndarray:
        return block.fields["Quadrature_Weights"] if self.improved else EMPTY

    # -- flux ------------------------------------------------------------------------------------
    def flux_divergence(self, block: BlockView) -> None:
        """Flux_Divergence[start:stop] from the current Temperature (ghosts included under MPI)."""
        s = block.fields
        nl = block.bonds
        args = (s["Volume"], s["Temperature"], self._weights(block), self.kappa, float(self.horizon))
        compiled_with_lengths(block, FLUX_DIVERGENCE)(
            block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], args, s["Flux_Divergence"]
        )
        Q = s["Flux_Divergence"][block.start : block.stop]
        if not np.isfinite(Q).all():
            k = block.start + int(np.argmax(~np.isfinite(Q)))
            raise InstabilityError(
                f"the flux divergence of block {block.name!r} is not finite at local point {k} "
                f"(temperature {float(s['Temperature'][k])!r}); check the prescribed and initial temperatures",
                collective=False,
            )

    def flux_jacobian(self, block: BlockView, row_of_local: np.ndarray, bond_pos: np.ndarray, diag_pos: np.ndarray, data: np.ndarray) -> None:
        """Write the rows d(Q V)/dT of the block's points into a CSR matrix's ``data``: bond b's
        entry at ``bond_pos[b]``, row r's diagonal at ``diag_pos[r]`` (r = row_of_local[i])."""
        s = block.fields
        nl = block.bonds
        diag = np.zeros(s.num_points)
        args = (s["Volume"], self._weights(block), self.kappa, float(self.horizon), bond_pos, data)
        law = FLUX_JACOBIAN_WEIGHTED if self.improved else FLUX_JACOBIAN
        compiled_with_lengths(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], args, diag)
        data[diag_pos[row_of_local[block.start : block.stop]]] = diag[block.start : block.stop]

    # -- the force interface: no force -------------------------------------------------------------
    def force_state(self, block: BlockView, t: np.ndarray) -> None:
        nl = block.bonds
        t[nl.offsets[block.start] : nl.offsets[block.stop]] = 0.0
        self.flux_divergence(block)

    def force_fused(self, block: BlockView, force_density: np.ndarray) -> bool:
        force_density[block.start : block.stop] = 0.0
        self.flux_divergence(block)
        return True
