"""J-integral computes.

``J_Integral`` (peridyn): the energy release rate at a straight crack front, a GLOBAL output, by
the equivalent domain integral (Li, Shih & Needleman 1985, Eng. Fract. Mech. 21, 405-421;
Moran & Shih 1987, Eng. Fract. Mech. 27, 615-642):

    J = (1/B) sum_i V_i (sigma_ab u_a,c e_c - W e_b) q_,b(x_i)

over the points of the ring r_in < r < r_out around the crack front (r: distance from the front
line in the plane normal to it), with e the unit crack-growth direction, B the length of crack
front in the model (``Thickness``: the plate thickness, or the Height of a 2D model), and the
weight q = 1 inside r_in, 0 outside r_out, linear in r between, so q_,b = -(r_b / r)/(r_out - r_in)
in the ring. The displacement gradient is the peridynamic (nonlocal) gradient of the intact
bonds, H = [sum_j (1-d_ij) (u_j - u_i) (x) xi V_j] [sum_j (1-d_ij) xi (x) xi V_j]^-1 (the
correspondence shape-tensor gradient, Silling et al. 2007, J. Elasticity 88, eq. 21, with
omega = 1), the stress the small-strain Hooke stress of the material's elastic constants
(``Material.elastic_moduli()``: any material whose constants are Hookean), and
W = sigma : eps / 2. This is the "domain integral from the deformation gradient" of
docs/fracture.md; with r_in a few horizons from the tip the ring stays in the region where the
peridynamic field is close to the classical one.

``JIntegral`` (Peridigm's key, PERIDIGM_MODELS.md §12): accepted with ``Block ID`` and ``dt``;
like Peridigm it warns that it is not implemented and produces no value.
"""
from __future__ import annotations

import logging

import numpy as np
from pydantic import Field, model_validator

from ..core.fields import FieldSpec, Relation
from ..core.interfaces import Compute
from ..core.params import ModelParams
from ..core.traversal import PointSum
from ..kernels import default_backend

log = logging.getLogger("peridyn.computes")


# Loop law (peridyn.core.traversal), run on reference positions: the bond context's
# (ex, ey, ez) = xi = x_j - x_i (L). args (x, y (n, 3) reference and current positions L, V (n,)
# L^3, bond_damage (nb,) or empty, ring (n,) uint8: 1 at the points wanted, H (n, 9) written at
# those points: H_ab = du_a/dx_b row-major, dimensionless).
def gradient_gate(i, b, p, args):
    """Only the bonds of wanted points that are not broken for good (1 - d > 0) count."""
    bond_damage, ring = args[3], args[4]
    if ring[i] == 0:
        return False
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    return not keep <= 0.0


def gradient_point(i, args):
    """(K, U): sum_j (1-d) V_j xi (x) xi (L^5) and sum_j (1-d) V_j (u_j - u_i) (x) xi (L^5) of
    point i, (3, 3), summed into by its bonds."""
    return np.zeros((3, 3)), np.zeros((3, 3))


def gradient_term(i, j, b, ex, ey, ez, L, z, p, args):
    """Adds the bond's (1-d) V_j xi (x) xi to K and (1-d) V_j (u_j - u_i) (x) xi to U
    (p = (K, U)); contributes nothing to the law's own sum."""
    x, y, volume, bond_damage, ring, H = args
    K, U = p
    keep = 1.0 - bond_damage[b] if bond_damage.shape[0] > 0 else 1.0
    w = keep * volume[j]
    xi = (ex, ey, ez)
    for a in range(3):
        ua = (y[j, a] - x[j, a]) - (y[i, a] - x[i, a])
        xa = xi[a]
        for c in range(3):
            xc = xi[c]
            K[a, c] += w * xa * xc
            U[a, c] += w * ua * xc
    return 0.0


def gradient_finish(i, acc, p, args):
    """H[i] = U K^-1 at a wanted point (0 where the family has no extent, tr K <= 0; a direction
    in which it has none, K_aa < 1e-10 tr K, is decoupled and gets a zero gradient column);
    returns tr K (L^5), 0 at the other points."""
    x, y, volume, bond_damage, ring, H = args
    if ring[i] == 0:
        return 0.0
    K, U = p
    tr = K[0, 0] + K[1, 1] + K[2, 2]
    if tr <= 0.0:
        for a in range(9):
            H[i, a] = 0.0
        return tr
    for a in range(3):
        if K[a, a] < 1.0e-10 * tr:  # no extent along a: decouple it
            for c in range(3):
                K[a, c] = 0.0
                K[c, a] = 0.0
            K[a, a] = tr
    G = U @ np.linalg.inv(K)
    for a in range(3):
        for c in range(3):
            H[i, 3 * a + c] = G[a, c]
    return tr


