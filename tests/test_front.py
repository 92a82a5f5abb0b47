"""Two objectives: the front archive, the hypervolume, the objective ``pareto`` and NSGA-II."""

from __future__ import annotations

import json

import numpy as np
import pytest

import metaknot as mk
from metaknot.front import ParetoArchive, hypervolume_2d, nondominated_mask
from metaknot.problems import KnotIndices, KnotSelection, get_curve

pymoo_hv = pytest.importorskip("pymoo.indicators.hv")

DATA = get_curve("archimedean", n_points=60)


def brute_nondominated(F: np.ndarray) -> np.ndarray:
    keep = np.isfinite(F).all(axis=1)
    for i in range(len(F)):
        for j in range(len(F)):
            if i == j or not np.isfinite(F[j]).all():
                continue
            if (F[j] <= F[i]).all() and ((F[j] < F[i]).any() or j < i):
                keep[i] = False
    return keep


@pytest.mark.parametrize("seed", range(6))
def test_nondominated_mask_matches_pairwise_check(seed: int) -> None:
    rng = np.random.default_rng(seed)
    F = rng.integers(0, 6, size=(40, 2)).astype(float)  # many ties
    F[rng.random(40) < 0.1] = np.inf
    np.testing.assert_array_equal(nondominated_mask(F), brute_nondominated(F))


@pytest.mark.parametrize("seed", range(6))
def test_hypervolume_matches_pymoo(seed: int) -> None:
    rng = np.random.default_rng(seed)
    F = rng.random((30, 2)) * 1.2  # some beyond the reference point
    ref = np.array([1.0, 1.0])
    inside = F[(F < ref).all(axis=1)]
    assert hypervolume_2d(F, ref) == pytest.approx(pymoo_hv.HV(ref_point=ref)(inside), rel=1e-12)


def test_hypervolume_of_a_staircase_by_hand() -> None:
    F = [(0.1, 0.6), (0.4, 0.3), (0.5, 0.5), (0.8, 0.1)]  # (0.5, 0.5) is dominated
    # rectangles: [0.1, 0.4) x 0.4, [0.4, 0.8) x 0.7, [0.8, 1.0) x 0.9
    assert hypervolume_2d(F, (1.0, 1.0)) == pytest.approx(0.3 * 0.4 + 0.4 * 0.7 + 0.2 * 0.9)
    assert hypervolume_2d(np.empty((0, 2)), (1.0, 1.0)) == 0.0


@pytest.mark.parametrize("seed", range(4))
def test_archive_keeps_the_front_and_its_running_gap(seed: int) -> None:
    rng = np.random.default_rng(seed)
    archive = ParetoArchive()
    seen = np.empty((0, 2))
    for _ in range(5):
        F = rng.random((25, 2)) ** 2 * 1.1
        F[rng.random(25) < 0.1] = np.inf
        X = rng.integers(0, 2, size=(25, 3))
        gaps = archive.add(X, F, {"rmse": F[:, 1] * 7})
        for i in range(len(F)):  # the gap after each candidate, recomputed from scratch
            prefix = np.vstack([seen, F[: i + 1]])
            assert gaps[i] == pytest.approx(1 - hypervolume_2d(prefix, (1, 1)), abs=1e-12)
        seen = np.vstack([seen, F])
    expected = seen[nondominated_mask(seen) & (seen < 1).all(axis=1)]
    np.testing.assert_allclose(archive.F, expected[np.argsort(expected[:, 0])])
    np.testing.assert_allclose(archive.metrics["rmse"], archive.F[:, 1] * 7)
    assert archive.X.shape == (len(archive), 3)


def test_archive_rejects_a_bad_box() -> None:
    with pytest.raises(ValueError, match="ideal < reference"):
        ParetoArchive(reference=(1.0, 0.0))


