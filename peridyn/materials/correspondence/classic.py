"""Peridigm's classic correspondence materials: ``Elastic Correspondence``, ``Elastic Plastic
Correspondence``, ``Isotropic Hardening Correspondence`` and ``Viscoplastic Needleman
Correspondence`` (PERIDIGM_CORRESPONDENCE.md §2-§7).

Each force evaluation, per block: K⁻¹ and F from the current positions, the velocity gradient
and the Flanagan-Taylor update of V and R (rate form: nothing is recomputed from F), the stress
update of the model in the unrotated configuration, the Cauchy stress, A = P K⁻¹, and the vector
force state of every bond of the block's points, T(i→j) = ω (A_i ξ) plus the hourglass term
M(i→j) η. The engine gathers T from both bond ends (the non-ordinary path of
:class:`peridyn.core.interfaces.Material`). Bond damage is ignored, as in Peridigm.

Loops are loop laws (:mod:`peridyn.core.traversal`) run by the block's backend: the kinematics
(:mod:`.kinematics`: ``SHAPE_TENSOR``, ``KINEMATICS``), the bond force states ``BOND_STATES`` or,
with an hourglass force, ``BOND_STATES_HOURGLASS`` (:class:`BondMap` of width 3, below) and Partial_Stress (:mod:`.forces`: ``PARTIAL_STRESS``); the
stress updates have no bond loop; the implicit tangent (:mod:`.fd_tangent`) stays hand-written.
"""
from __future__ import annotations

import logging
import math
from typing import Any, ClassVar

import numpy as np

from ...core.errors import InstabilityError
from ...core.fields import FieldSpec, Length, Relation, Temporal
from ...core.interfaces import SMALL_STRAIN, BlockView, ElasticModuli, Material
from ...core.traversal import BondMap
from ...kernels import compiled
from ..moduli import bulk_and_shear, isotropic_moduli
from . import params as P
from .forces import force_state_bond, hourglass_bond, partial_stress_kernel
from .kinematics import kinematics_kernel, shape_tensor_kernel
from .stress import (
    MAX_BISECTION,
    NEEDLEMAN_NON_FINITE,
    elastic_plastic_stress_kernel,
    elastic_stress_kernel,
    isotropic_hardening_stress_kernel,
    needleman_stress_kernel,
    rotate_piola_kernel,
)

log = logging.getLogger(__name__)

PI = 3.141592653589793

TENSOR2 = Temporal.TWO_STEP
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0])


# Loop laws (peridyn.core.traversal), run on reference positions: the bond context's (ex, ey, ez) =
# ξ = x_j - x_i and L = ζ = |ξ| (L). args (y (n, 3) current positions L, horizon (n,) L,
# omega_kind, omega_table (nb,) or empty, A (n, 9) = P K⁻¹ M L^-6 T^-2, F (n, 9), c1 M L^-1 T^-2).
# Two variants, picked by the material's c1: without the hourglass term (c1 == 0) and with it.
def bond_state(i, j, b, ex, ey, ez, L, z, p, args):
    """T(i→j) = ω(ζ, δ_i)(A_i ξ) (force per volume squared): the classic vector force state."""
    y, horizon, omega_kind, omega_table, A, F, c1 = args
    return force_state_bond(A, i, ex, ey, ez, L, horizon[i], omega_kind, omega_table, b)


def bond_state_hourglass(i, j, b, ex, ey, ez, L, z, p, args):
    """T(i→j) = ω(ζ, δ_i)(A_i ξ) + M(i→j) η: with the hourglass term of §7 (c1 = 18 C K / π)."""
    y, horizon, omega_kind, omega_table, A, F, c1 = args
    tx, ty, tz = force_state_bond(A, i, ex, ey, ez, L, horizon[i], omega_kind, omega_table, b)
    hx, hy, hz = hourglass_bond(i, j, ex, ey, ez, L, y, F, c1, horizon[i])
    return tx + hx, ty + hy, tz + hz


#: T (nb, 3) of the bonds of a range of points, c1 == 0
BOND_STATES = BondMap(bond_state, width=3, z_from_positions=True)
#: T (nb, 3) with the hourglass term, c1 != 0
BOND_STATES_HOURGLASS = BondMap(bond_state_hourglass, width=3, z_from_positions=True)


