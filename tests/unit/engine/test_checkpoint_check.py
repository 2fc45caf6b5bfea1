"""A checkpoint that cannot be continued (torn, corrupted, an array missing, renamed, reshaped
or of another dtype, NaN where no state has one, metadata of the wrong type) is refused with one
line naming the checkpoint file and --restart, exit 2, before the output is touched (issue #33).
The corruptions are drawn by hypothesis from a real checkpoint of a tiny deck."""
import itertools
import json
import shutil
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.engine.checkpoint_check import FINITE_FIELDS
from peridyn.engine.restart import checkpoints_of

CUBE = textwrap.dedent(
    """
    Discretization:
      Type: "PdQuickGrid"
      NeighborhoodType: "Spherical"
      TensorProduct3DMeshGenerator:
        Type: "PdQuickGrid"
        X Origin: 0.0
        Y Origin: 0.0
        Z Origin: 0.0
        X Length: 6.0
        Y Length: 3.0
        Z Length: 3.0
        Number Points X: 6
        Number Points Y: 3
        Number Points Z: 3
    Materials:
      Steel:
        Material Model: "Elastic"
        Density: 7800.0
        Bulk Modulus: 130.0e9
        Shear Modulus: 78.0e9
    Damage Models:
      D:
        Damage Model: "Critical Stretch"
        Critical Stretch: 0.5
    Blocks:
      All:
        Block Names: "block_1"
        Material: "Steel"
        Damage Model: "D"
        Horizon: 3.1
    Boundary Conditions:
      All Node Set: "{points}"
      Kick:
        Type: "Initial Velocity"
        Node Set: "All Node Set"
        Coordinate: "x"
        Value: "x"
    Solver:
      Final Time: 2.0e-5
      Verlet:
        Fixed dt: 1.0e-6
    Output:
      Output Filename: "cube"
      Output Frequency: 5
      Output Variables:
        Displacement: true
        Damage: true
    Restart:
      Restart Frequency: 10
      Keep: 10
    """
).format(points=" ".join(str(i) for i in range(1, 55)))


