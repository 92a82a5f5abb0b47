"""The curve model: open and closed curves behind one interface, and the one rule of closedness."""

from __future__ import annotations

import numpy as np
import pytest

from metaknot.bspline import closed_parameterize, fit_spline, parameterize
from metaknot.bspline.curve import ClosedCurve, OpenCurve, closure, make_curve
from metaknot.bspline.moves import MoveEvaluator, PeriodicMoveEvaluator
from metaknot.problems import get_curve


def polygon(n: int, gap: float = 0.0) -> np.ndarray:
    """``n`` points around a circle, the last ``gap`` of the turn left open."""
    angle = np.linspace(0, 2 * np.pi * (1 - gap), n, endpoint=gap > 0)
    return np.column_stack((np.cos(angle), np.sin(angle)))


def test_closure_by_the_closing_chord_in_point_spacings():
    ring = polygon(60)  # chord = one spacing
    found = closure(ring)
    assert found.closed and not found.repeats_first
    assert found.chord_spacings == pytest.approx(1.0, rel=1e-9)
    again = closure(np.vstack((ring, ring[:1])))
    assert again.closed and again.repeats_first and again.chord_spacings == 0
    assert closure(np.vstack((ring, ring[:1] + 1e-9))).repeats_first
    assert closure(polygon(60, gap=0.03)).closed  # a gap of about 2 spacings
    assert not closure(polygon(60, gap=0.2)).closed  # a "C": about 12 spacings
    assert not closure(get_curve("archimedean").points).closed
    assert closure(get_curve("epitrochoid").points).repeats_first
    assert not closure(ring[:3]).closed  # too few points to tell
    # values of one coordinate end near where they started, yet trace no outline
    values = np.sin(np.linspace(0, 3, 50))
    assert np.abs(values[-1] - values[0]) < 2.5 * np.abs(np.diff(values)).max()
    assert not closure(values).closed and not closure(values[:, None]).closed


def test_closure_reads_the_seam_step_as_a_spacing():
    """An outline sampled densely along its sides but with its widest step at the seam (as
    glyph outlines resampled per segment are) is closed, not an open curve with a gap."""
    angle = np.concatenate((np.linspace(0.0, 2 * np.pi - 0.3, 200), [2 * np.pi - 0.15]))
    outline = np.column_stack((np.cos(angle), np.sin(angle)))
    steps = np.linalg.norm(np.diff(outline, axis=0), axis=1)
    chord = np.linalg.norm(outline[-1] - outline[0])
    assert chord > 2.5 * np.median(steps)  # by the median step alone it would look open
    assert closure(outline).closed


def test_open_and_closed_curves_fit_as_the_kernels_do():
    spiral = get_curve("archimedean", n_points=80).points
    open_curve = make_curve(spiral, degree=3)
    assert isinstance(open_curve, OpenCurve) and not open_curve.closed
    u = parameterize(spiral, "centripetal")
    np.testing.assert_array_equal(open_curve.params, u)
    masks = np.random.default_rng(0).random((6, 78)) < 0.3
    np.testing.assert_array_equal(open_curve.evaluate_masks(masks).sse,
                                  OpenCurve(u, spiral, 3).evaluate_masks(masks).sse)
    knots = u[[10, 30, 50]]
    np.testing.assert_array_equal(open_curve.fit(knots).spline.c,
                                  fit_spline(u, spiral, knots).spline.c)
    assert (open_curve.extra_control_points, open_curve.max_interior_knots,
            open_curve.max_index, open_curve.knot_bounds) == (4, 76, 78, (u[0], u[-1]))

    outline = get_curve("epitrochoid", n_points=90).points  # its last point repeats the first
    closed_curve = make_curve(outline, degree=3, closed=True)
    assert isinstance(closed_curve, ClosedCurve) and closed_curve.n_points == 89
    w = closed_parameterize(outline[:-1])
    np.testing.assert_array_equal(closed_curve.params, w)
    masks = np.random.default_rng(1).random((6, 88)) < 0.3
    rows = np.where(masks, w[1:], np.nan)
    reference = ClosedCurve(w, outline[:-1], 3)
    np.testing.assert_array_equal(closed_curve.evaluate_masks(masks).sse,
                                  reference.evaluate_positions(rows, nan_is_absent=True).sse)
    knots = w[[10, 30, 50, 70]]
    np.testing.assert_array_equal(closed_curve.fit(knots).spline.c,
                                  reference.fit(knots).spline.c)
    assert (closed_curve.extra_control_points, closed_curve.max_interior_knots,
            closed_curve.max_index, closed_curve.knot_bounds) == (1, 88, 88, (0.0, 1.0))
    moves = closed_curve.move_evaluator(knots)
    assert isinstance(moves, PeriodicMoveEvaluator)
    np.testing.assert_allclose(
        moves.sse, reference.evaluate_positions(knots[None], nan_is_absent=True).sse[0],
        rtol=1e-12)
    assert type(open_curve.move_evaluator(u[[10, 30, 50]])) is MoveEvaluator
    assert closed_curve.move_evaluator(np.array([0.5, 0.5, 0.6])) is None  # cannot be fitted


