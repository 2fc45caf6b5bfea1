"""Node-set values of the Boundary Conditions list: inline lists and node-set files (§1.4)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from peridyn.core.errors import InputError
from peridyn.io.nodesets import find_input_file, is_node_set_file_name, parse_node_set_value, read_node_set_file

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
CASES = SHARED / "conformance" / "cases"
PATH = ("Boundary Conditions", "Min X Node Set")


def parse(value, deck_dir: Path = Path(".")):
    return parse_node_set_value(value, deck_dir=deck_dir, path=PATH, deck_file="deck.yaml")


@pytest.mark.parametrize(
    ("value", "is_file"),
    [
        ("nodeset_1.txt", True),
        ("1_left.txt", True),  # Peridigm's strtol would read a prefix 1; we do not
        ("../nodelist_1.csv", True),
        ("  nodes.txt  ", True),
        ("1", False),
        ("+3", False),
        ("-2", False),
        ("0", False),
        ("-0", False),
        ("1 2", False),
        ("1\t2", False),
        ("a b", False),
        ("", False),
        ("   ", False),
    ],
)
def test_file_name_or_inline_list(value, is_file):
    assert is_node_set_file_name(value) is is_file


def test_inline_list_is_one_based_in_order_with_duplicates():
    ids = parse("7 1 4\t10 4")
    assert ids.dtype == np.int64
    assert_array_equal(ids, [7, 1, 4, 10, 4])


def test_single_number_is_an_inline_list():
    assert_array_equal(parse("3"), [3])
    assert_array_equal(parse("+3"), [3])


def test_trailing_whitespace_does_not_duplicate_the_last_id():
    # Peridigm gives [1, 1] for "1 " (a defect we do not copy)
    assert_array_equal(parse("1 "), [1])
    assert_array_equal(parse(" 2 4 \t"), [2, 4])


def test_blank_value_is_an_empty_set():
    assert parse("").shape == (0,)
    assert parse("  ").shape == (0,)


@pytest.mark.parametrize("value", ["0", "-0", "1 0", "2 -5"])
def test_zero_or_negative_inline_id_is_an_error(value):
    with pytest.raises(InputError) as info:
        parse(value)
    err = info.value
    assert err.file == "deck.yaml"
    assert err.path == PATH
    assert "1-based" in str(err)


@pytest.mark.parametrize("value", ["1 x", "1 2.0", "3 1e2"])
def test_non_integer_inline_token_is_an_error(value):
    with pytest.raises(InputError, match="is not a point number") as info:
        parse(value)
    assert "Min X Node Set" in str(info.value)


def test_value_must_be_a_string():
    with pytest.raises(InputError, match="must be a string"):
        parse(5)


def test_file_with_comments_blank_lines_and_several_ids_per_line(tmp_path):
    (tmp_path / "set.txt").write_text(
        "# a comment\n"
        "\n"
        "   \n"
        "  3\n"
        "/ another comment 99\n"
        "* and another 98\n"
        "5 1\t2   \n"
        "   # indented comment 97\n"
        "3\n"
    )
    ids = parse("set.txt", deck_dir=tmp_path)
    assert ids.dtype == np.int64
    assert_array_equal(ids, [3, 5, 1, 2, 3])
    assert_array_equal(read_node_set_file(tmp_path / "set.txt"), [3, 5, 1, 2, 3])


def test_file_name_relative_to_deck_dir_or_absolute(tmp_path):
    sub = tmp_path / "sets"
    sub.mkdir()
    (sub / "left.txt").write_text("4\n")
    assert_array_equal(parse("sets/left.txt", deck_dir=tmp_path), [4])
    assert_array_equal(parse(str(sub / "left.txt"), deck_dir=Path("/nonexistent")), [4])


def test_parent_relative_name_falls_back_to_the_deck_folder(tmp_path, caplog):
    # Peridigm's test decks name "../nodelist_1.csv"; the conformance runner copies files flat
    deck_dir = tmp_path / "scratch"
    deck_dir.mkdir()
    (deck_dir / "nodelist_1.csv").write_text("5\n6\n")
    with caplog.at_level("WARNING"):
        assert_array_equal(parse("../nodelist_1.csv", deck_dir=deck_dir), [5, 6])
    assert "nodelist_1.csv" in caplog.text
    # the file where the name says wins when it exists
    (tmp_path / "nodelist_1.csv").write_text("7\n")
    assert_array_equal(parse("../nodelist_1.csv", deck_dir=deck_dir), [7])
    assert find_input_file("../absent.txt", deck_dir) == deck_dir / "../absent.txt"


def test_non_integer_in_file_names_file_and_line(tmp_path):
    (tmp_path / "bad.txt").write_text("1 2\n# fine\n3 four 5\n")
    with pytest.raises(InputError) as info:
        parse("bad.txt", deck_dir=tmp_path)
    err = info.value
    assert err.line == 3
    assert err.file == str(tmp_path / "bad.txt")
    assert f"{tmp_path / 'bad.txt'}:3" in str(err)
    assert "'four'" in str(err)
    assert err.path == PATH


def test_zero_in_file_is_an_error_with_line(tmp_path):
    (tmp_path / "zero.txt").write_text("1\n\n0\n")
    with pytest.raises(InputError, match="1-based") as info:
        parse("zero.txt", deck_dir=tmp_path)
    assert info.value.line == 3


def test_plain_number_file_keeps_order_duplicates_and_line_layout(tmp_path):
    ids = np.random.default_rng(3).integers(1, 10**6, size=5000)
    lines = [" ".join(str(v) for v in ids[k : k + 7]) for k in range(0, ids.size, 7)]
    (tmp_path / "plain.txt").write_text("\n".join(lines) + "\n\n  \t\n" + str(ids[0]) + "\n")
    assert_array_equal(parse("plain.txt", deck_dir=tmp_path), np.concatenate([ids, ids[:1]]))


def test_number_too_large_in_file_is_an_error_with_line(tmp_path):
    (tmp_path / "huge.txt").write_text("1\n2\n99999999999999999999999\n")
    with pytest.raises(InputError, match="too large") as info:
        parse("huge.txt", deck_dir=tmp_path)
    assert info.value.line == 3


def test_missing_file_names_deck_path_and_file_looked_for(tmp_path):
    with pytest.raises(InputError) as info:
        parse("nodeset_9.txt", deck_dir=tmp_path)
    text = str(info.value)
    assert "Boundary Conditions > Min X Node Set" in text
    assert "node-set file 'nodeset_9.txt' not found" in text and f"looked in {str(tmp_path)!r}" in text
    assert info.value.file == "deck.yaml"


def test_read_node_set_file_missing():
    with pytest.raises(InputError, match="not found"):
        read_node_set_file("/nonexistent/set.txt")


@pytest.mark.skipif(not CASES.is_dir(), reason="conformance cases not available")
def test_conformance_deck_node_sets():
    case = CASES / "Compression_QS_3x2x2_TextFile"
    assert_array_equal(parse("nodeset_1.txt", deck_dir=case), [1, 2, 3, 4])
    assert_array_equal(parse("nodeset_2.txt", deck_dir=case), [9, 10, 11, 12])
    assert_array_equal(parse("2 4", deck_dir=case), [2, 4])
