"""Peridigm's ``tensile_test`` example, unchanged (run on demand, not a test): whole-run wall time,
peak memory and Young's modulus against Peridigm on the same machine type.

The deck (``/work/shared/benchmarks/tensile_test``: a dog-bone bar of 12,625 points, Elastic
Correspondence, QuasiStatic with 4 load steps on Peridigm's finite-difference tangent) is copied
to a temporary folder and run with ``/usr/bin/time -v peridyn run`` (a fresh process: set-up and
numba cache loading included). Young's modulus as the accuracy anchor of the benchmarks' README:
the gauge strain from the ``Nearest_Point_Data`` computes (change of the distance of the two
gauge points over their initial distance, along y) and the mean of the end reactions
(``Block_Data`` sums of Force, y) over the 0.635 cm x 0.315 cm section, at the last step.

Peridigm (README, 2026-11-23): 504 s, 1.66 GiB, E = 178.5 GPa (deck moduli: 180.0 GPa).

    python benchmarks/tensile_test.py [--deck DIR] [--keep] [--material MODEL]

``--material`` swaps the deck's material model (same density and moduli; `Hourglass Coefficient`
dropped for non-correspondence models), e.g. ``Elastic`` (LPS) or ``Pals``, to measure the
surface effect of a model on the same bar: E against the deck's 180 GPa.
"""
from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

DECK = Path("/work/shared/benchmarks/tensile_test")
SECTION = 0.635 * 0.315  # cm^2
PERIDIGM = {"wall_s": 504.0, "peak_GiB": 1.66, "E_GPa": 178.5}
E_DECK = 9.0 * 1.5e12 * 6.923e11 / (3.0 * 1.5e12 + 6.923e11)  # dyne/cm^2


def global_series(path: Path) -> dict[str, list[float]]:
    """Exodus global variables: name -> values per output step."""
    import netCDF4

    with netCDF4.Dataset(path) as ds:
        if "name_glo_var" not in ds.variables:
            return {}
        names = ["".join(c.decode() for c in row if c).strip() for row in ds["name_glo_var"][:].data]
        vals = ds["vals_glo_var"][:].data
    return {name: [float(v) for v in vals[:, k]] for k, name in enumerate(names)}


def youngs_modulus(g: dict[str, list[float]]) -> dict:
    """Gauge strain, end reaction and E (GPa) at the last step from the computes' outputs."""
    def pick(label: str, comp: str) -> float:
        for key in (f"{label}{comp}", f"{label}_{comp}", f"{label}{comp.lower()}"):
            if key in g:
                return g[key][-1]
        raise KeyError(f"{label} {comp} not among {sorted(g)}")

    y_top, y_bot = pick("Gage_Top_Initial_Position", "Y"), pick("Gage_Bottom_Initial_Position", "Y")
    u_top, u_bot = pick("Gage_Top_Displacement", "Y"), pick("Gage_Bottom_Displacement", "Y")
    strain = (u_top - u_bot) / (y_top - y_bot)
    top, bottom = pick("Top_Reaction_Force", "Y"), pick("Bottom_Reaction_Force", "Y")
    force = 0.5 * (abs(top) + abs(bottom))
    E = force / SECTION / strain  # dyne/cm^2; 1 GPa = 1e10 dyne/cm^2
    return {"gauge_strain": strain, "top_reaction": top, "bottom_reaction": bottom, "E_GPa": E / 1e10,
            "E_error_vs_deck": E / E_DECK - 1.0}


def swap_material(yaml_file: Path, model: str) -> None:
    """Replace the deck's Material Model by ``model`` (moduli and density kept)."""
    text = yaml_file.read_text()
    text = re.sub(r'Material Model: "[^"]*"', f'Material Model: "{model}"', text)
    if "Correspondence" not in model:  # drop what only the correspondence family has
        for key in ("Hourglass Coefficient", "Hourglass_Force_Density", "Cauchy_Stress"):
            text = re.sub(rf"\n\s*{key}: [^\n]*", "", text)
    yaml_file.write_text(text)


def run(deck: Path, keep: bool, material: str | None = None) -> dict:
    tmp = Path(tempfile.mkdtemp(prefix="tensile_test_"))
    try:
        work = tmp / "tensile_test"
        shutil.copytree(deck, work)
        if material:
            swap_material(work / "tensile_test.yaml", material)
        cmd = ["/usr/bin/time", "-v", sys.executable, "-m", "peridyn", "run", "tensile_test.yaml", "--no-progress", "-v"]
        proc = subprocess.run(cmd, cwd=work, capture_output=True, text=True, check=False)
        err = proc.stderr
        out = {"returncode": proc.returncode, "folder": str(work) if keep else None}
        m = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", err)
        if m:
            parts = [float(p) for p in m.group(1).split(":")]
            wall = 0.0
            for p in parts:
                wall = wall * 60.0 + p
            out["wall_s"] = wall
        m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", err)
        if m:
            out["peak_GiB"] = int(m.group(1)) / 2**20
        out["newton"] = [line for line in (proc.stdout + err).splitlines() if re.search(r"load step|iteration|tangent", line, re.IGNORECASE)][-40:]
        exo = work / "tensile_test.e"
        if proc.returncode == 0 and exo.exists():
            out.update(youngs_modulus(global_series(exo)))
        else:
            out["tail"] = (proc.stdout + err)[-4000:]
        return out
    finally:
        if not keep:
            shutil.rmtree(tmp, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--deck", type=Path, default=DECK)
    ap.add_argument("--keep", action="store_true", help="keep the run folder")
    ap.add_argument("--material", help="material model to use instead of the deck's (e.g. Elastic, Pals)")
    args = ap.parse_args()
    res = run(args.deck, args.keep, args.material)
    res["material"] = args.material or "deck (Elastic Correspondence)"
    res["peridigm"] = PERIDIGM
    print(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
