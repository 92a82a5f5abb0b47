"""Interior knots of multiplicity 1 to the degree: the compiled fits of open curves against
scipy's ``make_lsq_spline`` (which takes repeated knots), those of closed curves against the
wrapped design matrix of scipy's B-splines, the Schoenberg-Whitney test against a maximum
bipartite matching, and the refusals of a knot repeated more often than allowed."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.interpolate import BSpline, make_lsq_spline
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import maximum_bipartite_matching

from metaknot.bspline import Infeasibility, closed_parameterize
from metaknot.bspline.curve import ClosedCurve, OpenCurve


def wavy(n: int, dim: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Parameters with uneven spacing in [0, 1] and a noisy curve with a kink at 0.45."""
    rng = np.random.default_rng(seed)
    u = np.concatenate(([0.0], np.sort(rng.uniform(0.0, 1.0, n - 2)), [1.0]))
    columns = [np.abs(u - 0.45), np.sin(5 * u), np.cos(3 * u) * u]
    return u, np.column_stack(columns)[:, :dim] + rng.normal(0.0, 1e-3, (n, 3))[:, :dim]


def with_multiple_knot(degree: int, multiplicity: int) -> np.ndarray:
    """Interior knots around a knot of the given multiplicity at 0.45 (sorted)."""
    return np.sort(np.concatenate(([0.2, 0.7, 0.85], np.full(multiplicity, 0.45))))


CASES = [(p, m) for p in range(1, 6) for m in range(1, p + 1)]


@pytest.mark.parametrize(("degree", "multiplicity"), CASES)
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_open_fits_with_a_multiple_knot_match_make_lsq_spline(degree, multiplicity, dim):
    u, points = wavy(80, dim, seed=degree * 10 + multiplicity)
    interior = with_multiple_knot(degree, multiplicity)
    curve = OpenCurve(u, points, degree)
    t = np.concatenate((np.zeros(degree + 1), interior, np.ones(degree + 1)))
    reference = make_lsq_spline(u, points, t, k=degree)
    residual = points - reference(u)
    sse = float((residual**2).sum())

    fitted = curve.fit(interior, max_multiplicity=multiplicity)
    np.testing.assert_array_equal(fitted.spline.t, t)
    np.testing.assert_allclose(fitted.spline.c, reference.c, rtol=0, atol=1e-9)
    batch = curve.evaluate_positions(np.tile(interior, (20, 1)),  # the threaded batch too
                                     max_multiplicity=multiplicity)
    serial = curve.evaluate_positions(interior[None, :], max_multiplicity=multiplicity)
    for fit in (batch, serial):
        assert (fit.reason == Infeasibility.FEASIBLE).all()
        np.testing.assert_allclose(fit.sse, sse, rtol=1e-9)
        np.testing.assert_allclose(fit.max_deviation,
                                   np.linalg.norm(residual, axis=1).max(), rtol=1e-8)
    assert fit.n_control_points[0] == interior.size + degree + 1


def test_a_corner_is_reproduced_by_a_knot_of_multiplicity_p():
    """|u - 0.45| is a cubic spline with a triple knot at 0.45: fitted exactly, and not with
    a double knot."""
    u = np.linspace(0.0, 1.0, 101)
    points = np.abs(u - 0.45)[:, None]
    curve = OpenCurve(u, points, 3)
    rows = np.array([[0.45, 0.45, 0.45], [0.44, 0.45, 0.45]])
    fit = curve.evaluate_positions(rows, max_multiplicity=3)
    assert fit.sse[0] < 1e-24 < fit.sse[1]


def wrapped_reference(u, points, interior, degree):
    """SSE of the periodic least-squares fit with breakpoints 0 and ``interior`` (repeats
    allowed), from the extended knot vector written out here and scipy's design matrix with
    the last ``degree`` columns folded onto the first."""
    breaks = np.concatenate(([0.0], np.sort(interior)))
    m = breaks.size
    t = np.concatenate((breaks[m - degree:] - 1.0, breaks, [1.0],
                        np.concatenate((breaks, [1.0]))[1: degree + 1] + 1.0))
    full = BSpline.design_matrix(u, t, degree).toarray()
    wrapped = full[:, :m].copy()
    wrapped[:, :degree] += full[:, m:]
    coef, *_ = np.linalg.lstsq(wrapped, points, rcond=None)
    return float(((points - wrapped @ coef) ** 2).sum())


