"""The point laws of a step (``PointUpdate``, ``PointReduction``) on every backend: the node-set
scatters write what numpy's fancy assignment writes, the Verlet updates what their formulas
give, and a reduction is the sum in item order on the CPU, the same bits on every CPU backend and
thread count. A parfor pass of numba once dropped the writes of a scatter inlined into a parallel
loop: ``test_scatters_write_every_entry`` is the guard."""
from __future__ import annotations

import numpy as np
import pytest

from peridyn.kernels import scatter as S
from peridyn.kernels.numba_cpu import NumbaBackend, SerialNumbaBackend
from peridyn.solvers.explicit import laws as L

BACKENDS = [NumbaBackend, SerialNumbaBackend]


def gpu_backend():
    pytest.importorskip("numba.cuda")
    from peridyn.kernels.numba_cuda import CudaBackend, simulated

    if not simulated():
        pytest.skip("the GPU backend is tested here under numba-cuda's simulator")
    return CudaBackend()


def backends():
    return [pytest.param(cls, id=cls.name) for cls in BACKENDS] + [pytest.param(gpu_backend, id="cuda")]


def run(backend, law, count, args, out=None):
    """Run ``law`` on ``backend`` with host arrays (copied to and from the backend)."""
    dev = tuple(backend.asarray(a) if isinstance(a, np.ndarray) else a for a in args)
    if out is None:
        backend.kernel(law)(0, count, dev)
    else:
        o = backend.asarray(out)
        backend.kernel(law)(0, count, dev, o)
        out[:] = backend.to_host(o)
    return [backend.to_host(d) if isinstance(a, np.ndarray) else a for a, d in zip(args, dev)]


