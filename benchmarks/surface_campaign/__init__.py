"""Issue #33's campaign over the new surface: meshes and .geo files, regions, Surface Traction,
restart files, stress-law modules, the Python API, the commands' arguments and a 2-rank sample.

Entry point: ``python benchmarks/surface_campaign.py --cases 2000 --seed 1`` (see that file).
The entry point sets numba's threading layer (workqueue: the cases run in children forked from
its process, and GNU OpenMP refuses to fork) before anything imports numba; importing this
package changes no environment (tests import its deck helpers in pytest's own process).
"""
from __future__ import annotations

import os
import random
import shutil
import sys
import tempfile
from pathlib import Path

from .decks import GEO_BOX, RESTART, XML_DECK, base, make_meshes, write_deck  # noqa: E402,F401
from .engine import ALL_CLASSES, BAD_CLASSES, Case, Outcome, Pool  # noqa: E402,F401
from .families import Fixtures, gen_geo, gen_law, gen_mesh, gen_region, gen_restart, gen_traction  # noqa: E402
from .cli_api import gen_api, gen_cli, gen_mpi  # noqa: E402

GENERATORS = {"mesh": gen_mesh, "geo": gen_geo, "regions": gen_region, "traction": gen_traction, "restart": gen_restart,
              "stress_law": gen_law, "api": gen_api, "cli": gen_cli, "mpi": gen_mpi}
SHARES = {"mesh": 0.12, "geo": 0.08, "regions": 0.15, "traction": 0.13, "restart": 0.12, "stress_law": 0.06, "api": 0.17,
          "cli": 0.14, "mpi": 0.03}


def _quiet_main(argv: list[str], cwd: Path) -> int:
    """peridyn in this process (to compile its kernels once), its output to a file."""
    from peridyn.cli import main

    old = os.getcwd()
    fd1, fd2 = os.dup(1), os.dup(2)
    log = os.open(cwd / ".warm.log", os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    sys.stdout.flush()
    sys.stderr.flush()
    os.dup2(log, 1)
    os.dup2(log, 2)
    try:
        os.chdir(cwd)
        return int(main(argv))
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(fd1, 1)
        os.dup2(fd2, 2)
        for f in (fd1, fd2, log):
            os.close(f)
        os.chdir(old)


def make_fixtures(root: Path) -> Fixtures:
    """Meshes, a checkpointed run and one of another deck; warms peridyn's kernels in this process."""
    meshes = make_meshes(root / "meshes")
    run_dir, other = root / "run", root / "other"
    for folder, modulus in ((run_dir, 200.0e9), (other, 190.0e9)):
        folder.mkdir(parents=True)
        tree = base()
        tree["Restart"] = dict(RESTART)
        tree["Materials"]["Steel"]["Young's Modulus"] = modulus
        write_deck(folder, tree)
        rc = _quiet_main(["run", "deck.yaml", "--output-dir", ".", "--no-progress"], folder)
        if rc != 0:
            raise RuntimeError(f"fixture run failed ({rc}): {(folder / '.warm.log').read_text()[-2000:]}")
        (folder / ".warm.log").unlink()
    # warm the mesh reader, a .geo and the stress-law material in this process
    warm = root / "warm"
    warm.mkdir()
    from .decks import mesh_deck

    shutil.copy2(meshes["tet.msh"], warm / "part.msh")
    write_deck(warm, mesh_deck("part.msh"))
    _quiet_main(["run", "deck.yaml", "--output-dir", ".", "--no-progress"], warm)
    from .families import GOOD_LAW, LAW_HEAD

    (warm / "userlaw_warm.py").write_text(LAW_HEAD + GOOD_LAW)
    sys.path.insert(0, str(warm))
    t = base()
    t["Materials"] = {"Steel": {"Material Model": "Stress Law Correspondence", "Density": 7800.0, "Shear Modulus": 76.9e9,
                                "Bulk Modulus": 166.7e9, "Hourglass Coefficient": 0.02, "Stress Law": "userlaw_warm:law",
                                "Law Parameters": [76.9e9, 115.4e9]}}
    write_deck(warm, t, "law.yaml")
    _quiet_main(["run", "law.yaml", "--output-dir", ".", "--no-progress"], warm)
    import peridyn.api  # noqa: F401

    return Fixtures(meshes=meshes, geo=GEO_BOX, run_dir=run_dir, other_dir=other, result=run_dir / "base.e", xml=XML_DECK)


def plan(n: int, seed: int, fx: Fixtures, families: list[str] | None = None) -> list[Case]:
    """``n`` cases (at least one of every family), each from random.Random(f'{seed}:{family}:{i}')."""
    fams = families or list(GENERATORS)
    total = sum(SHARES[f] for f in fams)
    counts = {f: max(1, round(n * SHARES[f] / total)) for f in fams}
    cases = []
    for f in fams:
        for i in range(counts[f]):
            cases.append(GENERATORS[f](random.Random(f"{seed}:{f}:{i}"), fx))
    random.Random(seed).shuffle(cases)
    cases.sort(key=lambda c: c.mode != "mpi")  # the slow 2-rank subprocesses first, the forks fill the other slot
    return cases


def campaign(n: int, seed: int, jobs: int = 2, families: list[str] | None = None, keep: Path | None = None,
             progress: bool = False) -> tuple[list[tuple[Case, Outcome]], float, float]:
    """Run it: ([(case, outcome)], set-up seconds, run seconds)."""
    import time

    t0 = time.perf_counter()
    root = Path(tempfile.mkdtemp(prefix="surface-campaign-"))
    try:
        fx = make_fixtures(root)
        cases = plan(n, seed, fx, families)
        t1 = time.perf_counter()
        results: list[tuple[Case, Outcome]] = []

        def report(case, out, spec, tmp):
            results.append((case, out))
            if progress and (len(results) % 50 == 0 or out.klass in BAD_CLASSES):
                bad = f"  BAD {out.klass}: {case.family}: {case.name[:90]} | {out.line[:160]}" if out.klass in BAD_CLASSES else ""
                print(f"[{len(results)}/{len(cases)} {time.perf_counter() - t1:.0f}s]{bad}", file=sys.stderr, flush=True)
        Pool(jobs, keep).run(cases, report)
        return results, t1 - t0, time.perf_counter() - t1
    finally:
        shutil.rmtree(root, ignore_errors=True)
