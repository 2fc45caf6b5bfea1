"""A parameter study with peridyn.Study: the quickstart plate (quickstart.yaml, ends pulled at
5 m/s) for several critical stretches. Each run gets its own folder under the study folder; the
table results.csv lists, per critical stretch, the largest damage and the fraction of points
more than half broken. Run it again after stopping it (Ctrl-C): finished runs are skipped.

    python examples/api_study.py                     # 4 critical stretches, 60 x 30 x 3 points
    python examples/api_study.py --small --processes 2

A tougher plate (larger critical stretch) is damaged less: its largest damage falls as the
critical stretch grows, and at 0.02, above the strain the pull reaches in the run (about
10 m/s * 6e-5 s / 60 mm = 1e-2 on average), no bond breaks.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import peridyn

HERE = Path(__file__).resolve().parent
STRETCH = "Damage Models/Brittle/Critical Stretch"


def damage_summary(model: "peridyn.Model") -> dict:
    """What the table keeps of a finished run (a module-level function: it travels to the
    worker processes)."""
    damage = model["Damage"]
    return {"max_damage": float(damage.max()), "broken_fraction": float((damage > 0.5).mean()), "steps": model.steps_taken}


def study(folder: Path, stretches: list[float], small: bool = False, processes: int = 1) -> list[dict]:
    deck = peridyn.deck_tree(HERE / "quickstart.yaml")
    if small:  # 30 x 15 x 2 points of 2 mm; the grips (half spaces of the deck) are again two columns each
        grid = deck["Discretization"]["TensorProduct3DMeshGenerator"]
        grid.update({"Number Points X": 30, "Number Points Y": 15, "Number Points Z": 2, "Z Length": 0.004})
        deck["Blocks"]["Plate"]["Horizon"] = 0.00603
    runs = peridyn.Study(deck, [{STRETCH: s} for s in stretches], folder, extract=damage_summary, directory=HERE)
    rows = runs.run(processes=processes)
    for row in rows:
        print(f"{row['run']}: critical stretch {row[STRETCH]:.4g}: {row['status']}, "
              f"max damage {row.get('max_damage', float('nan')):.3f}, broken {100 * row.get('broken_fraction', float('nan')):.1f} %")
    print(f"table: {folder / 'results.csv'}")
    return rows


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true", help="30 x 15 x 2 points")
    parser.add_argument("--processes", type=int, default=1, help="runs at once (default 1)")
    parser.add_argument("--out", default="api_study", help="the study folder (default: ./api_study)")
    args = parser.parse_args()
    study(Path(args.out), [0.0015, 0.003, 0.006, 0.02], small=args.small, processes=args.processes)
