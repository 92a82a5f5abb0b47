"""The knot placement methods from the literature: known answers, open, closed and noisy data,
the tolerance met on the reported knots, bad input, and the registered optimizers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline

import metaknot as mk
from metaknot.algorithms.literature import METHODS, Target
from metaknot.bspline import closed_parameterize, fit_spline, parameterize
from metaknot.bspline.curve import ClosedCurve
from metaknot.problems import FreeKnots, KnotIndices, KnotSelection, PointSet, add_noise, get_curve
from metaknot.suite.functions import KANG_KNOTS, kang_spline, titanium

NAMES = sorted(METHODS)
#: methods that place knots where a derivative jumps (or remove all others)
JUMP_METHODS = ("bisection", "lyche_morken", "sparse_l1")

X = np.linspace(0.0, 1.0, 201)
TWO_PIECES = BSpline(np.r_[[0.0] * 4, 0.4, [1.0] * 4], np.array([0.0, 1.0, -1.0, 2.0, 0.5]),
                     3)(X)


def star(n: int = 200) -> np.ndarray:
    angle = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    radius = 1.0 + 0.25 * np.cos(5 * angle) ** 3
    return np.column_stack((radius * np.cos(angle), radius * np.sin(angle)))


def test_all_six_methods_are_registered():
    assert set(NAMES) == {"newknt", "equidistribution", "dominant_points", "lyche_morken",
                          "bisection", "sparse_l1"}
    assert set(NAMES) <= set(mk.available_optimizers())


@pytest.mark.parametrize("name", NAMES)
def test_a_straight_line_gets_no_interior_knot(name):
    assert METHODS[name](X, 2 * X + 1, 1e-6).knots.size == 0  # function data
    assert METHODS[name](X, np.column_stack((X, 3 * X - 1)), 1e-6).knots.size == 0  # a curve


@pytest.mark.parametrize("name", NAMES)
def test_two_cubic_pieces(name):
    tolerance = 1e-2 * np.ptp(TWO_PIECES)
    found = METHODS[name](X, TWO_PIECES, tolerance)
    assert found.within
    if name in JUMP_METHODS:  # one knot, at the joint
        assert found.knots.size == 1 and abs(found.knots[0] - 0.4) < 0.005
    else:  # equidistribution and dominant points do not look for the joint: a few knots
        assert 1 <= found.knots.size <= 4
    assert METHODS[name](X, TWO_PIECES, 1e-6).knots.size >= 1  # a polynomial will not do


def test_sparse_l1_finds_kangs_true_knots_to_the_sampling_resolution():
    x, y = kang_spline()
    found = METHODS["sparse_l1"](x, y, 1e-3 * np.ptp(y))
    assert found.within
    step = x[1] - x[0]
    for knot in np.unique(KANG_KNOTS):
        assert np.abs(found.knots - knot).min() <= 1.5 * step, knot
    assert found.knots.size <= 2 * len(KANG_KNOTS)


def reported_error(found, u, q, closed):
    fitted = ClosedCurve(u, q, 3).fit(found.knots) if closed else fit_spline(u, q, found.knots, 3)
    return fitted.max_deviation if found.metric == "max_deviation" else fitted.rmse


@pytest.mark.parametrize("name", NAMES)
def test_tolerance_met_on_open_closed_and_noisy_data(name):
    spiral = get_curve("archimedean", n_points=150)
    noisy = add_noise(spiral, 1e-3 * spiral.scale, np.random.SeedSequence(3))
    outline = star()
    cases = [  # (params, points, closed, tolerance, metric)
        (parameterize(spiral.points, "centripetal"), spiral.points, False,
         1e-3 * spiral.scale, "max_deviation"),
        (closed_parameterize(outline), outline, True, 2e-3, "max_deviation"),
        (parameterize(noisy.points, "centripetal"), noisy.points, False,
         1.05 * 1e-3 * spiral.scale * np.sqrt(2), "rmse"),
    ]
    for u, q, closed, tolerance, metric in cases:
        found = METHODS[name](u, q, tolerance, closed=closed, metric=metric)
        assert found.within, (closed, metric, found.reason)
        assert found.fits > 0
        # checked again by a fit of its own, not the method's evaluator
        assert reported_error(found, u, q, closed) == pytest.approx(found.error, rel=1e-6)
        lo, hi = (0.0, 1.0) if closed else (u[0], u[-1])
        assert np.all((found.knots > lo) & (found.knots < hi))
        assert np.all(np.diff(found.knots) > 0)


def test_a_tolerance_out_of_reach_is_said_not_hidden():
    q = add_noise(get_curve("archimedean", n_points=40), 0.01, np.random.SeedSequence(1)).points
    found = METHODS["newknt"](parameterize(q, "centripetal"), q, 1e-30)
    assert not found.within
    assert "below what interpolation reaches" in found.reason


@pytest.mark.parametrize(("change", "message"), [
    ({"tolerance": 0.0}, "tolerance must be a number > 0"),
    ({"tolerance": float("nan")}, "tolerance must be a number > 0"),
    ({"params": X[::-1]}, "params must be finite and strictly increasing"),
    ({"params": X[:10]}, "params must be one value per point"),
    ({"points": np.where(X > 0.5, np.nan, X)}, "points contains NaN or infinite values"),
    ({"points": X[:4]}, "points: a degree-3 fit needs at least 5 points; got 4"),
    ({"metric": "mae"}, "metric must be 'max_deviation' or 'rmse'"),
    ({"closed": True}, "a closed outline's params must start at 0 and stay below 1"),
    ({"degree": 9}, "degree"),
])
def test_bad_input_gets_a_one_line_error(change, message):
    args = {"params": X, "points": TWO_PIECES, "tolerance": 1e-3, "metric": "max_deviation",
            "closed": False, "degree": 3, **change}
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")) \
            as error:
        Target(args.pop("params"), args.pop("points"), args.pop("tolerance"), **args)
    assert "\n" not in str(error.value)


def test_a_feature_equidistribution_does_not_know_is_refused_by_optimizer_and_method():
    with pytest.raises(ValueError, match="feature must be 'derivative' or 'curvature'; got 'slope"):
        mk.get_optimizer("equidistribution", feature="slope")
    with pytest.raises(ValueError, match="feature must be 'derivative' or 'curvature'"):
        METHODS["equidistribution"](X, TWO_PIECES, 1e-3, feature="slope")


def test_the_optimizer_takes_the_problems_tolerance_and_declares_its_fits():
    data = get_curve("archimedean", n_points=120)
    problem = KnotSelection(data, objective="error_bounded",
                            objective_options={"relative_tolerance": 1e-3})
    result = mk.minimize(problem, "bisection", budget=10, seed=0)
    assert result.status == "ok" and result.n_evaluations == 1
    assert result.external_fits > 0 and result.audited_fits <= result.accounted_fits
    n_cp = result.best_f // 1
    assert result.best_f - n_cp <= 1.0  # within the tolerance (error_bounded: CP + err/tol)
    direct = METHODS["bisection"](problem.params, problem.points, 1e-3 * data.scale)
    assert n_cp <= direct.knots.size + 4 + 2  # the knots, snapped to data points


@pytest.mark.parametrize("problem", [
    KnotIndices(PointSet(star(120)), n_knots=9, closed=True),
    FreeKnots(get_curve("archimedean", n_points=80), n_knots=7),
])
def test_a_fixed_count_gets_that_many_knots_closed_and_open(problem):
    result = mk.minimize(problem, "sparse_l1", budget=3, seed=0)
    assert result.status == "ok" and np.isfinite(result.best_f)
    assert np.count_nonzero(~np.isnan(np.asarray(result.best_x, dtype=float))) == \
        problem.n_knots


# --------------------------------------------------------------------------------------------
# metaknot fit: --method NAME, and the literature's knots as starts of its own search


def test_fit_method_name_returns_that_methods_knots_within_the_tolerance():
    points = get_curve("archimedean", n_points=120).points
    result = mk.fit(points, 1e-3, relative=True, method="dominant_points", closed=False)
    direct = METHODS["dominant_points"](result.params, result.points, result.tolerance)
    assert result.method == "dominant_points"
    assert result.n_control_points == direct.knots.size + 4
    assert result.metrics["max_deviation"] <= result.tolerance
    x, y = titanium()  # 49 points with a sharp peak: the classic ranking stops short
    with pytest.raises(ValueError, match="'lyche_morken' does not reach the tolerance: its "
                                         "fit with") as error:
        mk.fit(np.column_stack((x, y)), 1e-3, relative=True, function=True,
               method="lyche_morken")
    assert "\n" not in str(error.value)
    with pytest.raises(ValueError, match=r"or a literature method .*sparse_l1.*; got 'ga'"):
        mk.fit(points, 1e-3, method="ga")


def test_the_cli_help_names_every_literature_method(capsys):
    from metaknot.cli import main

    with pytest.raises(SystemExit):
        main(["fit", "--help"])
    shown = " ".join(capsys.readouterr().out.split())
    assert all(name in shown for name in NAMES)


def test_fit_starts_from_the_literature_knots_and_ends_no_worse(monkeypatch):
    from metaknot.apps import fit as tolerance_fit

    # a cubic spline with three knots off the data grid: bisection's refined knots find them
    knots = np.r_[[0.0] * 4, 0.2113, 0.5071, 0.7519, [1.0] * 4]
    data = np.column_stack((X, BSpline(knots, np.array([0.0, 1, -1, 2, 0.5, 1.5, -0.5]), 3)(X)))
    result = mk.fit(data, 1e-5, relative=True, function=True, method="removal", polish=False)
    assert "literature starts: bisection 7, lyche_morken" in " ".join(result.stages)
    assert result.n_control_points == 7
    monkeypatch.setattr(tolerance_fit, "LITERATURE_STARTS", ())
    without = mk.fit(data, 1e-5, relative=True, function=True, method="removal", polish=False)
    assert without.n_control_points > 7  # the start is what makes the difference
    polished = mk.fit(data, 1e-5, relative=True, function=True, method="removal")
    assert polished.n_control_points == 7  # ... or the polish: free knots find them too


@pytest.mark.parametrize("degree", [1, 2, 3])
def test_bisection_refines_a_single_knot(degree):
    """One knot is refined like several: inside the middle 90 % of its span and no worse than
    where it started (scipy's LSMR trust-region variant raised IndexError on one variable in
    about 40 % of random 8-point data sets; ``metaknot fit`` crashed with it)."""
    from metaknot.algorithms.bisection import refine_knots

    rng = np.random.default_rng(degree)
    for _ in range(25):
        points = rng.standard_normal((8, 2))
        params = parameterize(points, "centripetal")
        target = Target(params, points, 0.5, degree=degree)
        start = np.array([rng.uniform(0.05, 0.95)])
        refined = refine_knots(target, start, 20)
        assert refined.shape == (1,)
        assert 0.55 * start[0] - 1e-12 <= refined[0] <= start[0] + 0.45 * (1.0 - start[0]) + 1e-12
        assert target.error(refined) <= target.error(start)


@pytest.mark.parametrize("degree", [4, 5])
def test_the_equidistribution_pilot_is_fitted_at_high_degrees(degree):
    """The knot density's pilot spline is of degree p + 2 (6 or 7 here: scipy fits it; its
    knots come from the averaging formula of degree 5 at most); it raised "degree must be
    between 1 and 5" before. The density follows the data: it rises where they bend most."""
    from metaknot.algorithms.literature import knot_density

    x = np.linspace(0.0, 1.0, 120)
    y = np.tanh(40 * (x - 0.7))  # a sharp step near 0.7, flat elsewhere
    grid, cumulative = knot_density(x, y, degree, 1.0 / (degree + 1))
    flat, start, end = np.interp([0.5, 0.6, 0.8], grid, cumulative)
    assert (end - start) / 0.2 > 2 * flat / 0.5  # knots per unit length: step vs. flat part
    found = METHODS["equidistribution"](x, y, 1e-2, degree=degree)
    assert found.within


