"""Adapters to other optimizer libraries: by name, seeded, budgeted, with a clear message when
the library is missing. (The every-optimizer tests run them for budget, seeds and callbacks.)"""

from __future__ import annotations

import sys

import numpy as np
import pytest

import metaknot as mk
from metaknot.algorithms import CMAESKnots, NevergradOptimizer, PymooOptimizer
from metaknot.bspline import averaging_knots
from metaknot.problems import FreeKnots, KnotIndices, KnotSelection, get_curve

SPIRAL = get_curve("archimedean", n_points=60)


@pytest.mark.parametrize(("name", "module"), [("cmaes", "cmaes"), ("nevergrad", "nevergrad"),
                                              ("pymoo", "pymoo")])
def test_a_missing_library_is_named(monkeypatch, name, module):
    monkeypatch.setitem(sys.modules, module, None)  # import now fails
    with pytest.raises(ImportError, match=f"needs the {module} package"):
        mk.minimize(FreeKnots(SPIRAL, n_knots=5), name, budget=10, seed=0)


def test_nevergrad_variants_by_name():
    assert mk.get_optimizer("nevergrad:CMA").variant == "CMA"
    assert mk.get_optimizer("nevergrad:DiscreteOnePlusOne", batch_size=4).batch_size == 4
    with pytest.raises(ValueError, match="did you mean"):
        mk.minimize(KnotSelection(SPIRAL), "nevergrad:DiscreteOnePlusOn", budget=10, seed=0)
    with pytest.raises(ValueError, match="has no variants"):
        mk.get_optimizer("ga:fast")


@pytest.mark.parametrize("optimizer", ["NGOpt", "DiscreteOnePlusOne", "TwoPointsDE"])
def test_nevergrad_on_index_sets_evaluates_sorted_distinct_sets(optimizer):
    seen = []

    class Watching(KnotIndices):
        def evaluate(self, X):
            seen.append(np.array(X))
            return super().evaluate(X)

    problem = Watching(SPIRAL, n_knots=6)
    result = mk.minimize(problem, NevergradOptimizer(optimizer, batch_size=8), budget=200,
                         seed=1)
    X = np.concatenate(seen)
    assert len(X) == result.n_evaluations == 200
    assert (np.diff(X, axis=1) > 0).all() and X.min() >= 1 and X.max() <= 58


def test_nevergrad_batch_size_is_the_batch():
    sizes = []
    mk.minimize(KnotSelection(SPIRAL), NevergradOptimizer("DiscreteOnePlusOne", batch_size=7),
                budget=50, seed=0, callbacks=[lambda p: sizes.append(len(p.batch_f))])
    assert sizes == [7] * 7 + [1]


@pytest.mark.parametrize("k", [10, 20])
def test_cmaes_improves_on_the_averaging_knots(k):
    problem = FreeKnots("vivaldi", n_knots=k, objective="paper",
                        objective_options={"error_floor": 0.0})
    start = problem.evaluate(averaging_knots(problem.params, k, 3)[None, :])[0]
    infeasible = []
    result = mk.minimize(problem, CMAESKnots(), budget=3000, seed=0,
                         callbacks=[lambda p: infeasible.append(np.isinf(p.batch_f).sum())])
    assert result.best_f < 0.95 * start
    assert sum(infeasible) < 0.1 * result.n_evaluations


def test_cmaes_settings_matter():
    problem = FreeKnots("vivaldi", n_knots=10)
    base = mk.minimize(problem, CMAESKnots(), budget=400, seed=0)
    for options in ({"sigma": 0.4}, {"population": 20}, {"span_range": 20.0}):
        other = mk.minimize(problem, CMAESKnots(**options), budget=400, seed=0)
        assert not np.array_equal(other.trace_best, base.trace_best), options


@pytest.mark.parametrize("optimizer", ["nevergrad", "pymoo"])
def test_a_continuous_problem_without_knots_is_refused_by_name(optimizer):
    """The adapters map their unit box to knots: on another continuous problem they failed
    with "... 'params' is not one of them" (cmaes and nlopt refused it by name)."""

    class Sphere(mk.Problem):
        name = "sphere"
        encoding = mk.Encoding.continuous(3, 0.0, 1.0)

        def evaluate(self, X):
            return (np.asarray(X) ** 2).sum(axis=1)

        def decode(self, x):
            return x

    with pytest.raises(ValueError, match=f"optimizer '{optimizer}' needs a FreeKnots problem "
                                         "for continuous candidates; got 'sphere'"):
        mk.minimize(Sphere(), optimizer, budget=20, seed=0)


def test_cmaes_refuses_a_variable_knot_count():
    with pytest.raises(ValueError, match="fixed number of knots"):
        mk.minimize(FreeKnots(SPIRAL, n_knots=5, variable_count=True), "cmaes", budget=10)


