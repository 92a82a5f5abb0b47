"""The audited budget: what an optimizer can reach, the fit tally, and the run's audit.

An optimizer is handed a :class:`~metaknot.Task` (an allowlist) and, if it overrides ``run``,
the :class:`~metaknot.Evaluator`. Eight routes once scored candidates without the budget
counting them; each has a test here: the first six are closed (the attribute is not there),
the last two (and any other way to the fitting layer) are caught by the audit, which marks the
run ``status="budget_violation"`` with both counts. Honest runs of every registered optimizer,
open and closed, must pass the audit.
"""

from __future__ import annotations

import gc

import numpy as np
import pytest

import metaknot as mk
from metaknot.bspline import closed_parameterize, fit_spline, parameterize
from metaknot.bspline.curve import ClosedCurve, OpenCurve
from metaknot.bspline.moves import MoveEvaluator, PeriodicMoveEvaluator
from metaknot.budget import fits_tallied
from metaknot.problems import FreeKnots, KnotIndices, KnotProblem, KnotSelection, get_curve
from tests.test_all_optimizers import CASES, IDS

SPIRAL = get_curve("archimedean", n_points=60)
OUTLINE = get_curve("epitrochoid", n_points=80)


# --------------------------------------------------------------------------------------------
# the fit tally: every entry point of the fitting layer counts its fits


def tallied(action) -> int:
    before = fits_tallied()
    action()
    return fits_tallied() - before


def test_every_entry_point_of_the_fitting_layer_counts_its_fits():
    q = SPIRAL.points
    u = parameterize(q, "centripetal")
    masks = np.random.default_rng(0).random((7, u.size - 2)) < 0.3
    assert tallied(lambda: OpenCurve(u, q, 3).evaluate_masks(masks)) == 7
    knots = u[[10, 20, 30, 40]]
    assert tallied(lambda: fit_spline(u, q, knots)) == 1
    moves = MoveEvaluator(u, q, knots)
    assert tallied(lambda: moves.rebind(u[[10, 25, 40]])) == 1
    assert tallied(lambda: moves.evaluate(np.concatenate((knots, knots[:3])),
                                          np.array([0, 4, 7]))[0]) == 2
    w = closed_parameterize(OUTLINE.points)
    rows = np.where(np.random.default_rng(1).random((5, w.size - 1)) < 0.3, w[1:], np.nan)
    closed = ClosedCurve(w, OUTLINE.points, 3)
    assert tallied(lambda: closed.evaluate_positions(rows, nan_is_absent=True)) == 5
    assert tallied(lambda: closed.fit(w[[10, 30, 50, 70]])) == 1
    assert tallied(lambda: closed.errors([w[[10, 40]], w[[20, 60]]], "max_deviation")) == 2
    closed_knots = w[[10, 20, 30, 40, 50, 60, 70]]
    closed_moves = PeriodicMoveEvaluator(w, OUTLINE.points, closed_knots)
    assert tallied(lambda: closed_moves.rebind(w[[10, 25, 40, 55, 70]])) == 1
    assert tallied(lambda: closed_moves.evaluate(np.concatenate((closed_knots, closed_knots[:4])),
                                                 np.array([0, 7, 11]))[0]) == 2
    assert tallied(lambda: closed_moves.evaluate_replacements([0, 2, 4], [1, 2, 4], [0.3],
                                                              [0, 0, 1, 1])[0]) == 3


def test_the_tally_is_per_thread():
    import threading

    q = SPIRAL.points
    u = parameterize(q, "centripetal")
    seen = {}

    def elsewhere():
        seen["before"] = fits_tallied()
        OpenCurve(u, q, 3).evaluate_masks(np.ones((3, u.size - 2), dtype=bool))
        seen["after"] = fits_tallied()

    before = fits_tallied()
    thread = threading.Thread(target=elsewhere)
    thread.start()
    thread.join()
    assert fits_tallied() == before
    assert seen["after"] - seen["before"] == 3


# --------------------------------------------------------------------------------------------
# the eight routes