def test_bisection_answers_knots_that_can_be_fitted():
    """Splitting a span at a data point next to a refined knot can leave a span without data
    (a singular fit): such a split is undone. Noisy random data at an unreachable tolerance
    drive the splitting to its end; the answer is fitted (a finite error) every time, where
    about one in ten came back singular before."""
    rng = np.random.default_rng(5)
    for _ in range(150):
        n, degree = int(rng.choice([8, 12, 20])), int(rng.integers(1, 4))
        angle = np.sort(rng.random(n))
        points = np.column_stack((np.cos(angle), np.sin(angle)))
        points += 0.01 * rng.standard_normal((n, 2))
        found = METHODS["bisection"](parameterize(points, "centripetal"), points, 1e-7,
                                     degree=degree)
        assert np.isfinite(found.error), (n, degree, found.knots)


@pytest.mark.parametrize("name", NAMES)
def test_every_answer_can_be_fitted(name):
    """Small noisy sets, open and closed, degrees 1-5, tolerances reachable or not: whatever a
    method answers can be fitted (a finite error; its reason says when it misses the
    tolerance). Sparse selection on closed outlines of degree 4-5 answered two knots where
    p - 1 are needed, before."""
    rng = np.random.default_rng(NAMES.index(name))
    for trial in range(80):
        n, degree, closed = int(rng.choice([8, 12, 20])), int(rng.integers(1, 6)), trial % 2
        s = np.sort(rng.random(n)) if trial % 4 < 2 else np.linspace(0, 1, n,
                                                                     endpoint=not closed)
        points = np.column_stack((np.cos(2 * np.pi * s), np.sin(2 * np.pi * s)))
        points += 0.01 * rng.standard_normal((n, 2))
        params = closed_parameterize(points) if closed else parameterize(points, "centripetal")
        try:
            found = METHODS[name](params, points, float(rng.choice([1e-7, 1e-3, 1e-2])),
                                  degree=degree, closed=bool(closed))
        except ValueError as error:
            assert "fit needs at least" in str(error)
            continue
        assert np.isfinite(found.error), (n, degree, closed, found.knots)


