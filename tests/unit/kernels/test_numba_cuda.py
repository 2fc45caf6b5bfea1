"""The GPU backend compiles the same loop laws as the CPU backends and computes the same values:
every law kind (point sums with a gate, point and finish, vector sums, bond maps, pair forces,
point maps) and the built-in materials' and damage laws, on device arrays, against the numba
backend. Under numba-cuda's simulator the arithmetic is Python's and the values are equal bit for
bit; on a GPU the compiler may fuse a multiply and an add, so the bound is round-off (1e-12
relative)."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba.cuda")

from numba import config  # noqa: E402

from peridyn.damage.critical_stretch import CRITICAL_STRETCH  # noqa: E402
from peridyn.kernels.numba_cpu import NumbaBackend  # noqa: E402
from peridyn.kernels.numba_cuda import CudaBackend, is_device_array  # noqa: E402
from peridyn.materials import elastic  # noqa: E402

from . import laws_for_tests as laws  # noqa: E402
from .test_backends import random_bonds  # noqa: E402

RTOL = 0.0 if config.ENABLE_CUDASIM else 1e-12


def both(law, n, offsets, neighbors, zeta, y, args, shape, dtype=float, start=0, stop=None, writes=()):
    """(CPU result, GPU result) of ``law``; ``writes`` are indices into ``args`` of arrays the
    law writes (compared too)."""
    stop = n if stop is None else stop
    cpu, gpu = NumbaBackend(), CudaBackend()
    out_c = np.full(shape, -7.0, dtype=dtype)
    args_c = tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args)
    cpu.kernel(law)(start, stop, offsets, neighbors, zeta, y, args_c, out_c)
    d = [gpu.asarray(a) if isinstance(a, np.ndarray) else a for a in args]
    out_g = gpu.asarray(np.full(shape, -7.0, dtype=dtype))
    gpu.kernel(law)(start, stop, gpu.asarray(offsets), gpu.asarray(neighbors), gpu.asarray(zeta), gpu.asarray(y), tuple(d), out_g)
    assert is_device_array(out_g)
    results = [(out_c, gpu.to_host(out_g))] + [(args_c[k], gpu.to_host(d[k])) for k in writes]
    return results


def close(a, b):
    if RTOL == 0.0:
        np.testing.assert_array_equal(a, b)
    else:
        np.testing.assert_allclose(a, b, rtol=RTOL, atol=RTOL * float(np.max(np.abs(a), initial=0.0)))


def test_every_law_kind_on_the_gpu_backend_equals_the_cpu_backend():
    offsets, neighbors, x, y, zeta, rng = random_bonds()
    n = len(offsets) - 1
    mark = (rng.uniform(0, 1, len(neighbors)) < 0.3).astype(np.uint8)
    args = (rng.uniform(1, 2, n), rng.uniform(0, 1, n), 3.0, mark)
    for law, shape in ((laws.SUM, (n,)), (laws.STRETCH, (len(neighbors),)), (laws.PAIR, (n, 3)),
                       (laws.MOMENT, (n, 3)), (laws.UNIT, (len(neighbors), 3))):
        margs = (args[0], 2.5) if law in (laws.MOMENT, laws.UNIT) else args
        for cpu, gpu in both(law, n, offsets, neighbors, zeta, y, margs, shape):
            close(cpu, gpu)
    # a range of points is computed and nothing else is written
    (cpu, gpu), = both(laws.SUM, n, offsets, neighbors, zeta, y, args, (n,), start=5, stop=9)
    assert np.all(gpu[:5] == -7.0) and np.all(gpu[9:] == -7.0)
    close(cpu, gpu)


def test_the_elastic_and_damage_laws_on_the_gpu_backend_equal_the_cpu_backend():
    offsets, neighbors, x, y, zeta, rng = random_bonds(n=30, k=9, seed=5)
    n, nb = len(offsets) - 1, len(neighbors)
    V = rng.uniform(0.5, 1.5, n)
    m = np.zeros(n)
    empty = np.zeros(0)
    for kind in (0, 1, 2):  # influence functions: one, parabolic decay, Gaussian
        (m_c, m_g), = both(elastic.WEIGHTED_VOLUME_FROM_X, n, offsets, neighbors, x, x, (V, kind, 0.8, empty), (n,))
        close(m_c, m_g)
        m = m_c
        # damage: bonds stretched beyond 1 % break; the dilatation then counts them
        d_n = np.zeros(nb, dtype=np.uint8)
        d_np1 = np.zeros(nb, dtype=np.uint8)
        damage = np.zeros(n)
        cs_args = (0.01, d_n, d_np1, True, empty, 0.0, damage, offsets)
        results = both(CRITICAL_STRETCH, n, offsets, neighbors, zeta, y, cs_args, (n,), writes=(2,))
        for cpu, gpu in results:
            close(cpu, gpu)
        broken = results[1][0]
        assert 0 < np.count_nonzero(broken) < nb  # some bonds broke, not all
        theta_args = (V, m, kind, 0.8, empty, broken.astype(float), rng.uniform(-1, 1, n), 1e-3)
        (th_c, th_g), = both(elastic.DILATATION, n, offsets, neighbors, zeta, y, theta_args, (n,))
        close(th_c, th_g)
        (ac_c, ac_g), = both(elastic.COEFFICIENTS, n, offsets, neighbors, zeta, y, (m, th_c, 2.0, 1.5), (n, 2))
        close(ac_c, ac_g)
        f_args = (ac_c[:, 0].copy(), ac_c[:, 1].copy(), V, kind, 0.8, empty, broken.astype(float), np.zeros(0, np.int32),
                  theta_args[6], 1e-3)
        (f_c, f_g), = both(elastic.PAIR_FORCE, n, offsets, neighbors, zeta, y, f_args, (n, 3))
        close(f_c, f_g)
        assert np.max(np.abs(f_c)) > 0


def test_device_arrays_round_trip_and_constants_are_copied_once():
    gpu = CudaBackend()
    a = np.arange(6.0).reshape(2, 3)
    d = gpu.asarray(a)
    assert gpu.asarray(d) is d
    np.testing.assert_array_equal(gpu.to_host(d), a)
    assert gpu.resident(a) is gpu.resident(a)
    assert gpu.empty().shape == (0,) and gpu.empty(np.uint8).dtype == np.uint8
    assert gpu.to_host(gpu.zeros((2, 2))).sum() == 0.0
