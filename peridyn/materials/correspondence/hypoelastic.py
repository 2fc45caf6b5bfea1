"""Peridigm's hypoelastic correspondence materials: ``Elastic Hypoelastic Correspondence``,
``Elastic Plastic Hypoelastic Correspondence`` and ``Isotropic Hardening Hypoelastic
Correspondence`` (PERIDIGM_CORRESPONDENCE.md §1, §5.2/§5.3/§5.6, §8, §11).

An Eulerian ("updated Lagrangian") non-ordinary state-based family. Each evaluation, before any
block's force (``precompute``): gradient weights φ on the current configuration (a pseudo-inverse
of the moment matrix by Peridigm's SVD), the velocity gradient L_i = Σ_j (Δv ⊗ φ) V'_j with
volumes V'_j = J_N,j V_j, the Jacobian J_NP1 = J_N (1 + tr L dt) and the weighted volume m0_i;
L, m0 and J are exchanged to the ghosts. Then per block (``force_state``): a velocity gradient per
bond (L̄ corrected along the bond), the Flanagan-Taylor update of a stretch and rotation per bond,
the stress update per bond (unrotated), the non-homogeneity integral and the force state
T_b = (J_N,i T) J_N,j of every bond. The node-level kinematics and stresses (Left_Stretch_Tensor,
Cauchy_Stress, ...) are outputs only: they never enter the force.

Horizons: the neighbor lists come from the block's ``Horizon``; the Horizon field of the block's
points is overwritten with ``Actual Horizon`` δa, which every formula uses (ω(|η|, δa) at the
deformed length; with the default influence function ``One`` nothing is cut off at δa).
"""
from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from pydantic import Field, field_validator, model_validator

from ...core.errors import InputError
from ...core.fields import FieldSpec, Length, Relation, Temporal
from ...core.influence import TABLE
from ...core.interfaces import BlockView, ElasticModuli, Material
from ...kernels import compiled
from ..moduli import bulk_and_shear, isotropic_moduli
from . import hypoelastic_kernels as HK
from .params import CorrespondenceBaseParams

TWO = Temporal.TWO_STEP
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0])
EMPTY1 = np.zeros(0)
EMPTY9 = np.zeros((0, 9))

#: the node-level deformation gradient F_NP1 = F_N + L F_N dt (behind Green_Lagrange_Strain). Not
#: "Deformation_Gradient": that name belongs to the compute class (recomputed from the shape
#: tensor), and Peridigm refuses the combination (a field registered twice, §11)
DEFORMATION_GRADIENT = "Rate_Form_Deformation_Gradient"


# ------------------------------------------------------------------------------------------------
# parameters (§1)
# ------------------------------------------------------------------------------------------------
class HypoelasticParams(CorrespondenceBaseParams):
    """Density, two elastic constants, ``Actual Horizon`` and the gradient order."""

    actual_horizon: float = Field(
        alias="Actual Horizon", gt=0,
        description="horizon delta_a used by the model (L); the block's Horizon only builds the (larger) neighbor lists",
    )
    gradient_order_of_accuracy: int = Field(
        1, alias="Gradient Order Of Accuracy", description="order of the gradient approximation; only 1 is implemented",
    )

    #: read by the classic family only; Peridigm ignores it here
    ignored_keys: ClassVar[frozenset[str]] = frozenset({"Hourglass Coefficient"})

    @model_validator(mode="before")
    @classmethod
    def _no_thermal(cls, data: Any) -> Any:
        if isinstance(data, dict) and "Thermal Expansion Coefficient" in data:
            raise ValueError("'Thermal Expansion Coefficient' is not supported by the hypoelastic correspondence materials "
                             "(Peridigm refuses it too); remove it")
        return data

    @field_validator("gradient_order_of_accuracy")
    @classmethod
    def _order_one(cls, value: int) -> int:
        if value != 1:
            raise ValueError(f"'Gradient Order Of Accuracy' = {value} is not implemented (only 1; higher orders are unverified "
                             "against Peridigm); use 1")
        return value


class ElasticPlasticHypoelasticParams(HypoelasticParams):
    yield_stress: float = Field(alias="Yield Stress", gt=0, description="(initial) yield stress sigma_y of J2 plasticity (Pa in SI)")


