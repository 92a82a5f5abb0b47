"""Tests that kill the surviving mutants of the optimizers (docs/mutation-testing.md).

Each test pins down a behaviour a mutant of ``algorithms/`` changed without any other test
failing: a hyperparameter that must act (and be validated under its own name), a default, an
operator's law, or a documented closed form. References are closed forms, exhaustive
enumerations on tiny instances, or the documented defaults.
"""

from __future__ import annotations

import itertools
import math
import re

import numpy as np
import pytest
from scipy.interpolate import splprep

import metaknot as mk
import metaknot.algorithms.baselines as bl
from metaknot.algorithms import (
    AveragingKnots,
    DolphinEcholocation,
    FitpackKnots,
    GeneticAlgorithm,
    LocalSearch,
    NloptKnots,
    OnePlusOneEA,
    RandomSearch,
    UniformKnots,
)
from metaknot.algorithms.dolphin import alternative_probabilities, sample_alternatives
from metaknot.algorithms.ga import index_mutation, two_point_crossover
from metaknot.algorithms.knot_map import KnotMap
from metaknot.algorithms.local_search import index_neighbours, mask_neighbours
from metaknot.algorithms.one_plus_one import step_at_least_one
from metaknot.bspline import averaging_knots, fit_spline, fitpack
from metaknot.problems import FreeKnots, KnotIndices, KnotSelection, get_curve
from tests.test_local_methods import OneMax

SPIRAL = get_curve("archimedean", n_points=40)


class NegativeSum(mk.Problem):
    """Ordered integer alternatives, negative values and no ``objective`` attribute."""

    name = "test_negative_sum"

    def __init__(self, n_var: int = 6, upper: int = 9) -> None:
        self.encoding = mk.Encoding.integer(n_var, 0, upper)

    def evaluate(self, X):
        return -1.0 - np.asarray(X).sum(axis=1).astype(float)

    def decode(self, x):
        return np.asarray(x)


def within_binomial(count: int, trials: int, p: float, n_sd: float = 5.0) -> bool:
    return abs(count - trials * p) <= n_sd * math.sqrt(trials * p * (1 - p))


def set_up(optimizer: mk.Optimizer, problem: mk.Problem, budget: int = 10_000, seed: int = 0):
    evaluator = mk.Evaluator(problem, budget)
    optimizer.setup(evaluator.task, np.random.default_rng(seed))
    return evaluator


# --------------------------------------------------------------------------------------------
# every hyperparameter is validated under its own name, at its documented bounds


REJECTED = [
    (OnePlusOneEA, {"rate": 0.0}, "rate"), (OnePlusOneEA, {"rate": -0.5}, "rate"),
    (OnePlusOneEA, {"rate": 1.5}, "rate"), (OnePlusOneEA, {"offspring": 0}, "offspring"),
    (OnePlusOneEA, {"offspring": 1.5}, "offspring"), (OnePlusOneEA, {"max_step": 0}, "max_step"),
    (OnePlusOneEA, {"max_step": 1.5}, "max_step"),
    (LocalSearch, {"max_step": 0}, "max_step"), (LocalSearch, {"max_step": 1.5}, "max_step"),
    (LocalSearch, {"batch_size": 0}, "batch_size"),
    (LocalSearch, {"batch_size": 1.5}, "batch_size"),
    (GeneticAlgorithm, {"population": 1}, "population"),
    (GeneticAlgorithm, {"population": -3}, "population"),
    (GeneticAlgorithm, {"population": 2.5}, "population"),
    (GeneticAlgorithm, {"tournament_size": 1}, "tournament_size"),
    (GeneticAlgorithm, {"crossover_rate": 1.5}, "crossover_rate"),
    (GeneticAlgorithm, {"crossover_rate": -0.1}, "crossover_rate"),
    (GeneticAlgorithm, {"mutation_rate": -0.1}, "mutation_rate"),
    (GeneticAlgorithm, {"mutation_rate": 1.5}, "mutation_rate"),
    (GeneticAlgorithm, {"elite": -1}, "elite"), (GeneticAlgorithm, {"elite": 0.5}, "elite"),
    (GeneticAlgorithm, {"max_step": 0}, "max_step"),
    (GeneticAlgorithm, {"max_step": 1.5}, "max_step"),
    (DolphinEcholocation, {"population": 1}, "population"),
    (DolphinEcholocation, {"population": 2.5}, "population"),
    (DolphinEcholocation, {"loops": 0}, "loops"), (DolphinEcholocation, {"loops": 1.5}, "loops"),
    (DolphinEcholocation, {"pp1": -0.1}, "pp1"), (DolphinEcholocation, {"pp1": 1.5}, "pp1"),
    (DolphinEcholocation, {"power": 0.0}, "power"), (DolphinEcholocation, {"re": 0}, "re"),
    (DolphinEcholocation, {"re": 1.5}, "re"), (DolphinEcholocation, {"epsilon": 0.0}, "epsilon"),
    (NloptKnots, {"variant": "LN_NOPE"}, "variant"),
    (NloptKnots, {"local_variant": "GN_ISRES"}, "local_variant"),
    (NloptKnots, {"box_map": "round"}, "box_map"),
    (NloptKnots, {"restarts": -1}, "restarts"), (NloptKnots, {"restarts": 1.5}, "restarts"),
    (NloptKnots, {"min_gap": 0.0}, "min_gap"), (NloptKnots, {"min_gap": 0.6}, "min_gap"),
    (NloptKnots, {"data_gap": -0.1}, "data_gap"),
    (NloptKnots, {"span_range": 1.0}, "span_range"),
    (NloptKnots, {"span_range": 0.5}, "span_range"),
    (NloptKnots, {"span_range": -2.0}, "span_range"),
    (NloptKnots, {"initial_step": 0.0}, "initial_step"),
    (NloptKnots, {"initial_step": 1.5}, "initial_step"),
    (NloptKnots, {"perturbation": 0.0}, "perturbation"),
    (NloptKnots, {"k_grid": 1}, "k_grid"), (NloptKnots, {"k_grid": 2.5}, "k_grid"),
    (RandomSearch, {"batch_size": 0}, "batch_size"),
    (RandomSearch, {"batch_size": -2}, "batch_size"),
    (RandomSearch, {"batch_size": 1.5}, "batch_size"),
    (UniformKnots, {"max_knots": 0}, "max_knots"), (UniformKnots, {"batch_size": 0}, "batch_size"),
    (FitpackKnots, {"target": "tolerance", "tolerance": 0.0}, "tolerance"),
]


