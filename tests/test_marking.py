"""Dörfler marking: the bulk criterion holds and the set is minimal (up to ties); maximum strategy."""
import numpy as np
import pytest
from mpi4py import MPI

from nc_dolfinx.estimator.marking import doerfler_threshold, mark


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
    """The threshold is found among the largest values only, widening the search ×8 until the bulk is
    reached: with 2e5 nearly equal values θ = 0.5 needs ~1e5 of them (two widenings past the first
    4096), θ = 0.05 about 1e4. The marked set is still the brute-force minimal one."""
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


def test_threshold_of_zero_indicators_marks_nothing():
    assert doerfler_threshold(np.zeros(5), 0.5) == np.inf
    assert len(mark(np.zeros(5), 0.5, comm=MPI.COMM_SELF)) == 0


@pytest.mark.parametrize("theta", [0.25, 0.5, 0.9])
def test_maximum_strategy(theta):
    values = np.random.default_rng(1).uniform(size=100)  # η_K²
    marked = mark(values, theta, "maximum", MPI.COMM_SELF)
    expected = np.flatnonzero(np.sqrt(values) >= theta * np.sqrt(values.max()))
    assert np.array_equal(np.sort(marked), expected)
