"""Budget, run loop, parameter checks, encodings and the registry (metaknot core)."""

from __future__ import annotations

import os
import sys
import textwrap
import warnings

import numpy as np
import pytest

import metaknot as mk
from metaknot import registry
from metaknot.problems import KnotSelection, KnotSolution

# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------


class Sphere(mk.Problem):
    """Cheap continuous test problem: sum of squares over [-1, 1]^n."""

    name = "test_sphere"

    def __init__(self, n_var: int = 4) -> None:
        self.encoding = mk.Encoding.continuous(n_var, -1.0, 1.0)

    def evaluate(self, X):
        return np.sum(np.asarray(X) ** 2, axis=1)

    def decode(self, x):
        return np.asarray(x)


class Counting(mk.Problem):
    """Wraps a problem and records every batch the framework evaluates."""

    def __init__(self, inner: mk.Problem) -> None:
        self.inner = inner
        self.encoding = inner.encoding
        self.name = inner.name
        self.batches: list[int] = []
        self.values: list[np.ndarray] = []

    @property
    def n_calls(self) -> int:
        return sum(self.batches)

    def evaluate(self, X):
        F = np.asarray(self.inner.evaluate(X), dtype=float)
        self.batches.append(len(X))
        self.values.append(F.copy())
        return F

    def decode(self, x):
        return self.inner.decode(x)

    def sample(self, rng, n):
        return self.inner.sample(rng, n)

    def all_values(self) -> np.ndarray:
        return np.concatenate(self.values) if self.values else np.empty(0)


class HugeBatch(mk.Optimizer):
    """Asks for far more candidates than the budget allows, every time."""

    name = "test_huge_batch"

    def __init__(self, batch: int = 5000) -> None:
        self.batch = batch
        self.told = 0

    def ask(self):
        return self.problem.encoding.sample(self.rng, self.batch)

    def tell(self, X, F):
        assert len(X) == len(F)
        self.told += len(F)


class Greedy(mk.Optimizer):
    """Ignores ``evaluator.done`` and keeps calling the evaluator, swallowing the exhaustion
    signal a few times before giving up."""

    name = "test_greedy"

    def __init__(self) -> None:
        self.refused = 0

    def ask(self):
        return self.problem.encoding.sample(self.rng, 7)

    def tell(self, X, F):
        pass

    def run(self, evaluator):
        for _ in range(200):
            try:
                evaluator(self.ask())
            except mk.BudgetExhausted:
                self.refused += 1
        # and finally once more without catching: the runner must cope
        evaluator(self.ask())


class Stubborn(mk.Optimizer):
    """Calls the evaluator directly from ``run`` with one giant batch, then single rows."""

    name = "test_stubborn"

    def ask(self):
        return self.problem.encoding.sample(self.rng, 1)

    def tell(self, X, F):
        pass

    def run(self, evaluator):
        evaluator(self.problem.encoding.sample(self.rng, 10_000))
        while True:
            evaluator(self.ask())


