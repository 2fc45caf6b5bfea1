"""Shapes discretization: lattices, volumes, symmetry, node sets, blocks, order, overlap,
parameter errors through the deck loader, the point estimate, and a run end to end."""
from __future__ import annotations

import math
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from peridyn.cli import main
from peridyn.core.errors import ExitCode, InputError
from peridyn.deck.model import load_deck
from peridyn.io.shapes import Shapes, ShapesParams, generate


def params(**shapes) -> ShapesParams:
    return ShapesParams.model_validate({"Shapes": shapes}, context={"deck": True})


def box(lo, hi, h, block="block_1"):
    return {"Shape": "Box", "Block": block, "Min": list(lo), "Max": list(hi), "Spacing": h}


def sphere(c, r, h, block="block_1"):
    return {"Shape": "Sphere", "Block": block, "Center": list(c), "Radius": r, "Spacing": h}


def cylinder(c, r, length, h, axis=None, block="block_1"):
    out = {"Shape": "Cylinder", "Block": block, "Center": list(c), "Radius": r, "Length": length, "Spacing": h}
    if axis:
        out["Axis"] = axis
    return out


def lattice_count(q: float, dims: int) -> int:
    """Cell-centred points (odd integers i, j[, k]) with i^2 + j^2 [+ k^2] <= q, by brute force."""
    m = int(math.sqrt(q)) + 2
    odd = range(-(2 * m - 1), 2 * m, 2)
    if dims == 2:
        return sum(1 for i in odd for j in odd if i * i + j * j <= q)
    return sum(1 for i in odd for j in odd for k in odd if i * i + j * j + k * k <= q)


def is_lexicographic(x: np.ndarray) -> bool:
    """x fastest, then y, then z."""
    order = np.lexsort((x[:, 0], x[:, 1], x[:, 2]))
    return bool(np.array_equal(order, np.arange(len(x))))


def assert_point_symmetric(x: np.ndarray, center, scale: float) -> None:
    """The point set maps onto itself under x -> 2c - x (to round-off)."""
    c = np.asarray(center, dtype=float)
    mirrored = 2.0 * c - x

    def by_position(a: np.ndarray) -> np.ndarray:
        return a[np.lexsort(np.round((a - c) / scale * 1e6).T)]

    assert_allclose(by_position(mirrored), by_position(x), rtol=0, atol=1e-12 * scale)


# ------------------------------------------------------------------------------------------------
# Points and volumes
# ------------------------------------------------------------------------------------------------
def test_box_cells_counts_volume_and_order():
    # lengths 1.0, 0.5, 0.26 with h 0.1: 10, 5 and round(2.6) = 3 cells
    disc = generate(params(B=box((0.0, 1.0, -0.13), (1.0, 1.5, 0.13), 0.1)))
    disc.validate()
    assert disc.num_points == 10 * 5 * 3
    assert is_lexicographic(disc.x)
    assert_allclose(disc.x[0], [0.05, 1.05, -0.13 + 0.26 / 6], rtol=1e-13)
    assert_allclose(disc.x[-1], [0.95, 1.45, 0.13 - 0.26 / 6], rtol=1e-13)
    assert_allclose(disc.volume, 0.1 * 0.1 * (0.26 / 3), rtol=1e-13)
    assert disc.volume.sum() == pytest.approx(1.0 * 0.5 * 0.26, rel=1e-12)  # exact by construction
    assert_allclose(disc.x.mean(axis=0), [0.5, 1.25, 0.0], atol=1e-14)


def test_box_rounds_half_up_and_keeps_at_least_one_cell():
    disc = generate(params(B=box((0, 0, 0), (5.0, 0.5, 1.0), 2.0)))  # 2.5 -> 3 cells, 0.25 -> 1, 0.5 -> 1
    assert disc.num_points == 3
    assert_allclose(disc.x[:, 0], [5 / 6, 2.5, 25 / 6])
    assert_allclose(disc.x[:, 1:], [[0.25, 0.5]] * 3)
    assert disc.volume.sum() == pytest.approx(2.5, rel=1e-14)


