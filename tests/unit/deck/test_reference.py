"""docs/reference.md is written from the parameter models (``peridyn schema --reference``) and
is up to date with the built-in models."""
from pathlib import Path

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.deck.reference import reference_markdown, unit_of
from peridyn.testing import isolated_registry

PAGE = Path(__file__).resolve().parents[3] / "docs" / "reference.md"


def test_the_shipped_reference_is_up_to_date():
    with isolated_registry():
        text = reference_markdown()
    assert PAGE.read_text() == text, "docs/reference.md is stale: run `peridyn schema --reference docs/reference.md`"


def test_it_lists_every_parameter_with_type_unit_and_default():
    text = PAGE.read_text()
    assert "| `Density` | number | M/L^3, kg/m^3 in SI | required | mass density" in text
    assert "| `Verlet > Safety Factor` | number |" in text  # nested sections, by path
    assert "| `Hourglass Coefficient` |" in text and "accepted and ignored" in text
    for section in ("## Materials", "## Damage Models", "## Boundary Conditions", "## Solver", "## Compute Class Parameters", "## Contact > Models"):
        assert section in text


def test_units_are_read_from_the_descriptions():
    assert unit_of("thickness of a 2D model (L)") == "L"
    assert unit_of("time step (T); default: the critical time step estimate") == "T"
    assert unit_of("bulk modulus K (Pa in SI); give this or Young's Modulus") == "Pa in SI"
    assert unit_of("2D plane strain (needs Height)") == ""
    assert unit_of("Lame constant (Large values)") == ""


def test_the_command_writes_it(tmp_path, capsys):
    out = tmp_path / "reference.md"
    assert main(["schema", "--reference", str(out)]) == ExitCode.OK
    assert out.read_text().startswith("# Deck reference")
