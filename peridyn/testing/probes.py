"""Measurements the conformance suites make on a built model (no assertions here).

* :func:`stated_moduli`: the bulk and shear moduli a deck's material parameters state;
* :func:`interior_points`: the points whose family (and their families' families) is whole;
* :func:`force_moduli`: the cubic elastic constants a material shows under quadratic
  displacement fields, from the force density at interior points (the Navier operator);
* :func:`energy_moduli`: the same constants from the stored energy density under homogeneous
  strains, for materials that define an energy.

A material on a cubic lattice is at best cubic: it has three constants C11, C12, C44 (Voigt
notation). Their isotropic averages, the bulk modulus ``(C11 + 2 C12) / 3`` and the shear
modulus ``(C11 - C12 + 3 C44) / 5``, are what a correct isotropic model reproduces (the
linear peridynamic solid exactly; a bond-based model within its lattice error); the cubic
anisotropy is the lattice's.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["CubicModuli", "energy_moduli", "force_moduli", "interior_points", "relative_log_error", "stated_moduli", "uniform_stretch"]

#: deck names of the elastic constants :func:`stated_moduli` reads
MODULUS_KEYS = {"Bulk Modulus": "K", "Shear Modulus": "G", "Young's Modulus": "E", "Poisson's Ratio": "nu"}


@dataclass(frozen=True)
class CubicModuli:
    """Elastic constants C11, C12, C44 of a response with cubic symmetry (M L^-1 T^-2), and
    ``spread``: the largest relative difference between the points they were measured at."""

    c11: float
    c12: float
    c44: float
    spread: float = 0.0
    dimension: int = 3  #: 2: in-plane constants of a plate (C44 is then C66)

    @property
    def bulk(self) -> float:
        """The bulk modulus, exact for any cubic response: (C11 + 2 C12) / 3 (3D), the 2D bulk
        modulus (C11 + C12) / 2 (plate)."""
        if self.dimension == 2:
            return 0.5 * (self.c11 + self.c12)
        return (self.c11 + 2.0 * self.c12) / 3.0

    @property
    def shear(self) -> float:
        """The isotropic (Voigt) average of the shear modulus: (C11 - C12 + 3 C44) / 5 (3D),
        (C11 - C12 + 2 C66) / 4 (plate)."""
        if self.dimension == 2:
            return 0.25 * (self.c11 - self.c12 + 2.0 * self.c44)
        return (self.c11 - self.c12 + 3.0 * self.c44) / 5.0


def stated_moduli(params: dict[str, Any]) -> tuple[float, float] | None:
    """(K, G) that the deck parameters ``params`` state, or None when they state neither.

    Two of ``Bulk Modulus``, ``Shear Modulus``, ``Young's Modulus``, ``Poisson's Ratio`` give
    both, as Peridigm converts them (with ``Plane Strain`` / ``Plane Stress``: the 2D bulk
    modulus). One of ``Bulk Modulus`` / ``Young's Modulus`` alone is read as a bond-based
    material, whose Poisson's ratio is fixed: 1/4 in 3D (G = 3 K / 5, K = E / 1.5); in 2D 1/4 in
    plane strain, 1/3 in plane stress, and G = K / 2 either way (K the 2D bulk modulus).
    """
    from ..materials.moduli import bulk_and_shear

    strain, stress = bool(params.get("Plane Strain")), bool(params.get("Plane Stress"))
    given = {MODULUS_KEYS[k]: float(v) for k, v in params.items() if k in MODULUS_KEYS and v is not None}
    if len(given) == 2:
        return bulk_and_shear(**given, plane_strain=strain, plane_stress=stress)
    if set(given) not in ({"K"}, {"E"}):
        return None
    if not (strain or stress):
        K = given["K"] if "K" in given else given["E"] / 1.5
        return K, 0.6 * K
    K = given["K"] if "K" in given else bulk_and_shear(E=given["E"], nu=0.25 if strain else 1.0 / 3.0, plane_strain=strain, plane_stress=stress)[0]
    return K, 0.5 * K


def interior_points(sim: Any, depth: int = 2) -> np.ndarray:
    """Indices of the owned points whose neighborhood is whole to ``depth`` horizons: depth 1,
    a family as large as the largest (on a lattice: no bond cut by a surface); depth 2, and
    every neighbor's too (what a state-based force at the point depends on)."""
    nl = sim.bonds
    n = sim.num_owned
    counts = np.diff(nl.offsets)[:n]
    inside = counts == counts.max() if n else np.zeros(0, bool)
    rows = np.repeat(np.arange(n), counts)
    for _ in range(depth - 1):
        neighbors = nl.neighbors[: nl.offsets[n]]
        outside = np.ones(sim.num_local, bool)
        outside[:n] = ~inside
        bad = np.zeros(n, bool)
        bad[rows[outside[neighbors]]] = True
        inside = inside & ~bad
    return np.nonzero(inside)[0]


