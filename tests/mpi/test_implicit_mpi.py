"""The implicit solvers under MPI: QuasiStatic, NOXQuasiStatic and Implicit decks give the serial
results on 2 and 3 ranks (to round-off), the distributed Krylov solvers, the direct solver on rank
0 and the block-Jacobi (AMG per rank) preconditioner agree with the serial solvers on the same
tangent, and a rank that owns no points takes part in every collective call."""
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from peridyn.deck.files import dump_yaml
from peridyn.io.exodus_reader import read_results
from peridyn.testing import build_simulation, cube_deck
from peridyn.testing.mpi import MPIEXEC, mpirun, requires_mpi

pytestmark = [pytest.mark.mpi, requires_mpi]

LPS = {"Material Model": "Elastic", "Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 80.0e9}
BOND_BASED = {"Material Model": "Elastic Bond Based", "Density": 7800.0, "Bulk Modulus": 160.0e9}


# ------------------------------------------------------------------------------------------------
# decks
# ------------------------------------------------------------------------------------------------
def box(material, shape, horizon=2.015, **kw) -> dict:
    """A PdQuickGrid box of unit spacing (shape = points per direction), one block."""
    return cube_deck(material, shape=shape, horizon_factor=horizon, **kw)


def bar(solver: dict, *, material=LPS, shape=(8, 3, 3), pull="0.002*t", body_force=None, damage=None, clamp="xyz") -> dict:
    """A bar clamped at x < 1 and pulled along x at x > shape[0] - 1 (or loaded by a body
    force), with an output of every step."""
    tree = box(material, shape, damage=damage)
    sim = build_simulation(tree)
    x, gid = sim.discretization.x, sim.discretization.gid
    ids = lambda mask: " ".join(str(g + 1) for g in gid[mask])  # noqa: E731
    bcs = {"Left Node Set": ids(x[:, 0] < 1.0), "Right Node Set": ids(x[:, 0] > shape[0] - 1.0), "All Node Set": ids(x[:, 0] > -1.0)}
    for c in clamp:
        bcs[f"L{c}"] = {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": c, "Value": "0.0"}
    if pull is not None:
        bcs["RX"] = {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "x", "Value": pull}
    if body_force is not None:
        bcs["B"] = {"Type": "Body Force", "Node Set": "All Node Set", "Coordinate": "z", "Value": body_force}
    tree["Boundary Conditions"] = bcs
    tree["Solver"] = solver
    variables = {"Displacement": True, "Velocity": True, "Force": True, "Dilatation": True, "Nonlinear_Solver_Iterations": True}
    if damage is not None:
        variables["Damage"] = True
    tree["Output"] = {"Output Filename": "out", "Output Frequency": 1, "Output Variables": variables}
    return tree


def qs(**keys) -> dict:
    solver = {"Initial Time": 0.0, "Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": 3, "Relative Tolerance": 1e-8, **keys}}
    return solver


def nox(direction: dict, preconditioner=None, line_search="Polynomial") -> dict:
    solver = {
        "Initial Time": 0.0,
        "Final Time": 1.0,
        "NOXQuasiStatic": {
            "Number of Load Steps": 2,
            "Max Solver Iterations": 50,
            "Relative Tolerance": 1.0e-9,
            "Direction": direction,
            "Line Search": {"Method": line_search},
        },
    }
    if preconditioner is not None:
        solver["Peridigm Preconditioner"] = preconditioner
    return solver


MATRIX_FREE = {"Method": "Newton", "Newton": {"Linear Solver": {"Jacobian Operator": "Matrix-Free", "Preconditioner": "User Defined"}}}
NEWTON_JACOBI = {
    "Method": "Newton",
    "Newton": {"Linear Solver": {"Preconditioner": "AztecOO", "Aztec Preconditioner": "Jacobi", "Steps": 2}},
}
NEWTON_ILU = {"Method": "Newton", "Newton": {"Linear Solver": {"Preconditioner": "AztecOO"}}}
NLCG = {
    "Method": "NonlinearCG",
    "Nonlinear CG": {
        "Restart Frequency": 15,
        "Precondition": "On",
        "Linear Solver": {"Preconditioner": "AztecOO", "Aztec Preconditioner": "Jacobi", "AztecOO Preconditioner Iterations": 5},
    },
}
IMPLICIT = {"Initial Time": 0.0, "Final Time": 5.0e-5, "Implicit": {"Fixed dt": 1.0e-5, "Absolute Tolerance": 1.0e-12}}


# ------------------------------------------------------------------------------------------------
def run_deck(tree: dict, folder: Path, ranks: int) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "deck.yaml").write_text(dump_yaml(tree))
    proc = mpirun(ranks, ["run", "deck.yaml", "-q"], folder)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert sorted(p.name for p in folder.glob("out*.e*")) == ["out.e"]  # one merged file
    return folder / "out.e"


