"""Genetic algorithm (``ga``): operators, elitism, repair, exhaustive optimum, budget, seeds."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import metaknot as mk
from metaknot.algorithms.ga import (
    GeneticAlgorithm,
    flip_mutation,
    index_mutation,
    tournament_selection,
    two_point_crossover,
    uniform_crossover,
)
from metaknot.problems import FreeKnots, KnotIndices, KnotSelection, get_curve


def within_binomial(count: int, trials: int, p: float, n_sd: float = 5.0) -> bool:
    """True if ``count`` successes of ``trials`` is within ``n_sd`` standard deviations of p."""
    return abs(count - trials * p) <= n_sd * np.sqrt(trials * p * (1 - p)) + 1e-12


class OneMax(mk.Problem):
    """Binary toy problem: number of zeros (lower is better); optional all-zero start."""

    name = "test_onemax"

    def __init__(self, n_var: int = 20, zero_start: bool = False) -> None:
        self.encoding = mk.Encoding.binary(n_var)
        self.zero_start = zero_start

    def evaluate(self, X):
        return (np.asarray(X) == 0).sum(axis=1).astype(float)

    def decode(self, x):
        return np.asarray(x)

    def sample(self, rng, n):
        if self.zero_start:
            return np.zeros((n, self.encoding.n_var), dtype=np.int64)
        return super().sample(rng, n)


class Counting(mk.Problem):
    """Wraps a problem; records the size of every evaluated batch."""

    def __init__(self, inner: mk.Problem) -> None:
        self.inner, self.encoding, self.name = inner, inner.encoding, inner.name
        self.batches: list[int] = []

    def evaluate(self, X):
        self.batches.append(len(X))
        return self.inner.evaluate(X)

    def decode(self, x):
        return self.inner.decode(x)

    def sample(self, rng, n):
        return self.inner.sample(rng, n)


@pytest.fixture(scope="module")
def spiral_indices() -> KnotIndices:
    return KnotIndices(get_curve("archimedean", n_points=40), n_knots=8)


# --------------------------------------------------------------------------------------------
# tournament selection
# --------------------------------------------------------------------------------------------


class StubRng:
    """Draws the given contestants."""

    def __init__(self, contestants) -> None:
        self.contestants = np.asarray(contestants)

    def integers(self, low, high, size):
        assert (low, high, size) == (0, 5, self.contestants.shape)
        return self.contestants


def test_tournament_hand_example():
    F = np.array([3.0, np.inf, 1.0, 7.0, np.nan])
    contestants = [[0, 1], [1, 0], [2, 3], [3, 2], [1, 4], [4, 3], [3, 0], [1, 1], [4, 2]]
    winners = tournament_selection(F, 9, 2, StubRng(contestants))
    # better value wins; any finite value beats inf; NaN ranks after everything
    np.testing.assert_array_equal(winners, [0, 0, 2, 2, 1, 3, 0, 1, 2])
    # a tie goes to the first tied contestant drawn (contestants are drawn at random)
    F = np.array([2.0, 2.0, np.inf, np.inf, 1.0])
    winners = tournament_selection(F, 4, 2, StubRng([[0, 1], [1, 0], [3, 2], [2, 3]]))
    np.testing.assert_array_equal(winners, [0, 1, 3, 2])


def test_tournament_three_way_hand_example():
    F = np.array([5.0, 2.0, 9.0, 4.0, 2.5])
    winners = tournament_selection(F, 3, 3, StubRng([[0, 2, 3], [4, 2, 1], [2, 2, 0]]))
    np.testing.assert_array_equal(winners, [3, 1, 0])


@pytest.mark.parametrize("size", [2, 3])
def test_tournament_win_frequencies_match_closed_form(size):
    # individual of rank r (0 = best) among P wins with ((P-r)^t - (P-r-1)^t) / P^t
    F = np.array([4.0, 0.5, 9.0, 2.0, 7.0, 1.0])
    P, n = F.size, 120_000
    winners = tournament_selection(F, n, size, np.random.default_rng(1))
    counts = np.bincount(winners, minlength=P)
    for r, i in enumerate(np.argsort(F)):
        p = ((P - r) ** size - (P - r - 1) ** size) / P ** size
        assert within_binomial(counts[i], n, p), (r, counts[i], n * p)


def test_tournament_ties_and_inf_are_broken_at_random():
    n = 60_000
    all_inf = tournament_selection(np.full(4, np.inf), n, 2, np.random.default_rng(2))
    for i in range(4):
        assert within_binomial(np.sum(all_inf == i), n, 0.25)
    tied = tournament_selection(np.array([1.0, 1.0, 5.0]), n, 2, np.random.default_rng(3))
    # winner is 0 or 1 unless both contestants are 2; the tie goes either way equally
    assert within_binomial(np.sum(tied == 2), n, 1 / 9)
    assert within_binomial(np.sum(tied == 0), n, 4 / 9)


# --------------------------------------------------------------------------------------------
# crossover
# --------------------------------------------------------------------------------------------


def parents(m: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    A = np.tile(np.arange(n), (m, 1))
    return A, A + 100


def test_uniform_crossover_takes_each_gene_from_a_parent():
    A, B = parents(4000, 30)
    C1, C2 = uniform_crossover(A, B, 1.0, np.random.default_rng(4))
    from_b = C1 == B
    assert np.all(from_b | (C1 == A))
    np.testing.assert_array_equal(C2, np.where(from_b, A, B))  # the complementary child
    assert within_binomial(int(from_b.sum()), from_b.size, 0.5)


@pytest.mark.parametrize("cross", [uniform_crossover, two_point_crossover])
def test_crossover_rate(cross):
    A, B = parents(20_000, 30)
    C1, C2 = cross(A, B, 0.0, np.random.default_rng(5))
    np.testing.assert_array_equal(C1, A)
    np.testing.assert_array_equal(C2, B)
    C1, _ = cross(A, B, 0.3, np.random.default_rng(6))
    crossed = (C1 != A).any(axis=1)  # a crossed pair always exchanges a gene (up to 2^-30)
    assert within_binomial(int(crossed.sum()), len(A), 0.3)


def test_two_point_crossover_exchanges_one_inner_segment():
    n, m = 6, 30_000
    A, B = parents(m, n)
    C1, C2 = two_point_crossover(A, B, 1.0, np.random.default_rng(7))
    swapped = C1 == B
    assert np.all(swapped | (C1 == A))
    np.testing.assert_array_equal(C2, np.where(swapped, A, B))
    lo, hi = swapped.argmax(axis=1), n - swapped[:, ::-1].argmax(axis=1)
    # pattern A..A B..B A..A with both outer segments non-empty: lo >= 1, hi <= n - 1
    assert swapped.any(axis=1).all() and (lo >= 1).all() and (hi <= n - 1).all()
    cols = np.arange(n)
    np.testing.assert_array_equal(swapped, (cols >= lo[:, None]) & (cols < hi[:, None]))
    # the cut pair is uniform over the C(5, 2) = 10 pairs of distinct inner cut points
    counts = {pair: 0 for pair in itertools.combinations(range(1, n), 2)}
    for pair in zip(lo.tolist(), hi.tolist(), strict=True):
        counts[pair] += 1
    assert all(within_binomial(c, m, 0.1) for c in counts.values())


def test_two_point_crossover_on_two_genes_cuts_once():
    A, B = parents(50, 2)
    C1, _ = two_point_crossover(A, B, 1.0, np.random.default_rng(8))
    np.testing.assert_array_equal(C1, np.tile([0, 101], (50, 1)))


# --------------------------------------------------------------------------------------------
# mutation
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("rate", [0.01, 0.2])
def test_flip_mutation_rate(rate):
    X = np.random.default_rng(9).integers(0, 2, size=(2000, 50))
    Y = flip_mutation(X, rate, np.random.default_rng(10))
    assert set(np.unique(Y)) <= {0, 1}
    assert within_binomial(int((Y != X).sum()), X.size, rate)


def test_ga_default_mutation_rate_is_one_over_n():
    # identical all-zero parents: crossover cannot change them, so every 1 is a flipped bit
    problem = OneMax(n_var=25, zero_start=True)
    ga = GeneticAlgorithm(population=400, elite=0)
    ga.setup(problem, np.random.default_rng(11))
    X = ga.ask()
    ga.tell(X, problem.evaluate(X))
    flips = sum(int(ga.ask().sum()) for _ in range(10))
    assert ga.rate == pytest.approx(1 / 25)
    assert within_binomial(flips, 10 * 400 * 25, 1 / 25)


def test_step_mutation_moves_by_uniform_steps():
    X = np.full((4000, 40), 50)
    Y = index_mutation(X, 0.1, np.zeros(40, int), np.full(40, 100), np.random.default_rng(12),
                       kind="step", max_step=3)
    moved = Y != X
    assert within_binomial(int(moved.sum()), X.size, 0.1)
    steps = (Y - X)[moved]
    for step in (-3, -2, -1, 1, 2, 3):
        assert within_binomial(int(np.sum(steps == step)), steps.size, 1 / 6)


def test_reset_mutation_moves_to_a_uniform_other_alternative():
    X = np.full((4000, 40), 2)
    Y = index_mutation(X, 0.2, np.zeros(40, int), np.full(40, 4), np.random.default_rng(13),
                       kind="reset")
    moved = Y != X
    assert within_binomial(int(moved.sum()), X.size, 0.2)
    for value in (0, 1, 3, 4):
        assert within_binomial(int(np.sum(Y[moved] == value)), int(moved.sum()), 0.25)


@pytest.mark.parametrize("kind", ["step", "reset"])
def test_index_offspring_are_sorted_distinct_in_bounds(spiral_indices, kind):
    ga = GeneticAlgorithm(population=30, mutation_rate=0.5, index_mutation=kind, max_step=4,
                          crossover="uniform")
    ga.setup(spiral_indices, np.random.default_rng(14))
    for _ in range(6):
        X = ga.ask()
        assert X.shape[1] == 8 and X.dtype.kind == "i"
        assert (np.diff(X, axis=1) > 0).all()
        assert (X >= 1).all() and (X <= 38).all()
        ga.tell(X, spiral_indices.evaluate(X))


# --------------------------------------------------------------------------------------------
# elitism and the ask/tell protocol
# --------------------------------------------------------------------------------------------


def initialised(problem: mk.Problem, **kwargs) -> GeneticAlgorithm:
    ga = GeneticAlgorithm(**kwargs)
    ga.setup(problem, np.random.default_rng(15))
    X = ga.ask()
    ga.tell(X, problem.evaluate(X))
    return ga


def test_elitism_keeps_the_best_individuals_unchanged():
    problem = OneMax(n_var=20)
    ga = initialised(problem, population=10, elite=3)
    best = np.argsort(ga.pop_f, kind="stable")[:3]
    elite_x, elite_f = ga.pop_x[best].copy(), ga.pop_f[best].copy()
    children = ga.ask()
    assert len(children) == 7  # the elite are not re-evaluated
    ga.tell(children, np.full(7, np.inf))  # all offspring worse (infeasible)
    assert len(ga.pop_f) == 10
    np.testing.assert_array_equal(ga.pop_x[:3], elite_x)
    np.testing.assert_array_equal(ga.pop_f[:3], elite_f)
    np.testing.assert_array_equal(ga.pop_x[3:], children)


def test_without_elitism_the_generation_is_replaced():
    problem = OneMax(n_var=20)
    ga = initialised(problem, population=10, elite=0)
    children = ga.ask()
    assert len(children) == 10
    ga.tell(children, np.full(10, np.inf))
    np.testing.assert_array_equal(ga.pop_x, children)


def test_population_best_never_worsens_with_elitism():
    problem = OneMax(n_var=30)
    ga = initialised(problem, population=12, elite=1, mutation_rate=0.3)
    bests = [ga.pop_f.min()]
    for _ in range(15):
        X = ga.ask()
        ga.tell(X, problem.evaluate(X))
        bests.append(ga.pop_f.min())
    assert np.all(np.diff(bests) <= 0)


def test_truncated_batches_are_handled():
    problem = OneMax(n_var=20)
    ga = GeneticAlgorithm(population=8, elite=1)
    ga.setup(problem, np.random.default_rng(16))
    X = ga.ask()
    ga.tell(X[:3], problem.evaluate(X[:3]))  # truncated initial population
    rest = ga.ask()
    assert len(rest) == 5
    ga.tell(rest, problem.evaluate(rest))
    old_x, old_f = ga.pop_x.copy(), ga.pop_f.copy()
    children = ga.ask()[:3]  # truncated offspring: the best 5 parents fill up
    F = problem.evaluate(children)
    ga.tell(children, F)
    keep = np.argsort(old_f, kind="stable")[:5]
    np.testing.assert_array_equal(ga.pop_x, np.concatenate((old_x[keep], children)))
    np.testing.assert_array_equal(ga.pop_f, np.concatenate((old_f[keep], F)))
    assert len(ga.ask()) == 7


def test_all_infeasible_population_still_breeds(spiral_indices):
    ga = GeneticAlgorithm(population=10)
    ga.setup(spiral_indices, np.random.default_rng(17))
    X = ga.ask()
    ga.tell(X, np.full(10, np.inf))
    children = ga.ask()
    assert children.shape == (9, 8) and (np.diff(children, axis=1) > 0).all()


# --------------------------------------------------------------------------------------------
# finding the exhaustive optimum
# --------------------------------------------------------------------------------------------


def hits(problem: mk.Problem, optimizer: str, best: float, budget: int, seeds: range,
         **kwargs) -> int:
    return sum(np.isclose(mk.minimize(problem, optimizer, budget=budget, seed=s,
                                      optimizer_kwargs=kwargs).best_f, best, rtol=1e-12, atol=0)
               for s in seeds)


def test_binary_ga_finds_exhaustive_optimum():
    # 10 points -> 8-bit masks: all 256 candidates in one batch give the optimum
    problem = KnotSelection(get_curve("archimedean", n_points=10), objective="bic",
                            objective_options={"error_floor": 3e-3})
    F = problem.evaluate(np.array(list(itertools.product((0, 1), repeat=8))))
    best = F.min()
    assert np.sum(np.isclose(F, best, rtol=1e-12, atol=0)) == 1  # a unique optimum
    seeds = range(80)
    ga_hits = hits(problem, "ga", best, 128, seeds, population=16)
    random_hits = hits(problem, "random_search", best, 128, seeds, batch_size=16)
    assert ga_hits > 40  # most seeds (expected about 2/3)
    # random search over half the space succeeds with 1 - (255/256)^128 = 0.39 (31 of 80)
    assert ga_hits >= random_hits + 8


def test_index_ga_finds_exhaustive_optimum():
    # 20 points, 3 knots: all C(18, 3) = 816 index sets
    problem = KnotIndices(get_curve("vivaldi", n_points=20), n_knots=3, objective="bic",
                          objective_options={"error_floor": 3e-3})
    F = problem.evaluate(np.array(list(itertools.combinations(range(1, 19), 3))))
    seeds = range(20)
    assert hits(problem, "ga", F.min(), 300, seeds, population=10) >= 15


# --------------------------------------------------------------------------------------------
# framework contract: budget, seeds, callbacks, parameters
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("budget", [1, 7, 20, 56, 137])
def test_budget_is_used_exactly(budget):
    problem = Counting(OneMax(n_var=16))
    result = mk.minimize(problem, GeneticAlgorithm(population=20, elite=2), budget=budget,
                         seed=3)
    assert result.n_evaluations == budget == sum(problem.batches)
    expected = ([20] + [18] * 10)[: len(problem.batches)]
    assert problem.batches[:-1] == expected[:-1] and problem.batches[-1] <= expected[-1]


def test_budget_on_knot_problem(spiral_indices):
    result = mk.minimize(spiral_indices, "ga", budget=95, seed=0,
                         optimizer_kwargs={"population": 12})
    assert result.n_evaluations == 95
    assert np.isclose(result.best_f, spiral_indices.evaluate(result.best_x[None])[0])


@pytest.mark.parametrize("problem_name", ["selection", "indices"])
def test_determinism_by_seed(problem_name, spiral_indices):
    problem = spiral_indices if problem_name == "indices" else \
        KnotSelection(get_curve("archimedean", n_points=40))

    def run(seed):
        return mk.minimize(problem, "ga", budget=300, seed=seed,
                           optimizer_kwargs={"population": 20, "crossover": "two_point"})

    a, b, c = run(5), run(5), run(6)
    np.testing.assert_array_equal(a.best_x, b.best_x)
    assert a.best_f == b.best_f
    np.testing.assert_array_equal(a.trace_evaluations, b.trace_evaluations)
    np.testing.assert_array_equal(a.trace_best, b.trace_best)
    assert not (np.array_equal(a.best_x, c.best_x)
                and np.array_equal(a.trace_best, c.trace_best))


def test_callbacks_report_progress_and_can_stop():
    seen: list[mk.Progress] = []
    result = mk.minimize(OneMax(n_var=30), "ga", budget=200, seed=1, callbacks=[seen.append],
                         optimizer_kwargs={"population": 20, "elite": 4})
    assert [p.n_evaluations for p in seen] == [20, 36, 52, 68, 84, 100, 116, 132, 148, 164,
                                               180, 196, 200]
    best = [p.best_f for p in seen]
    assert np.all(np.diff(best) <= 0) and best[-1] == result.best_f
    assert all(p.budget == 200 and p.batch_f.size in (20, 16, 4) for p in seen)

    stopped = mk.minimize(OneMax(n_var=30), "ga", budget=200, seed=1,
                          callbacks=[lambda p: p.n_evaluations >= 52],
                          optimizer_kwargs={"population": 20, "elite": 4})
    assert stopped.n_evaluations == 52


def test_registered_and_params_recorded():
    ga = mk.get_optimizer("ga", population=30, crossover="two_point")
    assert isinstance(ga, GeneticAlgorithm) and ga.name == "ga"
    assert "ga" in mk.available_optimizers()
    assert ga.hyperparameters() == {"population": 30, "tournament_size": 2,
                                    "crossover": "two_point", "crossover_rate": 0.9,
                                    "mutation_rate": None, "elite": 1,
                                    "index_mutation": "step", "max_step": 3}


def test_continuous_problems_are_rejected():
    with pytest.raises(ValueError, match="binary, integer"):
        GeneticAlgorithm().setup(FreeKnots(get_curve("archimedean", n_points=30), n_knots=3),
                                 np.random.default_rng(0))


@pytest.mark.parametrize("kwargs, name", [
    ({"population": 1}, "population"),
    ({"population": 10.5}, "population"),
    ({"tournament_size": 1}, "tournament_size"),
    ({"crossover": "one_point"}, "crossover"),
    ({"crossover_rate": -0.1}, "crossover_rate"),
    ({"crossover_rate": 1.5}, "crossover_rate"),
    ({"mutation_rate": 1.01}, "mutation_rate"),
    ({"mutation_rate": float("nan")}, "mutation_rate"),
    ({"elite": -1}, "elite"),
    ({"elite": 10, "population": 10}, "elite"),
    ({"index_mutation": "swap"}, "index_mutation"),
    ({"max_step": 0}, "max_step"),
])
def test_bad_parameters(kwargs, name):
    with pytest.raises(ValueError, match=name):
        GeneticAlgorithm(**kwargs)


# --------------------------------------------------------------------------------------------
# each setting acts in the optimizer (not only in the operator functions)


def _children(problem: mk.Problem, seed: int = 0, **kwargs) -> tuple[np.ndarray, np.ndarray]:
    ga = initialised(problem, **kwargs)
    ga.rng = np.random.default_rng(seed)
    return ga.pop_x.copy(), ga.offspring(60)


def test_crossover_rate_is_used():
    problem = OneMax(n_var=40)
    parents_x, copies = _children(problem, crossover_rate=0.0, mutation_rate=0.0, population=30)
    rows = {tuple(r) for r in parents_x}
    assert all(tuple(c) in rows for c in copies)  # no crossover, no mutation: parents only
    _, crossed = _children(problem, crossover_rate=1.0, mutation_rate=0.0, population=30)
    assert sum(tuple(c) not in rows for c in crossed) > 30


def test_tournament_size_is_used():
    problem = OneMax(n_var=40)
    ga = initialised(problem, population=20, tournament_size=400, crossover_rate=0.0,
                     mutation_rate=0.0)
    best = ga.pop_x[np.argmin(ga.pop_f)]
    # a tournament of 400 draws from 20 individuals all but surely includes the best
    assert (ga.offspring(19) == best).all()
    weak = initialised(problem, population=20, tournament_size=2, crossover_rate=0.0,
                       mutation_rate=0.0)
    assert not (weak.offspring(19) == weak.pop_x[np.argmin(weak.pop_f)]).all()


def test_index_mutation_kind_is_used():
    problem = KnotIndices(get_curve("archimedean", n_points=80), n_knots=3)
    for kind, far in (("step", False), ("reset", True)):
        ga = initialised(problem, population=30, crossover_rate=0.0, mutation_rate=1.0,
                         index_mutation=kind, max_step=1, elite=0)
        parents_x = ga.pop_x.copy()
        children = ga.offspring(200)
        # each child comes from one parent; its genes moved by 1 (step) or anywhere (reset):
        # the distance of a child to its nearest parent (largest gene move)
        distance = np.min(np.abs(children[:, None, :] - parents_x[None, :, :]).max(axis=2),
                          axis=1)
        assert (distance.max() > 3) == far, kind