@pytest.mark.parametrize(("cls", "kwargs", "name"), REJECTED,
                         ids=[f"{c.__name__}-{k}" for c, k, _ in REJECTED])
def test_out_of_range_settings_are_refused_under_their_own_name(cls, kwargs, name):
    with pytest.raises(ValueError, match=rf"^{re.escape(name)} must"):
        cls(**kwargs)


ACCEPTED = [
    (OnePlusOneEA, {"rate": 1.0, "offspring": 1, "max_step": 1}),
    (LocalSearch, {"max_step": 1, "batch_size": 1}),
    (GeneticAlgorithm, {"population": 2, "tournament_size": 2, "crossover_rate": 0.0,
                        "mutation_rate": 0.0, "elite": 0, "max_step": 1}),
    (GeneticAlgorithm, {"crossover_rate": 1.0, "mutation_rate": 1.0, "population": 2,
                        "elite": 1}),
    (DolphinEcholocation, {"population": 2, "loops": 1, "pp1": 0.0, "re": 1}),
    (DolphinEcholocation, {"pp1": 1.0, "power": 1e-3, "epsilon": 1e-9}),
    (NloptKnots, {"restarts": 0, "min_gap": 0.5, "data_gap": 0.0, "span_range": 1.001,
                  "initial_step": 1.0, "k_grid": 2}),
    (RandomSearch, {"batch_size": 1}),
    (AveragingKnots, {"max_knots": 1, "batch_size": 1}),
    (FitpackKnots, {"max_knots": 3, "batch_size": 2}),
]


@pytest.mark.parametrize(("cls", "kwargs"), ACCEPTED)
def test_boundary_settings_are_accepted_and_kept(cls, kwargs):
    params = cls(**kwargs).hyperparameters()
    for key, value in kwargs.items():
        assert params[key] == value and type(params[key]) is type(value), key


DEFAULTS = {
    "dolphin": {"population": 50, "loops": None, "pp1": 0.1, "power": 1.0, "re": 5,
                "epsilon": 1e-3, "fitness": "auto"},
    "ga": {"population": 50, "tournament_size": 2, "crossover": "uniform", "crossover_rate": 0.9,
           "mutation_rate": None, "elite": 1, "index_mutation": "step", "max_step": 3},
    "one_plus_one": {"rate": None, "offspring": 1, "max_step": 1},
    "local_search": {"max_step": 2, "batch_size": 64, "iterated": True, "kick": 3,
                     "pivot": "first"},
    "random_search": {"batch_size": 100},
    "nlopt": {"variant": "LN_BOBYQA", "local_variant": "LN_BOBYQA", "restarts": 0,
              "min_gap": 1e-4, "data_gap": None, "box_map": "auto", "span_range": 4.0,
              "initial_step": 0.1, "perturbation": 0.05, "k_grid": 5},
    "uniform": {"max_knots": None, "batch_size": 64},
    "averaging": {"max_knots": None, "batch_size": 64},
    "fitpack": {"target": "count", "tolerance": None, "max_knots": None, "batch_size": 64},
}


@pytest.mark.parametrize("name", sorted(DEFAULTS))
def test_defaults_are_the_documented_ones(name):
    assert mk.get_optimizer(name).hyperparameters() == DEFAULTS[name]


# --------------------------------------------------------------------------------------------
# (1+1) EA