def assert_same_results(a: Path, b: Path, rtol: float) -> None:
    """Every variable of the two files agrees to ``rtol`` relative to the largest value of that
    variable (all components of a vector together); the iteration counter exactly."""
    ra, rb = read_results(a), read_results(b)
    np.testing.assert_array_equal(ra["times"], rb["times"])
    np.testing.assert_array_equal(ra["node_num_map"], rb["node_num_map"])
    for kind in ("nodal", "element", "global"):
        assert set(ra[kind]) == set(rb[kind])
        scales: dict[str, float] = {}
        for name, y in rb[kind].items():
            base = name[:-1] if name[-1:] in "XYZ" else name
            scales[base] = max(scales.get(base, 0.0), float(np.nanmax(np.abs(y))) if np.size(y) else 0.0)
        for name in ra[kind]:
            x, y = np.asarray(ra[kind][name]), np.asarray(rb[kind][name])
            if name == "Nonlinear_Solver_Iterations":
                np.testing.assert_array_equal(x, y, err_msg=name)
                continue
            scale = scales[name[:-1] if name[-1:] in "XYZ" else name]
            np.testing.assert_allclose(x, y, rtol=0, atol=rtol * scale + 1e-300, err_msg=f"{kind} {name}")


def check_ranks(tree: dict, tmp_path: Path, ranks=(2, 3), rtol=1e-8) -> dict:
    serial = run_deck(tree, tmp_path / "np1", 1)
    for n in ranks:
        assert_same_results(run_deck(tree, tmp_path / f"np{n}", n), serial, rtol)
    return read_results(serial)


# ------------------------------------------------------------------------------------------------
# whole decks on 1, 2 and 3 ranks
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "solver",
    [
        pytest.param(qs(), id="belos-cg"),
        pytest.param(qs(**{"Belos Linear Solver": "BlockGMRES"}), id="belos-gmres"),
        pytest.param(qs(**{"Linear Solver": "Direct"}), id="direct"),
        pytest.param(qs(**{"Linear Solver": "AMG"}), id="amg"),
    ],
)
def test_quasistatic_same_results_on_1_2_3_ranks(tmp_path, solver):
    """QuasiStatic with a damage model (nothing breaks: the generic force path and the
    RANK_DEFICIENT_NODES set) and each linear solver."""
    r = check_ranks(bar(solver, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 0.5}), tmp_path)
    assert np.abs(r["nodal"]["DisplacementX"][-1]).max() > 0.0015  # the bar was pulled


@pytest.mark.parametrize(
    "solver",
    [
        pytest.param(nox(MATRIX_FREE, "Block 3x3"), id="matrix-free-block3x3"),
        pytest.param(nox(NEWTON_JACOBI), id="newton-jacobi"),
        pytest.param(nox(NLCG, line_search="NonlinearCG"), id="nonlinear-cg"),
    ],
)
def test_nox_same_results_and_iterations_on_1_2_3_ranks(tmp_path, solver):
    """NOXQuasiStatic: same solution and the same Nonlinear_Solver_Iterations (compared
    exactly) on any number of ranks."""
    r = check_ranks(bar(solver), tmp_path)
    assert r["global"]["Nonlinear_Solver_Iterations"][-1] > 2


def test_nox_block_jacobi_ilu_converges_on_2_ranks(tmp_path):
    """AztecOO's default incomplete LU becomes block-Jacobi (an ILU of each rank's owned block)
    under MPI: a different preconditioner, the same solution."""
    tree = bar(nox(NEWTON_ILU))
    ser = read_results(run_deck(tree, tmp_path / "np1", 1))
    par = read_results(run_deck(tree, tmp_path / "np2", 2))
    scale = np.abs(ser["nodal"]["DisplacementX"]).max()
    for c in "XYZ":
        np.testing.assert_allclose(par["nodal"][f"Displacement{c}"], ser["nodal"][f"Displacement{c}"], rtol=0, atol=1e-7 * scale)


