"""CUDA kernels of the explicit step outside the bond loops: the Verlet updates, conditions on
node sets, and the energy sums the monitor reads (shapes as in :mod:`peridyn.solvers.verlet`:
(n, 3) point vectors, (n,) point scalars; one thread per point or per node-set entry).

The point updates repeat the arithmetic of the CPU kernels of ``peridyn.solvers.verlet`` and
``peridyn.solvers.common`` operation for operation (the same values up to the GPU compiler's
fused multiply-adds); the sums are reduced in a fixed order (per block, then one block), so a
run gives the same energies every time.
"""
from __future__ import annotations

from numba import config, cuda, float64

#: threads per block of the reductions (a power of two; few under the simulator, where each
#: thread is a Python thread)
REDUCE_THREADS = 2 if config.ENABLE_CUDASIM else 128
#: most blocks of a reduction (each thread strides over the points)
REDUCE_BLOCKS = 1 if config.ENABLE_CUDASIM else 1024
#: sums of ``energy_partials`` (internal work, work on prescribed components, body-force
#: work, kinetic energy of free components, sum of force densities, acceleration "shadow")
SUMS = 7


@cuda.jit(cache=True)
def kick(n, v, a, dt2):
    for i in range(cuda.grid(1), n, cuda.gridsize(1)):
        for c in range(3):
            v[i, c] += dt2 * a[i, c]


@cuda.jit(cache=True)
def drift(n, v, dt, x, u, y, du):
    for i in range(cuda.grid(1), n, cuda.gridsize(1)):
        for c in range(3):
            d = dt * v[i, c]
            du[i, c] = d
            y[i, c] = (x[i, c] + u[i, c]) + d
            u[i, c] += d


@cuda.jit(cache=True)
def acceleration_kick(n, f, b, rho, dt2, a, v, kick):
    for i in range(cuda.grid(1), n, cuda.gridsize(1)):
        has_b = b.shape[0] > 0
        for c in range(3):
            acc = f[i, c]
            if has_b:
                acc += b[i, c]
            acc /= rho[i]
            a[i, c] = acc
            if kick:
                v[i, c] += dt2 * acc


@cuda.jit(cache=True)
def fill(out, value):
    """Every entry of a 2-D array set to ``value``."""
    for i in range(cuda.grid(1), out.shape[0], cuda.gridsize(1)):
        for c in range(out.shape[1]):
            out[i, c] = value


@cuda.jit(cache=True)
def set_component(points, component, values, out):
    """out[points[k], component] = values[k] (a condition's values on its node set)."""
    for k in range(cuda.grid(1), points.shape[0], cuda.gridsize(1)):
        out[points[k], component] = values[k]


@cuda.jit(cache=True)
def set_scalar(points, values, out):
    for k in range(cuda.grid(1), points.shape[0], cuda.gridsize(1)):
        out[points[k]] = values[k]


@cuda.jit(cache=True)
def set_difference(points, values, base, out):
    """out[points[k]] = values[k] - base[k] (a temperature change)."""
    for k in range(cuda.grid(1), points.shape[0], cuda.gridsize(1)):
        out[points[k]] = values[k] - base[k]


@cuda.jit(cache=True)
def prescribed_displacement(points, component, current, previous, rate, u, v):
    """Prescribed Displacement through the velocity (``PrescribedDisplacement.increment``):
    du = f(t) - f(t_prev), or f(t) - u where the two values are equal; v = du * rate,
    rate = 1 / (t - t_prev)."""
    for k in range(cuda.grid(1), points.shape[0], cuda.gridsize(1)):
        p = points[k]
        du = current[k] - previous[k]
        if du == 0.0:
            du = current[k] - u[p, component]
        v[p, component] = du * rate


@cuda.jit(device=True)
def _block_sum(buf, t):
    """buf[k, 0] = the sum of buf[k, :] over the block's threads (a tree, fixed order; every
    thread of the block calls it)."""
    cuda.syncthreads()
    s = REDUCE_THREADS // 2
    while s > 0:
        if t < s:
            for k in range(SUMS):
                buf[k, t] += buf[k, t + s]
        cuda.syncthreads()
        s //= 2


@cuda.jit(cache=True)
def energy_partials(n, du, f_old, f_new, b_old, b_new, volume, free, v, mass, a, partial):
    """Per-block partial sums (``SUMS`` per block, row ``blockIdx.x`` of ``partial``) of the
    step's work and energies, each point's terms as ``step_account_kernel`` and
    ``kinetic_free_kernel`` compute them (the last two sums without their factor dt^2 / 4)."""
    buf = cuda.shared.array((SUMS, REDUCE_THREADS), float64)
    t = cuda.threadIdx.x
    has_b = b_old.shape[0] > 0
    s_all = 0.0
    s_presc = 0.0
    s_body = 0.0
    s_kin = 0.0
    s_f = 0.0
    s_shadow = 0.0
    s_load = 0.0
    for i in range(cuda.grid(1), n, cuda.gridsize(1)):
        w_a = 0.0
        w_p = 0.0
        w_b = 0.0
        kin = 0.0
        sh = 0.0
        e = 0.0
        for c in range(3):
            w = 0.5 * (f_old[i, c] + f_new[i, c]) * du[i, c]
            w_a += w
            s_f += f_new[i, c]
            if free[i, c]:
                if has_b:
                    w_b += 0.5 * (b_old[i, c] + b_new[i, c]) * du[i, c]
                    e += b_new[i, c] * b_new[i, c]
                kin += v[i, c] * v[i, c]
                sh += a[i, c] * a[i, c]
            else:
                w_p += w
        s_all += w_a * volume[i]
        s_presc += w_p * volume[i]
        s_body += w_b * volume[i]
        s_kin += 0.5 * mass[i] * kin
        s_shadow += 0.5 * mass[i] * sh
        if e > 0.0:
            s_load += 0.5 * volume[i] * volume[i] / mass[i] * e
    buf[0, t] = s_all
    buf[1, t] = s_presc
    buf[2, t] = s_body
    buf[3, t] = s_kin
    buf[4, t] = s_f
    buf[5, t] = s_shadow
    buf[6, t] = s_load
    _block_sum(buf, t)
    if t == 0:
        for k in range(SUMS):
            partial[cuda.blockIdx.x, k] = buf[k, 0]


@cuda.jit(cache=True)
def reduce_partials(partial, nblocks, out):
    """out[k] = sum of partial[:nblocks, k], one block of ``REDUCE_THREADS`` threads."""
    buf = cuda.shared.array((SUMS, REDUCE_THREADS), float64)
    t = cuda.threadIdx.x
    for k in range(SUMS):
        acc = 0.0
        r = t
        while r < nblocks:
            acc += partial[r, k]
            r += REDUCE_THREADS
        buf[k, t] = acc
    _block_sum(buf, t)
    if t == 0:
        for k in range(SUMS):
            out[k] = buf[k, 0]