DISPLACEMENT_GRADIENT = PointSum(gradient_term, point=gradient_point, finish=gradient_finish, gate=gradient_gate, allocates=True)


def displacement_gradient(points, offsets, neighbors, zeta, x, y, volume, bond_damage, backend=None):
    """H (p, 9) at the local points ``points`` (p > 0) from their intact bonds (the law
    DISPLACEMENT_GRADIENT). Shapes: zeta (nb,) bond lengths (L); x, y (n, 3) L; volume (n,);
    bond_damage (nb,) or empty."""
    n = x.shape[0]
    ring = np.zeros(n, dtype=np.uint8)
    ring[points] = 1
    H = np.zeros((n, 9))
    kernel = (backend or default_backend()).kernel(DISPLACEMENT_GRADIENT)
    kernel(int(points.min()), int(points.max()) + 1, offsets, neighbors, zeta, x, (x, y, volume, bond_damage, ring, H), np.zeros(n))
    return H[points]


def hooke(H: np.ndarray, E: float, nu: float, mode: str) -> tuple[np.ndarray, np.ndarray]:
    """Small-strain stress (p, 3, 3) and energy density W (p,) from gradients H (p, 3, 3);
    mode "3d", "plane stress" or "plane strain" (2D: in-plane x-y components only)."""
    eps = 0.5 * (H + np.swapaxes(H, 1, 2))
    sig = np.zeros_like(eps)
    if mode == "3d":
        lam = E * nu / ((1 + nu) * (1 - 2 * nu))
        mu = E / (2 * (1 + nu))
        tr = np.trace(eps, axis1=1, axis2=2)
        sig = 2 * mu * eps + lam * tr[:, None, None] * np.eye(3)
    else:
        e2 = eps[:, :2, :2]
        tr = e2[:, 0, 0] + e2[:, 1, 1]
        mu = E / (2 * (1 + nu))
        lam = E * nu / (1 - nu * nu) if mode == "plane stress" else E * nu / ((1 + nu) * (1 - 2 * nu))
        sig[:, :2, :2] = 2 * mu * e2 + lam * tr[:, None, None] * np.eye(2)
        eps = eps.copy()
        eps[:, 2, :] = 0.0
        eps[:, :, 2] = 0.0
    W = 0.5 * np.einsum("pab,pab->p", sig, eps)
    return sig, W


def elastic_constants(material) -> tuple[float, float, str]:
    """(E, nu, mode) of the small-strain Hooke law equivalent to a block's material, from its
    ``elastic_moduli()`` (any material, built-in or plugin, whose constants are Hookean)."""
    moduli = material.elastic_moduli()
    if moduli is None or not moduli.hookean:
        why = "gives no elastic constants" if moduli is None else "is not linear elastic (ElasticModuli.hookean is false)"
        raise ValueError(f"J_Integral supports blocks of linear elastic materials (Material.elastic_moduli() with hookean "
                         f"constants, e.g. 'Elastic', 'Elastic Bond Based'); {material.name!r} {why}")
    E, nu = moduli.youngs_and_poisson()
    return E, nu, moduli.planar


def _unit(v, what: str) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    n = float(np.linalg.norm(v))
    if not n > 0.0:
        raise ValueError(f"{what} must not be the zero vector")
    return v / n


class JIntegralParams(ModelParams):
    crack_tip_x: float = Field(alias="Crack Tip X", description="a point of the crack front (L)")
    crack_tip_y: float = Field(alias="Crack Tip Y", description="a point of the crack front (L)")
    crack_tip_z: float = Field(0.0, alias="Crack Tip Z", description="a point of the crack front (L)")
    crack_direction_x: float = Field(1.0, alias="Crack Direction X", description="crack growth direction e (normalized; default +x)")
    crack_direction_y: float = Field(0.0, alias="Crack Direction Y", description="crack growth direction e")
    crack_direction_z: float = Field(0.0, alias="Crack Direction Z", description="crack growth direction e")
    front_direction_x: float = Field(0.0, alias="Crack Front X", description="direction of the crack front line t (default z)")
    front_direction_y: float = Field(0.0, alias="Crack Front Y", description="direction of the crack front line t")
    front_direction_z: float = Field(1.0, alias="Crack Front Z", description="direction of the crack front line t")
    inner_radius: float = Field(alias="Inner Radius", gt=0, description="q = 1 within this distance of the front (L); a few horizons")
    outer_radius: float = Field(alias="Outer Radius", gt=0, description="q = 0 beyond this distance of the front (L)")
    thickness: float = Field(alias="Thickness", gt=0, description="length of crack front in the model (L): plate thickness or 2D Height")
    block: str | None = Field(None, alias="Block", description="block name (default: every block)")
    output_label: str | None = Field(None, alias="Output Label", description="name of the global output (default: the section name)")

    @model_validator(mode="after")
    def _geometry(self):
        if not self.outer_radius > self.inner_radius:
            raise ValueError("'Outer Radius' must be larger than 'Inner Radius'")
        e = _unit((self.crack_direction_x, self.crack_direction_y, self.crack_direction_z), "Crack Direction")
        t = _unit((self.front_direction_x, self.front_direction_y, self.front_direction_z), "Crack Front")
        if abs(float(e @ t)) > 1e-6:
            raise ValueError("'Crack Direction' must be perpendicular to 'Crack Front'")
        return self