@pytest.mark.parametrize("closed", [False, True])
def test_errors_and_knot_sets_of_either_curve(closed):
    points = get_curve("epitrochoid" if closed else "archimedean", n_points=90).points
    curve = make_curve(points, closed=closed)
    sets = [curve.spread_knots(k) for k in (curve.min_interior_knots + 2, 8, 20)]
    errors = curve.errors(sets, "max_deviation")
    for knots, error in zip(sets, errors, strict=True):
        assert error == pytest.approx(curve.fit(knots).max_deviation, rel=1e-9)
    assert curve.errors([np.array([0.5, 0.5])], "rmse")[0] == np.inf
    assert curve.interpolation_residuals().max() < 1e-8


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("n", [9, 10, 31, 32])
def test_a_closed_outline_is_interpolated_at_every_degree(n, degree):
    """Breakpoints at every data point make the periodic system singular for an even degree
    on an even number of evenly spaced points (``metaknot fit --closed --degree 2`` failed
    with "singular"); interpolation then breaks at the midpoints: a residual of rounding."""
    curve = make_curve(polygon(n) * (1 + 0.1 * (np.arange(n) % 3))[:, None], degree=degree,
                       closed=True, parameterization="uniform")
    assert curve.interpolation_residuals().max() < 1e-9


@pytest.mark.parametrize("closed", [False, True])
def test_start_knots_for_every_count_a_problem_allows(closed):
    """The averaging knots (NURBS Book) wherever that formula applies, so the starts of the
    optimizers are as before; a closed outline allows more knots (up to N - 1), and beyond
    the formula's N - p - 1 it gets the curve's spread breakpoints: never an error."""
    from metaknot.bspline import averaging_knots

    for degree in (2, 3, 5):
        curve = make_curve(polygon(24, gap=0.0 if closed else 0.3), degree=degree,
                           closed=closed)
        low, high = curve.knot_bounds
        for count in range(1, curve.max_interior_knots + 1):
            knots = curve.start_knots(count)
            assert knots.shape == (count,) and (np.diff(knots) > 0).all()
            assert low < knots[0] and knots[-1] < high
            if count <= curve.n_points - degree - 1:
                np.testing.assert_array_equal(knots, averaging_knots(curve.params, count,
                                                                     degree))
            else:
                assert closed
                np.testing.assert_array_equal(knots, curve.spread_knots(count))


def test_a_closed_curve_refuses_explicit_parameters():
    with pytest.raises(ValueError, match="explicit parameters do not apply"):
        make_curve(polygon(20), closed=True, params=np.linspace(0, 1, 20))