@pytest.mark.parametrize("axis", ["x", "y", "z"])
def test_cylinder_count_volume_symmetry_and_order(axis):
    c, r, length, h = (0.3, -0.2, 0.7), 1.0, 0.4, 0.05
    disc = generate(params(C=cylinder(c, r, length, h, axis=axis)))
    a = "xyz".index(axis)
    layers = round(length / h)
    assert disc.num_points == lattice_count((2 * r / h) ** 2, 2) * layers
    assert is_lexicographic(disc.x)
    # the volume is rescaled to the exact one; the lattice's own volume is close to it
    exact = math.pi * r * r * length
    assert disc.volume.sum() == pytest.approx(exact, rel=1e-12)
    assert disc.num_points * h * h * (length / layers) == pytest.approx(exact, rel=0.01)
    assert_allclose(disc.x.mean(axis=0), c, rtol=0, atol=1e-13)
    assert_point_symmetric(disc.x, c, h)
    # inside the body; the layers span the length
    radial = np.delete(disc.x - c, a, axis=1)
    assert np.all(np.hypot(radial[:, 0], radial[:, 1]) <= r)
    along = disc.x[:, a] - c[a]
    assert along.min() == pytest.approx(-length / 2 + h / 2) and along.max() == pytest.approx(length / 2 - h / 2)
    # cell-centred cross-section: no point on the axis, in-plane coordinates at (k + 1/2) h
    in_plane = radial / h - 0.5
    assert_allclose(in_plane, np.round(in_plane), atol=1e-9)


def test_sphere_count_volume_and_symmetry():
    c, r, h = (0.0, 0.0, 0.0076), 0.005, 0.0005
    disc = generate(params(Ball=sphere(c, r, h)))
    assert disc.num_points == lattice_count((2 * r / h) ** 2, 3)
    assert is_lexicographic(disc.x)
    exact = 4.0 / 3.0 * math.pi * r**3
    assert disc.volume.sum() == pytest.approx(exact, rel=1e-12)
    assert disc.num_points * h**3 == pytest.approx(exact, rel=0.02)  # the lattice itself, R/h = 10
    assert_allclose(disc.x.mean(axis=0), c, rtol=0, atol=1e-15)
    assert_point_symmetric(disc.x, c, h)
    assert np.all(np.linalg.norm(disc.x - c, axis=1) <= r)
    assert disc.min_element_radius == pytest.approx((3 * disc.volume.min() / (4 * math.pi)) ** (1 / 3), rel=1e-14)


def test_smallest_sphere_and_cylinder_have_a_point_per_octant_or_quadrant():
    assert generate(params(S=sphere((1, 2, 3), 0.9, 1.0))).num_points == 8  # sqrt(3)/2 <= 0.9
    assert generate(params(C=cylinder((1, 2, 3), 0.75, 1.0, 1.0))).num_points == 4  # sqrt(2)/2 <= 0.75


# ------------------------------------------------------------------------------------------------
# Blocks, node sets, order
# ------------------------------------------------------------------------------------------------
def test_blocks_node_sets_and_deck_order():
    disc = generate(
        params(
            Disk=cylinder((0, 0, 0.00125), 0.004, 0.0025, 0.0005, block="block_3"),
            Ball=sphere((0, 0, 0.0076), 0.002, 0.0005, block="block_1"),
            Base=box((-0.004, -0.004, -0.002), (0.004, 0.004, -0.001), 0.0005, block="block_3"),
        )
    )
    disc.validate()
    assert list(disc.node_sets) == ["Disk", "Ball", "Base"]
    sizes = [disc.node_sets[n].size for n in ("Disk", "Ball", "Base")]
    start = 0
    for name, size in zip(("Disk", "Ball", "Base"), sizes):
        members = disc.node_sets[name]
        assert members.dtype == np.int64
        assert_array_equal(members, np.arange(start, start + size))
        start += size
    assert start == disc.num_points
    assert_array_equal(disc.gid, np.arange(disc.num_points))
    assert disc.block_id.dtype == np.int64
    assert_array_equal(disc.block_id, np.repeat([3, 1, 3], sizes))
    assert disc.block_names == {1: "block_1", 3: "block_3"}
    assert disc.neighbor_rule is None and disc.source == "Shapes generator"
    assert disc.x[disc.node_sets["Ball"]].min(axis=0)[2] > 0.0076 - 0.002


