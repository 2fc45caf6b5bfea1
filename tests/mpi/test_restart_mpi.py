"""Checkpoints and restarts on 2 ranks (docs/restart.md): SIGTERM to mpiexec stops every rank
at the same step with a checkpoint; a job killed at a random moment leaves a usable checkpoint
and a readable output; a restart on 2 ranks continues bit for bit, and a checkpoint moves
between 1 and 2 ranks (within round-off; in fact bit for bit, since every sum runs in global-id
order)."""
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from peridyn.deck.files import dump_yaml
from peridyn.engine.restart import checkpoints_of
from peridyn.io.exodus_reader import read_results
from peridyn.testing.mpi import MPIEXEC, mpirun, requires_mpi

pytestmark = [pytest.mark.mpi, requires_mpi]

from tests.unit.engine.test_restart import assert_same_file, exodus_values, flyby_tree

LONG = {"final_time": 0.1, "frequency": 25, "keep": 2}  # 364 steps


def _deck(folder: Path, **kw) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "flyby.yaml").write_text(dump_yaml(flyby_tree(**kw)))
    return folder / "flyby.yaml"


def _ok(proc) -> None:
    assert proc.returncode == 0, proc.stderr[-3000:]


@pytest.fixture(scope="module")
def whole(tmp_path_factory) -> Path:
    """The uninterrupted run on 2 ranks."""
    out = tmp_path_factory.mktemp("whole2")
    _deck(out, **LONG)
    _ok(mpirun(2, ["run", "flyby.yaml", "-q"], cwd=out))
    return out


def _start(folder: Path) -> subprocess.Popen:
    env = dict(os.environ, PERIDYN_NO_PROGRESS="1")
    return subprocess.Popen([MPIEXEC, "-n", "2", sys.executable, "-m", "peridyn", "run", "flyby.yaml", "-q"], cwd=folder,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, start_new_session=True)


def _wait_for_checkpoint(proc, folder: Path, timeout: float = 120.0) -> None:
    t0 = time.monotonic()
    while not checkpoints_of(folder / "restart", "flyby"):
        assert proc.poll() is None, proc.communicate()[1][-3000:]
        assert time.monotonic() - t0 < timeout
        time.sleep(0.01)


def test_sigterm_to_mpiexec_stops_both_ranks_at_one_checkpoint_and_the_restart_continues_bit_for_bit(whole, tmp_path):
    _deck(tmp_path, **LONG)
    proc = _start(tmp_path)
    _wait_for_checkpoint(proc, tmp_path)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    if proc.returncode == 0:
        pytest.skip("the run ended before the signal came")
    assert proc.returncode == 143, err[-3000:]
    assert "stopped by SIGTERM after" in err  # after a step, or after the section if it came in its last 16 steps
    assert "continue with 'mpiexec -n 2 peridyn run flyby.yaml --restart'" in err, err[-3000:]
    (pos, _), *_ = checkpoints_of(tmp_path / "restart", "flyby")[-1:]
    assert pos[1] % 16 == 0  # the ranks agree on a signal every 16 steps
    # each rank's frames in its own piece, kept under the partial name until the restart joins them
    assert all(read_results(tmp_path / f"flyby.partial.e.2.{r}")["times"].size >= 1 for r in range(2))
    _ok(mpirun(2, ["run", "flyby.yaml", "-q", "--restart"], cwd=tmp_path))
    assert_same_file(whole / "flyby.e", tmp_path / "flyby.e")
    assert not list(tmp_path.glob("flyby.*e.2.*"))


@pytest.mark.parametrize("seed", [3, 4])
def test_a_job_killed_at_a_random_moment_continues_bit_for_bit(whole, tmp_path, seed):
    """SIGKILL to mpiexec and both ranks at once (a node lost), at a random moment."""
    _deck(tmp_path, **LONG)
    proc = _start(tmp_path)
    _wait_for_checkpoint(proc, tmp_path)
    time.sleep(random.Random(seed).uniform(0.0, 0.6))
    os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate(timeout=60)
    pieces = sorted(tmp_path.glob("flyby.partial.e.2.*"))
    outputs = pieces or [tmp_path / ("flyby.partial.e" if (tmp_path / "flyby.partial.e").exists() else "flyby.e")]
    assert min(read_results(p)["times"].size for p in outputs) >= 1
    _ok(mpirun(2, ["run", "flyby.yaml", "-q", "--restart"], cwd=tmp_path))
    assert_same_file(whole / "flyby.e", tmp_path / "flyby.e")


