"""The largest stable Verlet safety factor with stiff contact springs (run on demand, not a test).

Peridigm's critical time step counts bonds only (PERIDIGM_CONTACT.md §7), but a ``Short Range
Force`` spring is the bond-based law with micromodulus 18 k / (pi delta^4), so a ``Spring
Constant`` k well above the bulk modulus K lowers the true limit. For each k/K this finds, by
bisection in log(Safety Factor), the largest factor (relative to the bond-only estimate) whose
run stays stable, and sets it against ContactManager.stable_time_step() / the bond estimate,
the factor our set-up warning suggests.

Scene: two 6^3-point Elastic (LPS) cubes of steel (Shapes discretization, spacing h = 1 mm,
``Omit Bonds Between Blocks: All``), face to face with the facing points exactly R_c = h apart,
approaching at 0.2 m/s each and pressed together by an opposite body force on each cube
(``--drives force``) or by prescribed motion of their back layers at 0.2 m/s (``motion``), so
the contact springs act during most of the run: 1,000 steps at the bond estimate (about 55,000 at the
smallest factor; ``--length`` scales this).

Each run is ``peridyn run`` in a subprocess, classified from its end-of-run summary and Exodus
output. stable: exit 0, no NaN in the output, largest energy balance error of the run <= 1 %
(runs well inside the limit stay below 0.2 %; the solver warns above 3 %) and a stored energy not
below -1 % of the energy scale (the run starts unstrained: a negative one is energy created);
together these bound the kinetic energy by the work done on the bodies. stopped: exit 3, by the
energy monitor; we record whether its message blames the contact springs. silent: exit 0 but a
test above failed. nan: a non-finite value in the output (must never happen). error: any other
exit code. Near the limit the runs are stopped late (slow energy growth), so the limit found
depends somewhat on the run length (``--length``).

    NUMBA_NUM_THREADS=1 python benchmarks/contact_stability.py            # 2 horizons x 2 drives, ~25 min
    NUMBA_NUM_THREADS=1 python benchmarks/contact_stability.py --quick    # 2 ratios, ~1 min
"""
from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import logging
import math
import os
import platform
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
RATIOS = (1, 3, 10, 30, 100, 300, 1000)
QUICK_RATIOS = (3, 300)
H = 1.0e-3  # point spacing (m)
K, G, RHO = 130.0e9, 78.0e9, 7800.0
SPEED = 0.2  # approach speed of each cube (m/s)
BODY_FORCE = 1.6e10  # N/m^3 pressing each cube towards the other (about 0.07 % strain)
STEPS_AT_ONE = 1000  # run length in steps at Safety Factor 1 (times --length)
LENGTH = [1.0]
MARGIN = [1.0]  # ContactManager's STABLE_STEP_MARGIN, if any (the "bare" estimate is without it)
USUAL = (0.7, 0.9)  # Peridigm's usual safety factors
FRAMES = 20  # output frames per run
MAX_BALANCE = 0.01  # "stable runs stay below 1%" (the Verlet solver warns above 3%)


