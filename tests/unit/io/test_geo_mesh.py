"""gmsh ``.geo`` meshing in a child process (peridyn/io/geo_mesh.py, gmsh_worker.py): the same
mesh as gmsh in-process; Merge/Include loops, Exit;, crashes, sizes set inside the script, a
mesh too large for memory and files without volumes are one-line input errors; Ctrl-C and
SIGTERM stop a run that is meshing, with no lock or output left behind."""
from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from numpy.testing import assert_array_equal

from peridyn.cli import main
from peridyn.core.errors import ExitCode, InputError

meshio = pytest.importorskip("meshio")
gmsh = pytest.importorskip("gmsh")
from peridyn.io import geo_mesh  # noqa: E402
from peridyn.io.geo_mesh import check_includes  # noqa: E402
from peridyn.io.meshio_mesh import _points, read_mesh  # noqa: E402

BOX = 'SetFactory("OpenCASCADE");\nBox(1) = {0, 0, 0, 2, 1, 1};\nPhysical Volume("Body") = {1};\n'
DECK = textwrap.dedent(
    """\
    Discretization:
      Type: "Mesh"
      Input Mesh File: "part.geo"
    Materials:
      Steel:
        Material Model: "Elastic"
        Density: 7800.0
        Bulk Modulus: 130.0e9
        Shear Modulus: 78.0e9
    Blocks:
      All:
        Block Names: "Body"
        Material: "Steel"
        Horizon: 0.5
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
    """
)


def case(folder: Path, geo: str | bytes, deck: str = DECK) -> Path:
    (folder / "part.geo").write_bytes(geo if isinstance(geo, bytes) else geo.encode())
    (folder / "deck.yaml").write_text(deck)
    return folder / "deck.yaml"


def one_line_error(deck: Path, capsys) -> str:
    """Run the deck; it must end with exit 2, one line on stderr, and leave no lock or output."""
    capsys.readouterr()
    assert main(["run", str(deck), "--output-dir", str(deck.parent), "-q", "--no-progress"]) == ExitCode.INPUT_ERROR
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert not list(deck.parent.glob("run*")), list(deck.parent.iterdir())  # no run.lock, no run.e
    return err[0]


def in_process(path: Path, mesh_size: float) -> "meshio.Mesh":
    """The mesh as gmsh makes it in this process, with the calls peridyn made before the worker."""
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.model.add("reference")
        gmsh.merge(str(path))
        gmsh.option.setNumber("Mesh.MeshSizeMax", mesh_size)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(path.with_suffix(".msh")))
    finally:
        gmsh.finalize()
    return meshio.read(path.with_suffix(".msh"))


def test_the_worker_makes_gmsh_s_own_mesh_bit_for_bit(tmp_path):
    geo = Path(__file__).parents[3] / "examples" / "meshed_plate_hole.geo"
    disc = read_mesh(geo, mesh_size=4.0)
    (tmp_path / "plate.geo").write_text(geo.read_text())
    ref = _points(in_process(tmp_path / "plate.geo", 4.0), geo, 1.0)
    assert disc.num_points > 1000
    assert_array_equal(disc.x, ref.x)
    assert_array_equal(disc.volume, ref.volume)
    assert_array_equal(disc.block_id, ref.block_id)
    assert disc.block_names == ref.block_names == {1: "Plate", 2: "GripLeft", 3: "GripRight"}
    assert disc.node_sets.keys() == ref.node_sets.keys()
    for name in disc.node_sets:
        assert_array_equal(disc.node_sets[name], ref.node_sets[name])


# ------------------------------------------------------------------------------------------------
# Merge and Include loops
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "files, top, words, where",
    [
        ({"a.geo": 'Point(1) = {0, 0, 0};\nMerge "a.geo";\n'}, "a.geo", "'a.geo' merges itself (Merge \"a.geo\")", "a.geo:2"),
        ({"a.geo": 'Include "./a.geo";\n'}, "a.geo", "'a.geo' includes itself", "a.geo:1"),
        ({"a.geo": '// Merge "a.geo";\nInclude "sub/b.geo";\n', "sub/b.geo": '/* Include\n "x.geo" */\nInclude "c.geo";\n',
          "sub/c.geo": 'Merge "../a.geo";  // back to the top\n'},
         "a.geo", "'a.geo' merges itself through 'b.geo', 'c.geo'", "c.geo:1"),
        ({"a.geo": 'Include "b.geo";\n', "b.geo": 'Include "b.geo";\n'}, "a.geo", "'a.geo' includes itself", "b.geo:1"),
    ],
)
def test_merge_and_include_loops_are_refused_before_gmsh(tmp_path, files, top, words, where):
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text(text)
    with pytest.raises(InputError) as info:
        check_includes(tmp_path / top)
    line = info.value.one_line()
    assert words in line and f"{where}: Discretization > Input Mesh File:" in line and "remove the" in line, line