class Bypass(mk.Optimizer):
    """Random search that also scores ``extra`` candidates per ask by ``route``, behind the
    evaluator's back, and keeps the best of them as its incumbent's seed."""

    def __init__(self, route: str, extra: int = 50) -> None:
        self.route = route
        self.extra = extra

    def ask(self) -> np.ndarray:
        X = self.problem.sample(self.rng, self.extra)
        F = ROUTES[self.route](self.problem, X)
        return X[np.argsort(F)[:4]]

    def tell(self, X, F):
        pass


def find_problem(task) -> KnotProblem:
    """The problem behind ``task``, found among all live objects."""
    for obj in gc.get_objects():
        if isinstance(obj, KnotProblem) and obj.encoding is task.encoding:
            return obj
    raise LookupError("not found")


ROUTES = {
    "task._problem.evaluate": lambda t, X: t._problem.evaluate(X),
    "task._evaluator.problem.evaluate": lambda t, X: t._evaluator.problem.evaluate(X),
    "task.objective(task._fit_batch(X), task.info)":
        lambda t, X: t.objective(t._fit_batch(X), t.info),
    "task._evaluate_moves": lambda t, X: t._evaluate_moves(None, X, X[0]),
    "object.__getattribute__(task, '_problem')":
        lambda t, X: object.__getattribute__(t, "_problem").evaluate(X),
    "task.sample.__self__": lambda t, X: t.sample.__self__.evaluate(X),
    "gc.get_objects()": lambda t, X: find_problem(t).evaluate(X),
    "OpenCurve(params, points, degree).evaluate_masks":
        lambda t, X: OpenCurve(t.params, t.points, t.degree).evaluate_masks(X.astype(bool)).sse
        * (X.sum(axis=1) + t.degree + 1),
}
CLOSED = list(ROUTES)[:6]
AUDITED = list(ROUTES)[6:]


@pytest.mark.parametrize("route", CLOSED)
def test_routes_through_the_task_are_closed(route):
    with pytest.raises(AttributeError) as error:
        mk.minimize(KnotSelection(SPIRAL), Bypass(route), budget=20, seed=0)
    message = str(error.value)
    assert "evaluator" in message or "public settings" in message or "_problem" in message


@pytest.mark.parametrize("route", AUDITED)
def test_routes_around_the_task_are_marked_by_the_audit(route):
    result = mk.minimize(KnotSelection(SPIRAL), Bypass(route, extra=50), budget=20, seed=0)
    assert result.status == "budget_violation"
    assert result.n_evaluations == 20
    # 5 asks of 50 candidates scored behind the evaluator's back, 20 through it
    assert result.audited_fits == 5 * 50 + 20
    assert result.accounted_fits == 20
    assert "made 270 fits during the run, the run accounts for 20" in result.error
    record = result.record()
    assert (record["status"], record["audited_fits"], record["accounted_fits"]) == \
        ("budget_violation", 270, 20)


def test_an_honest_copy_of_the_bypass_passes_the_audit():
    """The same optimizer scoring its extra candidates through the evaluator: no violation."""

    class Honest(Bypass):
        def run(self, evaluator):
            while not evaluator.done:
                X = self.problem.sample(self.rng, self.extra)
                evaluator(X)

    result = mk.minimize(KnotSelection(SPIRAL), Honest("gc.get_objects()"), budget=120, seed=0)
    assert (result.status, result.audited_fits, result.accounted_fits) == ("ok", 120, 120)


def test_the_gc_route_is_caught_on_closed_curves_and_through_the_move_evaluator():
    closed = KnotSelection(OUTLINE, closed=True)
    result = mk.minimize(closed, Bypass("gc.get_objects()", extra=30), budget=12, seed=0)
    assert result.status == "budget_violation" and result.audited_fits == 3 * 30 + 12

    class Mover(mk.Optimizer):
        def ask(self):
            moves = next(o for o in gc.get_objects() if isinstance(o, MoveEvaluator))
            u = np.asarray(self.problem.params)
            moves.rebind(u[[5, 15, 25]])  # a fit of knots of its own choosing
            return self.problem.sample(self.rng, 2)

        def tell(self, X, F):
            pass

    problem = KnotSelection(SPIRAL)
    bait = MoveEvaluator(problem.params, problem.points, problem.params[[10, 20]])  # noqa: F841
    result = mk.minimize(problem, Mover(), budget=6, seed=0)
    assert result.status == "budget_violation"
    assert (result.audited_fits, result.accounted_fits) == (3 + 6, 6)