def test_the_data_polygon_of_either_curve():
    ring = polygon(12)
    closed = make_curve(ring, closed=True)
    line = make_curve(ring[:8])  # an arc: open
    # a closed outline comes round to its first point, at parameter 1
    assert np.array_equal(closed.domain_params, np.append(closed.params, 1.0))
    assert np.array_equal(closed.around(closed.points)[-1], closed.points[0])
    assert closed.around(closed.points).shape == (13, 2) and closed.end_indices.size == 0
    assert np.array_equal(line.domain_params, line.params)
    assert np.array_equal(line.around(line.points), line.points)
    assert line.end_indices.tolist() == [0, 7]
    values = np.arange(5.0)
    assert closed.extend(values, 2).tolist() == [3, 4, 0, 1, 2, 3, 4, 0, 1]
    assert line.extend(values, 2).tolist() == [0, 0, 0, 1, 2, 3, 4, 4, 4]
    assert line.extend(values, 1, "reflect").tolist() == [1, 0, 1, 2, 3, 4, 3]
    rows = np.arange(6.0).reshape(3, 2)  # per-span rows extend along the first axis only
    assert closed.extend(rows, 1).tolist() == [[4, 5], [0, 1], [2, 3], [4, 5], [0, 1]]


def test_knots_for_breaks_and_the_coefficient_map():
    from scipy.interpolate import BSpline, make_lsq_spline

    ring = polygon(40)
    closed, line = make_curve(ring, closed=True), make_curve(ring[:30])
    breaks = line.params[[0, 5, 11, 17, 23, 29]]
    # The NURBS Book eq. 9.8 at the breaks, by hand: t_j = (b_j + b_{j+1} + b_{j+2}) / 3
    assert np.allclose(line.knots_for_breaks(breaks), [breaks[1:4].mean(), breaks[2:5].mean()])
    assert line.knots_for_breaks(breaks[:4]).size == 0
    at = closed.params[[0, 7, 19, 30]]
    assert np.array_equal(closed.knots_for_breaks(at), at[1:])
    # open: the clamped knot vector scipy's least squares takes, coefficients one to one
    knots = line.params[[7, 15, 22]]
    t, spread = line.coefficient_map(knots)
    assert np.allclose(make_lsq_spline(line.params, line.points, t, k=3)(line.params),
                       line.fit(knots).spline(line.params))
    assert np.array_equal(spread.toarray(), np.eye(t.size - 4))
    # closed: any distinct coefficients spread over the periodic knot vector give a spline
    # that closes with its derivatives, and the least-squares fit is one of them
    knots = closed.params[[6, 13, 21, 30]]
    t, spread = closed.coefficient_map(knots)
    c = spread @ np.random.default_rng(0).normal(size=(knots.size + 1, 2))
    spline = BSpline(t, c, 3)
    for order in range(3):
        assert np.allclose(spline(0.0, nu=order), spline(1.0, nu=order))
    fitted = closed.fit(knots).spline
    assert np.allclose(fitted.t, t)
    assert np.allclose(spread @ np.asarray(fitted.c)[: knots.size + 1], np.asarray(fitted.c))


def test_a_closed_curve_takes_parameters_over_one_period():
    ring = polygon(12)
    u = closed_parameterize(ring)
    with pytest.raises(ValueError, match="start at 0 and stay below 1"):
        ClosedCurve(u + 0.01, ring, 3)
    with pytest.raises(ValueError, match="start at 0 and stay below 1"):
        ClosedCurve(np.linspace(0, 1, 12), ring, 3)


def _both_curves():
    ring = polygon(40)
    return {"open": make_curve(ring), "closed": make_curve(ring, closed=True)}


@pytest.mark.parametrize("kind", ["open", "closed"])
@pytest.mark.parametrize(("offsets", "message"), [
    ([0, 9], r"offsets must run from 0 to len\(knots\)"),
    ([0, 3], r"offsets must run from 0 to len\(knots\)"),
    ([-1, 6], r"offsets must run from 0 to len\(knots\)"),
    ([], r"offsets must run from 0 to len\(knots\)"),
    ([[0, 6]], r"offsets must run from 0 to len\(knots\)"),
    ([0, 4, 2, 6], "offsets must be non-decreasing"),
    ([0, 2.5, 6], "offsets must be integers"),
])
def test_evaluate_knots_refuses_offsets_that_do_not_match_the_knots(kind, offsets, message):
    """A closed curve's evaluate_knots took any offsets (numpy's boolean-assignment errors,
    or rows from offsets starting at -1); fractional offsets were truncated on both."""
    curve = _both_curves()[kind]
    knots = curve.candidate_params[[5, 10, 15, 20, 25, 30]]
    assert curve.evaluate_knots(knots, [0, 6]).feasible.all()
    with pytest.raises(ValueError, match=message):
        curve.evaluate_knots(knots, offsets)
    with pytest.raises(ValueError, match=r"knots must be a 1-D array; got shape \(1, 6\)"):
        curve.evaluate_knots(knots[None, :], [0, 6])


