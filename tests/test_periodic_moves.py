"""Delta evaluation of knot moves on closed curves against the full periodic fit.

Every candidate scored by a :class:`PeriodicMoveEvaluator` must come back as
:meth:`ClosedCurve.evaluate_knots` (the periodic batched kernel) scores it: the same reason
code, the same control-point count, the same SSE to 1e-10 relative and the same maximum
deviation; the moves the delta path decided are also checked against scipy (dense least squares
on the wrapped design matrix). The tests check that the delta path did the work, and that it
refuses what its conditioning certificate cannot vouch for.
"""

from __future__ import annotations

import numpy as np
import pytest

import metaknot as mk
from metaknot.bspline import Infeasibility, closed_parameterize
from metaknot.bspline.curve import ClosedCurve, make_curve
from metaknot.bspline.moves import (
    PATH_CHECKS,
    PATH_DELTA,
    PATH_FULL,
    PeriodicMoveEvaluator,
    bit_flips,
)
from metaknot.problems import FreeKnots, KnotIndices, KnotSelection, get_curve
from tests.test_moves import assert_same_scores
from tests.test_periodic import dense_reference, outline


def seed_outline(name: str, n_points: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Parameters and points of a seed curve as a closed outline (its repeated point
    dropped)."""
    points = get_curve(name, **({} if n_points is None else {"n_points": n_points})).points
    curve = make_curve(points, closed=True)
    return curve.params, curve.points


def closed_curve(name: str) -> tuple[np.ndarray, np.ndarray]:
    if name in ("epitrochoid", "vivaldi"):
        return seed_outline(name)
    dim = {"star-1d": 1, "star-2d": 2, "star-3d": 3}[name]
    points = outline(140, dim, seed=dim)
    return closed_parameterize(points, "chord" if dim == 3 else "centripetal"), points


CURVES = ["epitrochoid", "vivaldi", "star-1d", "star-2d", "star-3d"]


def stack(rows: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    offsets = np.concatenate(([0], np.cumsum([len(r) for r in rows]))).astype(np.int64)
    knots = np.concatenate(rows) if rows else np.empty(0)
    return knots.astype(np.float64), offsets


def assert_same(me: PeriodicMoveEvaluator, knots: np.ndarray, offsets: np.ndarray,
                max_deviation: bool = True) -> np.ndarray:
    """Scores of the move evaluator equal the periodic batched kernel's; returns the paths."""
    fit, path = me.evaluate(knots, offsets, max_deviation=max_deviation)
    ref = ClosedCurve(me.u, me.q, me.degree).evaluate_knots(knots, offsets,
                                                            max_deviation=max_deviation)
    assert_same_scores(fit, ref, me.q, max_deviation)
    assert np.all(path[~ref.feasible] != PATH_DELTA)
    return path


def feasible_evaluator(u, q, degree, rng, density) -> tuple[PeriodicMoveEvaluator, np.ndarray]:
    """A move evaluator bound to a random feasible mask over ``u[1:]`` (re-drawn until the
    mask can be fitted)."""
    for _ in range(200):
        mask = rng.random(u.size - 1) < density
        try:
            return PeriodicMoveEvaluator(u, q, u[1:][mask], degree), mask
        except ValueError:
            continue
    raise AssertionError("no feasible mask found")


def one_bit_flips(mask: np.ndarray) -> np.ndarray:
    return np.repeat(mask[None], mask.size, axis=0) ^ np.eye(mask.size, dtype=bool)


def mask_rows(u: np.ndarray, masks: np.ndarray) -> list[np.ndarray]:
    return [u[1:][m] for m in masks]


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("name", CURVES)
def test_every_bit_flip_matches_the_full_periodic_fit(name, degree):
    u, q = closed_curve(name)
    rng = np.random.default_rng(degree)
    me, mask = feasible_evaluator(u, q, degree, rng, 0.3)
    flips = one_bit_flips(mask)
    path = assert_same(me, *stack(mask_rows(u, flips)))
    if degree <= 3:
        assert np.mean(path == PATH_DELTA) > 0.9, np.bincount(path)
    # the same moves given as replacements score the same, by the same paths
    by_moves, move_path = me.evaluate_replacements(
        *bit_flips(u, mask, np.arange(mask.size), closed=True), max_deviation=True)
    fit, _ = me.evaluate(*stack(mask_rows(u, flips)), max_deviation=True)
    np.testing.assert_array_equal(move_path, path)
    np.testing.assert_array_equal(by_moves.reason, fit.reason)
    np.testing.assert_allclose(by_moves.sse, fit.sse, rtol=1e-12)
    np.testing.assert_allclose(by_moves.max_deviation, fit.max_deviation, rtol=1e-12)


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
def test_the_delta_path_matches_scipy(degree):
    """Dense least squares on scipy's wrapped design matrix: the independent reference."""
    rng = np.random.default_rng(10 + degree)
    checked = 0
    for dim in (1, 2, 3):
        points = outline(90, dim, seed=degree)
        u = closed_parameterize(points, "centripetal")
        me, mask = feasible_evaluator(u, points, degree, rng, 0.35)
        flips = one_bit_flips(mask)[rng.choice(mask.size, 15, replace=False)]
        rows = mask_rows(u, flips)
        fit, path = me.evaluate(*stack(rows), max_deviation=True)
        for b in np.flatnonzero(path == PATH_DELTA):
            sse, max_dev = dense_reference(u, points, rows[b], degree)
            np.testing.assert_allclose(fit.sse[b], sse, rtol=1e-8)
            np.testing.assert_allclose(fit.max_deviation[b], max_dev, rtol=1e-8)
            checked += 1
    assert checked >= 25


@pytest.mark.parametrize("degree", [1, 3, 5])
@pytest.mark.parametrize("name", ["epitrochoid", "star-2d", "star-3d"])
def test_add_remove_and_shift_moves_everywhere_on_the_circle(name, degree):
    """Every knot removed, shifted either way and doubled, a knot added in every gap (the
    seam's included: before the first knot and after the last), and two neighbouring knots
    replaced by one: at the seam and at the second cut as anywhere else."""
    u, q = closed_curve(name)
    rng = np.random.default_rng(degree + 7)
    interior = np.sort(rng.choice(u[1:], 24, replace=False))
    me = PeriodicMoveEvaluator(u, q, interior, degree)
    bounds = np.concatenate(([0.0], interior, [1.0]))
    rows = []
    for j in range(interior.size):
        rows.append(np.delete(interior, j))  # remove
        for side in (-1, 1):  # shift a third of the way to a neighbour
            moved = interior.copy()
            moved[j] += (bounds[j + 1 + side] - interior[j]) / 3
            rows.append(moved)
        rows.append(np.sort(np.append(interior, (interior[j] + bounds[j + 2]) / 2)))  # add
        if j + 1 < interior.size:  # two for one
            merged = np.delete(interior, j + 1)
            merged[j] = (interior[j] + interior[j + 1]) / 2
            rows.append(merged)
    rows.append(np.sort(np.append(interior, interior[0] / 2)))  # added at the seam
    rows.append(interior.copy())  # the incumbent itself
    path = assert_same(me, *stack(rows))
    feasible = me.evaluate(*stack(rows))[0].feasible
    if degree <= 3:
        assert (path[feasible] == PATH_DELTA).all(), np.bincount(path)
    else:
        assert np.mean(path[feasible] == PATH_DELTA) > 0.5, np.bincount(path)


def test_infeasible_moves_get_the_batch_evaluators_reason():
    u, q = closed_curve("star-2d")
    interior = u[5::6].copy()
    me = PeriodicMoveEvaluator(u, q, interior, 3)
    gap = (u[20] + u[21]) / 2
    rows = [
        np.sort(np.append(interior, interior[2])),  # coincident with a knot
        np.sort(np.append(interior, 1.0)),  # on the period's end
        np.append(0.0, interior),  # on the seam's breakpoint
        np.sort(np.append(interior, -0.5)),  # outside
        np.sort(np.concatenate((interior, gap + 1e-9 * np.arange(6)))),  # no data inside
        u[1:].copy(),  # one control point per data point: feasible, interpolation
        np.concatenate((u[1:], [0.999999])),  # more control points than points
        interior[:1].copy(),  # fewer breakpoints than the degree
        np.concatenate((interior[:3], interior[4:], interior[3:4])),  # out of order
    ]
    fit, path = me.evaluate(*stack(rows))
    ref = ClosedCurve(u, q, 3).evaluate_knots(*stack(rows))
    np.testing.assert_array_equal(fit.reason, ref.reason)
    expected = {Infeasibility.COINCIDENT_KNOTS, Infeasibility.KNOT_OUT_OF_RANGE,
                Infeasibility.SINGULAR, Infeasibility.TOO_MANY_CONTROL_POINTS}
    assert expected <= {Infeasibility(r) for r in fit.reason}
    assert np.all(path[~ref.feasible] != PATH_DELTA)
    assert path[0] == path[1] == path[2] == path[3] == PATH_CHECKS
    assert ref.feasible[-1] and path[-1] == PATH_FULL  # sorted, as the batch evaluator does
    assert path[4] == PATH_FULL  # no data between the knots: the certificate refuses
    assert_same(me, *stack(rows))
    # not a number: out of range (as for the problems, which never pass NaN for "no knot")
    fit, path = me.evaluate(*stack([np.append(interior[:-1], np.nan)]))
    assert fit.reason[0] == Infeasibility.KNOT_OUT_OF_RANGE and path[0] == PATH_CHECKS


@pytest.mark.parametrize("degree", [3, 4, 5])
def test_near_singular_moves_are_refused_by_the_certificate(degree):
    # dense knots (50-90 % of the points) plus two or three more between neighbouring points
    # make many candidates singular or nearly so: a singular one must come back SINGULAR, as
    # from the full fit, and never as a delta-path fit
    u, q = seed_outline("epitrochoid", n_points=100)
    rng = np.random.default_rng(degree)
    paths, reasons = [], []
    for density in (0.5, 0.8, 0.9):
        mask = rng.random(u.size - 1) < density
        me = PeriodicMoveEvaluator(u, q, u[1:][mask], degree)
        rows = []
        for i in range(1, u.size - 2):
            for count in (2, 3):
                crowd = u[i] + (u[i + 1] - u[i]) * np.arange(1, count + 1) / (count + 1)
                rows.append(np.unique(np.concatenate((u[1:][mask], crowd))))
        path = assert_same(me, *stack(rows), max_deviation=False)
        ref = ClosedCurve(u, q, degree).evaluate_knots(*stack(rows), max_deviation=False)
        paths.append(path)
        reasons.append(ref.reason)
    paths, reasons = np.concatenate(paths), np.concatenate(reasons)
    singular = reasons == Infeasibility.SINGULAR
    assert np.all(paths[singular] == PATH_FULL)
    if degree <= 4:
        assert singular.any()
    # the certificate also refuses feasible candidates it cannot vouch for, and vouches for
    # most of the rest
    assert (paths[~singular] == PATH_FULL).any()
    assert (paths == PATH_DELTA).sum() > 150


def test_knots_crowded_between_two_points_are_refused_on_both_sides_of_the_seam():
    u, q = closed_curve("star-2d")
    interior = u[3::5].copy()
    me = PeriodicMoveEvaluator(u, q, interior, 3)
    rows = []
    for i in (1, 40, u.size - 2):  # after the seam, mid-circle, before the seam
        crowd = u[i] + (u[i + 1] - u[i]) * np.arange(1, 7) / 7  # a function without data
        rows.append(np.unique(np.concatenate((interior, crowd))))
    fit, path = me.evaluate(*stack(rows))
    ref = ClosedCurve(u, q, 3).evaluate_knots(*stack(rows))
    assert (ref.reason == Infeasibility.SINGULAR).all()
    np.testing.assert_array_equal(fit.reason, ref.reason)
    assert (path == PATH_FULL).all()


def test_rebind_moves_the_incumbent_and_the_incumbent_scores_itself():
    u, q = closed_curve("star-3d")
    rng = np.random.default_rng(5)
    me, mask = feasible_evaluator(u, q, 3, rng, 0.3)
    for _ in range(20):  # a random walk of accepted flips
        flips = one_bit_flips(mask)
        fit, _ = me.evaluate(*stack(mask_rows(u, flips)), max_deviation=False)
        mask = flips[rng.choice(np.flatnonzero(fit.feasible))]
        me.rebind(u[1:][mask])
        fit, path = me.evaluate(*stack(mask_rows(u, mask[None])), max_deviation=True)
        ref = ClosedCurve(u, q, 3).evaluate_positions(u[1:][mask][None, :], nan_is_absent=True)
        assert path[0] == PATH_DELTA
        np.testing.assert_allclose(fit.sse, ref.sse, rtol=1e-10)
        np.testing.assert_allclose(fit.max_deviation, ref.max_deviation, rtol=1e-10)
        np.testing.assert_allclose(me.sse, ref.sse[0], rtol=1e-10)
    assert_same(me, *stack(mask_rows(u, one_bit_flips(mask))))


def test_an_infeasible_incumbent_is_refused():
    u, q = closed_curve("star-2d")
    with pytest.raises(ValueError, match="incumbent cannot be fitted"):
        PeriodicMoveEvaluator(u, q, (u[20] + u[21]) / 2 + 1e-9 * np.arange(6), 3)
    with pytest.raises(ValueError, match="incumbent cannot be fitted"):
        PeriodicMoveEvaluator(u, q, np.linspace(0.001, 0.999, u.size + 3), 3)
    with pytest.raises(ValueError, match="distinct"):
        PeriodicMoveEvaluator(u, q, np.array([0.5, 0.5, 0.7]), 3)
    with pytest.raises(ValueError, match="1-D"):
        PeriodicMoveEvaluator(u, q, np.ones((2, 2)) * 0.5, 3)
    with pytest.raises(ValueError, match=r"\[0, 1\)"):
        PeriodicMoveEvaluator(u * 2, q, u[5::5], 3)
    with pytest.raises(ValueError, match="mask must have shape"):
        bit_flips(u, np.zeros(u.size - 2), [0], closed=True)


def test_wide_changes_fall_back_to_the_full_fit():
    u, q = closed_curve("star-2d")
    interior = u[4::5].copy()
    me = PeriodicMoveEvaluator(u, q, interior, 3, max_window_rows=40)
    near = interior.copy()
    near[5] += 1e-3
    wide = interior.copy()
    wide[3] += 1e-3
    wide[-4] -= 1e-3  # a change spanning more than half the circle: no cut holds it
    path = assert_same(me, *stack([near, wide]))
    assert list(path) == [PATH_DELTA, PATH_FULL]
    me = PeriodicMoveEvaluator(u, q, interior, 3, max_window_rows=3)
    assert list(assert_same(me, *stack([near]))) == [PATH_FULL]
    # too few breakpoints for the degree: no cut holds a change, every move is fitted in full
    few = u[10::14].copy()
    me = PeriodicMoveEvaluator(u, q, few, 5)
    assert me._cuts.size == 0
    rows = [np.delete(few, 3), np.sort(np.append(few, (few[4] + few[5]) / 2)), few]
    assert list(assert_same(me, *stack(rows))) == [PATH_FULL, PATH_FULL, PATH_DELTA]


def test_moves_near_interpolation_merge_rows_that_barely_reached_their_columns():
    """Near interpolation a frame's state holds rows that barely reached their column (huge
    reciprocal weights, entries to match) and fill-in that died out along the band; merged
    after the window's rows in the wrong order (the active rows before the wrap triangles),
    their products overflowed to NaN. Every removal of a knot from a knot at nearly every
    point."""
    q = get_curve("epitrochoid", n_points=120).points
    curve = make_curve(q, closed=True)
    interior = curve.params[1:-1].copy()
    me = PeriodicMoveEvaluator(curve.params, curve.points, interior, 3)
    path = assert_same(me, *stack([np.delete(interior, i) for i in range(interior.size)]))
    assert np.mean(path == PATH_DELTA) > 0.9


# --------------------------------------------------------------------------------------------
# in problems and runs

POINTS = get_curve("epitrochoid", n_points=120).points
PROBLEMS = {
    "mask-paper": lambda: KnotSelection(POINTS, objective="paper", closed=True),
    "mask-bounded-maxdev": lambda: KnotSelection(
        POINTS, objective="error_bounded", objective_options={"relative_tolerance": 1e-3},
        closed=True),
    "indices-bic": lambda: KnotIndices(POINTS, n_knots=20, objective="bic", closed=True),
    "free-variable": lambda: FreeKnots(POINTS, n_knots=20, variable_count=True, closed=True,
                                       objective="error_bounded",
                                       objective_options={"metric": "rmse"}),
}


@pytest.mark.parametrize("name", PROBLEMS)
def test_closed_problems_evaluate_moves_as_the_full_evaluation(name):
    from tests.test_delta_runs import assert_near_equals_full

    problem = PROBLEMS[name]()
    rng = np.random.default_rng(1)
    if problem.encoding.kind == "binary":
        x = (rng.random(problem.encoding.n_var) < 0.3).astype(np.int64)
    elif problem.encoding.kind == "integer":
        x = np.sort(rng.choice(np.arange(1, problem.last_candidate_point + 1), problem.n_knots,
                               replace=False))
        x[-1] = problem.last_candidate_point  # the last point, which only a closed curve has
    else:
        x = np.sort(rng.uniform(0.02, 0.98, problem.n_knots))
        x[-3:] = np.nan
    assert_near_equals_full(problem, x, rng)


@pytest.mark.parametrize("optimizer,budget", [("one_plus_one", 1500), ("local_search", 3000)])
def test_closed_runs_use_delta_evaluation_and_end_where_full_evaluation_ends(optimizer, budget):
    results = {}
    for delta in (True, False, True):
        problem = KnotSelection(POINTS, objective="paper", closed=True)
        problem.delta_evaluation = delta
        results.setdefault(delta, []).append(mk.minimize(problem, optimizer, budget=budget,
                                                         seed=4))
    fast, again, full = results[True][0], results[True][1], results[False][0]
    assert full.delta_evaluations == 0
    assert fast.delta_evaluations > 0.5 * fast.n_evaluations
    assert fast.status == "ok" and fast.audited_fits >= fast.n_evaluations
    assert fast.n_evaluations == full.n_evaluations
    np.testing.assert_allclose(fast.best_f, full.best_f, rtol=1e-9)
    np.testing.assert_array_equal(fast.best_x, full.best_x)
    np.testing.assert_allclose(fast.trace.best_f, full.trace.best_f, rtol=1e-9)
    # the same seed gives the same run
    assert again.best_f == fast.best_f and again.delta_evaluations == fast.delta_evaluations
    np.testing.assert_array_equal(again.best_x, fast.best_x)
    np.testing.assert_array_equal(again.trace.best_f, fast.trace.best_f)


def test_candidates_of_more_knots_than_points_are_reported_not_written_past() -> None:
    """More knots than data points, as whole candidates or as one replacement: reported as
    too many control points, as :meth:`ClosedCurve.evaluate_positions` reports them (the
    compiled loop gathered them into a workspace sized for the data and wrote past it)."""
    params, points = seed_outline("epitrochoid", 60)
    incumbent = params[[6, 14, 22, 30, 38, 46]]
    moves = PeriodicMoveEvaluator(params, points, incumbent)
    many = np.linspace(0.001, 0.999, 100 * params.size)
    batch, path = moves.evaluate(many, np.array([0, many.size]))
    assert batch.reason.tolist() == [Infeasibility.TOO_MANY_CONTROL_POINTS]
    assert path.tolist() == [PATH_CHECKS]
    curve = ClosedCurve(params, points, 3)
    full = curve.evaluate_positions(many[None, :], nan_is_absent=True)
    assert batch.reason.tolist() == full.reason.tolist()
    assert batch.n_control_points.tolist() == full.n_control_points.tolist()
    batch, _ = moves.evaluate_replacements([0], [incumbent.size], many, [0, many.size])
    assert batch.reason.tolist() == [Infeasibility.TOO_MANY_CONTROL_POINTS]
    # out of range before too many, as the batch evaluator decides
    bad = np.concatenate((many, [1.5]))
    batch, _ = moves.evaluate(bad, np.array([0, bad.size]))
    assert batch.reason.tolist() == [Infeasibility.KNOT_OUT_OF_RANGE]
    assert curve.evaluate_positions(bad[None, :], nan_is_absent=True).reason.tolist() == \
        [Infeasibility.KNOT_OUT_OF_RANGE]


def test_an_unsorted_incumbent_is_refused() -> None:
    """The incumbent's knots index the replacements: unsorted, a replacement removed another
    knot than the one named (and was scored singular), as the open evaluator refuses them."""
    params, points = seed_outline("epitrochoid", 60)
    incumbent = params[[6, 14, 22, 30, 38, 46]]
    with pytest.raises(ValueError, match="the incumbent cannot be fitted: coincident"):
        PeriodicMoveEvaluator(params, points, incumbent[::-1])
    moves = PeriodicMoveEvaluator(params, points, incumbent)
    with pytest.raises(ValueError, match="the incumbent cannot be fitted: coincident"):
        moves.rebind(incumbent[[1, 0, 2, 3, 4, 5]])
    assert np.array_equal(moves.interior, incumbent)
