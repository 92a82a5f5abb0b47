"""Dolphin Echolocation (``dolphin``): schedule, accumulative fitness, binary reduction, runs."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import metaknot as mk
import metaknot.algorithms.dolphin as dolphin_module
from metaknot.algorithms.dolphin import (
    DolphinEcholocation,
    accumulative_fitness,
    alternative_probabilities,
    fitness_values,
    pp_schedule,
    reflect,
)
from metaknot.problems import FreeKnots, KnotIndices, KnotSelection, archimedean_spiral

# --------------------------------------------------------------------------------------------
# fixtures and independent references
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def spiral_mask():
    return KnotSelection("archimedean")  # 98 bits


@pytest.fixture(scope="module")
def small_indices():
    return KnotIndices(archimedean_spiral(30), n_knots=3)


def fold(index: int, n: int) -> int:
    """Reference mirror: reflect at 0 and at n - 1, one step at a time, until inside."""
    if n == 1:
        return 0
    while index < 0 or index > n - 1:
        index = -index if index < 0 else 2 * (n - 1) - index
    return index


def af_reference(alternatives, fitness, n_alt, re, epsilon, best):
    """Step 4 written as the paper's loops (slow, plain Python)."""
    n_loc, n_var = np.shape(alternatives)
    af = np.zeros((max(n_alt), n_var))
    for i in range(n_loc):
        for j in range(n_var):
            for k in range(-re, re + 1):
                af[fold(alternatives[i][j] + k, n_alt[j]), j] += (re - abs(k)) / re * fitness[i]
    for j in range(n_var):
        af[: n_alt[j], j] += epsilon
        af[best[j], j] = 0.0
    return af


# --------------------------------------------------------------------------------------------
# the PP schedule (eq. 1)
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("loops", "pp1", "power", "expected"), [
    (5, 0.1, 1.0, [0.1, 0.325, 0.55, 0.775, 1.0]),           # steps of 0.9 / 4
    (3, 0.2, 2.0, [0.2, 0.5, 1.0]),                          # (i^2 - 1) / 8 = 0, 3/8, 1
    (4, 0.0, 0.5, [0.0, 2**0.5 - 1, 3**0.5 - 1, 1.0]),        # (sqrt(i) - 1) / (2 - 1)
    (2, 0.15, 1.0, [0.15, 1.0]),
    (3, 1.0, 1.0, [1.0, 1.0, 1.0]),
    (1, 0.1, 1.0, [0.1]),                                    # loops = 1: no division by zero
    (1, 0.4, 3.0, [0.4]),
])
def test_pp_schedule_hand_values(loops, pp1, power, expected):
    np.testing.assert_allclose(pp_schedule(loops, pp1, power), expected, rtol=1e-12)


# --------------------------------------------------------------------------------------------
# reflection and accumulative fitness
# --------------------------------------------------------------------------------------------


def test_reflect_hand_values():
    # 5 alternatives 0..4: -m -> m, 4 + m -> 4 - m, folded again beyond the far edge
    np.testing.assert_array_equal(reflect(np.arange(-5, 10), 5),
                                  [3, 4, 3, 2, 1, 0, 1, 2, 3, 4, 3, 2, 1, 0, 1])
    np.testing.assert_array_equal(reflect(np.arange(-3, 5), 2), [1, 0, 1, 0, 1, 0, 1, 0])
    np.testing.assert_array_equal(reflect(np.arange(-3, 4), 1), [0] * 7)