# ------------------------------------------------------------------------------------------------
# Overlap
# ------------------------------------------------------------------------------------------------
def test_overlapping_shapes_are_an_input_error():
    p = params(A=box((0, 0, 0), (1, 1, 1), 0.1), B=sphere((1.0, 0.5, 0.5), 0.3, 0.1, block="block_2"))
    with pytest.raises(InputError) as info:
        generate(p)
    err = info.value
    assert err.path == ("Discretization", "Shapes", "B") and "overlaps shape 'A'" in err.message and err.fix


def test_touching_shapes_and_different_spacings_are_fine():
    disc = generate(
        params(
            A=box((0, 0, 0), (1, 1, 1), 0.1),
            B=box((1, 0, 0), (2, 1, 1), 0.05, block="block_2"),  # shares the face x = 1
            C=sphere((0.5, 0.5, 1.3), 0.3, 0.1, block="block_2"),  # rests on the top face
        )
    )
    assert disc.num_points == 1000 + 8000 + disc.node_sets["C"].size


# ------------------------------------------------------------------------------------------------
# Parameter errors, through the deck loader
# ------------------------------------------------------------------------------------------------
DECK = textwrap.dedent(
    """
    Discretization:
      Type: "Shapes"
      Shapes:
        Left:
          Shape: "Box"
          Block: "block_1"
          Min: [0.0, 0.0, 0.0]
          Max: [0.004, 0.002, 0.002]
          Spacing: 0.001
        Right:
          Shape: "Box"
          Block: "block_2"
          Min: [0.004, 0.0, 0.0]
          Max: [0.008, 0.002, 0.002]
          Spacing: 0.001
    Materials:
      Steel:
        Material Model: "Elastic"
        Density: 7800.0
        Bulk Modulus: 130.0e9
        Shear Modulus: 78.0e9
    Blocks:
      All:
        Block Names: "block_1 block_2"
        Material: "Steel"
        Horizon: 0.0031
    Boundary Conditions:
      Kick:
        Type: "Initial Velocity"
        Node Set: "Right"
        Coordinate: "x"
        Value: "1.0"
    Solver:
      Initial Time: 0.0
      Final Time: 1.0e-6
      Verlet:
        Safety Factor: 0.5
    Output:
      Output Filename: "run"
      Output Frequency: 1
      Output Variables:
        Displacement: true
        Velocity: true
    """
)
LEFT_BOX = 'Shape: "Box"\n      Block: "block_1"\n      Min: [0.0, 0.0, 0.0]\n      Max: [0.004, 0.002, 0.002]\n'
LEFT_SPACING = "Spacing: 0.001\n    Right:"


def as_left(lines: str) -> tuple[str, str]:
    """Replace the Left box by the given keys (indented like it)."""
    return LEFT_BOX, "".join(f"      {line}\n" for line in lines.strip().splitlines())[6:]


def write_deck(folder: Path, text: str = DECK) -> Path:
    path = folder / "deck.yaml"
    path.write_text(text)
    return path


def test_the_deck_validates(tmp_path):
    deck = load_deck(write_deck(tmp_path))
    assert deck.discretization.type == "Shapes"
    assert list(deck.discretization.params.shapes) == ["Left", "Right"]


