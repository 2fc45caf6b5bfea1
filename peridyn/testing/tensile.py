"""A straight tensile bar that measures a material's Young's modulus the way an experiment does.

The set-up of Peridigm's tensile example (``tensile_test.yaml``), on a bar of our own making:

* a lattice bar of square section, the long axis along y, centred on the origin; spacing
  ``h = horizon / ratio``; ``n`` points across (odd, so that the centre planes x = 0 and z = 0
  hold points), the section ``n h`` close to ``section`` horizons;
* three blocks: ``block_1`` (bottom grip), ``block_2`` (gauge section) and ``block_3`` (top grip);
  each grip is ``grip`` horizons long;
* both grips are pulled by the prescribed displacement ``u_y = y * strain * t``; their points on
  the centre plane x = 0 (z = 0) are held in x (z), which removes the rigid motions without
  resisting the Poisson contraction (by symmetry those points do not move sideways);
* ``Nearest_Point_Data`` gauges one horizon inside the gauge section on the axis, and
  ``Block_Data`` sums of ``Force`` over each grip (the reaction forces).

The engineering modulus is then ``E = F / (A eps)`` with ``F`` the mean of the two grips'
reactions, ``A = (n h)^2`` the section, and ``eps`` the gauge elongation over the gauge length.
Peridigm's correspondence model gives -0.82 % on its own (dog-bone) example; a linear
peridynamic solid on a lattice has the errors of its discrete bond sums and of its softer
surface layer, and they shrink as the horizon holds more spacings.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["TensileBar", "lattice_youngs_modulus", "tensile_bar", "youngs_modulus_from_outputs"]

#: Output labels of the bar's computes.
GAUGE_LABELS = ("Gage_Top_Displacement", "Gage_Bottom_Displacement", "Gage_Top_Initial_Position", "Gage_Bottom_Initial_Position")
REACTION_LABELS = ("Top_Reaction_Force", "Bottom_Reaction_Force")


@dataclass(frozen=True)
class TensileBar:
    """What :func:`tensile_bar` made: the deck tree and the bar's dimensions (deck units)."""

    tree: dict[str, Any]
    spacing: float
    points_across: int
    num_points: int
    section_area: float

    def youngs_modulus(self, sim) -> float:
        """The engineering modulus from the computes of a finished run ``sim``."""
        sim.outputs.run_computes(GAUGE_LABELS + REACTION_LABELS)
        values = {name: np.asarray(sim.fields[name], dtype=float) for name in GAUGE_LABELS + REACTION_LABELS}
        return youngs_modulus_from_outputs(values, self.section_area)


def youngs_modulus_from_outputs(values: dict[str, np.ndarray], section_area: float) -> float:
    """``E = F / (A eps)`` from the bar's global outputs (vectors of three components).

    ``F`` is the mean magnitude of the two grips' y reactions (they balance when the gauge
    section is in equilibrium), ``eps`` the change of the gauges' distance over their initial
    distance."""
    top, bottom = values["Gage_Top_Displacement"], values["Gage_Bottom_Displacement"]
    length = values["Gage_Top_Initial_Position"][1] - values["Gage_Bottom_Initial_Position"][1]
    strain = (top[1] - bottom[1]) / length
    force = 0.5 * (values["Bottom_Reaction_Force"][1] - values["Top_Reaction_Force"][1])
    return float(force / (section_area * strain))


