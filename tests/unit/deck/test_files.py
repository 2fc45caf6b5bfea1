"""Tests of peridyn.deck (source, readers, files): Teuchos typing, both formats, line numbers, dump/convert."""
from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from peridyn.core.errors import InputError
from peridyn.deck.source import INT_MAX, INT_MIN, DeckSource, infer_scalar
from peridyn.deck.files import convert, dump_yaml, load_deck_file
from peridyn.deck.xml_reader import parse_xml_text
from peridyn.deck.yaml_reader import parse_yaml_text

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
CASES = SHARED / "conformance" / "cases"
YAML_DECKS = sorted(CASES.glob("*/*.yaml")) if CASES.is_dir() else []
XML_DECKS = sorted(CASES.glob("*/*.xml")) if CASES.is_dir() else []
needs_shared = pytest.mark.skipif(not CASES.is_dir(), reason="../shared conformance decks absent")


def typed(x: Any) -> Any:
    """A structure equal for two trees only if values, Python types and key order all match."""
    if isinstance(x, dict):
        return [(k, typed(v)) for k, v in x.items()]
    if isinstance(x, list):
        return ("list", [typed(v) for v in x])
    if isinstance(x, float):
        return ("float", repr(x))
    return (type(x).__name__, x)


def one(value_text: str) -> Any:
    """The value of ``K`` in a one-entry YAML deck."""
    return parse_yaml_text(f"Peridigm:\n  K: {value_text}\n").tree["K"]


# --------------------------------------------------------------------------------------------
# YAML typing
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "text, expected",
    [
        ("200e9", 200e9),
        ("1e-3", 1e-3),
        ("160.0e10", 160.0e10),
        ("1", 1),
        ("-7", -7),
        ("+7", 7),
        ("007", 7),
        ("1.0", 1.0),
        (".5", 0.5),
        ("5.", 5.0),
        ("-2.5E+3", -2500.0),
        ("3000000000", 3e9),  # does not fit a 32-bit int: Teuchos reads a double
        ("true", True),
        ("TRUE", True),
        ("False", False),
        ("yes", True),  # Teuchos (and yaml-cpp before it) also read yes/no as bools
        ("no", False),
        ("1 2 3", "1 2 3"),
        ('"1"', "1"),
        ("'1.0'", "1.0"),
        ('"true"', "true"),
        ("1e", "1e"),
        ("0x10", "0x10"),
        ("1_000", "1_000"),
        ("null", "null"),
        ("~", "~"),
        (".inf", ".inf"),
        ("y*0.01*t", "y*0.01*t"),
        ("Prescribed Displacement", "Prescribed Displacement"),
        ("{}", {}),
        ('""', ""),
        ("", {}),  # `Key:` with nothing after it is an empty parameter list
    ],
)
def test_yaml_scalar_typing(text: str, expected: Any) -> None:
    assert typed(one(text)) == typed(expected)


@pytest.mark.parametrize("text", ["inf", "-inf", "+Infinity", "nan", "NaN"])
def test_yaml_inf_and_nan_are_floats(text: str) -> None:
    value = one(text)
    assert isinstance(value, float) and (math.isinf(value) or math.isnan(value))


def test_infer_scalar_matches_loader() -> None:
    for text in ["1", "1.5", "abc", "True", "1 2"]:
        assert typed(infer_scalar(text)) == typed(one(text))


@pytest.mark.parametrize(
    "text, expected",
    [
        ("[1, 2, 3]", [1, 2, 3]),
        ("[1, 2.5]", [1.0, 2.5]),  # a Teuchos array has one type: the lowest of its items
        ("[a, 1]", ["a", "1"]),
        ('["1", 2]', ["1", "2"]),
        ("[1.50, x]", ["1.50", "x"]),
        ("[]", []),
        ("\n    - 1\n    - 2e3", [1.0, 2000.0]),
        ("!!str 5", "5"),
        ("!!double 1", 1.0),
        ("!!int '3'", 3),
        ("!!double [1, 2]", [1.0, 2.0]),
    ],
)
def test_yaml_sequences_and_tags(text: str, expected: Any) -> None:
    assert typed(one(text)) == typed(expected)