def _centre(x: np.ndarray) -> np.ndarray:
    return 0.5 * (x.min(axis=0) + x.max(axis=0))


def _quadratic_fields() -> list[tuple[str, Callable[[np.ndarray, int, int], np.ndarray], int]]:
    """(name, u(r, a, b) (n, 3) dimensionless, measured component: 0 = a, 1 = b) of the three
    fields: for a cubic material f_a = C11 (A), f_a = C44 (B), f_b = C12 + C44 (C)."""

    def field_a(r, a, b):
        u = np.zeros_like(r)
        u[:, a] = 0.5 * r[:, a] ** 2
        return u

    def field_b(r, a, b):
        u = np.zeros_like(r)
        u[:, a] = 0.5 * r[:, b] ** 2
        return u

    def field_c(r, a, b):
        u = np.zeros_like(r)
        u[:, a] = r[:, a] * r[:, b]
        return u

    return [("A", field_a, 0), ("B", field_b, 0), ("C", field_c, 1)]


def _axis_pairs(dimension: int) -> list[tuple[int, int]]:
    return [(0, 1), (1, 0)] if dimension == 2 else [(0, 1), (1, 2), (2, 0)]


def force_moduli(
    sim: Any, spacing: float, strain: float = 1e-5, *, dimension: int = 3, force: Callable[[Any], np.ndarray] | None = None
) -> CubicModuli:
    """Cubic constants from the force density at depth-2 interior points of a lattice model.

    For a displacement u with constant second derivatives, linear elasticity gives the force
    density div sigma = (K + G/3) grad div u + G lap u (isotropic, 3D), or with cubic constants:
    ``u_a = x_a^2 / 2`` -> f_a = C11, ``u_a = x_b^2 / 2`` -> f_a = C44, ``u_a = x_a x_b`` ->
    f_b = C12 + C44 (the same in 2D with C66). Each field is applied as
    ``u = strain * spacing * q((x - c) / spacing)`` (|grad u| <= strain x half the body's width
    in spacings) along the axis pairs (a, b) = (0, 1), (1, 2), (2, 0) (plate: (0, 1), (1, 0));
    the constants are the means over pairs and interior points.

    sim: a lattice model of ``spacing`` (L) large enough to have interior points (a cube of 15
    points per side for a horizon of 3.015 spacings). ``force(sim)`` returns (n, 3) force
    densities (M L^-2 T^-2; default ``sim.evaluate_forces``). ``spread`` of the result: the
    largest |f_i - mean| / |mean| of a measured component over the interior points (round-off
    and O(strain) geometric nonlinearity in a correct model: about 1e-5).
    """
    force = force or (lambda s: s.evaluate_forces().copy())
    n = sim.num_owned
    x = sim.fields["Model_Coordinates"][:n].copy()
    idx = interior_points(sim, 2)
    if idx.size == 0:
        raise ValueError("the model has no interior points (a family whole to two horizons); use a larger body")
    r = (x - _centre(x)) / spacing
    scale = strain / spacing  # second derivative of u (1/L)
    values: dict[str, list[float]] = {"A": [], "B": [], "C": []}
    spread = 0.0
    y = sim.fields["Coordinates"]
    try:
        for a, b in _axis_pairs(dimension):
            for name, field, which in _quadratic_fields():
                y[:n] = x + (strain * spacing) * field(r, a, b)
                f = force(sim)[idx, (a, b)[which]] / scale
                mean = float(f.mean())
                values[name].append(mean)
                spread = max(spread, float(np.abs(f - mean).max()) / max(abs(mean), 1e-300))
    finally:
        y[:n] = x
    c11 = float(np.mean(values["A"]))
    c44 = float(np.mean(values["B"]))
    c12 = float(np.mean(values["C"])) - c44
    return CubicModuli(c11, c12, c44, spread, dimension)