def test_pareto_objective_scale() -> None:
    problem = KnotSelection(DATA, objective="pareto", objective_options={"error_floor": 1e-4})
    scale = problem.info.scale
    F = problem.objective.scale([4, 30, 60], [1e-4 * scale, 1e-2 * scale, scale], problem.info)
    np.testing.assert_allclose(F, [[4 / 60, 0.0], [0.5, 0.5], [1.0, 1.0]], atol=1e-12)
    below = problem.objective.scale([10], [1e-9 * scale], problem.info)
    assert below[0, 1] == 0.0  # errors below the floor count as exact
    with pytest.raises(ValueError, match="error_floor"):
        KnotSelection(DATA, objective="pareto", objective_options={"error_floor": 0})


def test_pareto_values_are_control_points_and_error() -> None:
    problem = KnotSelection(DATA, objective="pareto",
                            objective_options={"metric": "max_deviation"})
    X = problem.sample(np.random.default_rng(0), 20)
    F, metrics = problem.evaluate_with_metrics(X)
    assert F.shape == (20, 2)
    ok = np.isfinite(F[:, 0])
    np.testing.assert_allclose(F[ok, 0], metrics["n_control_points"][ok] / 60)
    expected = problem.objective.scale(metrics["n_control_points"][ok],
                                       metrics["max_deviation"][ok], problem.info)
    np.testing.assert_allclose(F[ok], expected)


class Collect(mk.Callback):
    def __init__(self) -> None:
        self.cp: list[np.ndarray] = []
        self.rmse: list[np.ndarray] = []
        self.gaps: list[np.ndarray] = []

    def on_batch(self, progress):
        self.cp.append(progress.batch_metrics["n_control_points"])
        self.rmse.append(progress.batch_metrics["rmse"])
        self.gaps.append(np.asarray(progress.batch_f))


@pytest.mark.parametrize("optimizer", ["pymoo:NSGA2", "random_search", "averaging"])
def test_run_record_carries_a_front_that_dominates_everything_evaluated(optimizer: str) -> None:
    problem = KnotSelection(DATA, objective="pareto")
    seen = Collect()
    result = mk.minimize(problem, optimizer, budget=600, seed=3, callbacks=[seen])
    front = result.front
    F = np.column_stack((front["objective_0"], front["objective_1"]))
    assert nondominated_mask(F).all()
    # every evaluated candidate is weakly dominated by a member of the front
    evaluated = problem.objective.scale(np.concatenate(seen.cp), np.concatenate(seen.rmse),
                                        problem.info)
    evaluated = evaluated[np.isfinite(evaluated).all(axis=1) & (evaluated < 1).all(axis=1)]
    covered = ((F[None, :, 0] <= evaluated[:, None, 0])
               & (F[None, :, 1] <= evaluated[:, None, 1])).any(axis=1)
    assert covered.all()
    np.testing.assert_allclose(F[:, 0], np.asarray(front["n_control_points"]) / 60)
    # the scalar is the hypervolume gap, by pymoo's indicator
    hv = pymoo_hv.HV(ref_point=np.array([1.0, 1.0]))(F)
    assert result.best_f == pytest.approx(1 - hv, abs=1e-12)
    assert np.all(np.diff(np.concatenate(seen.gaps)) <= 0)
    record = result.record()
    assert record["hypervolume"] == pytest.approx(hv, abs=1e-12)
    assert record["front_size"] == len(F)
    assert json.loads(record["front"]) == front
    # the solution is the knee: the member nearest the ideal point
    knee = int(np.argmin(np.hypot(F[:, 0], F[:, 1])))
    assert result.metrics["n_control_points"] == front["n_control_points"][knee]


@pytest.mark.parametrize("optimizer", ["ga", "dolphin", "one_plus_one", "local_search", "pymoo:GA",
                                       "nevergrad:NGOpt"])
def test_single_objective_optimizers_refuse_a_front(optimizer: str) -> None:
    problem = KnotSelection(DATA, objective="pareto")
    with pytest.raises(ValueError, match=r"minimises one objective.*pymoo:NSGA2"):
        mk.minimize(problem, optimizer, budget=50, seed=0)