def tree(ratio: float, factor: float, hf: float, drive: str, final_time: float = 1.0, frequency: int = 1) -> dict:
    """The deck (without the ``Peridigm`` key) for k/K = ratio, horizon hf * h."""
    def box(block: str, x0: float, x1: float) -> dict:
        return {"Shape": "Box", "Block": block, "Min": [x0 * H, 0.0, 0.0], "Max": [x1 * H, 6 * H, 6 * H], "Spacing": H}

    shapes = {"Left Back": box("block_1", 0, 1), "Left": box("block_1", 1, 6), "Right": box("block_2", 6, 11), "Right Back": box("block_2", 11, 12)}
    bcs = {}
    for name, sign in (("Left Back", 1), ("Left", 1), ("Right", -1), ("Right Back", -1)):
        bcs[f"Velocity {name}"] = {"Type": "Initial Velocity", "Node Set": name, "Coordinate": "x", "Value": str(sign * SPEED)}
        if drive == "force":
            bcs[f"Push {name}"] = {"Type": "Body Force", "Node Set": name, "Coordinate": "x", "Value": str(sign * BODY_FORCE)}
        elif "Back" in name:
            bcs[f"Drive {name}"] = {"Type": "Prescribed Displacement", "Node Set": name, "Coordinate": "x", "Value": f"{sign * SPEED}*t"}
    return {
        "Discretization": {"Type": "Shapes", "Omit Bonds Between Blocks": "All", "Shapes": shapes},
        "Materials": {"Steel": {"Material Model": "Elastic", "Density": RHO, "Bulk Modulus": K, "Shear Modulus": G}},
        "Blocks": {"Cubes": {"Block Names": "block_1 block_2", "Material": "Steel", "Horizon": hf * H}},
        "Contact": {
            "Search Radius": (hf + 1.0) * H, "Search Frequency": 100,
            "Models": {"Springs": {"Contact Model": "Short Range Force", "Contact Radius": H, "Spring Constant": ratio * K}},
            "Interactions": {"General Contact": {"Contact Model": "Springs"}},
        },
        "Boundary Conditions": bcs,
        "Solver": {"Initial Time": 0.0, "Final Time": final_time, "Verlet": {"Safety Factor": factor}},
        "Output": {"Output Filename": "run", "Output Frequency": frequency, "Output Variables": {
            "Displacement": True, "Velocity": True, "Contact_Force_Density": True, "Global_Kinetic_Energy": True}},
    }


def estimates(hf: float, drive: str) -> tuple[float, dict[float, float]]:
    """(bond-only critical time step, {ratio: stable_time_step / bond estimate}), in-process."""
    from peridyn.contact import manager
    from peridyn.testing import build_simulation

    MARGIN[0] = getattr(manager, "STABLE_STEP_MARGIN", 1.0)

    logging.getLogger("peridyn").setLevel(logging.ERROR)
    out, dt = {}, math.nan
    for r in RATIOS:
        sim = build_simulation(tree(r, 1.0, hf, drive))
        dt = sim.critical_time_step()
        out[r] = sim.contact.stable_time_step() / dt
    return dt, out


