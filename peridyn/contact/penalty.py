"""``Penalty Contact``: PeriLab's penalty contact model (PeriLab.jl, ``src/Models/Contact/
Penalty_model.jl``, name ``"Penalty Contact"``; its 3D law).

PeriLab visits each master-slave pair once: with d = |y_s - y_m| < R_c, n the unit vector
between the points and c_contact the deck's ``Contact Stiffness`` (a stiffness in the role of a
bulk modulus), it adds to each point

    f = (9 c_contact / (pi delta^5)) (R_c - d) V_partner,   pushing the two points apart,

delta the slave's horizon: the bond-based law with micromodulus 9 c_contact / (pi delta^4) and
"stretch" (R_c - d) / delta, in compression only (half of Peridigm's ``Short Range Force`` with
``Spring Constant`` c_contact: Peridigm adds 9 k / (pi delta^5) from each of the pair's two
visits). Friction is PeriLab's (and Peridigm's) kinetic Coulomb term, mu |f| opposite to the
point's tangential velocity relative to the pair's mean tangential velocity.

peridyn has no master and slave: every pair is visited from both points, and each visit adds
half of the law with its own point's horizon and stiffness (coefficient 4.5 c_b / (pi delta_b^5)
for a point of block b), so a pair of one block gets PeriLab's force exactly, and the forces of
a pair are equal and opposite whatever its blocks (linear momentum is conserved). A pair that one
point holds in its reference bond list gets the other point's half only (the one visit Peridigm
gives it, ``ContactPairs.visits``).

The stiffness is the deck's ``Contact Stiffness`` (PeriLab's key and meaning) or, with
``Penalty Factor`` p instead, c_contact = p K_b, K_b the bulk modulus of the visiting point's
block from its material's ``elastic_moduli()``: the contact spring then follows the material
(p = 2 makes the pair law the bond-based material's own micromodulus 18 K / (pi delta^4)).
"""
from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numba import njit
from pydantic import Field, field_validator, model_validator

from ..core.errors import InputError
from ..core.interfaces import VISIT_FROM_PARTNER, VISIT_FROM_POINT, ContactModel, ContactPairs, ContactState, ElasticModuli
from ..core.params import ModelParams, ParamKeyError
from ..core.traversal import Backend, PointUpdate

#: half of PeriLab's 3D penalty constant 9 / pi: each of a pair's two visits adds this much
HALF_PENALTY = 4.5 / math.pi


class PenaltyContactParams(ModelParams):
    contact_radius: float = Field(alias="Contact Radius", gt=0, description="distance below which two points repel (L)")
    contact_stiffness: float | None = Field(
        None, alias="Contact Stiffness", gt=0,
        description="c_contact, PeriLab's contact stiffness in the role of a bulk modulus (M L^-1 T^-2); or give 'Penalty Factor'",
    )
    penalty_factor: float | None = Field(
        None, alias="Penalty Factor", gt=0,
        description="p: c_contact = p times the bulk modulus of each point's block (dimensionless); or give 'Contact Stiffness'",
    )
    friction_coefficient: float = Field(0.0, alias="Friction Coefficient", ge=0, description="kinetic Coulomb friction coefficient mu")
    horizon: float | None = Field(None, alias="Horizon", description="not allowed (each block's horizon is used)")

    @field_validator("horizon", mode="before")
    @classmethod
    def _no_horizon(cls, v: Any) -> Any:
        raise ValueError("'Horizon' is not a contact model parameter: the contact horizon of each block is the block's own Horizon")

    @model_validator(mode="after")
    def _one_stiffness(self) -> "PenaltyContactParams":
        if (self.contact_stiffness is None) == (self.penalty_factor is None):
            both = self.contact_stiffness is not None
            raise ParamKeyError(
                "Penalty Factor" if both else "Contact Stiffness",
                ("give either 'Contact Stiffness' or 'Penalty Factor', not both" if both else
                 "missing the contact stiffness: give 'Contact Stiffness' (M L^-1 T^-2) or 'Penalty Factor' (times the bulk modulus)"),
            )
        return self


@njit(cache=True, inline="always")
def _fifth_power(h):
    """h^5 as numba computes ``h ** 5`` (by squaring), written out so that every target, the
    GPU simulator's Python included, gets the same bits."""
    h2 = h * h
    return h * (h2 * h2)