def test_af_hand_example_both_edges():
    # two locations, two variables, 4 alternatives each, Re = 2: weights 0, 1/2, 1, 1/2, 0
    alternatives = np.array([[0, 1], [3, 2]])
    fitness = np.array([2.0, 1.0])
    # variable 0: location 0 at the lower edge, alternatives -2..2 -> 2, 1, 0, 1, 2:
    #   AF0 += 2 * [1, 1/2 + 1/2, 0, 0] = [2, 2, 0, 0]
    # location 1 at the upper edge, 1..5 -> 1, 2, 3, 2, 1:  AF0 += 1 * [0, 0, 1/2 + 1/2, 1]
    # variable 1: location 0 at 1, -1..3 -> 1, 0, 1, 2, 3:  AF1 += 2 * [1/2, 1, 1/2, 0]
    # location 1 at 2, 0..4 -> 0, 1, 2, 3, 2:               AF1 += 1 * [0, 1/2, 1, 1/2]
    expected = np.array([[2.0, 1.0], [2.0, 2.5], [1.0, 2.0], [1.0, 0.5]])
    np.testing.assert_allclose(accumulative_fitness(alternatives, fitness, 4, 2), expected)
    # + epsilon, then the loop-best (location 0: alternatives 0 and 1) zeroed
    with_eps = np.array([[0.0, 1.1], [2.1, 0.0], [1.1, 2.1], [1.1, 0.6]])
    af = accumulative_fitness(alternatives, fitness, 4, 2, epsilon=0.1, best=np.array([0, 1]))
    np.testing.assert_allclose(af, with_eps)
    # probabilities with PP = 0.3: 0.3 for the best, 0.7 * AF / (sum of the others) elsewhere
    p = alternative_probabilities(af, np.array([0, 1]), 0.3)
    np.testing.assert_allclose(p[:, 0], [0.3, 0.7 * 2.1 / 4.3, 0.7 * 1.1 / 4.3, 0.7 * 1.1 / 4.3])
    np.testing.assert_allclose(p[:, 1], [0.7 * 1.1 / 3.8, 0.3, 0.7 * 2.1 / 3.8, 0.7 * 0.6 / 3.8])


@pytest.mark.parametrize(("n_alt", "re", "position", "fit", "expected"), [
    # 2 alternatives, Re = 3 > 2: -3..3 -> 1, 0, 1, 0, 1, 0, 1 with weights 0, 1/3, 2/3, 1, ...
    #   alternative 0: 1/3 + 1 + 1/3 = 5/3; alternative 1: 2/3 + 2/3 = 4/3; times fitness 3
    (2, 3, 0, 3.0, [5.0, 4.0]),
    # 3 alternatives, Re = 4, at 1: -3..5 -> 1, 2, 1, 0, 1, 2, 1, 0, 1 (folded twice)
    #   weights 0, 1/4, 1/2, 3/4, 1, 3/4, 1/2, 1/4, 0 -> [3/4 + 1/4, 1/2 + 1 + 1/2, 1/4 + 3/4]
    (3, 4, 1, 4.0, [4.0, 8.0, 4.0]),
    # Re = 1: only the alternative itself (the weight at |k| = Re is 0)
    (6, 1, 5, 2.0, [0, 0, 0, 0, 0, 2.0]),
    # a single alternative takes everything
    (1, 3, 0, 2.0, [6.0]),
])
def test_af_radius_at_least_the_alternatives(n_alt, re, position, fit, expected):
    af = accumulative_fitness(np.array([[position]]), np.array([fit]), n_alt, re)
    np.testing.assert_allclose(af[:, 0], expected)


def test_af_matches_paper_loops_and_conserves_mass():
    rng = np.random.default_rng(7)
    n_alt = np.array([2, 9, 5, 1, 12])
    for re in (1, 2, 3, 6, 13):
        alternatives = np.column_stack([rng.integers(0, n, 8) for n in n_alt])
        fitness = rng.random(8)
        best = alternatives[3]
        af = accumulative_fitness(alternatives, fitness, n_alt, re, epsilon=0.05, best=best)
        np.testing.assert_allclose(
            af, af_reference(alternatives.tolist(), fitness, n_alt.tolist(), re, 0.05, best),
            rtol=1e-12, atol=1e-15)
        # the weights (Re - |k|) / Re sum to Re: total mass Re * sum(fitness) per variable
        raw = accumulative_fitness(alternatives, fitness, n_alt, re)
        np.testing.assert_allclose(raw.sum(axis=0), re * fitness.sum(), rtol=1e-12)
        assert not raw[n_alt.max() - 1, 0] and not af[5:, 2].any()  # no alternative past n


