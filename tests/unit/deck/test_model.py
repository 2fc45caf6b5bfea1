"""Deck validation: every problem found in one pass, each naming file, deck path and fix."""
import textwrap

import pytest

from peridyn.deck.model import load_deck, tidy
from peridyn.core.errors import InputError

GOOD = """
Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    TensorProduct3DMeshGenerator:
      Type: "PdQuickGrid"
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 3.0
      Y Length: 1.0
      Z Length: 1.0
      Number Points X: 3
      Number Points Y: 1
      Number Points Z: 1
  Materials:
    Steel:
      Material Model: "Elastic"
      Density: 7800.0
      Bulk Modulus: 130.0e9
      Shear Modulus: 78.0e9
  Blocks:
    All:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: 1.5
  Boundary Conditions:
    Left Node Set: "1"
    Pull:
      Type: "Prescribed Displacement"
      Node Set: "Left Node Set"
      Coordinate: "x"
      Value: "-0.001*t"
  Solver:
    Initial Time: 0.0
    Final Time: 1.0e-5
    Verlet:
      Fixed dt: 1.0e-6
  Output:
    Output Filename: "out"
    Output Frequency: 1
    Output Variables:
      Displacement: true
"""


def write(tmp_path, text, name="deck.yaml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


def errors_of(tmp_path, text):
    with pytest.raises(InputError) as info:
        load_deck(write(tmp_path, text))
    return info.value.one_line().splitlines()


def test_good_deck_validates(tmp_path):
    deck = load_deck(write(tmp_path, GOOD))
    assert deck.materials["Steel"].params.bulk_modulus == 130.0e9  # unquoted 130.0e9 is a number
    assert [s.method for s in deck.solvers] == ["Verlet"]
    assert deck.outputs[0].variables == ["Displacement"]
    assert deck.boundary_conditions[0].type == "PRESCRIBED_DISPLACEMENT"


def test_top_key_is_optional(tmp_path):
    text = "\n".join(line[2:] for line in GOOD.strip().splitlines()[1:])
    assert load_deck(write(tmp_path, text)).blocks[0].material == "Steel"


def test_misspelled_key_names_file_path_and_suggestion(tmp_path):
    (line,) = errors_of(tmp_path, GOOD.replace("Bulk Modulus:", "Bulk Modulu:"))
    assert "deck.yaml" in line and "Materials > Steel" in line and "'Bulk Modulu'" in line and "did you mean 'Bulk Modulus'" in line


def test_unknown_model_lists_close_matches_and_available(tmp_path):
    (line,) = errors_of(tmp_path, GOOD.replace('"Elastic"', '"Elastc"'))
    assert "Materials > Steel > Material Model" in line and "did you mean 'Elastic'" in line and "'peridyn plugins' lists all" in line


def test_all_problems_are_reported_together(tmp_path):
    bad = GOOD.replace("Shear Modulus: 78.0e9", "Shear Modulus: 78.0e9\n      Young's Modulus: 200.0e9")
    bad = bad.replace('Material: "Steel"', 'Material: "Stel"').replace("Fixed dt: 1.0e-6", "Fixed dt: -1.0")
    bad = bad.replace('Value: "-0.001*t"', 'Value: "-0.001*tt"')
    lines = errors_of(tmp_path, bad)
    text = "\n".join(lines)
    assert len(lines) == 4, text
    assert "give exactly two of" in text
    assert "Blocks > All > Material" in text and "did you mean 'Steel'" in text
    assert "Solver > Verlet > Fixed dt" in text
    assert "Boundary Conditions > Pull" in text and "'tt'" in text


def test_line_numbers_are_reported(tmp_path):
    (line,) = errors_of(tmp_path, GOOD.replace("Bulk Modulus:", "Bulk Modulu:"))
    assert "deck.yaml:" in line.split(":", 2)[0] + ":" and line.split(":")[1].strip().isdigit()


def test_unknown_section_and_missing_section(tmp_path):
    lines = errors_of(tmp_path, GOOD.replace("  Blocks:", "  Blcks:"))
    text = "\n".join(lines)
    assert "unknown section 'Blcks'" in text and "did you mean 'Blocks'" in text
    assert "missing required section 'Blocks'" in text


def test_unknown_node_set_and_bc_type(tmp_path):
    bad = GOOD.replace('Node Set: "Left Node Set"', 'Node Set: "Rigth Node Set"').replace('"Prescribed Displacement"', '"Prescribed Displacment"')
    text = "\n".join(errors_of(tmp_path, bad))
    assert "unknown boundary condition type 'Prescribed Displacment'" in text and "PRESCRIBED_DISPLACEMENT" in text


def test_bc_type_matching_ignores_case_and_spaces():
    assert tidy(" prescribed displacement ") == "PRESCRIBED_DISPLACEMENT"
    assert tidy("Prescribed_Displacement") == "PRESCRIBED_DISPLACEMENT"


def test_peridigm_key_that_peridigm_ignores_is_accepted_with_a_warning(tmp_path, caplog):
    deck = load_deck(write(tmp_path, GOOD.replace("Density: 7800.0", "Density: 7800.0\n      Apply Shear Correction Factor: true")))
    assert deck.materials["Steel"].params.density == 7800.0
    assert any("Apply Shear Correction Factor" in r.getMessage() for r in caplog.records)


def test_horizon_in_material_is_refused(tmp_path):
    text = "\n".join(errors_of(tmp_path, GOOD.replace("Density: 7800.0", "Density: 7800.0\n      Horizon: 1.0")))
    assert "Materials > Steel > Horizon" in text and "set Horizon in the block" in text


def test_several_solver_and_output_sections_in_deck_order(tmp_path):
    extra = GOOD.replace("  Output:", "  Solver2:\n    Initial Time: 1.0e-5\n    Final Time: 2.0e-5\n    Verlet:\n      Fixed dt: 1.0e-6\n  Output:")
    extra += '  Output History:\n    Output Filename: "hist"\n    Output Frequency: 2\n    Output Variables:\n      Global_Kinetic_Energy: true\n'
    deck = load_deck(write(tmp_path, extra))
    assert [s.section for s in deck.solvers] == ["Solver", "Solver2"]
    assert [o.section for o in deck.outputs] == ["Output", "Output History"]


def test_xml_deck(tmp_path):
    xml = """<ParameterList>
      <ParameterList name="Discretization">
        <Parameter name="Type" type="string" value="PdQuickGrid"/>
        <ParameterList name="TensorProduct3DMeshGenerator">
          <Parameter name="Type" type="string" value="PdQuickGrid"/>
          <Parameter name="X Origin" type="double" value="0.0"/><Parameter name="Y Origin" type="double" value="0.0"/>
          <Parameter name="Z Origin" type="double" value="0.0"/><Parameter name="X Length" type="double" value="2.0"/>
          <Parameter name="Y Length" type="double" value="1.0"/><Parameter name="Z Length" type="double" value="1.0"/>
          <Parameter name="Number Points X" type="int" value="2"/><Parameter name="Number Points Y" type="int" value="1"/>
          <Parameter name="Number Points Z" type="int" value="1"/>
        </ParameterList>
      </ParameterList>
      <ParameterList name="Materials"><ParameterList name="M">
        <Parameter name="Material Model" type="string" value="Elastic"/>
        <Parameter name="Density" type="double" value="7800.0"/>
        <Parameter name="Bulk Modulus" type="double" value="130.0e9"/>
        <Parameter name="Shear Modulus" type="string" value="lots"/>
      </ParameterList></ParameterList>
      <ParameterList name="Blocks"><ParameterList name="B">
        <Parameter name="Block Names" type="string" value="block_1"/>
        <Parameter name="Material" type="string" value="M"/>
        <Parameter name="Horizon" type="double" value="1.5"/>
      </ParameterList></ParameterList>
    </ParameterList>"""
    p = write(tmp_path, xml, "deck.xml")
    with pytest.raises(InputError) as info:
        load_deck(p)
    (line,) = info.value.one_line().splitlines()
    assert "deck.xml" in line and "Materials > M > Shear Modulus" in line and "'lots'" in line


@pytest.mark.parametrize("value, says", [('"maybe"', "true or false"), ("3", "true or false"),
                                         ("[true]", "a sequence cannot hold"), ("nan", "must be finite")])
def test_merge_rank_files_takes_only_true_or_false(tmp_path, value, says):
    text = GOOD.replace("    Output Frequency: 1\n", f"    Output Frequency: 1\n    Merge Rank Files: {value}\n")
    assert "Merge Rank Files" in text
    (line,) = errors_of(tmp_path, text)
    assert "Merge Rank Files" in line and says in line, line
    assert load_deck(write(tmp_path, text.replace(f"Merge Rank Files: {value}", "Merge Rank Files: false"))).outputs[0].params.merge_rank_files is False
