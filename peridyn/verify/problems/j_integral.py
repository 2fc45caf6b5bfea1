"""``j-integral``: the ``J_Integral`` compute around the right tip of the centre-cracked plate of
``griffith`` (tests/verification/test_griffith.py; its deck builders are imported, not copied)
against (a) the energy release rate of the loading, G = K_I^2 / E' with Tada's finite-width
K_I, in the elastic subcritical state, and (b) the G_c of the critical-stretch model at the
load of the first bond break."""
from __future__ import annotations

import math
import time
from typing import Any

from .base import Check, Measurement, Problem
from .griffith import CRITICAL_ENERGY, E, G0, initiation, plate_deck, tada
from ...engine.session import run_sections

#: horizon / spacing: the ``griffith`` plate's (first-bond failure matches Griffith within 10 % only for m ~ 3..4)
M = 3.0
#: relative residual the plate is solved to (griffith's 1e-10 moves J and the stretches by < 1e-6 relative, for a third Newton iteration)
TOLERANCE = 1.0e-6


def critical_energy_of_stretch(s0: float, delta: float) -> float:
    """G_c (J/m^2) that a critical stretch s0 stands for in the bond-based plane-stress model:
    G_c = c h s0^2 delta^4 / 4 with c = 9 E / (pi h delta^3), i.e. 9 E delta s0^2 / (4 pi) (Ha &
    Bobaru 2010, eq. 4; peridyn.damage.critical_energy)."""
    return 9.0 * E * delta * s0**2 / (4.0 * math.pi)


def rings(a: float, delta: float) -> dict[str, tuple[float, float]]:
    """(inner, outer) radius (m) of the J rings around the tip: "J" the banded one, from one
    horizon (outside the tip's nonlocal zone) to a (inside the plate: the other tip is 2a away,
    the side edge 1.5a, the grips 5a); "J2" a second, a/2 .. 5a/4, shown for path independence."""
    return {"J": (delta, a), "J2": (a / 2.0, 1.25 * a)}


def cracked_plate(a_per_delta: float) -> tuple[dict[str, Any], dict[str, float]]:
    """``griffith``'s plate with horizon M dx, a = a_per_delta horizons and width about 5a (an
    even number of points across, so that the tips lie between two columns of points, as at
    a/delta = 4, 6), ``Critical Energy`` damage and the J rings around the right tip."""
    a_cells = int(round(M * a_per_delta))
    if abs(a_cells - M * a_per_delta) > 1e-9:
        raise ValueError(f"a/delta = {a_per_delta:g} does not put the tip on the lattice (m = {M:g}): a must be whole spacings")
    n = 5 * a_cells + a_cells % 2
    tree, g = plate_deck(n=n, m=M, a_cells=a_cells, damage=CRITICAL_ENERGY)
    ring = {"Compute Class": "J_Integral", "Crack Tip X": g["a"], "Crack Tip Y": 0.0, "Thickness": g["h"]}
    tree["Compute Class Parameters"] = {k: {**ring, "Inner Radius": ri, "Outer Radius": ro} for k, (ri, ro) in rings(g["a"], g["delta"]).items()}
    tree["Solver"]["QuasiStatic"]["Relative Tolerance"] = TOLERANCE
    return tree, g


