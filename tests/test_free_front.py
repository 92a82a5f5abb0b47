"""The free-knot front (``free_front``): reproducible, exactly on budget, at least the averaging
scan's front, every member a least-squares fit, and clean refusals."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import make_lsq_spline

import metaknot as mk
from metaknot.front import nondominated_mask
from metaknot.problems import FreeKnots, KnotIndices, KnotSelection, get_curve

DATA = get_curve("archimedean", n_points=40)


def front_problem(**kwargs) -> FreeKnots:
    return FreeKnots(DATA, n_knots=DATA.n_points - 4, variable_count=True, objective="pareto",
                     **kwargs)


def front_of(result: mk.RunResult) -> np.ndarray:
    return np.column_stack([result.front["objective_0"], result.front["objective_1"]])


def test_same_seed_same_front() -> None:
    a, b = (mk.minimize(front_problem(), "free_front", budget=3000, seed=3) for _ in range(2))
    assert a.front == b.front and a.n_evaluations == b.n_evaluations == 3000
    np.testing.assert_array_equal(a.best_x, b.best_x)
    np.testing.assert_array_equal(a.trace_evaluations, b.trace_evaluations)
    np.testing.assert_array_equal(a.trace_best, b.trace_best)


@pytest.mark.parametrize("budget", [1, 20, 36, 37, 999])
def test_the_budget_is_spent_exactly(budget: int) -> None:
    seen = []

    class Counting(FreeKnots):
        def evaluate(self, X):
            seen.append(len(X))
            return super().evaluate(X)

    problem = Counting(DATA, n_knots=36, variable_count=True, objective="pareto")
    result = mk.minimize(problem, "free_front", budget=budget, seed=0)
    assert sum(seen) == result.n_evaluations == budget


def test_the_front_dominates_or_equals_the_averaging_scan() -> None:
    scan = mk.minimize(front_problem(), "averaging", budget=5000, seed=0)
    ours = mk.minimize(front_problem(), "free_front", budget=3000, seed=0)
    A, F = front_of(scan), front_of(ours)
    for a in A:
        assert ((F[:, 0] <= a[0]) & (F[:, 1] <= a[1])).any(), a
    # and the refinement does better than the scan somewhere (a lower error at some count)
    assert ours.best_f < scan.best_f
    assert nondominated_mask(F).all()


def test_each_member_of_the_front_is_refitted_by_scipy() -> None:
    problem = front_problem()
    evaluator = mk.Evaluator(problem, 800)
    optimizer = mk.get_optimizer("free_front")
    optimizer.setup(evaluator.task, np.random.default_rng(0))
    optimizer.run(evaluator)
    archive = evaluator.front
    u, q, k = problem.params, problem.points, problem.degree
    for x, rmse in zip(archive.X, archive.metrics["rmse"], strict=True):
        interior = np.sort(x[~np.isnan(x)])
        t = np.concatenate((np.full(k + 1, u[0]), interior, np.full(k + 1, u[-1])))
        spline = make_lsq_spline(u, q, t, k=k)
        assert np.sqrt(np.mean(np.sum((spline(u) - q) ** 2, axis=1))) == \
            pytest.approx(rmse, rel=1e-7)
    cp, rmse = archive.metrics["n_control_points"], archive.metrics["rmse"]
    assert len(cp) >= 5 and np.all(np.diff(cp) > 0) and np.all(np.diff(rmse) < 0)
    np.testing.assert_allclose(problem.objective.scale(cp, rmse, problem.info), archive.F,
                               rtol=1e-12)
    np.testing.assert_array_equal(cp, [np.isfinite(x).sum() + k + 1 for x in archive.X])


def test_one_count_and_one_objective_improves_on_the_averaging_knots() -> None:
    problem = FreeKnots(DATA, n_knots=6, objective="paper", objective_options={"error_floor": 0})
    averaging = mk.minimize(problem, "averaging", budget=10, seed=0)
    ours = mk.minimize(problem, "free_front", budget=400, seed=0)
    assert ours.best_f < averaging.best_f


@pytest.mark.parametrize("problem", [KnotSelection(DATA, objective="pareto"),
                                     KnotIndices(DATA, n_knots=5, objective="pareto")],
                         ids=["mask", "indices"])
def test_refuses_data_point_encodings(problem) -> None:
    with pytest.raises(ValueError, match="needs a FreeKnots problem"):
        mk.minimize(problem, "free_front", budget=50, seed=0)


def test_a_closed_outline_gets_a_front_of_periodic_fits() -> None:
    closed = FreeKnots(get_curve("epitrochoid", n_points=60), n_knots=30, closed=True,
                       variable_count=True, objective="pareto")
    result = mk.minimize(closed, "free_front", budget=600, seed=0)
    scan = mk.minimize(closed, "averaging", budget=600, seed=0)
    assert result.n_evaluations == 600 and len(result.front["rmse"]) >= 5
    assert result.best_f < scan.best_f


def test_refuses_bad_settings() -> None:
    with pytest.raises(ValueError, match="local_variant"):
        mk.get_optimizer("free_front", local_variant="GN_CRS2_LM")
    with pytest.raises(ValueError, match="min_gap"):
        mk.minimize(front_problem(), "free_front", budget=50, seed=0,
                    optimizer_kwargs={"min_gap": 0.2})


def test_the_density_start_puts_knots_where_the_curve_bends() -> None:
    x = np.linspace(0.0, 1.0, 200)
    points = np.column_stack([x, np.exp(-(((x - 0.7) / 0.05) ** 2))])
    problem = FreeKnots(points, n_knots=40, variable_count=True, objective="pareto",
                        parameterization="uniform")
    optimizer = mk.get_optimizer("free_front")
    evaluator = mk.Evaluator(problem, 10)
    optimizer.setup(evaluator.task, np.random.default_rng(0))
    knots = optimizer.density_knots(12)
    assert knots.size == 12 and np.all(np.diff(knots) > 0)
    assert 0.0 < knots[0] and knots[-1] < 1.0
    bump = (knots > 0.55) & (knots < 0.85)  # 30 % of the range
    assert bump.sum() >= 8, knots
    off = mk.get_optimizer("free_front", density_exponent=0.0)
    off.setup(mk.Evaluator(problem, 10).task, np.random.default_rng(0))
    assert off.density_knots(12) is None