# --------------------------------------------------------------------------------------------
# falsifying the record


class Resetting(mk.Optimizer):
    """Tries to make the evaluator forget what it counted."""

    def __init__(self, how: str) -> None:
        self.how = how

    def run(self, evaluator):
        for _ in range(40):
            if evaluator.done:
                if self.how == "public":
                    evaluator.n_evaluations = 0
                else:
                    evaluator._n_evaluations = 0  # private: reachable, and audited
            evaluator(self.problem.sample(self.rng, 5))


def test_the_evaluation_count_cannot_be_reset_and_a_private_reset_is_caught():
    with pytest.raises(AttributeError):
        mk.minimize(KnotSelection(SPIRAL), Resetting("public"), budget=20, seed=0)
    result = mk.minimize(KnotSelection(SPIRAL), Resetting("private"), budget=20, seed=0)
    assert result.status == "budget_violation"
    assert (result.n_evaluations, result.audited_fits) == (20, 200)  # 40 batches of 5


class Enlarging(mk.Optimizer):
    """Overrides ``run`` and gives itself a larger budget."""

    def __init__(self, how: str) -> None:
        self.how = how

    def run(self, evaluator):
        if self.how == "public":
            evaluator.budget = 10**6
        else:
            evaluator._budget = 10**6
        while evaluator.n_evaluations < 500:
            evaluator(self.problem.sample(self.rng, 50))


def test_the_budget_cannot_be_changed_and_a_private_change_is_caught():
    with pytest.raises(AttributeError):
        mk.minimize(KnotSelection(SPIRAL), Enlarging("public"), budget=10, seed=0)
    result = mk.minimize(KnotSelection(SPIRAL), Enlarging("private"), budget=10, seed=0)
    assert result.status == "budget_violation" and result.n_evaluations == 500
    assert "the budget changed from 10 to 1000000" in result.error
    assert "500 evaluations were recorded against a budget of 10" in result.error
    assert result.budget == result.record()["budget"] == 10  # the budget it was given


def test_the_task_is_read_only_and_has_no_private_attributes():
    problem = FreeKnots(SPIRAL, n_knots=5, variable_count=True)
    task = mk.Evaluator(problem, 10).task
    for name in ("_problem", "_evaluator", "_fit_batch", "_moves", "evaluate_near", "decode",
                 "delta_evaluation", "__dict__"):
        with pytest.raises(AttributeError):
            getattr(task, name)
    with pytest.raises(AttributeError, match="read-only"):
        task.degree = 5
    with pytest.raises(AttributeError):
        task.count_fits.__self__._evaluator  # noqa: B018 - the bound object is the task
    with pytest.raises(ValueError, match="read-only"):
        task.params[0] = 1.0  # arrays come as read-only views
    assert getattr(task.pad, "__self__", None) is not problem
    np.testing.assert_array_equal(task.pad([0.5]), problem.pad([0.5]))
    assert task.sample.__self__ is task
    with pytest.raises(ValueError, match="whole number"):
        task.count_fits(-3)


# --------------------------------------------------------------------------------------------
# honest runs pass


def make(kind: str, closed: bool) -> KnotProblem:
    data = OUTLINE if closed else SPIRAL
    if kind == "binary":
        return KnotSelection(data, closed=closed)
    if kind == "integer":
        return KnotIndices(data, n_knots=6, closed=closed)
    return FreeKnots(data, n_knots=6, closed=closed)


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
@pytest.mark.parametrize(("name", "kind"), CASES, ids=IDS)
def test_every_optimizer_passes_the_audit(name, kind, closed):
    result = mk.minimize(make(kind, closed), name, budget=60, seed=3)
    assert result.status == "ok", result.error
    assert 0 < result.audited_fits <= result.accounted_fits


def test_moves_and_callbacks_that_fit_are_accounted_for():
    """Delta evaluation rebinds its move evaluator (a fit beyond the candidates), and a user's
    callback may decode the incumbent: neither is the optimizer's doing."""
    problem = KnotSelection(SPIRAL)

    def decode_incumbent(progress):
        fit_spline(problem.params, problem.points, problem.params[[10, 30]])

    result = mk.minimize(problem, "one_plus_one", budget=200, seed=1,
                         callbacks=[decode_incumbent])
    assert result.status == "ok"
    assert result.delta_evaluations > 0
    assert result.audited_fits > result.n_evaluations  # rebinds and the callback's fits


