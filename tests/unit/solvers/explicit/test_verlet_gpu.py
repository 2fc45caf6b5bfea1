"""Explicit dynamics on the GPU (``peridyn run --device gpu``) against the same deck on the CPU:
every field of every output frame and the energy account, with damage, influence functions,
thermal strain, body forces and prescribed motion. The runs use numba-cuda's simulator
(``NUMBA_ENABLE_CUDASIM=1``, tests/conftest.py) at small sizes: there the arithmetic is the CPU's
and the fields are equal; on a GPU the bound is round-off, 1e-12 of the largest value of each
quantity (all components of a vector), and for force densities and dilatations the value of a
stretch round-off in every bond (:func:`stretch_roundoff_force`, ``DILATATION_ROUNDOFF``)."""
from __future__ import annotations

import copy
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("numba.cuda")
netCDF4 = pytest.importorskip("netCDF4")

SIMULATED = os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"
RTOL = 0.0 if SIMULATED else 1e-12


def lattice_deck(material: dict, *, n: int = 4, damage: dict | None = None, conditions: dict | None = None, steps: int = 6,
                 dt: float = 1.0e-7, influence: str | None = None, variables=("Displacement", "Velocity", "Force_Density")) -> dict:
    """A cube of n^3 points, 1 mm apart, horizon 2.015 mm, stretched outwards by an initial velocity."""
    h = 1.0e-3
    disc = {"Type": "PdQuickGrid", "NeighborhoodType": "Spherical",
            "TensorProduct3DMeshGenerator": {"Type": "PdQuickGrid", "X Origin": 0.0, "Y Origin": 0.0, "Z Origin": 0.0,
                                             "X Length": n * h, "Y Length": n * h, "Z Length": n * h,
                                             "Number Points X": n, "Number Points Y": n, "Number Points Z": n}}
    if influence:
        disc["Influence Function"] = influence
    c = n * h / 2
    bcs = {"All Node Set": " ".join(str(k + 1) for k in range(n**3)),
           "Left Node Set": " ".join(str(k + 1) for k in range(n)),
           "Spread": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "x", "Value": f"200.0*(x-{c})/{c}"}}
    bcs.update(conditions or {})
    tree = {"Discretization": disc, "Materials": {"M": material},
            "Blocks": {"B": {"Block Names": "block_1", "Material": "M", "Horizon": 2.015 * h}},
            "Boundary Conditions": bcs,
            "Solver": {"Initial Time": 0.0, "Final Time": steps * dt, "Verlet": {"Fixed dt": dt}},
            "Output": {"Output File Type": "ExodusII", "Output Filename": "run", "Output Frequency": 2,
                       "Output Variables": {v: True for v in variables}}}
    if damage:
        tree["Damage Models"] = {"D": damage}
        tree["Blocks"]["B"]["Damage Model"] = "D"
    return {"Peridigm": tree}


STEEL = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 130.0e9, "Shear Modulus": 78.0e9}
LOADS = {
    "Pull": {"Type": "Body Force", "Node Set": "Left Node Set", "Coordinate": "z", "Value": "1e12*t"},
    "Hold": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": "y", "Value": "1e-3*t"},
}
#: the plane x = 2 mm across the 4 mm cube, between the second and third layers of points
PLANE = {"Type": "Rectangular_Plane", "Normal_X": 1.0, "Normal_Y": 0.0, "Normal_Z": 0.0,
         "Lower_Left_Corner_X": 0.002, "Lower_Left_Corner_Y": -0.001, "Lower_Left_Corner_Z": 0.005,
         "Bottom_Unit_Vector_X": 0.0, "Bottom_Unit_Vector_Y": 1.0, "Bottom_Unit_Vector_Z": 0.0, "Bottom_Length": 0.01, "Side_Length": 0.01}


def with_bond_filter(deck: dict) -> dict:
    """``deck`` on the same 4 x 4 x 4 points as a ``Shapes`` mesh, with the bonds across ``PLANE``
    removed from the neighbor lists (PdQuickGrid takes no bond filter)."""
    deck["Peridigm"]["Discretization"] = {
        "Type": "Shapes", "Bond Filters": {"Cut": PLANE},
        "Shapes": {"Cube": {"Shape": "Box", "Block": "block_1", "Min": [0.0, 0.0, 0.0], "Max": [0.004, 0.004, 0.004], "Spacing": 0.001}}}
    return deck