@pytest.mark.parametrize(("degree", "multiplicity"), CASES)
def test_closed_fits_with_a_multiple_breakpoint_match_the_wrapped_design_matrix(degree,
                                                                               multiplicity):
    angle = np.linspace(0.0, 2 * np.pi, 90, endpoint=False)
    points = np.column_stack((np.cos(angle) * (1 + 0.2 * np.sign(np.sin(3 * angle))),
                              np.sin(angle)))
    u = closed_parameterize(points)
    interior = np.sort(np.concatenate(([0.15, 0.3, 0.8], np.full(multiplicity, 0.55))))
    curve = ClosedCurve(u, points, degree)
    expected = wrapped_reference(u, points, interior, degree)
    for rows in (interior[None, :], np.tile(interior, (20, 1))):
        fit = curve.evaluate_positions(rows, max_multiplicity=multiplicity)
        assert (fit.reason == Infeasibility.FEASIBLE).all()
        np.testing.assert_allclose(fit.sse, expected, rtol=1e-9)
    fitted = curve.fit(interior, max_multiplicity=multiplicity)
    np.testing.assert_allclose((fitted.residuals ** 2).sum(), expected, rtol=1e-9)
    assert fitted.n_control_points == interior.size + 1


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
def test_a_knot_repeated_more_often_than_allowed_is_infeasible(closed):
    u, points = wavy(60, 2)
    curve = OpenCurve(u, points, 3)
    if closed:
        points = points[:, :2] + np.column_stack((np.cos(6 * u), np.sin(6 * u)))
        curve = ClosedCurve(closed_parameterize(points), points, 3)
    double = [[0.2, 0.5, 0.5, 0.8]]
    quadruple = [[0.2, 0.5, 0.5, 0.5, 0.5]]
    for rows, allowed, reason in ((double, 1, Infeasibility.COINCIDENT_KNOTS),
                                  (double, 2, Infeasibility.FEASIBLE),
                                  (quadruple, 3, Infeasibility.COINCIDENT_KNOTS)):
        for batch in (np.array(rows), np.repeat(rows, 20, axis=0)):
            fit = curve.evaluate_positions(batch, max_multiplicity=allowed)
            assert (fit.reason == reason).all(), (rows, allowed, fit.reason)
            assert np.isfinite(fit.sse).all() == (reason == Infeasibility.FEASIBLE)
    with pytest.raises(ValueError, match=r"coincident|distinct"):
        curve.fit(double[0])
    with pytest.raises(ValueError, match="repeated"):
        curve.fit(quadruple[0], max_multiplicity=3)
    for bad in (0, 4, 1.5, "2"):
        with pytest.raises(ValueError, match="max_multiplicity must be an integer from 1 to "
                                             r"the degree \(3\)"):
            curve.evaluate_positions(np.array(double), max_multiplicity=bad)


def matching_exists(u, t, degree):
    """Whether every B-spline on ``t`` has a data parameter of its own at which it is
    nonzero (a perfect matching of basis functions to data: Schoenberg-Whitney)."""
    nonzero = csr_matrix(BSpline.design_matrix(u, t, degree).toarray().T > 1e-14)
    matching = maximum_bipartite_matching(nonzero, perm_type="column")
    return bool((matching >= 0).all())