def test_probability_columns_sum_to_one():
    rng = np.random.default_rng(3)
    for pp in (0.0, 0.1, 0.5, 0.99, 1.0):
        af = rng.random((7, 5)) + 1e-3
        best = rng.integers(0, 7, 5)
        p = alternative_probabilities(af, best, pp)
        np.testing.assert_allclose(p.sum(axis=0), 1.0, rtol=1e-12)
        np.testing.assert_allclose(p[best, np.arange(5)], pp)
        assert (p >= 0).all()
    # a variable with a single alternative: the best keeps it
    np.testing.assert_allclose(alternative_probabilities(np.zeros((1, 2)), [0, 0], 0.3), [[1, 1]])


# --------------------------------------------------------------------------------------------
# fitness transforms
# --------------------------------------------------------------------------------------------


def test_fitness_transforms_by_hand():
    # inverse, scaled so the loop-best has 1: min / F; infeasible 0
    np.testing.assert_allclose(fitness_values([2.0, 4.0, np.inf, 8.0], "inverse"),
                               [1.0, 0.5, 0.0, 0.25])
    # rank among the 4 feasible: 5 worst (1), 0 (2), -3 and -3 tie for 3 and 4 (3.5); / 4
    expected = [3.5 / 4, 1 / 4, 0.0, 3.5 / 4, 2 / 4]
    np.testing.assert_allclose(fitness_values([-3.0, 5.0, np.inf, -3.0, 0.0], "rank"), expected)
    np.testing.assert_allclose(fitness_values([1.0, 3.0, 2.0], "rank"), [1.0, 1 / 3, 2 / 3])
    np.testing.assert_array_equal(fitness_values([np.inf, np.inf], "inverse"), [0.0, 0.0])
    with pytest.raises(ValueError, match="fitness='inverse'"):
        fitness_values([1.0, 0.0], "inverse")


# --------------------------------------------------------------------------------------------
# the binary reduction: each new bit equals the loop-best's bit with probability PP(i)
# --------------------------------------------------------------------------------------------


@pytest.mark.filterwarnings("ignore:on a 0/1 mask")  # re and epsilon are set on purpose here
@pytest.mark.parametrize(("pp1", "power", "re", "epsilon"), [(0.1, 1.0, 5, 1e-3),
                                                              (0.5, 0.5, 1, 1.0)])
def test_binary_agreement_with_loop_best_is_pp(spiral_mask, pp1, power, re, epsilon):
    loops, population = 6, 60
    opt = DolphinEcholocation(population=population, loops=loops, pp1=pp1, power=power, re=re,
                              epsilon=epsilon)
    opt.setup(spiral_mask, np.random.default_rng(11))
    i = np.arange(1, loops + 1)
    pp = pp1 + (1 - pp1) * (i**power - 1) / (loops**power - 1)  # eq. 1, written out again
    X = opt.ask()
    for loop in range(loops):
        F = spiral_mask.evaluate(X)
        best = X[np.argmin(F)]
        opt.tell(X, F)
        # exactly PP for the best bit and 1 - PP for the other, whatever AF, Re and epsilon
        cols = np.arange(X.shape[1])
        np.testing.assert_allclose(opt.probabilities[best, cols], pp[loop], rtol=1e-12)
        np.testing.assert_allclose(opt.probabilities[1 - best, cols], 1 - pp[loop], atol=1e-12)
        X = opt.ask()
        agreement = np.mean(X == best)
        sigma = np.sqrt(pp[loop] * (1 - pp[loop]) / X.size)  # binomial, 60 x 98 bits
        assert abs(agreement - pp[loop]) <= 5 * sigma + 1e-12, (loop, agreement, pp[loop])
    assert np.all(X == best)  # PP(loops) = 1: every location is the last loop-best


def test_index_sets_stay_sorted_and_distinct(small_indices):
    opt = DolphinEcholocation(population=40, loops=5, re=3)
    opt.setup(small_indices, np.random.default_rng(2))
    for _ in range(5):
        X = opt.ask()
        assert (np.diff(X, axis=1) > 0).all() and X.min() >= 1 and X.max() <= 28
        opt.tell(X, small_indices.evaluate(X))
        np.testing.assert_allclose(opt.probabilities.sum(axis=0), 1.0, rtol=1e-12)
    assert opt.best_f == pytest.approx(np.min(small_indices.evaluate(opt.best_x[None])))