def run(folder: Path, ratio: float, factor: float, hf: float, drive: str, dt_crit: float) -> dict:
    """One ``peridyn run``, classified."""
    folder.mkdir(parents=True, exist_ok=True)
    final = STEPS_AT_ONE * LENGTH[0] * dt_crit
    steps = int(final / (factor * dt_crit))
    deck = folder / "deck.yaml"
    deck.write_text(yaml.safe_dump({"Peridigm": tree(ratio, factor, hf, drive, final, max(1, steps // FRAMES))}, sort_keys=False))
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    p = subprocess.run([sys.executable, "-m", "peridyn", "run", "deck.yaml", "--no-progress"], cwd=folder, env=env,
                       capture_output=True, text=True, timeout=600, check=False)
    err = p.stderr
    res = {"factor": factor, "rc": p.returncode, "deck": str(deck), "stderr": err, "steps": steps}
    m = re.search(r"'Safety Factor' <= ([0-9.eE+-]+)", err)
    res["warned"] = bool(re.search(r"contact springs .* lower the stable time step estimate", err))
    res["suggested"] = float(m.group(1)) if m and res["warned"] else None
    m = re.search(r"kinetic ([^ ]+) -> ([^,]+), stored ([^,]+), work by loads ([^,]+), by prescribed motion ([^;]+);.*worst ([0-9.eE+-]+)%", err)
    finite = _finite(folder / "run.e")
    res["error_line"] = next((ln[7:] for ln in err.splitlines() if ln.startswith("error: ")), "")
    stopped_at = re.search(r"unstable at step (\d+)", res["error_line"])
    res["stopped_at"] = int(stopped_at.group(1)) if stopped_at else None
    if not finite:
        res["class"] = "nan"
    elif p.returncode == 3:
        res["class"] = "stopped"
        text = res["error_line"].lower()
        res["names_contact"] = "springs" if "contact springs" in text else "other" if "contact" in text else ""
    elif p.returncode != 0 or m is None:
        res["class"] = "error"
    else:
        k0, k1, stored, w_loads, w_presc, worst = (float(g) for g in m.groups())
        res["worst_balance"], res["stored"] = worst / 100, stored
        res["balance_warning"] = "energy of the run was off by up to" in err
        scale = max(k0, k1, abs(stored), abs(w_loads), abs(w_presc))
        bounded = worst / 100 <= MAX_BALANCE and stored >= -MAX_BALANCE * scale
        res["class"] = "stable" if bounded else "silent"
    return res


def _finite(path: Path) -> bool:
    """Whether every nodal and global value in the Exodus output is finite (True if none written)."""
    if not path.exists():
        return True
    from peridyn.io.exodus_reader import read_results

    r = read_results(path)
    return all(bool(np.isfinite(a).all()) for a in [*r["nodal"].values(), *r["global"].values()])


def sweep(ratio: float, hf: float, drive: str, dt_crit: float, est: float, work: Path, lo: float, hi: float, runs: int) -> dict:
    """A run at a quarter of the estimate (which must be stable), the usual factors, then
    bisection of log(factor) in the bracket they leave."""
    results = {}

    def probe(f: float) -> bool:
        res = run(work / f"h{hf}_{drive}_r{ratio}_sf{f:.4f}", ratio, f, hf, drive, dt_crit)
        results[f] = res
        print(f"  k/K {ratio:>5}  SF {f:.4f}: {res['class']}" + (f" at step {res['stopped_at']}" if res["stopped_at"] else "")
              + ("" if res["class"] != "stopped" else f" (names contact: {res['names_contact'] or 'NO'})"), flush=True)
        return res["class"] == "stable"

    ref = est / 4
    if probe(ref):
        lo = max(lo, ref)
    for f in USUAL:
        if probe(f):
            lo = max(lo, f)
        else:
            hi = min(hi, f)
    if lo > hi:  # not monotone: keep the lower bracket
        lo = 0.02
    for _ in range(runs):
        if hi / lo < 1.03:
            break
        mid = math.sqrt(lo * hi)
        if probe(mid):
            lo = mid
        else:
            hi = mid
    return {"ratio": ratio, "lo": lo, "hi": hi, "runs": results, "ref": ref}


def machine() -> str:
    """nproc and lscpu (the ``env`` on PATH is coreutils' env, which prints environment variables,
    not the machine: it is not run), versions, and a hash of the uncommitted sources that matter."""
    def sh(*cmd: str) -> str:
        try:
            return subprocess.run(cmd, capture_output=True, text=True, check=False).stdout.strip()
        except OSError:
            return ""

    keep = ("Architecture", "CPU(s)", "Model name", "Thread(s) per core", "Hypervisor vendor")
    lines = [f"nproc: {sh('nproc')}"] + [ln for ln in sh("lscpu").splitlines()[:20] if ln.split(":")[0] in keep]
    src = HERE.parent / "peridyn"
    files = sorted((src / "contact").glob("*.py")) + [src / "solvers" / "common.py", src / "solvers" / "verlet.py"]
    digest = hashlib.sha1(b"".join(f.read_bytes() for f in files)).hexdigest()[:10]
    lines.append(f"Python {platform.python_version()}, numpy {np.__version__}, peridyn at {sh('git', '-C', str(HERE.parent), 'describe', '--always', '--dirty')}"
                 f" (sha1 of peridyn/contact/*.py + solvers/monitors/energy.py + solvers/explicit/verlet.py: {digest})")
    return "\n".join(f"    {ln}" for ln in lines)


def report(tables: list[tuple[float, str, float, dict, list[dict]]], command: str, start: str) -> str:
    out = [f"# Contact stiffness and the stable Verlet time step\n\nDate: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC\n\nCommand:\n\n    {command}\n",
           f"Machine:\n\n{machine()}\n", (__doc__ or "").split("\n\n    NUMBA")[0].split("\n", 2)[2].strip() + "\n",
           ("Columns: *estimate* = ContactManager.stable_time_step() / bond-only estimate (the factor the set-up warning "
            "suggests); *warned* = whether the runs at 0.7 / 0.9 printed the contact warning; *measured* = largest factor "
            "found stable (the whole run), the smallest unstable one in brackets with how it ended; *meas/est* should be "
            ">= 1 (conservative). Unstable runs: stopped by the monitor (exit 3) / of them blaming the contact springs "
            "(ContactManager.diagnosis) / silent (exit 0) / NaN in the output.\n")]
    if machine() != start:
        out.insert(2, f"**The sources changed during the sweep** (other engineers' edits); at the start:\n\n{start}\n")
    notes, examples = [], {}
    for hf, drive, dt_crit, est, rows in tables:
        where = f"horizon {hf} h, {drive}"
        out.append(f"\n## Horizon {hf} h, pressed by {'body force' if drive == 'force' else 'prescribed motion of the back layers'} "
                   f"(bond-only estimate {dt_crit:.4g} s)\n")
        out.append("| k/K | estimate | warned at 0.7 / 0.9 | runs at 0.7 / 0.9 | measured | meas/est | stopped / blaming contact springs / silent / NaN | runs |")
        out.append("|---|---|---|---|---|---|---|---|")
        unnamed = []
        for row in rows:
            rs, e = row["runs"], est[row["ratio"]]
            bad = [r for r in rs.values() if r["class"] != "stable"]
            cnt = {c: sum(r["class"] == c for r in bad) for c in ("stopped", "silent", "nan", "error")}
            named = sum(r.get("names_contact") == "springs" for r in bad)
            named_s = f"{named}" + (f" (+{n2} 'contact was active')" if (n2 := sum(r.get("names_contact") == "other" for r in bad)) else "")
            for f in USUAL:
                sugg = rs[f]["suggested"]
                if rs[f]["warned"] != (f > e) or (sugg is not None and abs(sugg - e) > 0.005 * e + 1e-3):
                    notes.append(f"{where}, k/K {row['ratio']}, SF {f}: warned {rs[f]['warned']}, suggested {sugg}, estimate {e:.3g}")
            lo_s = f"{row['lo']:.3g}" if row["lo"] in rs else f"< {row['hi']:.3g}"
            h = rs.get(row["hi"])
            hi_s = "none up to 2" if h is None else f"{row['hi']:.3g}: {h['class']}" + (f" at step {h['stopped_at']} of {h['steps']}" if h["stopped_at"] else "")
            out.append(f"| {row['ratio']} | {e:.3g}" + (f" (bare {e / MARGIN[0]:.3g})" if MARGIN[0] != 1.0 else "") + f" | {' / '.join('yes' if rs[f]['warned'] else 'no' for f in USUAL)} | "
                       f"{' / '.join(rs[f]['class'] for f in USUAL)} | {lo_s} ({hi_s}) | {row['lo'] / e:.2f} | "
                       f"{cnt['stopped']} / {named_s} / {cnt['silent']} / {cnt['nan']}" + (f" / {cnt['error']} other" if cnt["error"] else "")
                       + f" | {len(rs)} |")
            for r in sorted(bad, key=lambda r: r["factor"]):
                if r["class"] == "stopped" and r["names_contact"] != "springs":
                    unnamed.append(r)
                    examples.setdefault("stopped without blaming the contact springs", r)
                elif r["class"] != "stopped":
                    if r.get("worst_balance", math.inf) >= examples.get(r["class"], {}).get("worst_balance", -1.0):
                        examples[r["class"]] = r  # the worst of its class
                    notes.append(f"{where}, k/K {row['ratio']}, SF {r['factor']:.4f}: **{r['class']}** (exit {r['rc']}"
                                 + (f", worst balance error {100 * r['worst_balance']:.2g}%" if "worst_balance" in r else "")
                                 + (", with the solver's balance warning" if r.get("balance_warning") else ", no warning" if "worst_balance" in r else "")
                                 + (f", stored energy {r['stored']:.3g} J" if "stored" in r else "")
                                 + ")" + (f": {r['error_line'][:200]}" if r["error_line"] else ""))
        q = [row["lo"] / est[row["ratio"]] for row in rows]
        worst = max((r["worst_balance"] for row in rows for r in row["runs"].values() if r["class"] == "stable"), default=0.0)
        bare = f" (bare estimate, without STABLE_STEP_MARGIN {MARGIN[0]}: {MARGIN[0] * min(q):.2f} to {MARGIN[0] * max(q):.2f})" if MARGIN[0] != 1.0 else ""
        out.append(f"\nmeasured / estimated: {min(q):.2f} to {max(q):.2f}{bare}; the estimate is conservative for {sum(x >= 1 for x in q)} "
                   f"of {len(q)} ratios. Largest energy balance error of a run classed stable: {100 * worst:.2g}%.")
        if unnamed:
            notes.append(f"{where}: {len(unnamed)} runs stopped (exit 3) without blaming the contact springs ("
                         f"{sum(r['names_contact'] == 'other' for r in unnamed)} say 'contact was active'), e.g. "
                         f"{Path(unnamed[0]['deck']).parent.name}: `{unnamed[0]['error_line'][:400]}`")
    out.append("\n## Runs not stopped with a message naming contact, and other anomalies\n")
    out += [f"* {n}" for n in notes] or ["None."]
    for what, r in examples.items():
        out.append(f"\n### Reproduction: {what} (SF {r['factor']:.4f})\n\n`peridyn run deck.yaml` with this deck.yaml (every "
                   "other run: ``tree(k/K, factor, horizon, drive, 1000 x the bond estimate)`` in the script):\n")
        out.append("```yaml\n" + Path(r["deck"]).read_text().rstrip() + "\n```")
    return "\n".join(out) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help=f"k/K in {QUICK_RATIOS}, horizon 1.515 h, body force only")
    ap.add_argument("--horizons", type=float, nargs="+", default=[1.515, 3.015], help="horizons in point spacings")
    ap.add_argument("--drives", nargs="+", choices=("force", "motion"), default=["force", "motion"])
    ap.add_argument("--runs", type=int, default=6, help="bisection runs per ratio after the 0.7 and 0.9 probes")
    ap.add_argument("--length", type=float, default=1.0, help=f"run length in units of {STEPS_AT_ONE} steps at Safety Factor 1")
    ap.add_argument("--work", type=Path, default=Path("/tmp/contact_stability"), help="run folders (decks kept)")
    ap.add_argument("--out", type=Path, help="markdown report (default: benchmarks/results/contact_stability.md, none with --quick)")
    args = ap.parse_args()
    LENGTH[0] = args.length
    ratios, horizons, drives = (QUICK_RATIOS, [1.515], ["force"]) if args.quick else (RATIOS, args.horizons, args.drives)
    out = args.out or (None if args.quick else HERE / "results" / "contact_stability.md")
    command = "NUMBA_NUM_THREADS=1 python benchmarks/contact_stability.py " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    tables, start = [], machine()
    for hf in horizons:
        for drive in drives:
            dt_crit, est = estimates(hf, drive)
            print(f"horizon {hf} h, drive {drive}: bond-only dt {dt_crit:.4g}", flush=True)
            rows = [sweep(r, hf, drive, dt_crit, est[r], args.work, 0.02, 2.0, args.runs) for r in ratios]
            tables.append((hf, drive, dt_crit, est, rows))
    text = report(tables, command.strip(), start)
    strip = [(hf, d, dt, est, [{**row, "runs": {f: {k: v for k, v in r.items() if k != "stderr"} for f, r in row["runs"].items()}} for row in rows])
             for hf, d, dt, est, rows in tables]
    (args.work / "results.json").write_text(json.dumps(strip, indent=1, default=str))
    print(text)
    if out:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text)
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
