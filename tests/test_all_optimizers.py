"""Every registered optimizer: the budget holds, runs are reproducible, progress is reported."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import metaknot as mk
from metaknot.problems import FreeKnots, KnotIndices, KnotSelection, get_curve

DATA = get_curve("archimedean", n_points=40)
PROBLEMS = {"binary": KnotSelection, "integer": KnotIndices, "continuous": FreeKnots}


def make_problem(kind: str) -> mk.Problem:
    if kind == "binary":
        return KnotSelection(DATA)
    if kind == "integer":
        return KnotIndices(DATA, n_knots=6)
    return FreeKnots(DATA, n_knots=6)


def counting(problem: mk.Problem) -> mk.Problem:
    """The same problem (same class, so optimizers treat it alike), counting every candidate
    that reaches ``evaluate`` in ``problem.seen``."""

    class Counting(type(problem)):
        def evaluate(self, X: np.ndarray) -> np.ndarray:
            self.seen += len(X)
            return super().evaluate(X)

    clone = copy.copy(problem)
    clone.__class__ = Counting
    clone.seen = 0
    return clone


def cases() -> list[tuple[str, str]]:
    out = []
    for name in mk.available_optimizers():
        optimizer = mk.get_optimizer(name)
        out += [(name, kind) for kind in ("binary", "integer", "continuous")
                if kind in optimizer.encodings]
    return out


CASES = cases()
IDS = [f"{name}-{kind}" for name, kind in CASES]


def test_every_optimizer_has_a_case() -> None:
    assert {name for name, _ in CASES} == set(mk.available_optimizers())


@pytest.mark.parametrize(("name", "kind"), CASES, ids=IDS)
@pytest.mark.parametrize("budget", [1, 37, 150])
def test_budget_is_never_exceeded(name: str, kind: str, budget: int) -> None:
    problem = counting(make_problem(kind))
    result = mk.minimize(problem, name, budget=budget, seed=11)
    assert result.n_evaluations <= budget
    # rows scored beyond the evaluations are steps asked ahead and dropped unseen after an
    # accepted one (Optimizer.acceptance): accounted as fits, never seen by the optimizer;
    # an optimizer's own fits charged to the budget (a Jacobian) are counted, not evaluated
    evaluated = result.n_evaluations - result.charged_fits
    assert evaluated <= problem.seen <= result.accounted_fits
    if mk.get_optimizer(name).acceptance is mk.Optimizer.acceptance:
        assert problem.seen == evaluated
    assert result.n_evaluations >= 1
    assert result.status == "ok" and result.audited_fits <= result.accounted_fits
    if result.best_x is not None:
        assert np.isfinite(result.best_f)
        assert result.best_f == pytest.approx(float(make_problem(kind).evaluate(result.best_x)[0]))


@pytest.mark.parametrize(("name", "kind"), CASES, ids=IDS)
@pytest.mark.parametrize("degree", [2, 4, 5])
def test_small_closed_outlines_with_the_most_knots(name: str, kind: str, degree: int) -> None:
    """A closed outline of 10 points takes up to 9 knots, beyond the N - p - 1 the averaging
    knots reach (the starts of the baselines, nlopt, CMA-ES, nevergrad, pymoo and free_front
    raised there), and degrees 4-5 (the equidistribution pilot is of degree p + 2): every
    optimizer runs to the end."""
    angle = np.linspace(0, 2 * np.pi, 10, endpoint=False)
    points = np.column_stack((np.cos(angle), np.sin(angle) * (1 + 0.2 * np.cos(3 * angle))))
    options = {} if kind == "binary" else {"n_knots": 9}
    problem = PROBLEMS[kind](points, closed=True, degree=degree, **options)
    result = mk.minimize(problem, name, budget=60, seed=2)
    assert result.status == "ok" and 1 <= result.n_evaluations <= 60


@settings(max_examples=400, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(case=st.sampled_from(CASES), n_points=st.integers(4, 14), degree=st.integers(1, 5),
       closed=st.booleans(), objective=st.sampled_from(["paper", "error_bounded", "bic"]),
       share=st.sampled_from([0.0, 0.4, 1.0]), noise=st.integers(0, 2**31),
       budget=st.sampled_from([1, 9, 40]))
def test_tiny_problems_run_or_are_refused_before_any_evaluation(
        case, n_points, degree, closed, objective, share, noise, budget) -> None:
    """Every optimizer on small open and closed point sets of every degree, with any knot
    count the problem allows: the run ends with status ok, or the problem refuses too few
    points for the degree by a ValueError before evaluating anything. An error in mid-run (it
    carries ``partial_result``) is a fault: pymoo running out of new candidates, start knots
    beyond the averaging formula's range, a singular closed interpolation and the
    equidistribution pilot's degree were found this way."""
    name, kind = case
    angle = np.linspace(0, 2 * np.pi, n_points, endpoint=not closed)
    rng = np.random.default_rng(noise)
    points = np.column_stack((np.cos(angle), np.sin(angle) * (1 + 0.3 * np.cos(2 * angle))))
    points += 0.01 * rng.standard_normal(points.shape)
    options = {"closed": closed, "degree": degree, "objective": objective}
    try:
        if kind != "binary":
            top = n_points - 1 if closed else n_points - degree - 1
            options["n_knots"] = max(1, round(share * top))
        problem = PROBLEMS[kind](points, **options)
        result = mk.minimize(problem, name, budget=budget, seed=noise % 100)
    except ValueError as error:
        assert getattr(error, "partial_result", None) is None, f"failed in mid-run: {error}"
        assert "fit needs at least" in str(error), str(error)  # too few points: the one refusal
        event("refused")
        return
    event("ran")
    assert result.status == "ok" and 1 <= result.n_evaluations <= budget


