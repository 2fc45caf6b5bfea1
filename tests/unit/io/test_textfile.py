"""Text File discretization (§2.4): format, errors, and points against Peridigm's gold files."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_array_equal
from pydantic import ValidationError

from peridyn.core.errors import InputError
from peridyn.io.textfile import TextFile, TextFileParams, min_element_radius, read_text_mesh

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
CASES = SHARED / "conformance" / "cases"
needs_cases = pytest.mark.skipif(not CASES.is_dir(), reason="conformance cases not available")


def reader(name: str, deck_dir: Path) -> TextFile:
    return TextFile(TextFileParams.model_validate({"Input Mesh File": name}), deck_dir=deck_dir)


def gold(path: Path):
    netCDF4 = pytest.importorskip("netCDF4")
    ds = netCDF4.Dataset(path)
    ds.set_auto_mask(False)
    return ds


def test_reads_points_blocks_and_skips_comments(tmp_path):
    (tmp_path / "mesh.txt").write_text(
        "# x y z block volume\n"
        "\n"
        "  1.0 2.0 3.0 2 0.5\n"
        "/ comment\n"
        "* comment\n"
        "\t-1e-1  0 .5  7   2.5e-1  \n"
        "4 5 6 2.9 1\n"  # block id truncated like static_cast<int>
    )
    disc = reader("mesh.txt", tmp_path).read()
    disc.validate()
    assert_array_equal(disc.x, [[1.0, 2.0, 3.0], [-0.1, 0.0, 0.5], [4.0, 5.0, 6.0]])
    assert_array_equal(disc.volume, [0.5, 0.25, 1.0])
    assert_array_equal(disc.block_id, [2, 7, 2])
    assert disc.block_id.dtype == np.int64
    assert_array_equal(disc.gid, [0, 1, 2])
    assert disc.block_names == {2: "block_2", 7: "block_7"}
    assert disc.node_sets == {}
    assert disc.neighbor_rule is None
    # (3 V / 4 pi)^(1/3) of the smallest cell
    assert disc.min_element_radius == math.pow(0.238732414637843 * 0.25, 0.33333333333333333)
    assert disc.min_element_radius == pytest.approx((3 * 0.25 / (4 * math.pi)) ** (1 / 3), rel=1e-14)


def test_min_element_radius_is_the_minimum_over_points():
    volume = np.array([8.0, 1.0, 27.0])
    expected = min(math.pow(0.238732414637843 * v, 0.33333333333333333) for v in volume)
    assert min_element_radius(volume) == expected
    assert min_element_radius(np.zeros(0)) == 1.0e50


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("1 2 3 1", "expected 5 numbers"),
        ("1 2 3 1 1 1", "found 6"),
        ("1 2 3 one 1", "'one' is not a number"),
        ("1 2 3 1 nan", "'nan' is not a number"),
        ("1 2 3 1 0", "not positive"),
        ("1 2 3 1 -2", "not positive"),
    ],
)
def test_bad_line_names_file_and_line(tmp_path, line, message):
    path = tmp_path / "mesh.txt"
    path.write_text("# header\n0 0 0 1 1\n" + line + "\n")
    with pytest.raises(InputError, match=message) as info:
        read_text_mesh(path)
    assert info.value.line == 3
    assert f"{path}:3" in str(info.value)


@needs_cases
def test_parent_relative_mesh_name_as_in_interface_aware_decks(tmp_path):
    # the deck says "../meshOneBlock.csv"; the runner copies the case's files into one folder
    source = CASES / "InterfaceAwareDamageModelOneBlock" / "meshOneBlock.csv"
    (tmp_path / "meshOneBlock.csv").write_bytes(source.read_bytes())
    disc = reader("../meshOneBlock.csv", tmp_path).read()
    assert disc.num_points == 16
    assert disc.block_names == {1: "block_1"}


def test_empty_file_is_an_error(tmp_path):
    (tmp_path / "mesh.txt").write_text("# only a comment\n\n")
    with pytest.raises(InputError, match="no points"):
        reader("mesh.txt", tmp_path).read()


def test_missing_file_is_an_error(tmp_path):
    with pytest.raises(InputError, match="not found") as info:
        reader("nope.txt", tmp_path).read()
    assert str(tmp_path / "nope.txt") in str(info.value)
    assert "Input Mesh File" in str(info.value)


def test_params_require_the_file_and_forbid_unknown_keys():
    with pytest.raises(ValidationError):
        TextFileParams.model_validate({})
    with pytest.raises(ValidationError):
        TextFileParams.model_validate({"Input Mesh File": "a.txt", "Bogus": 1})
    assert TextFile.name == "Text File"
    assert TextFile.supports_bond_filters


@needs_cases
@pytest.mark.parametrize(
    ("case", "mesh", "output"),
    [
        ("Compression_QS_3x2x2_TextFile", "Compression_QS_3x2x2_TextFile.txt", "Compression_QS_3x2x2_TextFile_gold.e"),
        ("MultipleHorizons", "MultipleHorizons.txt", "MultipleHorizons_gold.e"),
    ],
)
def test_points_match_peridigm_gold(case, mesh, output):
    disc = reader(mesh, CASES / case).read()
    disc.validate()
    ds = gold(CASES / case / output)
    x_gold = np.stack([ds["coordx"][:], ds["coordy"][:], ds["coordz"][:]], axis=1)
    assert_array_equal(disc.x, x_gold)
    assert_array_equal(disc.gid, ds["node_num_map"][:] - 1)
    # block membership: the gold's element blocks list the points of each block
    block_ids = ds["eb_prop1"][:]
    assert sorted(disc.block_names) == sorted(int(b) for b in block_ids)
    for index, block in enumerate(block_ids):
        points = ds[f"connect{index + 1}"][:].ravel() - 1
        assert np.all(disc.block_id[points] == block)
    assert sum(len(ds[f"connect{i + 1}"][:]) for i in range(len(block_ids))) == disc.num_points
    ds.close()