def reference_trace(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Best-so-far improvements recomputed from all evaluated values."""
    evals, best = [], []
    current = np.inf
    for i, f in enumerate(values, start=1):
        if f < current:
            current = f
            evals.append(i)
            best.append(f)
    if not evals or evals[-1] != len(values):
        evals.append(len(values))
        best.append(current)
    return np.array(evals), np.array(best)


@pytest.fixture(scope="module")
def spiral_problem():
    return KnotSelection("archimedean")


# --------------------------------------------------------------------------------------------
# budget
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("budget", "batch_size"), [(250, 100), (1, 100), (99, 10), (100, 100),
                                                    (37, 1), (1001, 64)])
def test_exact_budget_random_search(budget, batch_size):
    problem = Counting(Sphere())
    result = mk.minimize(problem, "random_search", budget=budget, seed=3,
                         optimizer_kwargs={"batch_size": batch_size})
    assert problem.n_calls == budget
    assert result.n_evaluations == budget
    assert result.budget == budget
    # full batches, then the remainder
    full, rest = divmod(budget, batch_size)
    assert problem.batches == [batch_size] * full + ([rest] if rest else [])


def test_exact_budget_on_knot_problem(spiral_problem):
    problem = Counting(spiral_problem)
    seen = []
    result = mk.minimize(problem, "random_search", budget=230, seed=1,
                         callbacks=[lambda p: seen.append(p.n_evaluations)])
    assert problem.n_calls == 230
    assert result.n_evaluations == 230
    assert seen == [100, 200, 230]
    assert isinstance(result.solution, KnotSolution)
    assert result.best_f == pytest.approx(float(spiral_problem.evaluate(result.best_x[None])[0]),
                                          rel=1e-12)
    assert result.best_f == pytest.approx(problem.all_values().min(), rel=0, abs=0)
    assert result.solution.objective_value == pytest.approx(result.best_f, rel=1e-12)


def test_budget_given_by_names():
    result = mk.minimize("mask", "random_search", budget=130, seed=2,
                         problem_kwargs={"points": "archimedean"},
                         optimizer_kwargs={"batch_size": 50})
    assert result.n_evaluations == 130
    assert result.problem == "mask"
    assert result.optimizer == "random_search"
    assert result.optimizer_params == {"batch_size": 50}


@pytest.mark.parametrize("budget", [1, 13, 4999, 5000])
def test_huge_batches_are_truncated(budget):
    problem = Counting(Sphere())
    optimizer = HugeBatch()
    result = mk.minimize(problem, optimizer, budget=budget, seed=0)
    assert problem.n_calls == budget
    assert problem.batches == [budget]  # one truncated batch
    assert optimizer.told == budget  # tell() only hears about evaluated rows
    assert result.n_evaluations == budget


@pytest.mark.parametrize("budget", [1, 50, 700])
def test_evaluator_refuses_after_exhaustion(budget):
    problem = Counting(Sphere())
    optimizer = Greedy()
    result = mk.minimize(problem, optimizer, budget=budget, seed=0)
    assert problem.n_calls == budget
    assert result.n_evaluations == budget
    assert optimizer.refused == 200 - int(np.ceil(budget / 7))


def test_stubborn_optimizer_cannot_exceed_budget():
    problem = Counting(Sphere())
    result = mk.minimize(problem, Stubborn(), budget=321, seed=0)
    assert problem.n_calls == 321
    assert problem.batches == [321]
    assert result.n_evaluations == 321


def test_evaluator_direct():
    problem = Counting(Sphere(2))
    ev = mk.Evaluator(problem, 5)
    X = np.array([[0.5, 0.5], [0.1, 0.0], [0.9, 0.9], [0.0, 0.0], [0.2, 0.2], [0.0, 0.0]])
    F = ev(X[:2])
    np.testing.assert_allclose(F, [0.5, 0.01])
    assert ev.remaining == 3 and not ev.done
    F = ev(X[2:])  # 4 rows asked, 3 left
    assert F.shape == (3,)
    np.testing.assert_allclose(F, [1.62, 0.0, 0.08])
    assert ev.done and ev.remaining == 0
    with pytest.raises(mk.BudgetExhausted):
        ev(X[:1])
    assert problem.n_calls == 5
    np.testing.assert_array_equal(ev.best_x, [0.0, 0.0])
    assert ev.best_f == 0.0


def test_trace_recorder_on_an_evaluator():
    """Improvements at every strict decrease, checkpoints on the log grid, the last evaluation
    always a checkpoint; the incumbent's metrics beside its value."""
    problem = KnotSelection("archimedean")
    recorder = mk.TraceRecorder(per_decade=1)  # checkpoints 1, 10, 100 (budget 150: and 150)
    ev = mk.Evaluator(problem, 150, [recorder])
    X = problem.sample(np.random.default_rng(3), 150)
    F = np.concatenate([ev(X[i : i + 40]) for i in range(0, 150, 40)])
    trace = recorder.trace()
    running = np.minimum.accumulate(F)
    improved = np.flatnonzero(np.diff(np.concatenate(([np.inf], running))) < 0) + 1
    np.testing.assert_array_equal(trace.evaluations[trace.improvement], improved)
    np.testing.assert_array_equal(trace.evaluations[trace.checkpoint], [1, 10, 100, 150])
    np.testing.assert_array_equal(
        np.union1d(improved, [1, 10, 100, 150]), trace.evaluations)
    np.testing.assert_array_equal(trace.best_f, running[trace.evaluations - 1])
    # metrics of the incumbent at each row, recomputed from its candidate
    incumbent = [int(np.argmin(F[:e])) for e in trace.evaluations]
    fits = [problem.decode(X[i]).fit for i in incumbent]
    np.testing.assert_allclose(trace.metrics["rmse"], [f.rmse for f in fits], rtol=1e-9)
    np.testing.assert_array_equal(trace.metrics["n_control_points"],
                                  [f.n_control_points for f in fits])


def test_checkpoint_grid():
    from metaknot.callbacks import checkpoint_grid

    np.testing.assert_array_equal(checkpoint_grid(1000, 1), [1, 10, 100, 1000])
    np.testing.assert_array_equal(checkpoint_grid(250, 2), [1, 3, 10, 32, 100, 250])
    grid = checkpoint_grid(100_000, 10)
    assert grid[0] == 1 and grid[-1] == 100_000 and (np.diff(grid) > 0).all()
    # shared below the budget: a longer run's grid extends a shorter one's
    short = checkpoint_grid(5000, 10)
    np.testing.assert_array_equal(short[:-1], grid[: short.size - 1])


@pytest.mark.parametrize("budget", [0, -5, 2.5, True, "10", None])
def test_bad_budget(budget):
    with pytest.raises(ValueError, match="budget"):
        mk.Evaluator(Sphere(), budget)
    with pytest.raises(ValueError, match="budget"):
        mk.minimize(Sphere(), "random_search", budget=budget, seed=0)


def test_evaluator_nan_counts_as_inf():
    class NaNProblem(Sphere):
        def evaluate(self, X):
            F = super().evaluate(X)
            F[::2] = np.nan
            return F

    ev = mk.Evaluator(NaNProblem(2), 10)
    with pytest.warns(RuntimeWarning, match="NaN"):
        F = ev(np.full((4, 2), 0.5))
    assert np.isinf(F[::2]).all() and np.isfinite(F[1::2]).all()
    assert ev.best_f == 0.5


def test_evaluator_bad_shape_from_problem():
    class Wrong(Sphere):
        def evaluate(self, X):
            return np.zeros(len(X) + 1)

    with pytest.raises(ValueError, match="shape"):
        mk.Evaluator(Wrong(2), 10)(np.zeros((3, 2)))


@pytest.mark.parametrize(("values", "message"), [
    (lambda F: F + 1j, r"Odd.evaluate returned complex values; objective values must be real"),
    (lambda F: np.array(["a"] * len(F)), r"Odd.evaluate returned values of dtype <U1"),
    (lambda F: None, r"Odd.evaluate returned None; return one value per candidate"),
])
def test_evaluator_names_values_that_are_not_real_numbers(values, message):
    """A problem's complex values lost their imaginary parts with only a numpy warning; text
    and None got numpy's or a shape's message. Integers and lists are taken as numbers."""
    class Odd(Sphere):
        def evaluate(self, X):
            return values(super().evaluate(X))

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=message):
            mk.Evaluator(Odd(2), 10)(np.zeros((3, 2)))

    class Listed(Sphere):
        def evaluate(self, X):
            return [1, 2, 3]

    np.testing.assert_array_equal(mk.Evaluator(Listed(2), 10)(np.zeros((3, 2))), [1, 2, 3])