def three_block_bar(tmp_path: Path, solver: dict, shape=(24, 4, 4)) -> dict:
    """A box of unit spacing and horizon 3.015 read from a Text File (``tmp_path/mesh.txt``, for
    decks in subfolders) in three blocks along x like the NOX_QS.g hex mesh (ends: block_2 and
    block_1, middle: block_3), one material; both ends stretched to 0.01 (x - L/2) along x with y
    and z held."""
    g = np.stack(np.meshgrid(*[np.arange(n) + 0.5 for n in shape], indexing="ij"), axis=-1).reshape(-1, 3)
    L = shape[0]
    left, right = g[:, 0] < L / 4, g[:, 0] > 3 * L / 4
    block = np.where(left, 2, np.where(right, 1, 3))
    lines = [f"{x:.1f} {y:.1f} {z:.1f} {b} 1.0" for (x, y, z), b in zip(g, block)]
    (tmp_path / "mesh.txt").write_text("# x y z block volume\n" + "\n".join(lines) + "\n")
    ids = lambda mask: " ".join(str(k + 1) for k in np.nonzero(mask)[0])
    bcs = {"Left Node Set": ids(left), "Right Node Set": ids(right)}
    for end in ("Left", "Right"):
        bcs[f"{end} X"] = {"Type": "Prescribed Displacement", "Node Set": f"{end} Node Set", "Coordinate": "x", "Value": f"0.01*(x-{L / 2})"}
        for c in "yz":
            bcs[f"{end} {c}"] = {"Type": "Prescribed Displacement", "Node Set": f"{end} Node Set", "Coordinate": c, "Value": "0.0"}
    return {
        "Discretization": {"Type": "Text File", "Input Mesh File": "../mesh.txt"},
        "Materials": {"M": LPS},
        "Blocks": {"All": {"Block Names": "block_1 block_2 block_3", "Material": "M", "Horizon": 3.015}},
        "Boundary Conditions": bcs,
        "Solver": solver,
        "Output": {"Output Filename": "out", "Output Frequency": 1, "Output Variables": {"Displacement": True, "Nonlinear_Solver_Iterations": True}},
    }


@pytest.mark.parametrize(
    "solver",
    [
        pytest.param(nox(NEWTON_ILU, "Full Tangent"), id="full-tangent-default-aztec"),
        pytest.param(nox({"Method": "Newton", "Newton": {"Linear Solver": {"Preconditioner": "AztecOO", "Aztec Preconditioner": "ilu"}}}), id="newton-ilu"),
    ],
)
def test_nox_ilu_on_a_three_block_mesh_on_2_ranks(tmp_path, solver):
    """NOXQuasiStatic with AztecOO's "ilu" on a three-block box whose owned blocks (576 x 576,
    ~400 entries a row) made SciPy's SuperLU spilu abort with "free(): invalid pointer" on 2
    ranks: ILU(0) of each rank's owned block runs, and 1 and 2 ranks reach the same solution
    (to well within the 1e-9 NOX tolerance)."""
    tree = three_block_bar(tmp_path, solver)
    ser = read_results(run_deck(tree, tmp_path / "np1", 1))
    par = read_results(run_deck(tree, tmp_path / "np2", 2))
    scale = np.abs(ser["nodal"]["DisplacementX"]).max()
    assert scale > 0.1  # stretched by 0.01 (x - 12)
    for c in "XYZ":
        np.testing.assert_allclose(par["nodal"][f"Displacement{c}"], ser["nodal"][f"Displacement{c}"], rtol=0, atol=1e-8 * scale)
    for r in (ser, par):
        assert r["global"]["Nonlinear_Solver_Iterations"][-1] >= 2


def test_implicit_same_results_on_1_2_3_ranks(tmp_path):
    """Newmark dynamics driven by a body force, Belos CG to 1e-10."""
    r = check_ranks(bar(IMPLICIT, pull=None, body_force="1.0e10"), tmp_path, rtol=1e-7)
    assert np.abs(r["nodal"]["DisplacementZ"][-1]).max() > 0.0


