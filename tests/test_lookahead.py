"""Steps asked ahead (:meth:`metaknot.Optimizer.acceptance`): the (1+1) EA's batches of the next
steps' children, counted up to the first one taken, leave the run of one step per call."""

from __future__ import annotations

import numpy as np
import pytest

import metaknot as mk
from metaknot.algorithms.one_plus_one import OnePlusOneEA
from metaknot.budget import Evaluator
from metaknot.callbacks import StopWhenStalled
from metaknot.problems import KnotIndices, KnotSelection, get_curve
from tests.test_fast_path import assert_same_run

SPIRAL = get_curve("archimedean", n_points=60)
OUTLINE = get_curve("epitrochoid", n_points=80)


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
@pytest.mark.parametrize(("problem", "options"), [
    (lambda closed: KnotSelection(OUTLINE if closed else SPIRAL, closed=closed), {}),
    (lambda closed: KnotIndices(OUTLINE if closed else SPIRAL, n_knots=8, closed=closed),
     {"max_step": 3}),
    (lambda closed: KnotSelection(OUTLINE if closed else SPIRAL, closed=closed,
                                  objective="error_bounded"), {"rate": 0.05}),
], ids=["mask", "indices", "mask-error-bounded"])
def test_the_one_plus_one_ea_asking_ahead_runs_as_one_step_per_call(monkeypatch, problem,
                                                                  options, closed):
    calls = []
    evaluate = Evaluator.__call__

    def counting(self, X, near=None, accept=None):
        calls.append(len(X))
        return evaluate(self, X, near=near, accept=accept)

    monkeypatch.setattr(Evaluator, "__call__", counting)
    ahead = mk.minimize(problem(closed), "one_plus_one", budget=1500, seed=5,
                        optimizer_kwargs=options)
    asked_ahead = list(calls)
    calls.clear()
    with monkeypatch.context() as m:
        m.setattr(OnePlusOneEA, "lookahead", 1)  # one step per call
        single = mk.minimize(problem(closed), "one_plus_one", budget=1500, seed=5,
                             optimizer_kwargs=options)
    assert ahead.status == single.status == "ok"
    assert_same_run(ahead, single, same_fits=False)  # best, values, trace, delta evaluations
    # the children scored after the one taken are accounted fits, not a budget violation
    assert ahead.audited_fits == ahead.accounted_fits > single.audited_fits
    assert max(calls) == 1 and len(calls) == 1500
    assert max(asked_ahead) == OnePlusOneEA.lookahead  # long runs of rejections, batched
    assert len(asked_ahead) < 1500 / 3  # the point: far fewer calls


def test_the_rows_after_the_one_taken_are_dropped_unseen():
    problem = KnotSelection(SPIRAL)
    rng = np.random.default_rng(0)
    X = problem.sample(rng, 6)
    values = problem.evaluate(X)
    seen = []
    evaluator = Evaluator(problem, 100, callbacks=[lambda p: seen.append(p.batch_f.copy())])
    accept = np.full(6, -np.inf)
    accept[3] = values[3]  # the fourth row is taken (at its own value: "at most")
    F = evaluator(X, accept=accept)
    np.testing.assert_array_equal(F, values[:4])
    assert evaluator.n_evaluations == 4
    assert evaluator.best_f == values[:4].min()
    np.testing.assert_array_equal(seen[0], values[:4])
    # the two dropped fits are accounted (fits made inside evaluations), not a violation
    assert evaluator.accounted_fits == 6
    # nothing taken: every row counts
    F = evaluator(X, accept=np.full(6, -np.inf))
    assert F.size == 6 and evaluator.n_evaluations == 10
    # delta evaluations are counted for the rows kept only
    near = X[0]
    moves = np.repeat(near[None, :], 5, axis=0)
    moves[np.arange(5), np.arange(5) + 10] ^= 1
    move_values = problem.evaluate(moves)
    accept = np.full(5, -np.inf)
    accept[1] = move_values[1] * (1 + 1e-9)  # delta values equal full ones to 1e-9
    before = evaluator.delta_evaluations
    assert evaluator(moves, near=near, accept=accept).size == 2
    assert evaluator.delta_evaluations - before == 2


def test_accept_is_checked():
    problem = KnotSelection(SPIRAL)
    X = problem.sample(np.random.default_rng(0), 3)
    evaluator = Evaluator(problem, 10)
    with pytest.raises(ValueError, match="one value per candidate"):
        evaluator(X, accept=np.zeros(2))
    front = KnotSelection(SPIRAL, objective="pareto")
    with pytest.raises(ValueError, match="two"):
        Evaluator(front, 10)(X, accept=np.zeros(3))
    assert evaluator.n_evaluations == 0


def test_a_stop_asked_by_a_callback_takes_effect_after_the_rows_counted():
    """StopWhenStalled stops a one-step-per-call run at its patience; asking ahead, after the
    batch in which the patience ran out (the rows counted are the run's, as before)."""
    problem = KnotSelection(SPIRAL)
    result = mk.minimize(problem, "one_plus_one", budget=20000, seed=2,
                         callbacks=[StopWhenStalled(300)])
    assert result.n_evaluations < 20000
    trace = result.trace.columns()
    last_improvement = trace["evaluations"][trace["improvement"]][-1]
    stalled = result.n_evaluations - last_improvement
    assert 300 <= stalled < 300 + OnePlusOneEA.lookahead