# --------------------------------------------------------------------------------------------
# quality: the exhaustive optimum of a small index problem
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("objective", ["paper", "bic"])  # inverse and rank fitness
def test_reaches_exhaustive_optimum(objective):
    problem = KnotIndices(archimedean_spiral(30), n_knots=3, objective=objective)
    everything = np.array(list(itertools.combinations(range(1, 29), 3)))  # 3276 knot sets
    ranked = np.sort(problem.evaluate(everything))
    de_rank, rs_rank = [], []
    for seed in range(10):
        de = mk.minimize(problem, "dolphin", budget=600, seed=seed,
                         optimizer_kwargs={"population": 30})
        rs = mk.minimize(problem, "random_search", budget=600, seed=seed)
        de_rank.append(int(np.searchsorted(ranked, de.best_f)))
        rs_rank.append(int(np.searchsorted(ranked, rs.best_f)))
    assert np.median(de_rank) == 0, de_rank  # the optimum in at least half of the seeds
    assert max(de_rank) <= 4, de_rank  # always among the best 5 of 3276
    assert sum(d <= r for d, r in zip(de_rank, rs_rank, strict=True)) >= 8, (de_rank, rs_rank)


# --------------------------------------------------------------------------------------------
# runs: seeds, budget, callbacks
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("make", [lambda: KnotSelection("archimedean"),
                                  lambda: KnotIndices("archimedean", n_knots=6)])
def test_determinism_by_seed(make):
    a, b, c = (mk.minimize(make(), "dolphin", budget=330, seed=s,
                           optimizer_kwargs={"population": 30}) for s in (4, 4, 5))
    np.testing.assert_array_equal(a.best_x, b.best_x)
    assert a.best_f == b.best_f
    np.testing.assert_array_equal(a.trace_evaluations, b.trace_evaluations)
    np.testing.assert_array_equal(a.trace_best, b.trace_best)
    assert not np.array_equal(a.best_x, c.best_x) and a.best_f != c.best_f


@pytest.mark.parametrize(("budget", "population"), [(1, 50), (7, 50), (50, 50), (101, 50),
                                                    (237, 20), (64, 2)])
def test_budget_exact_with_derived_loops(small_indices, budget, population):
    batches = []
    result = mk.minimize(small_indices, "dolphin", budget=budget, seed=0,
                         optimizer_kwargs={"population": population},
                         callbacks=[lambda p: batches.append(p.batch_f.size)])
    full, rest = divmod(budget, population)
    assert result.n_evaluations == budget
    assert batches == [population] * full + ([rest] if rest else [])


@pytest.mark.parametrize(("budget", "used"), [(100, 30), (25, 25), (30, 30)])
def test_explicit_loops_end_the_run(small_indices, budget, used):
    result = mk.minimize(small_indices, "dolphin", budget=budget, seed=0,
                         optimizer_kwargs={"population": 10, "loops": 3})
    assert result.n_evaluations == used


def test_derived_loops_make_pp_reach_one(small_indices):
    opt = DolphinEcholocation(population=20)
    mk.minimize(small_indices, opt, budget=101, seed=0)  # 6 loops, the last of 1 location
    assert opt.n_loops == 6 and opt.loop == 6
    np.testing.assert_allclose(opt.pp, 0.1 + 0.9 * np.arange(6) / 5)


def test_callbacks_report_progress_and_can_stop(spiral_mask):
    seen = []
    result = mk.minimize(spiral_mask, "dolphin", budget=200, seed=1,
                         optimizer_kwargs={"population": 40}, callbacks=[seen.append])
    assert [p.n_evaluations for p in seen] == [40, 80, 120, 160, 200]
    best = [p.best_f for p in seen]
    assert best == sorted(best, reverse=True) and best[-1] == result.best_f
    stopped = mk.minimize(spiral_mask, "dolphin", budget=200, seed=1,
                          optimizer_kwargs={"population": 40}, callbacks=[lambda p: True])
    assert stopped.n_evaluations == 40


