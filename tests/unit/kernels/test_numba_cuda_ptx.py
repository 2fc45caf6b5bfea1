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

from ..solvers.test_verlet_gpu import CASES  # noqa: E402

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
    from peridyn.kernels import codegen
    from peridyn.kernels.numba_cuda import CudaBackend
    from peridyn.gpu import kernels as K
    from peridyn.gpu.state import DeviceModel
    from peridyn.solvers.verlet_gpu import evaluate_forces
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
                sig = tuple(numba.typeof(a) for a in args)
                for cc in ((8, 0), (9, 0)):
                    compile_ptx(module._kernel.py_func, sig, cc=cc)
                compiled.append(type(law).__name__ + ":" + "/".join(f.__name__ for f in codegen.law_functions(law).values()))

            return launch

        def zeros(self, shape, dtype=float):
            return np.zeros(shape, dtype=dtype)

        def asarray(self, array):
            return np.ascontiguousarray(array)

        def empty(self, dtype=float):
            return np.zeros(0, dtype=dtype)

        def to_host(self, array):
            return np.asarray(array)

    for tree in json.loads(sys.argv[1]):
        sim = build_simulation(tree["Peridigm"], directory=".")
        evaluate_forces(sim, DeviceModel(sim, PTXBackend()))

    f8 = numba.float64
    v2, v1, b2, i1 = f8[:, ::1], f8[::1], numba.boolean[:, ::1], numba.int64[::1]
    i8 = numba.int64
    step = {
        "kick": (i8, v2, v2, f8), "drift": (i8, v2, f8, v2, v2, v2, v2),
        "acceleration_kick": (i8, v2, v2, v1, f8, v2, v2, numba.boolean), "fill": (v2, f8),
        "set_component": (i1, i8, v1, v2), "set_scalar": (i1, v1, v1), "set_difference": (i1, v1, v1, v1),
        "prescribed_displacement": (i1, i8, v1, v1, f8, v2, v2),
        "energy_partials": (i8, v2, v2, v2, v2, v2, v1, b2, v2, v1, v2, v2), "reduce_partials": (v2, i8, v1),
    }
    for name, sig in step.items():
        compile_ptx(getattr(K, name).py_func, sig, cc=(9, 0))
        compiled.append("step:" + name)
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
                     "step:energy_partials", "step:prescribed_displacement"):
        assert expected in names, sorted(names)