@pytest.mark.parametrize("optimizer", ["pymoo:NSGA2", "random_search", "averaging", "fitpack"])
@pytest.mark.parametrize("budget", [1, 77, 400])
def test_multi_objective_budget_and_same_seed(optimizer: str, budget: int) -> None:
    runs = [mk.minimize(KnotSelection(DATA, objective="pareto"), optimizer, budget=budget,
                        seed=4) for _ in range(2)]
    a, b = runs
    assert a.n_evaluations <= budget and a.n_evaluations == b.n_evaluations
    assert a.front == b.front and a.best_f == b.best_f


def test_nsga2_on_index_sets_and_single_objective() -> None:
    # on K fixed indices the front is one point: control points are fixed
    problem = KnotIndices(DATA, n_knots=6, objective="pareto")
    result = mk.minimize(problem, "pymoo:NSGA2", budget=300, seed=0)
    assert set(result.front["n_control_points"]) == {10}
    # on one objective NSGA-II is a GA with crowding
    single = mk.minimize(KnotIndices(DATA, n_knots=6), "pymoo:NSGA2", budget=300, seed=0)
    assert single.front is None and np.isfinite(single.best_f)


@pytest.mark.parametrize("curve", ["archimedean", "vivaldi"])
def test_nsga2_front_beats_random_search_and_its_start(curve: str) -> None:
    problem = KnotSelection(get_curve(curve, n_points=120), objective="pareto")
    gaps = {
        name: np.median([mk.minimize(problem, name, budget=3000, seed=s,
                                     optimizer_kwargs=kw).best_f for s in range(3)])
        for name, kw in [("random_search", {}), ("averaging", {}),
                         ("pymoo:NSGA2", {"population": 60, "initial": "averaging"})]
    }
    assert gaps["pymoo:NSGA2"] < gaps["random_search"]
    assert gaps["pymoo:NSGA2"] < gaps["averaging"]  # it improves on the averaging front


def test_initial_averaging_puts_the_averaging_masks_first() -> None:
    from metaknot.algorithms.pymoo_adapter import PymooOptimizer

    problem = KnotSelection(DATA, objective="pareto")
    optimizer = PymooOptimizer("NSGA2", population=20, initial="averaging")
    optimizer.setup(problem, np.random.default_rng(0))
    first = optimizer.ask()
    counts = first.sum(axis=1)
    # ten averaging masks at knot counts spread over 1..56, then ten random ones
    np.testing.assert_array_equal(counts[:10], np.linspace(1, 56, 10).round())
    with pytest.raises(ValueError, match="initial"):
        PymooOptimizer("DE", initial="averaging")


def test_spec_skips_single_objective_algorithms_on_a_front() -> None:
    from metaknot.experiments.spec import run_spec
    from tests.test_spec import compose_cfg

    spec = run_spec(compose_cfg("objective=pareto", "optimizer=ga"))
    assert "one objective" in spec.compatible()
    ok = run_spec(compose_cfg("objective=pareto", "optimizer=pymoo", "optimizer.variant=NSGA2"))
    assert ok.compatible() is None


@pytest.mark.parametrize("optimizer", ["nlopt", "cmaes"])
def test_free_knot_optimizers_refuse_a_front(optimizer: str) -> None:
    from metaknot.problems import FreeKnots

    with pytest.raises(ValueError, match="minimises one objective"):
        mk.minimize(FreeKnots(DATA, n_knots=5, objective="pareto"), optimizer, budget=50, seed=0)


def test_fitpack_front_holds_the_best_fit_per_count() -> None:
    from scipy.interpolate import splev, splprep

    from metaknot.bspline import fitpack

    problem = KnotSelection(DATA)
    front = fitpack.front(problem.params, problem.points, 3, n_smoothing=60)
    assert np.all(np.diff(front["n_control_points"]) > 0)
    assert np.all(front["max_deviation"] >= front["rmse"])
    total = float(((DATA.points - DATA.points.mean(axis=0)) ** 2).sum())
    for s in np.geomspace(total * 1e-14, total * 0.5, 60)[::7]:  # some of the same s, directly
        (t, c, k), _ = splprep(DATA.points.T, u=problem.params, k=3, s=s, full_output=1,
                               quiet=1)[0]
        fitted = np.column_stack(splev(problem.params, (t, c, k)))
        rmse = np.sqrt(np.mean(np.sum((DATA.points - fitted) ** 2, axis=1)))
        at = np.flatnonzero(front["n_control_points"] == len(t) - 4)
        assert at.size == 1 and front["rmse"][at[0]] <= rmse * (1 + 1e-12)


