"""Dörfler marking: the bulk criterion holds and the set is minimal (up to ties); the threshold found in
parallel without gathering is the one of exact arithmetic, whatever the partition; maximum strategy."""
import importlib.util
import json
from fractions import Fraction

import numpy as np
import pytest
from mpi4py import MPI

from conftest import ROOT, run
from nc_dolfinx.estimator.marking import TIE_RTOL, doerfler_threshold, mark


def brute_force_minimal_size(values, theta):
    """Smallest k such that some k cells carry θ of the total (greedy on sorted values is optimal)."""
    s = np.sort(values)[::-1]
    return int(np.argmax(np.cumsum(s) >= theta * s.sum() * (1 - 1e-14)) + 1)


@pytest.mark.parametrize("theta", [0.1, 0.3, 0.5, 0.8, 1.0])
@pytest.mark.parametrize("seed", range(5))
def test_doerfler_set_is_minimal_and_satisfies_the_bulk_criterion(theta, seed):
    values = np.random.default_rng(seed).lognormal(size=200) ** 2  # η_K², distinct
    marked = mark(values, theta, "doerfler", MPI.COMM_SELF)
    assert values[marked].sum() >= theta * values.sum() * (1 - 1e-12)
    assert len(marked) == brute_force_minimal_size(values, theta)
    # the marked cells are the largest ones
    assert values[marked].min() >= np.delete(values, marked).max(initial=0)


@pytest.mark.parametrize("theta", [0.05, 0.5, 0.9])
def test_doerfler_on_many_cells_where_the_largest_few_do_not_suffice(theta):
    """2e5 nearly equal values: θ = 0.5 needs ~1e5 of them, θ = 0.05 about 1e4 (far from the largest few);
    the marked set is still the brute-force minimal one."""
    values = np.random.default_rng(7).uniform(1.0, 1.1, size=200_000)
    marked = mark(values, theta, "doerfler", MPI.COMM_SELF)
    assert len(marked) == brute_force_minimal_size(values, theta) > 4096
    assert values[marked].min() >= np.delete(values, marked).max(initial=0)


def test_ties_at_the_threshold_are_marked_together():
    values = np.array([4.0, 1.0, 1.0, 1.0, 1.0, 0.5])
    marked = mark(values, 0.5, "doerfler", MPI.COMM_SELF)  # 4 + 1 reaches half of 8.5; three 1's tie
    assert sorted(marked) == [0, 1, 2, 3, 4]
    # values equal up to round-off are ties too, so the set does not depend on the partition
    noisy = values * (1 + 1e-13 * np.array([0, 1, -1, 2, -2, 0]))
    assert sorted(mark(noisy, 0.5, "doerfler", MPI.COMM_SELF)) == [0, 1, 2, 3, 4]


def exact_threshold(values, theta):
    """The Dörfler threshold by its definition, in exact arithmetic: the largest value x whose smaller
    values sum to at most (1 − θ(1 − 1e-14)) Σ η_K², the running sums over the sorted distinct values
    taken as exact rationals."""
    total = float(np.sum(values))
    left_out = Fraction(total * ((1 - theta) + theta * 1e-14))
    below, best = Fraction(0), None
    for value, count in zip(*np.unique(values, return_counts=True)):
        if below > left_out:
            break
        best = value
        below += Fraction(float(value)) * int(count)
    return best


@pytest.mark.parametrize("theta", [0.01, 0.3, 0.5, 0.9, 1.0])
@pytest.mark.parametrize("kind", ["lognormal", "ties", "tiny and huge", "one cell"])
def test_bisection_threshold_is_the_exact_one(theta, kind):
    """The bisection on bit patterns ends on the very value of the definition in exact arithmetic."""
    rng = np.random.default_rng(3)
    values = {"lognormal": rng.lognormal(sigma=3.0, size=5000) ** 2,
              "ties": np.repeat([9.0, 4.0, 1.0, 0.25, 0.0], 200),
              "tiny and huge": np.concatenate([rng.uniform(1e-300, 1e-290, 100), rng.uniform(1e280, 1e290, 5)]),
              "one cell": np.array([0.7])}[kind]
    assert doerfler_threshold(values, theta) == exact_threshold(values, theta)


@pytest.mark.parametrize("nprocs", [2, 3])
def test_marked_set_of_a_split_set_is_the_serial_one(nprocs):
    """One global set of η_K² (distinct values, exact ties, ties up to round-off, zeros, tiny values) split
    unevenly over 2 and 3 ranks (tests/mpi/doerfler_split.py): the marked global indices are those of the
    definition on the whole set (exact threshold, ties at TIE_RTOL), as on one rank."""
    script = ROOT / "tests" / "mpi" / "doerfler_split.py"
    spec = importlib.util.spec_from_file_location("doerfler_split", script)
    split = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(split)
    values = split.global_values()
    proc = run([script], nprocs, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    marked = json.loads(proc.stdout.strip().splitlines()[-1])
    assert sorted(map(float, marked)) == sorted(split.THETAS)
    for theta, indices in marked.items():
        expected = np.flatnonzero(values >= exact_threshold(values, float(theta)) * (1 - TIE_RTOL))
        assert indices == expected.tolist(), theta
        assert 0 < len(indices) < len(values) - 50 or float(theta) == 1.0  # never everything but the zeros


def test_threshold_of_zero_indicators_marks_nothing():
    assert doerfler_threshold(np.zeros(5), 0.5) == np.inf
    assert len(mark(np.zeros(5), 0.5, comm=MPI.COMM_SELF)) == 0


@pytest.mark.parametrize("theta", [0.25, 0.5, 0.9])
def test_maximum_strategy(theta):
    values = np.random.default_rng(1).uniform(size=100)  # η_K²
    marked = mark(values, theta, "maximum", MPI.COMM_SELF)
    expected = np.flatnonzero(np.sqrt(values) >= theta * np.sqrt(values.max()))
    assert np.array_equal(np.sort(marked), expected)
