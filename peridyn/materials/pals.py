"""``Pals``: the position-aware linear peridynamic solid (PERIDIGM_MODELS.md §4; Peridigm's
``Peridigm_Pals_Model.cpp``, ``pals.cxx``).

LPS with influence functions corrected point by point. Each point i solves, once, two 6x6
linear systems for Lagrange multipliers lambda_i, tau_i (12 numbers, the outputs
``Lagrange_Multiplier_Dilatation_1..6`` and ``Lagrange_Multiplier_Deviatoric_1..6``) that make
its dilatation influence function omega and deviatoric influence function sigma reproduce, on
its own (possibly truncated) family, the moments of a full family: the dilatation is exact for
every homogeneous deformation and the deviatoric stiffness is the stated shear modulus, at the
surface as in the bulk. Ordinary LPS (``Elastic``) normalises by a weighted volume that a
truncated family makes smaller, which stiffens points near a free surface; Pals does not.
The bond functions and formulas are in :mod:`peridyn.materials.pals_kernels`. Per point,

    theta_i = sum_j (omega r) e V_j                                   (no 3/m factor)
    p_i     = sum_j -((2 mu)(sigma r)/3) e V_j + (K + (2 mu) m_i / 9) theta_i,  m_i = sum_j sigma r^2 V_j
    t_ij    = (p_i omega) r + ((2 mu) sigma) (e - theta_i r / 3)
    W_i     = (K/2) theta_i^2 + mu sum_j sigma (e - theta_i r / 3)^2 V_j

The influence functions are ``Dilatation Influence Function`` omega_0 and ``Deviatoric
Influence Function`` sigma_0 (``One``, ``Parabolic Decay`` or ``Gaussian``), independent of the
discretization's ``Influence Function``.

Differences from Peridigm (docs/damage.md): Peridigm's Pals ignores bond damage; here a bond
of damage d contributes (1 - d) times its share to theta, p, the force state and the energy
(no reference result depends on Peridigm's behaviour: with damage, the cases compare Damage
only). The implicit tangent is Peridigm's finite-difference one, compiled
(:func:`peridyn.materials.pals_kernels.fd_tangent_kernel`, bit-identical to the solvers' Python
path).
"""
from __future__ import annotations

import numpy as np
from pydantic import Field, field_validator

from ..core.errors import InputError
from ..core.fields import FieldSpec, Relation, Temporal
from ..core.influence import NAMED
from ..core.interfaces import SMALL_STRAIN, BlockView, ElasticModuli, Material
from ..kernels.lengths import compiled_with_lengths
from . import pals_kernels as kern
from .moduli import IsotropicElasticParams, isotropic_moduli

EMPTY = np.zeros(0)
MULTIPLIER_FIELDS = tuple(f"Lagrange_Multiplier_Dilatation_{k}" for k in range(1, 7)) + tuple(
    f"Lagrange_Multiplier_Deviatoric_{k}" for k in range(1, 7)
)


class PalsParams(IsotropicElasticParams):
    dilatation_influence_function: str = Field(
        "One", alias="Dilatation Influence Function", description="omega_0: 'One', 'Parabolic Decay' or 'Gaussian' (of |xi| and the horizon)"
    )
    deviatoric_influence_function: str = Field(
        "One", alias="Deviatoric Influence Function", description="sigma_0: 'One', 'Parabolic Decay' or 'Gaussian' (of |xi| and the horizon)"
    )
    finite_difference_probe_length: float | None = Field(
        None, alias="Finite Difference Probe Length", gt=0, description="implicit solvers, finite-difference tangent: probe (L); default 1e-6 x the smallest element radius"
    )
    ignored_keys = frozenset({"Hourglass Coefficient", "Apply Shear Correction Factor", "Apply Automatic Differentiation Jacobian"})

    @field_validator("dilatation_influence_function", "deviatoric_influence_function")
    @classmethod
    def _named(cls, v: str) -> str:
        if v not in NAMED:
            raise ValueError(f"{v!r} is not an influence function Pals knows: use 'One', 'Parabolic Decay' or 'Gaussian' "
                             "(Pals takes no user expressions)")
        return v