def test_one_plus_lambda_keeps_the_best_child_and_copies_it():
    ea = OnePlusOneEA(offspring=4)
    set_up(ea, OneMax(10))
    first = ea.ask()
    ea.tell(first, np.array([9.0]))
    X = ea.ask()
    assert X.shape == (4, 10)
    expected = X[1].copy()
    ea.tell(X, np.array([3.0, 1.0, 2.0, 4.0]))
    assert np.array_equal(ea.parent, expected) and ea.parent_f == 1.0
    X[:] = 1 - X  # the caller's array may be reused: the parent is a copy
    assert np.array_equal(ea.parent, expected)


def test_index_steps_go_both_ways_and_stay_integers():
    x = np.array([10, 20, 30, 40])
    children = step_at_least_one(x, 0.5, 400, 1, np.random.default_rng(0))
    assert np.issubdtype(children.dtype, np.integer)
    moves = (children - x)[children != x]
    assert set(np.unique(moves)) == {-1, 1}
    assert within_binomial(int((moves > 0).sum()), moves.size, 0.5)


def test_default_rate_is_one_over_n():
    problem = KnotSelection(SPIRAL)  # n = 38 bits
    default = mk.minimize(problem, OnePlusOneEA(), budget=300, seed=5)
    explicit = mk.minimize(problem, OnePlusOneEA(rate=1 / 38), budget=300, seed=5)
    assert np.array_equal(default.trace_best, explicit.trace_best)
    assert np.array_equal(default.best_x, explicit.best_x)


# --------------------------------------------------------------------------------------------
# local search


def index_moves_by_exhaustion(x, lower, upper, max_step):
    """Every sorted K-subset of lower..upper that swaps one element of x for a free one at most
    max_step away (exhaustive over all subsets)."""
    x = set(int(v) for v in x)
    out = set()
    for y in itertools.combinations(range(lower, upper + 1), len(x)):
        gone, new = x - set(y), set(y) - x
        if len(gone) == 1 and abs(gone.pop() - new.pop()) <= max_step:
            out.add(y)
    return out


@pytest.mark.parametrize("max_step", [None, 1, 2, 3])
def test_index_neighbours_match_exhaustive_enumeration(max_step):
    rng = np.random.default_rng(1)
    for _ in range(20):
        x = np.sort(rng.choice(np.arange(2, 12), size=4, replace=False))
        got = index_neighbours(x, 2, 11) if max_step is None else \
            index_neighbours(x, 2, 11, max_step)
        assert got.shape[1] == 4 and np.issubdtype(got.dtype, np.integer)
        assert {tuple(r) for r in got} == index_moves_by_exhaustion(x, 2, 11, max_step or 1)
        assert len({tuple(r) for r in got}) == len(got)  # distinct rows


@pytest.mark.parametrize("max_multiplicity", [1, 2, 3])
def test_index_neighbours_are_distinct_rows_in_lexicographic_order(max_multiplicity):
    """Best improvement breaks ties by this order; with multiple knots two copies of a value
    moved alike give one row."""
    rng = np.random.default_rng(3)
    for _ in range(30):
        x = np.sort(rng.integers(1, 9, size=5))
        _, counts = np.unique(x, return_counts=True)
        if counts.max() > max_multiplicity:
            continue
        got = index_neighbours(x, 1, 8, 2, max_multiplicity)
        expected = set()
        for k in range(x.size):
            for target in range(x[k] - 2, x[k] + 3):
                if target != x[k] and 1 <= target <= 8 \
                        and np.count_nonzero(x == target) < max_multiplicity:
                    y = x.copy()
                    y[k] = target
                    expected.add(tuple(np.sort(y)))
        assert [tuple(r) for r in got] == sorted(expected)


def test_a_packed_index_set_has_no_neighbours():
    got = index_neighbours(np.array([3, 4, 5, 6]), 3, 6, 2)
    assert got.shape == (0, 4) and np.issubdtype(got.dtype, np.integer)


def test_mask_neighbours_default_is_one_point_shifts():
    rng = np.random.default_rng(2)
    for _ in range(20):
        mask = (rng.random(12) < 0.4).astype(np.int64)
        assert np.array_equal(mask_neighbours(mask), mask_neighbours(mask, 1))


def drive_to_the_first_neighbourhood(ls: LocalSearch, problem: mk.Problem) -> mk.Evaluator:
    evaluator = set_up(ls, problem)
    while True:
        X = ls.ask()
        if not ls._scanning:
            return evaluator, X
        ls.tell(X, evaluator(X))


def test_local_search_uses_max_step_on_masks():
    ls = LocalSearch(max_step=3, pivot="best")
    _, X = drive_to_the_first_neighbourhood(ls, KnotSelection(SPIRAL))
    assert np.array_equal(X, mask_neighbours(ls.incumbent, 3))


