"""The mutation tool (peridyn.verify.mutation), its catalogue, and two of the references that make
the mutations visible: the modal solution of Verlet (problems.modal) and the stability band
(the lattice constants: test_lattice.py)."""
import math
import subprocess
import sys

import numpy as np
import pytest

from peridyn.verify import PROBLEMS
from peridyn.verify.mutation import PACKAGE, Substitution, apply, child_env, package_copy
from peridyn.verify.mutations import BY_NAME, CI, MUTATIONS
from peridyn.verify.problems.dynamics import Stability
from peridyn.verify.problems.modal import Modes


def test_apply_replaces_and_refuses_a_substitution_that_does_not_match():
    assert apply("a = 3.0 * b\n", Substitution("x.py", "3.0 * b", "2.9 * b")) == "a = 2.9 * b\n"
    with pytest.raises(ValueError, match="occurs 0 times"):
        apply("a = 3.0 * b\n", Substitution("x.py", "3.1 * b", "2.9 * b"))
    with pytest.raises(ValueError, match="occurs 2 times, expected 1"):
        apply("3.0 * b + 3.0 * b", Substitution("x.py", "3.0 * b", "2.9 * b"))
    assert apply("3.0 * b + 3.0 * b", Substitution("x.py", "3.0 * b", "c", count=0)) == "c + c"


@pytest.mark.parametrize("mutation", MUTATIONS, ids=lambda m: m.name)
def test_every_catalogued_error_matches_the_source_and_names_real_problems(mutation):
    for sub in mutation.substitutions:
        text = (PACKAGE / sub.path).read_text(encoding="utf-8")
        assert apply(text, sub) != text
    assert mutation.problems and all(p in PROBLEMS for p in mutation.problems)


def test_the_catalogue_covers_the_issues_errors_and_every_area():
    assert set(CI) <= set(BY_NAME) and len(MUTATIONS) >= 13
    assert {"materials", "damage", "contact", "solvers", "time step"} <= {m.area for m in MUTATIONS}


def test_a_copy_carries_the_substitution_and_is_the_package_a_child_imports(tmp_path):
    sub = BY_NAME["critical-step-x1.7"].substitutions[0]
    root = package_copy(tmp_path, [sub])
    assert sub.new in (root / "peridyn" / sub.path).read_text() and not list(root.rglob("__pycache__"))
    env = child_env(root, tmp_path / "cache")
    p = subprocess.run([sys.executable, "-c", "import os, peridyn; print(peridyn.__file__, os.environ['NUMBA_CACHE_DIR'])"],
                       env=env, capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    path, cache = p.stdout.split()
    assert path.startswith(str(root)) and cache.startswith(str(tmp_path / "cache"))


# -- the modal reference ----------------------------------------------------------------------------
def chain() -> tuple[np.ndarray, np.ndarray]:
    """Two unit masses on springs (1, 3) in x, free in y and z (rigid there): stiffness and v0."""
    k = np.zeros((6, 6))
    k[0, 0], k[0, 3], k[3, 0], k[3, 3] = 4.0, -3.0, -3.0, 3.0
    v0 = np.array([[0.3, 1.0, 0.0], [-0.7, 0.0, 2.0]])
    return k, v0


def hand_verlet(k: np.ndarray, v0: np.ndarray, dt: float, steps: int) -> np.ndarray:
    u, v = np.zeros(6), v0.reshape(-1).copy()
    a = -k @ u
    for _ in range(steps):
        v += 0.5 * dt * a
        u += dt * v
        a = -k @ u
        v += 0.5 * dt * a
    return u.reshape(2, 3)


def test_modes_give_velocity_verlets_exact_sequence_and_the_continuous_motion():
    k, v0 = chain()
    modes = Modes(k, 1.0, v0)
    assert modes.asymmetry == 0.0
    for dt, steps in ((0.1, 7), (0.5, 40), (0.75, 3)):
        np.testing.assert_allclose(modes.verlet(dt, steps), hand_verlet(k, v0, dt, steps), rtol=0, atol=1e-12)
    lam, phi = np.linalg.eigh(k[np.ix_([0, 3], [0, 3])])
    q = phi.T @ v0[:, 0]
    t = 2.7
    exact_x = phi @ (q * np.sin(np.sqrt(lam) * t) / np.sqrt(lam))
    u = modes.continuous(t)
    np.testing.assert_allclose(u[:, 0], exact_x, atol=1e-13)
    np.testing.assert_allclose(u[:, 1:], v0[:, 1:] * t, atol=1e-13)  # rigid directions drift
    # Verlet converges to it at second order
    e = [np.abs(modes.verlet(t / n, n) - u).max() for n in (100, 200)]
    assert math.log2(e[0] / e[1]) == pytest.approx(2.0, abs=0.01)
    with pytest.raises(ValueError, match="stability limit"):
        modes.verlet(2.0 / modes.omega_max * 1.0001, 3)


def test_a_wrong_kick_misses_the_exact_verlet_sequence():
    k, v0 = chain()
    modes = Modes(k, 1.0, v0)
    u, v = np.zeros(6), v0.reshape(-1).copy()
    a = -k @ u
    for _ in range(20):  # the first half kick 10 % too large
        v += 1.1 * 0.05 * a
        u += 0.1 * v
        a = -k @ u
        v += 0.05 * a
    assert np.abs(u.reshape(2, 3) - modes.verlet(0.1, 20)).max() > 1e-3


# -- the stability band ------------------------------------------------------------------------------
@pytest.mark.parametrize("method", Stability.methods)
def test_the_stability_band_is_two_sided_per_material(method):
    p = Stability()
    lo, hi = p.RATIO_BAND[method]
    assert 1.0 < lo < hi < Stability.HIGH
    middle = 0.5 * (lo + hi)

    def passes(ratio):
        return p.checks(method, [{"resolution": 3.015, "values": {"largest stable ratio": ratio}}], True)[0].passed

    assert passes(middle)
    assert not passes(middle / 1.7) and not passes(min(middle / 0.6, Stability.HIGH))