@pytest.mark.parametrize("before, after, damage", [(1, 2, True), (2, 1, True), (2, 1, False), (1, 2, False)])
def test_a_checkpoint_continues_on_another_number_of_ranks(tmp_path, before, after, damage):
    """Stopped after step 18 (of 36) on one count, continued on the other: the file equals the
    uninterrupted run's within round-off (1e-12 of each variable's largest value). Without damage
    the checkpoint holds no bond field: its bonds are checked by their digest, the same on any
    number of ranks."""
    ref, cont = tmp_path / "ref", tmp_path / "cont"
    _deck(ref, damage=damage)
    _deck(cont, damage=damage)
    _ok(mpirun(before, ["run", "flyby.yaml", "-q"], cwd=ref))
    _ok(mpirun(before, ["run", "flyby.yaml", "-q"], cwd=cont))
    path = dict(checkpoints_of(cont / "restart", "flyby"))[(0, 18)]
    with np.load(path) as saved:
        assert ("bond_keys" in saved.files) == damage
    _ok(mpirun(after, ["run", "flyby.yaml", "-q", "--restart", str(path)], cwd=cont))
    a, b = exodus_values(ref / "flyby.e"), exodus_values(cont / "flyby.e")
    assert a.keys() == b.keys()
    for k in a:
        assert a[k].shape == b[k].shape, k
        scale = max(float(np.abs(a[k]).max()), 1e-300)
        assert np.allclose(a[k], b[k], rtol=0.0, atol=1e-12 * scale), k


def _one_error_line(proc) -> str:
    assert proc.returncode == 2, proc.stderr[-3000:]
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr[-3000:]
    return lines[0]


@pytest.mark.parametrize("corrupt", ["flip", "truncate", "rank 1's ghost rows", "wrong dtype"])
def test_a_bad_checkpoint_is_one_line_exit_2_on_two_ranks(whole, tmp_path, corrupt):
    """Every rank reaches the same verdict before the restore (whose contact rebuild is
    collective): one line, exit 2, no hang, also when only rank 1's rows are wrong."""
    import zipfile

    out = tmp_path / "run"
    _deck(out, **LONG)
    (out / "flyby.e").write_bytes((whole / "flyby.e").read_bytes())
    src = checkpoints_of(whole / "restart", "flyby")[0][1]
    bad = out / "bad.npz"
    with np.load(src) as data:
        arrays = {k: data[k] for k in data.files}
    if corrupt == "flip":
        raw = bytearray(src.read_bytes())
        with zipfile.ZipFile(src) as z:
            start = z.getinfo("np1/Velocity.npy").header_offset
        for k in range(8):
            raw[start + 300 + 16 * k] ^= 0xFF
        bad.write_bytes(bytes(raw))
    elif corrupt == "truncate":
        bad.write_bytes(src.read_bytes()[:1000])
    elif corrupt == "rank 1's ghost rows":
        np.savez(bad, **{k: v for k, v in arrays.items() if k != "r1/acceleration"})
    else:
        np.savez(bad, **{**arrays, "np1/Velocity": arrays["np1/Velocity"].astype(np.float32)})
    before = (out / "flyby.e").read_bytes()
    line = _one_error_line(mpirun(2, ["run", "flyby.yaml", "-q", "--restart", "bad.npz"], cwd=out))
    assert line.startswith("error: bad.npz: --restart: "), line
    assert (out / "flyby.e").read_bytes() == before and not (out / "flyby.partial.e").exists()


def test_a_folder_where_the_output_goes_is_one_line_exit_2_on_two_ranks(tmp_path):
    _deck(tmp_path)
    (tmp_path / "flyby.partial.e").mkdir()
    line = _one_error_line(mpirun(2, ["run", "flyby.yaml", "-q"], cwd=tmp_path))
    assert "flyby.partial.e" in line and "is a folder" in line, line
    assert not (tmp_path / "restart").exists()