def test_comments_diamonds_and_mesh_files_are_not_loops(tmp_path):
    (tmp_path / "a.geo").write_text('// Merge "a.geo";\n/* Include "a.geo"; */\nInclude "b.geo";\nInclude "c.geo";\nMerge "a.msh";\n'
                                    'Printf("Merge \\"a.geo\\"");\n')
    (tmp_path / "b.geo").write_text('Include "d.geo";\n')
    (tmp_path / "c.geo").write_text('Include "d.geo";\n')
    (tmp_path / "d.geo").write_text("lc = 1;\n")
    (tmp_path / "a.msh").write_text('Merge "a.geo";\n')  # a mesh file, not a script: not read
    check_includes(tmp_path / "a.geo")


def test_a_deck_whose_geo_merges_itself_is_one_line(tmp_path, capsys):
    line = one_line_error(case(tmp_path, BOX + 'Merge "part.geo";\n'), capsys)
    assert line.startswith(f"error: {tmp_path / 'part.geo'}:4: Discretization > Input Mesh File: 'part.geo' merges itself"), line


def test_a_loop_built_by_an_expression_is_an_input_error(tmp_path):
    """A name gmsh computes is not seen before gmsh: gmsh follows it until the file handles
    run out, in the child, which still reports."""
    (tmp_path / "part.geo").write_text('Merge StrCat("pa", "rt.geo");\n')
    with pytest.raises(InputError, match=r"gmsh could not mesh 'part.geo' \(Error: Unable to open file.*Merge or Include that leads back"):
        read_mesh(tmp_path / "part.geo")


# ------------------------------------------------------------------------------------------------
# Scripts that end gmsh, make no volume, or crash it
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("ending", ["Exit;\n", "Box(2) = {3, 0, 0, 1, 1, 1};\nExit;\nBox(3) = {5, 0, 0, 1, 1, 1};\n"])
def test_a_geo_that_exits_is_one_line_and_leaves_no_lock(tmp_path, capsys, ending):
    line = one_line_error(case(tmp_path, BOX + ending), capsys)
    assert "part.geo: Discretization > Input Mesh File: gmsh ended (exit status 0) before meshing 'part.geo'" in line, line
    assert "remove Exit;" in line, line


@pytest.mark.parametrize(
    "geo, words",
    [
        (b"", "the gmsh script 'part.geo' is empty (0 bytes)"),
        (b"\x00\xff\xfe\x01garbage\n", "gmsh could not mesh 'part.geo'"),
        ('SetFactory("OpenCASCADE");\nRectangle(1) = {0, 0, 0, 1, 1};\nMesh.MeshSizeMax = 1e-9;\n', "has no volume elements"),
        ('Merge "empty.msh";\n', "has no volume elements"),
    ],
)
def test_geo_without_volumes_or_unreadable_is_one_line(tmp_path, capsys, geo, words):
    (tmp_path / "empty.msh").write_bytes(b"")
    line = one_line_error(case(tmp_path, geo), capsys)
    assert "part.geo: Discretization > Input Mesh File:" in line and words in line, line


def fake_worker(monkeypatch, code: str) -> None:
    monkeypatch.setattr(geo_mesh, "_worker_command", lambda request: [sys.executable, "-c", code, str(request)])


@pytest.mark.parametrize(
    "code, words",
    [
        ("import os, signal; os.kill(os.getpid(), signal.SIGSEGV)", "gmsh crashed (signal 11, SIGSEGV) meshing 'part.geo'"),
        ("import os, signal; os.kill(os.getpid(), signal.SIGABRT)", "gmsh crashed (signal 6, SIGABRT) meshing 'part.geo'"),
        ("import os, signal; os.kill(os.getpid(), signal.SIGKILL)", "gmsh killed (by the system: out of memory?) (signal 9"),
        ("import sys; print('PETSC ERROR: out of luck'); sys.exit(3)", "gmsh ended (exit status 3) before meshing 'part.geo'"),
    ],
)
def test_a_dying_worker_is_an_input_error_naming_the_geo(tmp_path, monkeypatch, code, words):
    (tmp_path / "part.geo").write_text(BOX)
    fake_worker(monkeypatch, code)
    with pytest.raises(InputError) as info:
        read_mesh(tmp_path / "part.geo")
    assert info.value.file == str(tmp_path / "part.geo") and info.value.path == ("Discretization", "Input Mesh File")
    assert words in info.value.message, info.value.message


