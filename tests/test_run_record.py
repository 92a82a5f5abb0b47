"""The run record and the seams under it: the task view, callbacks with a lifecycle, external
fits, seeds, timings and the flat record."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import metaknot as mk
import metaknot.bspline.fitpack as fitpack_module
from metaknot.algorithms import DolphinEcholocation, FitpackKnots, GeneticAlgorithm
from metaknot.problems import KnotIndices, KnotSelection, add_noise, get_curve

SPIRAL = get_curve("archimedean", n_points=60)


# --------------------------------------------------------------------------------------------
# the task: an optimizer cannot evaluate


class Peeking(mk.Optimizer):
    """Tries to reach the objective through what setup gave it."""

    def __init__(self, member: str = "evaluate") -> None:
        self.member = member

    def ask(self):
        X = self.problem.sample(self.rng, 4)
        getattr(self.problem, self.member)(X if self.member != "decode" else X[0])
        return X

    def tell(self, X, F):
        pass


@pytest.mark.parametrize("member", ["evaluate", "evaluate_details", "evaluate_with_metrics",
                                    "decode"])
def test_an_optimizer_cannot_evaluate_through_its_task(member):
    with pytest.raises(AttributeError, match="only through the evaluator"):
        mk.minimize(KnotSelection(SPIRAL), Peeking(member), budget=20, seed=0)


def test_task_forwards_settings_and_owns_the_budget():
    problem = KnotIndices(SPIRAL, n_knots=4)
    evaluator = mk.Evaluator(problem, 25)
    task = evaluator.task
    assert task.encoding is problem.encoding and task.degree == 3 and task.n_knots == 4
    np.testing.assert_array_equal(task.params, problem.params)
    assert task.problem_type is KnotIndices
    assert (task.budget, task.remaining, task.n_evaluations) == (25, 25, 0)
    evaluator(problem.sample(np.random.default_rng(0), 10))
    assert (task.remaining, task.n_evaluations) == (15, 10)
    with pytest.raises(AttributeError, match="read-only"):
        task.degree = 5
    assert problem.degree == 3


# --------------------------------------------------------------------------------------------
# the run loop


class Idle(mk.Optimizer):
    """Asks for nothing but never says it is finished."""

    def ask(self):
        return np.empty((0, self.problem.encoding.n_var))

    def tell(self, X, F):
        pass


def test_an_empty_ask_while_not_finished_is_an_error():
    with pytest.raises(RuntimeError, match=r"Idle.ask\(\) returned no candidates"):
        mk.minimize(KnotSelection(SPIRAL), Idle(), budget=10, seed=0)


class Forgetful(Idle):
    """Forgets to return its candidates."""

    def ask(self):
        self.problem.sample(self.rng, 4)


def test_an_ask_returning_none_is_named():
    """A missing ``return`` in ``ask`` is named as such (it was "object of type 'NoneType'
    has no len()")."""
    with pytest.raises(TypeError, match=r"Forgetful.ask\(\) returned None; return an array"):
        mk.minimize(KnotSelection(SPIRAL), Forgetful(), budget=10, seed=0)


# --------------------------------------------------------------------------------------------
# callbacks with a lifecycle


class Lifecycle(mk.Callback):
    def __init__(self) -> None:
        self.events: list[tuple] = []

    def on_start(self, run):
        self.events.append(("start", run.problem.name, run.optimizer.name, run.budget))

    def on_batch(self, progress):
        self.events.append(("batch", progress.n_evaluations))

    def on_end(self, result):
        self.events.append(("end", None if result is None else result.status))


def test_callback_lifecycle_and_plain_callables_together():
    lifecycle, plain = Lifecycle(), []
    result = mk.minimize(KnotSelection(SPIRAL), "random_search", budget=250, seed=1,
                         callbacks=[lifecycle, plain.append])
    assert lifecycle.events == [("start", "mask", "random_search", 250),
                                ("batch", 100), ("batch", 200), ("batch", 250), ("end", "ok")]
    assert [p.n_evaluations for p in plain] == [100, 200, 250]
    assert result.status == "ok"


class _Crash(mk.Optimizer):
    def setup(self, problem, rng):
        super().setup(problem, rng)
        self.asked = 0

    def ask(self):
        self.asked += 1
        if self.asked == 3:
            raise KeyError("boom")
        return self.problem.sample(self.rng, 10)

    def tell(self, X, F):
        pass


def test_on_end_sees_the_partial_result_of_a_failed_run():
    lifecycle = Lifecycle()
    with pytest.raises(KeyError) as info:
        mk.minimize(KnotSelection(SPIRAL), _Crash(), budget=100, seed=0, callbacks=[lifecycle])
    assert lifecycle.events[-1] == ("end", "failed")
    partial = info.value.partial_result
    assert partial.status == "failed" and "KeyError" in partial.error
    assert partial.record()["status"] == "failed"


def test_progress_carries_the_batch_metrics():
    seen = []
    problem = KnotSelection(SPIRAL)
    mk.minimize(problem, "random_search", budget=30, seed=2, callbacks=[seen.append],
                optimizer_kwargs={"batch_size": 30})
    (progress,) = seen
    assert set(progress.batch_metrics) == {"rmse", "n_control_points"}
    X = problem.sample(mk.make_rng(2), 30)
    _, fit = problem.evaluate_details(X)
    ok = fit.feasible
    np.testing.assert_allclose(progress.batch_metrics["rmse"][ok],
                               np.sqrt(fit.sse[ok] / SPIRAL.n_points))
    assert np.isnan(progress.batch_metrics["rmse"][~ok]).all()


def test_max_deviation_metric_when_the_objective_computes_it():
    problem = KnotSelection(SPIRAL, objective="error_bounded")
    result = mk.minimize(problem, "random_search", budget=40, seed=0)
    assert "max_deviation" in result.trace.metrics
    assert result.trace.metrics["max_deviation"][-1] == pytest.approx(
        result.solution.fit.max_deviation, rel=1e-9)


def test_a_subclass_overriding_evaluate_is_respected():
    class Shifted(KnotSelection):
        def evaluate(self, X):
            return super().evaluate(X) + 100.0

    result = mk.minimize(Shifted(SPIRAL), "random_search", budget=50, seed=0)
    plain = mk.minimize(KnotSelection(SPIRAL), "random_search", budget=50, seed=0)
    assert result.best_f == pytest.approx(plain.best_f + 100.0)


# --------------------------------------------------------------------------------------------
# external fits


def test_fitpack_scan_is_counted_as_external_fits(monkeypatch):
    calls = []
    real = fitpack_module.splprep

    def counting_splprep(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(fitpack_module, "splprep", counting_splprep)
    result = mk.minimize(KnotSelection(SPIRAL), FitpackKnots(), budget=200, seed=0)
    assert len(calls) > 5
    assert result.external_fits == len(calls) + 1  # + the fit without interior knots
    assert result.record()["external_fits"] == result.external_fits


def test_search_methods_make_no_external_fits():
    result = mk.minimize(KnotSelection(SPIRAL), GeneticAlgorithm(), budget=200, seed=0)
    assert result.external_fits == 0


# --------------------------------------------------------------------------------------------
# seeds, timings and the record


def test_seed_sequence_is_recorded_as_entropy_and_spawn_key():
    child = np.random.SeedSequence(7).spawn(3)[2]
    result = mk.minimize(KnotSelection(SPIRAL), "random_search", budget=20, seed=child)
    assert result.seed == 7 and result.seed_spawn_key == (2,)
    record = result.record()
    assert record["seed"] == 7 and record["seed_spawn_key"] == "2"
    again = mk.minimize(KnotSelection(SPIRAL), "random_search", budget=20,
                        seed=np.random.SeedSequence(7, spawn_key=(2,)))
    np.testing.assert_array_equal(again.best_x, result.best_x)


def test_timings_split_the_run(monkeypatch):
    """Each part's time lands in its own entry: an optimizer whose setup waits 30 ms more and
    whose run waits 300 ms more (bounds a busy machine does not break; comparing the two parts'
    own times did: setup 3.9 ms against 1.8 ms of optimising was seen under load)."""
    import time

    setup, run = DolphinEcholocation.setup, DolphinEcholocation.run

    def slow_setup(self, problem, rng):
        setup(self, problem, rng)
        time.sleep(0.03)

    def slow_run(self, evaluator):
        time.sleep(0.3)
        run(self, evaluator)

    monkeypatch.setattr(DolphinEcholocation, "setup", slow_setup)
    monkeypatch.setattr(DolphinEcholocation, "run", slow_run)
    result = mk.minimize(KnotSelection(SPIRAL), DolphinEcholocation(), budget=300, seed=0)
    t = result.timings
    assert set(t) == {"setup_seconds", "optimize_seconds", "decode_seconds"}
    assert all(v >= 0 for v in t.values())
    assert sum(t.values()) <= result.elapsed
    assert t["setup_seconds"] >= 0.03 and t["optimize_seconds"] >= 0.3
    assert t["setup_seconds"] < 0.3  # the run's wait is not in the setup


def test_record_is_flat_and_complete():
    data = add_noise(SPIRAL, 0.01, np.random.SeedSequence(3, spawn_key=(0,)))
    problem = KnotSelection(data, objective="paper", objective_options={"error_floor": 2e-5},
                            density=0.3)
    result = mk.minimize(problem, GeneticAlgorithm(population=20), budget=100, seed=3)
    record = result.record()
    assert all(not isinstance(v, dict | list | np.ndarray) for v in record.values())
    # one name, one meaning: `objective` is the name, the value is `best_f`
    assert record["objective"] == "paper" and record["objective.error_floor"] == 2e-5
    assert record["best_f"] == result.best_f
    assert record["problem"] == "mask" and record["encoding"] == "binary"
    assert record["data"] == data.name and record["noise"] == 0.01
    assert record["noise_seed"] == "3/0"
    assert record["data_fingerprint"] == data.fingerprint != SPIRAL.fingerprint
    assert record["density"] == 0.3 and record["degree"] == 3
    assert record["parameterization"] == "centripetal"
    assert record["optimizer"] == "ga" and record["optimizer.population"] == 20
    assert record["optimizer.crossover"] == "uniform"
    assert record["budget"] == record["n_evaluations"] == 100
    fit = result.solution.fit
    assert record["rmse"] == pytest.approx(fit.rmse)
    assert record["euclidean_distance"] == pytest.approx(fit.euclidean_distance)
    assert record["max_deviation"] == pytest.approx(fit.max_deviation)
    assert record["n_control_points"] == fit.n_control_points
    assert record["status"] == "ok" and record["error"] is None
    assert record["seed"] == 3 and record["seed_spawn_key"] == ""
    summary = result.summary()
    assert "objective" not in summary and summary["best_f"] == result.best_f


def test_fingerprint_tells_data_apart():
    a = get_curve("archimedean", n_points=60)
    assert a.fingerprint == SPIRAL.fingerprint
    assert get_curve("archimedean", n_points=61).fingerprint != SPIRAL.fingerprint
    moved = type(a)(a.points + 1e-12, name=a.name)
    assert moved.fingerprint != a.fingerprint


def test_record_of_a_run_without_feasible_candidates():
    # degree 5 on 8 points: every mask with interior knots is infeasible except the empty one,
    # which random search at density 1 never draws
    data = get_curve("archimedean", n_points=8)
    problem = KnotSelection(data, degree=5, density=1.0)
    result = mk.minimize(problem, "random_search", budget=5, seed=0)
    assert result.best_x is None and result.solution is None
    record = result.record()
    assert np.isnan(record["rmse"]) and record["best_f"] == np.inf


def test_git_commit_is_looked_up_once_and_inherited(tmp_path):
    import subprocess
    import sys

    code = ("from metaknot.experiments.environment import environment; "
            "print(environment()['git_commit'])")
    env = {k: v for k, v in __import__("os").environ.items() if k != "METAKNOT_GIT_COMMIT"}
    looked_up = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                               env=env, cwd=tmp_path, check=True).stdout.strip()
    head = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                          cwd=Path(mk.__file__).parent, check=False).stdout.strip()
    if head:  # a git checkout: the record names its commit
        assert looked_up.startswith(head)
    inherited = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                               env={**env, "METAKNOT_GIT_COMMIT": "abc123"}, cwd=tmp_path,
                               check=True).stdout.strip()
    assert inherited == "abc123"