# --------------------------------------------------------------------------------------------
# parameters and encodings
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("kwargs", "name"), [
    ({"population": 1}, "population"), ({"population": 2.5}, "population"),
    ({"loops": 0}, "loops"), ({"loops": 1.5}, "loops"),
    ({"pp1": -0.1}, "pp1"), ({"pp1": 1.01}, "pp1"), ({"pp1": np.nan}, "pp1"),
    ({"power": 0}, "power"), ({"power": -1.0}, "power"),
    ({"re": 0}, "re"), ({"re": 2.5}, "re"),
    ({"epsilon": 0}, "epsilon"), ({"epsilon": -1e-3}, "epsilon"),
    ({"fitness": "log"}, "fitness"),
])
def test_bad_parameters(kwargs, name):
    with pytest.raises(ValueError, match=name):
        DolphinEcholocation(**kwargs)


def test_registered_by_name_with_params():
    opt = mk.get_optimizer("dolphin", population=12, re=3)
    assert isinstance(opt, DolphinEcholocation) and dolphin_module.DolphinEcholocation.name == \
        "dolphin"
    assert opt.hyperparameters() == {"population": 12, "loops": None, "pp1": 0.1, "power": 1.0,
                            "re": 3, "epsilon": 1e-3, "fitness": "auto"}


def test_rejects_continuous_encoding():
    with pytest.raises(ValueError, match="binary, integer"):
        mk.minimize(FreeKnots("archimedean", n_knots=4), "dolphin", budget=10, seed=0)


def test_inverse_fitness_refused_on_negative_objective():
    problem = KnotIndices(archimedean_spiral(30), n_knots=3, objective="bic")  # BIC < 0 here
    with pytest.raises(ValueError, match="fitness='inverse'"):
        mk.minimize(problem, "dolphin", budget=60, seed=0, optimizer_kwargs={"fitness": "inverse"})


def test_loops_from_the_budget_need_a_task(small_indices):
    with pytest.raises(ValueError, match="loops=None derives the number of loops"):
        DolphinEcholocation().setup(small_indices, np.random.default_rng(0))