class ClassicCorrespondence(Material):
    """The family's sequence; subclasses supply the stress update (``_update_stress``)."""

    Params: ClassVar[type] = P.ClassicParams
    force_state_kind = "vector"
    ghost_inputs = ("Velocity",)  # the velocity gradient reads the neighbors' velocities
    tangent_perturbs_velocity = True  # Peridigm's finite-difference probe moves v by eps/dt too
    plastic: ClassVar[bool] = False

    def __init__(self, params, *, horizon: float | None, options: dict[str, Any] | None = None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        self.K, self.G = bulk_and_shear(params.bulk_modulus, params.shear_modulus, params.youngs_modulus, params.poissons_ratio,
                                        plane_strain=params.plane_strain, plane_stress=params.plane_stress)
        self.c1 = ((18.0 * params.hourglass_coefficient) * self.K) / PI
        self._work: dict[str, np.ndarray] = {}
        self.omega_table: np.ndarray | None = None  # an expression influence function's, tabulated once

    requires_constant_horizon = False  # the per-point Horizon field is used

    def finite_difference_probe_length(self) -> float | None:
        return self.params.finite_difference_probe_length

    @property
    def density(self) -> float:
        return float(self.params.density)

    @property
    def bulk_modulus(self) -> float:
        return float(self.K)

    def elastic_moduli(self) -> ElasticModuli:
        """K and G (Hookean unless the model is plastic)."""
        return isotropic_moduli(self.params, self.K, self.G, hookean=not self.plastic)

    def fields(self) -> list[FieldSpec]:
        specs = [
            FieldSpec("Horizon", Relation.ELEMENT),
            FieldSpec("Deformation_Gradient", Relation.ELEMENT, Length.TENSOR),
            FieldSpec("Shape_Tensor_Inverse", Relation.ELEMENT, Length.TENSOR),
            FieldSpec("Left_Stretch_Tensor", Relation.ELEMENT, Length.TENSOR, TENSOR2),
            FieldSpec("Rotation_Tensor", Relation.ELEMENT, Length.TENSOR, TENSOR2),
            FieldSpec("Unrotated_Cauchy_Stress", Relation.ELEMENT, Length.TENSOR, TENSOR2),
        ]
        if self.plastic:
            specs.append(FieldSpec("Equivalent_Plastic_Strain", Relation.ELEMENT, Length.SCALAR, TENSOR2))
        return specs

    def output_fields(self) -> list[FieldSpec]:
        specs = [
            FieldSpec("Unrotated_Rate_Of_Deformation", Relation.ELEMENT, Length.TENSOR),
            FieldSpec("Cauchy_Stress", Relation.ELEMENT, Length.TENSOR, TENSOR2),
            FieldSpec("Partial_Stress", Relation.ELEMENT, Length.TENSOR, TENSOR2),
        ]
        if self.plastic:
            specs.append(FieldSpec("Von_Mises_Stress", Relation.ELEMENT))
        return specs

    # -- helpers ------------------------------------------------------------------------------
    def _omega(self, block: BlockView):
        inf = block.influence
        table = self.omega_table
        if inf.needs_table and table is None:
            s, nl = block.fields, block.bonds
            table = self.omega_table = inf.table_for(nl.offsets, nl.neighbors, s["Model_Coordinates"], np.arange(block.start, block.stop), block.horizon)
        return inf.kind, table if table is not None else np.zeros(0)

    def _scratch(self, name: str, shape: tuple[int, ...]) -> np.ndarray:
        a = self._work.get(name)
        if a is None or a.shape != shape:
            a = self._work[name] = np.zeros(shape)
        return a

    def _field_or_scratch(self, block: BlockView, name: str, width: int = 9) -> np.ndarray:
        s = block.fields
        if name in s:
            return s[name]
        return self._scratch(name, (s.num_points, width) if width > 1 else (s.num_points,))

    def _singular(self, block: BlockView, i: int, what: str) -> None:
        gid = int(block.extras["gid"][i]) + 1 if "gid" in block.extras else i + 1
        raise InstabilityError(
            f"{self.name}: the {what} of point {gid} (block {block.name}) is singular: every point needs at least three "
            "neighbors that do not lie in one plane (Peridigm stops here too)",
            collective=False,
        )

    def _where(self, block: BlockView, i: int) -> str:
        """``material 'deck name', point <global id> (block b, x = (..)) at t = ..`` of local point i."""
        path = self.options.get("path") or ()
        label = f"{self.name} {str(path[-1])!r}" if path else self.name
        gid = int(block.extras["gid"][i]) + 1 if "gid" in block.extras else i + 1
        x = block.fields["Model_Coordinates"][i]
        return f"{label}, point {gid} (block {block.name}, x = ({x[0]:.6g}, {x[1]:.6g}, {x[2]:.6g})) at t = {block.time:.6g}"

    # -- the Material contract ----------------------------------------------------------------
    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        lo, hi = block.start, block.stop
        for name in ("Left_Stretch_Tensor", "Rotation_Tensor"):
            s.n(name)[lo:hi] = IDENTITY
            s.np1(name)[lo:hi] = IDENTITY
        for name in ("Unrotated_Cauchy_Stress",) + (("Equivalent_Plastic_Strain",) if self.plastic else ()):
            s.n(name)[lo:hi] = 0.0
            s.np1(name)[lo:hi] = 0.0
        kind, table = self._omega(block)
        bad = shape_tensor_kernel(lo, hi, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Coordinates"], s["Volume"], s["Horizon"],
                                  kind, table, s["Shape_Tensor_Inverse"], s["Deformation_Gradient"], backend=block.backend)
        if bad >= 0:
            self._singular(block, bad, "shape tensor")

    def force_state(self, block: BlockView, T: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        lo, hi = block.start, block.stop
        n = s.num_points
        kind, table = self._omega(block)
        x, y, vol, hz = s["Model_Coordinates"], s["Coordinates"], s["Volume"], s["Horizon"]
        d = self._field_or_scratch(block, "Unrotated_Rate_Of_Deformation")
        bad_k, bad_f = kinematics_kernel(
            lo, hi, nl.offsets, nl.neighbors, x, y, s["Velocity"], vol, hz, kind, table,
            s.n("Left_Stretch_Tensor"), s.n("Rotation_Tensor"), float(block.time_step),
            s["Shape_Tensor_Inverse"], s["Deformation_Gradient"], s.np1("Left_Stretch_Tensor"), s.np1("Rotation_Tensor"), d,
            backend=block.backend,
        )
        if bad_k >= 0:
            self._singular(block, bad_k, "shape tensor")
        if bad_f >= 0:
            self._singular(block, bad_f, "deformation gradient")
        self._update_stress(block, d)
        sigma = self._field_or_scratch(block, "Cauchy_Stress")
        A = self._scratch("A", (n, 9))
        bad = rotate_piola_kernel(lo, hi, s.np1("Rotation_Tensor"), s.np1("Unrotated_Cauchy_Stress"), s["Deformation_Gradient"],
                                  s["Shape_Tensor_Inverse"], sigma, A)
        if bad >= 0:
            self._singular(block, bad, "deformation gradient")
        args = (y, hz, kind, table, A, s["Deformation_Gradient"], float(self.c1))
        compiled(block, BOND_STATES_HOURGLASS if self.c1 != 0.0 else BOND_STATES)(lo, hi, nl.offsets, nl.neighbors, x, x, args, T)
        if "Partial_Stress" in s:
            ps = s["Partial_Stress"]
            ps[lo:hi] = 0.0
            partial_stress_kernel(lo, hi, nl.offsets, nl.neighbors, x, vol, hz, kind, table, A, ps, backend=block.backend)

    def _update_stress(self, block: BlockView, d: np.ndarray) -> None:
        raise NotImplementedError

    # -- implicit tangent ---------------------------------------------------------------------
    def _stress_model(self) -> tuple[int, np.ndarray]:
        """(model id, parameters) of :mod:`.fd_tangent` for this material's stress update."""
        raise NotImplementedError

    def _temperature_change(self, block: BlockView) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros(0), np.zeros(0)

    def tangent(self, block: BlockView, target) -> bool:
        """Peridigm's central finite-difference tangent (§12.3) of the block's points in
        compiled code (:mod:`.fd_tangent`): the same probes, arithmetic and order as the
        solver's Python finite-difference path, without a Python call per probe. Returns False
        (the Python path) only when the probe length cannot be determined."""
        eps = target.probe_length  # the material's own, else the solver's (peridyn.solvers.linalg.tangent)
        if eps is None:
            return False
        import numba

        from .fd_tangent import fd_tangent_kernel

        s, nl = block.fields, block.bonds
        lo, hi = block.start, block.stop
        if hi <= lo:
            return True
        kind, table = self._omega(block)
        model, prm = self._stress_model()
        dT_N, dT_NP1 = self._temperature_change(block)
        dt = float(block.time_step)
        dv = eps / dt if dt > 0 else 0.0
        eqps_N = s.n("Equivalent_Plastic_Strain") if self.plastic else np.zeros(1)  # not read by the elastic model
        pts = np.arange(lo, hi, dtype=np.int64)
        pts = pts[np.argsort(target.eval_rank[pts], kind="stable")]
        workers = max(1, min(int(numba.get_num_threads()), hi - lo))
        M = 3 * (int(target.max_degree) + 1)
        batch = max(workers, min(8 * workers, (64 << 20) // max(1, 8 * M * M)))
        bad, status = fd_tangent_kernel(
            pts, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Coordinates"], s["Velocity"], s["Volume"], s["Horizon"],
            kind, table, s.n("Left_Stretch_Tensor"), s.n("Rotation_Tensor"), s.n("Unrotated_Cauchy_Stress"), eqps_N, dt,
            model, prm, dT_N, dT_NP1, float(self.c1), float(eps), float(dv), int(target.nrows), target.row_of_local,
            target.indptr, target.indices, target.data, int(target.max_degree), workers, batch,
        )
        if bad >= 0:
            self._singular(block, int(bad), "shape tensor" if status == 1 else "deformation gradient")
        return True

    def _vm(self, block: BlockView) -> np.ndarray:
        return self._field_or_scratch(block, "Von_Mises_Stress", 1)


class ElasticCorrespondence(ClassicCorrespondence):
    name = "Elastic Correspondence"
    Params = P.ElasticCorrespondenceParams
    small_strain_limit = SMALL_STRAIN
    #: a free body spun by 20 degrees already gains kinetic energy from its stress update (its
    #: stored energy from work turns negative: -1e-4 of its kinetic energy, 6x more at 360)
    small_rotation_limit = math.radians(15.0)

    def fields(self) -> list[FieldSpec]:
        specs = super().fields()
        if self.params.thermal_expansion_coefficient is not None:
            specs.append(FieldSpec("Temperature_Change", Relation.NODE, Length.SCALAR, TENSOR2))
        return specs

    def _update_stress(self, block: BlockView, d: np.ndarray) -> None:
        s = block.fields
        alpha = self.params.thermal_expansion_coefficient
        if alpha is not None:
            dT_N, dT_NP1, a = s.n("Temperature_Change"), s.np1("Temperature_Change"), float(alpha)
        else:
            dT_N = dT_NP1 = np.zeros(0)
            a = 0.0
        elastic_stress_kernel(block.start, block.stop, d, s.n("Unrotated_Cauchy_Stress"), float(block.time_step), self.K, self.G,
                              dT_N, dT_NP1, a, s.np1("Unrotated_Cauchy_Stress"))

    def _stress_model(self) -> tuple[int, np.ndarray]:
        alpha = self.params.thermal_expansion_coefficient
        return 0, np.array([self.K, self.G, float(alpha) if alpha is not None else 0.0])

    def _temperature_change(self, block: BlockView) -> tuple[np.ndarray, np.ndarray]:
        if self.params.thermal_expansion_coefficient is None:
            return np.zeros(0), np.zeros(0)
        s = block.fields
        return s.n("Temperature_Change"), s.np1("Temperature_Change")


class ElasticPlasticCorrespondence(ClassicCorrespondence):
    name = "Elastic Plastic Correspondence"
    Params = P.ElasticPlasticCorrespondenceParams
    plastic = True

    def _update_stress(self, block: BlockView, d: np.ndarray) -> None:
        s = block.fields
        elastic_plastic_stress_kernel(block.start, block.stop, d, s.n("Unrotated_Cauchy_Stress"), s.n("Equivalent_Plastic_Strain"),
                                      float(block.time_step), self.K, self.G, float(self.params.yield_stress),
                                      s.np1("Unrotated_Cauchy_Stress"), s.np1("Equivalent_Plastic_Strain"), self._vm(block))

    def _stress_model(self) -> tuple[int, np.ndarray]:
        return 1, np.array([self.K, self.G, float(self.params.yield_stress)])


def _flaw_args(params) -> tuple:
    flaw = params.flaw
    return (True, *flaw) if flaw is not None else (False, 0.0, 0.0, 0.0, 1.0, 0.0)


class IsotropicHardeningCorrespondence(ClassicCorrespondence):
    name = "Isotropic Hardening Correspondence"
    Params = P.IsotropicHardeningCorrespondenceParams
    plastic = True

    def _update_stress(self, block: BlockView, d: np.ndarray) -> None:
        s, p = block.fields, self.params
        on, fx, fy, fz, size, mag = _flaw_args(p)
        isotropic_hardening_stress_kernel(
            block.start, block.stop, d, s.n("Unrotated_Cauchy_Stress"), s.n("Equivalent_Plastic_Strain"), float(block.time_step),
            self.K, self.G, float(p.yield_stress), float(p.hardening_modulus), on, s["Model_Coordinates"], fx, fy, fz, size, mag,
            s.np1("Unrotated_Cauchy_Stress"), s.np1("Equivalent_Plastic_Strain"), self._vm(block),
        )

    def _stress_model(self) -> tuple[int, np.ndarray]:
        p = self.params
        on, fx, fy, fz, size, mag = _flaw_args(p)
        return 2, np.array([self.K, self.G, float(p.yield_stress), float(p.hardening_modulus), 1.0 if on else 0.0, fx, fy, fz, size, mag],
                           dtype=np.float64)


class ViscoplasticNeedlemanCorrespondence(ClassicCorrespondence):
    name = "Viscoplastic Needleman Correspondence"
    Params = P.ViscoplasticNeedlemanCorrespondenceParams
    plastic = True

    def _update_stress(self, block: BlockView, d: np.ndarray) -> None:
        s, p = block.fields, self.params
        on, fx, fy, fz, size, mag = _flaw_args(p)
        bad, status, elastic = needleman_stress_kernel(
            block.start, block.stop, d, s.n("Unrotated_Cauchy_Stress"), s.n("Equivalent_Plastic_Strain"), float(block.time_step),
            self.K, self.G, float(p.yield_stress), float(p.strain_hardening_exponent), float(p.rate_hardening_exponent),
            float(p.reference_strain_rate), float(p.reference_strain_0), float(p.reference_strain_1), on, s["Model_Coordinates"],
            fx, fy, fz, size, mag, s.np1("Unrotated_Cauchy_Stress"), s.np1("Equivalent_Plastic_Strain"), self._vm(block),
        )
        if elastic:
            log.debug("%s: the plastic multiplier bisection found no root at %d point(s); they stay elastic this step (as in Peridigm)",
                      self.name, elastic)
        if bad >= 0:
            self._local_failure(block, int(bad), int(status))

    def _local_failure(self, block: BlockView, i: int, status: int) -> None:
        """Stop the run (exit 3) for a point whose stress update failed (status of
        :func:`.stress.needleman_point`), naming the material, the point and its yield stress."""
        p = self.params
        sr = float(p.yield_stress)
        if p.flaw is not None:
            fx, fy, fz, size, mag = p.flaw
            x = block.fields["Model_Coordinates"][i]
            r2 = (x[0] - fx) ** 2 + (x[1] - fy) ** 2 + (x[2] - fz) ** 2
            sr = sr * (1.0 - mag * math.exp(-r2 / size / size))
        if status == NEEDLEMAN_NON_FINITE:
            what = "the stress update gave a non-finite stress or plastic strain"
        else:
            what = f"the plastic multiplier bisection found no root in [0, 1] ({MAX_BISECTION} iterations)"
        raise InstabilityError(
            f"{self._where(block, i)}: {what}; the yield stress there is {sr:.6g}: check 'Yield Stress', the flaw and the "
            "hardening exponents, or shorten the time step", collective=False,
        )

    def _stress_model(self) -> tuple[int, np.ndarray]:
        p = self.params
        on, fx, fy, fz, size, mag = _flaw_args(p)
        return 3, np.array([self.K, self.G, float(p.yield_stress), float(p.strain_hardening_exponent), float(p.rate_hardening_exponent),
                            float(p.reference_strain_rate), float(p.reference_strain_0), float(p.reference_strain_1),
                            1.0 if on else 0.0, fx, fy, fz, size, mag], dtype=np.float64)