# --------------------------------------------------------------------------------------------
# trace
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("objective", ["paper", "pareto"])
def test_a_recorder_fed_by_the_evaluator_records_what_a_callback_records(objective):
    """An evaluator given a recorder as its ``trace`` passes it only the batches that add
    rows (an improvement or a checkpoint in them); the trace is the one a recorder sees as
    a callback after every batch: improvements, checkpoints, metrics and the last
    evaluation of a run stopped early by a callback, batches of one and of many."""
    problem = KnotSelection("archimedean", objective=objective)
    X = problem.sample(np.random.default_rng(8), 700)
    sizes = [1] * 60 + [7, 1, 33, 1, 1, 120, 2] * 20
    traces = []
    for fed in (True, False):
        recorder = mk.TraceRecorder(per_decade=4)
        recorder.on_start(mk.RunStart(problem, mk.get_optimizer("random_search"), 700))
        def stop(progress: mk.Progress) -> bool:
            return progress.n_evaluations >= 333

        ev = mk.Evaluator(problem, 700, [stop] if fed else [recorder, stop],
                          trace=recorder if fed else None)
        start = 0
        for size in sizes:
            try:
                start += ev(X[start:start + size]).size
            except mk.BudgetExhausted:
                break
        traces.append(recorder.trace(ev.n_evaluations))
    assert ev.stop_requested and 333 < ev.n_evaluations < 562  # stopped between checkpoints
    fed, called = traces
    assert fed.evaluations[-1] == ev.n_evaluations
    assert 10 < fed.evaluations.size < ev.n_evaluations / 2
    for name in ("evaluations", "best_f", "improvement", "checkpoint"):
        np.testing.assert_array_equal(getattr(fed, name), getattr(called, name))
    assert fed.metrics.keys() == called.metrics.keys()
    for name in fed.metrics:
        np.testing.assert_array_equal(fed.metrics[name], called.metrics[name])


@pytest.mark.parametrize(("budget", "batch_size", "seed"), [(1000, 64, 0), (517, 100, 9),
                                                            (1, 10, 4)])
def test_trace_properties(budget, batch_size, seed):
    problem = Counting(Sphere(6))
    result = mk.minimize(problem, "random_search", budget=budget, seed=seed,
                         optimizer_kwargs={"batch_size": batch_size})
    evals, best = result.trace_evaluations, result.trace_best
    assert evals.shape == best.shape and evals.size >= 1
    assert np.all(np.diff(evals) > 0)
    assert np.all(np.diff(best) <= 0)
    assert evals[0] >= 1
    assert evals[-1] == result.n_evaluations == budget
    assert best[-1] == result.best_f
    # against the best-so-far recomputed from every evaluated value
    ref_evals, ref_best = reference_trace(problem.all_values())
    np.testing.assert_array_equal(evals, ref_evals)
    np.testing.assert_array_equal(best, ref_best)
    assert result.best_f == problem.all_values().min()
    assert result.best_f == pytest.approx(float(np.sum(result.best_x**2)), rel=1e-15)


def test_trace_on_knot_problem(spiral_problem):
    problem = Counting(spiral_problem)
    result = mk.minimize(problem, "random_search", budget=450, seed=5,
                         optimizer_kwargs={"batch_size": 40})
    ref_evals, ref_best = reference_trace(problem.all_values())
    np.testing.assert_array_equal(result.trace_evaluations, ref_evals)
    np.testing.assert_array_equal(result.trace_best, ref_best)
    assert result.trace_evaluations[-1] == 450
    assert result.trace_best[-1] == result.best_f


def test_trace_metrics_keep_the_problems_order_in_every_process():
    """The trace's metric columns come in the order the problem gives them, whatever the
    interpreter's string hashing (a set of names would order them differently from one
    process to the next)."""
    import subprocess

    code = textwrap.dedent("""
        import metaknot as mk
        from metaknot.problems import KnotSelection, get_curve
        problem = KnotSelection(get_curve("archimedean", n_points=30), objective="error_bounded")
        for batch in (1, 7):
            result = mk.minimize(problem, "random_search", budget=20, seed=0,
                                 optimizer_kwargs={"batch_size": batch})
            print(*result.trace.metrics)
        print(*problem.evaluate_with_metrics(problem.sample(__import__("numpy").random
                                                              .default_rng(0), 2))[1])
    """)
    outputs = set()
    for hash_seed in range(6):
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              env={**os.environ, "PYTHONHASHSEED": str(hash_seed)},
                              timeout=120)
        assert done.returncode == 0, done.stderr
        lines = done.stdout.split("\n")
        assert lines[0] == lines[1] == lines[2], lines
        outputs.add(lines[0])
    assert len(outputs) == 1


def test_trace_when_nothing_is_feasible():
    class Infeasible(Sphere):
        def evaluate(self, X):
            return np.full(len(X), np.inf)

        def decode(self, x):
            raise AssertionError("nothing feasible: decode must not be called")

    result = mk.minimize(Infeasible(), "random_search", budget=30, seed=0)
    assert result.best_x is None
    assert result.best_f == np.inf
    assert result.solution is None
    np.testing.assert_array_equal(result.trace_evaluations, [30])
    assert result.trace_best[-1] == np.inf


# --------------------------------------------------------------------------------------------
# callbacks
# --------------------------------------------------------------------------------------------


