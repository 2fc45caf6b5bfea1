"""The run session (engine/session.py): ``peridyn run`` and the Python API share one lifecycle,
so what the command does about checkpoints, locks and closing the API does too."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from peridyn.api import Model
from peridyn.core.errors import InputError, InstabilityError
from peridyn.engine.output_paths import OutputLock
from peridyn.engine.restart import RunInterrupted, checkpoints_of
from peridyn.engine.session import RunSession, keeps_output
from tests.unit.engine.test_restart import assert_same_file, run, write_deck


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("whole")
    deck = write_deck(folder)
    assert run(deck, folder) == 0
    return folder


def test_the_api_writes_the_checkpoints_of_a_restart_section(uninterrupted, tmp_path):
    """The same deck through the API writes the same checkpoints and the same file as the command."""
    deck = write_deck(tmp_path / "deck")
    with Model(deck, output_dir=tmp_path / "api") as m:
        m.run()
    names = [p.name for _, p in checkpoints_of(tmp_path / "api" / "restart", "flyby")]
    assert names == [p.name for _, p in checkpoints_of(uninterrupted / "restart", "flyby")] and len(names) >= 3
    assert_same_file(uninterrupted / "flyby.e", tmp_path / "api" / "flyby.e")


def test_the_api_continues_from_a_checkpoint_to_the_uninterrupted_file(uninterrupted, tmp_path):
    """A run continued with ``Model(restart=...)`` and stepped from Python writes, bit for bit,
    the file of the run never stopped."""
    out = tmp_path / "cont"
    shutil.copytree(uninterrupted, out)  # as a run stopped after the checkpoint left the folder
    middle = dict(checkpoints_of(out / "restart", "flyby"))[(0, 18)]
    m = Model(out / "flyby.yaml", output_dir=out, restart=middle)
    m.step(2)
    m.run()
    assert m.finished
    assert 0 < m.steps_taken <= 36 - 18 + 1  # it went on from step 18, not from the start
    assert_same_file(uninterrupted / "flyby.e", out / "flyby.e")
    assert_same_file(uninterrupted / "energy.h", out / "energy.h")


def test_a_failed_set_up_releases_the_lock_and_creates_no_output(tmp_path, monkeypatch):
    deck = write_deck(tmp_path)
    from peridyn.engine import session

    def broken(*args, **kwargs):
        raise InputError("simulated set-up error", fix="none")

    monkeypatch.setattr(session, "Simulation", broken)
    s = RunSession(deck, output_dir=tmp_path / "out")
    with pytest.raises(InputError):
        s.open()
    assert s.closed
    assert not list((tmp_path / "out").glob("flyby.e*"))
    lock = OutputLock(tmp_path / "out" / "flyby.lock")
    assert lock.acquire()  # released
    lock.release()


@pytest.mark.parametrize("exc, ranks, kept", [
    (None, 1, True),
    (InstabilityError("grew"), 1, True),
    (InstabilityError("grew", collective=False), 1, True),
    (InstabilityError("grew", collective=False), 2, False),
    (InstabilityError("grew"), 2, True),
    (RunInterrupted("stopped", 15), 1, False),
    (RuntimeError("boom"), 1, False),
    (KeyboardInterrupt(), 2, False),
])
def test_which_endings_keep_the_output_complete(exc, ranks, kept):
    assert keeps_output(exc, ranks) is kept


def test_closing_is_idempotent_and_a_second_session_in_the_folder_is_refused_until_then(tmp_path):
    deck = write_deck(tmp_path)
    a = RunSession(deck, output_dir=tmp_path / "out", progress=False)
    a.open()
    with pytest.raises(InputError, match="lock|running|another"):
        RunSession(deck, output_dir=tmp_path / "out", progress=False).open()
    a.close(complete=False)
    a.close(complete=True)  # no second close of the outputs
    b = RunSession(deck, output_dir=tmp_path / "out", progress=False)
    b.open()
    b.close()
