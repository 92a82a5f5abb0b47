"""Small batches give the results of large ones, bit for bit.

Batches of a few candidates are fitted on the calling thread; ``metaknot.bspline.curve.
SERIAL_BATCH = 0`` sends every batch to the kernel's thread pool, and every registered
optimizer must then leave the same run: best candidate, best value, trace and metrics. The
objectives and metrics have one path for a batch of any size; their values are checked here
against the documented formulas, written with numpy.
"""

from __future__ import annotations

import contextlib

import numpy as np
import pytest

import metaknot as mk
from metaknot.bspline import curve as curve_module
from metaknot.bspline import fit as fit_module
from metaknot.bspline.curve import make_curve
from metaknot.problems import FreeKnots, KnotIndices, KnotSelection, get_curve
from metaknot.problems.objectives import DataInfo, get_objective
from tests.test_all_optimizers import CASES, IDS

SPIRAL = get_curve("archimedean", n_points=60)
OUTLINE = get_curve("epitrochoid", n_points=80)


@contextlib.contextmanager
def general_path():
    """Every batch through the kernel's thread pool."""
    serial = curve_module.SERIAL_BATCH
    curve_module.SERIAL_BATCH = 0
    try:
        yield
    finally:
        curve_module.SERIAL_BATCH = serial


def make(kind: str, closed: bool, **options) -> mk.Problem:
    data = OUTLINE if closed else SPIRAL
    if kind == "binary":
        return KnotSelection(data, closed=closed, **options)
    if kind == "integer":
        return KnotIndices(data, n_knots=6, closed=closed, **options)
    return FreeKnots(data, n_knots=6, closed=closed, **options)


def assert_same_run(fast: mk.RunResult, general: mk.RunResult, *, same_fits: bool = True
                    ) -> None:
    assert fast.n_evaluations == general.n_evaluations
    assert fast.best_f == general.best_f
    np.testing.assert_array_equal(fast.best_x, general.best_x)
    assert fast.best_x.dtype == general.best_x.dtype
    a, b = fast.trace.columns(), general.trace.columns()
    assert a.keys() == b.keys()
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)  # NaN equals NaN
    assert fast.delta_evaluations == general.delta_evaluations
    if same_fits:
        assert (fast.audited_fits, fast.accounted_fits) == \
            (general.audited_fits, general.accounted_fits)


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
@pytest.mark.parametrize(("name", "kind"), CASES, ids=IDS)
def test_every_optimizer_runs_the_same_on_both_paths(name, kind, closed):
    fast = mk.minimize(make(kind, closed), name, budget=60, seed=3)
    with general_path():
        general = mk.minimize(make(kind, closed), name, budget=60, seed=3)
    assert fast.status == general.status == "ok"
    assert_same_run(fast, general)


SEQUENTIAL = [("one_plus_one", "binary", {}), ("one_plus_one", "integer", {}),
              ("random_search", "binary", {"batch_size": 1}),
              ("random_search", "integer", {"batch_size": 3}),
              ("random_search", "continuous", {"batch_size": 1}),
              ("local_search", "binary", {})]
OBJECTIVE_OPTIONS = [("paper", {}), ("paper", {"error_floor": 0.0}), ("bic", {}),
                     ("error_bounded", {}), ("error_bounded", {"metric": "rmse"}),
                     ("rmse", {})]


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
@pytest.mark.parametrize(("objective", "options"), OBJECTIVE_OPTIONS,
                         ids=[f"{o}-{'-'.join(map(str, v.values()))}" for o, v in
                              OBJECTIVE_OPTIONS])
@pytest.mark.parametrize(("name", "kind", "settings"), SEQUENTIAL,
                         ids=[f"{n}-{k}-{s}" for n, k, s in SEQUENTIAL])
def test_sequential_runs_are_the_same_for_every_objective(name, kind, settings, objective,
                                                          options, closed):
    def run():
        problem = make(kind, closed, objective=objective, objective_options=options)
        return mk.minimize(problem, name, budget=150, seed=8, optimizer_kwargs=settings)

    fast = run()
    with general_path():
        general = run()
    assert_same_run(fast, general)


def random_batch(rng: np.random.Generator, size: int) -> fit_module.BatchFit:
    """Fits of a few control points with SSEs and deviations over many magnitudes, some
    infeasible."""
    reason = np.where(rng.random(size) < 0.2, rng.integers(1, 6, size), 0).astype(np.int8)
    sse = np.where(reason == 0, 10.0 ** rng.uniform(-30, 3, size), np.inf)
    deviation = np.where(reason == 0, 10.0 ** rng.uniform(-15, 2, size), np.inf)
    return fit_module.BatchFit(sse, deviation, rng.integers(4, 60, size), reason)