SHORT_RANGE = {"Contact Model": "Short Range Force", "Contact Radius": 0.9, "Spring Constant": 1.0e9, "Friction Coefficient": 0.3}
#: PeriLab's law, its stiffness from each block's bulk modulus
PENALTY = {"Contact Model": "Penalty Contact", "Contact Radius": 0.9, "Penalty Factor": 2.0, "Friction Coefficient": 0.3}


def contact_deck(steps: int = 8, dt: float = 5.0e-4, model: dict = SHORT_RANGE) -> dict:
    """Two 3x3x3 boxes of points 1 apart (no bonds between them) flying into each other at 2 x 100 m/s,
    offset by half a spacing across, with contact ``model`` (Short Range Force) and friction."""
    disc = {"Type": "Shapes", "Omit Bonds Between Blocks": "All",
            "Shapes": {"Left": {"Shape": "Box", "Block": "block_1", "Min": [0.0, 0.0, 0.0], "Max": [3.0, 3.0, 3.0], "Spacing": 1.0},
                       "Right": {"Shape": "Box", "Block": "block_2", "Min": [3.5, 0.5, 0.0], "Max": [6.5, 3.5, 3.0], "Spacing": 1.0}}}
    material = {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1.0e9, "Shear Modulus": 6.0e8}
    tree = {"Discretization": disc, "Materials": {"M": material},
            "Blocks": {"B1": {"Block Names": "block_1", "Material": "M", "Horizon": 2.1},
                       "B2": {"Block Names": "block_2", "Material": "M", "Horizon": 2.1}},
            "Boundary Conditions": {"All Node Set": " ".join(str(k + 1) for k in range(54)),
                                    "Fly": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "x",
                                            "Value": "100.0-200.0*floor(x/3.25)"}},
            "Contact": {"Search Radius": 2.0, "Search Frequency": 3,
                        "Models": {"C": dict(model)}},
            "Solver": {"Initial Time": 0.0, "Final Time": steps * dt, "Verlet": {"Fixed dt": dt}},
            "Output": {"Output File Type": "ExodusII", "Output Filename": "run", "Output Frequency": 2,
                       "Output Variables": {"Displacement": True, "Velocity": True, "Force_Density": True, "Contact_Force_Density": True}}}
    return {"Peridigm": tree}


CASES = {
    "lps_critical_stretch_loads": lattice_deck(STEEL, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 0.0005},
                                               conditions=LOADS, variables=("Displacement", "Velocity", "Force_Density", "Damage", "Dilatation")),
    "lps_parabolic_thermal": lattice_deck(
        {**STEEL, "Thermal Expansion Coefficient": 1.0e-5}, influence="Parabolic Decay",
        conditions={"Heat": {"Type": "Prescribed Temperature", "Node Set": "All Node Set", "Value": "1e8*t*x"}},
        variables=("Displacement", "Force_Density", "Dilatation", "Temperature")),
    "lps_gaussian_time_dependent_stretch": lattice_deck(
        STEEL, influence="Gaussian", damage={"Damage Model": "Time Dependent Critical Stretch", "Time Dependent Critical Stretch": "0.002-3e2*t"},
        variables=("Displacement", "Velocity", "Damage")),
    "bond_based_critical_stretch": lattice_deck({"Material Model": "Elastic Bond Based", "Density": 7800.0, "Bulk Modulus": 130.0e9},
                                                damage={"Damage Model": "Critical Stretch", "Critical Stretch": 0.0004},
                                                conditions=LOADS, variables=("Displacement", "Velocity", "Force_Density", "Damage")),
    "lps_two_bodies_contact_friction": contact_deck(),
    "lps_two_bodies_penalty_contact_friction": contact_deck(model=PENALTY),
    "bond_based_initial_damage_plane": lattice_deck(
        {"Material Model": "Elastic Bond Based", "Density": 7800.0, "Bulk Modulus": 130.0e9},
        damage={"Damage Model": "Initial Damage", "Bond Filters": {"Cut": PLANE}}, variables=("Displacement", "Velocity", "Damage")),
    "lps_surface_traction_ramp": lattice_deck(STEEL, conditions={
        "Pull": {"Type": "Surface Traction", "Node Set": "Left Node Set", "Traction": [0.0, 2.0e8, -1.0e8], "Area": 4.0e-6,
                 "Scale": "min(t/3.0e-7, 1.0)"}}, variables=("Displacement", "Velocity", "Force_Density")),
    "lps_bond_filter": with_bond_filter(lattice_deck(STEEL, conditions=LOADS, variables=("Displacement", "Velocity", "Dilatation"))),
}


