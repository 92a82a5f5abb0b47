"""Delta evaluation inside runs: the knot problems' ``evaluate_near`` and the optimizers that
use it give the values a full evaluation gives, and the run record says how many candidates
the delta path decided."""

from __future__ import annotations

import numpy as np
import pytest

import metaknot as mk
from metaknot.budget import Evaluator
from metaknot.optimizer import Optimizer
from metaknot.problems import FreeKnots, KnotIndices, KnotSelection, get_curve

POINTS = get_curve("archimedean", n_points=90).points


def neighbours_of(problem, x, rng, count=60):
    """Candidates one or two local moves from ``x`` in the problem's encoding."""
    kind = problem.encoding.kind
    rows = []
    for _ in range(count):
        y = np.array(x, copy=True)
        if kind == "binary":
            y[rng.integers(y.size)] ^= 1
            if rng.random() < 0.3:
                y[rng.integers(y.size)] ^= 1
        elif kind == "integer":
            k = rng.integers(y.size)
            y[k] = np.clip(y[k] + rng.choice((-2, -1, 1, 2)), 1, POINTS.shape[0] - 2)
            y = np.sort(y)
        else:
            k = rng.integers(y.size)
            y[k] = y[k] + rng.normal(0, 0.01) if not np.isnan(y[k]) else rng.random()
            y = np.sort(y)
        rows.append(y)
    return np.array(rows)


PROBLEMS = {
    "mask-paper": lambda: KnotSelection(POINTS, objective="paper"),
    "mask-bounded-maxdev": lambda: KnotSelection(
        POINTS, objective="error_bounded", objective_options={"relative_tolerance": 1e-3}),
    "mask-pareto": lambda: KnotSelection(POINTS, objective="pareto"),
    "indices-bic": lambda: KnotIndices(POINTS, n_knots=12, objective="bic", degree=2),
    "free-paper": lambda: FreeKnots(POINTS, n_knots=10, objective="paper", degree=4),
    "free-variable": lambda: FreeKnots(POINTS, n_knots=12, variable_count=True,
                                       objective="error_bounded",
                                       objective_options={"metric": "rmse"}),
}


def assert_near_equals_full(problem, x, rng):
    """The neighbours of ``x`` scored by ``evaluate_near`` as the full evaluation scores them
    (values and metrics, to 1e-9), most by the delta path; returns them and the full values."""
    X = neighbours_of(problem, x, rng)
    values, metrics, n_delta = problem.evaluate_near(X, x)
    full, full_metrics = problem.evaluate_with_metrics(X)
    np.testing.assert_allclose(values, full, rtol=1e-9)
    assert metrics.keys() == full_metrics.keys()
    for key in metrics:
        np.testing.assert_allclose(metrics[key], full_metrics[key], rtol=1e-9)
    assert np.count_nonzero(n_delta) > len(X) // 2
    return X, full


@pytest.mark.parametrize("name", PROBLEMS)
def test_evaluate_near_equals_the_full_evaluation(name):
    problem = PROBLEMS[name]()
    rng = np.random.default_rng(1)
    if problem.encoding.kind == "binary":
        x = (rng.random(problem.encoding.n_var) < 0.3).astype(np.int64)
    elif problem.encoding.kind == "integer":
        x = np.sort(rng.choice(np.arange(1, POINTS.shape[0] - 1), problem.n_knots, replace=False))
    else:
        x = np.sort(rng.uniform(0.05, 0.95, problem.n_knots))
        if getattr(problem, "variable_count", False):
            x[-3:] = np.nan
    X, full = assert_near_equals_full(problem, x, rng)
    problem.delta_evaluation = False
    assert np.count_nonzero(problem.evaluate_near(X, x)[2]) == 0
    np.testing.assert_array_equal(problem.evaluate_near(X, x)[0], full)


def test_closed_curves_use_delta_evaluation_and_infeasible_origins_are_evaluated_in_full():
    rng = np.random.default_rng(2)
    closed = KnotSelection("epitrochoid", closed=True)
    x = (rng.random(closed.encoding.n_var) < 0.3).astype(np.int64)
    X = neighbours_of(closed, x, rng, 10)
    values, _, n_delta = closed.evaluate_near(X, x)
    assert np.count_nonzero(n_delta) > 5
    np.testing.assert_allclose(values, closed.evaluate(X), rtol=1e-9)
    problem = KnotIndices(POINTS, n_knots=5)
    x = np.array([3, 3, 10, 20, 30])  # coincident knots: the origin cannot be fitted
    X = np.array([[3, 4, 10, 20, 30], [2, 3, 10, 20, 30]])
    values, _, n_delta = problem.evaluate_near(X, x)
    assert np.count_nonzero(n_delta) == 0
    np.testing.assert_array_equal(values, problem.evaluate(X))


@pytest.mark.parametrize("optimizer,budget", [("one_plus_one", 1500), ("local_search", 3000)])
def test_runs_use_delta_evaluation_and_end_where_full_evaluation_ends(optimizer, budget):
    results = {}
    for delta in (True, False):
        problem = KnotSelection(POINTS, objective="paper")
        problem.delta_evaluation = delta
        results[delta] = mk.minimize(problem, optimizer, budget=budget, seed=4)
    fast, full = results[True], results[False]
    assert full.delta_evaluations == 0
    assert fast.delta_evaluations > 0.5 * fast.n_evaluations
    assert fast.record()["delta_evaluations"] == fast.delta_evaluations
    assert fast.n_evaluations == full.n_evaluations
    np.testing.assert_allclose(fast.best_f, full.best_f, rtol=1e-9)
    np.testing.assert_array_equal(fast.best_x, full.best_x)
    np.testing.assert_allclose(fast.trace.best_f, full.trace.best_f, rtol=1e-9)