@pytest.mark.parametrize(
    "old, new, where, words",
    [
        (LEFT_SPACING, "Spacing: 0.0\n    Right:", "Left > Spacing", "greater than 0"),
        (LEFT_SPACING, "Spacing: -1.0\n    Right:", "Left > Spacing", "greater than 0"),
        (LEFT_SPACING, "Spacing: [1]\n    Right:", "Left > Spacing", "must be a number"),
        ("Max: [0.004, 0.002, 0.002]", "Max: [0.004, -0.002, 0.002]", "Left > Max", "'Max' must be larger than 'Min'"),
        ("Max: [0.004, 0.002, 0.002]", "Max: [0.004, 0.002]", "Left > Max", "at least 3 items"),
        ('Block: "block_1"', 'Block: "blk1"', "Left > Block", "block_<positive integer>"),
        ('Block: "block_1"', 'Block: "block_0"', "Left > Block", "block_<positive integer>"),
        ('Block: "block_1"', 'Block: "block_01"', "Left > Block", "no leading zeros"),
        ('Shape: "Box"', 'Shape: "Cone"', "Left > Shape", "must be one of 'Box', 'Cylinder' or 'Sphere'"),
        (LEFT_SPACING, "Spacng: 0.001\n    Right:", "Left", "unknown key 'Spacng'; did you mean 'Spacing'?"),
        (LEFT_SPACING, "Spacing: 0.001\n      Radius: 0.1\n    Right:", "Left", "'Radius' does not apply to a Box"),
        (LEFT_SPACING, "spacing: 0.001\n    Right:", "Left", "'spacing' is not a deck key: write 'Spacing'"),
        (LEFT_SPACING, "Spacing: 0.001\n      spacing: 0.001\n    Right:", "Left", "unknown key 'spacing'; did you mean 'Spacing'?"),
        (*as_left('Shape: "Sphere"\nBlock: "block_1"\nCenter: [0, 0, -1]'), "Left", "a Sphere needs 'Radius'"),
        (*as_left('Shape: "Sphere"\nBlock: "block_1"\nCenter: [0, 0, -1]\nRadius: 0.0'), "Left > Radius", "greater than 0"),
        (*as_left('Shape: "Sphere"\nBlock: "block_1"\nCenter: [0, 0, -1]\nRadius: 0.0004'), "Left", "reduce Spacing"),
        (*as_left('Shape: "Cylinder"\nBlock: "block_1"\nCenter: [0, 0, -1]\nRadius: 0.01\nLength: -0.1'), "Left > Length", "greater than 0"),
        (*as_left('Shape: "Cylinder"\nBlock: "block_1"\nCenter: [0, 0, -1]\nRadius: 0.0007\nLength: 0.1'), "Left", "has no lattice point"),
        (*as_left('Shape: "Cylinder"\nBlock: "block_1"\nCenter: [0, 0, -1]\nRadius: 0.01\nLength: 0.1\nAxis: "w"'), "Left > Axis", "one of 'x', 'y' or 'z'"),
        (*as_left('Shape: "Sphere"\nBlock: "block_1"\nCenter: [0, 0, -1]\nRadius: 0.01\nLength: 0.1'), "Left", "'Length' does not apply to a Sphere"),
        (*as_left('Shape: "Sphere"\nBlock: "block_1"\nCenter: [1.0e9, 0, 0]\nRadius: 0.01'), "Left", "too small for coordinates"),
        ("    Right:", "    LEFT:", "", "name the same node set 'LEFT'"),
        ("    Right:", "    Right Node Set:", "", "contains 'Node Set'"),
        ("  Shapes:\n    Left:", "  Shapes: {}\n  Unused:\n    Left:", "", "give at least one shape"),
    ],
)
def test_parameter_errors_name_the_key_and_a_fix(tmp_path, old, new, where, words):
    assert old in DECK
    with pytest.raises(InputError) as info:
        load_deck(write_deck(tmp_path, DECK.replace(old, new, 1)))
    lines = info.value.one_line().splitlines()
    key = "Discretization > Shapes" + (f" > {where}" if where else "")
    line = next((line for line in lines if words in line), lines[0])
    assert f"{key}:" in line and words in line, line
    assert "deck.yaml" in line