@njit(cache=True, inline="always")
def pair_coefficient(visit, p, j, block, horizon, coef):
    """kappa of a pair (M L^-6 T^-2 per unit penetration and partner volume): for each point whose
    visit the pair has, its half of the law, coef_b / delta_b^5 with coef_b = 4.5 c_b / pi."""
    kappa = 0.0
    if visit & VISIT_FROM_POINT:
        kappa += coef[block[p]] / _fifth_power(horizon[p])
    if visit & VISIT_FROM_PARTNER:
        kappa += coef[block[j]] / _fifth_power(horizon[j])
    return kappa


@njit(cache=True, inline="always", error_model="numpy")
def penalty_row(p, lo, hi, partners, visits, block, horizon, y, v, volume, rc, rc2, coef, mu):
    """The penalty contact force density on owned point p (M L^-2 T^-2): a gather over p's row
    [lo, hi) of the contact pairs in its order. coef (num_blocks,): 4.5 c_contact / pi per block
    (M L^-1 T^-2). Shapes: partners, visits (num_pairs,); block, horizon, volume (n,); y, v (n, 3)."""
    fx = 0.0
    fy = 0.0
    fz = 0.0
    for q in range(lo, hi):
        j = partners[q]
        dx = y[j, 0] - y[p, 0]
        dy = y[j, 1] - y[p, 1]
        dz = y[j, 2] - y[p, 2]
        s2 = dx * dx + dy * dy + dz * dz
        if not s2 < rc2:
            continue
        kappa = pair_coefficient(visits[q], p, j, block, horizon, coef)
        d = math.sqrt(s2)
        g = kappa * (rc - d) * volume[j]  # |normal force density| on p
        ux = dx / d
        uy = dy / d
        uz = dz / d
        fx -= g * ux
        fy -= g * uy
        fz -= g * uz
        if mu != 0.0:
            ap = v[p, 0] * ux + v[p, 1] * uy + v[p, 2] * uz
            aj = v[j, 0] * ux + v[j, 1] * uy + v[j, 2] * uz
            # p's tangential velocity relative to the pair's mean: half the tangential difference
            rx = 0.5 * ((v[p, 0] - ap * ux) - (v[j, 0] - aj * ux))
            ry = 0.5 * ((v[p, 1] - ap * uy) - (v[j, 1] - aj * uy))
            rz = 0.5 * ((v[p, 2] - ap * uz) - (v[j, 2] - aj * uz))
            rn = math.sqrt(rx * rx + ry * ry + rz * rz)
            if rn != 0.0:
                m = mu * g / rn
                fx -= m * rx
                fy -= m * ry
                fz -= m * rz
    return fx, fy, fz


def _penalty_force(p, args):
    """out[p] += the penalty contact force density on owned point p (``penalty_row``); args
    (offsets, partners, visits, block, horizon, y, v, volume, rc, coef, mu, out), out (num_owned, 3)."""
    offsets, partners, visits, block, horizon, y, v, volume, rc, coef, mu, out = args
    fx, fy, fz = penalty_row(p, offsets[p], offsets[p + 1], partners, visits, block, horizon, y, v, volume, rc, rc * rc, coef, mu)
    out[p, 0] += fx
    out[p, 1] += fy
    out[p, 2] += fz


#: the force of every owned point, a gather over its row: the same law on every backend
PENALTY_FORCE = PointUpdate(_penalty_force)


# not a loop law: one running sum over every contact pair of every owned point (a serial reduction)
@njit(cache=True)
def penalty_energy_kernel(num_owned, offsets, partners, visits, block, horizon, y, volume, rc, coef):
    """Half the spring energy kappa (R_c - d)^2 V_p V_j / 2 of every pair in the owned rows (M L^2
    T^-2): both points' halves together are the pair's energy, whichever ranks own them."""
    total = 0.0
    for p in range(num_owned):
        for q in range(offsets[p], offsets[p + 1]):
            j = partners[q]
            dx = y[j, 0] - y[p, 0]
            dy = y[j, 1] - y[p, 1]
            dz = y[j, 2] - y[p, 2]
            d = math.sqrt(dx * dx + dy * dy + dz * dz)
            if not d < rc:
                continue
            kappa = pair_coefficient(visits[q], p, j, block, horizon, coef)
            g = rc - d
            total += 0.25 * kappa * g * g * volume[p] * volume[j]
    return total