@pytest.mark.parametrize(
    "text, words",
    [
        ("[true, false]", "true/false"),
        ("[[1, 2], [3, 4]]", "nested"),
        ("[{a: 1}]", "sequence item"),
        ("!!int x", "not an int"),
        ("!!foo 1", "!!foo"),
    ],
)
def test_yaml_value_errors(text: str, words: str) -> None:
    with pytest.raises(InputError, match=words) as info:
        parse_yaml_text(f"Peridigm:\n  K: {text}\n", "d.yaml")
    assert info.value.file == "d.yaml" and info.value.line == 2


# --------------------------------------------------------------------------------------------
# YAML structure
# --------------------------------------------------------------------------------------------

BODY = """\
Discretization:
  Type: "PdQuickGrid"
Materials:
  My Elastic:
    Material Model: "Elastic"
    Bulk Modulus: 130.0e9
Solver:
  Verlet:
    Fixed dt: 1e-5
"""


def indent(text: str) -> str:
    return "".join("  " + line + "\n" for line in text.splitlines())


def test_peridigm_top_key_is_optional() -> None:
    wrapped = parse_yaml_text("Peridigm:\n" + indent(BODY))
    bare = parse_yaml_text(BODY)
    assert typed(wrapped.tree) == typed(bare.tree)
    assert list(bare.tree) == ["Discretization", "Materials", "Solver"]
    assert wrapped.lines[("Materials", "My Elastic", "Bulk Modulus")] == 7
    assert bare.lines[("Materials", "My Elastic", "Bulk Modulus")] == 6


def test_any_single_wrapper_key_is_unwrapped_but_not_a_section() -> None:
    assert parse_yaml_text("MyDeck:\n  Blocks: {}\n").tree == {"Blocks": {}}
    assert parse_yaml_text("Discretization:\n  Type: x\n").tree == {"Discretization": {"Type": "x"}}
    assert parse_yaml_text("Solver 2:\n  Verlet: {}\n").tree == {"Solver 2": {"Verlet": {}}}
    assert parse_yaml_text("Peridigm:\n").tree == {}
    assert parse_yaml_text("Verbose: false\n").tree == {"Verbose": False}


@pytest.mark.parametrize("text", ["", "- 1\n- 2\n", "just text\n", "# only a comment\n"])
def test_top_level_must_be_a_mapping(text: str) -> None:
    with pytest.raises(InputError, match="named sections") as info:
        parse_yaml_text(text, "d.yaml")
    assert info.value.file == "d.yaml"


def test_yaml_duplicate_key_replaces_in_place_with_warning(caplog: pytest.LogCaptureFixture) -> None:
    text = """\
Peridigm:
  Solver:
    QuasiStatic:
      Number of Load Steps: 1
  Output:
    Output Frequency: 1
  Solver:
    NOXQuasiStatic:
      Number of Load Steps: 2
"""
    with caplog.at_level(logging.WARNING, logger="peridyn.deck"):
        deck = parse_yaml_text(text, "dup.yaml")
    assert list(deck.tree) == ["Solver", "Output"]  # first position, last value
    assert deck.tree["Solver"] == {"NOXQuasiStatic": {"Number of Load Steps": 2}}
    assert deck.lines[("Solver",)] == 7
    assert deck.lines[("Solver", "NOXQuasiStatic", "Number of Load Steps")] == 9
    assert ("Solver", "QuasiStatic") not in deck.lines
    records = [r for r in caplog.records if r.name == "peridyn.deck"]
    assert len(records) == 1
    message = records[0].getMessage()
    assert "dup.yaml:7" in message and "Solver" in message


def test_yaml_anchors_and_multiple_documents_are_rejected() -> None:
    with pytest.raises(InputError, match="anchors") as info:
        parse_yaml_text("a: &x 1\nb: *x\n", "d.yaml")
    assert info.value.line == 1
    with pytest.raises(InputError, match="single document") as info:
        parse_yaml_text("a: 1\n---\nb: 2\n", "d.yaml")
    assert info.value.line == 2