@pytest.mark.parametrize("degree", [1, 2, 3, 4])
def test_schoenberg_whitney_with_multiple_knots_as_a_bipartite_matching_says(degree):
    """Few data on a grid and knots on the grid (so data sit on multiple knots): the
    kernel's greedy test agrees with a maximum matching on scipy's basis values, and both
    answers occur."""
    rng = np.random.default_rng(degree)
    grid = np.linspace(0.0, 1.0, 13)
    seen = set()
    for _ in range(300):
        u = np.sort(rng.choice(grid, rng.integers(degree + 3, 12), replace=False))
        u[0], u[-1] = 0.0, 1.0
        u = np.unique(u)
        sites = rng.choice(grid[1:-1], rng.integers(1, 4), replace=False)
        interior = np.sort(np.repeat(sites, rng.integers(1, degree + 1, sites.size)))
        if u.size < interior.size + degree + 1:
            continue
        t = np.concatenate((np.zeros(degree + 1), interior, np.ones(degree + 1)))
        points = rng.normal(size=(u.size, 2))
        reason = OpenCurve(u, points, degree).evaluate_positions(
            interior[None, :], max_multiplicity=degree).reason[0]
        expected = matching_exists(u, t, degree)
        if expected:  # feasible, unless the system is too ill-conditioned to trust
            assert reason in (Infeasibility.FEASIBLE, Infeasibility.SINGULAR), (u, interior)
        else:
            assert reason == Infeasibility.SCHOENBERG_WHITNEY, (u, interior, reason)
        seen.add((expected, reason))
    assert {(True, Infeasibility.FEASIBLE), (False, Infeasibility.SCHOENBERG_WHITNEY)} <= seen


def merged_by_hand(row: np.ndarray, spacing: float) -> np.ndarray:
    """The merge of one sorted row, written as a loop over groups."""
    out, start = [], 0
    for k in range(1, row.size + 1):
        if k == row.size or not row[k] - row[start] < spacing:
            out += [row[start:k].mean()] * (k - start)
            start = k
    return np.array(out)


def test_merging_close_knots_matches_a_loop_over_groups():
    from metaknot.problems.knot_problems import merge_close_knots

    rng = np.random.default_rng(4)
    rows = np.sort(rng.choice(np.linspace(0.1, 0.9, 9), (200, 7))
                   + rng.uniform(-1e-3, 1e-3, (200, 7)), axis=1)
    rows[::7, -2:] = np.nan  # absent knots (variable_count) stay absent
    for spacing in (0.0, 5e-4, 2e-3, 0.15):
        merged = merge_close_knots(rows, spacing)
        for row, got in zip(rows, merged, strict=True):
            present = ~np.isnan(row)
            np.testing.assert_array_equal(got[present], merged_by_hand(row[present], spacing))
            assert np.isnan(got[~present]).all()
    assert (merge_close_knots(rows, 2e-3) != rows)[~np.isnan(rows)].any()
    np.testing.assert_array_equal(merge_close_knots(rows[0], 2e-3),
                                  merge_close_knots(rows[:1], 2e-3)[0])


def kang_problem(**options):
    from metaknot.problems import FreeKnots
    from metaknot.suite import get_instance

    return FreeKnots(get_instance("kang_spline").point_set(), n_knots=11, objective="rmse",
                     **options)


def test_free_knots_with_merge_spacing_recover_kangs_double_knot():
    """Kang et al.'s cubic has a double knot at 0.5408: with ``merge_spacing`` its knots (the
    double one given twice, or as two knots 1e-9 apart) reproduce the data; without it two
    equal knots are infeasible."""
    from metaknot.suite.functions import KANG_KNOTS

    exact = np.array(KANG_KNOTS)
    apart = exact.copy()
    apart[6:8] += [-5e-10, 5e-10]  # merged at their mean, 0.5408
    merging = kang_problem(merge_spacing=1e-6)
    values = merging.evaluate(np.array([exact, apart]))
    assert (values < 1e-9).all()
    plain = kang_problem()
    assert plain.evaluate(exact[None, :])[0] == np.inf
    solution = merging.decode(apart)
    assert np.count_nonzero(np.isclose(solution.fit.spline.t, 0.5408, atol=1e-8)) == 2
    assert solution.fit.n_control_points == 15
    assert merging.describe()["merge_spacing"] == 1e-6 and "merge_spacing" not in \
        plain.describe()
    # local moves near a double knot: delta evaluation, the values of evaluate
    moved = np.array([apart, np.where(np.arange(11) == 3, 0.3, apart)])
    near_values, _, delta = merging.evaluate_near(moved, apart)
    np.testing.assert_allclose(near_values, merging.evaluate(moved), rtol=1e-9, atol=1e-12)
    assert np.all(delta)