def newnot_as_published(breaks, jumps_source, k, count):
    """NEWNOT as A Practical Guide to Splines prints it, for a function: ``jumps_source[i]``
    is the (k-1)st derivative on interval i; returns the ``count`` new interior breaks."""
    spans = breaks.size - 1
    slope = np.empty(spans)
    g = np.zeros(spans + 1)
    previous = abs(jumps_source[1] - jumps_source[0]) / (breaks[2] - breaks[0])
    for i in range(1, spans):  # the Fortran loop i = 2..spans
        current = abs(jumps_source[i] - jumps_source[i - 1]) / (breaks[i + 1] - breaks[i - 1])
        slope[i - 1] = (current + previous) ** (1.0 / k)
        g[i] = g[i - 1] + slope[i - 1] * (breaks[i] - breaks[i - 1])
        previous = current
    slope[spans - 1] = (2.0 * previous) ** (1.0 / k)
    g[spans] = g[spans - 1] + slope[spans - 1] * (breaks[spans] - breaks[spans - 1])
    step = g[spans] / (count + 1)
    if step <= 0:
        return breaks[0] + np.arange(1, count + 1) * (breaks[-1] - breaks[0]) / (count + 1)
    out, j = [], 0
    for i in range(1, count + 1):
        level = i * step
        while j < spans - 1 and level > g[j + 1]:
            j += 1
        out.append(0.5 * (breaks[j] + breaks[j + 1]) if slope[j] == 0 else
                   breaks[j] + (level - g[j]) / slope[j])
    return np.array(out)