@pytest.mark.parametrize(
    "text, line, hint",
    [
        ("Peridigm:\n  a: 1\n b: 2\n", 3, "indentation"),
        ("Peridigm:\n  a: [1, 2\n", 3, "closed"),
        ("Peridigm:\n\ta: 1\n", 2, "tabs"),
        ("Peridigm:\n  a: b: c\n", 2, "quote"),
    ],
)
def test_yaml_syntax_errors_name_file_and_line(text: str, line: int, hint: str) -> None:
    with pytest.raises(InputError) as info:
        parse_yaml_text(text, "bad.yaml")
    err = info.value
    assert err.file == "bad.yaml" and err.line == line
    assert f"bad.yaml:{line}" in str(err) and hint in str(err)


def test_line_of_uses_longest_known_prefix() -> None:
    deck = parse_yaml_text("Peridigm:\n" + indent(BODY))
    assert deck.line_of(("Materials", "My Elastic", "Bulk Modulus")) == 7
    assert deck.line_of(("Materials", "My Elastic", "Shear Modulus")) == 5
    assert deck.line_of(("Materials",)) == 4
    assert deck.line_of(("Nowhere", "x")) is None
    assert deck.line_of(()) is None


# --------------------------------------------------------------------------------------------
# XML
# --------------------------------------------------------------------------------------------

XML = """\
<?xml version="1.0"?>
<ParameterList name="Peridigm">
  <!-- a comment -->
  <Parameter name="Verbose" type="bool" value="false"/>
  <ParameterList name="Materials">
    <ParameterList name="My Elastic">
      <Parameter name="Material Model" type="string" value=" Elastic "/>
      <Parameter name="Bulk Modulus" type="double" value="1.5e12"/>
      <Parameter name="Count" type="INT" value="3"/>
      <Parameter name="On" type="Bool" value="1"/>
      <Parameter name="Off" type="bool" value="FALSE"/>
      <Parameter name="Doubles" type="Array(double)" value="{1, 2.5, -3e2}"/>
      <Parameter name="Ints" type="Array(int)" value="{ 1,2 , 3 }"/>
      <Parameter name="Names" type="Array(string)" value="{a, b c}"/>
      <Parameter name="None" type="Array(int)" value="{}"/>
      <Parameter name="Expr" type="string" value="if(t&lt;=1){value=1;}"/>
    </ParameterList>
  </ParameterList>
  <!--
  <ParameterList name="Solver"><Parameter name="x" type="int" value="1"/></ParameterList>
  -->
</ParameterList>
"""


def test_xml_types_arrays_bools_and_comments() -> None:
    deck = parse_xml_text(XML, "d.xml")
    assert deck.fmt == "xml" and deck.path == Path("d.xml")
    expected = {
        "Verbose": False,
        "Materials": {
            "My Elastic": {
                "Material Model": " Elastic ",
                "Bulk Modulus": 1.5e12,
                "Count": 3,
                "On": True,
                "Off": False,
                "Doubles": [1.0, 2.5, -300.0],
                "Ints": [1, 2, 3],
                "Names": ["a", "b c"],
                "None": [],
                "Expr": "if(t<=1){value=1;}",
            }
        },
    }
    assert typed(deck.tree) == typed(expected)
    assert deck.lines[("Verbose",)] == 4
    assert deck.lines[("Materials",)] == 5
    assert deck.lines[("Materials", "My Elastic", "Bulk Modulus")] == 8
    assert deck.line_of(("Materials", "My Elastic", "Bulk Modulus", "extra")) == 8


def xml_deck(body: str) -> str:
    return f'<ParameterList>\n  <ParameterList name="S">\n{body}\n  </ParameterList>\n</ParameterList>\n'


