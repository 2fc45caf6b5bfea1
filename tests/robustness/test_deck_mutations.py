"""Property-based robustness: mutated example and conformance decks never crash peridyn.

Every mutation (see mutations.py) of every deck must end in exit 0, a clean exit 2 (one line per
problem, naming file, deck path, problem and fix) or exit 3 - never exit 1, a hang, a non-finite
value in an output file, a lost earlier result, a messy exit 2, or exit 0 for a deck that is
obviously invalid. ``check`` cases run in-process (a warm worker); ``run`` cases run shrunk decks
in a subprocess.

Environment: PERIDYN_FUZZ_CHECK_EXAMPLES (default 300) and PERIDYN_FUZZ_RUN_EXAMPLES (default 40)
size it (about one minute on two cores in CI; the 2,000-case surface campaign in benchmarks/ samples wider); PERIDYN_FUZZ_SEED picks other cases (default:
derandomized, the same cases every time); PERIDYN_FUZZ_TOLERATE=exit2_messy,... lists classes not
to fail on; PERIDYN_FUZZ_MAX_LINE (default 400) is the longest clean error line. The longer
campaign with a table of outcome classes is ``python benchmarks/deck_campaign.py``.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import seed as hseed
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mutations import find_decks  # noqa: E402
from cases import Case, cases, deck_bytes  # noqa: E402
from runner import calibrate, run_case  # noqa: E402

from peridyn.deck.files import load_deck_file  # noqa: E402

pytestmark = pytest.mark.robustness

CHECK_EXAMPLES = int(os.environ.get("PERIDYN_FUZZ_CHECK_EXAMPLES", "300"))
RUN_EXAMPLES = int(os.environ.get("PERIDYN_FUZZ_RUN_EXAMPLES", "40"))
SEED = os.environ.get("PERIDYN_FUZZ_SEED")
#: outcome classes not to fail on (comma-separated), e.g. while a known problem is being fixed
TOLERATE = {c.strip() for c in os.environ.get("PERIDYN_FUZZ_TOLERATE", "").split(",") if c.strip()}


def _settings(n: int):
    """Reproducible settings: derandomized unless a seed is given; no shrinking (each example is
    already a single mutation, and shrinking would re-run slow subprocesses)."""
    s = settings(max_examples=n, deadline=None, database=None, derandomize=SEED is None,
                 phases=[Phase.explicit, Phase.generate], print_blob=False,
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                        HealthCheck.filter_too_much, HealthCheck.function_scoped_fixture])

    def wrap(f):
        f = s(f)
        return hseed(int(SEED))(f) if SEED is not None else f

    return wrap


@pytest.fixture(scope="module")
def decks():
    found = find_decks()
    if not found:
        pytest.skip("no decks found")
    for d in found:
        calibrate(d)
    return found


def _verdict(case: Case, outcome) -> str:
    tail = "\n".join(ln[:300] for ln in outcome.stderr.strip().splitlines()[-6:])
    return (f"{outcome.klass}: {case.describe()}\n  flags: {'; '.join(outcome.flags)}\n"
            f"  error line: {outcome.error_line[:300]}\n  stderr tail:\n{tail}")


def test_decks_round_trip_through_the_writers(decks, tmp_path):
    """The harness writes an unmutated tree back (YAML via dump_yaml, and XML) without changing it."""
    for deck in decks:
        for fmt in ("yaml", "xml"):
            path = tmp_path / f"{deck.path.stem}.{fmt}"
            path.write_bytes(deck_bytes(deck.tree, fmt))
            assert repr(load_deck_file(path).tree) == repr(deck.tree), (deck.name, fmt)


@_settings(CHECK_EXAMPLES)
@given(data=st.data())
def test_check_survives_mutations(decks, data):
    case = data.draw(cases(decks, "check"), label="case")
    outcome = run_case(case, check_timeout=30.0)
    assert not outcome.bad or outcome.klass in TOLERATE, _verdict(case, outcome)


@pytest.mark.slow
@_settings(RUN_EXAMPLES)
@given(data=st.data())
def test_run_survives_mutations(decks, data):
    case = data.draw(cases(decks, "run"), label="case")
    outcome = run_case(case, run_timeout=60.0)
    assert not outcome.bad or outcome.klass in TOLERATE, _verdict(case, outcome)
