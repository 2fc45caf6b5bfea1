"""Griffith: a centre-cracked plate of a bond-based plane-stress material with ``Critical
Energy`` damage starts to crack at the load of the Griffith criterion.

Plate: width 2b = 60 dx, height 2W (so the ends barely matter), crack 2a = 24 dx along y = 0
(a Rectangular_Plane bond filter), horizon 3 dx (m = 3), one layer of points (2D, Height = dx),
the top and bottom rows (one horizon thick) pulled apart with u_y = +-U and u_x = -nu eps x (the
lateral contraction of the uncracked plate). The load is the mean stress over the width,
sigma = (reaction of the top rows) / (2b h).

Griffith (plane stress): G = K_I^2 / E = G0 with K_I = sigma sqrt(pi a) F(a/b) and the
finite-width factor of Tada, Paris & Irwin (The Stress Analysis of Cracks Handbook, 3rd ed.
2000, p. 5.2; accurate to 0.1 % for any a/b under uniform remote tension):
F = (1 - 0.025 (a/b)^2 + 0.06 (a/b)^4) sqrt(sec(pi a / 2b)). So sigma_c = sqrt(E G0/(pi a)) / F.

Initiation = the first bond breaking at the crack tips. The model is linear until then, so one
static solve below the load gives it: sigma_init = sigma s0 / max(stretch). The test checks it
against Griffith within 10 % (measured: 1.05), then checks the engine's damage model breaks no
bond at 0.99 sigma_init and breaks bonds, only at the two tips, at 1.01 sigma_init.

The tolerance holds for m = 3 (benchmarks/griffith.py, docs/fracture.md): at fixed m the ratio
hardly moves with delta/a (1.05, 1.07 for delta/a = 1/4, 1/6), but first-bond failure falls with
m (K_init/K_c = 1.42, 1.07, 0.92, 0.81, 0.73 for m = 2..6 on the K-field problem) while the
load at which the crack runs stays within 10 % of Griffith (m = 3: ~1.10, m = 4: ~0.93).
"""
import math

import numpy as np
import pytest

from peridyn.testing.harness import build_simulation

from peridyn.verify.problems.griffith import DX, E, G0, plate_deck, tada  # the plate of `peridyn verify`
from peridyn.engine.session import run_sections


def mean_stress(sim, g) -> float:
    """Reaction of the top grip over the cross-section (Pa)."""
    x, V, f = sim.fields["Model_Coordinates"], sim.fields["Volume"], sim.fields["Force_Density"]
    top = x[: sim.num_owned, 1] > g["H"] / 2
    return float(-np.sum(f[: sim.num_owned][top, 1] * V[: sim.num_owned][top]) / (g["W"] * g["h"]))


def bond_stretches(sim, g) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(owner, neighbor, stretch) of every bond between points outside the grips."""
    nl, x, y = sim.bonds, sim.fields["Model_Coordinates"], sim.fields["Coordinates"]
    i = np.repeat(np.arange(sim.num_owned), np.diff(nl.offsets[: sim.num_owned + 1]))
    j = nl.neighbors[: i.size]
    L0 = sim.fields["Bond_Length"][: i.size]
    s = (np.linalg.norm(y[j] - y[i], axis=1) - L0) / L0
    free = np.abs(x[:, 1]) < g["H"] / 2
    keep = free[i] & free[j]
    return i[keep], j[keep], s[keep]


def griffith_stress(g) -> float:
    return math.sqrt(E * G0 / (math.pi * g["a"])) / tada(g["a"], g["W"] / 2)


@pytest.fixture(scope="module")
def loaded_plate():
    """The plate solved at about a quarter of the Griffith load, with Critical Energy damage and
    J_Integral rings (4 to 10 dx) around both tips."""
    tree, g = plate_deck(damage={"Damage Model": "Critical Energy", "Critical Energy": G0})
    a = g["a"]
    ring = {"Compute Class": "J_Integral", "Crack Tip Y": 0.0, "Inner Radius": 4 * DX, "Outer Radius": 10 * DX, "Thickness": g["h"]}
    tree["Compute Class Parameters"] = {"Right": {**ring, "Crack Tip X": a}, "Left": {**ring, "Crack Tip X": -a, "Crack Direction X": -1.0}}
    sim = build_simulation(tree)
    run_sections(sim)
    return sim, g


def test_the_critical_stretch_is_the_plane_stress_conversion(loaded_plate):
    sim, g = loaded_plate
    damage = sim.blocks[0].damage
    # Ha & Bobaru 2010: s0 = sqrt(4 pi G0 / (9 E delta)) for the plane-stress bond-based model
    assert damage.s_c == pytest.approx(math.sqrt(4.0 * math.pi * G0 / (9.0 * E * g["delta"])), rel=1e-12)


def test_crack_starts_growing_at_the_griffith_load(loaded_plate):
    sim, g = loaded_plate
    assert not np.any(sim.fields["Bond_Damage"]), "no bond may break at a quarter of the Griffith load"
    sigma = mean_stress(sim, g)
    _, _, s = bond_stretches(sim, g)
    s0 = sim.blocks[0].damage.s_c
    factor = s0 / s.max()  # linear model: the load multiplier of the first break
    sigma_init = factor * sigma
    ratio = sigma_init / griffith_stress(g)
    assert abs(ratio - 1.0) < 0.10, f"initiation at {ratio:.3f} x the Griffith stress"

    # the engine's damage model, at the displacement field scaled to just below / above it
    x = sim.fields["Model_Coordinates"]
    u = sim.fields["Coordinates"] - x
    broken = {}
    for k in (0.99, 1.01):
        sim.fields["Coordinates"][:] = x + (k * factor) * u
        sim.evaluate_forces()
        broken[k] = np.flatnonzero(sim.fields["Damage"][: sim.num_owned] > 0.0)
    assert broken[0.99].size == 0
    assert broken[1.01].size > 0
    near_tip = (np.abs(np.abs(x[broken[1.01], 0]) - g["a"]) < g["delta"] + DX) & (np.abs(x[broken[1.01], 1]) < g["delta"] + DX)
    assert near_tip.all(), "bonds break only at the crack tips"
    assert np.any(x[broken[1.01], 0] > 0) and np.any(x[broken[1.01], 0] < 0), "both tips start at once (symmetry)"


def test_j_of_the_plate_is_k_squared_over_e(loaded_plate):
    """J_Integral on the plate below crack growth: K_I = sigma sqrt(pi a) F(a/b) (Tada), J =
    K_I^2 / E (plane stress). Measured 0.973 at both tips; tolerance 8 % (the peridynamic field
    near the tip differs from the classical one by O(delta); a square plate, where the ends
    lower K_I by about 6 %, gives 0.886)."""
    sim, g = loaded_plate
    a = g["a"]
    K = mean_stress(sim, g) * math.sqrt(math.pi * a) * tada(a, g["W"] / 2)
    right, left = (sim.outputs.computes[k].value(sim) / (K**2 / E) for k in ("Right", "Left"))
    assert right == pytest.approx(left, rel=1e-6)  # symmetry
    assert abs(right - 1.0) < 0.08, right


def test_energy_release_rate_at_initiation_is_g0(loaded_plate):
    """The same statement in energy: J (linear in the load squared) at the initiation load is
    G0; measured 1.065 (the two errors above combined); tolerance 15 %."""
    sim, g = loaded_plate
    _, _, s = bond_stretches(sim, g)
    factor = sim.blocks[0].damage.s_c / s.max()
    J_init = sim.outputs.computes["Right"].value(sim) * factor**2
    assert abs(J_init / G0 - 1.0) < 0.15, J_init / G0
