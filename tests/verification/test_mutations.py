"""Mutation testing of ``peridyn verify`` in CI: the issue's three physics errors, each put into its
own copy of the package (own kernel caches, so compiled kernels are not shared), make the
problems that measure them fail with exit 1 and a named band check (not a crashed point), while
the unchanged package passes the same problems. The full catalogue runs in
benchmarks/verify_mutations.py (results: benchmarks/results/verify_mutations.md).

The unchanged run and the selected mutations start at once, one child per core (each its own
process, folder and kernel caches); each test waits for its own. Measured on 2 shared cores:
30-125 s per mutation (kernels compiled cold), 2 min 22 s in all one after another."""
from concurrent.futures import ThreadPoolExecutor

import pytest

from peridyn.core.resources import usable_cores
from peridyn.verify.mutation import run_mutation, run_problems
from peridyn.verify.mutations import BY_NAME, CI

pytestmark = pytest.mark.slow

#: per CI mutation: the words one failed check of each problem must contain (what it measures)
MEASURED_BY = {
    "lps-dilatation-2.9": {"wave-speed": "c_lattice", "dispersion": "c_lattice", "poisson-ratio": "C/C_lattice",
                           "static-modulus": "C/C_lattice", "manufactured-lps": "u_exact"},
    "critical-step-x1.7": {"stability": "largest stable step / estimate"},
    "verlet-kick-x1.1": {"verlet-energy": "u_Verlet exact"},
}


UNCHANGED = "unchanged"


@pytest.fixture(scope="module")
def outcomes(request, tmp_path_factory):
    """The selected tests' children started at once on a pool of one per core."""
    pool = ThreadPoolExecutor(max_workers=max(1, min(usable_cores(), 4)))
    futures = {}
    for item in request.session.items:
        if item.module is not request.module:
            continue
        if item.originalname == "test_the_unchanged_package_passes_the_problems_of_the_ci_mutations":
            problems = list(dict.fromkeys(p for name in CI for p in BY_NAME[name].problems))
            futures[UNCHANGED] = pool.submit(run_problems, problems, tmp_path_factory.mktemp(UNCHANGED) / "out", quick=True)
        elif item.originalname == "test_each_ci_mutation_fails_the_problems_that_measure_it":
            name = item.callspec.params["name"]
            futures[name] = pool.submit(run_mutation, BY_NAME[name], tmp_path_factory.mktemp("mutation"))
    try:
        yield futures
    finally:
        pool.shutdown(cancel_futures=True)


def test_the_unchanged_package_passes_the_problems_of_the_ci_mutations(outcomes):
    outcome = outcomes[UNCHANGED].result()
    assert outcome.returncode == 0 and not outcome.failed, (outcome.failed, outcome.log_tail)


@pytest.mark.parametrize("name", CI)
def test_each_ci_mutation_fails_the_problems_that_measure_it(name, outcomes):
    outcome = outcomes[name].result()
    assert outcome.returncode == 1, outcome.log_tail
    crashed = [c for c in outcome.failed if c["what"].startswith("point ")]
    assert not crashed, crashed
    for problem, words in MEASURED_BY[name].items():
        assert any(c["problem"] == problem and words in c["what"] for c in outcome.failed), (problem, outcome.failed)