class PenaltyContact(ContactModel):
    """PeriLab's ``Penalty Contact`` (3D law; see the module docstring).

    ``options["blocks"]`` (set by the contact manager): per block, in block-index order, (block
    name, its :class:`~peridyn.core.interfaces.Material`), whose ``elastic_moduli()`` give the
    bulk moduli ``Penalty Factor`` scales and tell planar blocks, which are refused (PeriLab's
    plane-stress and plane-strain laws are not built).
    """

    name = "Penalty Contact"
    Params = PenaltyContactParams
    devices = frozenset({"cpu", "gpu"})  # force_on runs on either backend
    stiffness_key: ClassVar[str] = "Contact Stiffness' or 'Penalty Factor"

    def __init__(self, params: ModelParams, *, options: dict[str, Any] | None = None) -> None:
        super().__init__(params, options=options)
        self.mu = float(params.friction_coefficient)
        blocks: list[tuple[str, ElasticModuli | None]] = [(name, material.elastic_moduli())
                                                           for name, material in self.options.get("blocks", ())]
        path = tuple(self.options.get("path", ()))
        for name, moduli in blocks:
            if moduli is not None and moduli.planar != "3d":
                raise InputError(
                    f"block {name!r} is a planar ({moduli.planar}) model; 'Penalty Contact' has PeriLab's 3D law only",
                    path=path + ("Contact Model",), fix="use 'Short Range Force' for planar blocks, or a 3D material",
                )
        if params.penalty_factor is None:
            self._coef: np.ndarray = np.full(max(len(blocks), 1), HALF_PENALTY * float(params.contact_stiffness))
            return
        if not blocks:
            raise InputError("'Penalty Factor' needs the blocks' bulk moduli, and the model was built without its blocks",
                             path=path + ("Penalty Factor",), fix="give 'Contact Stiffness' instead")
        coef = []
        for name, moduli in blocks:
            if moduli is None or not moduli.bulk > 0:
                raise InputError(
                    f"'Penalty Factor' scales the bulk modulus of each block, and the material of block {name!r} states none "
                    "(Material.elastic_moduli)",
                    path=path + ("Penalty Factor",), fix="give 'Contact Stiffness' (M L^-1 T^-2) instead of 'Penalty Factor'",
                )
            coef.append(HALF_PENALTY * float(params.penalty_factor) * float(moduli.bulk))
        self._coef = np.array(coef)

    @property
    def contact_radius(self) -> float:
        return float(self.params.contact_radius)

    def contact_stiffness(self) -> np.ndarray:
        """c_contact per block (M L^-1 T^-2), block-index order."""
        return np.asarray(self._coef) / HALF_PENALTY

    def _block_coef(self, block: np.ndarray) -> np.ndarray:
        coef = self._coef
        need = int(block.max()) + 1 if block.size else 1
        if coef.size < need:  # built without its blocks (Contact Stiffness): one value for every block
            coef = self._coef = np.full(need, float(coef[0]))
        return coef

    def pair_stiffness(self, horizon: np.ndarray) -> np.ndarray:
        """9 c_contact / (pi delta^5) with the largest c_contact of the blocks (M L^-5 T^-2)."""
        with np.errstate(all="ignore"):
            return (2.0 * float(np.max(self._coef))) / np.asarray(horizon, float) ** 5

    def force(self, pairs: ContactPairs, state: ContactState, out: np.ndarray) -> None:
        from ..kernels import default_backend

        self.force_on(default_backend(), pairs, state, out)

    def force_on(self, backend: Backend, pairs: ContactPairs, state: ContactState, out: Any) -> None:
        """``force`` on ``backend``'s arrays: the ``PENALTY_FORCE`` law run there, the blocks'
        coefficients copied there once (a GPU run's model is built with its blocks)."""
        if state.num_owned:
            coef = backend.resident(self._block_coef(state.block) if backend.device == "cpu" else self._coef)
            backend.kernel(PENALTY_FORCE)(0, state.num_owned, (
                pairs.offsets, pairs.partners, pairs.visits, state.block, state.horizon, state.y, state.v, state.volume,
                float(self.params.contact_radius), coef, float(self.mu), out,
            ))

    def potential_energy(self, pairs: ContactPairs, state: ContactState) -> float:
        return float(penalty_energy_kernel(
            state.num_owned, pairs.offsets, pairs.partners, pairs.visits, state.block, state.horizon, state.y, state.volume,
            float(self.params.contact_radius), self._block_coef(state.block),
        ))