class Pals(Material):
    """Position-aware linear peridynamic solid (Peridigm's ``Pals``)."""
    small_strain_limit = SMALL_STRAIN  # a linear law

    name = "Pals"
    Params = PalsParams

    def __init__(self, params: PalsParams, *, horizon: float | None, options=None) -> None:
        super().__init__(params, horizon=horizon, options=options)
        self.K, self.mu = params.moduli()
        self.kind_w = NAMED[params.dilatation_influence_function]
        self.kind_s = NAMED[params.deviatoric_influence_function]
        if horizon is None and (self.kind_w != 0 or self.kind_s != 0):
            raise ValueError("Pals with a 'Parabolic Decay' or 'Gaussian' influence function needs a constant horizon "
                             "(a number, not an expression)")
        self.lam = EMPTY.reshape(0, 6)  # (n_local, 6) multipliers, rows of the block's points
        self.tau = EMPTY.reshape(0, 6)
        self.W = EMPTY  # (num_bonds,) omega and sigma of the block's bonds (constant: computed once)
        self.Sg = EMPTY

    def finite_difference_probe_length(self) -> float | None:
        return self.params.finite_difference_probe_length

    @property
    def density(self) -> float:
        return float(self.params.density)

    @property
    def bulk_modulus(self) -> float:
        return float(self.K)

    def elastic_moduli(self) -> ElasticModuli:
        return isotropic_moduli(self.params, self.K, self.mu, hookean=True)

    def fields(self) -> list[FieldSpec]:
        return [
            FieldSpec("Weighted_Volume", Relation.ELEMENT),  # sum sigma |xi|^2 V: dimensionless (15/2)
            FieldSpec("Dilatation", Relation.ELEMENT, 1, Temporal.CONSTANT),
            FieldSpec("Pals_Pressure", Relation.ELEMENT, 1, Temporal.CONSTANT, units="M L^-1 T^-2"),
        ]

    def output_fields(self) -> list[FieldSpec]:
        return [FieldSpec(name, Relation.ELEMENT) for name in MULTIPLIER_FIELDS + (
            "Dilatation_Normalization", "Deviatoric_Normalization", "Normalized_Weighted_Volume")]

    def _delta(self, block: BlockView) -> float:
        return float(block.horizon) if self.horizon is not None else 0.0

    def _damage(self, block: BlockView) -> np.ndarray:
        return block.fields.get("Bond_Damage", EMPTY)

    def initialize(self, block: BlockView) -> None:
        s, nl = block.fields, block.bonds
        n = s.num_points
        if self.lam.shape[0] != n:
            self.lam = np.zeros((n, 6))
            self.tau = np.zeros((n, 6))
        delta = self._delta(block)
        bad = kern.multipliers_kernel(block.start, block.stop, nl.offsets, nl.neighbors, s["Model_Coordinates"], s["Volume"],
                                      self.kind_w, self.kind_s, delta, self.lam, self.tau)
        if bad >= 0:
            gid = int(block.extras["gid"][bad]) + 1 if "gid" in block.extras else int(bad) + 1
            raise InputError(f"Pals: the Lagrange-multiplier matrix of point {gid} (block {block.name}) is singular: "
                             f"it has {int(nl.offsets[bad + 1] - nl.offsets[bad])} neighbors",
                             path=self.options.get("path", ()), fix="use a larger horizon: every point needs neighbors in several directions")
        # the sums over reference bonds: the kernels' y is x
        self._run(block, kern.WEIGHTED_VOLUME, (s["Volume"], self.tau, self.kind_s, delta), s["Weighted_Volume"], reference=True)
        if self.W.shape[0] != nl.num_bonds:
            self.W = np.zeros(nl.num_bonds)
            self.Sg = np.zeros(nl.num_bonds)
        influence = (self.lam, self.tau, self.kind_w, self.kind_s, delta)
        self._run(block, kern.DILATATION_INFLUENCE, influence, self.W, reference=True)
        self._run(block, kern.DEVIATORIC_INFLUENCE, influence, self.Sg, reference=True)
        lo, hi = block.start, block.stop
        for k, name in enumerate(MULTIPLIER_FIELDS):
            if name in s:
                s[name][lo:hi] = (self.lam if k < 6 else self.tau)[lo:hi, k % 6]
        for name in ("Dilatation_Normalization", "Deviatoric_Normalization"):
            if name in s:
                s[name][lo:hi] = 1.0  # Peridigm's normalising constants, switched off (always 1)
        if "Normalized_Weighted_Volume" in s:
            s["Normalized_Weighted_Volume"][lo:hi] = 0.0  # registered but never filled by Peridigm

    def _run(self, block: BlockView, law, args: tuple, out: np.ndarray, reference: bool = False) -> None:
        """``law`` over the block's points: on the current bonds, or on the reference ones."""
        s, nl = block.fields, block.bonds
        y = s["Model_Coordinates"] if reference else s["Coordinates"]
        compiled_with_lengths(block, law)(block.start, block.stop, nl.offsets, nl.neighbors, y, args, out)

    def precompute(self, block: BlockView) -> None:
        """Dilatation theta_i and the Pals pressure p_i of the block's points."""
        s = block.fields
        args = (s["Volume"], self.W, self.Sg, s["Weighted_Volume"], self.K, 2.0 * self.mu, self._damage(block), s["Pals_Pressure"])
        self._run(block, kern.THETA_PRESSURE, args, s["Dilatation"])

    def force_state(self, block: BlockView, t: np.ndarray) -> None:
        s = block.fields
        self._run(block, kern.FORCE_STATE, (self.W, self.Sg, s["Dilatation"], s["Pals_Pressure"], 2.0 * self.mu, self._damage(block)), t)

    def tangent(self, block: BlockView, target) -> bool:
        """Peridigm's central finite-difference tangent (its only one for Pals), compiled:
        the same probes, arithmetic and order as the solvers' Python path."""
        s, nl = block.fields, block.bonds
        if target.probe_length is None:
            return False  # the solvers' own path picks the probe
        pts = np.arange(block.start, block.stop)
        pts = pts[np.argsort(target.eval_rank[pts], kind="stable")]
        degree = np.diff(nl.offsets[block.start : block.stop + 1])
        kern.fd_tangent_kernel(
            pts, nl.offsets, nl.neighbors, s["Bond_Length"], s["Coordinates"], s["Volume"], self.W, self.Sg,
            s["Weighted_Volume"], self.K, self.mu, self._damage(block),
            float(target.probe_length), target.row_of_local, target.nrows, target.indptr, target.indices, target.data,
            int(degree.max()) if degree.size else 1,
        )
        return True

    def stored_energy_density(self, block: BlockView, out: np.ndarray) -> None:
        s = block.fields
        self._run(block, kern.STORED_ENERGY, (s["Volume"], self.Sg, s["Dilatation"], self.K, self.mu, self._damage(block)), out)
