"""Every GPU kernel an explicit run launches compiles for a real GPU (PTX for compute
capability 8.0 and 9.0, no device needed), not only under the simulator, which runs the kernels
as Python and so accepts code the CUDA target refuses. Needs numba-cuda's NVVM and NVRTC
(``numba-cuda[cu12]``, which the ``test`` extra installs on Linux); skipped without them."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

pytest.importorskip("numba.cuda")

from ..solvers.explicit.test_verlet_gpu import CASES  # noqa: E402

SCRIPT = textwrap.dedent(
    r'''
    import json, sys
    import numpy as np
    import numba
    from numba import cuda
    from numba.cuda import compile_ptx
    from peridyn.kernels.numba_cuda import cuda_module

    cuda_module()  # numpy 2.5 has no row_stack, which numba-cuda's compiler calls: cuda_module() restores it
    try:
        compile_ptx(lambda a: None, (numba.float64[::1],), cc=(8, 0))
    except Exception as exc:  # no NVVM or NVRTC
        print(json.dumps({"skip": f"{type(exc).__name__}: {exc}"[:300]}))
        sys.exit(0)
    import numba.cuda.dispatcher as cuda_dispatcher

    class NoDevice:  # device functions are compiled for "the current device": there is none here
        compute_capability = (9, 0)

    cuda_dispatcher.get_current_device = lambda: NoDevice()
    from peridyn.core.traversal import PointReduction, PointUpdate
    from peridyn.core.state import SolverState
    from peridyn.gpu.placement import DevicePlacement
    from peridyn.kernels import codegen
    from peridyn.kernels import scatter as S
    from peridyn.kernels.numba_cuda import CudaBackend
    from peridyn.solvers.explicit import laws as L
    from peridyn.testing.harness import build_simulation

    compiled = []

    class PTXBackend(CudaBackend):
        """The GPU backend's kernels compiled to PTX for the types they are called with, on
        host arrays (the same numba types as device arrays), instead of launched."""

        def __init__(self):
            super().__init__()
            self.threads = 128

        def kernel(self, law):
            text = self.source(law)
            module = codegen.load_module(text, f"peridyn_kernel_ptx_{codegen.law_digest(law, text)}")

            def launch(*args):
                if isinstance(law, PointReduction):  # both passes of the fixed-order sum
                    start, stop, a, out = args
                    partial = np.zeros((1, law.width))
                    targets = [(module._partials, (start, stop, a, partial)), (module._total, (partial, 1, out))]
                else:
                    targets = [(module._kernel, args)]
                for fn, call in targets:
                    sig = tuple(numba.typeof(a) for a in call)
                    for cc in ((8, 0), (9, 0)):
                        compile_ptx(fn.py_func, sig, cc=cc)
                compiled.append(type(law).__name__ + ":" + "/".join(f.__name__ for f in codegen.law_functions(law).values()))

            return launch

        def zeros(self, shape, dtype=float):
            return np.zeros(shape, dtype=dtype)

        def asarray(self, array):
            return np.ascontiguousarray(array)

        def empty(self, dtype=float):
            return np.zeros(0, dtype=dtype)

        def resident(self, array):
            return np.ascontiguousarray(array)

        def to_host(self, array):
            return np.asarray(array)

    for tree in json.loads(sys.argv[1]):
        sim = build_simulation(tree["Peridigm"], directory=".")
        DevicePlacement(sim, PTXBackend(), SolverState()).evaluate_forces()

    # the step's point laws with the types the step calls them with
    b = PTXBackend()
    n = 4
    v, e, s1 = np.zeros((n, 3)), np.zeros((0, 3)), np.zeros(n)
    pts, free = np.arange(n, dtype=np.int64), np.ones((n, 3), dtype=bool)
    b.kernel(L.KICK)(0, n, (v, v, 0.5))
    b.kernel(L.DRIFT)(0, n, (v, 0.1, v, v, v, v))
    b.kernel(L.ACCELERATE)(0, n, (v, e, s1, 0.5, v, v, True))
    b.kernel(L.COPY_VECTORS)(0, n, (v, v))
    b.kernel(L.STEP_SUMS)(0, n, (v, v, v, e, e, s1, free, v, v, s1), np.zeros(7))
    b.kernel(L.KINETIC_FREE)(0, n, (v, s1, free), np.zeros(1))
    b.kernel(S.ZERO_VECTORS)(0, n, (v,))
    b.kernel(S.SET_COMPONENT)(0, n, (pts, 1, s1, v))
    b.kernel(S.SET_SCALAR)(0, n, (pts, s1, s1))
    b.kernel(S.SET_DIFFERENCE)(0, n, (pts, s1, s1, s1))
    b.kernel(S.ADD_SCALED)(0, n, (pts, 0.5, v, v))
    b.kernel(S.PRESCRIBED_DISPLACEMENT)(0, n, (pts, 1, s1, s1, 0.5, v, v, e))
    # contact's laws (the pair search's binning: tests/unit/gpu/test_contact.py)
    from peridyn.contact import pair_laws as C
    from peridyn.contact.short_range import SHORT_RANGE_FORCE

    offsets, rows, bits, ids = np.arange(n + 1, dtype=np.int64), np.zeros(n, np.int32), np.zeros(n, np.uint8), np.arange(n, dtype=np.int64)
    b.kernel(C.COMPACT)(0, n, (1, rows, bits, offsets, rows, bits))
    b.kernel(C.MAX_DISPLACEMENT2)(0, n, (v, v), np.zeros(1))
    b.kernel(C.MIN_PAIR_DISTANCE2)(0, n, (offsets, rows, v), np.zeros(1))
    b.kernel(C.TRACK_MIN_DISTANCE)(0, 1, (np.zeros(1), np.zeros(2), 0.5))
    b.kernel(C.COPY_VECTORS)(0, n, (v, v))
    b.kernel(C.ADD_VECTORS)(0, n, (v, v))
    b.kernel(SHORT_RANGE_FORCE)(0, n, (offsets, rows, bits, ids, ids, s1, v, v, s1, 0.5, 1.0, 0.2, v))
    print(json.dumps({"compiled": compiled}))
    '''
)


def test_every_gpu_kernel_of_the_explicit_step_compiles_to_ptx(tmp_path):
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "0", "PERIDYN_KERNEL_CACHE": str(tmp_path / "kernels")}
    decks = json.dumps([CASES[k] for k in CASES])
    proc = subprocess.run([sys.executable, "-c", SCRIPT, decks], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-4000:]
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    if "skip" in result:
        pytest.skip(f"no NVVM/NVRTC to compile PTX with: {result['skip']}")
    names = set(result["compiled"])
    # the laws of every model with a GPU path, and every kernel of the step
    for expected in ("PointSum:stretch_damage_term/point_damage/broken_gate", "PointSum:dilatation_term/thermal_shift/dilatation_finish",
                     "PointMap:coefficients_of_point", "PairForce:pair_force/coefficients_point", "PairForce:pair_force",
                     "PointReduction:_step_sums", "PointUpdate:_prescribed_displacement", "PointUpdate:_accelerate",
                     "PointUpdate:_add_scaled", "PointUpdate:_short_range_force", "PointReduction:_row_min_distance2",
                     "PointReduction:_displacement2", "PointUpdate:_compact", "PointUpdate:_track_min_distance"):
        assert expected in names, sorted(names)