@pytest.mark.parametrize("kind", ["open", "closed"])
@pytest.mark.parametrize("shape", [(2, 1), (2, 50), (1, 1, "n"), ("n",)])
def test_evaluate_masks_refuses_masks_of_another_width(kind, shape):
    """A closed curve broadcast a ``(B, 1)`` mask over every candidate knot (a knot at every
    data point, silently) and took 1-D masks."""
    curve = _both_curves()[kind]
    n_var = curve.candidate_params.size
    masks = np.ones([n_var if s == "n" else s for s in shape], dtype=int)
    with pytest.raises(ValueError, match=rf"masks must have shape \(B, .*\) = \(B, {n_var}\)"):
        curve.evaluate_masks(masks)


@pytest.mark.parametrize("kind", ["open", "closed"])
@pytest.mark.parametrize(("indices", "message"), [
    ([[-1, 10, 15]], "indices must lie in 1.."),
    ([[0, 10, 15]], "indices must lie in 1.."),
    ([[5, 10, 40]], "indices must lie in 1.."),
    ([5, 10, 15], r"indices must have shape \(B, K\)"),
    ([[[5, 10, 15]]], r"indices must have shape \(B, K\)"),
    ([[5.5, 10, 15]], "indices must be integers"),
])
def test_evaluate_indices_refuses_indices_off_the_candidate_points(kind, indices, message):
    """A closed curve took negative indices as counted from the end (a fit of other knots,
    silently) and left the rest to numpy's IndexError and AxisError."""
    curve = _both_curves()[kind]
    with pytest.raises(ValueError, match=message):
        curve.evaluate_indices(indices)


def test_closed_evaluate_indices_takes_whole_numbers_up_to_the_last_point():
    curve = _both_curves()["closed"]
    rows = np.array([[5, 10, 39], [39, 5, 10]])
    expected = curve.evaluate_positions(curve.params[np.sort(rows, axis=1)])
    for indices in (rows, rows.astype(float)):
        got = curve.evaluate_indices(indices)
        assert np.array_equal(got.sse, expected.sse)
        assert np.array_equal(got.reason, expected.reason)


@pytest.mark.parametrize("kind", ["open", "closed"])
def test_errors_refuse_an_unknown_metric_and_knot_sets_of_two_dimensions(kind):
    """An unknown metric was read as ``rmse``; a knot set of two dimensions failed in numpy's
    concatenate (or, alone, was flattened)."""

    curve = _both_curves()[kind]
    knots = curve.candidate_params[[5, 10, 15, 20, 25, 30]]
    assert np.isfinite(curve.errors([knots, knots[:3]], "rmse")).all()
    with pytest.raises(ValueError, match="metric must be 'max_deviation' or 'rmse'; got"):
        curve.errors([knots], "bogus")
    for sets in ([knots[None, :]], [knots[None, :], knots[:3]], [knots, 0.5]):
        with pytest.raises(ValueError, match=r"knot set 0|knot set 1"):
            curve.errors(sets, "rmse")


@pytest.mark.parametrize("kind", ["open", "closed"])
def test_coefficient_map_takes_a_list_and_refuses_two_dimensions(kind):
    """A closed curve's coefficient_map failed on a list (no ``size``) and flattened knots of
    two dimensions, as the open one did."""
    curve = _both_curves()[kind]
    knots = curve.candidate_params[[5, 10, 15, 20, 25, 30]]
    t, spread = curve.coefficient_map(knots)
    t_list, spread_list = curve.coefficient_map(list(knots))
    assert np.array_equal(t, t_list) and (spread != spread_list).nnz == 0
    with pytest.raises(ValueError, match=r"interior_knots must be 1-D; got shape \(1, 6\)"):
        curve.coefficient_map(knots[None, :])
