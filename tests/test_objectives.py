"""Objectives (paper, bic, error_bounded, max_deviation) through the three knot problems.

Every objective value is recomputed here from an independent least-squares fit with
``scipy.interpolate.make_lsq_spline``; feasibility (Schoenberg-Whitney) is decided
independently by the rank of the collocation matrix ``BSpline.design_matrix``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from scipy.interpolate import BSpline, make_lsq_spline

from metaknot.problems import (
    FreeKnots,
    KnotIndices,
    KnotSelection,
    KnotSolution,
    PointSet,
    add_noise,
    get_curve,
)

DEGREE = 3

# --------------------------------------------------------------------------------------------
# independent reference
# --------------------------------------------------------------------------------------------


def centripetal(points):
    """Centripetal parameterization on [0, 1] (square root of the chord lengths)."""
    steps = np.sqrt(np.sqrt(np.sum(np.diff(points, axis=0) ** 2, axis=1)))
    u = np.concatenate([[0.0], np.cumsum(steps)]) / np.sum(steps)
    u[-1] = 1.0
    return u


@dataclass
class RefFit:
    feasible: bool
    n_cp: int
    sse: float = np.inf
    max_dev: float = np.inf
    spline: BSpline | None = None


def reference_fit(u, points, interior, k=DEGREE) -> RefFit:
    interior = np.asarray(interior, dtype=float)
    n_cp = interior.size + k + 1
    if n_cp > u.size:
        return RefFit(False, n_cp)
    if not np.all(np.isfinite(interior)) or np.any(interior <= u[0]) \
            or np.any(interior >= u[-1]) or np.any(np.diff(interior) <= 0):
        return RefFit(False, n_cp)
    t = np.concatenate([np.full(k + 1, u[0]), interior, np.full(k + 1, u[-1])])
    design = BSpline.design_matrix(u, t, k).toarray()
    if np.linalg.matrix_rank(design) < n_cp:  # Schoenberg-Whitney violated
        return RefFit(False, n_cp)
    spline = make_lsq_spline(u, points, t, k)
    dist = np.sqrt(np.sum((points - spline(u)) ** 2, axis=1))
    return RefFit(True, n_cp, float(np.sum(dist**2)), float(dist.max()), spline)


def scale_of(points):
    return float(np.sqrt(np.sum((points.max(axis=0) - points.min(axis=0)) ** 2)))


def ref_paper(fits, points, error_floor):
    n = points.shape[0]
    floor = error_floor * scale_of(points) * np.sqrt(n)
    return np.array([f.n_cp * max(np.sqrt(f.sse), floor) if f.feasible else np.inf
                     for f in fits])


def ref_bic(fits, points, error_floor=1e-9, k=DEGREE):
    n = points.shape[0] * points.shape[1]
    floor = (error_floor * scale_of(points)) ** 2 * n
    out = []
    for f in fits:
        if not f.feasible:
            out.append(np.inf)
            continue
        n_params = points.shape[1] * f.n_cp + (f.n_cp - k - 1)
        out.append(n * np.log(max(f.sse, floor) / n) + np.log(n) * n_params)
    return np.array(out)


def ref_error_bounded(fits, points, tol, metric="max_deviation"):
    n = points.shape[0]
    out = []
    for f in fits:
        if not f.feasible:
            out.append(np.inf)
            continue
        err = f.max_dev if metric == "max_deviation" else np.sqrt(f.sse / n)
        ratio = err / tol
        out.append(f.n_cp + ratio if ratio <= 1 else n + 2 + ratio)
    return np.array(out)


def mask_fits(problem, masks):
    u = problem.params
    return [reference_fit(u, problem.points, u[1:-1][m.astype(bool)]) for m in masks]


def all_masks(n_bits):
    return (np.arange(2**n_bits)[:, None] >> np.arange(n_bits)) & 1


def assert_values(actual, expected, rtol=1e-7, atol=1e-10):
    actual = np.asarray(actual)
    assert actual.shape == expected.shape
    assert not np.isnan(actual).any()
    np.testing.assert_array_equal(np.isinf(actual), np.isinf(expected))
    fin = np.isfinite(expected)
    np.testing.assert_allclose(actual[fin], expected[fin], rtol=rtol, atol=atol)


@pytest.fixture(scope="module")
def noisy_spiral():
    return add_noise(get_curve("archimedean"), 0.01, seed=11)


@pytest.fixture(scope="module")
def masks_batch():
    rng = np.random.default_rng(5)
    density = np.repeat([0.03, 0.1, 0.3, 0.6], 6)[:, None]
    masks = (rng.random((density.size, 98)) < density).astype(np.int64)
    masks[0] = 0  # no interior knot: a single Bezier segment
    masks[1] = 1  # 96 interior knots: interpolation (N control points)
    masks[1, [0, -1]] = 0
    masks[2] = 1  # 98 interior knots: more control points than data points (infeasible)
    return masks


# --------------------------------------------------------------------------------------------
# parameterization and single fits
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("curve", ["epitrochoid", "archimedean", "vivaldi"])
def test_centripetal_parameters(curve):
    problem = KnotSelection(curve)
    np.testing.assert_allclose(problem.params, centripetal(problem.points), rtol=0, atol=1e-13)


def test_decode_returns_scipy_spline(noisy_spiral, masks_batch):
    problem = KnotSelection(noisy_spiral)
    for mask in masks_batch[[0, 1, 5, 12, 20, 23]]:
        solution = problem.decode(mask)
        assert isinstance(solution, KnotSolution)
        assert isinstance(solution.fit.spline, BSpline)
        ref = reference_fit(problem.params, problem.points, problem.params[1:-1][mask == 1])
        assert ref.feasible
        np.testing.assert_allclose(solution.fit.spline.t, ref.spline.t, rtol=0, atol=1e-15)
        assert solution.fit.spline.k == DEGREE
        assert solution.fit.control_points.shape == (ref.n_cp, 2)
        np.testing.assert_allclose(solution.fit.spline.c, ref.spline.c, rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(solution.fit.spline(problem.params), ref.spline(problem.params),
                                   rtol=1e-7, atol=1e-9)
        assert solution.fit.n_control_points == ref.n_cp
        assert solution.fit.sse == pytest.approx(ref.sse, rel=1e-7, abs=1e-14)
        assert solution.fit.max_deviation == pytest.approx(ref.max_dev, rel=1e-7, abs=1e-12)
        assert solution.objective_value == pytest.approx(float(problem.evaluate(mask[None])[0]),
                                                   rel=1e-12)
        np.testing.assert_array_equal(solution.x, mask)


def test_decode_infeasible_raises(noisy_spiral):
    problem = FreeKnots(noisy_spiral, n_knots=3)
    with pytest.raises(ValueError, match="coincident"):
        problem.decode(np.array([0.3, 0.3, 0.6]))


# --------------------------------------------------------------------------------------------
# objective values against scipy
# --------------------------------------------------------------------------------------------


def test_paper_unguarded_is_control_points_times_euclidean_distance(noisy_spiral, masks_batch):
    problem = KnotSelection(noisy_spiral, objective="paper",
                            objective_options={"error_floor": 0.0})
    fits = mask_fits(problem, masks_batch)
    expected = np.array([f.n_cp * np.sqrt(f.sse) if f.feasible else np.inf for f in fits])
    values = problem.evaluate(masks_batch)
    assert_values(values, expected, atol=1e-9)
    assert values[2] == np.inf  # 102 control points for 100 data points
    # the seed's degenerate optimum: interpolation (N control points) drives it to ~0
    assert problem.evaluate(masks_batch[1:2])[0] < 1e-8


@pytest.mark.parametrize("curve", ["epitrochoid", "vivaldi"])
def test_paper_on_clean_seed_curves(curve):
    problem = KnotSelection(curve, objective="paper", objective_options={"error_floor": 0.0})
    masks = problem.sample(np.random.default_rng(3), 6)
    fits = mask_fits(problem, masks)
    assert_values(problem.evaluate(masks), ref_paper(fits, problem.points, 0.0), atol=1e-9)


def test_paper_error_floor_guard(noisy_spiral, masks_batch):
    u = centripetal(noisy_spiral.points)
    fits = [reference_fit(u, noisy_spiral.points, u[1:-1][m == 1]) for m in masks_batch]
    distances = np.array([np.sqrt(f.sse) for f in fits])
    n, scale = noisy_spiral.n_points, scale_of(noisy_spiral.points)
    # a floor in the middle of the achieved distances: it engages for some candidates only
    finite = np.sort(distances[np.isfinite(distances)])
    mid = finite.size // 2
    floor_level = float(np.sqrt(finite[mid - 1] * finite[mid]))
    error_floor = floor_level / (scale * np.sqrt(n))
    problem = KnotSelection(noisy_spiral, objective="paper",
                            objective_options={"error_floor": error_floor})
    values = problem.evaluate(masks_batch)
    expected = ref_paper(fits, noisy_spiral.points, error_floor)
    assert_values(values, expected)
    below = distances < floor_level
    assert below.any() and (~below).any()
    cps = np.array([f.n_cp for f in fits])
    # below the floor only the number of control points counts
    np.testing.assert_allclose(values[below], cps[below] * floor_level, rtol=1e-12)
    # interpolation no longer wins: its value is N x floor, not ~0
    assert values[1] == pytest.approx(n * floor_level, rel=1e-12)
    assert values[1] > values.min()
    # a huge floor: every feasible candidate is CP x floor exactly
    big = KnotSelection(noisy_spiral, objective="paper", objective_options={"error_floor": 10.0})
    feasible = np.array([f.feasible for f in fits])
    np.testing.assert_allclose(big.evaluate(masks_batch),
                               np.where(feasible, cps * 10.0 * scale * np.sqrt(n), np.inf),
                               rtol=1e-12)


def test_paper_default_floor_is_documented_value(noisy_spiral, masks_batch):
    problem = KnotSelection(noisy_spiral)  # default objective: paper, error_floor=1e-5
    fits = mask_fits(problem, masks_batch)
    assert_values(problem.evaluate(masks_batch), ref_paper(fits, problem.points, 1e-5))


@pytest.mark.parametrize("error_floor", [1e-9, 1e-3])
def test_bic_formula(noisy_spiral, masks_batch, error_floor):
    problem = KnotSelection(noisy_spiral, objective="bic",
                            objective_options={"error_floor": error_floor})
    fits = mask_fits(problem, masks_batch)
    expected = ref_bic(fits, problem.points, error_floor)
    assert_values(problem.evaluate(masks_batch), expected, rtol=1e-7, atol=1e-6)


def test_bic_three_dimensional():
    data = add_noise(get_curve("vivaldi"), 1e-3, seed=4)
    problem = KnotSelection(data, objective="bic")
    masks = problem.sample(np.random.default_rng(8), 8)
    fits = mask_fits(problem, masks)
    assert_values(problem.evaluate(masks), ref_bic(fits, data.points), rtol=1e-7, atol=1e-6)


@pytest.mark.parametrize("metric", ["max_deviation", "rmse"])
def test_error_bounded_values_and_ranking(noisy_spiral, masks_batch, metric):
    u = centripetal(noisy_spiral.points)
    fits = [reference_fit(u, noisy_spiral.points, u[1:-1][m == 1]) for m in masks_batch]
    n = noisy_spiral.n_points
    errs = np.array([(f.max_dev if metric == "max_deviation" else np.sqrt(f.sse / n))
                     if f.feasible else np.inf for f in fits])
    finite = np.sort(errs[np.isfinite(errs)])
    mid = finite.size // 2
    tol = float(np.sqrt(finite[mid - 1] * finite[mid]))  # strictly between two errors
    problem = KnotSelection(noisy_spiral, objective="error_bounded",
                            objective_options={"tolerance": tol, "metric": metric})
    values = problem.evaluate(masks_batch)
    assert_values(values, ref_error_bounded(fits, noisy_spiral.points, tol, metric))

    feasible = np.isfinite(errs)
    within = feasible & (errs <= tol)
    beyond = feasible & (errs > tol)
    assert within.sum() >= 2 and beyond.sum() >= 2
    # every candidate within tolerance ranks ahead of every candidate beyond it
    assert values[within].max() < values[beyond].min()
    # within tolerance: lexicographic (control points, error)
    cps = np.array([f.n_cp for f in fits])
    idx = np.flatnonzero(within)
    by_value = idx[np.argsort(values[idx], kind="stable")]
    by_key = idx[np.lexsort((errs[idx], cps[idx]))]
    np.testing.assert_array_equal(by_value, by_key)
    # beyond tolerance: ranked by error alone, whatever the number of control points
    idx = np.flatnonzero(beyond)
    np.testing.assert_array_equal(idx[np.argsort(values[idx])], idx[np.argsort(errs[idx])])


def test_error_bounded_relative_tolerance(noisy_spiral, masks_batch):
    problem = KnotSelection(noisy_spiral, objective="error_bounded",
                            objective_options={"relative_tolerance": 0.01})
    fits = mask_fits(problem, masks_batch)
    tol = 0.01 * scale_of(noisy_spiral.points)
    assert_values(problem.evaluate(masks_batch),
                  ref_error_bounded(fits, noisy_spiral.points, tol))


def test_error_bounded_infeasible_is_inf(noisy_spiral):
    problem = FreeKnots(noisy_spiral, n_knots=4, objective="error_bounded")
    values = problem.evaluate(np.array([[0.2, 0.4, 0.6, 0.8], [0.2, 0.4, 0.4, 0.8]]))
    assert np.isfinite(values[0])
    assert values[1] == np.inf


# --------------------------------------------------------------------------------------------
# exhaustive search on a small case
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def ten_points():
    t = np.linspace(0.0, 2.5, 10)
    pts = np.stack([np.cos(t) + 0.3 * t, np.sin(2.0 * t)], axis=1)
    return add_noise(PointSet(pts, name="ten"), 0.002, seed=9)


@pytest.fixture(scope="module")
def ten_point_fits(ten_points):
    u = centripetal(ten_points.points)
    masks = all_masks(8)
    return masks, [reference_fit(u, ten_points.points, u[1:-1][m == 1]) for m in masks]


def test_exhaustive_error_bounded_argmin(ten_points, ten_point_fits):
    masks, fits = ten_point_fits
    assert masks.shape == (256, 8)
    cps = np.array([f.n_cp for f in fits])
    errs = np.array([f.max_dev for f in fits])
    # a tolerance that a few 5-control-point fits meet and no 4-control-point fit does
    tol = 2.0 * errs[cps == 5].min()
    assert errs[cps == 4].min() > tol
    problem = KnotSelection(ten_points, objective="error_bounded",
                            objective_options={"tolerance": tol})
    assert problem.encoding.n_var == 8
    values = problem.evaluate(masks)  # all 256 masks in one batch
    expected = ref_error_bounded(fits, ten_points.points, tol)
    assert_values(values, expected)
    best = int(np.argmin(expected))
    assert np.sort(expected)[1] - expected[best] > 1e-6  # the optimum is unique
    assert int(np.argmin(values)) == best
    assert cps[best] == 5


def test_exhaustive_paper_and_bic(ten_points, ten_point_fits):
    masks, fits = ten_point_fits
    # more than N control points (7 or 8 knots) cannot be fitted
    cps = np.array([f.n_cp for f in fits])
    for objective, options, expected in [
        ("paper", {"error_floor": 1e-3},
         ref_paper(fits, ten_points.points, 1e-3)),
        ("paper", {"error_floor": 0.0}, ref_paper(fits, ten_points.points, 0.0)),
        ("bic", {}, ref_bic(fits, ten_points.points)),
    ]:
        problem = KnotSelection(ten_points, objective=objective, objective_options=options)
        values = problem.evaluate(masks)
        assert_values(values, expected, rtol=1e-7, atol=1e-8)
        assert np.all(np.isinf(values[cps > 10]))
        best = int(np.argmin(values))
        # the problem's optimum is an optimum of the reference (ties allowed: interpolants)
        assert expected[best] == pytest.approx(expected.min(), rel=1e-9, abs=1e-9)


def test_exhaustive_paper_floor_prefers_fewest_control_points(ten_points, ten_point_fits):
    masks, fits = ten_point_fits
    dist = np.array([np.sqrt(f.sse) for f in fits])
    cps = np.array([f.n_cp for f in fits])
    scale, n = scale_of(ten_points.points), ten_points.n_points
    # a floor that some 6-control-point fits reach while 5 x (best 5-point distance) stays
    # above 6 x floor: the optimum is a 6-point fit at the floor (fewer points never reach it,
    # and 4-point splines are a subspace of every 5-point spline space)
    floor_level = float(dist[cps == 5].min()) / 1.25
    assert dist[cps == 6].min() < floor_level
    assert np.all(cps[dist < floor_level] >= 6)
    problem = KnotSelection(ten_points, objective="paper",
                            objective_options={"error_floor": floor_level / (scale * np.sqrt(n))})
    values = problem.evaluate(masks)
    assert cps[int(np.argmin(values))] == 6
    assert values.min() == pytest.approx(6 * floor_level, rel=1e-9)


# --------------------------------------------------------------------------------------------
# KnotIndices and FreeKnots
# --------------------------------------------------------------------------------------------


def test_knot_indices_values_and_sorting(noisy_spiral):
    problem = KnotIndices(noisy_spiral, n_knots=6, objective="paper",
                          objective_options={"error_floor": 0.0})
    assert problem.encoding.n_var == 6
    rng = np.random.default_rng(2)
    X = np.sort(np.stack([rng.choice(np.arange(1, 99), 6, replace=False) for _ in range(10)]),
                axis=1)
    u = problem.params
    fits = [reference_fit(u, problem.points, u[x]) for x in X]
    expected = ref_paper(fits, problem.points, 0.0)
    assert np.isfinite(expected).all()
    assert_values(problem.evaluate(X), expected)
    # a candidate is a set: any order gives the same value
    shuffled = rng.permuted(X, axis=1)
    assert (shuffled != X).any()
    np.testing.assert_allclose(problem.evaluate(shuffled), problem.evaluate(X), rtol=1e-12)
    reversed_ = X[:, ::-1]
    np.testing.assert_allclose(problem.evaluate(reversed_), problem.evaluate(X), rtol=1e-12)
    # decode sorts too
    sol = problem.decode(reversed_[0])
    np.testing.assert_allclose(sol.fit.interior_knots, u[X[0]], rtol=0, atol=0)


def test_knot_indices_duplicates_are_infeasible(noisy_spiral):
    problem = KnotIndices(noisy_spiral, n_knots=4, objective="bic")
    X = np.array([[10, 30, 50, 70], [10, 30, 30, 70], [70, 10, 70, 30], [5, 5, 5, 5]])
    values = problem.evaluate(X)
    assert np.isfinite(values[0])
    assert values[1:].tolist() == [np.inf, np.inf, np.inf]


def test_knot_indices_out_of_range_rejected(noisy_spiral):
    problem = KnotIndices(noisy_spiral, n_knots=3)
    for bad in ([0, 10, 20], [10, 20, 99], [10, 20, 2.5]):
        with pytest.raises(ValueError):
            problem.evaluate(np.array([bad]))


def test_free_knots_values(noisy_spiral):
    problem = FreeKnots(noisy_spiral, n_knots=5, objective="bic")
    rng = np.random.default_rng(4)
    X = np.sort(rng.uniform(0.05, 0.95, size=(12, 5)), axis=1)
    fits = [reference_fit(problem.params, problem.points, x) for x in X]
    expected = ref_bic(fits, problem.points)
    assert_values(problem.evaluate(X), expected, rtol=1e-7, atol=1e-6)
    np.testing.assert_allclose(problem.evaluate(X[:, ::-1]), problem.evaluate(X), rtol=1e-12)
    sol = problem.decode(X[3][::-1])
    np.testing.assert_allclose(sol.fit.spline.c, fits[3].spline.c, rtol=1e-7, atol=1e-9)


@pytest.mark.parametrize("closed", [False, True])
def test_max_deviation_is_the_largest_point_distance_of_the_least_squares_fit(noisy_spiral,
                                                                              closed):
    """The objective ``max_deviation`` against the largest distance of a point to the
    independent least-squares fit (open: make_lsq_spline; closed: the wrapped design matrix of
    :func:`tests.test_periodic.dense_reference`); infeasible: inf."""
    from tests.test_periodic import dense_reference

    problem = FreeKnots(noisy_spiral, n_knots=5, objective="max_deviation", closed=closed)
    rng = np.random.default_rng(11)
    X = np.sort(rng.uniform(0.05, 0.95, size=(8, 5)), axis=1)
    u, q = problem.params, problem.points
    expected = []
    for x in X:
        if closed:
            reference = dense_reference(u, q, x, DEGREE)
            assert reference is not None
            expected.append(reference[1])
        else:
            expected.append(np.linalg.norm(q - reference_fit(u, q, x).spline(u), axis=1).max())
    np.testing.assert_allclose(problem.evaluate(X), expected, rtol=1e-9)
    assert problem.objective.needs_max_deviation
    X[0, 2] = X[0, 1]  # coincident knots
    assert problem.evaluate(X[:1])[0] == np.inf


@pytest.mark.parametrize("objective", ["paper", "bic", "error_bounded", "max_deviation"])
def test_free_knots_bad_positions_give_inf_not_nan(noisy_spiral, objective):
    problem = FreeKnots(noisy_spiral, n_knots=3, objective=objective)
    u0, u1 = problem.params[0], problem.params[-1]
    X = np.array([
        [0.2, 0.5, 0.7],       # feasible
        [0.2, 0.5, 0.5],       # coincident
        [0.7, 0.2, 0.7],       # coincident after sorting
        [u0, 0.5, 0.7],        # on the lower end
        [0.2, 0.5, u1],        # on the upper end
        [-0.3, 0.5, 0.7],      # outside
        [0.2, 0.5, 1.7],       # outside
        [np.nan, 0.5, 0.7],    # NaN
        [0.2, np.nan, np.nan],
        [0.2, 0.5, np.inf],
        [-np.inf, 0.5, 0.7],
    ])
    values = problem.evaluate(X)
    assert values.shape == (X.shape[0],)
    assert not np.isnan(values).any()
    assert np.isfinite(values[0])
    assert np.all(values[1:] == np.inf)
    # the feasible row is not disturbed by its infeasible neighbours
    assert values[0] == pytest.approx(problem.evaluate(X[:1])[0], rel=1e-12)


def test_free_knots_schoenberg_whitney_violation(noisy_spiral):
    problem = FreeKnots(noisy_spiral, n_knots=5)
    u = problem.params
    # five knots squeezed between two neighbouring data parameters: a basis function has no
    # data point of its own
    squeezed = np.linspace(u[40], u[41], 7)[1:-1]
    ref = reference_fit(u, problem.points, squeezed)
    assert not ref.feasible
    assert problem.evaluate(squeezed[None])[0] == np.inf


# --------------------------------------------------------------------------------------------
# configuration errors
# --------------------------------------------------------------------------------------------


def test_unknown_objective():
    with pytest.raises(ValueError, match="objective 'aic'") as info:
        KnotSelection("archimedean", objective="aic")
    for name in ("paper", "bic", "error_bounded"):
        assert name in str(info.value)


def test_unknown_objective_option():
    with pytest.raises(ValueError, match="paper"):
        KnotSelection("archimedean", objective="paper", objective_options={"bogus": 1})


@pytest.mark.parametrize("tolerance", [0.0, -1.0, np.nan, np.inf])
def test_bad_tolerance(tolerance):
    with pytest.raises(ValueError, match="tolerance"):
        KnotSelection("archimedean", objective="error_bounded",
                      objective_options={"tolerance": tolerance})


@pytest.mark.parametrize("rel", [0.0, -0.1, np.nan])
def test_bad_relative_tolerance(rel):
    with pytest.raises(ValueError, match="relative_tolerance"):
        KnotSelection("archimedean", objective="error_bounded",
                      objective_options={"relative_tolerance": rel})


def test_bad_metric_and_error_floor():
    with pytest.raises(ValueError, match="metric"):
        KnotSelection("archimedean", objective="error_bounded",
                      objective_options={"metric": "mae"})
    for objective in ("paper", "bic"):
        for floor in (-1e-3, np.nan, np.inf):
            with pytest.raises(ValueError, match="error_floor"):
                KnotSelection("archimedean", objective=objective,
                              objective_options={"error_floor": floor})


@pytest.mark.parametrize("cls", [KnotIndices, FreeKnots])
@pytest.mark.parametrize("n_knots", [0, -2, 97, 500, True, 2.5, "3"])
def test_n_knots_out_of_range(cls, n_knots):
    # archimedean: 100 points, cubic: at most N - degree - 1 = 96 interior knots
    with pytest.raises(ValueError, match="n_knots"):
        cls("archimedean", n_knots=n_knots)


@pytest.mark.parametrize("cls", [KnotIndices, FreeKnots])
def test_n_knots_limits_accepted(cls):
    assert cls("archimedean", n_knots=1).encoding.n_var == 1
    assert cls("archimedean", n_knots=96).encoding.n_var == 96
    assert cls("archimedean", n_knots=98, degree=1).encoding.n_var == 98


@pytest.mark.parametrize("density", [-0.1, 1.5, np.nan])
def test_density_outside_unit_interval(density):
    with pytest.raises(ValueError, match="density"):
        KnotSelection("archimedean", density=density)


def test_density_controls_sampling():
    for density in (0.0, 0.2, 1.0):
        problem = KnotSelection("epitrochoid", density=density)
        X = problem.sample(np.random.default_rng(0), 50)
        assert X.shape == (50, 359)
        assert np.mean(X) == pytest.approx(density, abs=0.02)


@pytest.mark.parametrize("cls", [KnotSelection, KnotIndices, FreeKnots])
def test_unknown_curve_name(cls):
    with pytest.raises(ValueError, match="curve 'lemniscate'"):
        cls("lemniscate")


def test_problem_accepts_arrays_and_point_sets():
    pts = get_curve("archimedean").points
    a = KnotSelection(pts)
    b = KnotSelection(PointSet(pts))
    c = KnotSelection("archimedean")
    masks = a.sample(np.random.default_rng(1), 5)
    np.testing.assert_array_equal(a.evaluate(masks), b.evaluate(masks))
    np.testing.assert_array_equal(a.evaluate(masks), c.evaluate(masks))
    assert a.encoding.kind == "binary" and a.encoding.n_var == 98


@pytest.mark.parametrize("name", ["error_bounded", "pareto", "max_deviation"])
def test_an_objective_by_max_deviation_refuses_fits_without_it(name):
    """The objectives that read the maximum deviation say which objective needs it, with the
    same error, when a batch was fitted without it."""
    from metaknot.bspline.fit import BatchFit
    from metaknot.problems.objectives import DataInfo, get_objective

    objective = get_objective(name, **({} if name == "max_deviation"
                                       else {"metric": "max_deviation"}))
    fit = BatchFit(sse=np.ones(2), max_deviation=None, n_control_points=np.full(2, 5),
                   reason=np.zeros(2, dtype=np.int8))
    data = DataInfo(n_points=10, dim=2, scale=1.0, degree=3, extra_control_points=4)
    with pytest.raises(ValueError, match=f"^{name} by max_deviation needs fits with "
                                         "max_deviation$"):
        objective(fit, data)