class JIntegral(Problem):
    name = "j-integral"
    title = "J-integral of a cracked plate against K_I^2/E' and, at crack initiation, against G_c"
    kind = "curve"
    computes = (
        "The `J_Integral` compute (equivalent domain integral with the peridynamic displacement gradient, "
        "docs/fracture.md) around the right tip of the plate of `griffith`: a plane-stress plate of `Elastic Bond Based` "
        "points (E = 3 GPa, nu = 1/3, one layer, dx = 1 mm, horizon delta = 3 dx) with `Critical Energy` damage "
        "(G0 = 300 J/m^2), a centre crack 2a along y = 0 (a bond filter; the tips lie between two columns of points), "
        "width 2b about 5a (an even number of points across), height twice the width, grips one horizon thick pulled "
        "apart to a mean end strain of 1e-4 (with the uncracked plate's lateral contraction) in one quasi-static step "
        "solved to a relative residual of 1e-6. Ring: q = 1 within delta of the tip, 0 beyond a (the column J on "
        "a/2 .. 5a/4 shows how much J moves with the ring: up to 4 %). The ladder grows the plate around a fixed "
        "lattice (a = (a/delta) delta), which is the same as refining a fixed crack at delta/dx = 3. (a) J at the "
        "solved load, where no bond is broken, over G = K_I^2 / E'. (b) The model is linear until a bond breaks, so "
        "the load of the first break is lambda = s0 / max(stretch) times the solved one (as in `griffith`) and "
        "J_init = lambda^2 J, set against the G_c the critical stretch s0 stands for. Error: |J / (K_I^2/E') - 1|; "
        "the columns give J_init / G_c."
    )
    reference = (
        "(a) Plane stress: G = K_I^2 / E' with E' = E, K_I = sigma sqrt(pi a) F(a/b), sigma the mean end stress "
        "(top grip's reaction over the section), F = (1 - 0.025 (a/b)^2 + 0.06 (a/b)^4) sqrt(sec(pi a / 2b)) (Tada, "
        "Paris & Irwin, The Stress Analysis of Cracks Handbook, 3rd ed., p. 5.2; 0.1 % for any a/b under uniform "
        "remote tension; F = 1.11 at a/b = 0.4; the plate, 4b high, is taken as infinitely high). J is path "
        "independent, so J = G on any ring that holds the tip and no other singularity. (b) The bond-based "
        "plane-stress critical stretch stands for G_c = c h s0^2 delta^4 / 4 = 9 E delta s0^2 / (4 pi) (Ha & Bobaru "
        "2010, eq. 4, the conversion `Critical Energy` uses; G_c is computed from the engine's s0, and a check asks it "
        "to be the deck's G0). Bands, per point: |J / (K_I^2/E') - 1| <= 8 %, |J_init / G_c - 1| <= 15 % (the "
        "tolerances of tests/verification/test_j_integral.py and test_griffith.py), no bond broken at the solved load. "
        "The error does not converge to zero with a/delta at fixed delta/dx = 3: the lattice of an m = 3 horizon "
        "(full point volumes) is stiffer than the continuum the micromodulus is calibrated to (C11 5.3 % above 9E/8; "
        "E_lattice = 1.064 E and nu = 0.318 in uniaxial stress; 1.055 E measured in the uncracked 60-point plate), so "
        "the strains, and J computed from them with the nominal E, come out low by several %, an offset that the "
        "softer nonlocal field near the tip and the crack faces, whose weight falls with delta/a, partly cancels at "
        "small a/delta; J_init / G_c is in addition first-bond failure at a "
        "sharp tip, which happens near G_c only for m ~ 3..4 (docs/fracture.md: K_init / K_c = 1.42 .. 0.73 for "
        "m = 2 .. 6). A J compute using a modulus 20 % low or 25 % high fails both J bands; a critical stretch 10 % "
        "off fails the G_c check alone."
    )
    resolution_name = "a/delta"
    size_name = "delta/a"
    error_name = "|J / (K_I^2/E') - 1|"
    methods = (f"m = {M:g}",)
    method_materials = {f"m = {M:g}": "Elastic Bond Based"}
    unfitted = {f"m = {M:g}": "at a fixed delta/dx = 3 the error tends to the m = 3 lattice's offset (stiffer than E by about "
                              "6 %; J/(K_I^2/E') 0.97, 0.98, 0.95, 0.96, 0.94 for a/delta = 2 .. 6), not to zero, as a/delta "
                              "grows; the ring's lattice sampling adds a few % of scatter"}
    #: per point: |J / (K_I^2/E') - 1| and |J_init / G_c - 1|
    every_band = {f"m = {M:g}": 0.08}
    INIT_BAND = 0.15

    def ladder(self, method: str, quick: bool) -> list[float]:
        return [2.0, 3.0] if quick else [2.0, 3.0, 4.0, 5.0, 6.0]

    def measure(self, method: str, resolution: float, quick: bool) -> Measurement:
        from ...testing import build_simulation

        t0 = time.perf_counter()
        tree, g = cracked_plate(resolution)
        sim = build_simulation(tree)
        run_sections(sim)
        sigma, factor, broken = initiation(sim, g)
        J = {k: c.value(sim) for k, c in sim.outputs.computes.items()}
        wall = time.perf_counter() - t0
        a, b = g["a"], g["W"] / 2.0
        K = sigma * math.sqrt(math.pi * a) * tada(a, b)
        G = K**2 / E
        s0 = sim.blocks[0].damage.s_c
        Gc = critical_energy_of_stretch(s0, g["delta"])
        J_init = factor**2 * J["J"]
        sigma_c = math.sqrt(E * G0 / (math.pi * a)) / tada(a, b)
        return Measurement(abs(J["J"] / G - 1.0), size=1.0 / resolution, steps=1, values={
            "points": sim.num_global, "a/b": a / b, "K_I^2/E' (J/m^2)": G, "J (J/m^2)": J["J"], "J/(K_I^2/E')": J["J"] / G,
            "J on a/2..5a/4 /(K_I^2/E')": J["J2"] / G, "G_c(s0) (J/m^2)": Gc, "J_init (J/m^2)": J_init, "J_init/G_c": J_init / Gc,
            "sigma_init/sigma_c": factor * sigma / sigma_c, "broken bonds at the solved load": broken, "wall (s)": wall})

    def extra_checks(self, method: str, points: list[dict[str, Any]], quick: bool) -> list[Check]:
        out = []
        for p in points:
            v = p["values"]
            out.append(Check(self.name, method, f"|J_init / G_c - 1| at the first bond break, a/delta = {p['resolution']:g}",
                             abs(v["J_init/G_c"] - 1.0), high=self.INIT_BAND))
            out.append(Check(self.name, method, f"bonds broken at the solved load (the subcritical state of (a)), a/delta = {p['resolution']:g}",
                             float(v["broken bonds at the solved load"]), high=0.0))
        p = points[-1]
        out.append(Check(self.name, method, "|G_c(s0) / G0 - 1|: the critical stretch stands for the deck's G0 (9 E delta s0^2 / (4 pi))",
                         abs(p["values"]["G_c(s0) (J/m^2)"] / G0 - 1.0), high=1e-9))
        return out