def lattice_family(ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """The family of a point of the unit cubic lattice within ``ratio`` spacings (inclusive, the
    point itself excluded): bond vectors (k, 3) in lexicographic order and their lengths (k,)."""
    reach = int(math.floor(ratio)) + 1
    g = np.arange(-reach, reach + 1, dtype=float)
    xi = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    d = np.linalg.norm(xi, axis=1)
    keep = (d > 0) & (d <= ratio)
    return xi[keep], d[keep]


def lattice_youngs_modulus(bulk: float, shear: float, ratio: float, influence=None) -> float:
    """Young's modulus along a lattice axis of the linear peridynamic solid (``Elastic``) on an
    infinite cubic lattice: the bar's modulus without its surfaces.

    The strain energy density of a homogeneous small strain ``eps`` is
    ``K/2 theta^2 + 15 mu / (2 m) sum_j w (e_j - theta |xi_j| / 3)^2 V``, with the discrete
    sums of the model (``m = sum w |xi|^2 V``, ``theta = 3/m sum w |xi| e V``,
    ``e = xi.eps.xi / |xi|``) over the lattice vectors with ``|xi| <= ratio`` spacings.
    Cubic symmetry makes the dilatation exact; the deviatoric bond sums are not isotropic, which
    is the lattice's error. Returns ``1 / S_1111`` (Pa when the moduli are), ``S`` the
    compliance. ``influence``: ``w(|xi| / horizon)``, default 1 (Peridigm's ``One``).
    """
    xi, d = lattice_family(ratio)
    w = np.ones_like(d) if influence is None else np.asarray(influence(d / ratio), dtype=float)
    m = np.sum(w * d * d)
    # the energy is a quadratic form in the 6 strain components (Voigt, engineering shears)
    pairs = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
    basis = np.zeros((6, 3, 3))
    for k, (i, j) in enumerate(pairs):
        basis[k, i, j] = basis[k, j, i] = 1.0 if i == j else 0.5
    e = np.einsum("bi,kij,bj->kb", xi, basis, xi) / d  # bond extension per unit strain component
    theta = 3.0 / m * (e @ (w * d))
    ed = e - np.outer(theta, d) / 3.0
    stiffness = bulk * np.outer(theta, theta) + 15.0 * shear / m * (ed * w) @ ed.T
    return float(1.0 / np.linalg.inv(stiffness)[0, 0])


def tensile_bar(
    material: dict[str, Any],
    directory: str | Path,
    *,
    ratio: float = 4.0,
    horizon: float = 1.0,
    section: float = 2.0,
    gauge: float = 4.0,
    grip: float = 2.0,
    strain: float = 0.005,
    solver: dict[str, Any] | None = None,
    layers: int | None = None,
) -> TensileBar:
    """Write the bar's text-file mesh into ``directory`` and return its deck.

    material: a ``Materials`` entry (``Material Model`` included) in the deck's units.
    ratio: horizon / spacing. horizon: the horizon (L). section, gauge, grip: the section width,
    gauge-section length and grip length in horizons. strain: the grips' applied strain at t = 1.
    solver: the ``Solver`` section; by default one QuasiStatic load step to t = 1.
    layers: points through the section along z (odd; 1 for a plate of one layer), by default as
    many as across x (a square section).
    """
    directory = Path(directory)
    h = horizon / ratio
    n = int(round(section * ratio))
    n += 1 - n % 2  # odd: the centre planes hold points
    n_grip = max(1, int(math.ceil(grip * ratio - 1e-9)))
    n_gauge = max(2, int(round(gauge * ratio)))
    ny = n_gauge + 2 * n_grip
    across = (np.arange(n) - (n - 1) / 2) * h
    nz = n if layers is None else int(layers)
    if nz < 1 or nz % 2 == 0:
        raise ValueError(f"layers must be odd and at least 1 (the centre plane z = 0 holds points), not {layers!r}")
    through = (np.arange(nz) - (nz - 1) / 2) * h
    along = (np.arange(ny) - (ny - 1) / 2) * h
    y, x, z = np.meshgrid(along, across, through, indexing="ij")
    x, y, z = x.ravel(), y.ravel(), z.ravel()
    row = np.repeat(np.arange(ny), n * nz)
    block = np.where(row < n_grip, 1, np.where(row >= ny - n_grip, 3, 2))
    lines = [f"{a:.17g} {b:.17g} {c:.17g} {k} {h**3:.17g}" for a, b, c, k in zip(x, y, z, block)]
    (directory / "tensile_bar.txt").write_text("# x y z block volume\n" + "\n".join(lines) + "\n")

    ids = np.arange(1, x.size + 1)
    grips = block != 2
    sets = {
        "grips": ids[grips],
        "grips_centre_x": ids[grips & (np.abs(x) < 0.5 * h)],
        "grips_centre_z": ids[grips & (np.abs(z) < 0.5 * h)],
    }
    for name, members in sets.items():
        (directory / f"tensile_bar_{name}.txt").write_text("\n".join(str(i) for i in members) + "\n")

    gauge_y = (n_gauge / 2.0) * h - horizon  # one horizon inside the gauge section
    computes: dict[str, Any] = {}
    for side, sign in (("Top", 1.0), ("Bottom", -1.0)):
        for what, variable in (("Initial_Position", "Model_Coordinates"), ("Displacement", "Displacement")):
            computes[f"Gage {side} {what}"] = {
                "Compute Class": "Nearest_Point_Data", "X": 0.0, "Y": sign * gauge_y, "Z": 0.0,
                "Variable": variable, "Output Label": f"Gage_{side}_{what}",
            }
        computes[f"{side} Reaction Force"] = {
            "Compute Class": "Block_Data", "Calculation Type": "Sum", "Block": "block_3" if side == "Top" else "block_1",
            "Variable": "Force", "Output Label": f"{side}_Reaction_Force",
        }
    tree: dict[str, Any] = {
        "Discretization": {
            "Type": "Text File", "Input Mesh File": "tensile_bar.txt",
        },
        "Materials": {"Bar Material": dict(material)},
        "Blocks": {"Bar": {"Block Names": "block_1 block_2 block_3", "Material": "Bar Material", "Horizon": float(horizon)}},
        "Boundary Conditions": {
            "Grips Node Set": "tensile_bar_grips.txt",
            "Grips Centre X Node Set": "tensile_bar_grips_centre_x.txt",
            "Grips Centre Z Node Set": "tensile_bar_grips_centre_z.txt",
            "Pull": {"Type": "Prescribed Displacement", "Node Set": "Grips Node Set", "Coordinate": "y", "Value": f"y*{strain!r}*t"},
            "Hold X": {"Type": "Prescribed Displacement", "Node Set": "Grips Centre X Node Set", "Coordinate": "x", "Value": "0.0"},
            "Hold Z": {"Type": "Prescribed Displacement", "Node Set": "Grips Centre Z Node Set", "Coordinate": "z", "Value": "0.0"},
        },
        "Solver": solver if solver is not None else {
            "Initial Time": 0.0, "Final Time": 1.0,
            "QuasiStatic": {"Number of Load Steps": 1, "Relative Tolerance": 1.0e-8, "Maximum Solver Iterations": 10},
        },
        "Compute Class Parameters": computes,
        "Output": {
            "Output File Type": "ExodusII", "Output Filename": "tensile_bar", "Output Frequency": 1,
            "Output Variables": {"Displacement": True, "Force": True, **{k: True for k in GAUGE_LABELS + REACTION_LABELS}},
        },
    }
    return TensileBar(tree=tree, spacing=h, points_across=n, num_points=int(x.size), section_area=float(n * h * nz * h))