@pytest.mark.parametrize(("name", "kind"), CASES, ids=IDS)
def test_same_seed_same_run(name: str, kind: str) -> None:
    runs = [mk.minimize(make_problem(kind), name, budget=120, seed=5) for _ in range(2)]
    a, b = runs
    assert a.n_evaluations == b.n_evaluations
    assert a.best_f == b.best_f
    np.testing.assert_array_equal(a.best_x, b.best_x)
    np.testing.assert_array_equal(a.trace_evaluations, b.trace_evaluations)
    np.testing.assert_array_equal(a.trace_best, b.trace_best)


@pytest.mark.parametrize(("name", "kind"), CASES, ids=IDS)
def test_progress_reaches_callbacks(name: str, kind: str) -> None:
    seen: list[mk.Progress] = []
    result = mk.minimize(make_problem(kind), name, budget=80, seed=2, callbacks=[seen.append])
    assert seen, "no progress reported"
    counts = [p.n_evaluations for p in seen]
    assert counts == sorted(counts) and counts[-1] == result.n_evaluations
    assert seen[-1].best_f == result.best_f


#: Deterministic baselines on a problem that fixes K evaluate one candidate: their run is a
#: single batch whether or not a callback stops it.
ONE_CANDIDATE = {(name, kind) for name in ("uniform", "averaging", "fitpack")
                 for kind in ("integer", "continuous")}
LONG_DATA = get_curve("archimedean", n_points=240)  # baselines scan 236 knot counts on masks


@pytest.mark.parametrize(("name", "kind"), CASES, ids=IDS)
def test_callback_can_stop_the_run(name: str, kind: str) -> None:
    def problem():
        if kind == "binary":
            return counting(KnotSelection(LONG_DATA))
        return counting(make_problem(kind))

    batches: list[int] = []
    free = mk.minimize(problem(), name, budget=500, seed=2, callbacks=[batches.append])
    if (name, kind) in ONE_CANDIDATE:
        assert free.n_evaluations == len(batches) == 1
        return
    assert len(batches) > 1, "the unstopped run must take several batches for the test to bite"
    stopped_problem = problem()
    stopped: list[int] = []
    result = mk.minimize(stopped_problem, name, budget=500, seed=2,
                         callbacks=[lambda p: stopped.append(p) or True])
    # the run stops after the first evaluated batch (fits an optimizer charged before it count
    # as evaluations the problem did not see)
    assert len(stopped) == 1
    assert stopped_problem.seen == result.n_evaluations - result.charged_fits
    assert result.n_evaluations == stopped[0].n_evaluations
    assert result.n_evaluations < free.n_evaluations


class Lifecycle(mk.Callback):
    def __init__(self) -> None:
        self.events: list[str] = []

    def on_start(self, run):
        self.events.append("start")

    def on_batch(self, progress):
        self.events.append("batch")

    def on_end(self, result):
        self.events.append("end" if result is not None and result.status == "ok" else "bad")


@pytest.mark.parametrize(("name", "kind"), CASES, ids=IDS)
def test_lifecycle_callbacks(name: str, kind: str) -> None:
    hooks = Lifecycle()
    result = mk.minimize(make_problem(kind), name, budget=90, seed=1, callbacks=[hooks])
    assert hooks.events[0] == "start" and hooks.events[-1] == "end"
    assert set(hooks.events[1:-1]) == {"batch"}
    assert len(result.trace) >= 1 and result.trace.checkpoint[-1]
    assert result.trace.evaluations[-1] == result.n_evaluations