def reference_values(name: str, fit: fit_module.BatchFit, data: DataInfo,
                     options: dict) -> np.ndarray:
    """The objectives' formulas as their docstrings state them, in numpy."""
    ok = fit.reason == 0
    rmse = np.sqrt(fit.sse / data.n_points)
    if name == "paper":
        floor = options.get("error_floor", 1e-5) * data.scale * np.sqrt(data.n_points)
        value = fit.n_control_points * np.maximum(np.sqrt(fit.sse), floor)
    elif name == "rmse":
        value = rmse
    elif name == "error_bounded":
        error = rmse if options.get("metric") == "rmse" else fit.max_deviation
        ratio = error / (options.get("relative_tolerance", 1e-3) * data.scale)
        value = np.where(ratio <= 1.0, fit.n_control_points + ratio,
                         data.n_points + 2 + ratio)
    else:
        n = data.n_points * data.dim
        sse = np.maximum(fit.sse, max((options.get("error_floor", 1e-9) * data.scale) ** 2 * n,
                                      np.finfo(float).tiny))
        k = data.dim * fit.n_control_points + fit.n_control_points - data.extra_control_points
        with np.errstate(invalid="ignore", over="ignore"):
            value = n * np.log(sse / n) + np.log(n) * k
    return np.where(ok, value, np.inf)


@pytest.mark.parametrize(("name", "options"), [
    *OBJECTIVE_OPTIONS, ("error_bounded", {"relative_tolerance": 1e-8})], ids=str)
def test_each_objective_values_a_batch_and_each_candidate_by_its_formula(name, options):
    objective = get_objective(name, **options)
    data = DataInfo(n_points=361, dim=2, scale=7.5, degree=3, extra_control_points=4)
    batch = random_batch(np.random.default_rng(4), 2000)
    values = objective(batch, data)
    np.testing.assert_array_equal(values, reference_values(name, batch, data, options))
    assert values.dtype == np.float64 and np.isinf(values[batch.reason != 0]).all()
    for b in range(0, len(batch), 7):
        one = fit_module.BatchFit(batch.sse[b:b + 1], batch.max_deviation[b:b + 1],
                                  batch.n_control_points[b:b + 1], batch.reason[b:b + 1])
        assert objective(one, data)[0] == values[b]


def test_run_metrics_are_those_of_the_fits_and_nan_where_infeasible():
    problem = make("binary", False, objective="error_bounded")
    X = np.random.default_rng(5).integers(0, 2, (300, problem.encoding.n_var))
    X[:40] = 1  # more control points than a fit allows: infeasible
    _, fit = problem.evaluate_details(X)
    _, metrics = problem.evaluate_with_metrics(X)
    ok = fit.reason == 0
    assert 0 < ok.sum() < len(ok)
    expected = {"rmse": np.sqrt(fit.sse / problem.data.n_points),
                "n_control_points": fit.n_control_points.astype(float),
                "max_deviation": fit.max_deviation}
    assert metrics.keys() == expected.keys()
    for name, column in expected.items():
        np.testing.assert_array_equal(metrics[name], np.where(ok, column, np.nan), err_msg=name)


def test_the_serial_kernel_fits_as_the_thread_pool_does():
    rng = np.random.default_rng(6)
    curve = make_curve(SPIRAL.points)
    masks = (rng.random((12, curve.candidate_params.size)) < 0.3).astype(np.int64)
    masks[0] = 1  # too many control points
    indices = np.sort(rng.integers(1, curve.max_index + 1, (12, 8)), axis=1)
    positions = rng.uniform(-0.1, 1.1, (12, 6))
    some_absent = np.where(rng.random((12, 6)) < 0.3, np.nan, rng.uniform(0, 1, (12, 6)))

    def absent(batch, max_deviation):
        return curve.evaluate_positions(batch, max_deviation=max_deviation, nan_is_absent=True)

    for evaluate, batch in ((curve.evaluate_masks, masks), (curve.evaluate_indices, indices),
                            (curve.evaluate_positions, positions),
                            (curve.evaluate_positions, some_absent), (absent, some_absent)):
        with general_path():
            pool = evaluate(batch, max_deviation=True)
        for first in range(0, 12, 3):  # batches of 3: fitted on the calling thread
            serial = evaluate(batch[first:first + 3], max_deviation=True)
            for field in ("sse", "max_deviation", "n_control_points", "reason"):
                np.testing.assert_array_equal(getattr(serial, field),
                                              getattr(pool, field)[first:first + 3])
        assert len(set(pool.reason.tolist())) > 1  # feasible and infeasible candidates