@pytest.mark.parametrize("bad", [-1e-3, np.inf, np.nan, "0.1", True])
def test_a_bad_merge_spacing_is_named(bad):
    with pytest.raises(ValueError, match="merge_spacing must be a number >= 0 or None"):
        kang_problem(merge_spacing=bad)


def test_a_mask_of_multiplicities_places_a_corner():
    """KnotSelection with max_multiplicity: each interior point's value is the multiplicity
    of a knot there; the values are those of the knots repeated, fitted as free knots are,
    and a triple knot at the corner of |x - 0.45| reproduces it."""
    from metaknot.problems import FreeKnots, KnotSelection, PointSet

    x = np.linspace(0.0, 1.0, 41)
    data = PointSet(np.column_stack((x, np.abs(x - 0.45))), "corner", params=x)
    masks = KnotSelection(data, max_multiplicity=3, objective="rmse")
    assert masks.encoding.kind == "integer" and masks.encoding.upper.max() == 3
    rng = np.random.default_rng(0)
    X = rng.integers(0, 4, (40, masks.encoding.n_var)) * (rng.random((40, 39)) < 0.15)
    X[0] = 0
    X[0, 17] = 3  # x[18] = 0.45
    values = masks.evaluate(X)
    assert values[0] < 1e-12
    for row, value in zip(X, values, strict=True):
        knots = np.repeat(x[1:-1], row)
        free = FreeKnots(data, n_knots=max(knots.size, 1), objective="rmse", merge_spacing=0.0)
        expected = free.evaluate(knots[None, :])[0] if knots.size else \
            KnotSelection(data, objective="rmse").evaluate(np.zeros((1, 39)))[0]
        assert value == pytest.approx(expected, rel=1e-12, abs=1e-15)
    assert np.isfinite(values).sum() > 20
    assert masks.decode(X[0]).fit.n_control_points == 3 + 4
    binary = KnotSelection(data, objective="rmse")
    assert binary.encoding.kind == "binary" and "max_multiplicity" not in binary.describe()
    with pytest.raises(ValueError, match="must lie in"):
        binary.evaluate(X[:1])
    with pytest.raises(ValueError, match="max_multiplicity must be an integer from 1"):
        KnotSelection(data, max_multiplicity=4)


@pytest.mark.parametrize("optimizer", ["one_plus_one", "local_search"])
def test_a_search_over_multiplicities_places_knots_at_the_corners(optimizer):
    """(1+1) and the local search on a curve with corners at 0.45 and 0.8 (201 points, noise
    1e-4, BIC): with multiplicities each ends with a multiple knot at a corner and a better
    BIC than on 0/1 masks, the same seed and budget."""
    import metaknot as mk
    from metaknot.problems import PointSet

    x = np.linspace(0.0, 1.0, 201)
    y = np.abs(x - 0.45) + 0.3 * np.abs(x - 0.8) \
        + np.random.default_rng(0).normal(0.0, 1e-4, x.size)
    data = PointSet(np.column_stack((x, y)), "corners", params=x)
    from metaknot.problems import KnotSelection

    found = {}
    for multiplicity in (1, 3):
        problem = KnotSelection(data, max_multiplicity=multiplicity, objective="bic")
        found[multiplicity] = mk.minimize(problem, optimizer, budget=3000, seed=0)
    assert found[3].best_f < found[1].best_f - 20
    counts = np.asarray(found[3].best_x)
    assert counts.max() >= 2 and set(x[1:-1][counts >= 2]) & {x[90], x[160]}