@pytest.mark.parametrize(
    "body, words",
    [
        ('<Parameter name="Density" type="double" value="7.8e3x"/>', "bad double"),
        ('<Parameter name="N" type="int" value="1.0"/>', "bad int"),
        ('<Parameter name="N" type="int" value="99999999999"/>', "32-bit"),
        ('<Parameter name="B" type="bool" value="maybe"/>', "bad bool"),
        ('<Parameter name="A" type="Array(double)" value="1, 2"/>', "not an array"),
        ('<Parameter name="A" type="Array(int)" value="{1, x}"/>', "bad Array"),
        ('<Parameter name="F" type="float" value="1"/>', "unknown parameter type"),
        ('<Parameter name="F" value="1"/>', "no type"),
        ('<Parameter type="int" value="1"/>', "no name"),
    ],
)
def test_xml_bad_values_give_line_and_path(body: str, words: str) -> None:
    with pytest.raises(InputError, match=words) as info:
        parse_xml_text(xml_deck(body), "d.xml")
    err = info.value
    assert err.file == "d.xml" and err.line == 3
    assert str(err).startswith("d.xml:3: S")


def test_xml_doctype_and_entities_rejected() -> None:
    bomb = '<?xml version="1.0"?>\n<!DOCTYPE x [<!ENTITY a "aaaa">]>\n<ParameterList/>\n'
    with pytest.raises(InputError, match="DOCTYPE") as info:
        parse_xml_text(bomb, "d.xml")
    assert info.value.line == 2
    with pytest.raises(InputError, match="undefined entity"):
        parse_xml_text("<ParameterList>&a;</ParameterList>", "d.xml")


@pytest.mark.parametrize(
    "text, line",
    [
        ('<ParameterList>\n  <ParameterList name="a">\n</ParameterList>\n', 4),
        ('<ParameterList>\n  <Parameter name="a" type="int" value=1/>\n</ParameterList>\n', 2),
        ("", 1),
    ],
)
def test_xml_syntax_errors_name_file_and_line(text: str, line: int) -> None:
    with pytest.raises(InputError, match="XML syntax error") as info:
        parse_xml_text(text, "bad.xml")
    assert info.value.file == "bad.xml" and info.value.line == line
    assert "closed" in str(info.value)


def test_xml_root_must_be_a_parameter_list() -> None:
    with pytest.raises(InputError, match="root element"):
        parse_xml_text("<Peridigm/>", "d.xml")


def test_xml_duplicates_replace_and_unknown_elements_warn(caplog: pytest.LogCaptureFixture) -> None:
    text = """\
<ParameterList>
  <ParameterList name="Solver">
    <ParameterList name="QuasiStatic"/>
  </ParameterList>
  <Parameter name="Verbose" type="bool" value="true"/>
  <Validators><Validator type="x"/></Validators>
  <ParameterList name="Solver">
    <ParameterList name="NOXQuasiStatic"/>
  </ParameterList>
</ParameterList>
"""
    with caplog.at_level(logging.WARNING, logger="peridyn.deck"):
        deck = parse_xml_text(text, "dup.xml")
    assert deck.tree == {"Solver": {"NOXQuasiStatic": {}}, "Verbose": True}
    assert list(deck.tree) == ["Solver", "Verbose"]
    assert deck.lines[("Solver",)] == 7 and ("Solver", "QuasiStatic") not in deck.lines
    messages = [r.getMessage() for r in caplog.records if r.name == "peridyn.deck"]
    assert len(messages) == 2
    assert any("Validators" in m and "dup.xml:6" in m for m in messages)
    assert any("Solver" in m and "dup.xml:7" in m for m in messages)


# --------------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------------


def test_extension_chooses_parser(tmp_path: Path) -> None:
    (tmp_path / "a.yml").write_text("Peridigm:\n  x: 1\n")
    (tmp_path / "a.XML").write_bytes(
        '<?xml version="1.0" encoding="ISO-8859-1"?>\n<ParameterList>'
        '<Parameter name="x" type="string" value="\u00e9"/></ParameterList>'.encode("latin-1")
    )
    yml = load_deck_file(tmp_path / "a.yml")
    assert isinstance(yml, DeckSource) and yml.fmt == "yaml" and yml.tree == {"x": 1}
    assert yml.path == tmp_path / "a.yml"
    xml = load_deck_file(str(tmp_path / "a.XML"))
    assert xml.fmt == "xml" and xml.tree == {"x": "\u00e9"}