def test_a_crash_is_exit_2_from_the_command_line(tmp_path, capsys, monkeypatch):
    fake_worker(monkeypatch, "import os, signal; os.kill(os.getpid(), signal.SIGSEGV)")
    line = one_line_error(case(tmp_path, BOX), capsys)
    assert "part.geo: Discretization > Input Mesh File: gmsh crashed (signal 11, SIGSEGV)" in line and "Mesh.Algorithm" in line, line


@pytest.mark.parametrize("options", [
    "Mesh.Algorithm = 8; Mesh.RecombineAll = 1; Mesh.Algorithm3D = 9;",  # gmsh 4.15: a segfault
    "Mesh.Algorithm = 9; Mesh.RecombineAll = 1; Mesh.Algorithm3D = 9;",  # gmsh 4.15: an abort in PETSc
    "Mesh.Algorithm3D = 9; Mesh.Recombine3DAll = 1;",                      # gmsh 4.15: trihedra, no point type
])
def test_option_combinations_gmsh_cannot_handle_are_input_errors(tmp_path, options):
    (tmp_path / "part.geo").write_text(BOX + options + "\n")
    try:
        disc = read_mesh(tmp_path / "part.geo", mesh_size=0.3)
    except InputError as exc:  # what gmsh 4.15 does; the file named is the .geo, never a temporary one
        assert exc.file == str(tmp_path / "part.geo") and "part.geo" in exc.message, exc.one_line()
    else:  # a gmsh that meshes it makes a valid mesh
        assert abs(disc.volume.sum() - 2.0) < 1e-12


# ------------------------------------------------------------------------------------------------
# Sizes, estimates and memory
# ------------------------------------------------------------------------------------------------
BUILTIN_CUBE = "".join(f"Point({i + 1}) = {{{x}, {y}, {z}, 1e-6}};\n" for i, (x, y, z) in enumerate(
    [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)])) + "Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};\n" \
    "Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};\nExtrude {0, 0, 1} { Surface{1}; }\n"


@pytest.mark.parametrize(
    "script, deck_size, source",
    [
        ("Mesh.CharacteristicLengthMax = 1e-6;", None, "(Mesh.MeshSizeMax)"),
        ("Mesh.MeshSizeMax = 1e-6;", None, "(Mesh.MeshSizeMax)"),
        ("Mesh.MeshSizeMax = 0.5;", 1e-6, "('Mesh Size')"),
        # the deck's Mesh Size (Mesh.MeshSizeMax) only caps the size: these are smaller still
        ("Characteristic Length{PointsOf{Volume{1};}} = 1e-6;", 0.5, "(the characteristic length of point"),
        ("MeshSize{3} = 1e-6;", 0.5, "(the characteristic length of point 3)"),
        ("Field[1] = Box; Field[1].VIn = 1e-6; Field[1].VOut = 0.5; Field[1].XMax = 0.1; Background Field = 1;", 0.5,
         "(Field[1].VIn (Box))"),
        ("Field[1] = Threshold; Field[1].SizeMin = 1e-6; Field[1].SizeMax = 0.5;", 0.5, "(Field[1].SizeMin (Threshold))"),
        ("Mesh.MeshSizeFactor = 1e-6;", 0.5, "('Mesh Size' times Mesh.MeshSizeFactor 1e-06)"),
    ],
)
def test_a_size_set_in_the_geo_cannot_bypass_the_limit(tmp_path, script, deck_size, source):
    (tmp_path / "part.geo").write_text(BOX + script + "\n")
    with pytest.raises(InputError) as info:
        read_mesh(tmp_path / "part.geo", mesh_size=deck_size)
    line = info.value.one_line()
    assert "would give up to about" in line and source in line and "(the limit is 1e+07)" in line, line
    assert "PERIDYN_NO_LIMITS=1" in line and "increase" in line, line


def test_point_sizes_of_the_built_in_kernel_count(tmp_path):
    (tmp_path / "part.geo").write_text(BUILTIN_CUBE)
    with pytest.raises(InputError, match=r"1e-06 \(the characteristic length of point 1\) would give up to about 8.49e\+18 tetrahedra"):
        read_mesh(tmp_path / "part.geo")


def test_a_minimum_size_lifts_the_estimate(tmp_path):
    (tmp_path / "part.geo").write_text(BOX + "MeshSize{3} = 1e-6;\nMesh.MeshSizeMin = 0.25;\n")
    disc = read_mesh(tmp_path / "part.geo", mesh_size=0.5)
    assert abs(disc.volume.sum() - 2.0) < 1e-12


