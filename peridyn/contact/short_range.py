"""``Short Range Force`` and ``Time Dependent Short Range Force``: Peridigm's contact models
(PERIDIGM_CONTACT.md §4).

Each pair is visited from both points (unless one holds the other in its reference bond list):
a visit with node i and partner j, d = |y_j - y_i| < R_c, adds to i

    N_i = -(tau V_j (y_j - y_i)) / d,   tau = (9 k / (pi delta^4)) (R_c - d) / delta

(delta: the horizon of the visiting point's block; 9 = 18 / 2 because each pair is visited
twice), and, when the friction coefficient mu is not zero, the kinetic Coulomb term
T_i = -mu |N_i| r_i / |r_i|, r_i the point's tangential velocity relative to the pair's mean
tangential velocity. The visit adds the mirror terms to j. Net: the bond-based law with
micromodulus 18 k / (pi delta^4) and "stretch" (R_c - d) / delta, in compression only.

The kernel gathers, per owned point, every term it receives, in the order Peridigm's scatter
adds them (one accumulator per block of the visiting point, visits in global-id order), so a
serial run reproduces Peridigm's sums bit for bit and an MPI run gives the serial result.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from pydantic import Field, field_validator

from ..core.interfaces import VISIT_FROM_PARTNER, VISIT_FROM_POINT, ContactModel, ContactPairs, ContactState
from ..core.errors import InstabilityError
from ..core.params import ModelParams
from ..core.traversal import Backend, PointUpdate

PI = 3.141592653589793
BIG = (1 << 63) - 1


def _no_horizon(value: Any) -> Any:
    raise ValueError("'Horizon' is not a contact model parameter: the contact horizon of each block is the block's own Horizon")


class ShortRangeForceParams(ModelParams):
    contact_radius: float = Field(alias="Contact Radius", gt=0, description="distance below which two points repel (L)")
    spring_constant: float = Field(alias="Spring Constant", gt=0, description="k, in the role of a bulk modulus (M L^-1 T^-2)")
    friction_coefficient: float = Field(0.0, alias="Friction Coefficient", ge=0, description="kinetic Coulomb friction coefficient mu")
    horizon: float | None = Field(None, alias="Horizon", description="not allowed (each block's horizon is used)")

    _check_horizon = field_validator("horizon", mode="before")(classmethod(lambda cls, v: _no_horizon(v)))


class TimeDependentShortRangeForceParams(ShortRangeForceParams):
    friction_coefficient: str | float = Field(  # type: ignore[assignment]
        0.0, alias="Friction Coefficient", description="mu as an expression in t (and 'value = ...'), evaluated every step"
    )

    @field_validator("friction_coefficient")
    @classmethod
    def _compiles(cls, v: str | float) -> str | float:
        if isinstance(v, str):
            from ..deck.expressions import compile_expression

            compile_expression(v, ("t",))
        elif not v >= 0:
            raise ValueError(f"the friction coefficient must be at least 0 (got {v!r})")
        return v


@njit(cache=True, inline="always")
def _visit_term(p, j, delta, y, v, volume, rc, rc2, k, mu):
    """The force density one visit adds to p (p the visiting point, or the visited one: the
    terms are the same, PERIDIGM_CONTACT.md §4.4). Returns (active, fx, fy, fz)."""
    dx = y[j, 0] - y[p, 0]
    dy = y[j, 1] - y[p, 1]
    dz = y[j, 2] - y[p, 2]
    s2 = (dx * dx + dy * dy) + dz * dz
    if not s2 < rc2:
        return False, 0.0, 0.0, 0.0
    d = math.sqrt(s2)
    c = (9.0 * k) / ((((PI * delta) * delta) * delta) * delta)
    tau = (c * (rc - d)) / delta
    tv = tau * volume[j]
    nx = -((tv * dx) / d)
    ny = -((tv * dy) / d)
    nz = -((tv * dz) / d)
    if mu == 0.0:
        return True, nx, ny, nz
    ux = dx / d
    uy = dy / d
    uz = dz / d
    ap = (v[p, 0] * ux + v[p, 1] * uy) + v[p, 2] * uz
    aj = (v[j, 0] * ux + v[j, 1] * uy) + v[j, 2] * uz
    px = v[p, 0] - ap * ux
    py = v[p, 1] - ap * uy
    pz = v[p, 2] - ap * uz
    rx = px - 0.5 * (px + (v[j, 0] - aj * ux))
    ry = py - 0.5 * (py + (v[j, 1] - aj * uy))
    rz = pz - 0.5 * (pz + (v[j, 2] - aj * uz))
    rn = math.sqrt((rx * rx + ry * ry) + rz * rz)
    if rn != 0.0:
        nn = math.sqrt((nx * nx + ny * ny) + nz * nz)
        m = (-mu) * nn
        return True, nx + (m * rx) / rn, ny + (m * ry) / rn, nz + (m * rz) / rn
    return True, nx + 0.0, ny + 0.0, nz + 0.0


@njit(cache=True, inline="always")
def short_range_row(p, lo, hi, partners, visits, gid, block, horizon, y, v, volume, rc, rc2, k, mu):
    """The contact force density on point p (M L^-2 T^-2) from its pairs partners[lo:hi],
    summed in Peridigm's scatter order (see the module docstring). Returns (fx, fy, fz)."""
    fx = 0.0
    fy = 0.0
    fz = 0.0
    if lo == hi:
        return fx, fy, fz
    bp = block[p]
    gp = gid[p]
    cur = -1
    while True:  # one accumulator per block of the visiting point, blocks in order
        nb = bp if bp > cur else BIG
        for q in range(lo, hi):
            b = block[partners[q]]
            if cur < b < nb:
                nb = b
        if nb == BIG:
            break
        cur = nb
        ax = 0.0
        ay = 0.0
        az = 0.0
        for phase in range(3):
            # phase 0: visits of partners before p; 1: p's own visits; 2: partners after p
            if bp != cur and phase != 0:
                break
            for q in range(lo, hi):
                j = partners[q]
                if phase == 1:
                    if not visits[q] & VISIT_FROM_POINT:
                        continue
                    delta = horizon[p]
                else:
                    if block[j] != cur or not visits[q] & VISIT_FROM_PARTNER:
                        continue
                    if bp == cur and (gid[j] > gp) != (phase == 2):
                        continue
                    delta = horizon[j]
                active, tx, ty, tz = _visit_term(p, j, delta, y, v, volume, rc, rc2, k, mu)
                if active:
                    ax += tx
                    ay += ty
                    az += tz
        fx += ax
        fy += ay
        fz += az
    return fx, fy, fz


