"""The quickstart plate (quickstart.yaml) driven from Python: the deck is read as a dict, its
file-based end conditions are replaced by Python callables, the run is stepped to mid-time and
then finished, a compute records the damage as it grows, and the result file is read back.

    python examples/api_quickstart.py            # the full 60 x 30 x 3 plate (52 s measured on a 2-core machine shared with other jobs)
    python examples/api_quickstart.py --small    # 30 x 15 x 2 points (a few seconds)

Each end is gripped by its three outer columns of points (two with --small), chosen with
``model.select`` and a region, as the deck's own node sets are. The plate cracks across the
middle, where the pull waves from the two ends meet: at full size the cracked points
(damage > 0.3) lie between x = 28.5 and 31.5 mm, symmetric about the middle (30 mm).
"""
from __future__ import annotations

import argparse
from pathlib import Path

import peridyn

HERE = Path(__file__).resolve().parent


def main(out: Path, small: bool = False) -> dict:
    deck = peridyn.deck_tree(HERE / "quickstart.yaml")  # the deck as a dict: change anything
    deck.pop("Boundary Conditions")  # the ends are pulled from Python below
    if small:
        grid = deck["Discretization"]["TensorProduct3DMeshGenerator"]
        grid.update({"Number Points X": 30, "Number Points Y": 15, "Number Points Z": 2, "Z Length": 0.004})
        deck["Blocks"]["Plate"]["Horizon"] = 0.00603  # 3 spacings of 2 mm
    model = peridyn.Model(deck, output_dir=out)
    # the grips: the points within 3 mm of each end, selected as the deck's regions select them
    # (faces inclusive within 1e-4 spacings, so round-off in the coordinates cannot make the two
    # grips differ; `model.x[:, 0] > 0.0565` would also catch a column stored at 0.05650000000000004)
    left = model.select({"Half Space": {"Point": [0.003, 0, 0], "Normal": [-1, 0, 0]}})  # (n,) bool, mesh order
    right = model.select({"Half Space": {"Point": [0.057, 0, 0], "Normal": [1, 0, 0]}})
    model.add_condition("Prescribed Displacement", left, lambda t, x: -5.0 * t)  # u_x = -5 m/s * t
    model.add_condition("Prescribed Displacement", right, lambda t, x: 5.0 * t)
    model.add_compute("max_damage", lambda m: float(m["Damage"].max()), every=10)

    model.run(until=3.0e-5)  # half way through the deck's 6e-5 s
    print(f"t = {model.time:.3g} s after {model.steps_taken} steps: largest damage {model['Damage'].max():.3f}")
    model.run()  # to the deck's Final Time; the output file is complete
    damage = model["Damage"]
    x = model.x[:, 0]
    crack = x[(damage > 0.3) & ~left & ~right]
    print(f"t = {model.time:.3g} s: largest damage {damage.max():.3f}, "
          f"cracked points at x = {crack.min() * 1e3:.1f} to {crack.max() * 1e3:.1f} mm" if crack.size else "no crack")
    times, growth = model.history("max_damage")
    result = peridyn.read(out / "quickstart.e")
    print(f"{result.path.name}: {result.num_frames} frames, fields {', '.join(result.fields)}")
    return {"damage": damage, "x": x, "history": (times, growth), "result": result, "model": model, "grips": (left, right)}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true", help="30 x 15 x 2 points")
    parser.add_argument("--out", default=".", help="folder for quickstart.e (default: here)")
    args = parser.parse_args()
    main(Path(args.out), small=args.small)
