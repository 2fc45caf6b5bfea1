"""Peridigm's pre-split meshes (io/exodus_pieces.py, engine/mesh_parts.py): the pieces of a mesh,
each read alone and put together, are the whole mesh's points, blocks and node sets in its
order; the pieces are found where Peridigm looks (the working folder), then beside the deck."""
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from peridyn.core.errors import InputError
from peridyn.engine.mesh_parts import assemble
from peridyn.io.exodus_mesh import ExodusMesh, ExodusMeshParams, read_exodus_mesh
from peridyn.io.exodus_pieces import find_pieces, piece_counts, piece_path, read_exodus_piece
from peridyn.testing.exodus_pieces import split_exodus, write_box_mesh

SETS = {"Left": (0, 0.0), "Right": (0, 6.0), "Middle": (0, 3.0)}


def box(tmp_path: Path, blocks: int = 2) -> Path:
    return write_box_mesh(tmp_path / "box.g", (6, 3, 2), 1.0, blocks=blocks, node_sets=SETS)


def owners(n: int, ranks: int, how: str) -> np.ndarray:
    if how == "slabs":
        return np.arange(n) * ranks // n
    return np.random.default_rng(3).integers(0, ranks, n)  # scattered: every piece holds bits of every block


@pytest.mark.parametrize("ranks, how", [(2, "slabs"), (3, "scattered"), (4, "scattered")])
def test_pieces_put_together_are_the_whole_mesh(tmp_path, ranks, how):
    whole = read_exodus_mesh(box(tmp_path))
    pieces = split_exodus(tmp_path / "box.g", owners(whole.num_points, ranks, how), ranks)
    assert [p.name for p in pieces] == [f"box.g.{ranks}.{r}" for r in range(ranks)]
    disc = assemble([read_exodus_piece(p) for p in pieces])
    assert_array_equal(disc.gid, whole.gid)
    assert_array_equal(disc.x, whole.x)
    assert_array_equal(disc.volume, whole.volume)
    assert_array_equal(disc.block_id, whole.block_id)
    assert disc.block_names == whole.block_names and list(disc.block_names) == list(whole.block_names)
    assert disc.min_element_radius == whole.min_element_radius
    assert set(disc.node_sets) == set(whole.node_sets) == set(SETS)
    for name in SETS:
        assert_array_equal(disc.node_sets[name], whole.node_sets[name], err_msg=name)


def test_a_piece_holds_its_own_points_with_global_ids(tmp_path):
    whole = read_exodus_mesh(box(tmp_path))
    owner = owners(whole.num_points, 2, "scattered")
    split_exodus(tmp_path / "box.g", owner, 2)
    part = read_exodus_piece(tmp_path / "box.g.2.1")
    assert sorted(part.points.gid) == sorted(whole.gid[owner == 1])
    assert part.points.node_sets == {}
    keys, gids = part.node_set_pairs["Left"]
    assert set(gids) <= set(whole.gid[whole.node_sets["Left"]]) and keys.size == gids.size


def test_an_empty_piece_is_read(tmp_path):
    whole = read_exodus_mesh(box(tmp_path, blocks=1))
    owner = np.zeros(whole.num_points, dtype=np.int64)
    split_exodus(tmp_path / "box.g", owner, 2)
    part = read_exodus_piece(tmp_path / "box.g.2.1")
    assert part.points.num_points == 0
    disc = assemble([read_exodus_piece(tmp_path / "box.g.2.0"), part])
    assert_array_equal(disc.x, whole.x)


def test_pieces_are_looked_for_in_the_working_folder_then_beside_the_deck(tmp_path, monkeypatch):
    deck_dir = tmp_path / "case"
    run_dir = deck_dir / "np2"
    run_dir.mkdir(parents=True)
    whole = read_exodus_mesh(box(deck_dir))
    split_exodus(deck_dir / "box.g", owners(whole.num_points, 2, "slabs"), 2)
    monkeypatch.chdir(run_dir)
    assert find_pieces("box.g", deck_dir, 2) == deck_dir / "box.g"  # only beside the deck
    for r in range(2):
        (deck_dir / f"box.g.2.{r}").rename(run_dir / f"box.g.2.{r}")
    assert find_pieces("box.g", deck_dir, 2) == run_dir / "box.g"  # where Peridigm runs
    assert find_pieces("box.g", deck_dir, 3) is None
    assert find_pieces("box.g", deck_dir, 1) is None
    (run_dir / "box.g.2.1").unlink()
    assert find_pieces("box.g", deck_dir, 2) is None  # not all of them


def test_zero_padded_piece_names_are_found(tmp_path):
    whole = read_exodus_mesh(box(tmp_path))
    split_exodus(tmp_path / "box.g", np.arange(whole.num_points) % 10, 10)
    (tmp_path / "box.g.10.3").rename(tmp_path / "box.g.10.03")
    assert piece_path(tmp_path / "box.g", 10, 3) == tmp_path / "box.g.10.03"
    assert piece_path(tmp_path / "box.g", 10, 4) == tmp_path / "box.g.10.4"
    assert find_pieces("box.g", tmp_path, 10) == tmp_path / "box.g"


def test_a_missing_whole_mesh_with_pieces_for_another_rank_count_says_so(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    whole = read_exodus_mesh(box(tmp_path))
    split_exodus(tmp_path / "box.g", owners(whole.num_points, 3, "slabs"), 3)
    (tmp_path / "box.g").unlink()
    assert piece_counts("box.g", tmp_path) == [3]
    reader = ExodusMesh(ExodusMeshParams.model_validate({"Input Mesh File": "box.g"}), deck_dir=tmp_path)
    assert reader.read_part(0, 2) is None
    with pytest.raises(InputError, match=r"'box.g' not found; there are pieces of it for 3 ranks.*mpiexec -n 3"):
        reader.read()
    part = reader.read_part(1, 3)
    assert part is not None and part.points.num_points > 0


def test_a_damaged_piece_is_bad_input(tmp_path):
    whole = read_exodus_mesh(box(tmp_path))
    split_exodus(tmp_path / "box.g", owners(whole.num_points, 2, "slabs"), 2)
    (tmp_path / "box.g.2.1").write_bytes(b"not a netCDF file")
    with pytest.raises(InputError, match=r"mesh piece 'box.g.2.1' is not a readable Exodus II"):
        read_exodus_piece(tmp_path / "box.g.2.1")
    (tmp_path / "box.g.2.1").write_bytes(b"CDF\x02" + b"\0" * 20)  # netCDF without Exodus' dimensions
    with pytest.raises(InputError, match=r"box.g.2.1: not an Exodus II file"):
        read_exodus_piece(tmp_path / "box.g.2.1")


def test_an_element_in_two_pieces_is_bad_input(tmp_path):
    whole = read_exodus_mesh(box(tmp_path))
    split_exodus(tmp_path / "box.g", owners(whole.num_points, 2, "slabs"), 2)
    a = read_exodus_piece(tmp_path / "box.g.2.0")
    with pytest.raises(InputError, match=r"is in more than one piece"):
        assemble([a, a])


def test_a_mesh_name_with_glob_characters_finds_its_pieces(tmp_path):
    path = write_box_mesh(tmp_path / "part[1].g", (4, 2, 2), 1.0, node_sets=SETS)
    split_exodus(path, owners(16, 2, "slabs"), 2)
    path.unlink()
    assert piece_counts("part[1].g", tmp_path) == [2]
    assert find_pieces("part[1].g", tmp_path, 2) == tmp_path / "part[1].g"