@pytest.mark.parametrize("make", backends())
@pytest.mark.parametrize("n", [1, 5, 3000, 5000])  # below, at and across the CPU's chunks of items
def test_scatters_write_every_entry(make, n):
    backend = make()
    rng = np.random.default_rng(n)
    points = np.sort(rng.choice(n, size=max(1, n // 3), replace=False)).astype(np.int64)
    values, base = rng.standard_normal(points.size), rng.standard_normal(points.size)
    vectors = rng.standard_normal((n, 3))

    expect = vectors.copy()
    expect[points, 1] = values
    got = run(backend, S.SET_COMPONENT, points.size, (points, 1, values, vectors.copy()))[3]
    assert np.array_equal(got, expect)

    scalars = rng.standard_normal(n)
    expect = scalars.copy()
    expect[points] = values - base
    assert np.array_equal(run(backend, S.SET_DIFFERENCE, points.size, (points, values, base, scalars.copy()))[3], expect)
    expect[points] = values
    assert np.array_equal(run(backend, S.SET_SCALAR, points.size, (points, values, expect.copy()))[2], expect)

    rows = rng.standard_normal((points.size, 3))
    expect = vectors.copy()
    expect[points] += 0.7 * rows
    assert np.array_equal(run(backend, S.ADD_SCALED, points.size, (points, 0.7, rows, vectors.copy()))[3], expect)
    assert not run(backend, S.ZERO_VECTORS, n, (vectors.copy(),))[0].any()

    # a prescribed displacement: du = f(t) - f(t_prev), or the target minus u where they are equal
    u, v, du = rng.standard_normal((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
    current, previous = values.copy(), values.copy()
    previous[::2] += 1.0
    step = current - previous
    step[1::2] = current[1::2] - u[points[1::2], 2]
    out = run(backend, S.PRESCRIBED_DISPLACEMENT, points.size, (points, 2, current, previous, 4.0, u, v, du))
    assert np.array_equal(out[6][points, 2], step * 4.0) and np.array_equal(out[7][points, 2], step)
    assert not np.delete(out[6], points, axis=0).any()


@pytest.mark.parametrize("make", backends())
def test_the_verlet_updates_and_sums(make):
    backend = make()
    n = 4099
    rng = np.random.default_rng(1)
    v, a, x, u, f, f0, b = (rng.standard_normal((n, 3)) for _ in range(7))
    rho, volume = rng.random(n) + 0.5, rng.random(n) + 0.5
    mass = rho * volume
    free = rng.random((n, 3)) > 0.3
    kicked = run(backend, L.KICK, n, (v.copy(), a, 0.25))[0]
    assert np.array_equal(kicked, v + 0.25 * a)
    _, _, _, u1, y1, du1 = run(backend, L.DRIFT, n, (v, 0.5, x, u.copy(), np.zeros((n, 3)), np.zeros((n, 3))))
    assert np.array_equal(du1, 0.5 * v) and np.array_equal(u1, u + 0.5 * v) and np.array_equal(y1, (x + u) + 0.5 * v)
    out = run(backend, L.ACCELERATE, n, (f, b, rho, 0.25, np.zeros((n, 3)), v.copy(), True))
    acc = (f + b) / rho[:, None]
    np.testing.assert_allclose(out[4], acc, rtol=1e-15)
    np.testing.assert_allclose(out[5], v + 0.25 * acc, rtol=1e-14, atol=1e-14)
    sums = np.zeros(7)
    run(backend, L.STEP_SUMS, n, (du1, f0, f, b, b, volume, free, v, a, mass), sums)
    w = 0.5 * (f0 + f) * du1
    expect = [(w.sum(axis=1) * volume).sum(), (np.where(free, 0.0, w).sum(axis=1) * volume).sum(),
              (np.where(free, b * du1, 0.0).sum(axis=1) * volume).sum(), (0.5 * mass * np.where(free, v * v, 0.0).sum(axis=1)).sum(),
              f.sum(), (0.5 * mass * np.where(free, a * a, 0.0).sum(axis=1)).sum(),
              (0.5 * volume**2 / mass * np.where(free, b * b, 0.0).sum(axis=1)).sum()]
    np.testing.assert_allclose(sums, expect, rtol=1e-11, atol=1e-11 * np.abs(expect).max())


def test_a_reduction_has_the_same_bits_on_every_cpu_backend():
    n = 10007
    rng = np.random.default_rng(2)
    v, mass, free = rng.standard_normal((n, 3)), rng.random(n), rng.random((n, 3)) > 0.5
    totals = []
    for cls in BACKENDS:
        out = np.zeros(1)
        cls().kernel(L.KINETIC_FREE)(0, n, (v, mass, free), out)
        totals.append(out[0])
    serial = 0.0
    for i in range(n):  # item order
        s = 0.0
        for c in range(3):
            if free[i, c]:
                s += v[i, c] * v[i, c]
        serial += 0.5 * mass[i] * s
    assert totals == [serial] * len(BACKENDS)


@pytest.mark.parametrize("make", backends())
@pytest.mark.parametrize("n", [0, 1, 5, 3000])
def test_a_largest_and_a_smallest_term_on_every_backend(make, n):
    """``combine="max"`` and ``"min"`` (contact's displacement and distance checks): the largest
    and smallest terms, a NaN counted as infinity by the displacement term itself, -inf and inf
    over no items."""
    from peridyn.contact import pair_laws as C

    backend = make()
    rng = np.random.default_rng(n + 3)
    y, y0 = rng.standard_normal((n, 3)), rng.standard_normal((n, 3))
    d2 = ((y - y0) ** 2).sum(axis=1)
    out = np.zeros(1)
    run(backend, C.MAX_DISPLACEMENT2, n, (y, y0), out)
    assert out[0] == (d2.max() if n else -np.inf)
    if n > 1:
        y[n // 2, 1] = np.nan
        run(backend, C.MAX_DISPLACEMENT2, n, (y, y0), out)
        assert out[0] == np.inf
    offsets = np.arange(n + 1, dtype=np.int64)  # row p: the pair (p, n - 1 - p)
    partners = np.arange(n, dtype=np.int32)[::-1].copy()
    run(backend, C.MIN_PAIR_DISTANCE2, n, (offsets, partners, y0), out)
    pair = ((y0[::-1] - y0) ** 2).sum(axis=1)
    assert out[0] == (pair.min() if n else np.inf)