@pytest.mark.parametrize("name", ["deck.peridigm", "deck.txt", "deck"])
def test_unknown_extension_is_an_input_error(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    path.write_text("Peridigm:\n  x: 1\n")
    with pytest.raises(InputError) as info:
        load_deck_file(path)
    assert info.value.file == str(path)
    assert ".yaml" in str(info.value) and ".xml" in str(info.value)


def test_missing_or_unreadable_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="does not exist") as info:
        load_deck_file(tmp_path / "nope.yaml")
    assert info.value.file == str(tmp_path / "nope.yaml")
    folder = tmp_path / "folder.xml"
    folder.mkdir()
    with pytest.raises(InputError, match="cannot read"):
        load_deck_file(folder)
    bad = tmp_path / "latin.yaml"
    bad.write_bytes(b"Peridigm:\n  x: \"\xe9\"\n")
    with pytest.raises(InputError, match="UTF-8") as info:
        load_deck_file(bad)
    assert info.value.line == 2


# --------------------------------------------------------------------------------------------
# dump_yaml
# --------------------------------------------------------------------------------------------


def test_dump_style() -> None:
    tree = {
        "Materials": {"My Elastic": {"Material Model": "Elastic", "Density": 2.0, "N1": 3}},
        "Flags": {"Enabled": True, "On": False},
        "Empty": {},
        "List": [1.0, 2.5e-05],
        "Names": ["a", 'q"b\\'],
        "1": "numeric key",
        "true": "bool key",
        "a: b": "colon",
        " padded ": "spaces",
        "Output": {"Value": "x\ny"},
    }
    text = dump_yaml(tree)
    assert text.splitlines()[:9] == [
        "Peridigm:",
        "  Materials:",
        "    My Elastic:",
        '      Material Model: "Elastic"',
        "      Density: 2.0",
        "      N1: 3",
        "  Flags:",
        "    Enabled: true",
        '    "On": false',  # quoted for YAML 1.1 readers, which take On/Off/Yes/No as bools
    ]
    for line in [
        "  Empty: {}",
        "  List: [1.0, 2.5e-05]",
        '  Names: ["a", "q\\"b\\\\"]',
        '  "1": "numeric key"',
        '  "true": "bool key"',
        '  "a: b": "colon"',
        '  " padded ": "spaces"',
        '    Value: "x\\ny"',
    ]:
        assert line in text.splitlines(), line
    assert typed(parse_yaml_text(text).tree) == typed(tree)
    assert dump_yaml({}) == "Peridigm: {}\n"
    assert dump_yaml({}, top_key=None) == "{}\n"
    assert dump_yaml({"A": 1, "B": 2}, top_key=None) == "A: 1\nB: 2\n"


@pytest.mark.parametrize(
    "tree, error",
    [
        ({1: 2}, TypeError),
        ({"a": None}, TypeError),
        ({"a": [1, 2.0]}, ValueError),
        ({"a": [True]}, ValueError),
        ({"a": 2**40}, ValueError),
    ],
)
def test_dump_rejects_what_no_deck_can_hold(tree: dict, error: type[Exception]) -> None:
    with pytest.raises(error):
        dump_yaml(tree)


def test_dump_special_floats_reload_as_floats() -> None:
    back = parse_yaml_text(dump_yaml({"a": math.inf, "b": -math.inf, "c": math.nan, "d": -0.0})).tree
    assert back["a"] == math.inf and back["b"] == -math.inf and math.isnan(back["c"])
    assert math.copysign(1.0, back["d"]) == -1.0