@pytest.mark.parametrize("max_multiplicity", [1, 2, 3])
def test_local_search_moves_on_a_mask_of_multiplicities(max_multiplicity):
    """The local search's neighbours of a mask of multiplicities are exactly: one knot's
    multiplicity lowered by one, a simple knot inserted at the middle of an empty span, all
    copies of a knot shifted by 1..max_step onto an empty point, one knot raised by one below
    the largest multiplicity; each once (on 0/1 masks the moves of before)."""
    from metaknot.algorithms.local_search import mask_neighbours

    rng = np.random.default_rng(max_multiplicity)
    for _ in range(30):
        mask = rng.integers(0, max_multiplicity + 1, 14) * (rng.random(14) < 0.4)
        on = np.flatnonzero(mask)
        expected = set()
        for i in on:
            y = mask.copy()
            y[i] -= 1
            expected.add(tuple(y))
            if mask[i] < max_multiplicity:
                y = mask.copy()
                y[i] += 1
                expected.add(tuple(y))
            for target in (i - 2, i - 1, i + 1, i + 2):
                if 0 <= target < mask.size and mask[target] == 0:
                    y = mask.copy()
                    y[target], y[i] = mask[i], 0
                    expected.add(tuple(y))
        bounds = [-1, *on.tolist(), mask.size]
        for left, right in itertools.pairwise(bounds):
            if right - left >= 2:
                y = mask.copy()
                y[(left + right) // 2] = 1
                expected.add(tuple(y))
        moves = mask_neighbours(mask, 2, ordered=False, max_multiplicity=max_multiplicity)
        assert len(moves) == len(expected) == len({tuple(row) for row in moves})
        assert {tuple(row) for row in moves} == expected
        ordered = mask_neighbours(mask, 2, max_multiplicity=max_multiplicity)
        assert [tuple(row) for row in ordered] == sorted(expected)


def test_index_moves_may_raise_a_multiplicity_when_allowed():
    """Shifts of an index set onto an index that holds a knot: refused for distinct knots,
    allowed while that index holds fewer than ``max_multiplicity`` knots."""
    from metaknot.algorithms.local_search import index_neighbours

    x = np.array([3, 4, 4, 9])
    distinct = {tuple(row) for row in index_neighbours(np.array([3, 4, 9]), 1, 12, 1)}
    assert distinct == {(2, 4, 9), (3, 5, 9), (3, 4, 8), (3, 4, 10)}
    double = {tuple(row) for row in index_neighbours(x, 1, 12, 1, max_multiplicity=2)}
    assert double == {(2, 4, 4, 9), (3, 3, 4, 9), (3, 4, 5, 9), (3, 4, 4, 8), (3, 4, 4, 10)}
    triple = {tuple(row) for row in index_neighbours(x, 1, 12, 1, max_multiplicity=3)}
    assert triple == double | {(4, 4, 4, 9)}


def test_count_baselines_scan_the_knot_count_on_a_mask_of_multiplicities():
    """The averaging baseline on a mask of multiplicities scans K as on a 0/1 mask (simple
    knots at the same points: the same values); it asked a fixed K of it and failed."""
    import metaknot as mk
    from metaknot.problems import KnotSelection, PointSet

    x = np.linspace(0.0, 1.0, 41)
    data = PointSet(np.column_stack((x, np.abs(x - 0.45))), "corner", params=x)
    runs = {m: mk.minimize(KnotSelection(data, max_multiplicity=m, objective="bic"),
                           "averaging", budget=200, seed=0) for m in (1, 3)}
    assert runs[3].n_evaluations == runs[1].n_evaluations == 37  # K = 1..N - p - 1
    assert runs[3].best_f == runs[1].best_f
    assert np.array_equal(np.asarray(runs[3].best_x), np.asarray(runs[1].best_x))


@pytest.mark.parametrize("optimizer", ["nevergrad", "nevergrad:DiscreteOnePlusOne", "pymoo",
                                       "pymoo:DE"])
def test_adapters_start_a_mask_of_multiplicities_where_a_mask_starts(optimizer):
    """nevergrad and pymoo on a mask of multiplicities (a corner, 101 points, BIC): their first
    candidates are 0/1 masks (nevergrad's box centre and pymoo's uniform integers put a multiple
    knot at most points: no feasible candidate in 1,000 evaluations), so they find a finite
    BIC as on the 0/1 mask, and may place a multiple knot."""
    import metaknot as mk
    from metaknot.problems import KnotSelection, PointSet

    x = np.linspace(0.0, 1.0, 101)
    y = np.abs(x - 0.45) + np.random.default_rng(0).normal(0.0, 1e-4, x.size)
    data = PointSet(np.column_stack((x, y)), "corner", params=x)
    binary = mk.minimize(KnotSelection(data, objective="bic"), optimizer, budget=1000, seed=0)
    counts = mk.minimize(KnotSelection(data, max_multiplicity=2, objective="bic"), optimizer,
                         budget=1000, seed=0)
    assert np.isfinite(counts.best_f) and counts.best_f < binary.best_f + 400
    assert set(np.unique(np.asarray(counts.best_x))) <= {0, 1, 2}


def test_index_sets_with_repeats_are_multiple_knots_when_allowed():
    """KnotIndices with max_multiplicity: an index repeated is a multiple knot at that data
    point, fitted as the same knots are by a mask of multiplicities; by default a repeat is
    infeasible, as before."""
    from metaknot.problems import KnotIndices, KnotSelection, PointSet

    x = np.linspace(0.0, 1.0, 41)
    data = PointSet(np.column_stack((x, np.abs(x - 0.45))), "corner", params=x)
    indices = KnotIndices(data, n_knots=4, max_multiplicity=3, objective="rmse")
    assert indices.encoding.kind == "integer" and not indices.encoding.distinct_sorted
    rows = np.array([[18, 18, 18, 30], [30, 18, 18, 5], [18, 18, 18, 18], [5, 12, 18, 30]])
    values = indices.evaluate(rows)
    masks = KnotSelection(data, max_multiplicity=3, objective="rmse")
    for row, value in zip(rows, values, strict=True):
        counts = np.bincount(row - 1, minlength=39)
        expected = masks.evaluate(counts[None, :])[0] if counts.max() <= 3 else np.inf
        assert value == pytest.approx(expected, rel=1e-12, abs=1e-15)
    assert values[0] < 1e-12 and values[2] == np.inf  # a corner; four copies refused
    assert indices.decode(rows[1]).fit.n_control_points == 4 + 4
    plain = KnotIndices(data, n_knots=4, objective="rmse")
    assert plain.evaluate(rows[:1])[0] == np.inf and plain.encoding.distinct_sorted
    assert "max_multiplicity" not in plain.describe() and \
        indices.describe()["max_multiplicity"] == 3


def count_moves(rng: np.random.Generator, counts: np.ndarray, most: int, sites: int
                ) -> np.ndarray:
    """Multiplicity vectors that set one site's count to each of ``0 .. most + 1`` (one more
    than allowed: refused), at ``sites`` random sites."""
    rows = []
    for site in rng.choice(counts.size, sites, replace=False):
        for value in range(most + 2):
            moved = counts.copy()
            moved[site] = value
            rows.append(moved)
    return np.array(rows)


@pytest.mark.parametrize("closed", [False, True])
@pytest.mark.parametrize("degree", [2, 3, 4, 5])  # degree 1: knots are distinct
def test_moves_that_raise_or_lower_a_multiplicity_score_as_the_batched_evaluator(closed, degree):
    """Delta evaluation of multiplicity moves (a knot's count raised or lowered by any amount,
    one more than allowed included) against the batched evaluator with the same
    ``max_multiplicity``: same reasons, SSE, control points and maximum deviation; most
    feasible candidates decided by the delta path (fewer at degrees 4-5, where the certificate
    gives up on every move of an incumbent whose multiple knots make its bound large)."""
    from metaknot.bspline.moves import PATH_DELTA, MoveEvaluator, PeriodicMoveEvaluator
    from tests.test_moves import assert_same_scores

    rng = np.random.default_rng(degree + 10 * closed)
    decided = np.zeros(2, dtype=np.int64)  # feasible candidates: by the delta path, in all
    for dim in (1, 2, 3):
        u, points = wavy(150, dim, seed=dim)
        if closed:
            u = np.linspace(0.0, 1.0, 150, endpoint=False)
            points = np.column_stack([np.cos(2 * np.pi * u), np.sin(2 * np.pi * u),
                                      np.abs(u - 0.45)])[:, :dim] \
                + rng.normal(0.0, 1e-3, (u.size, dim))
        sites = u[1:] if closed else u[1:-1]
        curve = (ClosedCurve if closed else OpenCurve)(u, points, degree)
        evaluator = PeriodicMoveEvaluator if closed else MoveEvaluator
        for most in range(2, degree + 1):
            for _ in range(100):  # an incumbent that can be fitted
                counts = np.where(rng.random(sites.size) < 0.24 / degree,
                                  rng.integers(1, most + 1, sites.size), 0)
                try:
                    moves = evaluator(u, points, np.repeat(sites, counts), degree,
                                      max_multiplicity=most)
                    break
                except ValueError:
                    continue
            rows = [np.repeat(sites, c) for c in count_moves(rng, counts, most, 25)]
            offsets = np.cumsum([0] + [r.size for r in rows]).astype(np.int64)
            knots = np.concatenate(rows)
            fit, path = moves.evaluate(knots, offsets, max_deviation=True)
            reference = curve.evaluate_knots(knots, offsets, max_deviation=True,
                                             max_multiplicity=most)
            assert_same_scores(fit, reference, moves.q, True)
            assert (reference.reason == Infeasibility.COINCIDENT_KNOTS).sum() >= 25
            feasible = reference.reason == Infeasibility.FEASIBLE
            # the certificate is cautious with high multiplicities of degree 4-5 (about half)
            decided += [np.count_nonzero(path[feasible] == PATH_DELTA), feasible.sum()]
    assert decided[0] > (0.5 if degree <= 3 else 0.2) * decided[1], decided


def test_a_move_evaluator_refuses_an_incumbent_beyond_its_multiplicity():
    from metaknot.bspline.moves import MoveEvaluator, PeriodicMoveEvaluator

    u, points = wavy(80, 2)
    knots = with_multiple_knot(3, 2)
    MoveEvaluator(u, points, knots, 3, max_multiplicity=2)  # allowed
    for evaluator in (MoveEvaluator, PeriodicMoveEvaluator):
        with pytest.raises(ValueError, match=r"repeat|distinct|coincident"):
            evaluator(u if evaluator is MoveEvaluator else u[:-1],
                      points if evaluator is MoveEvaluator else points[:-1], knots, 3)


@pytest.mark.parametrize("closed", [False, True])
@pytest.mark.parametrize(("encoding", "optimizer"), [("mask", "one_plus_one"),
                                                      ("indices", "one_plus_one")])
def test_runs_over_multiplicities_use_delta_evaluation_and_score_as_full_evaluation(
        closed, encoding, optimizer):
    """A search over knots of multiplicity up to 3 scores its moves by delta evaluation (most
    of them), and every candidate it scored has the value a full fit gives it.

    The run is not compared step for step with a run fitting every candidate in full: ties are
    common (on index sets a child whose moved indices swap places is its parent's knot set),
    and a tie is decided by the last bit of two values computed along different paths."""
    import metaknot as mk
    from metaknot.problems import KnotIndices, KnotSelection

    _, points = wavy(160, 2, seed=3)
    if closed:
        points = points[:-1]

    def make(delta: bool):
        problem = KnotSelection(points, objective="bic", max_multiplicity=3, closed=closed) \
            if encoding == "mask" else \
            KnotIndices(points, objective="bic", n_knots=12, max_multiplicity=3, closed=closed)
        problem.delta_evaluation = delta
        return problem

    problem, scored = make(True), []
    evaluate_near = problem.evaluate_near

    def recording(X, near):
        values, metrics, delta = evaluate_near(X, near)
        scored.append((X.copy(), values.copy()))
        return values, metrics, delta

    problem.evaluate_near = recording
    fast = mk.minimize(problem, optimizer, budget=1500, seed=2)
    assert fast.n_evaluations == 1500
    assert fast.delta_evaluations > 0.5 * fast.n_evaluations
    X = np.concatenate([x for x, _ in scored])
    assert len(X) >= 0.5 * fast.n_evaluations
    full_problem = make(False)
    np.testing.assert_allclose(np.concatenate([f for _, f in scored]),
                               full_problem.evaluate(X), rtol=1e-9)
    np.testing.assert_allclose(fast.best_f, full_problem.evaluate(fast.best_x[None])[0],
                               rtol=1e-9)
    full = mk.minimize(full_problem, optimizer, budget=200, seed=2)
    assert full.delta_evaluations == 0
