"""Peridigm's bond-associated correspondence materials: ``Elastic Bond Associated
Correspondence``, ``Elastic Plastic Bond Associated Correspondence`` and ``Isotropic Hardening
Bond Associated Correspondence`` (PERIDIGM_CORRESPONDENCE.md §1, §5.2/§5.3/§5.7, §8.2, §9-§11).

A Lagrangian formulation with one deformation gradient per bond. ``initialize`` computes the
influence state ω_ij = ω(|ξ|, δ_i)(1 - d_ij), the gradient weights φ_ij (moment matrix and its
pseudo-inverse, §8.2) and the weighted volume m_i = Σ ω_ij V_j, which is never updated.
``precompute`` re-derives ω and φ where the point damage grew, then the node deformation gradient
F = I + Σ (Δu ⊗ φ) V_j and its rate Ḟ from the displacements and velocities (exchanged to
ghosts). ``force_state`` builds, per bond with ω > 0, F_b = F̄ + ((η - F̄ξ) ⊗ ξ)/|ξ|² with
F̄ = ½(F_i + F_j) (Ḟ_b likewise with Δv), the Flanagan-Taylor update of the bond's own V, R,
the stress update of the model on the bond's own stress history, P_b = J_b σ_b F_b⁻ᵀ, the stress
integral 𝒮_i = Σ ω (0.5/m_i + 0.5/m_j) V_j P_b (I - ξ⊗ξ/|ξ|²) and the vector force state

    T(i→j) = (ω/m_i) P_b ξ/|ξ|² + 𝒮_i φ_ij.

The node-level quantities (Left_Stretch_Tensor, Rotation_Tensor, Unrotated_Rate_Of_Deformation,
Unrotated_Cauchy_Stress, Cauchy_Stress, Von_Mises_Stress, Equivalent_Plastic_Strain,
Stress_Triaxiality, Green_Lagrange_Strain) come from the node F and Ḟ with the same routines and
are outputs only: the force uses the bond quantities. The kernels are in
:mod:`.bond_associated_kernels` (loop laws run by the block's backend; the finite-difference
tangent, :mod:`.fd_tangent_rate`, stays hand-written).
"""
from __future__ import annotations

from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field, model_validator

from ...core.errors import InstabilityError
from ...core.fields import FieldSpec, Length, Relation, Temporal
from ...core.interfaces import BlockView, ElasticModuli, Material
from ...core.params import ModelParams, ParamKeyError, UsedWhen
from ..moduli import bulk_and_shear, isotropic_moduli
from . import bond_associated_kernels as kern
from . import bond_associated_gradients as grad
from .params import CorrespondenceBaseParams

TWO = Temporal.TWO_STEP
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0])
F_ROWS = ("Deformation_Gradient_X", "Deformation_Gradient_Y", "Deformation_Gradient_Z")
FDOT_ROWS = ("Deformation_Gradient_Dot_X", "Deformation_Gradient_Dot_Y", "Deformation_Gradient_Dot_Z")
BOND_TENSORS = ("Bond_Left_Stretch_Tensor", "Bond_Rotation_Tensor", "Bond_Unrotated_Cauchy_Stress")
EMPTY = np.zeros(0)
EMPTY9 = np.zeros((0, 9))


# ------------------------------------------------------------------------------------------------
# parameters (§1)
# ------------------------------------------------------------------------------------------------
class BondAssociatedParams(CorrespondenceBaseParams):
    """Density, two elastic constants, the gradient order. ``Hourglass Coefficient`` is accepted
    and ignored (this family has no hourglass force); thermal expansion is refused, as in Peridigm."""

    gradient_order: int = Field(
        1, alias="Gradient Order Of Accuracy", description="order of the polynomial reproduced by the gradient weights (only 1 is supported)"
    )
    ignored_keys = frozenset({"Hourglass Coefficient"})

    @model_validator(mode="before")
    @classmethod
    def _no_thermal(cls, data: Any) -> Any:
        if isinstance(data, dict) and "Thermal Expansion Coefficient" in data:
            raise ValueError("'Thermal Expansion Coefficient' is not supported by the bond-associated correspondence materials "
                             "(Peridigm refuses it too); remove it")
        return data

    @model_validator(mode="after")
    def _order(self):
        if self.gradient_order != 1:
            raise ValueError(f"'Gradient Order Of Accuracy' = {self.gradient_order} is not supported: only 1 is implemented "
                             "(higher orders are not validated against Peridigm); write 1 or leave it out")
        return self