def test_first_improvement_tries_the_whole_neighbourhood_in_chunks_in_a_random_order():
    ls = LocalSearch(max_step=3, batch_size=10)
    _, X = drive_to_the_first_neighbourhood(ls, KnotSelection(SPIRAL))
    whole = mask_neighbours(ls.incumbent, 3)
    threshold = ls.acceptance()
    assert threshold is not None and (threshold < ls.incumbent_f).all() \
        and (threshold == np.nextafter(ls.incumbent_f, -np.inf)).all()
    tried = [X]
    while len(ls._untried):  # told no better neighbour, it asks the next chunk
        ls.tell(tried[-1], np.full(len(tried[-1]), ls.incumbent_f))
        tried.append(ls.ask())
        assert len(tried[-1]) <= 10
    together = np.concatenate(tried)
    assert len(together) == len(whole) and not np.array_equal(together, whole)
    assert np.array_equal(np.unique(together, axis=0), whole)
    ls.tell(tried[-1], np.full(len(tried[-1]), ls.incumbent_f))
    assert ls._stuck  # the whole neighbourhood tried: a local optimum


def test_local_search_counts_its_improving_steps_and_copies_the_incumbent():
    ls = LocalSearch(max_step=1, iterated=False)
    problem = KnotIndices(get_curve("vivaldi", n_points=60), n_knots=6)
    evaluator = set_up(ls, problem)
    assert ls.steps == 0
    improvements = 0
    while not ls.finished():
        X = ls.ask()
        scanning, before = ls._scanning, ls.incumbent_f
        F = evaluator(X)
        ls.tell(X, F)
        if not scanning and F.min() < before:
            improvements += 1
        kept = ls.incumbent.copy()
        X[:] = 0  # the caller's array may be reused: the incumbent is a copy
        assert np.array_equal(ls.incumbent, kept)
    assert improvements >= 1 and ls.steps == improvements


class Infeasible(KnotSelection):
    def evaluate(self, X):
        return np.full(len(X), np.inf)


def test_local_search_without_a_feasible_start_finishes():
    ls = LocalSearch()
    result = mk.minimize(Infeasible(SPIRAL), ls, budget=500, seed=0)
    assert ls.finished() and result.n_evaluations == 40 - 3 - 1  # the scan K = 1..N-p-1


def test_local_search_with_no_neighbour_finishes():
    # six points, degree 1: the four interior indices are all knots, no move is possible
    problem = KnotIndices(get_curve("archimedean", n_points=6), n_knots=4, degree=1)
    for iterated in (False, True):  # no kick is possible either
        ls = LocalSearch(iterated=iterated)
        result = mk.minimize(problem, ls, budget=50, seed=0)
        assert ls.finished() and result.n_evaluations == 1


def test_local_search_with_one_neighbour_evaluates_it():
    problem = KnotIndices(get_curve("archimedean", n_points=7), n_knots=4, degree=1)
    ls = LocalSearch(max_step=1)
    set_up(ls, problem)
    ls._scanning, ls.incumbent, ls.incumbent_f = False, np.array([1, 2, 3, 4]), 1.0
    moves = ls.ask()
    assert moves.tolist() == [[1, 2, 3, 5]] and not ls.finished()


# --------------------------------------------------------------------------------------------
# genetic algorithm


def test_two_point_crossover_on_three_genes_swaps_the_middle_one():
    A, B = np.zeros((50, 3), dtype=np.int64), np.ones((50, 3), dtype=np.int64)
    first, second = two_point_crossover(A, B, 1.0, np.random.default_rng(0))
    assert (first == [0, 1, 0]).all() and (second == [1, 0, 1]).all()


def test_index_mutation_defaults_to_unit_steps():
    X = np.random.default_rng(0).integers(10, 90, size=(200, 5))
    out = index_mutation(X, 1.0, np.zeros(5, dtype=np.int64), np.full(5, 99),
                         np.random.default_rng(1))
    assert np.issubdtype(out.dtype, np.integer)
    assert set(np.unique(out - X)) == {-1, 1}


def test_reset_mutation_away_from_zero_is_uniform_over_the_other_values():
    lower, upper = np.full(4, 3), np.full(4, 9)
    X = np.random.default_rng(0).integers(3, 10, size=(3000, 4))
    out = index_mutation(X, 1.0, lower, upper, np.random.default_rng(1), kind="reset")
    assert np.issubdtype(out.dtype, np.integer)
    assert out.min() >= 3 and out.max() <= 9 and (out != X).all()
    for value in range(3, 10):  # each other value with probability 1/6
        others = X != value
        assert within_binomial(int((out[others] == value).sum()), int(others.sum()), 1 / 6)


def test_ga_samples_the_missing_part_of_a_truncated_first_population():
    ga = GeneticAlgorithm(population=5)
    set_up(ga, OneMax(8))
    first = ga.ask()
    assert len(first) == 5
    ga.tell(first[:4], np.arange(4.0))  # the budget cut the first batch
    assert len(ga.ask()) == 1