def test_callbacks_receive_progress():
    problem = Counting(Sphere(3))
    seen: list[mk.Progress] = []
    mk.minimize(problem, "random_search", budget=260, seed=2, callbacks=[seen.append],
                optimizer_kwargs={"batch_size": 100})
    assert [p.n_evaluations for p in seen] == [100, 200, 260]
    assert all(isinstance(p, mk.Progress) for p in seen)
    assert all(p.budget == 260 for p in seen)
    running = np.inf
    for progress, values in zip(seen, problem.values, strict=True):
        np.testing.assert_array_equal(progress.batch_f, values)
        running = min(running, values.min())
        assert progress.best_f == running
        assert progress.elapsed >= 0
    assert [p.elapsed for p in seen] == sorted(p.elapsed for p in seen)


def test_callback_returning_true_stops_early():
    problem = Counting(Sphere(3))
    calls = []

    def stop_at_300(progress):
        calls.append(progress.n_evaluations)
        return progress.n_evaluations >= 300

    result = mk.minimize(problem, "random_search", budget=10_000, seed=0,
                         callbacks=[stop_at_300], optimizer_kwargs={"batch_size": 100})
    assert result.n_evaluations == 300
    assert problem.n_calls == 300
    assert calls == [100, 200, 300]
    assert result.trace_evaluations[-1] == 300
    # one callback may be given without a list (it was "'function' object is not iterable")
    calls.clear()
    again = mk.minimize(Counting(Sphere(3)), "random_search", budget=10_000, seed=0,
                        callbacks=stop_at_300, optimizer_kwargs={"batch_size": 100})
    assert again.n_evaluations == 300 and calls == [100, 200, 300]


def test_a_recorder_fed_before_its_start_says_so():
    problem = KnotSelection("archimedean")
    evaluator = mk.Evaluator(problem, 100, trace=mk.TraceRecorder())
    with pytest.raises(RuntimeError, match="records after its on_start"):
        evaluator(problem.sample(np.random.default_rng(0), 3))


def test_a_run_stopped_between_checkpoints_ends_its_trace_at_its_last_evaluation():
    """A run whose last batches neither improve nor reach a checkpoint (all values equal
    after the first): its trace still ends with a checkpoint row at its last evaluation."""

    class Flat(Sphere):
        def evaluate(self, X):
            return np.ones(len(X))

    result = mk.minimize(Flat(2), "random_search", budget=10_000, seed=0,
                         callbacks=[lambda progress: progress.n_evaluations >= 300],
                         optimizer_kwargs={"batch_size": 10})
    assert result.n_evaluations == 300  # the last batch holds no checkpoint (251, 316)
    assert result.trace.evaluations[-1] == 300 and result.trace.checkpoint[-1]
    assert not result.trace.improvement[1:].any() and result.trace.best_f[-1] == 1.0