class ElasticPlasticBondAssociatedParams(BondAssociatedParams):
    yield_stress: float = Field(alias="Yield Stress", gt=0, description="yield stress sigma_y of J2 perfect plasticity (Pa in SI)")


HARDENING_KEYS = {
    "Power-law": (("yield_stress", "Yield Stress"), ("hardening_characteristic_strain", "Hardening Characteristic Strain"),
                  ("hardening_exponent", "Hardening Exponent")),
    "Saturation type exponential": (("initial_yield_stress", "Initial Yield Stress"), ("saturated_yield_stress", "Saturated Yield Stress"),
                                    ("exponential_constant", "Exponential Constant"), ("linear_constant", "Linear Constant")),
}


#: ranges of the hardening constants, checked for the keys of the chosen 'Hardening Rule' only
HARDENING_RANGES = {
    "yield_stress": UsedWhen(lambda p: True, "'Hardening Rule' is 'Power-law'", gt=0),
    "hardening_characteristic_strain": UsedWhen(lambda p: True, "'Hardening Rule' is 'Power-law'", gt=0),
    "initial_yield_stress": UsedWhen(lambda p: True, "'Hardening Rule' is 'Saturation type exponential'", gt=0),
    "saturated_yield_stress": UsedWhen(lambda p: True, "'Hardening Rule' is 'Saturation type exponential'", gt=0),
    "exponential_constant": UsedWhen(lambda p: True, "'Hardening Rule' is 'Saturation type exponential'", ge=0),
}


class HardeningParameters(ModelParams):
    """The ``Hardening Parameters`` sublist: the keys of the chosen ``Hardening Rule``."""

    yield_stress: float | None = Field(None, alias="Yield Stress", description="Power-law: initial yield stress sigma_y (Pa in SI)")
    hardening_characteristic_strain: float | None = Field(
        None, alias="Hardening Characteristic Strain", description="Power-law: eps_c of sigma_y (1 + eqps/eps_c)^n"
    )
    hardening_exponent: float | None = Field(None, alias="Hardening Exponent", description="Power-law: exponent n")
    initial_yield_stress: float | None = Field(None, alias="Initial Yield Stress", description="Saturation: sigma_0 (Pa in SI)")
    saturated_yield_stress: float | None = Field(None, alias="Saturated Yield Stress", description="Saturation: sigma_inf (Pa in SI)")
    exponential_constant: float | None = Field(None, alias="Exponential Constant", description="Saturation: beta (-)")
    linear_constant: float | None = Field(None, alias="Linear Constant", description="Saturation: linear hardening modulus h (Pa in SI)")


class IsotropicHardeningBondAssociatedParams(BondAssociatedParams):
    """Hardening curve sigma_y (1 + e/eps_c)^n (``Power-law``) or sigma_0 + (sigma_inf - sigma_0)
    (1 - exp(-beta e)) + h e (``Saturation type exponential``) of the equivalent plastic strain e."""

    hardening_rule: Literal["Power-law", "Saturation type exponential"] = Field(alias="Hardening Rule", description="the hardening curve")
    hardening_parameters: HardeningParameters = Field(alias="Hardening Parameters", description="the constants of the hardening rule")

    @model_validator(mode="after")
    def _rule_keys(self):
        hp = self.hardening_parameters
        missing = [alias for name, alias in HARDENING_KEYS[self.hardening_rule] if getattr(hp, name) is None]
        if missing:
            raise ValueError(f"'Hardening Rule' {self.hardening_rule!r} needs {', '.join(repr(m) for m in missing)} "
                             "in 'Hardening Parameters'")
        for name, alias in HARDENING_KEYS[self.hardening_rule]:  # only the chosen rule's keys are read
            rule = HARDENING_RANGES.get(name)
            problem = rule.problem(getattr(hp, name)) if rule else None
            if problem:
                raise ParamKeyError(("Hardening Parameters", alias), f"{alias!r} {problem}")
        return self

    def curve(self) -> tuple[int, float, float, float, float]:
        """(model code, p0, p1, p2, p3) of :mod:`.bond_associated_kernels`."""
        hp = self.hardening_parameters
        if self.hardening_rule == "Power-law":
            return kern.POWER_LAW, float(hp.yield_stress), float(hp.hardening_characteristic_strain), float(hp.hardening_exponent), 0.0
        return (kern.SATURATION, float(hp.initial_yield_stress), float(hp.saturated_yield_stress), float(hp.exponential_constant),
                float(hp.linear_constant))