def write_cube(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    deck = folder / "cube.yaml"
    deck.write_text(CUBE)
    return deck


def run(folder: Path, *extra: str) -> int:
    return main(["run", str(folder / "cube.yaml"), "--output-dir", str(folder), "-q", "--no-progress", *extra])


@pytest.fixture(scope="module")
def cube_run(tmp_path_factory) -> Path:
    """A finished run of the cube: checkpoints after steps 10 and 20 and at the end."""
    out = tmp_path_factory.mktemp("cube")
    write_cube(out)
    assert run(out) == ExitCode.OK
    assert [p for p, _ in checkpoints_of(out / "restart", "cube")] == [(0, 10), (0, 20), (1, 0)]
    return out


@pytest.fixture(scope="module")
def arrays(cube_run) -> dict[str, np.ndarray]:
    """The arrays of the checkpoint after step 10, ``meta`` included."""
    with np.load(cube_run / "restart" / "cube.000.0000000010.npz") as data:
        return {k: data[k] for k in data.files}


def refused(folder: Path, bad: Path, capsys) -> None:
    """``--restart bad`` is exit 2 with one line naming the file and --restart, and the output
    file is left byte for byte as it was."""
    before = (folder / "cube.e").read_bytes()
    capsys.readouterr()
    assert run(folder, "--restart", str(bad)) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: {bad}: --restart: "), err
    assert "Traceback" not in err
    assert (folder / "cube.e").read_bytes() == before
    assert not (folder / "cube.partial.e").exists()


_CASES = itertools.count()


def fresh(cube_run: Path, tmp_path: Path) -> Path:
    """A copy of the finished run's folder (one per hypothesis example)."""
    out = tmp_path / f"case{next(_CASES)}"
    shutil.copytree(cube_run, out)
    return out


SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@SETTINGS
@given(data=st.data())
def test_flipped_bytes_are_refused_or_change_nothing_the_run_reads(cube_run, tmp_path, capsys, data):
    """8 bytes flipped at random offsets: refused (a CRC, a header), or, where they fall on bytes
    no reader checks (a timestamp), the run continues to the same file as from the intact one."""
    out = fresh(cube_run, tmp_path)
    good = (cube_run / "restart" / "cube.000.0000000010.npz").read_bytes()
    raw = bytearray(good)
    for offset in data.draw(st.lists(st.integers(0, len(raw) - 1), min_size=8, max_size=8, unique=True)):
        raw[offset] ^= data.draw(st.integers(1, 255))
    bad = out / "bad.npz"
    bad.write_bytes(bytes(raw))
    capsys.readouterr()
    status = run(out, "--restart", str(bad))
    err = capsys.readouterr().err
    if status == ExitCode.OK:
        assert _same_values(out, cube_run)
        return
    assert status == ExitCode.INPUT_ERROR, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: {bad}: --restart: ") and "earlier checkpoint" in lines[0], err


def _same_values(a: Path, b: Path) -> bool:
    from tests.unit.engine.test_restart import exodus_values

    va, vb = exodus_values(a / "cube.e"), exodus_values(b / "cube.e")
    return va.keys() == vb.keys() and all(np.array_equal(va[k], vb[k]) for k in va)


@SETTINGS
@given(fraction=st.floats(0.0, 0.9999))
def test_a_checkpoint_cut_short_anywhere_is_refused(cube_run, tmp_path, capsys, fraction):
    out = fresh(cube_run, tmp_path)
    good = (cube_run / "restart" / "cube.000.0000000010.npz").read_bytes()
    bad = out / "torn.npz"
    bad.write_bytes(good[: int(fraction * len(good))])
    refused(out, bad, capsys)


def _mutations(arrays: dict[str, np.ndarray]):
    keys = sorted(arrays)
    floats = sorted(k for k in keys if arrays[k].dtype.kind == "f" and (k.split("/")[-1] in FINITE_FIELDS or k == "acceleration"))
    return st.one_of(
        st.tuples(st.just("delete"), st.sampled_from(keys)),
        st.tuples(st.just("rename"), st.sampled_from(keys)),
        st.tuples(st.just("drop a row"), st.sampled_from([k for k in keys if arrays[k].ndim >= 1 and arrays[k].shape[0] > 0])),
        st.tuples(st.just("add a column"), st.sampled_from([k for k in keys if k != "meta"])),
        st.tuples(st.sampled_from(["float32", "int32", "int64", "float64", "uint8", "U3", "bool"]), st.sampled_from([k for k in keys if k != "meta"])),
        st.tuples(st.sampled_from(["nan", "inf", "-inf"]), st.sampled_from(floats)),
    )


@SETTINGS
@given(data=st.data())
def test_an_array_deleted_renamed_reshaped_retyped_or_not_finite_is_refused(cube_run, arrays, tmp_path, capsys, data):
    what, key = data.draw(_mutations(arrays))
    edited = dict(arrays)
    a = edited[key]
    if what == "delete":
        del edited[key]
    elif what == "rename":
        edited[key + "_old"] = edited.pop(key)
    elif what == "drop a row":
        edited[key] = a[:-1]
    elif what == "add a column":
        edited[key] = np.stack([a, a], axis=-1)
    elif what in ("nan", "inf", "-inf"):
        a = a.copy()
        a.reshape(-1)[data.draw(st.integers(0, a.size - 1))] = float(what)
        edited[key] = a
    else:
        if np.dtype(what) == a.dtype:
            what = "float32" if a.dtype != np.float32 else "float64"
        edited[key] = a.astype(what)
    out = fresh(cube_run, tmp_path)
    bad = out / "edited.npz"
    np.savez(bad, **edited)
    refused(out, bad, capsys)


#: metadata values a checkpoint of this layout never has
BAD_META = {
    "format": [0, 2, "1", None],
    "deck_hash": [None, 7],
    "ranks": [0, -1, "1", 1.5, None],
    "num_global": [-1, 53, "54", None],
    "num_bonds_global": [-1, 1, None],
    "section": [-1, 2, "0", None],
    "sections": [0, 5, None],
    "step": [-1, 1.5, "10", None],
    "time": [float("nan"), float("inf"), "t", None],
    "time_prev": [float("nan"), None],
    "time_step": [-1.0, float("inf"), None],
    "dt": [0.0, -1e-6, float("nan"), "x"],
    "nonlinear_iterations": [-1, None],
    "fields": [None, [], {"Velocity": "edge"}, {}],
    "two_step": [None, "Damage", ["Nothing"], []],
    "writers": [None, [], [{"section": "Output"}], [{"section": "Output", "count": 1, "frames": 9}], [{"section": "Other", "count": 11, "frames": 3}]],
    "monitor": [None, {}, {"dt": "x"}],
    "contact": [7, {"capacity": -1}],
}


@SETTINGS
@given(data=st.data())
def test_metadata_of_the_wrong_type_or_range_is_refused(cube_run, arrays, tmp_path, capsys, data):
    key = data.draw(st.sampled_from(sorted(BAD_META)))
    meta = json.loads(str(arrays["meta"]))
    if data.draw(st.booleans()):
        meta.pop(key)
    else:
        meta[key] = data.draw(st.sampled_from(BAD_META[key]))
    out = fresh(cube_run, tmp_path)
    bad = out / "meta.npz"
    np.savez(bad, **{**arrays, "meta": np.array(json.dumps(meta))})
    refused(out, bad, capsys)


@pytest.mark.parametrize("meta", ["{", "[1, 2]", "null"])
def test_metadata_that_is_not_a_json_object_is_refused(cube_run, arrays, tmp_path, capsys, meta):
    out = fresh(cube_run, tmp_path)
    bad = out / "meta.npz"
    np.savez(bad, **{**arrays, "meta": np.array(meta)})
    refused(out, bad, capsys)


def test_an_object_array_is_refused_without_unpickling_it(cube_run, arrays, tmp_path, capsys):
    out = fresh(cube_run, tmp_path)
    bad = out / "pickle.npz"
    np.savez(bad, **{**arrays, "np1/Volume": np.array([object()] * 54, dtype=object)})
    refused(out, bad, capsys)


def test_a_folder_or_a_missing_file_given_as_the_checkpoint_is_refused(cube_run, tmp_path, capsys):
    out = fresh(cube_run, tmp_path)
    refused(out, out / "restart", capsys)
    refused(out, out / "nothing.npz", capsys)


def test_an_intact_copy_of_the_checkpoint_continues(cube_run, arrays, tmp_path):
    """The refusals above come from the corruption: the same arrays saved again continue."""
    out = fresh(cube_run, tmp_path)
    np.savez(out / "copy.npz", **arrays)
    assert run(out, "--restart", str(out / "copy.npz")) == ExitCode.OK
    assert _same_values(out, cube_run)


@pytest.mark.parametrize("corrupt", ["flip", "truncate", "drop Velocity"])
def test_the_command_exits_2_with_one_line_on_stderr(cube_run, arrays, tmp_path, corrupt):
    out = fresh(cube_run, tmp_path)
    bad = out / "bad.npz"
    good = (cube_run / "restart" / "cube.000.0000000010.npz").read_bytes()
    if corrupt == "flip":
        with zipfile.ZipFile(cube_run / "restart" / "cube.000.0000000010.npz") as z:
            info = z.getinfo("np1/Velocity.npy")
        raw = bytearray(good)
        for k in range(8):  # inside the member's data: its CRC no longer matches
            raw[info.header_offset + 200 + 8 * k] ^= 0xFF
        bad.write_bytes(bytes(raw))
    elif corrupt == "truncate":
        bad.write_bytes(good[: len(good) // 2])
    else:
        np.savez(bad, **{k: v for k, v in arrays.items() if k != "np1/Velocity"})
    proc = subprocess.run([sys.executable, "-m", "peridyn", "run", "cube.yaml", "-q", "--no-progress", "--restart", "bad.npz"],
                          cwd=out, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: bad.npz: --restart: "), proc.stderr
    assert "earlier checkpoint" in lines[0] and "without --restart" in lines[0]


def test_every_floating_field_of_the_checkpoint_must_be_finite(cube_run, arrays, tmp_path, capsys):
    """A NaN in a field outside FINITE_FIELDS (the model's Weighted_Volume, Dilatation, ...) is
    refused too: no field of a state a run reached holds one."""
    others = sorted(k for k, a in arrays.items() if a.dtype.kind == "f" and "/" in k and not k.startswith("contact/")
                    and k.split("/")[-1] not in FINITE_FIELDS)
    assert "np1/Weighted_Volume" in others
    for key in others:
        a = arrays[key].copy()
        a.reshape(-1)[0] = np.nan
        out = fresh(cube_run, tmp_path)
        bad = out / "nan.npz"
        np.savez(bad, **{**arrays, key: a})
        refused(out, bad, capsys)


@pytest.mark.parametrize("key", ["acceleration", "np1/Velocity", "np1/Displacement", "np1/Weighted_Volume"])
def test_a_finite_value_too_large_to_square_is_refused_naming_the_array(cube_run, arrays, tmp_path, capsys, key):
    a = arrays[key].copy()
    a.reshape(-1)[3] = -1e308
    out = fresh(cube_run, tmp_path)
    bad = out / "huge.npz"
    np.savez(bad, **{**arrays, key: a})
    refused(out, bad, capsys)
    out2 = fresh(cube_run, tmp_path)
    shutil.copy(bad, out2 / "huge.npz")
    assert run(out2, "--restart", str(out2 / "huge.npz")) == ExitCode.INPUT_ERROR
    assert f"{key} holds a value of magnitude 1e+308" in capsys.readouterr().err



ELASTIC = CUBE.replace('    Damage Model: "D"\n', "").replace("    Damage: true\n", "")


def test_a_model_without_bond_fields_checks_its_bonds_by_digest_and_gathers_no_key(tmp_path, capsys):
    """No bond field to place: no bond keys are stored (they were most of such a checkpoint), a
    digest of the bonds is; the run continues from it to the same results, and a digest that is
    not this model's bonds' is refused in one line."""
    from peridyn.io.exodus_reader import read_results

    assert ELASTIC.count("Damage") == 2  # the damage model is defined, no block uses it, no Damage output
    out = tmp_path / "run"
    out.mkdir()
    (out / "cube.yaml").write_text(ELASTIC)
    assert run(out) == ExitCode.OK
    ckpt = out / "restart" / "cube.000.0000000010.npz"
    with np.load(ckpt) as data:
        stored = {k: data[k] for k in data.files}
    meta = json.loads(str(stored["meta"]))
    assert "bond_keys" not in stored and len(meta["bond_digest"]) == 16
    whole = read_results(out / "cube.e")
    assert run(out, "--restart", str(ckpt)) == ExitCode.OK
    again = read_results(out / "cube.e")
    np.testing.assert_array_equal(again["times"], whole["times"])
    np.testing.assert_array_equal(again["nodal"]["DisplacementX"], whole["nodal"]["DisplacementX"])
    flipped = dict(meta, bond_digest=f"{int(meta['bond_digest'], 16) ^ 1:016x}")
    bad = out / "edited.npz"
    np.savez(bad, **{**stored, "meta": np.array(json.dumps(flipped))})
    capsys.readouterr()
    assert run(out, "--restart", str(bad)) == ExitCode.INPUT_ERROR
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "its bonds are not this model's" in lines[0], lines


@pytest.mark.parametrize("how", ["deleted", "renamed"])
def test_an_array_missing_from_a_section_start_checkpoint_is_refused(cube_run, tmp_path, capsys, how):
    """At a section's start the acceleration is one a restart could compute afresh: its absence
    must still be refused, as the checkpoint lists every array it was written with."""
    out = fresh(cube_run, tmp_path)
    with np.load(out / "restart" / "cube.001.0000000000.npz") as data:
        stored = {k: data[k] for k in data.files}
    assert "acceleration" in json.loads(str(stored["meta"]))["arrays"]
    moved = stored.pop("acceleration")
    if how == "renamed":
        stored["acceleration_x"] = moved
    bad = out / "gone.npz"
    np.savez(bad, **stored)
    refused(out, bad, capsys)