def test_stop_when_stalled_ends_a_run_that_no_longer_improves():
    """Random search on a sphere improves ever more rarely: the run ends at the first batch
    that completes ``evaluations`` evaluations without a new best, and not before."""
    from metaknot.callbacks import StopWhenStalled

    stall = 2_000
    result = mk.minimize(Sphere(3), "random_search", budget=1_000_000, seed=0,
                         callbacks=[StopWhenStalled(stall)],
                         optimizer_kwargs={"batch_size": 100})
    assert result.n_evaluations < 1_000_000
    trace = result.trace.columns()
    last = int(np.asarray(trace["evaluations"])[np.asarray(trace["improvement"])].max())
    # the callback sees batches of 100: stopped once `stall` more than the end of the batch of
    # the last improvement were spent
    assert result.n_evaluations == -(-last // 100) * 100 + stall
    again = mk.minimize(Sphere(3), "random_search", budget=1_000_000, seed=0,
                        callbacks=[StopWhenStalled(stall)],
                        optimizer_kwargs={"batch_size": 100})
    assert again.n_evaluations == result.n_evaluations  # the callback starts afresh each run
    with pytest.raises(ValueError, match="whole number >= 1"):
        StopWhenStalled(0)


def test_callback_returning_none_or_false_does_not_stop():
    problem = Counting(Sphere(3))
    result = mk.minimize(problem, "random_search", budget=500, seed=0,
                         callbacks=[lambda p: None, lambda p: False])
    assert result.n_evaluations == 500


def test_stop_also_applies_to_optimizers_with_own_run():
    problem = Counting(Sphere(3))
    result = mk.minimize(problem, Greedy(), budget=1000, seed=0,
                         callbacks=[lambda p: p.n_evaluations >= 21])
    assert problem.n_calls == 21
    assert result.n_evaluations == 21


def test_progress_bar_option_runs():
    result = mk.minimize(Sphere(2), "random_search", budget=150, seed=0, progress=True)
    assert result.n_evaluations == 150


# --------------------------------------------------------------------------------------------
# reproducibility
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("problem_factory", [lambda: Sphere(5), lambda: KnotSelection(
    "archimedean")])
def test_same_seed_same_result(problem_factory):
    a = mk.minimize(problem_factory(), "random_search", budget=333, seed=42)
    b = mk.minimize(problem_factory(), "random_search", budget=333, seed=42)
    np.testing.assert_array_equal(a.best_x, b.best_x)
    assert a.best_f == b.best_f
    np.testing.assert_array_equal(a.trace_evaluations, b.trace_evaluations)
    np.testing.assert_array_equal(a.trace_best, b.trace_best)
    assert a.seed == 42


@pytest.mark.parametrize("problem_factory", [lambda: Sphere(5), lambda: KnotSelection(
    "archimedean")])
def test_different_seed_different_result(problem_factory):
    a = mk.minimize(problem_factory(), "random_search", budget=333, seed=1)
    b = mk.minimize(problem_factory(), "random_search", budget=333, seed=2)
    assert not np.array_equal(a.best_x, b.best_x)
    assert a.best_f != b.best_f


def test_numpy_integer_seed_is_recorded():
    a = mk.minimize(Sphere(3), "random_search", budget=50, seed=np.int64(5))
    b = mk.minimize(Sphere(3), "random_search", budget=50, seed=5)
    np.testing.assert_array_equal(a.best_x, b.best_x)  # the same generator
    assert b.seed == 5
    assert a.seed == 5  # the record must say which seed reproduces the run


def test_seed_sequence_and_bad_seed():
    ss = np.random.SeedSequence(7)
    a = mk.minimize(Sphere(3), "random_search", budget=50, seed=np.random.SeedSequence(7))
    b = mk.minimize(Sphere(3), "random_search", budget=50, seed=ss)
    np.testing.assert_array_equal(a.best_x, b.best_x)
    for bad in (-1, 1.5, "seed", True):
        with pytest.raises(ValueError, match="seed"):
            mk.make_rng(bad)


# --------------------------------------------------------------------------------------------
# check_param
# --------------------------------------------------------------------------------------------


def test_check_param_accepts_and_converts():
    assert mk.check_param("n", 5, low=1, integer=True) == 5
    assert isinstance(mk.check_param("n", np.int64(5), integer=True), int)
    assert isinstance(mk.check_param("n", 5.0, integer=True), int)
    assert mk.check_param("rate", 0.25, low=0, high=1) == 0.25
    assert isinstance(mk.check_param("rate", np.float32(0.5)), float)
    assert mk.check_param("rate", 0, low=0) == 0.0  # closed lower bound
    assert mk.check_param("rate", 1, high=1) == 1.0  # closed upper bound


@pytest.mark.parametrize(
    ("value", "kwargs", "message"),
    [
        ("3", {}, "must be a number"),
        (None, {}, "must be a number"),
        (True, {}, "must be a number"),
        ([1], {}, "must be a number"),
        (2.5, {"integer": True}, "must be an integer"),
        (np.nan, {}, "must be finite"),
        (np.inf, {}, "must be finite"),
        (np.inf, {"integer": True}, "must be finite"),
        (np.nan, {"integer": True}, "must be finite"),
        (-np.inf, {"low": 0}, "must be finite"),
        (0, {"low": 1}, ">= 1"),
        (0.0, {"low": 0.0, "low_open": True}, "> 0"),
        (1.5, {"high": 1}, "<= 1"),
    ],
)
def test_check_param_errors(value, kwargs, message):
    with pytest.raises(ValueError, match="my_param") as info:
        mk.check_param("my_param", value, **kwargs)
    assert message in str(info.value)


@pytest.mark.parametrize("batch_size", [0, -1, 2.5, "100", None, np.inf, np.nan])
def test_random_search_rejects_bad_batch_size(batch_size):
    with pytest.raises(ValueError, match="batch_size"):
        mk.get_optimizer("random_search", batch_size=batch_size)


# --------------------------------------------------------------------------------------------
# Encoding.check
# --------------------------------------------------------------------------------------------


def test_encoding_check_accepts_valid():
    enc = mk.Encoding.binary(4)
    out = enc.check([1, 0, 1, 1])  # one candidate as a 1-D vector
    assert out.shape == (1, 4) and out.dtype == np.int64
    out = enc.check(np.array([[True, False, True, False]]))
    np.testing.assert_array_equal(out, [[1, 0, 1, 0]])
    assert out.dtype == np.int64
    assert enc.check(np.array([[1.0, 0.0, 1.0, 0.0]])).dtype == np.int64
    enc = mk.Encoding.integer(3, 2, 9)
    np.testing.assert_array_equal(enc.check([[2, 9, 5], [3, 3, 3]]), [[2, 9, 5], [3, 3, 3]])
    enc = mk.Encoding.continuous(2, 0.0, 1.0)
    out = enc.check(np.array([[0.5, 0.25]], dtype=np.float32))
    assert out.dtype == np.float64
    assert enc.check(np.empty((0, 2))).shape == (0, 2)


@pytest.mark.parametrize(
    ("encoding", "X", "message"),
    [
        (mk.Encoding.binary(4), np.zeros((2, 3)), r"shape \(B, 4\)"),
        (mk.Encoding.binary(4), np.zeros(5), r"shape \(B, 4\)"),
        (mk.Encoding.binary(4), np.zeros((2, 2, 4)), r"shape \(B, 4\)"),
        (mk.Encoding.binary(4), np.zeros(()), r"shape \(B, 4\)"),
        (mk.Encoding.binary(4), [[0, 1, 2, 0]], "must lie in"),
        (mk.Encoding.binary(4), [[0, 1, -1, 0]], "must lie in"),
        (mk.Encoding.binary(4), [[0, 1, 0.5, 0]], "whole numbers"),
        (mk.Encoding.binary(4), [[0, 1, np.nan, 0]], "whole numbers"),
        (mk.Encoding.binary(4), np.array([["0", "1", "0", "1"]]), "numeric"),
        (mk.Encoding.integer(3, 1, 10), [[1, 11, 5]], "must lie in"),
        (mk.Encoding.integer(3, 1, 10), [[0, 5, 5]], "must lie in"),
        (mk.Encoding.integer(3, 1, 10), [[1, 2.5, 5]], "whole numbers"),
        (mk.Encoding.integer(3, 1, 10), [[1, np.inf, 5]], "whole numbers"),
        (mk.Encoding.continuous(2, 0, 1), np.zeros((3, 3)), r"shape \(B, 2\)"),
        (mk.Encoding.continuous(2, 0, 1), np.array([["a", "b"]]), "numeric"),
    ],
)
def test_encoding_check_errors(encoding, X, message):
    with pytest.raises(ValueError, match=message):
        encoding.check(X)


def test_encoding_sample_respects_encoding():
    rng = np.random.default_rng(0)
    enc = mk.Encoding.integer(5, 1, 20, distinct_sorted=True)
    X = enc.sample(rng, 200)
    assert X.shape == (200, 5)
    assert X.min() >= 1 and X.max() <= 20
    assert np.all(np.diff(X, axis=1) > 0)  # distinct and sorted
    enc = mk.Encoding.continuous(4, -2.0, 3.0, distinct_sorted=True)
    X = enc.sample(rng, 200)
    assert X.min() >= -2.0 and X.max() <= 3.0 and np.all(np.diff(X, axis=1) > 0)
    X = mk.Encoding.binary(7).sample(rng, 100)
    assert set(np.unique(X)) == {0, 1}
    X = mk.Encoding.integer(3, 4, 6).sample(rng, 300)
    assert set(np.unique(X)) == {4, 5, 6}


def test_optimizer_rejects_unsupported_encoding():
    class BinaryOnly(mk.Optimizer):
        name = "test_binary_only"
        encodings = ("binary",)

        def ask(self):
            return np.zeros((1, self.problem.encoding.n_var))

        def tell(self, X, F):
            pass

    with pytest.raises(ValueError, match="continuous"):
        mk.minimize(Sphere(), BinaryOnly(), budget=5, seed=0)


# --------------------------------------------------------------------------------------------
# registry
# --------------------------------------------------------------------------------------------


def _clean_registry_steps(monkeypatch):
    for kind in ("problem", "optimizer"):
        registry._load_builtin(kind)
        monkeypatch.setitem(registry._REGISTRY, kind, dict(registry._REGISTRY[kind]))
    return registry._REGISTRY


@pytest.fixture
def clean_registry(monkeypatch):
    """Let a test add registry entries; the originals are restored afterwards."""
    return _clean_registry_steps(monkeypatch)


def test_get_by_name():
    opt = mk.get_optimizer("random_search", batch_size=7)
    assert type(opt).__name__ == "RandomSearch"
    assert opt.batch_size == 7 and opt.name == "random_search"
    problem = mk.get_problem("mask", points="archimedean")
    assert isinstance(problem, KnotSelection)
    assert problem.encoding.n_var == 98
    assert mk.get_problem("indices", points="archimedean", n_knots=4).encoding.n_var == 4
    assert mk.get_problem("free", points="archimedean", n_knots=3).encoding.kind \
        == "continuous"
    assert {"mask", "indices", "free"} <= set(mk.available_problems())
    assert "random_search" in mk.available_optimizers()


def test_unknown_optimizer_lists_names_and_hint():
    with pytest.raises(ValueError) as info:
        mk.get_optimizer("random_serch")
    message = str(info.value)
    assert "unknown optimizer 'random_serch'" in message
    assert "Did you mean 'random_search'?" in message
    for name in mk.available_optimizers():
        assert name in message


def test_unknown_problem_lists_names_and_hint():
    with pytest.raises(ValueError) as info:
        mk.get_problem("indice")
    message = str(info.value)
    assert "unknown problem 'indice'" in message
    assert "Did you mean 'indices'?" in message
    for name in ("free", "indices", "mask"):
        assert name in message
    with pytest.raises(ValueError, match="Available") as info:
        mk.get_problem("zzzzzzzz")
    assert "Did you mean" not in str(info.value)


def test_unknown_name_via_minimize():
    with pytest.raises(ValueError, match="unknown optimizer"):
        mk.minimize(Sphere(), "no_such_optimizer", budget=5)


def test_register_rejects_second_class_under_existing_name(clean_registry):
    class Impostor(mk.Optimizer):
        def ask(self):
            return np.zeros((1, 1))

        def tell(self, X, F):
            pass

    with pytest.raises(ValueError, match="random_search"):
        mk.register("random_search")(Impostor)
    assert type(mk.get_optimizer("random_search")).__name__ == "RandomSearch"
    assert Impostor.name != "random_search"  # a refused registration leaves no trace

    class ImpostorProblem(Sphere):
        pass

    with pytest.raises(ValueError, match="mask"):
        mk.register("mask")(ImpostorProblem)
    assert mk.get_problem("mask", points="archimedean").__class__ is KnotSelection


def test_register_new_names(clean_registry):
    @mk.register("test_new_search")
    class NewSearch(mk.Optimizer):
        def ask(self):
            return self.problem.sample(self.rng, 10)

        def tell(self, X, F):
            pass

    assert NewSearch.name == "test_new_search"
    assert mk.register("test_new_search")(NewSearch) is NewSearch  # same class again: fine
    assert "test_new_search" in mk.available_optimizers()
    result = mk.minimize(Sphere(), "test_new_search", budget=25, seed=0)
    assert result.n_evaluations == 25 and result.optimizer == "test_new_search"

    mk.register("test_sphere_problem")(Sphere)
    assert isinstance(mk.get_problem("test_sphere_problem", n_var=2), Sphere)
    assert "test_sphere_problem" in mk.available_problems()

    def factory(**kwargs):
        return Sphere(**kwargs)

    with pytest.raises(TypeError, match="kind"):
        mk.register("test_factory")(factory)
    mk.register("test_factory", kind="problem")(factory)
    assert mk.get_problem("test_factory", n_var=3).encoding.n_var == 3
    with pytest.raises(ValueError, match="kind"):
        mk.register("test_bad_kind", kind="metric")(factory)


def test_register_without_name_uses_class_name(clean_registry):
    # documented default: the class's own ``name`` attribute, else ``__name__``; a subclass
    # that sets no name must not be filed under the base class's placeholder name
    class FirstUnnamedSearch(mk.Optimizer):
        def ask(self):
            return self.problem.sample(self.rng, 4)

        def tell(self, X, F):
            pass

    class SecondUnnamedSearch(FirstUnnamedSearch):
        pass

    mk.register()(FirstUnnamedSearch)
    mk.register()(SecondUnnamedSearch)  # a different class: must not collide with the first
    assert "FirstUnnamedSearch" in mk.available_optimizers()
    assert "SecondUnnamedSearch" in mk.available_optimizers()
    assert "optimizer" not in mk.available_optimizers()


def test_clean_registry_fixture_restores_the_registry():
    """The fixture the registry tests use undoes their additions (checked here on its own,
    whatever the order the tests run in)."""
    for kind in ("problem", "optimizer"):
        registry._load_builtin(kind)
    before = {kind: dict(entries) for kind, entries in registry._REGISTRY.items()}
    with pytest.MonkeyPatch.context() as patch:
        _clean_registry_steps(patch)

        @mk.register("test_transient_search")
        class Transient(mk.Optimizer):
            def ask(self):
                return self.problem.sample(self.rng, 1)

            def tell(self, X, F):
                pass

        assert "test_transient_search" in mk.available_optimizers()
    assert "test_transient_search" not in mk.available_optimizers()
    assert registry._REGISTRY == before


# --------------------------------------------------------------------------------------------
# entry-point discovery
# --------------------------------------------------------------------------------------------

PLUGIN_MODULE = "metaknot_fake_plugin_mod"

PLUGIN_SOURCE = textwrap.dedent(
    """
    import numpy as np
    from metaknot import Encoding, Optimizer, Problem

    class FakeSearch(Optimizer):
        \"\"\"Evaluates the same batch of zeros-and-samples, counting asks.\"\"\"

        def __init__(self, batch_size=8):
            self.batch_size = batch_size
            self.asks = 0

        def ask(self):
            self.asks += 1
            return self.problem.sample(self.rng, self.batch_size)

        def tell(self, X, F):
            pass

    class FakeProblem(Problem):
        def __init__(self, n_var=3):
            self.encoding = Encoding.continuous(n_var, -1.0, 1.0)

        def evaluate(self, X):
            return np.abs(X).sum(axis=1)

        def decode(self, x):
            return x

    class NotAnOptimizer:
        pass
    """
)


@pytest.fixture
def fake_distribution(tmp_path, monkeypatch, clean_registry):
    dist = tmp_path / "fakepkg-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: fakepkg\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text(
        "[metaknot.optimizers]\n"
        f"fake_search = {PLUGIN_MODULE}:FakeSearch\n"
        f"fake_broken = {PLUGIN_MODULE}:NotAnOptimizer\n"
        "\n"
        "[metaknot.problems]\n"
        f"fake_problem = {PLUGIN_MODULE}:FakeProblem\n"
    )
    (tmp_path / f"{PLUGIN_MODULE}.py").write_text(PLUGIN_SOURCE)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, PLUGIN_MODULE, raising=False)
    yield tmp_path
    sys.modules.pop(PLUGIN_MODULE, None)