@pytest.mark.parametrize("budget", [50, 333])
def test_external_ask_tell_loop_without_loops(small_indices, budget):
    """Set up on a task, DE knows its budget at setup: an external ask/tell loop runs the same
    run as minimize."""
    evaluator = mk.Evaluator(small_indices, budget)
    opt = DolphinEcholocation(population=20)
    opt.setup(evaluator.task, mk.make_rng(4))
    assert opt.n_loops == -(-budget // 20)
    while not evaluator.done and not opt.finished():
        X = opt.ask()
        F = evaluator(X)
        opt.tell(X[: F.size], F)
    reference = mk.minimize(small_indices, DolphinEcholocation(population=20), budget=budget,
                            seed=4)
    assert evaluator.n_evaluations == reference.n_evaluations == budget
    assert evaluator.best_f == reference.best_f
    np.testing.assert_array_equal(evaluator.best_x, reference.best_x)


@pytest.mark.parametrize("problem_factory", [
    lambda: KnotSelection(archimedean_spiral(60)),
    # one knot among two data indices (1 or 2): two alternatives, offset by the lower bound
    lambda: KnotIndices(archimedean_spiral(4), n_knots=1, degree=1),
])
def test_binary_fast_path_is_the_general_formula_bit_for_bit(problem_factory, monkeypatch):
    """On two alternatives per variable DE samples through binary_probabilities; forcing the
    general AF path must give the very same locations and probabilities, loop after loop."""
    problem = problem_factory()
    runs = []
    for general in (False, True):
        opt = DolphinEcholocation(population=12, loops=15)
        evaluator = mk.Evaluator(problem, 10_000)
        opt.setup(evaluator.task, mk.make_rng(9))
        if general:
            assert opt._binary
            opt._binary = False
        locations, probabilities = [], []
        while not opt.finished():
            X = opt.ask()
            opt.tell(X, evaluator(X))
            locations.append(opt.ask())
            probabilities.append(opt.probabilities.copy())
        runs.append((locations, probabilities))
    (loc_a, p_a), (loc_b, p_b) = runs
    assert len(loc_a) == len(loc_b) == 15
    for a, b in zip(loc_a, loc_b, strict=True):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(p_a, p_b, strict=True):
        np.testing.assert_array_equal(a[:2], b[:2])


def test_sample_alternatives_inverts_the_cumulative_distribution():
    rng = np.random.default_rng(0)
    p = rng.random((7, 5))
    p /= p.sum(axis=0)
    u = rng.random((400, 5))
    picked = dolphin_module.sample_alternatives(p, u)
    cumulative = np.cumsum(p, axis=0)
    reference = (u[:, :, None] >= cumulative.T[None, :, :]).sum(axis=2)
    np.testing.assert_array_equal(picked, reference)


# --------------------------------------------------------------------------------------------
# fitness="auto": inversion only for objectives with a natural zero; rank otherwise
# --------------------------------------------------------------------------------------------


def _noisy_spiral(scale: float):
    data = archimedean_spiral(80)
    noise = np.random.default_rng(5).normal(0.0, 0.02, data.points.shape)
    return type(data)(scale * (data.points + noise), name="noisy spiral")


def _de_run(problem, **options):
    return mk.minimize(problem, DolphinEcholocation(population=20, **options), budget=600,
                       seed=3)


def test_auto_fitness_on_bic_does_not_depend_on_the_data_scale():
    """BIC is defined up to a constant: rescaling the data shifts every value by n ln(c^2).
    With fitness="auto" (rank on BIC) the search must not change."""
    small = KnotIndices(_noisy_spiral(1.0), n_knots=6, objective="bic")
    large = KnotIndices(_noisy_spiral(1e8), n_knots=6, objective="bic")
    X = small.sample(np.random.default_rng(0), 50)
    shift = large.evaluate(X) - small.evaluate(X)
    np.testing.assert_allclose(shift, shift[0], rtol=1e-9)  # a constant shift
    # the values change sign with the scale: a transform chosen by sign would switch
    assert (small.evaluate(X) < 0).all() and (large.evaluate(X) > 0).all()
    a, b = _de_run(small), _de_run(large)
    np.testing.assert_array_equal(a.best_x, b.best_x)
    np.testing.assert_array_equal(a.trace_evaluations, b.trace_evaluations)
    np.testing.assert_array_equal(_de_run(small, fitness="rank").best_x, a.best_x)


def test_auto_fitness_on_the_paper_objective_is_the_seeds_inverse():
    problem = KnotIndices(_noisy_spiral(1.0), n_knots=6, objective="paper")
    auto, inverse = _de_run(problem), _de_run(problem, fitness="inverse")
    np.testing.assert_array_equal(auto.best_x, inverse.best_x)
    np.testing.assert_array_equal(auto.trace_best, inverse.trace_best)
    rank = _de_run(problem, fitness="rank")
    assert not np.array_equal(rank.trace_best, auto.trace_best)  # the choice matters here


@pytest.mark.parametrize("options", [{"re": 2}, {"epsilon": 0.5}, {"fitness": "rank"}])
def test_settings_without_effect_on_masks_warn(spiral_mask, options):
    evaluator = mk.Evaluator(spiral_mask, 100)
    with pytest.warns(UserWarning, match="re, epsilon and fitness have no effect"):
        DolphinEcholocation(**options).setup(evaluator.task, np.random.default_rng(0))


def test_no_warning_with_defaults_or_on_indices(small_indices, spiral_mask, recwarn):
    DolphinEcholocation().setup(mk.Evaluator(spiral_mask, 100).task, np.random.default_rng(0))
    DolphinEcholocation(re=2, fitness="rank").setup(mk.Evaluator(small_indices, 100).task,
                                                    np.random.default_rng(0))
    assert not [w for w in recwarn if issubclass(w.category, UserWarning)]
