"""Short Range Force contact placed on the GPU (``ContactManager.place`` with the GPU's binning,
peridyn.gpu.pair_search) against the CPU's ContactManager: the same pairs, the same search and
rebuild schedule, the same contact force densities, on two copies of one model driven through
the same positions and velocities step by step. The runs use
numba-cuda's simulator (tests/conftest.py): there the arithmetic is the CPU's and the forces are
equal; on a GPU (``NUMBA_ENABLE_CUDASIM=0``) the bound is round-off, 1e-12 of the largest value
(fused multiply-adds). Also: every kernel compiles to PTX for a real GPU, without a device."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

pytest.importorskip("numba.cuda")

from peridyn.contact.short_range import ShortRangeForce, TimeDependentShortRangeForce  # noqa: E402
from peridyn.testing.harness import build_simulation  # noqa: E402

SIMULATED = os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"
RTOL = 0.0 if SIMULATED else 1e-12
ELASTIC = {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1e9, "Shear Modulus": 6e8}
STATS = ("searches", "builds", "overflows", "pairs", "max_pairs", "force_calls")


def two_boxes(*, gap=0.3, rc=0.8, rs=2.0, freq=3, mu=0.3, model="Short Range Force", omit=True, horizons=(2.1, 2.1)) -> dict:
    """Two 3x3x3 boxes (spacing 1) side by side along x, their facing planes of points ``gap``
    apart, the right one shifted by 0.5 in y."""
    contact = {"Search Radius": rs, "Search Frequency": freq,
               "Models": {"C": {"Contact Model": model, "Contact Radius": rc, "Spring Constant": 1e9, "Friction Coefficient": mu}}}
    disc = {"Type": "Shapes",
            "Shapes": {"Left": {"Shape": "Box", "Block": "block_1", "Min": [0.0, 0.0, 0.0], "Max": [3.0, 3.0, 3.0], "Spacing": 1.0},
                       "Right": {"Shape": "Box", "Block": "block_2", "Min": [2.0 + gap, 0.5, 0.0], "Max": [5.0 + gap, 3.5, 3.0],
                                 "Spacing": 1.0}}}
    if omit:
        disc["Omit Bonds Between Blocks"] = "All"
    blocks = {"B1": {"Block Names": "block_1", "Material": "M", "Horizon": horizons[0]},
              "B2": {"Block Names": "block_2", "Material": "M", "Horizon": horizons[1]}}
    return {"Discretization": disc, "Materials": {"M": ELASTIC}, "Blocks": blocks, "Contact": contact,
            "Solver": {"Final Time": 1.0, "Verlet": {"Fixed dt": 1e-3}}}


def drive(tree: dict, *, steps: int, dt: float, speed: float, jitter: float, capacity: int | None = None, seed: int = 3,
          shortcut: bool = True):
    """Step the CPU ContactManager and the same manager placed on the device, of two copies of
    ``tree``'s model, through the same positions (the boxes closing at 2 x ``speed`` along x,
    plus random offsets) and velocities; assert equal pairs, statistics and forces at every
    step. ``shortcut=False``: the GPU looks every candidate up in the bond lists (no
    reference-distance shortcut). Returns (the largest contact force density of each step, the
    CPU manager, the placed one)."""
    from peridyn.gpu.pair_search import BucketSearch
    from peridyn.gpu.state import DeviceModel
    from peridyn.kernels.numba_cuda import CudaBackend

    sim_c, sim_g = build_simulation(tree), build_simulation(tree)
    mc, mg = sim_c.contact, sim_g.contact
    if capacity is not None:
        mc.capacity = mg.capacity = capacity
    if not shortcut:
        mg.near2 = np.full(sim_g.num_owned, -1.0)
    backend = CudaBackend()
    dev = DeviceModel(sim_g, backend)
    assert mg.place(backend, dev.fields, dev.bonds, BucketSearch(backend, mg.num_owned, mg.rb)) is mg
    n = sim_c.num_owned
    x = sim_c.fields["Model_Coordinates"][:n].copy()
    left = sim_c.block_index[:n] == 0
    v0 = np.zeros((n, 3))
    v0[:, 0] = np.where(left, speed, -speed)
    rng = np.random.default_rng(seed)
    largest = []
    for step in range(steps + 1):
        t = step * dt
        if step > 0:
            mc.begin_step(step)
            mg.begin_step(step)
        v = v0 + rng.normal(scale=jitter * max(speed, 1.0), size=(n, 3))
        y = x + v0 * t + rng.normal(scale=jitter, size=(n, 3))
        for sim in (sim_c, sim_g):
            sim.fields["Coordinates"][:n] = y
            sim.fields["Velocity"][:n] = v
        dev.fields["Coordinates"].copy_to_device(sim_g.fields["Coordinates"])
        dev.fields["Velocity"].copy_to_device(sim_g.fields["Velocity"])
        base = rng.normal(size=(n, 3))
        f_c = base.copy()
        f_g = dev.backend.asarray(base)
        mc.add_force(f_c, t, step)
        mg.add_force(f_g, t, step)
        mg.to_host()
        pairs = mg.pairs
        assert np.array_equal(pairs.offsets, mc.pairs.offsets), step
        assert np.array_equal(pairs.partners, mc.pairs.partners), step
        assert np.array_equal(pairs.visits, mc.pairs.visits), step
        assert np.array_equal(mg.y_build, mc.y_build) and np.array_equal(mg.s, mc.s), step
        assert {k: mg.stats[k] for k in STATS} == {k: mc.stats[k] for k in STATS}, step
        fc_c = sim_c.fields["Contact_Force_Density"][:n]
        fc_g = dev.fields["Contact_Force_Density"].copy_to_host()[:n]
        scale = float(np.abs(fc_c).max())
        np.testing.assert_allclose(fc_g, fc_c, rtol=0, atol=RTOL * scale, err_msg=f"step {step}")
        np.testing.assert_allclose(f_g.copy_to_host(), f_c, rtol=0, atol=RTOL * max(scale, 1.0), err_msg=f"step {step}")
        largest.append(scale)
    s_c, s_g = mc.summary(), mg.summary()
    for key in STATS + ("min_distance", "min_distance_time", "penetration"):
        assert s_g[key] == pytest.approx(s_c[key], rel=RTOL), key
    sim_g.fields["Coordinates"][:n] = sim_c.fields["Coordinates"][:n]
    assert mg.potential_energy() == pytest.approx(mc.potential_energy(), rel=max(RTOL, 1e-15))
    return np.array(largest), mc, mg


def test_two_approaching_boxes_with_friction_and_searches():
    """Search Frequency 3, friction, row capacity 1 (every build overflows and grows)."""
    largest, mc, mg = drive(two_boxes(), steps=7, dt=0.004, speed=10.0, jitter=0.02, capacity=1)
    assert (largest > 0).all()  # in contact from step 0 (0.58 apart, R_c 0.8)
    assert mc.stats["searches"] == 3 and mc.stats["overflows"] >= 1 and mc.model.mu == 0.3


def test_a_skin_rebuild_mid_run_and_time_dependent_friction():
    """1.5 apart at the start, closing at 2 x 25: the short list is rebuilt by the skin rule (no
    search is due), and contact starts mid-run; the friction coefficient grows with t."""
    tree = two_boxes(gap=1.5, rs=3.0, freq=100, model="Time Dependent Short Range Force", mu="0.1 + 50.0*t")
    largest, mc, mg = drive(tree, steps=8, dt=0.004, speed=25.0, jitter=0.01)
    assert isinstance(mc.model, TimeDependentShortRangeForce) and mg.model.mu == pytest.approx(0.1 + 50.0 * 8 * 0.004)
    assert mc.stats["searches"] == 1 and mc.stats["builds"] >= 3
    assert largest[0] == 0.0 and largest[-1] > 0.0


def test_pairs_beyond_the_search_radius_at_the_last_search_do_not_touch():
    """1.58 apart at set-up with R_s = 1: no pair across the gap is listed until the search at
    step 6, although the boxes are closer than R_c from step 5 on (Peridigm's frozen lists)."""
    largest, mc, mg = drive(two_boxes(gap=1.5, rs=1.0, freq=6), steps=8, dt=0.004, speed=25.0, jitter=0.002)
    assert mc.stats["searches"] == 2
    assert (largest[:6] == 0.0).all() and largest[6] > 0.0


@pytest.mark.parametrize("shortcut", [True, False], ids=["shortcut", "bond-lookup"])
def test_bonded_points_within_the_contact_radius_do_not_touch(shortcut):
    """Bonds between the blocks are kept and the horizons differ (3.0 and 1.2, R_c 1.5): points
    1 apart are bonded and never in contact, diagonal neighbours of block 2 (1.41 apart) are not
    bonded and touch, and pairs bonded one way only get one visit."""
    tree = two_boxes(gap=0.2, rc=1.5, rs=2.5, freq=2, mu=0.2, omit=False, horizons=(3.0, 1.2))
    largest, mc, mg = drive(tree, steps=4, dt=0.002, speed=5.0, jitter=0.01, shortcut=shortcut)
    assert (largest > 0).all()
    pairs = mg.pairs
    sim = mc.sim
    nl = sim.bonds
    bonded = 0
    y = sim.fields["Coordinates"]
    for p in range(mc.num_owned):
        row = set(pairs.partners[pairs.offsets[p]:pairs.offsets[p + 1]].tolist())
        for j in nl.neighbors[nl.offsets[p]:nl.offsets[p + 1]]:
            if np.linalg.norm(y[j] - y[p]) < mc.rc and p in nl.neighbors[nl.offsets[j]:nl.offsets[j + 1]]:  # bonded both ways
                assert j not in row
                bonded += 1
    assert bonded > 0
    assert set(np.unique(pairs.visits).tolist()) >= {1, 2, 3}  # one-sided visits both ways, and two-sided ones


def test_the_short_range_models_declare_the_gpu():
    assert "gpu" in ShortRangeForce.devices and "gpu" in TimeDependentShortRangeForce.devices and "cpu" in ShortRangeForce.devices


PTX_SCRIPT = textwrap.dedent(
    r'''
    import json, sys
    import numba
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
    from peridyn.gpu import pair_search as C

    f8, i8, b1 = numba.float64, numba.int64, numba.boolean
    v2, v1, l1 = f8[:, ::1], f8[::1], i8[::1]
    i4, u1 = numba.int32[::1], numba.uint8[::1]
    sigs = {
        "bucket_count": (i8, v2, f8, i8, l1, l1),
        "scan_block_sums": (l1, i8, i8, l1),
        "scan_sums": (l1, i8),
        "scan_apply": (l1, i8, i8, l1, l1),
        "bucket_scatter": (i8, l1, l1, l1, l1),
        "gather_pairs": (i8, v2, f8, i8, l1, l1, v2, l1, v2, v1, l1, b1, f8, f8, l1, i4, l1, l1, l1, i8, i4, u1, l1, l1),
        "fill_int": (l1, i8),
    }
    done = []
    for name, sig in sigs.items():
        for cc in ((8, 0), (9, 0)):
            compile_ptx(getattr(C, name).py_func, sig, cc=cc)
        done.append(name)
    kernels = sorted(k for k, v in vars(C).items() if hasattr(v, "py_func") and not k.startswith("_"))  # device functions: inlined
    print(json.dumps({"compiled": done, "kernels": kernels}))
    '''
)


def test_every_contact_kernel_compiles_to_ptx(tmp_path):
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "0"}
    proc = subprocess.run([sys.executable, "-c", PTX_SCRIPT], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-4000:]
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    if "skip" in result:
        pytest.skip(f"no NVVM/NVRTC to compile PTX with: {result['skip']}")
    assert sorted(result["compiled"]) == result["kernels"]  # every kernel of the module, none forgotten