def run(folder: Path, deck: dict, *extra: str, name: str = "deck.yaml") -> subprocess.CompletedProcess:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_text(yaml.safe_dump(deck, sort_keys=False))
    return subprocess.run([sys.executable, "-m", "peridyn", "run", name, "--no-progress", *extra], cwd=folder, capture_output=True, text=True,
                          timeout=600)


def frames(path: Path) -> dict[str, np.ndarray]:
    """Every output variable of an Exodus file by name (``VelocityX``, ``Damage@eb1``), and "time"."""
    with netCDF4.Dataset(path) as ds:
        out = {"time": np.array(ds["time_whole"][:])}
        for kind in ("nod", "elem"):
            if f"name_{kind}_var" not in ds.variables:
                continue
            for i, name in enumerate(netCDF4.chartostring(ds[f"name_{kind}_var"][:]), 1):
                for k in ds.variables:
                    if k == f"vals_{kind}_var{i}" or k.startswith(f"vals_{kind}_var{i}eb"):
                        out[f"{name}@{k[len(f'vals_{kind}_var{i}'):]}" if kind == "elem" else str(name)] = np.array(ds[k][:])
    return out


def quantity_scale(fields: dict[str, np.ndarray], name: str) -> float:
    """The largest magnitude of the quantity ``name`` belongs to, over all its components
    (``VelocityY``'s is that of VelocityX, Y and Z): a component that should be zero holds
    round-off of the quantity, not of itself."""
    stem = name[:-1] if name[-1:] in "XYZ" and name[:-1] + "X" in fields else name
    parts = [fields[stem + c] for c in "XYZ" if stem + c in fields] or [fields[name]]
    return max(float(np.max(np.abs(f), initial=0.0)) for f in parts)


def stretch_roundoff_force(deck: dict) -> float:
    """The force density (N/m^3) of a stretch of one machine epsilon in every bond of a family,
    24 K eps / delta (bond-based: c = 18 K / (pi delta^4) over a family of volume 4/3 pi delta^3).
    A bond's stretch (|eta| - |xi|) / |xi| is the difference of two lengths of about delta, each
    right to half an ulp, so it is off by about eps whatever the stretch: the GPU, which forms
    |eta| with fused multiply-adds, differs from the CPU in that last bit. An interior point's
    force density is a near-cancelling sum of its bonds' forces, so these differences stand out
    against the quantity's own scale (measured on an H200: 1e-9 of it) but not against this bound."""
    tree = deck["Peridigm"]
    bulk = max(m["Bulk Modulus"] for m in tree["Materials"].values())
    horizon = min(b["Horizon"] for b in tree["Blocks"].values())
    return 24.0 * bulk * np.finfo(float).eps / horizon


#: the dilatation of an extension round-off of eps |xi| in every bond: theta = (3 / m) sum omega
#: e |xi| V with m = sum omega |xi|^2 V, so 3 eps (measured on an H200: 1.8e-16)
DILATATION_ROUNDOFF = 3.0 * float(np.finfo(float).eps)


def energy(log: str) -> list[float]:
    line = next(s for s in log.splitlines() if s.strip().startswith("energy:"))
    return [float(v) for v in re.findall(r"[-+]?\d+\.?\d*(?:e[-+]?\d+)?", line.split(";")[0])]