def test_the_limit_follows_the_memory(tmp_path, monkeypatch):
    (tmp_path / "part.geo").write_text(BOX)
    monkeypatch.setattr(geo_mesh, "available_memory", lambda: 200e6)  # room for about 1.8e5 tetrahedra
    monkeypatch.delenv("PERIDYN_NO_LIMITS", raising=False)
    with pytest.raises(InputError, match=r"would give up to about 2.12e\+06 tetrahedra in 'part.geo', about 2.02 GiB for gmsh, "
                       r"more than the 191 MiB of memory available; increase 'Mesh Size'"):
        read_mesh(tmp_path / "part.geo", mesh_size=0.02)


@pytest.mark.parametrize("poll", [geo_mesh.POLL_SECONDS, 5.0], ids=["polled", "done-before-the-first-poll"])
def test_no_limits_meshes_past_the_limit_with_a_warning(tmp_path, monkeypatch, caplog, poll):
    """The warning is given whether or not the parent polled while gmsh ran: a small mesh can be
    done before the first poll."""
    monkeypatch.setattr(geo_mesh, "POLL_SECONDS", poll)
    (tmp_path / "part.geo").write_text(BOX)
    monkeypatch.setattr(geo_mesh, "MAX_GEO_ELEMENTS", 100.0)
    monkeypatch.delenv("PERIDYN_NO_LIMITS", raising=False)
    with pytest.raises(InputError, match=r"a mesh size of 0.5 \('Mesh Size'\) would give up to about 136 tetrahedra in 'part.geo' "
                       r"\(the limit is 1e\+02\); increase 'Mesh Size', or set PERIDYN_NO_LIMITS=1"):
        read_mesh(tmp_path / "part.geo", mesh_size=0.5)
    monkeypatch.setenv("PERIDYN_NO_LIMITS", "1")
    with caplog.at_level(logging.WARNING, logger="peridyn.io.geo_mesh"):
        disc = read_mesh(tmp_path / "part.geo", mesh_size=0.5)
    assert abs(disc.volume.sum() - 2.0) < 1e-12
    assert any("PERIDYN_NO_LIMITS is set: meshing anyway" in r.getMessage() for r in caplog.records), caplog.text


def test_meshing_past_the_memory_is_stopped(tmp_path, monkeypatch):
    """``Mesh 3;`` in the script meshes while gmsh reads it, before any estimate: the memory
    watch stops it."""
    (tmp_path / "part.geo").write_text('SetFactory("OpenCASCADE");\nBox(1) = {0, 0, 0, 1, 1, 1};\nMesh.MeshSizeMax = 0.02;\nMesh 3;\n')
    monkeypatch.setattr(geo_mesh, "available_memory", lambda: 150e6)
    monkeypatch.delenv("PERIDYN_NO_LIMITS", raising=False)
    with pytest.raises(InputError, match=r"gmsh used more than 129 MiB meshing 'part.geo' \(of the 143 MiB available\) and was stopped"):
        read_mesh(tmp_path / "part.geo")


# ------------------------------------------------------------------------------------------------
# Ctrl-C and SIGTERM while gmsh works
# ------------------------------------------------------------------------------------------------
def children(pid: int) -> list[int]:
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="finds the child through /proc")
@pytest.mark.parametrize("signum, code", [(signal.SIGINT, ExitCode.INTERRUPTED), (signal.SIGTERM, 128 + signal.SIGTERM)])
def test_a_signal_stops_a_run_while_gmsh_meshes(tmp_path, signum, code):
    deck = case(tmp_path, 'SetFactory("OpenCASCADE");\nBox(1) = {0, 0, 0, 1, 1, 1};\nPhysical Volume("Body") = {1};\n'
                'Mesh.MeshSizeMax = 0.01;\n')  # minutes of meshing and gigabytes
    env = dict(os.environ, PERIDYN_NO_LIMITS="1", PYTHONFAULTHANDLER="1")  # meshing starts on any machine
    proc = subprocess.Popen([sys.executable, "-m", "peridyn", "run", str(deck), "-q", "--no-progress"], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not children(proc.pid) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        worker = children(proc.pid)
        assert worker, proc.communicate()
        time.sleep(1.0)  # gmsh has read the geometry and is meshing
        assert proc.poll() is None
        proc.send_signal(signum)
        try:
            _, err = proc.communicate(timeout=60)
        except subprocess.TimeoutExpired:  # once in a loaded full run: show where it hangs
            proc.send_signal(signal.SIGABRT)
            pytest.fail("the run did not stop within 60 s; its threads:\n" + proc.communicate(timeout=30)[1][-6000:])
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == code, err
    assert ("interrupted" if signum == signal.SIGINT else "meshing 'part.geo' was stopped by SIGTERM") in err, err
    assert not Path(f"/proc/{worker[0]}").exists()  # the worker is gone
    assert sorted(p.name for p in tmp_path.iterdir()) == ["deck.yaml", "part.geo"]  # no lock, no output