def test_moves_count_against_the_budget_and_optimizers_cannot_reach_evaluate_near():
    problem = KnotSelection(POINTS)
    evaluator = Evaluator(problem, 5)
    x = np.zeros(problem.encoding.n_var, dtype=np.int64)
    x[::10] = 1
    X = neighbours_of(problem, x, np.random.default_rng(0), 8)
    F = evaluator(X, near=x)
    assert F.size == 5 and evaluator.n_evaluations == 5
    assert evaluator.delta_evaluations == 5
    with pytest.raises(AttributeError, match="evaluator"):
        evaluator.task.evaluate_near(X, x)


def test_the_default_move_origin_is_none():
    class Plain(Optimizer):
        pass

    assert Plain().move_origin() is None


def test_a_trace_recorded_one_candidate_at_a_time_equals_one_recorded_in_batches():
    from metaknot import Progress, TraceRecorder

    rng = np.random.default_rng(3)
    values = np.where(rng.random(400) < 0.1, np.inf, rng.random(400) * 10)
    rmse = rng.random(400)
    cp = rng.integers(5, 50, 400).astype(float)
    extra = rng.random(400)  # a metric that appears only from evaluation 148 on
    recorders = {}
    for size in (1, 7):
        recorder = TraceRecorder(per_decade=5)
        best = np.inf
        for start in range(0, 400, size):
            stop = min(start + size, 400)
            metrics = {"rmse": rmse[start:stop], "n_control_points": cp[start:stop]}
            if start >= 147:  # a batch boundary for both sizes
                metrics["extra"] = extra[start:stop]
            best = min(best, float(values[start:stop].min()))
            recorder.on_batch(Progress(stop, 400, best, values[start:stop], 0.0, metrics))
        recorders[size] = recorder.trace()
    one, batched = recorders[1], recorders[7]
    np.testing.assert_array_equal(one.evaluations, batched.evaluations)
    np.testing.assert_array_equal(one.best_f, batched.best_f)
    np.testing.assert_array_equal(one.improvement, batched.improvement)
    np.testing.assert_array_equal(one.checkpoint, batched.checkpoint)
    assert one.metrics.keys() == batched.metrics.keys() == {"rmse", "n_control_points", "extra"}
    for key in one.metrics:
        np.testing.assert_array_equal(one.metrics[key], batched.metrics[key])


def test_mask_rows_far_from_the_origin_still_score_as_the_full_evaluation():
    problem = KnotSelection(POINTS, objective="error_bounded",
                            objective_options={"relative_tolerance": 1e-3})
    n_var = problem.encoding.n_var
    rng = np.random.default_rng(8)
    near = (rng.random(n_var) < 0.3).astype(np.int64)
    rows = [near.copy(), np.zeros(n_var, dtype=np.int64), np.ones(n_var, dtype=np.int64),
            1 - near]
    ends = near.copy()
    ends[[0, -1]] ^= 1  # the first and the last bit: a replacement spanning every knot
    rows.append(ends)
    rows += [(rng.random(n_var) < 0.3).astype(np.int64) for _ in range(5)]
    X = np.array(rows)
    values, metrics, n_delta = problem.evaluate_near(X, near)
    full, full_metrics = problem.evaluate_with_metrics(X)
    np.testing.assert_allclose(values, full, rtol=1e-9)
    for key in metrics:
        np.testing.assert_allclose(metrics[key], full_metrics[key], rtol=1e-9)
    assert np.count_nonzero(n_delta) >= 1  # the origin itself at least


def _knot_problem(kind: str, closed: bool):
    points = get_curve("epitrochoid", n_points=60).points
    if kind == "mask":
        return KnotSelection(points, closed=closed)
    return (KnotIndices if kind == "indices" else FreeKnots)(points, n_knots=8, closed=closed)


@pytest.mark.parametrize("closed", [False, True])
@pytest.mark.parametrize("kind", ["mask", "indices", "free"])
def test_evaluate_near_and_decode_take_one_candidate(kind, closed):
    """``near`` of several rows was a numba typing error (masks) or silently its first row;
    ``decode`` of several rows decoded the first. One row, 1-D or ``(1, n_var)``, is taken."""
    problem = _knot_problem(kind, closed)
    rng = np.random.default_rng(0)
    near = problem.sample(rng, 1)[0]
    X = problem.sample(rng, 3)
    values = problem.evaluate(X)
    n_var = problem.encoding.n_var
    for two_rows in (np.stack((near, near)), np.stack((near, X[0]))):
        with pytest.raises(ValueError, match=rf"near must be one candidate, shape \({n_var},\)"):
            problem.evaluate_near(X, two_rows)
        with pytest.raises(ValueError, match=rf"decode takes one candidate, shape \({n_var},\)"):
            problem.decode(two_rows)
    with pytest.raises(ValueError, match=rf"near must be one candidate, shape \({n_var},\)"):
        problem.evaluate_near(X, near[None, None, :])
    for one in (near, near[None, :]):
        got = problem.evaluate_near(X, one)[0]
        assert np.allclose(got, values, rtol=1e-9, equal_nan=True)
    assert problem.decode(near[None, :]).objective_value == problem.decode(near).objective_value