def test_infinite_values_are_refused():
    with pytest.raises(ValueError, match="must be finite"):
        params(B=box((0, 0, 0), (1, 1, 1), math.inf))
    with pytest.raises(ValueError, match="must be finite"):
        params(S=sphere((0, 0, math.nan), 1.0, 0.1))


# ------------------------------------------------------------------------------------------------
# Size: the estimate, and speed
# ------------------------------------------------------------------------------------------------
def test_estimate_is_close_and_never_below_for_round_shapes():
    p = params(
        A=box((0, 0, 0), (1, 0.5, 0.26), 0.1),
        S=sphere((3, 0, 0), 1.0, 0.05, block="block_2"),
        C=cylinder((-3, 0, 0), 1.0, 0.4, 0.05, axis="y", block="block_2"),
    )
    estimate = Shapes(p, deck_dir=Path(".")).estimate_points()
    actual = generate(p).num_points
    assert isinstance(estimate, int) and actual <= estimate <= 1.25 * actual


def test_estimate_of_an_absurd_spacing_is_fast_and_large():
    p = params(B=box((0, 0, 0), (1, 1, 1), 1e-9), S=sphere((5, 5, 5), 1.0, 1e-9, block="block_2"))
    t0 = time.perf_counter()
    estimate = Shapes(p, deck_dir=Path(".")).estimate_points()
    assert time.perf_counter() - t0 < 0.1
    assert estimate >= 1e27 and math.isfinite(float(estimate))


def test_an_absurd_spacing_is_refused_before_any_point_is_made(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("PERIDYN_NO_LIMITS", raising=False)
    deck = write_deck(tmp_path, DECK.replace(LEFT_SPACING, "Spacing: 1.0e-9\n    Right:"))
    t0 = time.perf_counter()
    assert main(["run", str(deck), "--output-dir", str(tmp_path), "-q", "--no-progress"]) == ExitCode.INPUT_ERROR
    assert time.perf_counter() - t0 < 10.0
    assert "Discretization" in capsys.readouterr().err
    assert not (tmp_path / "run.e").exists()


def test_a_million_points_are_vectorized():
    p = params(B=box((0, 0, 0), (1, 1, 1), 0.01))
    t0 = time.perf_counter()
    disc = generate(p)
    assert disc.num_points == 10**6
    assert time.perf_counter() - t0 < 3.0  # about 0.2 s; a loop over points would take far longer


# ------------------------------------------------------------------------------------------------
# End to end
# ------------------------------------------------------------------------------------------------
def run(deck: Path) -> int:
    return main(["run", str(deck), "--output-dir", str(deck.parent), "-q", "--no-progress"])


def test_two_boxes_run_end_to_end(tmp_path):
    from peridyn.io.exodus_reader import read_results

    text = DECK.replace('  Type: "Shapes"\n', '  Type: "Shapes"\n  Omit Bonds Between Blocks: "All"\n')
    assert run(write_deck(tmp_path, text)) == ExitCode.OK
    r = read_results(tmp_path / "run.e")
    assert r["coords"].shape == (32, 3) and len(r["times"]) > 1
    assert [(b["name"], len(b["nodes"])) for b in r["blocks"]] == [("block_1", 16), ("block_2", 16)]
    assert set(r["node_sets"]) >= {"LEFT", "RIGHT"}
    right = r["node_sets"]["RIGHT"]
    assert_allclose(r["coords"][right, 0].min(), 0.0045)
    # the blocks are not bonded: the kicked box translates, the other stays at rest
    velocity = r["nodal"]["VelocityX"][-1]
    left = np.setdiff1d(np.arange(32), right)
    assert_allclose(velocity[right], 1.0, rtol=0, atol=1e-9)
    assert_array_equal(velocity[left], 0.0)


def test_overlapping_shapes_stop_the_run_with_one_line(tmp_path, capsys):
    text = DECK.replace("Min: [0.004, 0.0, 0.0]", "Min: [0.002, 0.0, 0.0]")
    assert run(write_deck(tmp_path, text)) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Discretization > Shapes > Right" in err[0] and "overlaps shape 'Left'" in err[0]