def test_ngopt_surrogate_failure_falls_back_and_the_process_exits():
    """NGOpt's surrogate step fails under numpy 2 (a TypeError inside nevergrad); the adapter
    turns it into nevergrad's MetaModelFailure, so NGOpt falls back and the process ends (it
    used to hang on a leftover thread). Run in a subprocess with a timeout: a hang fails."""
    import subprocess

    code = ("import metaknot as mk\n"
            "from metaknot.problems import FreeKnots, get_curve\n"
            "p = FreeKnots(get_curve('archimedean', n_points=40), n_knots=6)\n"
            "r = mk.minimize(p, 'nevergrad:NGOpt', budget=150, seed=11)\n"
            "print(r.n_evaluations)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=240)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "150"


@pytest.mark.parametrize("algorithm", ["GA", "DE", "BRKGA"])
def test_pymoo_variants_by_name_and_reproducible(algorithm):
    assert mk.get_optimizer(f"pymoo:{algorithm}").variant == algorithm
    problem = KnotIndices(SPIRAL, n_knots=6)
    runs = [mk.minimize(problem, f"pymoo:{algorithm}", budget=300, seed=4) for _ in range(2)]
    np.testing.assert_array_equal(runs[0].best_x, runs[1].best_x)
    assert runs[0].n_evaluations == 300


def _pymoo_on(problem, algorithm):
    optimizer = PymooOptimizer(algorithm, population=20)
    optimizer.setup(mk.Evaluator(problem, 100).task, np.random.default_rng(0))
    return optimizer


def test_pymoo_decodes_random_keys():
    keys = np.random.default_rng(3).random((200, 58))
    mask = _pymoo_on(KnotSelection(SPIRAL), "DE").decode(keys)
    np.testing.assert_array_equal(mask, (keys > 0.5).astype(int))
    indices = _pymoo_on(KnotIndices(SPIRAL, n_knots=6), "BRKGA").decode(keys[:, :6])
    assert (np.diff(indices, axis=1) > 0).all() and indices.min() >= 1 and indices.max() <= 58
    free = _pymoo_on(FreeKnots(SPIRAL, n_knots=6), "DE")
    knots = free.decode(keys[:, :6])
    np.testing.assert_allclose(knots, [free.box.knots(k) for k in keys[:, :6]])
    assert (np.diff(knots, axis=1) > 0).all()


def test_pymoo_ga_genotypes():
    assert _pymoo_on(KnotSelection(SPIRAL), "GA").genotype == "binary"
    assert _pymoo_on(KnotIndices(SPIRAL, n_knots=6), "GA").genotype == "integer"
    assert _pymoo_on(FreeKnots(SPIRAL, n_knots=6), "GA").genotype == "keys"
    ga = _pymoo_on(KnotIndices(SPIRAL, n_knots=6), "GA")
    repaired = ga.decode(np.array([[3.2, 3.4, 10.0, 10.0, 57.6, 58.0]]))
    assert (np.diff(repaired, axis=1) > 0).all()


@pytest.mark.parametrize("variant", ["GA", "NSGA2"])
def test_pymoo_ends_the_run_when_it_runs_out_of_new_masks(variant):
    """A population of 50 on a mask of five bits (32 candidates): pymoo's mating, which
    eliminates duplicates, runs out of new candidates and pymoo ends the search; the run ends
    there, before its budget, with the best of the whole space (checked by evaluating all 32),
    not with a crash."""
    u = np.linspace(0.0, 1.0, 7)
    problem = KnotSelection(np.column_stack((np.cos(3 * u), np.sin(3 * u))), degree=5)
    assert problem.encoding.n_var == 5
    every = np.array([[(m >> b) & 1 for b in range(5)] for m in range(32)])
    result = mk.minimize(problem, PymooOptimizer(variant, population=50), budget=300, seed=1)
    assert result.status == "ok" and result.n_evaluations < 300
    assert result.best_f == problem.evaluate(every).min()


def test_pymoo_population_matters():
    problem = KnotSelection(SPIRAL)
    small = mk.minimize(problem, PymooOptimizer("GA", population=10), budget=300, seed=0)
    large = mk.minimize(problem, PymooOptimizer("GA", population=60), budget=300, seed=0)
    assert not np.array_equal(small.trace_best, large.trace_best)


def test_finite_penalty_is_worse_than_every_finite_value_seen():
    from metaknot.algorithms._adapters import FinitePenalty

    penalty = FinitePenalty()
    np.testing.assert_array_equal(penalty(np.array([np.inf])), [1e12])  # nothing seen yet
    values = penalty(np.array([-50.0, np.inf, -80.0]))  # BIC values are negative
    assert values[1] > -50.0 and values[1] == -50.0 + 50.0 + 1.0
    values = penalty(np.array([3.0, np.inf]))
    assert values[1] == 3.0 + 3.0 + 1.0 and values[0] == 3.0


def test_the_finite_penalty_of_one_value_is_that_of_a_batch_of_one():
    """nlopt's objective takes the scalar path: the same values and the same worst value seen
    as the batch path, over finite, infinite and NaN values in turn."""
    from metaknot.algorithms._adapters import FinitePenalty

    one, batch = FinitePenalty(), FinitePenalty()
    for value in (np.inf, 3.0, np.nan, -2.0, 7.5, np.inf, -np.inf, 1.0):
        assert one.one(value) == batch(np.array([value]))[0]
        assert one.worst == batch.worst
    assert one.value == 7.5 + 7.5 + 1.0
