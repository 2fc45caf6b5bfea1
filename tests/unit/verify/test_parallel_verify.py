"""``mpi``: one deck on one and two ranks, the difference banded; a wrong answer fails it."""
from __future__ import annotations

import pytest

from peridyn.verify.problems.parallel import AGREEMENT, ParallelAgreement, find_mpiexec

pytestmark = pytest.mark.skipif(find_mpiexec() is None, reason="mpiexec or mpi4py not installed (pip install mpi4py mpich)")


def points(problem, method, quick=True):
    out = []
    for r in problem.ladder(method, quick):
        m = problem.measure(method, r, quick)
        out.append({"resolution": r, "error": m.error, "values": m.values})
    return out


def test_two_ranks_give_the_serial_answer_with_breaking_bonds():
    p = ParallelAgreement()
    pts = points(p, "Elastic, Critical Stretch")
    assert [q["resolution"] for q in pts] == [1.0, 2.0]
    checks = p.checks("Elastic, Critical Stretch", pts, True)
    assert checks and all(c.passed for c in checks), [(c.what, c.value) for c in checks]


def test_a_rank_count_that_changes_the_answer_fails(monkeypatch):
    """A 2-rank run of a slightly different deck (density 1e-6 off) stands in for a decomposition
    that changed the physics: its difference leaves the round-off band."""
    p = ParallelAgreement()
    deck = p.deck

    def perturbed(method, n):
        tree = deck(method, n)
        if perturbed.calls:
            tree["Materials"]["M"]["Density"] *= 1.0 + 1e-6
        perturbed.calls += 1
        return tree

    perturbed.calls = 0
    monkeypatch.setattr(p, "deck", perturbed)
    pts = points(p, "Elastic")
    bad = [c for c in p.checks("Elastic", pts, True) if not c.passed]
    assert len(bad) == 1 and "ranks" in bad[0].what and bad[0].value > AGREEMENT