def _short_range_force(p, args):
    """out[p] += the contact force density on owned point p (``short_range_row``); args
    (offsets, partners, visits, gid, block, horizon, y, v, volume, rc, k, mu, out). Shapes:
    offsets (num_owned + 1,); partners, visits (num_pairs,); gid, block, horizon, volume (n,);
    y, v (n, 3); out (num_owned, 3)."""
    offsets, partners, visits, gid, block, horizon, y, v, volume, rc, k, mu, out = args
    fx, fy, fz = short_range_row(p, offsets[p], offsets[p + 1], partners, visits, gid, block, horizon, y, v, volume, rc, rc * rc, k, mu)
    out[p, 0] += fx
    out[p, 1] += fy
    out[p, 2] += fz


#: the force of every owned point, a gather over its row: the same law on every backend
SHORT_RANGE_FORCE = PointUpdate(_short_range_force)


# not a loop law: one running sum over every pair of every point (a global reduction in serial order)
@njit(cache=True)
def short_range_energy_kernel(num_owned, offsets, partners, visits, horizon, y, volume, rc, k):
    """sum over the visits i -> j of owned i of V_i V_j (9 k / (pi delta_i^5)) (R_c - d)^2 / 2,
    half of each pair's spring energy (serial: a sum that must not depend on threads)."""
    total = 0.0
    for p in range(num_owned):
        for q in range(offsets[p], offsets[p + 1]):
            if not visits[q] & VISIT_FROM_POINT:
                continue
            j = partners[q]
            dx = y[j, 0] - y[p, 0]
            dy = y[j, 1] - y[p, 1]
            dz = y[j, 2] - y[p, 2]
            d = math.sqrt((dx * dx + dy * dy) + dz * dz)
            if d < rc:
                delta = horizon[p]
                g = rc - d
                total += volume[p] * volume[j] * (9.0 * k / (PI * delta ** 5)) * g * g * 0.5
    return total


