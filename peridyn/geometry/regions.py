"""Evaluating the deck's regions (:mod:`peridyn.deck.regions`) on a point cloud: which points a
geometric node set holds (docs/regions.md).

Regions are evaluated on the *reference* coordinates of all points of the discretization,
which every MPI rank holds, so a node set is the same on any number of ranks. Boundaries are
inclusive with a tolerance of ``TOLERANCE`` times the point's spacing h_i = V_i^(1/3): a lattice
plane lying exactly on a box face, a sphere or a half-space plane is inside, whatever the
round-off of its coordinates. An ``Expression`` is evaluated on the coordinates rounded to a
decimal step of at most ``TOLERANCE`` h_i (:func:`decimal_snap`), so its comparisons read the
coordinates as the deck's decimal numbers: ``x > 0.0565`` leaves out a lattice plane stored at
0.05650000000000004 and ``x >= 0.0565`` keeps it, on either side of a body.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..core.errors import InputError
from ..deck.regions import RegionSpec, axis_vector
from .surface import Surface, free_surface

__all__ = ["TOLERANCE", "decimal_snap", "region_mask"]

#: boundaries are inclusive within this fraction of the local spacing
TOLERANCE = 1.0e-4


class _Cloud:
    """The points, their spacings and (computed once, when a Surface Layer asks) their free surface."""

    def __init__(self, x: np.ndarray, volume: np.ndarray, surface: Callable[[], Surface] | None) -> None:
        self.x = np.asarray(x, dtype=float).reshape(-1, 3)
        self.volume = np.asarray(volume, dtype=float)
        self.tol = TOLERANCE * np.cbrt(self.volume)
        self._snapped: np.ndarray | None = None
        self._provider = surface
        self._surface: Surface | None = None

    @property
    def snapped(self) -> np.ndarray:
        """(n, 3) the coordinates an Expression reads (:func:`decimal_snap`)."""
        if self._snapped is None:
            self._snapped = decimal_snap(self.x, self.tol)
        return self._snapped

    @property
    def surface(self) -> Surface:
        if self._surface is None:
            self._surface = self._provider() if self._provider is not None else free_surface(self.x, self.volume)
        return self._surface


def decimal_snap(x: np.ndarray, tol: np.ndarray) -> np.ndarray:
    """(n, 3) ``x`` (n, 3) rounded, per point, to the largest decimal step 10^-d not above
    ``tol`` (n,) (same unit as x): each coordinate moves by at most half a step, and a coordinate
    computed with round-off (``origin + i * dx``) becomes the double nearest its decimal value, the
    number a deck writes. Points of a lattice mirrored about a decimal plane come out exactly
    mirrored. Points whose ``tol`` is not positive and finite are left as they are."""
    x = np.asarray(x, dtype=float)
    out = x.copy()
    tol = np.asarray(tol, dtype=float)
    ok = np.isfinite(tol) & (tol > 0.0)
    if not ok.any():
        return out
    digits = np.ceil(-np.log10(tol[ok]))  # 10^-digits <= tol
    fine = digits >= 0
    with np.errstate(all="ignore"):
        up = 10.0 ** np.clip(digits, 0, 300)[:, None]  # exact powers of ten up to 1e22
        down = 10.0 ** np.clip(-digits, 0, 300)[:, None]
        xs = x[ok]
        snapped = np.where(fine[:, None], np.rint(xs * up) / up, np.rint(xs / down) * down)
    # beyond 2^52 steps a double has no fraction of a step left to round; keep such values
    keep = ~np.isfinite(snapped) | (np.abs(xs) >= 2.0**52 * np.where(fine, 1.0 / up[:, 0], down[:, 0])[:, None])
    out[ok] = np.where(keep, xs, snapped)
    return out


def region_mask(region: RegionSpec, x: np.ndarray, volume: np.ndarray, *, surface: Callable[[], Surface] | None = None,
                path: tuple[str, ...] = (), file: str | None = None) -> np.ndarray:
    """(n,) bool: the points of ``x`` (n, 3) (L, reference coordinates), with volumes
    ``volume`` (n,) (L^3), that lie in ``region``. ``surface``: returns the cloud's free surface
    (called only when a Surface Layer needs it; computed here when not given). An expression
    that is NaN at a point is an input error naming ``path``."""
    return _mask(region, _Cloud(x, volume, surface), path, file)


def _mask(r: RegionSpec, c: _Cloud, path: tuple[str, ...], file: str | None) -> np.ndarray:
    x, tol = c.x, c.tol
    if r.all is not None:
        return np.ones(len(x), dtype=bool)
    if r.box is not None:
        lo, hi = np.asarray(r.box.min), np.asarray(r.box.max)
        return np.all((x >= lo - tol[:, None]) & (x <= hi + tol[:, None]), axis=1)
    if r.sphere is not None:
        return np.linalg.norm(x - np.asarray(r.sphere.center), axis=1) <= r.sphere.radius + tol
    if r.cylinder is not None:
        cyl = r.cylinder
        a = np.asarray(axis_vector(cyl.axis), dtype=float)
        a = a / np.linalg.norm(a)
        d = x - np.asarray(cyl.center)
        s = d @ a
        radial = np.linalg.norm(d - s[:, None] * a, axis=1)
        inside = (radial <= cyl.radius + tol) & (radial >= cyl.inner_radius - tol) if cyl.inner_radius > 0 else radial <= cyl.radius + tol
        lo, hi = (-0.5 * cyl.length, 0.5 * cyl.length) if cyl.length is not None else (cyl.min, cyl.max)
        if lo is not None:
            inside &= s >= lo - tol
        if hi is not None:
            inside &= s <= hi + tol
        return inside
    if r.half_space is not None:
        n = np.asarray(r.half_space.normal, dtype=float)
        return (x - np.asarray(r.half_space.point)) @ (n / np.linalg.norm(n)) >= -tol
    if r.expression is not None:
        from ..deck.expressions import compile_expression

        with np.errstate(all="ignore"):
            xs = c.snapped
            value = np.broadcast_to(np.asarray(compile_expression(r.expression, ("x", "y", "z"))(x=xs[:, 0], y=xs[:, 1], z=xs[:, 2]), dtype=float), (len(x),))
        if np.isnan(value).any():
            k = int(np.argmax(np.isnan(value)))
            raise InputError(f"the region expression {r.expression!r} is NaN at the point {tuple(float(v) for v in x[k])}", file=file,
                             path=path + ("Expression",), fix="write an expression that is defined (zero or nonzero) at every point")
        return value != 0.0
    if r.surface_layer is not None:
        return c.surface.depth <= r.surface_layer.thickness + tol
    if r.union is not None:
        return np.logical_or.reduce([_mask(p, c, path + ("Union", k), file) for k, p in r.union.items()])
    if r.intersection is not None:
        return np.logical_and.reduce([_mask(p, c, path + ("Intersection", k), file) for k, p in r.intersection.items()])
    if r.difference is not None:
        first, *rest = (_mask(p, c, path + ("Difference", k), file) for k, p in r.difference.items())
        return first & ~np.logical_or.reduce(rest)
    raise AssertionError(f"unhandled region {r!r}")  # pragma: no cover - RegionSpec has exactly one key
