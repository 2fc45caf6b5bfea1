"""io/exodus_merge.py: the per-rank pieces of a file joined into the file one process writes, bit
for bit (peridyn's pieces), or by global id (Peridigm's); chunks smaller than a piece; pieces
that are not of one run refused."""
from types import SimpleNamespace

import netCDF4
import numpy as np
import pytest

from peridyn.engine.output_pieces import RankPiece, pieces_of, rank_file, recover_pieces
from peridyn.io.exodus_merge import NODE_ORDER, merge_pieces
from peridyn.io.exodus_writer import ExodusBlock, ExodusWriter

N, STEPS = 53, 3
NODAL, ELEMENT, GLOBAL = ["DisplacementX", "DisplacementY"], ["Damage", "Volume"], ["Kinetic"]


def model(seed: int = 0):
    """N points in three blocks interleaved in mothership order (the middle block without
    Damage), node sets in no particular order with a repeated entry, gids that are not
    positions, and per-step values."""
    rng = np.random.default_rng(seed)
    block = rng.integers(0, 3, N)
    block[:3] = [0, 1, 2]
    sets = {"Left": rng.permutation(N)[:17], "Repeat": np.array([5, 2, 5, 40]), "Empty": np.zeros(0, np.int64)}
    x = rng.normal(size=(N, 3))
    gid = np.arange(N) * 3 + 7
    values = {name: rng.normal(size=(STEPS, N)) for name in NODAL + ELEMENT}
    glob = rng.normal(size=(STEPS, 1))
    return SimpleNamespace(block=block, sets=sets, x=x, gid=gid, values=values, glob=glob)


TRUTH = np.array([[True, True], [False, True], [True, True]])


def whole_file(m, path):
    """The file one process writes (engine/output.py's OutputWriter._open and write)."""
    nodes = [np.flatnonzero(m.block == b) for b in range(3)]
    blocks = [ExodusBlock(b + 1, f"block_{b + 1}", nodes[b]) for b in range(3)]
    with ExodusWriter(path, coords=m.x, node_num_map=m.gid + 1, blocks=blocks, node_sets=sorted(m.sets.items()),
                      nodal_vars=NODAL, element_vars=ELEMENT, global_vars=GLOBAL, truth_table=TRUTH) as w:
        for s in range(STEPS):
            element = {v: [m.values[v][s][nodes[b]] if TRUTH[b, i] else None for b in range(3)] for i, v in enumerate(ELEMENT)}
            w.write_step(0.1 * s, nodal={v: m.values[v][s] for v in NODAL}, element=element, glob={"Kinetic": m.glob[s, 0]})


def write_pieces(m, base, ranks: int, owner, steps=STEPS):
    """Each rank's piece as engine/output.py writes it on ``ranks`` ranks (points owned by
    ``owner``, stored locally in an arbitrary order)."""
    rng = np.random.default_rng(1)
    for r in range(ranks):
        mine = rng.permutation(np.flatnonzero(owner == r))  # the local order is the partition's, not the file's
        sim = SimpleNamespace(num_owned=mine.size, block_index=m.block[mine], mothership_of_local=mine,
                              blocks=[SimpleNamespace(block_id=b + 1, name=f"block_{b + 1}") for b in range(3)],
                              node_sets=m.sets, fields={"Model_Coordinates": m.x[mine]}, gid=m.gid[mine])
        piece = RankPiece(sim)
        with piece.writer(rank_file(base, ranks, r), nodal_vars=NODAL,
                          element_vars=ELEMENT, global_vars=GLOBAL, truth_table=TRUTH) as w:
            for s in range(steps if np.isscalar(steps) else steps[r]):
                element = {}
                for i, v in enumerate(ELEMENT):
                    cols = piece.block_values(piece.values(m.values[v][s][mine]))
                    element[v] = [c if TRUTH[b, i] else None for b, c in enumerate(cols)]
                w.write_step(0.1 * s, nodal={v: piece.values(m.values[v][s][mine]) for v in NODAL}, element=element,
                             glob={"Kinetic": m.glob[s, 0]})


def same_file(a, b, skip=("qa_records",)):
    with netCDF4.Dataset(a) as x, netCDF4.Dataset(b) as y:
        assert set(x.variables) == set(y.variables)
        assert {d: len(v) for d, v in x.dimensions.items()} == {d: len(v) for d, v in y.dimensions.items()}
        for name in x.variables:
            if name not in skip:
                np.testing.assert_array_equal(np.asarray(x[name][:]), np.asarray(y[name][:]), err_msg=name)