# Hypothesis trees: keys without control characters, leaves of every deck type.
TRICKY = [
    "1e5", "true", "False", "yes", " a ", "", "1", "-2.5", "nan", "inf", "1 2 3", "null", "~",
    "a: b", "# x", "- x", "[1]", "{a}", '"q"', "back\\slash", "\u2028", "\x85", "\ufeff",
    "\u00e9t\u00e9", "\U0001f600", "tab\there", "\x00",
]
keys = st.text(st.characters(blacklist_categories=("Cc", "Cs")), max_size=12) | st.sampled_from(TRICKY[:-2])
strings = st.text(max_size=12) | st.sampled_from(TRICKY)
ints = st.integers(INT_MIN, INT_MAX)
floats = st.floats(allow_nan=False, allow_infinity=False)
leaves = st.one_of(
    st.booleans(), ints, floats, strings,
    st.lists(ints, max_size=4), st.lists(floats, max_size=4), st.lists(strings, max_size=4),
)
nodes = st.recursive(leaves, lambda inner: st.dictionaries(keys, inner, max_size=4), max_leaves=20)
trees = st.dictionaries(keys, nodes, max_size=5)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(trees)
def test_round_trip_hypothesis(tree: dict) -> None:
    assert typed(parse_yaml_text(dump_yaml(tree)).tree) == typed(tree)


@settings(max_examples=50, deadline=None)
@given(trees)
def test_round_trip_without_top_key(tree: dict) -> None:
    single = len(tree) == 1 and isinstance(next(iter(tree.values())), dict)
    assume(not single)  # a lone non-section list would be taken as the wrapper key
    assert typed(parse_yaml_text(dump_yaml(tree, top_key=None)).tree) == typed(tree)


# --------------------------------------------------------------------------------------------
# Conformance decks and convert
# --------------------------------------------------------------------------------------------


@needs_shared
@pytest.mark.parametrize("deck", YAML_DECKS + XML_DECKS, ids=lambda p: p.name)
def test_round_trip_conformance_decks(deck: Path) -> None:
    source = load_deck_file(deck)
    assert source.tree and source.lines
    assert typed(parse_yaml_text(dump_yaml(source.tree)).tree) == typed(source.tree)


@needs_shared
def test_conformance_yaml_typing() -> None:
    deck = load_deck_file(CASES / "NOX_QS_MatrixFree_3x3Prec" / "NOX_QS_MatrixFree_3x3Prec.yaml")
    material = deck.tree["Materials"]["My Material"]
    assert typed(material["Bulk Modulus"]) == typed(160.0e10)
    assert deck.tree["Verbose"] is False
    assert deck.lines[("Materials", "My Material", "Bulk Modulus")] == 23


@needs_shared
def test_conformance_disk_filter_runs_second_solver() -> None:
    deck = load_deck_file(CASES / "DiskFilter" / "DiskFilter.xml")
    assert "NOXQuasiStatic" in deck.tree["Solver"]


@needs_shared
@pytest.mark.parametrize("deck", XML_DECKS, ids=lambda p: p.parent.name)
def test_convert_conformance_xml(deck: Path, tmp_path: Path) -> None:
    out = tmp_path / "out.yaml"
    convert(deck, out)
    assert typed(load_deck_file(out).tree) == typed(load_deck_file(deck).tree)
    assert [p.name for p in tmp_path.iterdir()] == ["out.yaml"]


def test_convert_yaml_and_bad_sources_leave_dst_alone(tmp_path: Path) -> None:
    src = tmp_path / "in.yaml"
    src.write_text("Peridigm:\n" + indent(BODY))
    dst = tmp_path / "out.yaml"
    convert(src, dst)
    assert typed(load_deck_file(dst).tree) == typed(load_deck_file(src).tree)

    dst.write_text("keep me\n")
    bad = tmp_path / "bad.xml"
    bad.write_text('<ParameterList><Parameter name="x" type="double" value="oops"/></ParameterList>')
    with pytest.raises(InputError, match="bad double"):
        convert(bad, dst)
    with pytest.raises(InputError):
        convert(tmp_path / "missing.xml", dst)
    with pytest.raises(InputError, match="YAML"):
        convert(src, tmp_path / "out.txt")
    with pytest.raises(InputError, match="cannot write"):
        convert(src, tmp_path / "no" / "such" / "folder.yaml")
    assert dst.read_text() == "keep me\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.xml", "in.yaml", "out.yaml"]
