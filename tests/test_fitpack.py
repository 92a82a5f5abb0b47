"""The one FITPACK module: scipy's ``splprep`` on open and closed data, its refusals, its
front and its answer to a tolerance."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import splev, splprep

from metaknot.bspline import closed_parameterize, fitpack, parameterize
from metaknot.problems import get_curve

SPIRAL = get_curve("archimedean", n_points=80).points
OUTLINE = get_curve("epitrochoid", n_points=120).points[:-1]


def test_open_smoothing_spline_is_splprep():
    u = parameterize(SPIRAL, "centripetal")
    spline = fitpack.smoothing_spline(u, SPIRAL, 3, 1e-3)
    (t, c, k), _ = splprep(SPIRAL.T, u=u, k=3, s=1e-3)
    np.testing.assert_array_equal(spline.knots, t)
    np.testing.assert_array_equal(spline.interior_knots, t[4:-4])
    assert spline.n_control_points == t.size - 4
    fitted = np.column_stack(splev(u, (t, c, k)))
    np.testing.assert_allclose(spline.distances(u, SPIRAL),
                               np.linalg.norm(SPIRAL - fitted, axis=1), rtol=0, atol=0)
    np.testing.assert_allclose(spline.bspline()(u), fitted, atol=1e-12)


def test_closed_smoothing_spline_is_periodic_splprep():
    u = closed_parameterize(OUTLINE)
    spline = fitpack.smoothing_spline(u, OUTLINE, 3, 1e-2, closed=True)
    (t, _, _), _ = splprep(np.vstack((OUTLINE, OUTLINE[:1])).T, u=np.append(u, 1.0), k=3,
                           s=1e-2, per=1)
    np.testing.assert_array_equal(spline.knots, t)
    assert spline.n_control_points == t.size - 4 - 3  # the last 3 coefficients repeat
    curve = spline.bspline()
    np.testing.assert_allclose(curve(0.0), curve(1.0), atol=1e-12)


def test_a_refused_smoothing_factor_is_a_fitpack_error():
    u = parameterize(SPIRAL, "centripetal")
    with pytest.raises(fitpack.FitpackError, match="FITPACK refused s = -1"):
        fitpack.smoothing_spline(u, SPIRAL, 3, -1.0)


@pytest.mark.parametrize("closed", [False, True])
def test_the_front_holds_the_best_fit_per_count(closed):
    points = OUTLINE if closed else SPIRAL
    u = closed_parameterize(points) if closed else parameterize(points, "centripetal")
    front = fitpack.front(u, points, 3, 40, closed=closed)
    assert np.all(np.diff(front["n_control_points"]) > 0)
    assert np.all(front["max_deviation"] >= front["rmse"])
    total = float(((points - points.mean(axis=0)) ** 2).sum())
    for s in np.geomspace(total * 1e-14, total * 0.5, 40)[::5]:
        try:
            spline = fitpack.smoothing_spline(u, points, 3, float(s), closed=closed)
        except fitpack.FitpackError:
            continue
        rmse = np.sqrt(np.mean(spline.distances(u, points) ** 2))
        at = np.flatnonzero(front["n_control_points"] == spline.n_control_points)
        assert at.size == 1 and front["rmse"][at[0]] <= rmse * (1 + 1e-12)


@pytest.mark.parametrize("metric", ["max_deviation", "rmse"])
@pytest.mark.parametrize("closed", [False, True])
def test_fewest_within_is_within_and_no_front_member_with_fewer_is(metric, closed):
    points = OUTLINE if closed else SPIRAL
    u = closed_parameterize(points) if closed else parameterize(points, "centripetal")
    scale = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    tol = 1e-3 * scale
    answer = fitpack.fewest_within(u, points, 3, tol, metric, closed=closed)
    assert answer[metric] <= tol
    distance = np.linalg.norm(points - answer["spline"](u), axis=1)
    error = distance.max() if metric == "max_deviation" else np.sqrt(np.mean(distance**2))
    assert error == pytest.approx(answer[metric], rel=1e-9)
    front = fitpack.front(u, points, 3, 60, closed=closed)
    within = front["n_control_points"][front[metric] <= tol]
    assert answer["n_control_points"] <= within.min()


@pytest.mark.parametrize("closed", [False, True])
def test_fewest_within_leaves_out_only_the_near_interpolating_factors(monkeypatch, closed):
    """The scan runs down from the largest factor and stops at the first spline with far more
    control points than the fewest within the tolerance so far; the answer is the one the whole
    scan of 60 factors (then the same bisection) finds."""
    points = OUTLINE if closed else SPIRAL
    u = closed_parameterize(points) if closed else parameterize(points, "centripetal")
    tol = 1e-3 * float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    fitted = []  # (s, control points, within the tolerance) of each spline, in order
    smoothing_spline = fitpack.smoothing_spline

    def recording(*args, **kwargs):
        spline = smoothing_spline(*args, **kwargs)
        within = spline.distances(u, points).max() <= tol
        fitted.append((args[3], spline.n_control_points, within))
        return spline

    monkeypatch.setattr(fitpack, "smoothing_spline", recording)
    answer = fitpack.fewest_within(u, points, 3, tol, "max_deviation", closed=closed)
    smallest = min(s for s, _, _ in fitted)
    scan = fitted[: [s for s, _, _ in fitted].index(smallest) + 1]  # then the bisection
    assert [s for s, _, _ in scan] == sorted((s for s, _, _ in scan), reverse=True)
    fewest = np.inf
    for i, (_, n, within) in enumerate(scan):
        far = n > max(fitpack.SCAN_STOP_FACTOR * fewest, fewest + fitpack.SCAN_STOP_MARGIN)
        assert far == (i == len(scan) - 1)  # the first spline far beyond ends the scan
        fewest = min(fewest, n) if within else fewest
    assert answer["n_control_points"] <= fewest
    total = float(((points - points.mean(axis=0)) ** 2).sum())
    grid = np.exp(np.linspace(np.log(total * 1e-14), np.log(total), 60))
    assert np.count_nonzero(grid < smallest * (1 - 1e-9)) > 10  # near-interpolating: left out
    monkeypatch.setattr(fitpack, "SCAN_STOP_FACTOR", np.inf)  # the whole scan
    whole = fitpack.fewest_within(u, points, 3, tol, "max_deviation", closed=closed)
    assert (whole["n_control_points"], whole["s"]) == (answer["n_control_points"], answer["s"])


def test_fewest_within_refuses_an_impossible_tolerance():
    u = parameterize(SPIRAL, "centripetal")
    noisy = SPIRAL + np.random.default_rng(0).normal(0, 1e-2, SPIRAL.shape)
    noisy[10] = noisy[11]  # two equal points at different parameters: no spline within 0
    with pytest.raises(ValueError, match="no spline within the tolerance"):
        fitpack.fewest_within(u, noisy, 3, 0.0, "max_deviation")
