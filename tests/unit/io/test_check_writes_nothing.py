"""`peridyn check` validates and describes a deck without writing anything (issue #19): a deck
with Construct Interfaces used to leave Interfaces.e beside it."""
import os
import shutil
from pathlib import Path

import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode

CASE = Path(__file__).resolve().parents[4] / "shared" / "conformance" / "cases" / "Interfaces"


def listing(folder: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(folder)): (p.stat().st_size, p.stat().st_mtime_ns) for p in sorted(folder.rglob("*"))}


@pytest.mark.skipif(not CASE.is_dir(), reason="../shared/conformance is not present")
def test_check_of_a_deck_with_construct_interfaces_writes_nothing(tmp_path, monkeypatch, capsys):
    work = tmp_path / "case"
    shutil.copytree(CASE, work)
    deck = next(p for p in work.iterdir() if p.suffix in (".xml", ".yaml"))
    assert "Construct Interfaces" in deck.read_text()
    monkeypatch.chdir(work)
    before = listing(work)
    assert main(["check", deck.name]) == ExitCode.OK
    assert "valid" in capsys.readouterr().out
    assert listing(work) == before
    assert not (work / "Interfaces.e").exists()
    # a run still writes it
    assert main(["run", deck.name, "-q", "--no-progress"]) == ExitCode.OK
    assert (work / "Interfaces.e").exists()
    assert not any(name.endswith(".lock") for name in os.listdir(work))