@pytest.mark.parametrize("ranks, chunk", [(1, 1 << 20), (3, 1 << 20), (3, 7), (4, 1)])
def test_peridyns_pieces_join_to_the_one_process_file_bit_for_bit(tmp_path, ranks, chunk):
    m = model()
    whole_file(m, tmp_path / "whole.e")
    owner = np.random.default_rng(2).integers(0, ranks, N)
    owner[:ranks] = np.arange(ranks)
    write_pieces(m, tmp_path / "run.e", ranks, owner)
    pieces = pieces_of(tmp_path / "run.e")[1]
    assert [p.name for p in pieces] == [f"run.e.{ranks}.{r}" for r in range(ranks)]
    with netCDF4.Dataset(pieces[-1]) as ds:  # a piece holds its own points only
        assert len(ds.dimensions["num_nodes"]) == int(np.sum(owner == ranks - 1)) and NODE_ORDER in ds.variables
    assert merge_pieces(pieces, tmp_path / "run.e", chunk=chunk) == STEPS
    same_file(tmp_path / "run.e", tmp_path / "whole.e")


def test_peridigms_pieces_are_placed_by_global_id_with_node_sets_in_ascending_order(tmp_path):
    m = model(5)
    m.gid = np.arange(N)  # Peridigm's pieces: ids 1..N
    whole = tmp_path / "whole.e"
    m_sorted = SimpleNamespace(**{**vars(m), "sets": {k: np.sort(v) for k, v in m.sets.items()}})
    whole_file(m_sorted, whole)
    owner = np.arange(N) % 2
    write_pieces(m, tmp_path / "run.e", 2, owner)
    for p in pieces_of(tmp_path / "run.e")[1]:  # drop what peridyn adds
        with netCDF4.Dataset(p, "a") as ds:
            ds.renameVariable(NODE_ORDER, "unused_order")
            for k in range(1, 4):
                if f"peridyn_ns_order{k}" in ds.variables:
                    ds.renameVariable(f"peridyn_ns_order{k}", f"unused_ns{k}")
    merge_pieces(pieces_of(tmp_path / "run.e")[1], tmp_path / "run.e", chunk=5)
    same_file(tmp_path / "run.e", whole)


def test_pieces_of_other_runs_or_a_missing_piece_are_refused(tmp_path):
    m = model()
    owner = np.arange(N) % 3
    write_pieces(m, tmp_path / "a.e", 3, owner)
    pieces = pieces_of(tmp_path / "a.e")[1]
    with pytest.raises(ValueError, match="do not hold node"):
        merge_pieces(pieces[:2], tmp_path / "out.e")
    write_pieces(m, tmp_path / "b.e", 3, owner, steps=[3, 2, 3])
    with pytest.raises(ValueError, match="frames"):
        merge_pieces(pieces_of(tmp_path / "b.e")[1], tmp_path / "out.e")


def test_a_killed_runs_pieces_are_joined_to_the_frames_every_piece_holds(tmp_path):
    m = model()
    owner = np.arange(N) % 3
    write_pieces(m, tmp_path / "run.partial.e", 3, owner, steps=[3, 2, 3])
    assert recover_pieces(tmp_path / "run.partial.e") == 2
    assert not pieces_of(tmp_path / "run.partial.e")[1]
    with netCDF4.Dataset(tmp_path / "run.partial.e") as ds:
        assert len(ds.dimensions["time_step"]) == 2
        np.testing.assert_array_equal(np.asarray(ds["vals_nod_var1"][1]), m.values["DisplacementX"][1])


def test_peridyn_merge_joins_pieces_and_names_a_result_without_pieces_in_one_line(tmp_path, capsys):
    from peridyn.cli import main

    m = model()
    whole_file(m, tmp_path / "whole.e")
    write_pieces(m, tmp_path / "run.e", 2, np.arange(N) % 2)
    assert main(["merge", str(tmp_path / "run.e"), "-q"]) == 0
    same_file(tmp_path / "run.e", tmp_path / "whole.e")
    assert len(pieces_of(tmp_path / "run.e")[1]) == 2  # kept, as epu keeps them
    before = (tmp_path / "run.e").read_bytes()
    assert main(["merge", str(tmp_path / "other.e")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "other.e" in err[0] and "no pieces" in err[0], err
    (tmp_path / "run.e.2.1").write_bytes(b"CDF\x02 not a piece")  # a broken piece: refused, run.e left as it was
    assert main(["merge", str(tmp_path / "run.e")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "run.e.2.1 is not a readable Exodus piece" in err[0], err
    assert (tmp_path / "run.e").read_bytes() == before and not list(tmp_path.glob(".run*"))