# ------------------------------------------------------------------------------------------------
# the family
# ------------------------------------------------------------------------------------------------
class BondAssociatedCorrespondence(Material):
    """The family's sequence (§9); subclasses choose the stress update through ``curve``."""

    Params: ClassVar[type] = BondAssociatedParams
    force_state_kind = "vector"
    ghost_inputs = ("Velocity", "Displacement")  # F and Ḟ of a point read its neighbours' u and v
    precompute_fields = F_ROWS + FDOT_ROWS  # F_b averages both ends' node F and Ḟ
    requires_constant_horizon = False  # the per-point Horizon field is used
    tangent_perturbs_velocity = True  # Peridigm's finite-difference probe moves v by eps/dt too
    plastic: ClassVar[bool] = False

    def __init__(self, params, *, horizon: float | None, options: dict[str, Any] | None = None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        self.K, self.G = bulk_and_shear(params.bulk_modulus, params.shear_modulus, params.youngs_modulus, params.poissons_ratio,
                                        plane_strain=params.plane_strain, plane_stress=params.plane_stress)
        self._work: dict[str, np.ndarray] = {}
        self.omega_table: np.ndarray | None = None

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

    def curve(self) -> tuple[int, float, float, float, float]:
        """(model code, p0, p1, p2, p3) of the stress update (see the kernels module)."""
        return kern.ELASTIC, 0.0, 0.0, 0.0, 0.0

    def fields(self) -> list[FieldSpec]:
        specs = [
            FieldSpec("Horizon", Relation.ELEMENT),
            FieldSpec("Weighted_Volume", Relation.ELEMENT, halo=True, units="L^3"),
            FieldSpec("Influence_State", Relation.BOND),
            FieldSpec("Gradient_Weight", Relation.BOND, Length.VECTOR, units="L^-3"),
            *(FieldSpec(name, Relation.ELEMENT, Length.VECTOR) for name in F_ROWS + FDOT_ROWS),
            FieldSpec("Left_Stretch_Tensor", Relation.ELEMENT, Length.TENSOR, TWO),
            FieldSpec("Rotation_Tensor", Relation.ELEMENT, Length.TENSOR, TWO),
            FieldSpec("Unrotated_Cauchy_Stress", Relation.ELEMENT, Length.TENSOR, TWO),
            *(FieldSpec(name, Relation.BOND, Length.TENSOR, TWO) for name in BOND_TENSORS),
        ]
        if self.plastic:
            specs.append(FieldSpec("Equivalent_Plastic_Strain", Relation.ELEMENT, Length.SCALAR, TWO))
            specs.append(FieldSpec("Bond_Equivalent_Plastic_Strain", Relation.BOND, Length.SCALAR, TWO))
        return specs

    def output_fields(self) -> list[FieldSpec]:
        specs = [
            FieldSpec("Unrotated_Rate_Of_Deformation", Relation.ELEMENT, Length.TENSOR),
            FieldSpec("Cauchy_Stress", Relation.ELEMENT, Length.TENSOR, TWO),
            FieldSpec("Von_Mises_Stress", Relation.ELEMENT),
            FieldSpec("Green_Lagrange_Strain", Relation.ELEMENT, Length.TENSOR, TWO),
        ]
        if self.plastic:
            specs.append(FieldSpec("Stress_Triaxiality", Relation.ELEMENT))
        return specs

    # -- helpers ------------------------------------------------------------------------------
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

    def _omega(self, block: BlockView) -> tuple[int, np.ndarray]:
        inf = block.influence
        if inf.needs_table and self.omega_table is None:
            s, nl = block.fields, block.bonds
            self.omega_table = inf.table_for(nl.offsets, nl.neighbors, s["Model_Coordinates"], np.arange(block.start, block.stop), s["Horizon"])
        return inf.kind, self.omega_table if self.omega_table is not None else EMPTY

    def _fail(self, block: BlockView, i: int, code: int) -> None:
        gid = int(block.extras["gid"][i]) + 1 if "gid" in block.extras else i + 1
        where = f"point {gid} (block {block.name})"
        if code == kern.NO_CONVERGENCE:
            path = self.options.get("path") or ()
            label = f"{self.name} {str(path[-1])!r}" if path else self.name
            x = block.fields["Model_Coordinates"][i]
            raise InstabilityError(f"{label}: the plastic radial return did not converge in {kern.MAX_NEWTON} Newton iterations (or its "
                                   f"residual is not finite) at {where}, x = ({x[0]:.6g}, {x[1]:.6g}, {x[2]:.6g}), t = {block.time:.6g} "
                                   "(Peridigm aborts the run here too)", collective=False)
        what = "deformation gradient" if code == kern.SINGULAR_NODE_F else "deformation gradient of a bond"
        raise InstabilityError(f"{self.name}: the {what} of {where} is singular: every point needs at least three neighbors "
                               "that do not lie in one plane (Peridigm stops here too)", collective=False)

    # -- the Material contract ----------------------------------------------------------------
    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        lo, hi = block.start, block.stop
        b0, b1 = int(nl.offsets[lo]), int(nl.offsets[hi])
        for name in ("Left_Stretch_Tensor", "Rotation_Tensor"):
            s.n(name)[lo:hi] = IDENTITY
            s.np1(name)[lo:hi] = IDENTITY
        for name in ("Bond_Left_Stretch_Tensor", "Bond_Rotation_Tensor"):
            s.n(name)[b0:b1] = IDENTITY
            s.np1(name)[b0:b1] = IDENTITY
        for name in ("Unrotated_Cauchy_Stress", "Cauchy_Stress", "Green_Lagrange_Strain", "Damage") + (
                ("Equivalent_Plastic_Strain",) if self.plastic else ()):
            if name in s:
                s.n(name)[lo:hi] = 0.0
                s.np1(name)[lo:hi] = 0.0
        for name in ("Bond_Unrotated_Cauchy_Stress", "Bond_Damage") + (("Bond_Equivalent_Plastic_Strain",) if self.plastic else ()):
            if name in s:
                s.n(name)[b0:b1] = 0.0
                s.np1(name)[b0:b1] = 0.0
        for name in ("Unrotated_Rate_Of_Deformation", "Von_Mises_Stress", "Stress_Triaxiality", *F_ROWS, *FDOT_ROWS):
            if name in s:
                s[name][lo:hi] = 0.0
        kind, table = self._omega(block)
        grad.initialize_kernel(lo, hi, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Volume"], s["Horizon"], kind, table,
                               s.get("Bond_Damage", EMPTY), s["Influence_State"], s["Gradient_Weight"],
                               s["Weighted_Volume"], backend=block.backend)

    def precompute(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        kind, table = self._omega(block)
        damaged = "Damage" in s and "Bond_Damage" in s
        grad.precompute_kernel(
            block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Volume"], s["Horizon"], kind, table,
            s.n("Damage") if damaged else EMPTY, s["Damage"] if damaged else EMPTY, s["Bond_Damage"] if damaged else EMPTY,
            s["Influence_State"], s["Gradient_Weight"], s["Displacement"], s["Velocity"], *(s[name] for name in F_ROWS + FDOT_ROWS),
            backend=block.backend,
        )

    def force_state(self, block: BlockView, T: np.ndarray) -> None:
        s, nl = block.fields, block.bonds
        model, p0, p1, p2, p3 = self.curve()
        plastic = self.plastic
        green = "Green_Lagrange_Strain" in s
        bad, code = kern.force_kernel(
            block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Coordinates"], s["Velocity"], s["Volume"],
            s["Weighted_Volume"], s["Influence_State"], s["Gradient_Weight"], *(s[name] for name in F_ROWS + FDOT_ROWS),
            s.n("Left_Stretch_Tensor"), s.n("Rotation_Tensor"), s.np1("Left_Stretch_Tensor"), s.np1("Rotation_Tensor"),
            self._field_or_scratch(block, "Unrotated_Rate_Of_Deformation"),
            s.n("Unrotated_Cauchy_Stress"), s.np1("Unrotated_Cauchy_Stress"), self._field_or_scratch(block, "Cauchy_Stress"),
            self._field_or_scratch(block, "Von_Mises_Stress", 1),
            self._field_or_scratch(block, "Stress_Triaxiality", 1) if plastic else EMPTY,
            s.n("Equivalent_Plastic_Strain") if plastic else EMPTY, s.np1("Equivalent_Plastic_Strain") if plastic else EMPTY,
            s.n("Green_Lagrange_Strain") if green else EMPTY9, s.np1("Green_Lagrange_Strain") if green else EMPTY9,
            s.n("Bond_Left_Stretch_Tensor"), s.n("Bond_Rotation_Tensor"), s.np1("Bond_Left_Stretch_Tensor"), s.np1("Bond_Rotation_Tensor"),
            s.n("Bond_Unrotated_Cauchy_Stress"), s.np1("Bond_Unrotated_Cauchy_Stress"),
            s.n("Bond_Equivalent_Plastic_Strain") if plastic else EMPTY, s.np1("Bond_Equivalent_Plastic_Strain") if plastic else EMPTY,
            model, float(self.K), float(self.G), p0, p1, p2, p3, float(block.time_step), self._scratch("Piola", (nl.num_bonds, 9)), T,
            backend=block.backend, S=self._scratch("Stress_Integral", (s.num_points, 9)),
        )
        if bad >= 0:
            self._fail(block, int(bad), int(code))


    def tangent(self, block: BlockView, target) -> bool:
        """Peridigm's central finite-difference tangent (§12.3) in compiled code
        (:mod:`.fd_tangent_rate`): the probes and arithmetic of the solver's Python path, bit
        for bit."""
        eps = target.probe_length
        if eps is None:
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
        kind, table = self._omega(block)
        model, p0, p1, p2, p3 = self.curve()
        plastic = self.plastic
        damaged = "Damage" in s and "Bond_Damage" in s
        pts = np.arange(lo, hi, dtype=np.int64)
        pts = pts[np.argsort(target.eval_rank[pts], kind="stable")]
        W, batch, M = FR.batching(hi - lo, target.max_degree, numba.get_num_threads())
        y, v = s["Coordinates"], s["Velocity"]
        ys, vs = np.repeat(y[None], W, axis=0), np.repeat(v[None], W, axis=0)
        F6 = np.stack([s[name] for name in F_ROWS + FDOT_ROWS])
        F6s = np.repeat(F6[None], W, axis=0)
        T = np.zeros((nl.num_bonds, 3))
        Fps, Fms = np.empty((W, M)), np.empty((W, M))
        Kbuf = np.empty((batch, M * M))
        status = np.zeros(batch, dtype=np.int64)
        for k0 in range(0, pts.shape[0], batch):
            k1 = min(k0 + batch, pts.shape[0])
            FR.ba_blocks(
                pts, k0, k1, nl.offsets, nl.neighbors, s["Model_Coordinates"], ys, vs, s["Displacement"], s["Volume"], s["Horizon"],
                kind, table, damaged, s.n("Damage") if damaged else EMPTY, s["Damage"] if damaged else EMPTY,
                s["Bond_Damage"] if damaged else EMPTY, s["Influence_State"], s["Gradient_Weight"], s["Weighted_Volume"], F6, F6s,
                s.n("Bond_Left_Stretch_Tensor"), s.n("Bond_Rotation_Tensor"), s.np1("Bond_Left_Stretch_Tensor"), s.np1("Bond_Rotation_Tensor"),
                s.n("Bond_Unrotated_Cauchy_Stress"), s.np1("Bond_Unrotated_Cauchy_Stress"),
                s.n("Bond_Equivalent_Plastic_Strain") if plastic else EMPTY, s.np1("Bond_Equivalent_Plastic_Strain") if plastic else EMPTY,
                model, float(self.K), float(self.G), p0, p1, p2, p3, dt, eps, dv, self._scratch("Piola", (nl.num_bonds, 9)), T,
                Fps, Fms, Kbuf, status,
            )
            bad = np.flatnonzero(status[: k1 - k0])
            n_ok = int(bad[0]) if bad.size else k1 - k0
            FR.scatter_batch(pts, k0, k0 + n_ok, W, nl.offsets, nl.neighbors, int(target.nrows), target.row_of_local, Kbuf,
                             target.indptr, target.indices, target.data)
            if bad.size:
                self._fail(block, int(pts[k0 + n_ok]), int(status[n_ok]))
        return True


class ElasticBondAssociatedCorrespondence(BondAssociatedCorrespondence):
    name = "Elastic Bond Associated Correspondence"
    Params = BondAssociatedParams


class ElasticPlasticBondAssociatedCorrespondence(BondAssociatedCorrespondence):
    name = "Elastic Plastic Bond Associated Correspondence"
    Params = ElasticPlasticBondAssociatedParams
    plastic = True

    def curve(self) -> tuple[int, float, float, float, float]:
        return kern.PERFECT, float(self.params.yield_stress), 0.0, 0.0, 0.0


class IsotropicHardeningBondAssociatedCorrespondence(BondAssociatedCorrespondence):
    name = "Isotropic Hardening Bond Associated Correspondence"
    Params = IsotropicHardeningBondAssociatedParams
    plastic = True

    def curve(self) -> tuple[int, float, float, float, float]:
        return self.params.curve()
