"""The curve model: open and closed curves behind one interface, and the one rule of closedness."""

from __future__ import annotations

import numpy as np
import pytest

from metaknot.bspline import evaluate_masks, fit_spline, parameterize
from metaknot.bspline.curve import ClosedCurve, OpenCurve, closure, make_curve
from metaknot.bspline.moves import MoveEvaluator, PeriodicMoveEvaluator
from metaknot.bspline.periodic import closed_parameterize, evaluate_periodic, fit_periodic
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
                                  evaluate_masks(u, spiral, masks).sse)
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
    np.testing.assert_array_equal(closed_curve.evaluate_masks(masks).sse,
                                  evaluate_periodic(w, outline[:-1], rows).sse)
    knots = w[[10, 30, 50, 70]]
    np.testing.assert_array_equal(closed_curve.fit(knots).spline.c,
                                  fit_periodic(w, outline[:-1], knots).spline.c)
    assert (closed_curve.extra_control_points, closed_curve.max_interior_knots,
            closed_curve.max_index, closed_curve.knot_bounds) == (1, 88, 88, (0.0, 1.0))
    moves = closed_curve.move_evaluator(knots)
    assert isinstance(moves, PeriodicMoveEvaluator)
    np.testing.assert_allclose(moves.sse, evaluate_periodic(w, outline[:-1], knots[None]).sse[0],
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


def test_a_closed_curve_refuses_explicit_parameters():
    with pytest.raises(ValueError, match="explicit parameters do not apply"):
        make_curve(polygon(20), closed=True, params=np.linspace(0, 1, 20))