def is_two_point_child(child: np.ndarray, parents: np.ndarray) -> bool:
    """True if ``child`` is a parent with one segment taken from another parent."""
    for p in parents:
        differ = np.flatnonzero(child != p)
        if differ.size == 0:
            return True
        lo, hi = differ[0], differ[-1] + 1
        if (parents[:, lo:hi] == child[lo:hi]).all(axis=1).any():
            return True
    return False


@pytest.mark.parametrize("crossover", ["two_point", "uniform"])
def test_the_crossover_setting_picks_the_operator(crossover):
    ga = GeneticAlgorithm(population=30, crossover=crossover, crossover_rate=1.0,
                          mutation_rate=0.0)
    evaluator = set_up(ga, OneMax(40))
    X = ga.ask()
    ga.tell(X, evaluator(X))
    parents = ga.pop_x.copy()
    share = np.mean([is_two_point_child(c, parents) for c in ga.offspring(100)])
    if crossover == "two_point":
        assert share == 1.0
    else:
        assert share < 0.5


def test_ga_index_mutation_uses_max_step():
    problem = KnotIndices(get_curve("archimedean", n_points=120), n_knots=3)
    ga = GeneticAlgorithm(population=30, crossover_rate=0.0, mutation_rate=1.0, elite=0,
                          index_mutation="step", max_step=5)
    evaluator = set_up(ga, problem)
    X = ga.ask()
    ga.tell(X, evaluator(X))
    parents = ga.pop_x.copy()
    children = ga.offspring(200)
    distance = np.min(np.abs(children[:, None, :] - parents[None, :, :]).max(axis=2), axis=1)
    assert distance.max() >= 4


# --------------------------------------------------------------------------------------------
# the unit box map (knot_map)

PARAMS = 2.0 + 3.0 * np.array([0.0, 0.1, 0.3, 0.6, 1.0])  # range 3 from 2, widest spacing 1.2


@pytest.mark.parametrize(("min_gap", "data_gap", "expected"), [
    (0.1, 0.0, 0.3),    # min_gap of the range binds
    (1e-4, 0.25, 0.3),  # data_gap times the widest spacing binds
    (0.4, 0.0, 0.5),    # at most half the room two knots leave: 0.5 * 3 / 3
])
def test_gap_closed_form_on_a_shifted_range(min_gap, data_gap, expected):
    box = KnotMap(PARAMS, 1, kind="sorted", min_gap=min_gap, data_gap=data_gap)
    assert box.gap(2) == pytest.approx(expected)
    # sorted map: knot i at a + (i + 1) gap + free * y_i, free = range - 3 gap
    free = 3.0 - 3 * expected
    np.testing.assert_allclose(box.knots(np.array([0.0, 0.0])), [2 + expected, 2 + 2 * expected])
    np.testing.assert_allclose(box.knots(np.array([0.25, 1.0])),
                               [2 + expected + 0.25 * free, 5 - expected])
    np.testing.assert_allclose(box.unit(np.array([2 + expected + 0.25 * free, 5 - expected])),
                               [0.25, 1.0])


@pytest.mark.parametrize(("kind", "knots"), [
    ("sorted", [0.001, 0.002, 0.003, 0.999]),  # first knots below their gaps, last above
    ("spans", [0.2, 0.2001, 0.6, 0.9]),        # one span far below the gap, one 4x the last
])
def test_unit_clips_to_the_box(kind, knots):
    box = KnotMap(np.linspace(0.0, 1.0, 50), 3, kind=kind)
    y = box.unit(np.array(knots))
    assert y.min() == 0.0 and y.max() == 1.0


def test_spans_map_is_centred_on_the_averaging_knots():
    params = np.sort(np.random.default_rng(0).random(40))
    params = (params - params[0]) / (params[-1] - params[0])
    box = KnotMap(params, 2, data_gap=0.0, min_gap=1e-6)
    np.testing.assert_allclose(box.knots(np.full(5, 0.5)), averaging_knots(params, 5, 2),
                               atol=1e-10)


def test_knot_map_defaults_are_the_spans_map_of_the_adapters():
    problem = FreeKnots(get_curve("vivaldi", n_points=60), n_knots=6)
    default = KnotMap(problem.params, 3)
    explicit = KnotMap(problem.params, 3, kind="spans", min_gap=1e-4, data_gap=0.5,
                       span_range=4.0)
    for y in np.random.default_rng(0).random((20, 6)):
        np.testing.assert_array_equal(default.knots(y), explicit.knots(y))


# --------------------------------------------------------------------------------------------
# nlopt


class Recorded(FreeKnots):
    """FreeKnots that records every evaluated candidate and value."""

    def evaluate(self, X):
        F = super().evaluate(X)
        self.log.append((np.array(X, copy=True), np.array(F, copy=True)))
        return F


def recorded(**kwargs) -> Recorded:
    problem = Recorded(SPIRAL, **kwargs)
    problem.log = []
    return problem