class JIntegralDomain(Compute):
    """Energy release rate J (energy per crack area, J/m^2 in SI) at a crack front: a global
    scalar named by ``Output Label``."""

    name = "J_Integral"
    Params = JIntegralParams

    @classmethod
    def output_label(cls, params: JIntegralParams) -> str | None:
        return params.output_label

    def outputs(self, sim):
        return [FieldSpec(self.label, Relation.GLOBAL, 1)]

    def _blocks(self, sim):
        p = self.params
        return [b for b in sim.blocks if p.block is None or b.name == p.block]

    def check(self, sim) -> list[str]:
        blocks = self._blocks(sim)
        if not blocks:
            return [f"Block {self.params.block!r} is not a block of this model ({', '.join(b.name for b in sim.blocks)})"]
        problems = []
        for b in blocks:
            try:
                elastic_constants(b.material)
            except ValueError as exc:
                problems.append(f"{exc} (block {b.name})")
        return problems

    def initialize(self, sim) -> None:
        p = self.params
        self.tip = np.array([p.crack_tip_x, p.crack_tip_y, p.crack_tip_z])
        self.e = _unit((p.crack_direction_x, p.crack_direction_y, p.crack_direction_z), "Crack Direction")
        self.t = _unit((p.front_direction_x, p.front_direction_y, p.front_direction_z), "Crack Front")
        x = sim.fields["Model_Coordinates"]
        self.groups = []  # (points, q gradient (p, 3), E, nu, mode) per block
        for blk in self._blocks(sim):
            rows = np.arange(blk.start, blk.stop)
            d = x[rows] - self.tip
            d -= np.outer(d @ self.t, self.t)  # in-plane offset from the front line
            r = np.linalg.norm(d, axis=1)
            ring = (r > p.inner_radius) & (r < p.outer_radius)
            pts = rows[ring].astype(np.int64)
            dq = -d[ring] / (r[ring][:, None] * (p.outer_radius - p.inner_radius))
            self.groups.append((pts, dq, *elastic_constants(blk.material)))

    def value(self, sim) -> float:
        """J over all ranks (energy per area)."""
        s, nl = sim.fields, sim.bonds
        damage = s["Bond_Damage"] if "Bond_Damage" in s else np.zeros(0)
        total = 0.0
        for pts, dq, E, nu, mode in self.groups:
            if not pts.size:
                continue
            H = displacement_gradient(pts, nl.offsets, nl.neighbors, s["Bond_Length"], s["Model_Coordinates"], s["Coordinates"], s["Volume"],
                                      damage, sim.backend)
            H = H.reshape(-1, 3, 3)
            sig, W = hooke(H, E, nu, mode)
            du_de = H @ self.e  # (p, 3): u_a,c e_c
            integrand = np.einsum("pab,pa,pb->p", sig, du_de, dq) - W * (dq @ self.e)
            total += float(np.dot(integrand, s["Volume"][pts]))
        return float(sim.comm.allreduce_sum(np.array([total]))[0]) / self.params.thickness

    def compute(self, sim):
        sim.fields[self.label][:] = self.value(sim)


class PeridigmJIntegralParams(ModelParams):
    block_id: int = Field(alias="Block ID", description="block id the computation is restricted to")
    dt: float = Field(alias="dt", description="time step (unused: Peridigm's compute is not implemented)")


class PeridigmJIntegral(Compute):
    """Peridigm's ``JIntegral``: "not implemented (work in progress)" there; accepted so its
    decks run, checks that the block exists, and produces nothing (use ``J_Integral``)."""

    name = "JIntegral"
    Params = PeridigmJIntegralParams

    def outputs(self, sim):
        return []

    def check(self, sim) -> list[str]:
        if not any(b.block_id == self.params.block_id for b in sim.blocks):
            return [f"Block ID {self.params.block_id} is not a block of this model"]
        log.warning("Compute Class 'JIntegral' (Peridigm's) computes nothing, as in Peridigm; use 'J_Integral' for an energy release rate")
        return []

    def compute(self, sim):
        return None