@pytest.mark.parametrize("degree", [1, 2, 3, 4])
def test_newnot_without_a_floor_is_de_boors_newnot(degree):
    """floor=0: the knots NEWNOT computes from the same pilot fit, to rounding; with the
    default floor they move towards uniform (a little)."""
    from metaknot.algorithms.newknt import newnot

    x, y = titanium()
    target = Target(x, y, 1.0, degree=degree)
    knots = np.linspace(x[0], x[-1], 9)[1:-1]
    pilot = target.fit(knots)
    breaks = np.concatenate(([x[0]], knots, [x[-1]]))
    derivative = pilot.spline.derivative(degree)(0.5 * (breaks[1:] + breaks[:-1])).ravel()
    expected = newnot_as_published(breaks, derivative, degree + 1, knots.size)
    np.testing.assert_allclose(newnot(target, knots, floor=0.0), expected, rtol=0, atol=1e-9)
    floored = newnot(target, knots)
    assert 0 < np.abs(floored - expected).max() < 0.05 * np.ptp(x)


def test_newnot_with_zero_density_is_uniform_and_skips_flat_spans():
    from metaknot.algorithms.newknt import _inverse

    breaks = np.array([0.0, 1.0, 2.0, 4.0])
    np.testing.assert_allclose(_inverse(breaks, np.zeros(3), 3), [1.0, 2.0, 3.0])
    # g rises on the first and last spans only: no new knot lands inside the flat one
    np.testing.assert_allclose(_inverse(breaks, np.array([1.0, 0.0, 0.5]), 3),
                               [0.5, 1.0, 3.0])
