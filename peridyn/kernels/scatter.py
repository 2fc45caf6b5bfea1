"""Conditions on node sets as point laws: the values a condition computed on the host for the
entries of its node set, written into the step's arrays by whichever backend holds them (the
CPU's threads or a GPU), and the order in which a step applies its conditions.

Every law runs over the entries ``k`` of a node set (``points`` (k,) local point indices; a point
listed twice gets the same value twice). Shapes: point vectors (n, 3), point scalars (n,).
"""
from __future__ import annotations

from typing import Any, Iterable

from ..core.traversal import PointUpdate


def _zero_vectors(i, args):
    """out[i, :] = 0; args (out,)."""
    out = args[0]
    for c in range(3):
        out[i, c] = 0.0


def _set_component(k, args):
    """out[points[k], component] = values[k]; args (points, component, values, out)."""
    points, component, values, out = args
    out[points[k], component] = values[k]


def _set_scalar(k, args):
    """out[points[k]] = values[k]; args (points, values, out)."""
    points, values, out = args
    out[points[k]] = values[k]


def _set_difference(k, args):
    """out[points[k]] = values[k] - base[k] (a temperature change); args (points, values, base, out)."""
    points, values, base, out = args
    out[points[k]] = values[k] - base[k]


def _add_scaled(k, args):
    """out[points[k], :] += scale * vectors[k, :] (a traction's share); args (points, scale, vectors, out)."""
    points, scale, vectors, out = args
    p = points[k]
    for c in range(3):
        out[p, c] += scale * vectors[k, c]


def _prescribed_displacement(k, args):
    """A displacement prescribed through the velocity on component ``component`` of point
    p = points[k]: du = current[k] - previous[k], or current[k] - u[p] where the two values are
    equal (an absolute target); v[p] = du * rate (rate = 1 / (t - t_prev)), and du into
    ``increments`` when it is not empty. args (points, component, current, previous, rate, u, v,
    increments)."""
    points, component, current, previous, rate, u, v, increments = args
    p = points[k]
    du = current[k] - previous[k]
    if du == 0.0:
        du = current[k] - u[p, component]
    v[p, component] = du * rate
    if increments.shape[0] > 0:
        increments[p, component] = du


ZERO_VECTORS = PointUpdate(_zero_vectors)
SET_COMPONENT = PointUpdate(_set_component)
SET_SCALAR = PointUpdate(_set_scalar)
SET_DIFFERENCE = PointUpdate(_set_difference)
ADD_SCALED = PointUpdate(_add_scaled)
PRESCRIBED_DISPLACEMENT = PointUpdate(_prescribed_displacement)


def scatter(where: Any, law: PointUpdate, count: int, args: tuple) -> None:
    """Run ``law`` over ``count`` entries on the placement ``where`` (nothing for none)."""
    if count:
        where.backend.kernel(law)(0, count, args)


def apply_kinematic(where: Any, conditions: Iterable[Any], t: float, t_prev: float) -> None:
    """The kinematic conditions, in deck order, for the step t_prev -> t on the placement ``where``."""
    for c in conditions:
        c.apply_kinematic(where, t, t_prev)


def apply_body_forces(where: Any, conditions: list[Any], t: float) -> None:
    """External_Force_Density on ``where`` zeroed, then each force condition's share at time t
    (nothing without force conditions)."""
    if not conditions:
        return
    out = where.fields["External_Force_Density"]
    scatter(where, ZERO_VECTORS, out.shape[0], (out,))
    for c in conditions:
        c.apply_force(where, t)