def test_entry_point_optimizer_found_and_run(fake_distribution):
    assert "fake_search" not in registry._REGISTRY["optimizer"]
    assert "fake_search" in mk.available_optimizers()
    assert "fake_problem" in mk.available_problems()
    assert "random_search" in mk.available_optimizers()  # built-ins are still listed

    opt = mk.get_optimizer("fake_search", batch_size=6)
    assert type(opt).__module__ == PLUGIN_MODULE
    assert opt.name == "fake_search"
    problem = Counting(Sphere(3))
    result = mk.minimize(problem, "fake_search", budget=20, seed=0,
                         optimizer_kwargs={"batch_size": 6})
    assert result.optimizer == "fake_search"
    assert result.n_evaluations == 20 and problem.n_calls == 20
    assert problem.batches == [6, 6, 6, 2]


def test_entry_point_problem_found_and_run(fake_distribution):
    problem = mk.get_problem("fake_problem", n_var=4)
    assert type(problem).__module__ == PLUGIN_MODULE
    assert problem.encoding.n_var == 4
    result = mk.minimize("fake_problem", "fake_search", budget=40, seed=1,
                         problem_kwargs={"n_var": 2})
    assert result.n_evaluations == 40
    assert result.best_f == pytest.approx(np.abs(result.best_x).sum())


