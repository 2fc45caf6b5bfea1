"""The point updates and sums of a velocity-Verlet step, written once as point laws
(:class:`~peridyn.core.traversal.PointUpdate`, :class:`~peridyn.core.traversal.PointReduction`)
that every backend compiles: numba on CPU threads and numba-cuda on a GPU run the same arithmetic.

Shapes: point vectors (n, 3), point scalars (n,), ``free`` (n, 3) bool (the components no
condition prescribes); an empty (0, 3) array for a body force or an acceleration means "none".
Units: velocities L/T, accelerations L/T^2, force densities M L^-2 T^-2, volumes L^3, masses M.
"""
from __future__ import annotations

from ...core.traversal import PointReduction, PointUpdate


def _kick(i, args):
    """v += dt/2 a (the half kick before prescribed velocities are applied); args (v, a, dt2)."""
    v, a, dt2 = args
    for c in range(3):
        v[i, c] += dt2 * a[i, c]


def _drift(i, args):
    """du = dt v; y = (x + u) + du; u += du; args (v, dt, x, u, y, du)."""
    v, dt, x, u, y, du = args
    for c in range(3):
        d = dt * v[i, c]
        du[i, c] = d
        y[i, c] = (x[i, c] + u[i, c]) + d
        u[i, c] += d


def _accelerate(i, args):
    """a = (f + b) / rho (b empty: no body force), then v += dt/2 a when ``kick``; args
    (f, b, rho, dt2, a, v, kick)."""
    f, b, rho, dt2, a, v, kick = args
    has_b = b.shape[0] > 0
    for c in range(3):
        acc = f[i, c]
        if has_b:
            acc += b[i, c]
        acc /= rho[i]
        a[i, c] = acc
        if kick:
            v[i, c] += dt2 * acc


def _copy_vectors(i, args):
    """out[i, :] = values[i, :]; args (values, out)."""
    values, out = args
    for c in range(3):
        out[i, c] = values[i, c]


def _step_sums(i, args):
    """Point i's share of one step's seven sums (args (du, f_old, f_new, b_old, b_new, volume,
    free, v, a, mass); b_old empty: no body force, a empty: no accelerations): internal work on
    all components and on prescribed ones (trapezoidal rule), body-force work on free components,
    the kinetic energy of the free components, the sum of the force densities (finite or not),
    and 1/2 m |a|^2 and 1/2 V^2/m |b|^2 over free components (C and C_b before their dt^2/4)."""
    du, f_old, f_new, b_old, b_new, volume, free, v, a, mass = args
    has_b = b_old.shape[0] > 0
    has_a = a.shape[0] > 0
    w = 0.0
    p = 0.0
    q = 0.0
    k = 0.0
    g = 0.0
    e = 0.0
    force = 0.0
    for c in range(3):
        fw = 0.5 * (f_old[i, c] + f_new[i, c]) * du[i, c]
        w += fw
        force += f_new[i, c]
        if free[i, c]:
            if has_b:
                q += 0.5 * (b_old[i, c] + b_new[i, c]) * du[i, c]
                e += b_new[i, c] * b_new[i, c]
            k += v[i, c] * v[i, c]
            if has_a:
                g += a[i, c] * a[i, c]
        else:
            p += fw
    load = 0.5 * volume[i] * volume[i] / mass[i] * e if e > 0.0 else 0.0
    return w * volume[i], p * volume[i], q * volume[i], 0.5 * mass[i] * k, force, 0.5 * mass[i] * g, load


def _kinetic_free(i, args):
    """1/2 m_i sum_c v_ic^2 over point i's free components; args (v, mass, free)."""
    v, mass, free = args
    s = 0.0
    for c in range(3):
        if free[i, c]:
            s += v[i, c] * v[i, c]
    return 0.5 * mass[i] * s


KICK = PointUpdate(_kick)
DRIFT = PointUpdate(_drift)
ACCELERATE = PointUpdate(_accelerate)
COPY_VECTORS = PointUpdate(_copy_vectors)
#: the seven sums of ``_step_sums``, in that order
STEP_SUMS = PointReduction(_step_sums, width=7)
KINETIC_FREE = PointReduction(_kinetic_free)