def test_a_study_of_fronts_end_to_end(tmp_path) -> None:
    import subprocess
    import sys

    from metaknot.experiments.store import load_study

    for choice in ("method=nsga2_mask", "optimizer=ga,averaging"):
        done = subprocess.run(
            [sys.executable, "-m", "metaknot.cli", "run", "-m", "objective=pareto", choice,
             "problem=archimedean", "problem.n_points=80", "budget=300", "seed=0,1",
             f"results_dir={tmp_path}", "study=fronts"],
            cwd=tmp_path, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
    assert "minimises one objective" in done.stderr  # the GA runs are skipped, with the reason
    study = load_study(tmp_path / "fronts")
    assert sorted(study.runs.label) == ["averaging", "averaging", "nsga2", "nsga2"]
    fronts = study.fronts()
    assert set(fronts.run_id) == set(study.runs.run_id)
    for run in study.runs.itertuples():
        part = fronts[fronts.run_id == run.run_id]
        assert len(part) == run.front_size
        F = part[["objective_0", "objective_1"]].to_numpy()
        assert 1 - run.best_f == pytest.approx(hypervolume_2d(F, (1, 1)))


def test_report_draws_each_method_s_front(tmp_path) -> None:
    from metaknot.experiments.app import execute
    from metaknot.experiments.report import figures as f
    from metaknot.experiments.report.data import prepare
    from metaknot.experiments.spec import run_spec

    problem = KnotSelection(get_curve("archimedean", n_points=80), objective="pareto")
    for optimizer in ("random_search", "averaging"):
        for seed in range(3):
            execute(run_spec({
                "study": "fronts", "results_dir": str(tmp_path),
                "problem": {"curve": "archimedean", "n_points": 80},
                "encoding": {"kind": "mask"}, "objective": {"name": "pareto"},
                "optimizer": {"_name_": optimizer}, "budget": 300, "seed": seed,
                "threads": 1, "progress": False}), multirun=True)
    comparison = prepare(tmp_path / "fronts")
    figure = f.front_figure(comparison, comparison.instances[0])
    steps = [line for line in figure.axes[0].get_lines() if "front" in line.get_label()]
    labels = sorted(line.get_label() for line in steps)
    assert labels == ["FITPACK front", "averaging (median-hypervolume run's front)",
                      "random_search (median-hypervolume run's front)"]
    drawn = {line.get_label(): line.get_xydata() for line in steps}
    averaging = drawn["averaging (median-hypervolume run's front)"]
    stored = mk.minimize(problem, "averaging", budget=300, seed=0).front  # deterministic
    np.testing.assert_allclose(averaging[:, 0], stored["n_control_points"])
    np.testing.assert_allclose(averaging[:, 1], stored["rmse"])


def test_a_batch_with_nothing_feasible_leaves_no_front_and_no_incumbent() -> None:
    problem = KnotIndices(DATA, n_knots=4, objective="pareto")
    evaluator = mk.Evaluator(problem, budget=10)
    F = evaluator(np.array([[5, 5, 6, 7], [9, 9, 9, 9]]))  # coincident knots: infeasible
    assert np.isinf(F).all() and len(evaluator.front) == 0
    assert evaluator.best_x is None and evaluator.best_f == np.inf
    evaluator(np.array([[5, 15, 25, 35]]))
    assert len(evaluator.front) == 1 and evaluator.best_x is not None
    assert evaluator.best_f == pytest.approx(evaluator.front.gap)