def test_entry_point_names_in_unknown_name_message(fake_distribution):
    with pytest.raises(ValueError) as info:
        mk.get_optimizer("fake_serch")
    assert "Did you mean 'fake_search'?" in str(info.value)
    assert "random_search" in str(info.value)


def test_entry_point_of_wrong_type_rejected(fake_distribution):
    with pytest.raises(TypeError, match="fake_broken"):
        mk.get_optimizer("fake_broken")


def test_entry_points_gone_without_distribution():
    # the fake distribution's folder is no longer on sys.path and its entries were removed
    assert "fake_search" not in mk.available_optimizers()
    assert "fake_problem" not in mk.available_problems()
    with pytest.raises(ValueError, match="unknown optimizer"):
        mk.get_optimizer("fake_search")


class _FailsLater(mk.Optimizer):
    """Random candidates, then a crash in its third step."""

    def setup(self, problem, rng):
        super().setup(problem, rng)
        self.steps = 0

    def ask(self):
        self.steps += 1
        if self.steps == 3:
            self.fail()
        return self.problem.sample(self.rng, 10)

    def fail(self):
        raise ZeroDivisionError("bug in the optimizer")

    def tell(self, X, F):
        pass


def test_a_crashing_optimizer_keeps_what_was_computed():
    problem = KnotSelection("archimedean")
    with pytest.raises(ZeroDivisionError) as info:
        mk.minimize(problem, _FailsLater(), budget=100, seed=1)
    partial = info.value.partial_result
    assert partial.n_evaluations == 20
    assert partial.trace_evaluations[-1] == 20
    # the run's first batch, drawn again from the same seed: the best can only be better
    first_batch = problem.sample(mk.make_rng(1), 10)
    assert partial.best_f <= problem.evaluate(first_batch).min()
    assert partial.solution.objective_value == pytest.approx(partial.best_f)
    assert any("partial_result" in note for note in info.value.__notes__)