def test_a_failed_run_is_audited_too():
    class Crashing(Bypass):
        def tell(self, X, F):
            raise RuntimeError("boom")

    with pytest.raises(RuntimeError) as error:
        mk.minimize(KnotSelection(SPIRAL), Crashing("gc.get_objects()"), budget=20, seed=0)
    partial = error.value.partial_result
    assert partial.status == "budget_violation"
    assert "the run also failed: RuntimeError: boom" in partial.error


def test_evaluators_and_their_tasks_are_freed():
    import weakref

    problem = KnotSelection(SPIRAL)
    task = mk.Evaluator(problem, 10).task
    assert task.budget == 10  # the task keeps its evaluator
    evaluator = mk.Evaluator(problem, 10)
    assert evaluator.task is evaluator.task
    gone = weakref.ref(evaluator), weakref.ref(evaluator.task), weakref.ref(task)
    gc.disable()  # freed by reference counting alone: no cycle between evaluator and task
    try:
        del evaluator, task
        assert [ref() for ref in gone] == [None, None, None]
    finally:
        gc.enable()


def test_knot_spaces_are_recognised_through_a_task():
    """Optimizers test what a problem offers with the declared protocols, on the task too."""
    from metaknot.problems import FreeKnotSpace, KnotSpace

    free = mk.Evaluator(FreeKnots(SPIRAL, n_knots=4), 10).task
    mask = mk.Evaluator(KnotSelection(SPIRAL), 10).task
    assert isinstance(free, FreeKnotSpace) and isinstance(free, KnotSpace)
    assert isinstance(mask, KnotSpace) and not isinstance(mask, FreeKnotSpace)

    class Plain(mk.Problem):
        encoding = mk.Encoding.binary(3)

        def evaluate(self, X):
            return np.zeros(len(X))

        def decode(self, x):
            return x

    assert not isinstance(mk.Evaluator(Plain(), 5).task, KnotSpace)
    with pytest.raises(ValueError, match="needs a knot problem"):
        mk.minimize(Plain(), "local_search", budget=5, seed=0)
    with pytest.raises(ValueError, match="needs a FreeKnots problem"):
        mk.minimize(KnotSelection(SPIRAL), "nlopt", budget=5, seed=0)


class Charging(mk.Optimizer):
    """One candidate per step, and ``charge`` fits of its own charged to the budget after
    each (as a Jacobian would be)."""

    encodings = ("continuous",)

    def __init__(self, charge: int = 4) -> None:
        self.charge = charge

    def run(self, evaluator: mk.Evaluator) -> None:
        while not evaluator.done:
            evaluator(self.problem.sample(self.rng, 1))
            self.count_fits(self.charge, charged=True)


def test_fits_charged_to_the_budget_count_as_evaluations_before_the_next_one():
    problem = FreeKnots(SPIRAL, n_knots=5)
    seen: list[mk.Progress] = []
    result = mk.minimize(problem, Charging(4), budget=23, seed=0, callbacks=[seen.append])
    # each step after the charge of the one before; the sixth charge takes what leaves room
    # for its evaluation (1 of 4), the last one is declared after the last evaluation
    assert [p.n_evaluations for p in seen] == [1, 6, 11, 16, 21, 23]
    assert result.n_evaluations == 23 and result.charged_fits == 4 * 4 + 1
    assert result.external_fits == 3 + 4  # what the budget could not take: not charged
    assert result.status == "ok" and result.record()["charged_fits"] == 17
    tight = mk.minimize(problem, Charging(4), budget=8, seed=0)
    assert (tight.n_evaluations, tight.charged_fits, tight.external_fits) == (8, 4 + 1, 3 + 4)
    stopped = mk.minimize(problem, Charging(4), budget=50, seed=0,
                          callbacks=[lambda p: p.n_evaluations >= 6])
    assert (stopped.n_evaluations, stopped.charged_fits, stopped.external_fits) == (6, 4, 4)
