"""peridyn's own gold files: a deck run today must reproduce the Exodus file a reviewed
version wrote, to round-off. Regenerate a gold file only for a change that is meant to move
results (``python tests/regression/test_gold_files.py --regenerate``), and say why in the commit.
"""
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.io.exodus_reader import read_results

DATA = Path(__file__).resolve().parent / "data"
CASES = ["two_materials"]


def run(case: str, folder: Path) -> Path:
    for f in DATA.glob(f"{case}*"):
        if "_gold" not in f.name:
            shutil.copy(f, folder / f.name)
    assert main(["run", str(folder / f"{case}.yaml"), "--output-dir", str(folder), "-q", "--no-progress"]) == ExitCode.OK
    return folder / f"{case}.e"


def compare(result: Path, gold: Path, rtol: float = 1e-9) -> list[str]:
    """Differences beyond rtol (relative to each variable's largest magnitude; a vector's
    components X, Y, Z to the largest of the three, so that a component that is zero by symmetry
    is judged by the vector's scale, not by its own round-off) in times, coordinates, maps and
    every nodal, element and global variable."""
    r, g = read_results(result), read_results(gold)
    problems = []
    for key in ("coords", "times", "node_num_map", "elem_num_map"):
        if r[key].shape != g[key].shape or not np.allclose(r[key], g[key], rtol=1e-14, atol=0):
            problems.append(f"{key} differ")
    for kind in ("nodal", "element", "global"):
        if set(r[kind]) != set(g[kind]):
            problems.append(f"{kind} variables differ: {sorted(set(r[kind]) ^ set(g[kind]))}")
            continue
        for name, gv in g[kind].items():
            rv = r[kind][name]
            siblings = [name[:-1] + c for c in "XYZ"] if name[-1:] in ("X", "Y", "Z") else [name]
            siblings = [n for n in siblings if n in g[kind]] if all(n in g[kind] for n in siblings) else [name]
            scale = max((np.nanmax(np.abs(g[kind][n])) if np.size(g[kind][n]) else 0.0) for n in siblings)
            if rv.shape != gv.shape or not np.allclose(rv, gv, rtol=0, atol=rtol * scale + 1e-300, equal_nan=True):
                problems.append(f"{kind} {name}: max |diff| {np.nanmax(np.abs(rv - gv)):.3e} (scale {scale:.3e})")
    return problems


@pytest.mark.parametrize("case", CASES)
def test_output_matches_gold(case, tmp_path):
    problems = compare(run(case, tmp_path), DATA / f"{case}_gold.e")
    assert not problems, "\n".join(problems)


def test_comparison_detects_a_change(tmp_path):
    """The comparison is not vacuous: a perturbed copy fails it."""
    import netCDF4

    out = run(CASES[0], tmp_path)
    with netCDF4.Dataset(out, "a") as ds:
        ds.variables["vals_nod_var1"][3, 5] += 1e-6 * float(np.abs(ds.variables["vals_nod_var1"][:]).max())
    assert compare(out, DATA / f"{CASES[0]}_gold.e")


if __name__ == "__main__" and "--regenerate" in sys.argv:
    import tempfile

    for case in CASES:
        with tempfile.TemporaryDirectory() as tmp:
            shutil.copy(run(case, Path(tmp)), DATA / f"{case}_gold.e")
            print(f"regenerated {case}_gold.e")
