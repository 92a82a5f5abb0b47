"""Bad input gets a ``ValueError`` whose message names the problem, never a crash or NaN.

The explicit cases check the message of each kind of bad input for every public entry point;
the hypothesis tests throw random malformed and well-formed inputs at them and accept only a
``ValueError`` or a clean result (correct shapes, no NaN, objective values finite or ``+inf``).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import metaknot as mk
from metaknot.bspline import (
    BatchFit,
    Infeasibility,
    SplineFit,
    averaging_knots,
    check_degree,
    clamped_knot_vector,
    fit_spline,
    parameterize,
)
from metaknot.bspline.curve import ClosedCurve, OpenCurve, make_curve
from metaknot.problems import FreeKnots, KnotIndices, KnotSelection

N = 10
U = np.linspace(0.0, 1.0, N)
Q = np.column_stack((np.cos(3.0 * U), np.sin(3.0 * U)))
MASKS = np.zeros((2, N - 2), dtype=bool)
MASKS[0, 3] = MASKS[1, [2, 5]] = True
INDICES = np.array([[3, 6], [2, 7]])
POSITIONS = np.array([[0.3, 0.6], [0.25, 0.7]])


# one entry per public function: call(points, u, degree)
CALLS = {
    "parameterize": lambda pts, u, deg: parameterize(pts, "centripetal", degree=deg),
    "evaluate_masks": lambda pts, u, deg: OpenCurve(u, pts, deg).evaluate_masks(
        MASKS[:, : len(u) - 2]),
    "evaluate_indices": lambda pts, u, deg: OpenCurve(u, pts, deg).evaluate_indices(
        np.zeros((2, 0), int)),
    "evaluate_positions": lambda pts, u, deg: OpenCurve(u, pts, deg).evaluate_positions(
        POSITIONS),
    "fit_spline": lambda pts, u, deg: fit_spline(u, pts, [0.5], deg),
    "KnotSelection": lambda pts, u, deg: KnotSelection(points=pts, degree=deg),
}


def _with_value(row: int, value: float) -> np.ndarray:
    pts = Q.copy()
    pts[row, 1] = value
    return pts


# --------------------------------------------------------------------------------------------
# explicit cases


@pytest.mark.parametrize("call", CALLS.values(), ids=CALLS.keys())
@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf], ids=["nan", "inf", "-inf"])
def test_non_finite_coordinates(call, value):
    with pytest.raises(ValueError, match=r"NaN or infinite values \(first at row 4\)"):
        call(_with_value(4, value), U, 3)


@pytest.mark.parametrize("call", CALLS.values(), ids=CALLS.keys())
@pytest.mark.parametrize(("n_points", "degree"), [(4, 3), (2, 1), (6, 5), (3, 2)])
def test_too_few_points(call, n_points, degree):
    u = np.linspace(0.0, 1.0, n_points)
    pts = np.column_stack((u, u**2))
    with pytest.raises(ValueError, match=rf"needs at least {degree + 2} points; got {n_points}"):
        call(pts, u, degree)


@pytest.mark.parametrize("method", ["chord", "centripetal"])
def test_consecutive_duplicate_points(method):
    pts = Q.copy()
    pts[5] = pts[4]
    with pytest.raises(ValueError, match="points 4 and 5 coincide"):
        parameterize(pts, method)
    with pytest.raises(ValueError, match="points 4 and 5 coincide"):
        KnotSelection(points=pts, parameterization=method)
    # the uniform parameterization, and non-consecutive repeats, are fine
    u = parameterize(pts, "uniform")
    np.testing.assert_array_equal(u, np.linspace(0, 1, N))
    closed = np.vstack((Q, Q[:1]))  # a closed curve repeats its first point at the end
    assert (np.diff(parameterize(closed, method)) > 0).all()


@pytest.mark.parametrize("call", CALLS.values(), ids=CALLS.keys())
@pytest.mark.parametrize("shape", [(N, 2, 2), (2, N, 2, 1), ()])
def test_points_of_wrong_dimension(call, shape):
    pts = np.ones(shape)
    with pytest.raises(ValueError, match=r"must have shape \(N, d\)"):
        call(pts, U, 3)


@pytest.mark.parametrize("call", CALLS.values(), ids=CALLS.keys())
def test_points_without_coordinates(call):
    with pytest.raises(ValueError, match="at least one coordinate"):
        call(np.ones((N, 0)), U, 3)


@pytest.mark.parametrize("call", CALLS.values(), ids=CALLS.keys())
def test_non_numeric_points(call):
    pts = np.array([["a", "b"]] * N)
    with pytest.raises(ValueError, match=r"numeric|could not convert string to float"):
        call(pts, U, 3)


@pytest.mark.parametrize(
    "masks",
    [
        np.zeros((2, N - 3), dtype=bool),
        np.zeros((2, N - 1), dtype=bool),
        np.zeros((2, N), dtype=bool),
        np.zeros(N - 2, dtype=bool),
        np.zeros((1, 2, N - 2), dtype=bool),
    ],
    ids=["short", "long", "N", "1-D", "3-D"],
)
def test_masks_of_wrong_shape(masks):
    with pytest.raises(ValueError, match=rf"masks must have shape \(B, N - 2\) = \(B, {N - 2}\)"):
        OpenCurve(U, Q, 3).evaluate_masks(masks)


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
def test_masks_with_other_values(closed):
    """Masks of floats must hold 0 and 1 only (a NaN was taken as a knot); in integer masks any
    nonzero entry is a knot (the problems' encodings have checked them)."""
    curve = make_curve(Q, closed=closed)
    bits = np.zeros((2, curve.candidate_params.size), dtype=bool)
    bits[0, [1, 3, 5]] = bits[1, [2, 4, 6]] = True
    for bad in (np.where(bits, 2.0, 0.0), np.where(bits, 1.0, np.nan), bits * 0.5):
        with pytest.raises(ValueError, match="only 0 and 1"):
            curve.evaluate_masks(bad)
    masks = bits.astype(int)
    masks[0, 3] = 2
    expected = curve.evaluate_masks(bits).sse
    assert np.isfinite(expected).all()
    np.testing.assert_array_equal(curve.evaluate_masks(masks).sse, expected)
    np.testing.assert_array_equal(curve.evaluate_masks(bits.astype(float)).sse, expected)


@pytest.mark.parametrize(
    ("indices", "message"),
    [
        (np.array([3, 6]), r"indices must have shape \(B, K\)"),
        (np.ones((1, 2, 2), dtype=int), r"indices must have shape \(B, K\)"),
        ([[0, 3]], rf"indices must lie in 1..{N - 2}"),
        ([[3, N - 1]], rf"indices must lie in 1..{N - 2}"),
        ([[-4, 3]], rf"indices must lie in 1..{N - 2}"),
        ([[2.5, 3.0]], "indices must be integers"),
        ([[np.nan, 3.0]], "indices must be integers"),
    ],
)
def test_bad_indices(indices, message):
    with pytest.raises(ValueError, match=message):
        OpenCurve(U, Q, 3).evaluate_indices(indices)


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
@pytest.mark.parametrize("positions", [np.array([0.3, 0.6]), np.ones((1, 2, 2)), 0.5])
def test_positions_of_wrong_shape(positions, closed):
    """Open and closed curves refuse the same shapes (a 1-D row is not taken as one row by
    either)."""
    curve = make_curve(Q, closed=closed)
    with pytest.raises(ValueError, match=r"positions must have shape \(B, K\)"):
        curve.evaluate_positions(positions)
    if not closed:
        with pytest.raises(ValueError, match=r"positions must have shape \(B, K\)"):
            OpenCurve(U, Q, 3).evaluate_positions(positions)


@pytest.mark.parametrize(
    "values", [np.arange(N - 1.0), np.arange(N + 1.0), np.arange(float(N))[:, None], 0.5],
    ids=["short", "long", "column", "scalar"],
)
def test_explicit_parameters_of_wrong_shape(values):
    with pytest.raises(ValueError, match=rf"explicit parameter values must have shape \({N},\)"):
        parameterize(Q, values)


@pytest.mark.parametrize(
    ("values", "message"),
    [
        (np.r_[0.0, 2.0, 1.0, np.arange(3.0, N)], r"strictly increasing; values\[1\]"),
        (np.r_[0.0, 0.0, np.arange(2.0, N)], r"strictly increasing; values\[0\]"),
        (np.r_[np.nan, np.arange(1.0, N)], "NaN or infinite"),
        (np.r_[np.arange(N - 1.0), np.inf], "NaN or infinite"),
        (np.r_[np.arange(N - 1.0), 1e200], r"values of magnitude above 1e\+100 \(first at row"),
        (["a"] * N, "numeric"),
    ],
)
def test_bad_explicit_parameters(values, message):
    with pytest.raises(ValueError, match=message):
        parameterize(Q, values)


_EVALUATORS = {
    "evaluate_masks": lambda u: OpenCurve(u, Q, 3).evaluate_masks(MASKS),
    "evaluate_indices": lambda u: OpenCurve(u, Q, 3).evaluate_indices(INDICES),
    "evaluate_positions": lambda u: OpenCurve(u, Q, 3).evaluate_positions(POSITIONS),
    "fit_spline": lambda u: fit_spline(u, Q, [0.5], 3),
}


@pytest.mark.parametrize("call", _EVALUATORS.values(), ids=_EVALUATORS.keys())
@pytest.mark.parametrize(
    ("u", "message"),
    [
        (U[::-1].copy(), "finite and strictly increasing"),
        (np.r_[U[:3], U[2:-1]], "finite and strictly increasing"),
        (np.r_[np.nan, U[1:]], "finite and strictly increasing"),
        (np.r_[U[:-1], np.inf], "finite and strictly increasing"),
    ],
    ids=["decreasing", "repeated", "nan", "inf"],
)
def test_bad_parameter_values(call, u, message):
    with pytest.raises(ValueError, match=message):
        call(u)


@pytest.mark.parametrize("call", _EVALUATORS.values(), ids=_EVALUATORS.keys())
@pytest.mark.parametrize(
    "u", [U[:, None], U[None, :], U.reshape(2, N // 2)], ids=["column", "row", "2x5"]
)
def test_parameter_values_of_wrong_shape(call, u):
    """A 2-D parameter array must be rejected with a ValueError about its shape."""
    with pytest.raises(ValueError, match="shape"):
        call(u)


@pytest.mark.parametrize("call", _EVALUATORS.values(), ids=_EVALUATORS.keys())
def test_parameter_values_of_wrong_length(call):
    with pytest.raises(ValueError, match="shape"):
        call(np.linspace(0.0, 1.0, N + 1))


def test_fit_spline_interior_of_wrong_shape():
    with pytest.raises(ValueError, match="interior_knots must be 1-D"):
        fit_spline(U, Q, [[0.3, 0.6]], 3)
    with pytest.raises(ValueError, match="interior_knots must be 1-D"):
        fit_spline(U, Q, 0.5, 3)


def _with_data(call):
    return lambda deg: call(Q, U, deg)


_DEGREE_CALLS = {
    **{name: _with_data(call) for name, call in CALLS.items()},
    "check_degree": check_degree,
    "clamped_knot_vector": lambda deg: clamped_knot_vector(U, [0.5], deg),
    "averaging_knots": lambda deg: averaging_knots(U, 2, deg),
}


@pytest.mark.parametrize("call", _DEGREE_CALLS.values(), ids=_DEGREE_CALLS.keys())
@pytest.mark.parametrize(
    ("degree", "message"),
    [
        (0, "between 1 and 5, got 0"),
        (6, "between 1 and 5, got 6"),
        (-1, "between 1 and 5, got -1"),
        (np.int64(9), "between 1 and 5, got 9"),
        (2.5, "must be an integer between 1 and 5, got 2.5"),
        (3.0, "must be an integer between 1 and 5, got 3.0"),
        (True, "must be an integer between 1 and 5, got True"),
        (False, "must be an integer between 1 and 5, got False"),
        ("3", "must be an integer between 1 and 5, got '3'"),
        (None, "must be an integer between 1 and 5, got None"),
    ],
)
def test_degree_out_of_range(call, degree, message):
    with pytest.raises(ValueError, match=message):
        call(degree)


@pytest.mark.parametrize("method", ["foo", "Chord", "", "centripetal "])
def test_unknown_parameterization(method):
    with pytest.raises(ValueError, match=f"unknown parameterization {method!r}"):
        parameterize(Q, method)
    with pytest.raises(ValueError, match="unknown parameterization"):
        KnotSelection(points=Q, parameterization=method)


@pytest.mark.parametrize(
    ("x", "message"),
    [
        (np.ones((2, N - 3)), r"candidates must have shape \(B, 8\)"),
        (np.ones((2, 2, N - 2)), r"candidates must have shape \(B, 8\)"),
        (np.full((2, N - 2), 2), r"must lie in \[0.0, 1.0\]"),
        (np.full((1, N - 2), 0.5), "whole numbers"),
        (np.full((1, N - 2), np.nan), "whole numbers"),
        (np.array([["a"] * (N - 2)]), "numeric"),
    ],
)
def test_knot_selection_bad_candidates(x, message):
    problem = KnotSelection(points=Q, degree=3)
    with pytest.raises(ValueError, match=message):
        problem.evaluate(x)


@pytest.mark.parametrize(
    ("knots", "offsets", "message"),
    [
        ([0.3, 0.6], [0, 1], "offsets must run from 0 to len"),
        ([0.3, 0.6], [1, 2], "offsets must run from 0 to len"),
        ([0.3, 0.6], [], "offsets must run from 0 to len"),
        ([0.3, 0.6], [[0, 2]], "offsets must run from 0 to len"),
        ([0.3, 0.6], [0, 2, 1, 2], "offsets must be non-decreasing"),
    ],
)
def test_evaluate_knots_bad_offsets(knots, offsets, message):
    with pytest.raises(ValueError, match=message):
        OpenCurve(U, Q, 3).evaluate_knots(knots, offsets)


# --------------------------------------------------------------------------------------------
# huge but finite coordinates: overflow must not turn into NaN


HUGE = np.array([[0.0, 0.0], [1e308, 0.0], [-1e308, 1.0], [1e308, 2.0], [0.0, 3.0], [1.0, 4.0]])
#: Coordinates just below the accepted magnitude (1e100): accepted, and must stay finite.
SHAPE = np.array([[0.0, 0.0], [1.0, 0.0], [-1.0, 1.0], [1.0, 2.0], [0.0, 3.0], [1.0, 4.0]])
LARGE = 2e99 * SHAPE  # largest coordinate 8e99


@pytest.mark.parametrize("method", ["chord", "centripetal"])
def test_parameterize_rejects_overflowing_coordinates(method):
    with pytest.raises(ValueError, match="magnitude above 1e\\+100"):
        parameterize(HUGE, method, degree=1)


@pytest.mark.parametrize("method", ["chord", "centripetal"])
def test_parameterize_large_coordinates(method):
    """Chord lengths of 1e100 do not overflow: valid parameters, matching the closed form."""
    u = parameterize(LARGE, method, degree=1)
    assert np.isfinite(u).all(), f"parameterize returned {u}"
    assert (np.diff(u) > 0).all()
    d = np.linalg.norm(np.diff(SHAPE, axis=0), axis=1)  # the same chords, at unit scale
    d = d if method == "chord" else np.sqrt(d)
    np.testing.assert_allclose(u, np.concatenate(([0.0], np.cumsum(d))) / d.sum(), rtol=1e-12)


@pytest.mark.parametrize("scale", [1e101, 1e305, 1e308])
def test_evaluators_reject_overflowing_coordinates(scale):
    u = np.linspace(0.0, 1.0, 8)
    q = scale * np.column_stack(((-1.0) ** np.arange(8), np.linspace(-1.0, 1.0, 8)))
    masks = np.zeros((1, 6), dtype=bool)
    with pytest.raises(ValueError, match="magnitude above 1e\\+100"):
        OpenCurve(u, q, 1).evaluate_masks(masks)


@pytest.mark.parametrize("scale", [1e-150, 1e99])
def test_evaluators_extreme_but_accepted_coordinates(scale):
    u = np.linspace(0.0, 1.0, 8)
    q = scale * np.column_stack(((-1.0) ** np.arange(8), np.linspace(-1.0, 1.0, 8)))
    masks = np.array([[0] * 6, [0, 1, 0, 0, 1, 0], [1, 0, 1, 1, 0, 1]], dtype=bool)
    fit = OpenCurve(u, q, 1).evaluate_masks(masks)
    assert np.isfinite(fit.sse).all(), f"sse {fit.sse}"
    assert np.isfinite(fit.max_deviation).all(), f"max_deviation {fit.max_deviation}"
    # the data are not on a line: the largest deviation is not zero, and its square is at
    # least the mean of the squared deviations
    assert (fit.max_deviation > 0).all(), f"max_deviation {fit.max_deviation}"
    assert (fit.max_deviation**2 >= fit.sse / u.size * (1 - 1e-12)).all()


ALTERNATING = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])


def test_fit_spline_rejects_overflowing_coordinates():
    with pytest.raises(ValueError, match="magnitude above 1e\\+100"):
        fit_spline(np.linspace(0.0, 1.0, 6), 1e308 * ALTERNATING, [0.4], 1)


def test_fit_spline_large_coordinates_scale_exactly():
    """Just under the limit the fit is the unit-scale fit times the scale: no overflow."""
    u = np.linspace(0.0, 1.0, 6)
    unit = fit_spline(u, ALTERNATING, [0.4], 1)
    large = fit_spline(u, 9e99 * ALTERNATING, [0.4], 1)
    for name, value in large.metrics.items():
        assert np.isfinite(value), (name, value)
    assert large.rmse == pytest.approx(9e99 * unit.rmse, rel=1e-12)
    assert large.max_deviation == pytest.approx(9e99 * unit.max_deviation, rel=1e-12)


def test_knot_selection_rejects_overflowing_coordinates():
    with pytest.raises(ValueError, match="magnitude above 1e\\+100"):
        KnotSelection(points=1e308 * ALTERNATING, degree=1, parameterization="uniform")


def test_knot_selection_large_coordinates_scale_exactly():
    x = np.array([[0, 0, 0, 0], [0, 1, 0, 0], [1, 1, 0, 1]])
    options = {"degree": 1, "parameterization": "uniform", "objective": "paper",
               "objective_options": {"error_floor": 0.0}}
    unit = KnotSelection(points=ALTERNATING, **options).evaluate(x)
    large = KnotSelection(points=9e99 * ALTERNATING, **options).evaluate(x)
    assert np.isfinite(large).all(), large
    np.testing.assert_allclose(large, 9e99 * unit, rtol=1e-12)


# --------------------------------------------------------------------------------------------
# property-based: random malformed and well-formed input

SETTINGS = settings(
    max_examples=150,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)

BAD_DEGREES = [0, 6, -1, 2.5, True, None, "3", np.float64(3.0)]
degrees = st.one_of(st.integers(1, 5), st.integers(1, 5), st.sampled_from(BAD_DEGREES))

SPECIAL = [0.0, -0.0, 1.0, np.nan, np.inf, -np.inf, 1e308, -1e308, 1e-320, 1e154]
floats = st.one_of(
    st.floats(-10.0, 10.0),
    st.floats(-10.0, 10.0),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(SPECIAL),
)


@st.composite
def point_arrays(draw):
    """Mostly (N, d) float arrays, some with NaN/inf/huge values, duplicates or bad shapes."""
    n = draw(st.integers(0, 14))
    d = draw(st.integers(1, 3))
    clean = draw(st.booleans())
    elements = st.floats(-10.0, 10.0) if clean else floats
    pts = draw(hnp.arrays(np.float64, (n, d), elements=elements))
    change = draw(st.sampled_from(
        ["none", "none", "none", "duplicate", "nan", "1-D", "3-D", "no columns", "transpose"]
    ))
    if change == "duplicate" and n >= 2:
        i = draw(st.integers(0, n - 2))
        pts[i + 1] = pts[i]
    elif change == "nan" and n >= 1:
        pts[draw(st.integers(0, n - 1)), 0] = np.nan
    elif change == "1-D":
        pts = pts[:, 0]
    elif change == "3-D":
        pts = pts[:, :, None]
    elif change == "no columns":
        pts = pts[:, :0]
    elif change == "transpose":
        pts = pts.T
    return pts


def _n_rows(points) -> int:
    arr = np.asarray(points)
    return arr.shape[0] if arr.ndim >= 1 else 1


@st.composite
def params_for(draw, points):
    """Parameter values for ``points``: mostly valid, sometimes of wrong length, shape, order."""
    n = _n_rows(points)
    kind = draw(st.sampled_from(["uniform", "uniform", "random", "wrong length", "column",
                                 "unsorted", "nan"]))
    if kind == "uniform":
        return np.linspace(0.0, 1.0, n)
    if kind == "random":
        gaps = draw(hnp.arrays(np.float64, max(n - 1, 0), elements=st.floats(0.01, 10.0)))
        start = draw(st.floats(-100.0, 100.0))
        return start + np.concatenate(([0.0], np.cumsum(gaps)))
    if kind == "wrong length":
        return np.linspace(0.0, 1.0, max(n + draw(st.sampled_from([-2, -1, 1, 3])), 0))
    if kind == "column":
        return np.linspace(0.0, 1.0, n)[:, None]
    if kind == "unsorted":
        return draw(hnp.arrays(np.float64, n, elements=st.floats(0.0, 1.0)))
    u = np.linspace(0.0, 1.0, n)
    if n:
        u[draw(st.integers(0, n - 1))] = np.nan
    return u


def _check_batch(fit: BatchFit, n_candidates: int) -> None:
    assert isinstance(fit, BatchFit)
    for arr in (fit.sse, fit.max_deviation, fit.n_control_points, fit.reason):
        assert arr.shape == (n_candidates,)
    assert len(fit) == n_candidates
    assert not np.isnan(fit.sse).any(), f"NaN sse: {fit.sse}"
    assert not np.isnan(fit.max_deviation).any(), f"NaN max_deviation: {fit.max_deviation}"
    assert (fit.sse >= 0).all() and (fit.max_deviation >= 0).all()
    assert set(fit.reason.tolist()) <= {int(r) for r in Infeasibility}
    bad = ~fit.feasible
    assert (fit.sse[bad] == np.inf).all() and (fit.max_deviation[bad] == np.inf).all()


def _accept(call):
    """Run ``call``: a ValueError is accepted (returns None); anything else propagates."""
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            result = call()
        except ValueError:
            event("ValueError")
            return None
    event("clean result")
    return result


@SETTINGS
@given(data=st.data())
def test_fuzz_parameterize(data):
    points = data.draw(point_arrays())
    degree = data.draw(degrees)
    method = data.draw(st.one_of(
        st.sampled_from(["uniform", "chord", "centripetal", "bogus"]), params_for(points)
    ))
    u = _accept(lambda: parameterize(points, method, degree=degree))
    if u is None:
        return
    n = _n_rows(points)
    assert u.shape == (n,)
    assert np.isfinite(u).all(), f"parameters {u}"
    assert (np.diff(u) > 0).all(), f"parameters {u}"
    if isinstance(method, str):
        assert u[0] == 0.0 and u[-1] == 1.0


@st.composite
def mask_batches(draw, n):
    b = draw(st.integers(0, 5))
    width = max(n - 2, 0) if draw(st.integers(0, 4)) else max(n + draw(st.integers(-4, 2)), 0)
    values = draw(st.sampled_from([(0, 1), (0, 1), (0, 1, 2), (0.0, 1.0, 0.5)]))
    masks = draw(hnp.arrays(np.float64, (b, width), elements=st.sampled_from(values)))
    if draw(st.booleans()) and set(values) <= {0, 1}:
        masks = masks.astype(bool)
    return masks


@SETTINGS
@given(data=st.data())
def test_fuzz_evaluate_masks(data):
    points = data.draw(point_arrays())
    u = data.draw(params_for(points))
    masks = data.draw(mask_batches(_n_rows(points)))
    degree = data.draw(degrees)
    fit = _accept(lambda: OpenCurve(u, points, degree).evaluate_masks(masks))
    if fit is not None:
        _check_batch(fit, masks.shape[0])
        np.testing.assert_array_equal(fit.n_control_points,
                                      masks.astype(bool).sum(axis=1) + degree + 1)


@SETTINGS
@given(data=st.data())
def test_fuzz_evaluate_indices(data):
    points = data.draw(point_arrays())
    n = _n_rows(points)
    u = data.draw(params_for(points))
    b = data.draw(st.integers(0, 5))
    k = data.draw(st.integers(0, n + 2))
    lo, hi = (1, max(n - 2, 1)) if data.draw(st.integers(0, 4)) else (-1, n + 1)
    indices = data.draw(hnp.arrays(np.int64, (b, k), elements=st.integers(lo, hi)))
    if data.draw(st.integers(0, 5)) == 0:
        indices = indices.astype(np.float64) + data.draw(st.sampled_from([0.0, 0.5, np.nan]))
    degree = data.draw(degrees)
    fit = _accept(lambda: OpenCurve(u, points, degree).evaluate_indices(indices))
    if fit is not None:
        _check_batch(fit, b)
        assert (fit.n_control_points == k + degree + 1).all()


@SETTINGS
@given(data=st.data())
def test_fuzz_evaluate_positions(data):
    points = data.draw(point_arrays())
    n = _n_rows(points)
    u = data.draw(params_for(points))
    b = data.draw(st.integers(0, 5))
    k = data.draw(st.integers(0, n + 2))
    elements = st.one_of(st.floats(-0.2, 1.2), floats)
    positions = data.draw(hnp.arrays(np.float64, (b, k), elements=elements))
    degree = data.draw(degrees)
    fit = _accept(lambda: OpenCurve(u, points, degree).evaluate_positions(positions))
    if fit is not None:
        _check_batch(fit, b)
        assert (fit.n_control_points == k + degree + 1).all()


@SETTINGS
@given(data=st.data())
def test_fuzz_fit_spline(data):
    points = data.draw(point_arrays())
    n = _n_rows(points)
    u = data.draw(params_for(points))
    k = data.draw(st.integers(0, n + 1))
    interior = data.draw(hnp.arrays(np.float64, k, elements=st.one_of(st.floats(0.0, 1.0),
                                                                      floats)))
    if data.draw(st.booleans()):
        interior = np.sort(interior)
    degree = data.draw(degrees)
    fit = _accept(lambda: fit_spline(u, points, interior, degree))
    if fit is None:
        return
    assert isinstance(fit, SplineFit)
    d = np.asarray(points).reshape(n, -1).shape[1]
    assert fit.control_points.shape == (k + degree + 1, d)
    with np.errstate(all="ignore"):
        metrics = fit.metrics
    for key, value in metrics.items():
        assert not np.isnan(value) and value >= 0, f"{key} = {value}"


@SETTINGS
@given(data=st.data())
def test_fuzz_knot_selection(data):
    points = data.draw(point_arrays())
    degree = data.draw(degrees)
    method = data.draw(st.sampled_from(["uniform", "chord", "centripetal"]))
    objective = data.draw(st.sampled_from(["paper", "bic", "error_bounded"]))
    problem = _accept(lambda: KnotSelection(points=points, degree=degree,
                                            parameterization=method, objective=objective))
    if problem is None:
        return
    n_var = problem.encoding.n_var
    b = data.draw(st.integers(0, 5))
    width = n_var if data.draw(st.integers(0, 4)) else data.draw(st.integers(0, n_var + 2))
    values = data.draw(st.sampled_from([(0, 1), (0, 1), (0, 1), (0, 1, 2), (0.0, 1.0, np.nan)]))
    x = data.draw(hnp.arrays(np.float64, (b, width), elements=st.sampled_from(values)))
    out = _accept(lambda: problem.evaluate(x))
    if out is None:
        return
    assert out.shape == (b,)
    assert not np.isnan(out).any(), f"objective values {out}"
    assert (out > -np.inf).all(), f"objective values {out}"


def test_integer_settings_agree_about_numpy_integers_and_bools():
    """Every integer setting takes numpy integers and refuses bools (one rule:
    metaknot.validate)."""
    import metaknot as mk
    from metaknot.bspline import check_degree
    from metaknot.callbacks import TraceRecorder
    from metaknot.validate import is_integer, is_real

    assert is_integer(np.int32(3)) and not is_integer(True) and not is_integer(np.bool_(True))
    assert not is_integer(3.0) and is_real(3.0) and is_real(np.float32(1)) and not is_real(False)
    from metaknot.problems import KnotIndices, get_curve

    data = get_curve("archimedean", n_points=30)
    assert check_degree(np.int64(3)) == 3
    assert TraceRecorder(np.int64(4)).per_decade == 4
    assert KnotIndices(data, n_knots=np.int16(5)).n_knots == 5
    result = mk.minimize(KnotIndices(data, n_knots=3), "random_search", budget=np.int64(7),
                         seed=np.uint8(2))
    assert result.n_evaluations == 7
    for make in (lambda: check_degree(True), lambda: TraceRecorder(True),
                 lambda: KnotIndices(data, n_knots=np.bool_(True)),
                 lambda: mk.minimize(KnotIndices(data, n_knots=3), "random_search", budget=True),
                 lambda: mk.minimize(KnotIndices(data, n_knots=3), "random_search", budget=5,
                                     seed=False)):
        with pytest.raises(ValueError):
            make()


@pytest.mark.parametrize(("masks", "message"), [
    (np.ones((1, N + 50), dtype=bool), r"masks must have shape \(B, N - 2\)"),
    (np.ones(N - 2, dtype=bool), r"masks must have shape \(B, N - 2\)"),
    (np.where(np.arange(N - 2) == 3, 3, 0)[None, :], "only 0 and 1"),
    (np.where(np.arange(N - 2) == 3, -5, 0)[None, :], "only 0 and 1"),
])
def test_stack_masks_checks_its_masks(masks, message):
    """Masks wider than the interior points made the compiled gathering read past the
    parameters; entries other than 0 and 1 sized the output by their sum, leaving
    uninitialised knots (or a negative size)."""
    from metaknot.bspline.knots import stack_masks

    with pytest.raises(ValueError, match=message):
        stack_masks(U, masks)
    with pytest.raises(ValueError, match="parameter values must be a 1-D array"):
        stack_masks(U[None, :], MASKS)
    knots, offsets = stack_masks(U, MASKS)
    assert offsets.tolist() == np.concatenate(([0], np.cumsum(MASKS.sum(axis=1)))).tolist()
    assert np.array_equal(knots, np.concatenate([U[1:-1][m] for m in MASKS]))


@pytest.mark.parametrize("kind", ["mask", "indices", "free"])
def test_complex_candidates_from_an_optimizer_are_refused_by_name(kind):
    """An optimizer's complex candidates lost their imaginary parts in the encoding's cast
    (another candidate, silently, with only a numpy warning): the encoding refuses them."""
    problem = {"mask": KnotSelection(points=Q), "indices": KnotIndices(Q, n_knots=2),
               "free": FreeKnots(Q, n_knots=2)}[kind]
    X = problem.sample(np.random.default_rng(0), 3) + 1j
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # refused before any cast could warn
        with pytest.raises(ValueError, match="candidates must be real numbers; got complex"):
            problem.encoding.check(X)
        with pytest.raises(ValueError, match="candidates must be real numbers; got complex"):
            problem.evaluate(X)


def test_complex_knot_positions_are_refused_by_name():
    """Complex positions lost their imaginary parts with only a numpy warning (another
    candidate, silently), on open and closed curves, one candidate or a batch."""
    from metaknot.bspline import closed_parameterize
    from metaknot.bspline.knots import stack_positions

    positions = np.array([[0.3 + 0.2j, 0.6 + 0.0j]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # refused before any cast could warn
        curve, closed = OpenCurve(U, Q, 3), ClosedCurve(closed_parameterize(Q), Q, 3)
        for call in (lambda: curve.evaluate_positions(positions),
                     lambda: curve.evaluate_positions(np.repeat(positions, 40, axis=0)),
                     lambda: stack_positions(positions),
                     lambda: closed.evaluate_positions(positions, nan_is_absent=True)):
            with pytest.raises(ValueError, match="knot positions must be real numbers"):
                call()


def test_bit_flips_refuse_a_mask_of_other_values_than_0_and_1():
    """A mask value of 0.5 was read as a set bit."""
    from metaknot.bspline.moves import bit_flips

    mask = np.zeros(N - 2)
    mask[[3, 6]] = 1.0
    assert len(bit_flips(U, mask, [3, 4])[0]) == 2  # 0.0 and 1.0 as floats are taken
    mask[5] = 0.5
    with pytest.raises(ValueError, match="mask must contain only 0 and 1"):
        bit_flips(U, mask, [3, 4])


@pytest.mark.parametrize("value", ["false", "no", None, 0, 1.0])
@pytest.mark.parametrize("call", [
    lambda v: KnotSelection(points=Q, closed=v),
    lambda v: FreeKnots(Q, n_knots=2, variable_count=v),
    lambda v: mk.minimize(KnotSelection(points=Q), "ga", budget=5, seed=0, progress=v),
    lambda v: mk.fit(Q, 1e-2, relative=v),
    lambda v: mk.fit(Q, 1e-2, function=v),
    lambda v: mk.fit(Q, 1e-2, closed=v) if v is not None else mk.fit(Q, 1e-2, progress=v),
], ids=["problem closed", "variable_count", "minimize progress", "fit relative",
        "fit function", "fit closed or progress"])
def test_flags_are_true_or_false(call, value):
    """A flag given as the string "false" (or None, 0, 1.0) was taken for its truth value: a
    closed outline from closed="false". Flags are Python or numpy bools."""
    with pytest.raises(ValueError, match=r"must be True or False; got "):
        call(value)


def test_numpy_flags_and_reals_are_taken():
    assert KnotSelection(points=Q, closed=np.bool_(False)).closed is False
    assert mk.fit(Q, np.float32(1e-2), relative=np.bool_(True)).n_control_points >= 4