class RecordingOpt:
    """Wraps an nlopt.opt: records the maxeval, the evaluations before and the start of each
    run."""

    def __init__(self, opt, runs: list, evaluator) -> None:
        self.opt = opt
        runs.append({"maxeval": opt.get_maxeval(), "used": evaluator.n_evaluations})
        self.run = runs[-1]

    def optimize(self, x0):
        self.run["x0"] = np.array(x0, copy=True)
        return self.opt.optimize(x0)

    def force_stop(self):
        return self.opt.force_stop()


def test_nlopt_data_gap_acts():
    problem = FreeKnots(SPIRAL, n_knots=4)
    u = problem.params
    for data_gap in (0.0, 1.0):
        opt = NloptKnots(data_gap=data_gap)  # a local algorithm: default data_gap 0
        set_up(opt, problem)
        expected = min(max(1e-4 * (u[-1] - u[0]), data_gap * np.diff(u).max()),
                       0.5 * (u[-1] - u[0]) / 5)
        assert opt.gap(4) == pytest.approx(expected)


def test_nlopt_min_gap_must_leave_room_for_the_knots():
    problem = FreeKnots(SPIRAL, n_knots=3)
    with pytest.raises(ValueError, match="min_gap"):
        set_up(NloptKnots(min_gap=0.25), problem)  # 4 spans of a quarter: no room
    set_up(NloptKnots(min_gap=0.21), problem)


def test_nlopt_penalty_is_worse_than_every_finite_value_seen():
    problem = recorded(n_knots=5)
    opt = NloptKnots()
    set_up(opt, problem)
    assert np.isfinite(opt._penalty()) and opt._penalty() > 0  # nothing seen yet
    mk.minimize(problem, opt, budget=120, seed=1)
    values = np.concatenate([F for _, F in problem.log])
    worst = values[np.isfinite(values)].max()
    assert opt._penalty() == worst + abs(worst) + 1.0