@pytest.mark.parametrize("case", list(CASES))
def test_a_gpu_run_gives_the_cpu_run_fields_and_energies(tmp_path, case):
    deck = CASES[case]
    cpu = run(tmp_path / "cpu", deck)
    assert cpu.returncode == 0, cpu.stderr
    gpu = run(tmp_path / "gpu", deck, "--device", "gpu")
    assert gpu.returncode == 0, gpu.stderr
    assert "Verlet on the GPU" in gpu.stderr
    a, b = frames(tmp_path / "cpu" / "run.e"), frames(tmp_path / "gpu" / "run.e")
    assert a.keys() == b.keys() and len(a["time"]) >= 4  # steps 0, 2, 4, 6 (, 8)
    for k in a:
        atol = RTOL * quantity_scale(a, k)
        if k.startswith("Force_Density") and not SIMULATED:
            atol = max(atol, stretch_roundoff_force(deck))
        if k.startswith("Dilatation") and not SIMULATED:
            atol = max(atol, DILATATION_ROUNDOFF)
        np.testing.assert_allclose(b[k], a[k], rtol=RTOL, atol=atol, err_msg=f"{case}: {k}")
    e_cpu = energy(cpu.stderr)  # summed in another order on the device: round-off of the largest
    np.testing.assert_allclose(energy(gpu.stderr), e_cpu, rtol=1e-12, atol=1e-12 * max(abs(e) for e in e_cpu))
    if "Contact" in deck["Peridigm"]:
        assert "contact:" in gpu.stderr and re.search(r"(\d+) searches", gpu.stderr).group(1) != "0"
        with netCDF4.Dataset(tmp_path / "gpu" / "run.e") as ds:
            names = [str(s) for s in netCDF4.chartostring(ds["name_nod_var"][:])]
            fc = np.array(ds[f"vals_nod_var{names.index('Contact_Force_DensityX') + 1}"][:])
        assert np.abs(fc).max() > 0, "the bodies must touch"
    if "Damage" in str(deck):
        with netCDF4.Dataset(tmp_path / "gpu" / "run.e") as ds:
            names = [str(s) for s in netCDF4.chartostring(ds["name_elem_var"][:])]
            damage = np.array(ds[f"vals_elem_var{names.index('Damage') + 1}eb1"][:])
        assert 0.0 < damage.max() < 1.0, "the case must break some bonds, not all"


def test_the_deck_can_ask_for_the_gpu_and_the_command_line_wins(tmp_path):
    deck = copy.deepcopy(CASES["bond_based_critical_stretch"])
    deck["Peridigm"]["Solver"]["Device"] = "GPU"
    on_gpu = run(tmp_path / "a", deck)
    assert on_gpu.returncode == 0 and "Verlet on the GPU" in on_gpu.stderr, on_gpu.stderr
    on_cpu = run(tmp_path / "b", deck, "--device", "cpu")
    assert on_cpu.returncode == 0 and "on the GPU" not in on_cpu.stderr, on_cpu.stderr
    deck["Peridigm"]["Solver"]["Device"] = "TPU"
    bad = run(tmp_path / "c", deck)
    assert bad.returncode == 2 and "Device" in bad.stderr and "GPU" in bad.stderr


def test_a_run_that_goes_unstable_stops_at_the_same_step_on_the_gpu(tmp_path):
    """A horizon of 10 spacings on a cube of 6: 0.8 of the critical time step estimate is above
    the true limit (and not checked against the measured one), so an impact grows into an
    instability. The device's energy sums stop the run with exit status 3 at the step the CPU's
    stop it, with the diagnosis naming a point, and no NaN reaches the output; a NaN boundary
    value stops it before it reaches a field."""
    from peridyn.testing import cube_deck, node_set_ids

    tree = cube_deck(STEEL, n=6, spacing=1e-3, horizon_factor=10.0)
    tree["Boundary Conditions"] = {
        "Face Node Set": node_set_ids(tree, lambda x: x[:, 0] > 5e-3),
        "Impact": {"Type": "Initial Velocity", "Node Set": "Face Node Set", "Coordinate": "x", "Value": "-5.0"},
    }
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0, "Verlet": {"Safety Factor": 0.8}}
    tree["Output"] = {"Output Filename": "unstable", "Output Frequency": 5, "Output Variables": {"Displacement": True, "Velocity": True}}
    steps = []
    for device in ("cpu", "gpu"):
        proc = run(tmp_path / device, {"Peridigm": tree}, "--device", device)
        assert proc.returncode == 3, proc.stderr[-3000:]
        errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("error:")]
        assert len(errors) == 1 and " at point" in errors[0], proc.stderr
        steps.append(int(errors[0].split("at step ")[1].split()[0]))
        with netCDF4.Dataset(tmp_path / device / "unstable.e") as ds:
            assert all(np.isfinite(np.asarray(v[:])).all() for k, v in ds.variables.items() if k.startswith("vals_"))
    assert steps[0] <= 50 and steps[1] == steps[0], steps
    tree["Boundary Conditions"]["Pull"] = {"Type": "Prescribed Displacement", "Node Set": "Face Node Set", "Coordinate": "y",
                                           "Value": "(t - t)/(t - t)"}
    proc = run(tmp_path / "nan", {"Peridigm": tree}, "--device", "gpu")
    assert proc.returncode == 3 and "is nan" in proc.stderr, proc.stderr[-2000:]
