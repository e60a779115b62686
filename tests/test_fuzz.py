"""Property-based fuzzing of the command line's error contract (issue 31, item 5).

A small valid problem with at most one mutation (tests/fuzz_inputs.py: wrong types and ranges of every
schema key, misspelt keys, hostile names, expressions, titles, nesting, mesh and problem files, bad command-line
and PETSc options) must end in exit 0 with finite results, or in exit 1 with ONE line
``nc_dolfinx: error: …`` that names the key, file or option; never exit 3, a traceback, a hang, a file
outside OUT, nor a command run by a hostile input (the CANARY file).

Profiles (environment ``NC_FUZZ_PROFILE``):

- ``quick`` (default): derandomised (the same examples every run), 36 inputs on 1 rank (3 of each family
  of fuzz_inputs.FAMILIES) and 6 on 2 ranks (``NC_FUZZ_EXAMPLES`` / ``NC_FUZZ_EXAMPLES_MPI`` change the
  counts);
- ``long``: random seeds and 360 / 30 inputs (or the counts above); for a time budget with a report and
  the failing inputs saved, use ``benchmarks/fuzz_long.py --minutes N``.

Every example is run to its end (no shrinking) and the test fails at the end listing every break found,
deduplicated by kind, with one example input each. ``NC_FUZZ_VERBOSE=1`` (with ``pytest -s``) prints
every input and its outcome as it goes.
"""
import os

import pytest
from hypothesis import Phase, given, settings

from fuzz_inputs import (FAMILIES, SUPPRESS, describe, fuzz_inputs, input_key, run_input, self_check,
                         signature)

# CI runs these on one release (pyproject.toml): what they find is the input handling all releases share.
pytestmark = pytest.mark.one_release

PROFILE = os.environ.get("NC_FUZZ_PROFILE", "quick")
LONG = PROFILE == "long"
EXAMPLES = int(os.environ.get("NC_FUZZ_EXAMPLES", 360 if LONG else 36))
VERBOSE = os.environ.get("NC_FUZZ_VERBOSE") == "1"  # print every input and its outcome (with pytest -s)
EXAMPLES_MPI = int(os.environ.get("NC_FUZZ_EXAMPLES_MPI", 30 if LONG else 6))


def fuzz_settings(examples):
    return settings(max_examples=examples, derandomize=not LONG, database=None, deadline=None,
                    phases=[Phase.explicit, Phase.generate], suppress_health_check=SUPPRESS)


def explore(strategy, nprocs, examples):
    """Run ``examples`` different generated inputs on ``nprocs`` ranks; returns the outcomes. Hypothesis
    repeats an input now and then (more so derandomised): a repeated mutation is skipped, not run again,
    and up to 4 times as many inputs are drawn to find ``examples`` different ones."""
    outcomes, seen = [], set()

    @fuzz_settings(4 * examples)
    @given(strategy)
    def run_one(fi):
        key = input_key(fi)
        if key in seen or len(outcomes) >= examples:
            return
        seen.add(key)
        outcomes.append(run_input(fi, nprocs))
        if VERBOSE:
            print(f"{outcomes[-1].seconds:6.1f} s {'BREAK' if outcomes[-1].breaks else 'kept '} "
                  f"{describe(outcomes[-1], 160)}", flush=True)

    run_one()
    return outcomes


def report(outcomes):
    """The breaks, one example per kind (the first one met), and how many inputs showed each kind."""
    kinds = {}
    for o in outcomes:
        if o.breaks:
            kinds.setdefault(signature(o), []).append(o)
    lines = [f"{len(kinds)} kind(s) of contract break in {sum(map(len, kinds.values()))} of {len(outcomes)} "
             f"inputs:"]
    for kind, found in kinds.items():
        lines.append(f"- {kind} ({len(found)} input(s)); e.g. {describe(found[0])}")
    return "\n".join(lines)


def test_the_fuzzer_writes_the_problem_files_it_means():
    """The fuzzer's own check: every problem file written from a table reads back (tomllib) as that table."""
    @settings(max_examples=300, derandomize=not LONG, database=None, deadline=None,
              phases=[Phase.explicit, Phase.generate], suppress_health_check=SUPPRESS)
    @given(fuzz_inputs())
    def check(fi):
        self_check(fi)
        assert fi.expect in ("ok", "error", "either")
        assert fi.expect != "ok" or not fi.words

    check()


@pytest.mark.long
def test_command_line_keeps_its_error_contract_on_1_rank():
    """Every family of inputs in turn (so that each is tried), EXAMPLES inputs in all."""
    per_family = -(-EXAMPLES // len(FAMILIES))
    outcomes = [o for name in FAMILIES for o in explore(fuzz_inputs([name]), 1, per_family)]
    assert outcomes
    if any(o.breaks for o in outcomes):
        pytest.fail(report(outcomes), pytrace=False)


def test_command_line_keeps_its_error_contract_on_2_ranks():
    """Inputs of all families mixed, on 2 ranks (mpirun): the error line once, no rank left waiting."""
    outcomes = explore(fuzz_inputs(), 2, EXAMPLES_MPI)
    assert outcomes
    if any(o.breaks for o in outcomes):
        pytest.fail(report(outcomes), pytrace=False)