def test_a_rank_without_points(tmp_path):
    """Two points on three ranks: one rank owns nothing and still takes part in every
    reduction, halo exchange and gather of the three solvers."""
    tree = box(LPS, (2, 1, 1), horizon=1.5)
    tree["Boundary Conditions"] = {
        "Left Node Set": "1",
        "Right Node Set": "2",
        **{f"L{c}": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": c, "Value": "0.0"} for c in "xyz"},
        "RX": {"Type": "Prescribed Displacement", "Node Set": "Right Node Set", "Coordinate": "x", "Value": "0.001*t"},
    }
    tree["Output"] = {"Output Filename": "out", "Output Frequency": 1, "Output Variables": {"Displacement": True, "Force": True, "Nonlinear_Solver_Iterations": True}}
    for k, solver in enumerate([qs(**{"Linear Solver": "Direct"}), qs(), nox(MATRIX_FREE, "Block 3x3"), IMPLICIT]):
        tree["Solver"] = solver
        serial = run_deck(tree, tmp_path / f"s{k}_np1", 1)
        assert_same_results(run_deck(tree, tmp_path / f"s{k}_np3", 3), serial, 1e-8)


# ------------------------------------------------------------------------------------------------
# the distributed linear algebra against the serial solvers
# ------------------------------------------------------------------------------------------------
CHECK = textwrap.dedent(
    '''
    """Run under mpiexec: the distributed tangent of a perturbed box and every linear solver on
    it, compared on rank 0 with the gathered matrix (results.json, matrix.npz)."""
    import copy, json, sys
    from pathlib import Path
    import numpy as np
    from peridyn.deck.model import parse_deck
    from peridyn.engine.simulation import Simulation
    from peridyn.parallel.comm import get_comm
    from peridyn.deck.source import DeckSource
    from peridyn.solvers.linalg.aztecoo import aztecoo_gmres as aztec_gmres
    from peridyn.solvers.linalg.linear import LinearSolver, belos_cg, gmres, pcg
    from peridyn.solvers.linalg.tangent import TangentMatrix

    tree = json.loads(Path(sys.argv[1]).read_text())
    here = Path(sys.argv[1]).parent
    comm = get_comm()
    sim = Simulation(parse_deck(DeckSource(copy.deepcopy(tree), here / "deck.yaml", "yaml", {})), comm=comm, output_dir=here)
    x = sim.fields["Model_Coordinates"]
    sim.fields["Coordinates"][:] = x + 1.0e-3 * np.stack(
        [np.sin(x[:, 1] + 2 * x[:, 2]), np.cos(x[:, 0] - x[:, 2]), np.sin(0.7 * x[:, 0] * x[:, 1])], axis=1)
    sim.evaluate_forces()
    T = TangentMatrix(sim)
    T.assemble()
    par = T.comm if T.parallel else None
    n = T.n
    xr = x[T.owned_local]
    fixed = np.zeros((n, 3), dtype=bool)
    fixed[xr[:, 0] < 1.0] = True
    D = T.apply_kinematic_bc(fixed)
    T.scale(-1.0)
    b = np.stack([np.sin(3 * xr[:, 0]) + xr[:, 1], np.cos(xr[:, 1] * xr[:, 2]), 0.1 * xr[:, 0] - xr[:, 2]], axis=1).reshape(-1)
    b[fixed.reshape(-1)] = 0.0
    v = np.cos(3.0 * np.repeat(xr[:, 0] + 2 * xr[:, 1] - xr[:, 2], 3) + np.tile([0.0, 1.0, 2.0], n))
    A = T.gather_to_root()
    full = T.gather_vector
    out = {"D": D, "Av": full(T.matvec(v)), "v": full(v), "b": full(b), "diag": full(T.diagonal())}
    blocks = T.diagonal_blocks()
    out["blocks"] = comm.gather_points(blocks[T.row_of_local[:n]], sim.mothership_of_local[:n], sim.num_global)
    sols = {
        "cg": belos_cg(T.matvec, b, 1e-12, 10 * T.ndof, comm=par),
        "gmres": gmres(T.matvec, b, 1e-12, 50, 20, comm=par),
        "aztec-cgs": aztec_gmres(T.matvec, b, None, 1e-12, 300, 400, comm=par),
        "aztec-mgs": aztec_gmres(T.matvec, b, None, 1e-12, 30, 400, classical=False, comm=par),
        "pcg-jacobi": pcg(T.matvec, b, 1e-12, 1000, precond=lambda r, d=T.diagonal(): r / d, comm=par),
    }
    for method, tol in (("Belos", 1e-12), ("Direct", 0.0), ("AMG", 1e-11), ("Auto", 1e-11)):
        ls = LinearSolver(method, tol=tol, coords=xr)
        ls.set_matrix(T)
        sols[method] = ls.solve(b)
    ls = LinearSolver("AMG", tol=1e-11, coords=xr, symmetric=False)
    ls.set_matrix(T)
    sols["AMG-gmres"] = ls.solve(b)
    ob = T.owned_block()
    owned = comm.gather((sim.mothership_of_local[T.owned_local], ob.toarray()))
    T.damp(1.0001, 1.0e-5)
    out["damped"] = full(T.diagonal())
    xs = {k: (full(r.x), bool(r.converged)) for k, r in sols.items()}
    if comm.is_root:
        import scipy.sparse.linalg as spla
        Ad = A.toarray()
        bf = out["b"]
        exact = spla.spsolve(A.tocsc(), bf)
        big = float(np.abs(Ad).max())
        res = {"ranks": comm.size, "D": out["D"]}
        res["matvec"] = float(np.abs(Ad @ out["v"] - out["Av"]).max() / np.abs(out["Av"]).max())
        res["diag"] = float(np.abs(np.diag(Ad) - out["diag"]).max() / big)
        res["blocks"] = max(float(np.abs(np.diag(Ad[k::3, c::3]) - out["blocks"][:, k, c]).max()) for k in range(3) for c in range(3)) / big
        res["symmetry"] = float(np.abs(Ad - Ad.T).max() / big)
        d0 = np.diag(Ad) * 1.0001
        d0 = d0 + 1.0e-5 * np.abs(d0).max()
        res["damp"] = float(np.abs(out["damped"] - d0).max() / np.abs(d0).max())
        res["owned_block"] = max(
            [float(np.abs(Ad[np.ix_(d, d)] - blk).max()) for m, blk in owned if m.size for d in [(3 * m[:, None] + np.arange(3)).reshape(-1)]]
        ) / big
        res["solvers"] = {k: [float(np.abs(x - exact).max() / np.abs(exact).max()), ok] for k, (x, ok) in xs.items()}
        np.savez(here / "matrix.npz", A=Ad, x=exact)
        (here / "results.json").write_text(json.dumps(res))
    '''
)


def linear_algebra(tree: dict, folder: Path, ranks: int) -> tuple[dict, dict]:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "check.py").write_text(CHECK)
    (folder / "tree.json").write_text(json.dumps(tree))
    cmd = [sys.executable, str(folder / "check.py"), str(folder / "tree.json")]
    if ranks > 1:
        cmd = [MPIEXEC, "-n", str(ranks), *cmd]
    proc = subprocess.run(cmd, cwd=folder, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads((folder / "results.json").read_text()), dict(np.load(folder / "matrix.npz"))


@pytest.mark.parametrize(
    "material, shape, ranks",
    [
        pytest.param(LPS, (7, 4, 4), (2, 3), id="lps"),
        pytest.param(dict(LPS, **{"Apply Automatic Differentiation Jacobian": False}), (6, 3, 3), (2,), id="lps-finite-differences"),
        pytest.param(BOND_BASED, (7, 4, 4), (3,), id="bond-based"),
    ],
)
def test_distributed_linear_algebra_agrees_with_serial(tmp_path, material, shape, ranks):
    """On 2 or 3 ranks: the assembled tangent equals the serial one to round-off; the
    distributed product, diagonal, 3x3 diagonal blocks, kinematic BC value D, damping and owned
    blocks are those of the gathered matrix; CG, GMRES (Belos, AztecOO with classical and
    modified Gram-Schmidt), Jacobi-PCG, Direct (on rank 0), block-Jacobi AMG (CG and GMRES) and
    Auto all reach the direct solution."""
    tree = box(material, shape)
    serial, M1 = linear_algebra(tree, tmp_path / "np1", 1)
    for n in ranks:
        res, M = linear_algebra(tree, tmp_path / f"np{n}", n)
        assert res["ranks"] == n
        scale = np.abs(M1["A"]).max()
        np.testing.assert_allclose(M["A"], M1["A"], rtol=0, atol=1e-13 * scale)
        np.testing.assert_allclose(M["x"], M1["x"], rtol=0, atol=1e-11 * np.abs(M1["x"]).max())
        assert res["D"] == pytest.approx(serial["D"], rel=1e-14)
        for key in ("matvec", "diag", "blocks", "damp", "owned_block"):
            assert res[key] < 1e-14, (key, res[key])
        for name, (err, ok) in res["solvers"].items():
            assert ok, name
            assert err < 1e-8, (name, err)