def energy_moduli(sim: Any, strain: float = 1e-4, *, dimension: int = 3) -> CubicModuli:
    """Cubic constants from the stored energy density W_i (``Material.stored_energy_density``)
    at depth-1 interior points under homogeneous strains E, y = x + E (x - c):

    * E = E0 I (plate: E0 diag(1, 1, 0)): W = 9 K E0^2 / 2 (plate: 2 K E0^2);
    * E = E0 diag(1, -1, 0) and its permutations: W = (C11 - C12) E0^2;
    * engineering shear E0 in the plane (a, b): W = C44 E0^2 / 2.
    """
    n = sim.num_owned
    x = sim.fields["Model_Coordinates"][:n].copy()
    idx = interior_points(sim, 1)
    if idx.size == 0:
        raise ValueError("the model has no interior points; use a larger body")
    d = x - _centre(x)
    y = sim.fields["Coordinates"]
    spread = 0.0

    def energy(E: np.ndarray) -> float:
        nonlocal spread
        y[:n] = x + d @ E.T
        sim.evaluate_forces()  # the precompute (dilatation, ...) of this configuration
        W = np.zeros(sim.num_local)
        for blk in sim.blocks:
            blk.material.stored_energy_density(blk.view, W)
        w = W[idx]
        m = float(w.mean())
        spread = max(spread, float(np.abs(w - m).max()) / max(abs(m), 1e-300))
        return m

    try:
        dilatation = np.diag([1.0, 1.0, 0.0 if dimension == 2 else 1.0])
        bulk = energy(strain * dilatation) / strain**2 / (2.0 if dimension == 2 else 4.5)
        dev, c44 = [], []
        for a, b in _axis_pairs(dimension)[: 1 if dimension == 2 else 3]:
            E = np.zeros((3, 3))
            E[a, a], E[b, b] = strain, -strain
            dev.append(energy(E) / strain**2)
            E = np.zeros((3, 3))
            E[a, b] = E[b, a] = 0.5 * strain
            c44.append(2.0 * energy(E) / strain**2)
    finally:
        y[:n] = x
        sim.evaluate_forces()
    c11_minus_c12 = float(np.mean(dev))
    # 3D: C11 + 2 C12 = 3 K; plate: C11 + C12 = 2 K
    c12 = (2.0 * bulk - c11_minus_c12) / 2.0 if dimension == 2 else (3.0 * bulk - c11_minus_c12) / 3.0
    return CubicModuli(c12 + c11_minus_c12, c12, float(np.mean(c44)), spread, dimension)


def uniform_stretch(sim: Any, strain: float) -> tuple[np.ndarray, np.ndarray]:
    """Stretch the body uniformly about its centre by ``strain``: y = c + (1 + strain)(x - c).
    Returns (x - c (n, 3), force density (n, 3)) of the owned points."""
    x = sim.fields["Model_Coordinates"][: sim.num_owned]
    d = x - _centre(x)
    sim.fields["Coordinates"][: sim.num_owned] = x + strain * d
    f = sim.evaluate_forces()[: sim.num_owned].copy()
    return d, f


def relative_log_error(measured: float, stated: float) -> float:
    """|ln(measured / stated)| (inf when the signs differ or one is zero)."""
    if measured <= 0.0 or stated <= 0.0:
        return math.inf
    return abs(math.log(measured / stated))
