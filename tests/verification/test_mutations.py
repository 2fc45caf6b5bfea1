"""Mutation testing of ``peridyn verify`` in CI: the issue's three physics errors, each put into its
own copy of the package (own kernel caches, so compiled kernels are not shared), make the
problems that measure them fail with exit 1 and a named band check (not a crashed point), while
the unchanged package passes the same problems. The full catalogue runs in
benchmarks/verify_mutations.py (results: benchmarks/results/verify_mutations.md).

Measured on 2 shared cores: 30-125 s per mutation (kernels compiled cold), 2 min 12 s in all."""
import pytest

from peridyn.verify.mutation import run_mutation, run_problems
from peridyn.verify.mutations import BY_NAME, CI

pytestmark = pytest.mark.slow

#: per CI mutation: the words one failed check of each problem must contain (what it measures)
MEASURED_BY = {
    "lps-dilatation-2.9": {"wave-speed": "c_lattice", "dispersion": "c_lattice", "poisson-ratio": "C/C_lattice",
                           "static-modulus": "C/C_lattice"},
    "critical-step-x1.7": {"stability": "largest stable step / estimate"},
    "verlet-kick-x1.1": {"verlet-energy": "u_Verlet exact"},
}


def test_the_unchanged_package_passes_the_problems_of_the_ci_mutations(tmp_path):
    problems = list(dict.fromkeys(p for name in CI for p in BY_NAME[name].problems))
    outcome = run_problems(problems, tmp_path / "out", quick=True)
    assert outcome.returncode == 0 and not outcome.failed, (outcome.failed, outcome.log_tail)


@pytest.mark.parametrize("name", CI)
def test_each_ci_mutation_fails_the_problems_that_measure_it(name, tmp_path):
    mutation = BY_NAME[name]
    outcome = run_mutation(mutation, tmp_path)
    assert outcome.returncode == 1, outcome.log_tail
    crashed = [c for c in outcome.failed if c["what"].startswith("point ")]
    assert not crashed, crashed
    for problem, words in MEASURED_BY[name].items():
        assert any(c["problem"] == problem and words in c["what"] for c in outcome.failed), (problem, outcome.failed)