class ShortRangeForce(ContactModel):
    """Peridigm's ``Short Range Force`` contact model."""

    name = "Short Range Force"
    Params = ShortRangeForceParams
    devices = frozenset({"cpu", "gpu"})  # force_on runs on either backend

    def __init__(self, params: ModelParams, *, options: dict[str, Any] | None = None) -> None:
        super().__init__(params, options=options)
        self.mu = float(params.friction_coefficient) if not isinstance(params.friction_coefficient, str) else 0.0

    @property
    def contact_radius(self) -> float:
        return float(self.params.contact_radius)

    def spring_constant(self) -> float:
        return float(self.params.spring_constant)

    def pair_stiffness(self, horizon: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):
            return (18.0 * self.params.spring_constant) / (PI * np.asarray(horizon, float) ** 5)

    def force(self, pairs: ContactPairs, state: ContactState, out: np.ndarray) -> None:
        from ..kernels import default_backend

        self.force_on(default_backend(), pairs, state, out)

    def force_on(self, backend: Backend, pairs: ContactPairs, state: ContactState, out: Any) -> None:
        """``force`` with the pairs, the state and ``out`` (num_owned, 3) on ``backend`` (a GPU's
        device arrays, say): the ``SHORT_RANGE_FORCE`` law run there."""
        p = self.params
        if state.num_owned:
            backend.kernel(SHORT_RANGE_FORCE)(0, state.num_owned, (
                pairs.offsets, pairs.partners, pairs.visits, state.gid, state.block, state.horizon, state.y, state.v, state.volume,
                float(p.contact_radius), float(p.spring_constant), float(self.mu), out,
            ))

    def potential_energy(self, pairs: ContactPairs, state: ContactState) -> float:
        p = self.params
        return short_range_energy_kernel(state.num_owned, pairs.offsets, pairs.partners, pairs.visits, state.horizon, state.y,
                                         state.volume, float(p.contact_radius), float(p.spring_constant))


class TimeDependentShortRangeForce(ShortRangeForce):
    """``Time Dependent Short Range Force``: the friction coefficient is an expression in t,
    evaluated at t = 0 for step 0 and at each step's time after that (PERIDIGM_CONTACT.md §4.5)."""

    name = "Time Dependent Short Range Force"
    Params = TimeDependentShortRangeForceParams

    def __init__(self, params: ModelParams, *, options: dict[str, Any] | None = None) -> None:
        super().__init__(params, options=options)
        mu = params.friction_coefficient
        if isinstance(mu, str):
            from ..deck.expressions import compile_expression

            self._expr = compile_expression(mu, ("t",))
            try:
                self.begin_step(0.0)
            except InstabilityError as exc:  # already wrong at t = 0: the deck's value is bad
                from ..core.errors import InputError

                raise InputError(str(exc), path=tuple(self.options.get("path", ())) + ("Friction Coefficient",),
                                 fix="give an expression that is finite and at least 0 for every t of the run") from None
        else:
            self._expr = None
            self.mu = float(mu)

    def begin_step(self, time: float) -> None:
        if self._expr is None:
            return
        mu = float(np.asarray(self._expr(t=time), float).reshape(-1)[0])
        if not (math.isfinite(mu) and mu >= 0.0):
            raise InstabilityError(
                f"contact model {self.name!r}: the friction coefficient expression gives {mu!r} at t = {time:.6g}; "
                "it must be finite and at least 0",
                collective=True,  # every rank evaluates the same expression
            )
        self.mu = mu