class IsotropicHardeningHypoelasticParams(ElasticPlasticHypoelasticParams):
    """Power-law hardening: yield stress sigma_y (1 + eqps/eps_c)^n."""

    hardening_characteristic_strain: float = Field(
        alias="Hardening Characteristic Strain", gt=0, description="eps_c of the power law (-)",
    )
    hardening_exponent: float = Field(alias="Hardening Exponent", description="n of the power law (-)")


# ------------------------------------------------------------------------------------------------
# the family (§8)
# ------------------------------------------------------------------------------------------------
class HypoelasticCorrespondence(Material):
    """The family's sequence; subclasses choose the stress model (§5.8)."""

    Params: ClassVar[type] = HypoelasticParams
    force_state_kind = "vector"
    ghost_inputs = ("Velocity",)  # velocity gradients read the neighbors' velocities
    #: what the other end of a bond reads after precompute (Peridigm's synchronizeDataAfterPrecompute)
    precompute_fields = ("Velocity_Gradient", "Undamaged_Weighted_Volume", "Jacobian_Determinant")
    requires_constant_horizon = False  # every formula uses Actual Horizon
    tangent_perturbs_velocity = True  # Peridigm's finite-difference probe moves v by eps/dt too
    model: ClassVar[int] = HK.ELASTIC

    def __init__(self, params, *, horizon: float | None, options: dict[str, Any] | None = None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        self.K, self.G = bulk_and_shear(params.bulk_modulus, params.shear_modulus, params.youngs_modulus, params.poissons_ratio,
                                        plane_strain=params.plane_strain, plane_stress=params.plane_stress)
        self.table = EMPTY1
        self._d: np.ndarray | None = None
        self._N: np.ndarray | None = None

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

    @property
    def plastic(self) -> bool:
        return self.model != HK.ELASTIC

    def _stress_args(self) -> tuple[float, float, float]:
        return 0.0, 1.0, 0.0  # sigma_y, eps_c, n

    # -- fields --------------------------------------------------------------------------------
    def fields(self) -> list[FieldSpec]:
        T9, B = Length.TENSOR, Relation.BOND
        specs = [
            FieldSpec("Horizon", Relation.ELEMENT),
            FieldSpec("Velocity_Gradient", Relation.ELEMENT, T9, units="1/T"),
            FieldSpec("Jacobian_Determinant", Relation.ELEMENT, Length.SCALAR, TWO),
            FieldSpec("Undamaged_Weighted_Volume", Relation.ELEMENT, units="L^3"),
            FieldSpec("Left_Stretch_Tensor", Relation.ELEMENT, T9, TWO),
            FieldSpec("Rotation_Tensor", Relation.ELEMENT, T9, TWO),
            FieldSpec("Unrotated_Cauchy_Stress", Relation.ELEMENT, T9, TWO),
            FieldSpec(DEFORMATION_GRADIENT, Relation.ELEMENT, T9, TWO),
            FieldSpec("Gradient_Weight", B, Length.VECTOR),
            FieldSpec("Bond_Left_Stretch_Tensor", B, T9, TWO),
            FieldSpec("Bond_Rotation_Tensor", B, T9, TWO),
            FieldSpec("Bond_Unrotated_Cauchy_Stress", B, T9, TWO),
        ]
        if self.plastic:
            specs += [
                FieldSpec("Equivalent_Plastic_Strain", Relation.ELEMENT, Length.SCALAR, TWO),
                FieldSpec("Bond_Equivalent_Plastic_Strain", B, Length.SCALAR, TWO),
            ]
        return specs

    def output_fields(self) -> list[FieldSpec]:
        T9 = Length.TENSOR
        specs = [
            FieldSpec("Unrotated_Rate_Of_Deformation", Relation.ELEMENT, T9),
            FieldSpec("Cauchy_Stress", Relation.ELEMENT, T9, TWO),
            FieldSpec("Von_Mises_Stress", Relation.ELEMENT),
            FieldSpec("Green_Lagrange_Strain", Relation.ELEMENT, T9),
            FieldSpec("Weighted_Volume", Relation.ELEMENT),
            FieldSpec("Nonhomogeneous_Integral", Relation.ELEMENT, T9),
        ] + [FieldSpec(f"Velocity_Gradient_{c}", Relation.ELEMENT, Length.VECTOR) for c in "XYZ"]
        if self.plastic:
            specs.append(FieldSpec("Stress_Triaxiality", Relation.ELEMENT))
        return specs

    # -- helpers -------------------------------------------------------------------------------
    def _optional(self, block: BlockView, name: str, empty: np.ndarray) -> np.ndarray:
        return block.fields.get(name, empty)

    def _bond_damage(self, block: BlockView) -> np.ndarray:
        s = block.fields
        return s.n("Bond_Damage") if "Bond_Damage" in s else EMPTY1

    def _update_table(self, block: BlockView) -> None:
        """ω at the deformed lengths of the block's bonds, for an expression influence function."""
        inf = block.influence
        if inf is None or inf.kind != TABLE:
            self.table = EMPTY1
            return
        s, nl = block.fields, block.bonds
        lengths = np.zeros(nl.num_bonds)
        x, y = s["Model_Coordinates"], s["Coordinates"]
        compiled(block, HK.DEFORMED_LENGTH)(block.start, block.stop, nl.offsets, nl.neighbors, x, y, (), lengths)
        self.table = inf.evaluate(lengths[int(nl.offsets[block.start]) : int(nl.offsets[block.stop])], float(self.params.actual_horizon))

    # -- the Material contract -----------------------------------------------------------------
    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        lo, hi = block.start, block.stop
        if "Deformation_Gradient" in s:
            raise InputError(
                f"{self.name!r} cannot be combined with the Deformation_Gradient output or with a classic correspondence block "
                "(Peridigm refuses this field clash too)",
                path=tuple(self.options.get("path", ())),
                fix="output Velocity_Gradient or Green_Lagrange_Strain instead",
            )
        s["Horizon"][lo:hi] = float(self.params.actual_horizon)
        # every local row, ghosts included: the first precompute reads the neighbors' J_N
        s.n("Jacobian_Determinant")[:] = 1.0
        s.np1("Jacobian_Determinant")[:] = 1.0
        for name in ("Left_Stretch_Tensor", "Rotation_Tensor", DEFORMATION_GRADIENT):
            s.n(name)[lo:hi] = IDENTITY
            s.np1(name)[lo:hi] = IDENTITY
        s["Velocity_Gradient"][lo:hi] = 0.0
        s["Undamaged_Weighted_Volume"][lo:hi] = 0.0
        s.n("Unrotated_Cauchy_Stress")[lo:hi] = 0.0
        s.np1("Unrotated_Cauchy_Stress")[lo:hi] = 0.0
        for name in ("Cauchy_Stress", "Equivalent_Plastic_Strain"):
            if name in s:
                s.n(name)[lo:hi] = 0.0
                s.np1(name)[lo:hi] = 0.0
        for name in ("Von_Mises_Stress", "Stress_Triaxiality", "Unrotated_Rate_Of_Deformation", "Green_Lagrange_Strain", "Weighted_Volume",
                     "Nonhomogeneous_Integral"):
            if name in s:
                s[name][lo:hi] = 0.0
        b0, b1 = int(nl.offsets[lo]), int(nl.offsets[hi])
        s["Gradient_Weight"][b0:b1] = 0.0
        for name in ("Bond_Left_Stretch_Tensor", "Bond_Rotation_Tensor"):
            s.n(name)[b0:b1] = IDENTITY
            s.np1(name)[b0:b1] = IDENTITY
        for name in ("Bond_Unrotated_Cauchy_Stress", "Bond_Equivalent_Plastic_Strain", "Bond_Damage"):
            if name in s:
                s.n(name)[b0:b1] = 0
                s.np1(name)[b0:b1] = 0

    def precompute(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        lo, hi = block.start, block.stop
        self._update_table(block)
        kind = block.influence.kind if block.influence is not None else 0
        HK.precompute_kernel(
            lo, hi, nl.offsets, nl.neighbors, s["Coordinates"], s["Velocity"], s["Volume"], s["Horizon"], s.n("Jacobian_Determinant"),
            self._bond_damage(block), kind, self.table, float(block.time_step), s["Gradient_Weight"], s["Velocity_Gradient"],
            s.np1("Jacobian_Determinant"), s["Undamaged_Weighted_Volume"], self._optional(block, "Weighted_Volume", EMPTY1),
            backend=block.backend, x=s["Model_Coordinates"],
        )
        L = s["Velocity_Gradient"]
        for r, c in enumerate("XYZ"):
            name = f"Velocity_Gradient_{c}"
            if name in s:
                s[name][lo:hi] = L[lo:hi, 3 * r : 3 * r + 3]

    def force_state(self, block: BlockView, T: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        lo, hi = block.start, block.stop
        dt = float(block.time_step)
        kind = block.influence.kind if block.influence is not None else 0
        sy, ec, n = self._stress_args()
        eb_N, eb_NP1 = (s.n("Bond_Equivalent_Plastic_Strain"), s.np1("Bond_Equivalent_Plastic_Strain")) if self.plastic else (EMPTY1, EMPTY1)
        b0 = int(nl.offsets[lo]) if hi > lo else 0
        N = s["Nonhomogeneous_Integral"] if "Nonhomogeneous_Integral" in s else self._scratch(s.num_points)
        force = (
            s["Velocity"], s["Volume"], s["Horizon"], s.n("Jacobian_Determinant"), self._bond_damage(block), kind, self.table, b0, dt,
            s["Velocity_Gradient"], s["Undamaged_Weighted_Volume"], s["Gradient_Weight"],
            s.n("Bond_Left_Stretch_Tensor"), s.n("Bond_Rotation_Tensor"), s.n("Bond_Unrotated_Cauchy_Stress"), eb_N,
            self.model, self.K, self.G, sy, ec, n,
            s.np1("Bond_Left_Stretch_Tensor"), s.np1("Bond_Rotation_Tensor"), s.np1("Bond_Unrotated_Cauchy_Stress"), eb_NP1, N,
        )
        x, y = s["Model_Coordinates"], s["Coordinates"]
        compiled(block, HK.BOND_STRESS)(lo, hi, nl.offsets, nl.neighbors, x, y, force, N)
        compiled(block, HK.BOND_FORCE)(lo, hi, nl.offsets, nl.neighbors, x, y, force, T)
        # node level: outputs only (the force never reads them)
        gl = "Green_Lagrange_Strain" in s
        e_N, e_NP1 = (s.n("Equivalent_Plastic_Strain"), s.np1("Equivalent_Plastic_Strain")) if self.plastic else (EMPTY1, EMPTY1)
        d = s["Unrotated_Rate_Of_Deformation"] if "Unrotated_Rate_Of_Deformation" in s else self._scratch_d(s.num_points)
        HK.node_kernel(
            lo, hi, s["Velocity_Gradient"], dt, s.n(DEFORMATION_GRADIENT), s.np1(DEFORMATION_GRADIENT),
            s["Green_Lagrange_Strain"] if gl else EMPTY9,
            s.n("Left_Stretch_Tensor"), s.n("Rotation_Tensor"), s.np1("Left_Stretch_Tensor"), s.np1("Rotation_Tensor"), d,
            s.n("Unrotated_Cauchy_Stress"), s.np1("Unrotated_Cauchy_Stress"), self._optional(block, "Cauchy_Stress", EMPTY9),
            e_N, e_NP1, self._optional(block, "Von_Mises_Stress", EMPTY1), self._optional(block, "Stress_Triaxiality", EMPTY1),
            self.model, self.K, self.G, sy, ec, n,
        )

    def tangent(self, block: BlockView, target) -> bool:
        """Peridigm's central finite-difference tangent (§12.3) in compiled code
        (:mod:`.fd_tangent_rate`): the probes and arithmetic of the solver's Python path, bit for
        bit. An expression influence function (ω at deformed lengths, re-tabulated per probe)
        keeps the Python path (returns False)."""
        inf = block.influence
        eps = target.probe_length
        if eps is None or (inf is not None and inf.kind == TABLE):
            return False
        import numba

        from . import fd_tangent_rate as FR

        s, nl = block.fields, block.bonds
        lo, hi = block.start, block.stop
        if hi <= lo:
            return True
        eps = float(eps)
        dt = float(block.time_step)
        dv = eps / dt if dt > 0 else 0.0
        kind = inf.kind if inf is not None else 0
        sy, ec, nexp = self._stress_args()
        eb_N, eb_NP1 = (s.n("Bond_Equivalent_Plastic_Strain"), s.np1("Bond_Equivalent_Plastic_Strain")) if self.plastic else (EMPTY1, EMPTY1)
        pts = np.arange(lo, hi, dtype=np.int64)
        pts = pts[np.argsort(target.eval_rank[pts], kind="stable")]
        W, batch, M = FR.batching(hi - lo, target.max_degree, numba.get_num_threads())
        y, v, L, m0, phi = s["Coordinates"], s["Velocity"], s["Velocity_Gradient"], s["Undamaged_Weighted_Volume"], s["Gradient_Weight"]
        ys, vs = np.repeat(y[None], W, axis=0), np.repeat(v[None], W, axis=0)
        Ls, m0s = np.repeat(L[None], W, axis=0), np.repeat(m0[None], W, axis=0)
        Js = np.zeros((W, y.shape[0]))
        phi0 = phi.copy()
        T = np.zeros((nl.num_bonds, 3))
        Fps, Fms = np.empty((W, M)), np.empty((W, M))
        Kbuf = np.empty((batch, M * M))
        for k0 in range(0, pts.shape[0], batch):
            k1 = min(k0 + batch, pts.shape[0])
            FR.hypo_blocks(
                pts, k0, k1, nl.offsets, nl.neighbors, ys, vs, s["Volume"], s["Horizon"], s.n("Jacobian_Determinant"),
                self._bond_damage(block), kind, self.table, dt, eps, dv, L, m0, Ls, m0s, phi, phi0, Js,
                s.n("Bond_Left_Stretch_Tensor"), s.n("Bond_Rotation_Tensor"), s.n("Bond_Unrotated_Cauchy_Stress"), eb_N,
                self.model, self.K, self.G, sy, ec, nexp,
                s.np1("Bond_Left_Stretch_Tensor"), s.np1("Bond_Rotation_Tensor"), s.np1("Bond_Unrotated_Cauchy_Stress"), eb_NP1,
                T, Fps, Fms, Kbuf,
            )
            FR.scatter_batch(pts, k0, k1, W, nl.offsets, nl.neighbors, int(target.nrows), target.row_of_local, Kbuf,
                             target.indptr, target.indices, target.data)
        return True

    def _scratch_d(self, n: int) -> np.ndarray:
        d = self._d
        if d is None or d.shape[0] != n:
            d = self._d = np.zeros((n, 9))
        return d

    def _scratch(self, n: int) -> np.ndarray:
        """(n, 9) scratch for the non-homogeneity integrals when Nonhomogeneous_Integral is not output."""
        N = self._N
        if N is None or N.shape[0] != n:
            N = self._N = np.zeros((n, 9))
        return N


class ElasticHypoelasticCorrespondence(HypoelasticCorrespondence):
    name = "Elastic Hypoelastic Correspondence"
    Params = HypoelasticParams
    model = HK.ELASTIC


class ElasticPlasticHypoelasticCorrespondence(HypoelasticCorrespondence):
    name = "Elastic Plastic Hypoelastic Correspondence"
    Params = ElasticPlasticHypoelasticParams
    model = HK.PERFECTLY_PLASTIC

    def _stress_args(self) -> tuple[float, float, float]:
        return float(self.params.yield_stress), 1.0, 0.0


class IsotropicHardeningHypoelasticCorrespondence(HypoelasticCorrespondence):
    name = "Isotropic Hardening Hypoelastic Correspondence"
    Params = IsotropicHardeningHypoelasticParams
    model = HK.POWER_LAW

    def _stress_args(self) -> tuple[float, float, float]:
        p = self.params
        return float(p.yield_stress), float(p.hardening_characteristic_strain), float(p.hardening_exponent)