@pytest.mark.parametrize("budget", [400, 6])
def test_nlopt_restarts_share_the_budget_and_start_in_the_box(monkeypatch, budget):
    problem = recorded(n_knots=5, degree=2)
    opt = NloptKnots(restarts=3, perturbation=0.4)
    evaluator = set_up(opt, problem, budget=budget, seed=3)
    runs: list[dict] = []
    build = opt._build
    monkeypatch.setattr(opt, "_build", lambda *a: RecordingOpt(build(*a), runs, evaluator))
    opt.run(evaluator)
    # the first run starts from the averaging knots of the problem's degree
    np.testing.assert_allclose(problem.log[0][0][0], averaging_knots(problem.params, 5, 2))
    assert len(runs) >= 4
    for i, run in enumerate(runs):  # equal shares of what is left among the starts left
        assert run["maxeval"] == max(1, (budget - run["used"]) // max(4 - i, 1)), i
    X = np.concatenate([X for X, _ in problem.log])
    F = np.concatenate([F for _, F in problem.log])
    for run in runs[1:]:
        x0 = run["x0"]
        assert x0.min() >= 0.0 and x0.max() <= 1.0
        # perturbed copies of the best point so far, a draw per knot: unequal offsets
        best = opt.unit(X[np.argmin(F[: run["used"]])])
        inner = (x0 > 0) & (x0 < 1)
        if inner.sum() >= 2:
            assert np.ptp((x0 - best)[inner]) > 1e-9
    assert evaluator.n_evaluations == budget


def count_search(n: int, k_grid: int, value, restarts: int = 0, budget: int = 1000):
    """The variable-count search with a stand-in for the nlopt runs: the calls it makes."""
    problem = FreeKnots(get_curve("archimedean", n_points=60), n_knots=n, variable_count=True)
    opt = NloptKnots(k_grid=k_grid, restarts=restarts)
    evaluator = set_up(opt, problem, budget=budget)
    calls, points = [], {}

    def runs(evaluator, n_knots, budget, starts, start=None):
        calls.append((n_knots, budget, starts, start))
        points.setdefault(n_knots, np.full(n_knots, 0.5))
        return value(n_knots), points[n_knots]

    opt._optimize = runs
    opt.run(evaluator)
    return calls, points


@pytest.mark.parametrize(("n", "k_grid", "grid", "n_trials"), [
    (20, 5, [1, 6, 10, 15, 20], 5 + 2 * 3),  # widest gap 5: 3 halvings
    (10, 2, [1, 10], 2 + 2 * 4),            # widest gap 9: 4 halvings
    (1, 5, [1], 1 + 2 * 1),
])
def test_count_search_grid_and_trial_budget(n, k_grid, grid, n_trials):
    calls, _ = count_search(n, k_grid, lambda k: float(k))
    assert [c[0] for c in calls[: len(grid)]] == grid
    short = calls[:-1]
    assert all(c[1] == 1000 // (2 * n_trials) and c[2] == 1 and c[3] is None for c in short)
    assert len(short) <= n_trials


def test_count_search_short_runs_get_at_least_one_evaluation():
    calls, _ = count_search(20, 5, lambda k: float(k), budget=10)
    assert all(c[1] == 1 for c in calls[:-1])


@pytest.mark.parametrize("restarts", [0, 2])
def test_count_search_brackets_the_best_count_and_polishes_it(restarts):
    n = 20
    for best in range(1, n + 1):
        calls, points = count_search(n, 5, lambda k, m=best: abs(k - m) + 0.1 * (k > m),
                                     restarts=restarts)
        *short, final = calls
        tried = {c[0] for c in short}
        assert {best - 1, best + 1} & set(range(1, n + 1)) <= tried, best
        assert len(short) == len(tried) <= 11
        assert final[0] == best and final[1] == 1000 and final[2] == restarts + 1
        assert final[3] is points[best]


# --------------------------------------------------------------------------------------------
# Dolphin Echolocation


def test_epsilon_acts_on_index_sets():
    problem = KnotIndices(SPIRAL, n_knots=4)
    n_alt = 38
    de = DolphinEcholocation(population=10, loops=5, epsilon=1e9)
    evaluator = set_up(de, problem)
    X = de.ask()
    de.tell(X, evaluator(X))
    p, pp = de.probabilities, de.pp[0]
    best = X[np.argmin(evaluator(X))] - 1
    for j in range(4):
        others = np.delete(p[:n_alt, j], best[j])
        # an epsilon far above every fitness: the other alternatives become equally likely
        np.testing.assert_allclose(others, (1 - pp) / (n_alt - 1), rtol=1e-6)
        assert p[best[j], j] == pytest.approx(pp)


def test_auto_fitness_without_an_objective_is_rank():
    # no objective attribute and negative values: inverse fitness would be refused
    result = mk.minimize(NegativeSum(), DolphinEcholocation(population=10), budget=100, seed=0)
    assert result.n_evaluations == 100


@pytest.mark.parametrize("budget", [1, 7, 50, 51, 100, 101])
def test_derived_loops_are_the_budget_over_the_population(budget):
    de = DolphinEcholocation(population=50)
    set_up(de, KnotIndices(SPIRAL, n_knots=4), budget=budget)
    assert de.n_loops == math.ceil(budget / 50)
    assert de.pp[-1] == pytest.approx(1.0 if de.n_loops > 1 else 0.1)


def test_telling_past_the_last_loop_keeps_the_last_pp():
    problem = KnotSelection(SPIRAL)
    de = DolphinEcholocation(population=20, loops=2)
    evaluator = set_up(de, problem)
    for _ in range(4):
        X = de.ask()
        F = evaluator(X)
        de.tell(X, F)
    # PP = 1 at the last loop and after it: every new location is the loop-best
    assert (de.ask() == X[np.argmin(F)]).all()


def test_best_x_keeps_the_first_of_equal_values():
    de = DolphinEcholocation(population=4, loops=3)
    set_up(de, OneMax(6))
    X1 = np.eye(4, 6, dtype=np.int64)
    de.tell(X1, np.array([2.0, 1.0, 3.0, 4.0]))
    X2 = 1 - X1
    de.tell(X2, np.array([1.0, 5.0, 5.0, 5.0]))
    assert np.array_equal(de.best_x, X1[1]) and de.best_f == 1.0


def test_sampled_alternatives_are_integers_and_follow_the_probabilities():
    p = np.array([[0.2, 0.0], [0.5, 1.0], [0.3, 0.0]])
    picked = sample_alternatives(p, np.random.default_rng(0).random((4000, 2)))
    assert np.issubdtype(picked.dtype, np.integer)
    assert (picked[:, 1] == 1).all()
    for alternative, probability in enumerate(p[:, 0]):
        assert within_binomial(int((picked[:, 0] == alternative).sum()), 4000, probability)


def test_alternative_probabilities_with_small_or_no_other_fitness():
    af = np.array([[0.2, 0.0], [0.3, 0.0], [0.7, 4.0]])
    junk = [np.full(af.shape, 7.0) for _ in range(8)]  # freed buffers a fresh array may reuse
    del junk
    p = alternative_probabilities(af, np.array([2, 2]), 0.5)
    # column 0: the others share 1 - pp in proportion to AF (total 0.5 < 1)
    np.testing.assert_allclose(p[:, 0], [0.5 * 0.2 / 0.5, 0.5 * 0.3 / 0.5, 0.5])
    # column 1: no other alternative has fitness: the loop-best keeps probability 1
    np.testing.assert_array_equal(p[:, 1], [0.0, 0.0, 1.0])


# --------------------------------------------------------------------------------------------
# baselines


@pytest.mark.parametrize("user", ["averaging", "nlopt", "spans map"])
def test_averaging_knots_at_the_largest_count_of_degree_two(user):
    """K = N - 3 knots are allowed at degree 2 (not at degree 3): the averaging knots of the
    problem's degree start the baseline, nlopt and the spans map."""
    problem = FreeKnots(SPIRAL, n_knots=37, degree=2)
    expected = averaging_knots(problem.params, 37, 2)
    if user == "spans map":
        box = KnotMap(problem.params, 2, data_gap=0.0, min_gap=1e-9)
        np.testing.assert_allclose(box.knots(np.full(37, 0.5)), expected, atol=1e-10)
        return
    problem = recorded(n_knots=37, degree=2)
    mk.minimize(problem, user, budget=1)
    np.testing.assert_allclose(problem.log[0][0][0], expected, atol=1e-12)


def test_fitpack_knots_at_the_problems_degree_are_splprep_s():
    problem = KnotSelection(SPIRAL, degree=2)
    s = 1e-3
    ((t, _, _), _), _, _, _ = splprep(problem.points.T, u=problem.params, k=2, s=s,
                                      full_output=1, quiet=1)
    np.testing.assert_array_equal(fitpack.interior_knots(problem.params, problem.points, 2, s),
                                  t[3:-3])


def test_fitpack_search_starts_at_the_polynomial_fit_of_the_problems_degree():
    problem = KnotSelection(SPIRAL, degree=2)
    opt = FitpackKnots()
    set_up(opt, problem)
    assert opt._top == pytest.approx(np.log(fit_spline(problem.params, problem.points, [], 2).sse))


def test_fitpack_max_knots_bounds_the_scan():
    opt = FitpackKnots(max_knots=3)
    set_up(opt, KnotSelection(SPIRAL))
    assert opt.counts == [1, 2, 3]


def test_fitpack_counts_each_splprep_run_as_one_external_fit(monkeypatch):
    calls = []
    original = fitpack.interior_knots

    def counted(*args):
        calls.append(args)
        return original(*args)

    monkeypatch.setattr(fitpack, "interior_knots", counted)
    problem = KnotSelection(SPIRAL)
    evaluator = mk.Evaluator(problem, 10)
    opt = FitpackKnots(max_knots=4)
    opt.setup(evaluator.task, np.random.default_rng(0))
    opt.run(evaluator)
    assert len(calls) >= 2
    assert evaluator.external_fits == len(calls) + 1  # and the polynomial fit of the setup


@pytest.mark.parametrize(("curve", "n_points", "n_knots", "tolerance"), [
    ("archimedean", 40, 4, 1e-5), ("vivaldi", 20, 2, 1e-3)])
def test_fitpack_tolerance_cut_to_max_knots(curve, n_points, n_knots, tolerance):
    problem = FreeKnots(get_curve(curve, n_points=n_points), n_knots=n_knots,
                        variable_count=True)
    opt = FitpackKnots(target="tolerance", tolerance=tolerance)
    set_up(opt, problem)
    u = problem.params
    knots = fitpack.interior_knots(u, problem.points, 3, u.size * tolerance**2)
    assert knots.size > n_knots  # the cut applies
    (candidate,) = opt.ask()
    np.testing.assert_allclose(candidate, bl.with_count(knots, n_knots, u[0], u[-1]))


@pytest.mark.parametrize("kind", ["integer", "binary"])
def test_knots_go_to_the_nearest_interior_data_point(kind):
    u = KnotSelection(SPIRAL).params
    rng = np.random.default_rng(4)
    for _ in range(20):
        inner = np.sort(rng.choice(np.arange(4, 33, 3), size=3, replace=False))
        # a knot on either side of the first and last interior points, one at each inner
        first = u[0] + 0.2 * (u[1] - u[0]) if rng.random() < 0.5 else \
            u[1] + 0.3 * (u[2] - u[1])
        last = u[-1] - 0.2 * (u[-1] - u[-2]) if rng.random() < 0.5 else \
            u[-2] - 0.3 * (u[-2] - u[-3])
        knots = np.concatenate(([first], u[inner] + 0.3 * (u[inner + 1] - u[inner]), [last]))
        nearest = np.array([1 + np.argmin(np.abs(u[1:-1] - t)) for t in knots])  # exhaustive
        problem = KnotIndices(SPIRAL, n_knots=5) if kind == "integer" else KnotSelection(SPIRAL)
        candidate = bl.knots_to_candidate(problem, knots)
        if kind == "integer":
            np.testing.assert_array_equal(candidate, nearest)
        else:
            np.testing.assert_array_equal(np.flatnonzero(candidate) + 1, nearest)


def test_fitpack_unreachable_count_is_brought_to_k_between_the_range_ends():
    data = get_curve("archimedean", n_points=40)
    problem = FreeKnots(data, n_knots=33)  # a count FITPACK never chooses on these data
    opt = FitpackKnots()
    set_up(opt, problem)
    rows = []
    while len(X := opt.ask()):
        rows.extend(X)
    reference = FitpackKnots()
    set_up(reference, problem)
    found = reference.search({33})
    assert 33 not in found
    u = problem.params
    above = min(c for c in found if c > 33)
    below = max(c for c in found if c < 33)
    np.testing.assert_allclose(rows[0], bl.with_count(found[above][1], 33, u[0], u[-1]))
    np.testing.assert_allclose(rows[1], bl.with_count(found[below][1], 33, u[0], u[-1]))