class _InterruptedInCompiledCode(_FailsLater):
    """Random candidates; in its third step, Ctrl-C as compiled code hands it back: a
    SystemError caused by the KeyboardInterrupt."""

    def fail(self):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as interrupt:
            raise SystemError("<function bind> returned a result with an exception "
                              "set") from interrupt


def test_ctrl_c_inside_compiled_code_stops_the_run_as_ctrl_c():
    """Not a failed run: the KeyboardInterrupt itself, with what was computed (a study's
    sweep stops on it; it recorded a failed run and went on)."""
    with pytest.raises(KeyboardInterrupt) as info:
        mk.minimize(KnotSelection("archimedean"), _InterruptedInCompiledCode(), budget=100,
                    seed=1)
    assert info.value.partial_result.n_evaluations == 20
    assert mk.runner.interrupt_behind(ValueError("plain")) is None


def _reference_repair(values, lo, hi):
    """Encoding.repair's rule in plain Python: sorted values, in order, each to the nearest
    value not taken by an earlier one (ties: the lower)."""
    used, out = set(), []
    for v in sorted(values):
        c = next(c for step in range(hi - lo + 2) for c in (v - step, v + step)
                 if lo <= c <= hi and c not in used)
        used.add(c)
        out.append(c)
    return sorted(out)


@pytest.mark.parametrize("seed", range(5))
def test_repair_of_index_sets_against_the_rule(seed):
    rng = np.random.default_rng(seed)
    lo, hi, k = 1, 30, 12
    enc = mk.Encoding.integer(k, lo, hi, distinct_sorted=True)
    X = rng.integers(lo - 3, hi + 4, size=(400, k))  # repeats and values past the bounds
    Y = enc.repair(X)
    clipped = np.clip(X, lo, hi)
    for x, y in zip(clipped, Y, strict=True):
        assert y.tolist() == _reference_repair(x.tolist(), lo, hi)
    assert (np.diff(Y, axis=1) > 0).all() and Y.min() >= lo and Y.max() <= hi
    # integer candidates take the compiled path, others numpy's: the same sets
    np.testing.assert_array_equal(enc.repair(X.astype(np.float64)), Y)
    lower, upper = rng.integers(lo, 8, size=k), rng.integers(20, hi + 1, size=k)
    per_column = mk.Encoding("integer", k, lower, upper, distinct_sorted=True)
    np.testing.assert_array_equal(per_column.repair(X), per_column.repair(X.astype(float)))
    # rows that were already valid sets come back unchanged
    valid = np.sort(rng.permuted(np.tile(np.arange(lo, hi + 1), (50, 1)), axis=1)[:, :k], axis=1)
    np.testing.assert_array_equal(enc.repair(valid), valid)


def test_repair_examples():
    enc = mk.Encoding.integer(4, 1, 9, distinct_sorted=True)
    np.testing.assert_array_equal(
        enc.repair(np.array([[5, 5, 5, 5], [1, 1, 1, 1], [9, 9, 2, 9], [3, 4, 4, 5]])),
        [[3, 4, 5, 6], [1, 2, 3, 4], [2, 7, 8, 9], [3, 4, 5, 6]])
    with pytest.raises(ValueError, match="cannot pick 4 distinct values"):
        mk.Encoding.integer(4, 1, 3, distinct_sorted=True).repair(np.ones((1, 4)))


@pytest.mark.parametrize("kind", ["sets", "integer", "continuous", "binary"])
@pytest.mark.parametrize("shape", [(1, 8), (3, 12), (1, 2), (1, 1, 4), ()])
def test_repair_refuses_candidates_of_another_width(kind, shape):
    """Integer sets of more columns than the encoding made the compiled repair read bounds
    past their end and loop for ever; fewer columns were repaired silently, three dimensions
    came back as given; the other encodings failed in numpy's broadcasting."""
    enc = {"sets": mk.Encoding.integer(4, 1, 10, distinct_sorted=True),
           "integer": mk.Encoding.integer(4, 1, 10),
           "continuous": mk.Encoding.continuous(4, 0.0, 1.0, distinct_sorted=True),
           "binary": mk.Encoding.binary(4)}[kind]
    X = np.full(shape, 3, dtype=np.int64)
    with pytest.raises(ValueError, match=r"candidates must have shape \(B, 4\) for this"):
        enc.repair(X)


def test_repair_takes_one_candidate_as_a_1d_array():
    enc = mk.Encoding.integer(4, 1, 10, distinct_sorted=True)
    np.testing.assert_array_equal(enc.repair(np.array([3, 3, 3, 3])), [1, 2, 3, 4])
    np.testing.assert_array_equal(enc.repair(np.array([[3, 3, 3, 3]])), [[1, 2, 3, 4]])
