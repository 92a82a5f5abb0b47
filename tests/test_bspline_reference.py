"""The B-spline machinery against independent references (scipy, numpy, closed forms).

Reference fits use :func:`scipy.interpolate.make_lsq_spline` on a knot vector built here by
hand; feasibility is checked against the column rank of scipy's collocation matrix
(:meth:`scipy.interpolate.BSpline.design_matrix`) computed with numpy.

Tolerances
----------
Sums of squared errors are compared as ``|sse - ref| <= 1e-9 * ref + sse_floor(ref)``. The
floor is a roundoff floor: the fitted residual vector carries a rounding error of norm about
``delta = eps * sqrt(N) * max|q|`` (one unit of rounding per coordinate), so its squared norm
carries ``2 * |r| * delta + delta**2``. Calibration on the seed curves (degrees 1-5, masks of
density 0.05-0.9): where the collocation matrix has a condition number below 1e12, scipy and a
dense ``numpy.linalg.lstsq`` on the collocation matrix differ by at most 0.03 of this floor, and
so does the compiled kernel against scipy; the typical relative agreement is 1e-12. The largest
point distance is compared with an absolute floor of ``16 * eps * max|q|`` (measured below a
condition number of 1e10: up to ``0.9 * eps * max|q|`` for the kernel against scipy, up to
``8 * eps * max|q|`` between scipy and numpy).

A least-squares reference is only meaningful when the problem is numerically well posed, so a
disagreement with scipy counts where the collocation matrix has a condition number of at most
``1e10`` (above about ``1e16`` scipy's own fits are wrong by many orders of magnitude). Every
feasible fit, however conditioned, is also checked without a reference: its collocation matrix
must have full numerical rank, its SSE can never exceed that of a fit in a smaller spline space
(a subset of the knots, or a constant), and its largest point distance and the spline
:func:`fit_spline` returns for the same knots must agree with its SSE.
"""

from __future__ import annotations

import itertools

import numba
import numpy as np
import pytest
from scipy.interpolate import BSpline, make_lsq_spline

from metaknot.bspline import (
    Infeasibility,
    averaging_knots,
    clamped_knot_vector,
    fit_spline,
    parameterize,
)
from metaknot.bspline.curve import OpenCurve
from metaknot.problems import get_curve

EPS = np.finfo(np.float64).eps
REL = 1e-9
COND_MAX = 1e10
DENSE_POINTS = {"epitrochoid": 121, "archimedean": 100, "vivaldi": 121}
CURVES = ("epitrochoid", "archimedean", "vivaldi")
DEGREES = (1, 2, 3, 4, 5)


# --------------------------------------------------------------------------------------------
# helpers (independent of the code under test)


@pytest.fixture(scope="module")
def curves() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    out = {}
    for name in CURVES:
        q = np.asarray(get_curve(name).points, dtype=np.float64)
        out[name] = (parameterize(q, "centripetal"), q)
    return out


def knot_vector(u: np.ndarray, interior: np.ndarray, p: int) -> np.ndarray:
    """Clamped knot vector built by hand (not with the package's helper)."""
    return np.concatenate((np.full(p + 1, u[0]), np.sort(interior), np.full(p + 1, u[-1])))


def collocation(u: np.ndarray, interior: np.ndarray, p: int) -> np.ndarray:
    return BSpline.design_matrix(u, knot_vector(u, interior, p), p).toarray()


def scipy_fit(u, q, interior, p):
    """(sse, max point distance, spline) of scipy's least-squares spline."""
    spl = make_lsq_spline(u, q, knot_vector(u, interior, p), k=p)
    dist = np.linalg.norm(np.reshape(spl(u), q.shape) - q, axis=1)
    return float(dist @ dist), float(dist.max()), spl


def sse_floor(ref: float, q: np.ndarray) -> float:
    delta = EPS * np.sqrt(q.shape[0]) * np.abs(q).max()
    return delta * (2.0 * np.sqrt(max(ref, 0.0)) + delta)


def maxdev_floor(q: np.ndarray) -> float:
    return 16.0 * EPS * np.abs(q).max()


def assert_matches_scipy(u, q, p, interiors, fit, label):
    """Compare every feasible candidate with scipy; return how many were compared.

    A disagreement counts only where the collocation matrix is well conditioned (condition
    number <= ``COND_MAX``); elsewhere the reference itself is not trustworthy and the candidate
    is skipped. (The condition number is computed for disagreements only: SVDs are costly.)
    """
    compared = 0
    problems = []
    for b, interior in enumerate(interiors):
        if not fit.feasible[b]:
            continue
        ref_sse, ref_dev, _ = scipy_fit(u, q, interior, p)
        found = []
        if abs(fit.sse[b] - ref_sse) > REL * ref_sse + sse_floor(ref_sse, q):
            found.append(f"sse {fit.sse[b]!r} vs scipy {ref_sse!r}")
        if abs(fit.max_deviation[b] - ref_dev) > REL * ref_dev + maxdev_floor(q):
            found.append(f"max_dev {fit.max_deviation[b]!r} vs scipy {ref_dev!r}")
        if found:
            cond = np.linalg.cond(collocation(u, interior, p))
            if cond > COND_MAX:
                continue
            problems.append(f"{label}[{b}] (cond {cond:.1e}): " + "; ".join(found))
        compared += 1
    assert not problems, "\n".join(problems)
    return compared


# --------------------------------------------------------------------------------------------
# batched evaluators against scipy on the seed curves


@pytest.mark.parametrize("degree", DEGREES)
@pytest.mark.parametrize("name", CURVES)
def test_evaluate_masks_matches_scipy(curves, name, degree):
    u, q = curves[name]
    rng = np.random.default_rng(1000 + 10 * CURVES.index(name) + degree)
    densities = np.repeat([0.05, 0.2, 0.5, 0.8], 6)
    masks = rng.random((densities.size, u.size - 2)) < densities[:, None]
    fit = OpenCurve(u, q, degree).evaluate_masks(masks)
    assert len(fit) == masks.shape[0]
    np.testing.assert_array_equal(fit.n_control_points, masks.sum(axis=1) + degree + 1)
    interiors = [u[1:-1][m] for m in masks]
    compared = assert_matches_scipy(u, q, degree, interiors, fit, "mask")
    # knots at data parameters never violate Schoenberg-Whitney when n <= N; dense masks may
    # be numerically singular
    assert set(fit.reason) <= {Infeasibility.FEASIBLE, Infeasibility.SINGULAR}
    assert compared >= 0.75 * masks.shape[0]


@pytest.mark.parametrize("degree", DEGREES)
@pytest.mark.parametrize("name", CURVES)
def test_evaluate_indices_matches_scipy(curves, name, degree):
    u, q = curves[name]
    n = u.size
    rng = np.random.default_rng(2000 + 10 * CURVES.index(name) + degree)
    rows = []
    for k in (1, 3, n // 10, n // 3):
        for _ in range(3):
            rows.append(rng.choice(np.arange(1, n - 1), size=k, replace=False))
    fits = []
    for k in sorted({r.size for r in rows}):
        batch = np.array([r for r in rows if r.size == k])  # rows deliberately unsorted
        fit = OpenCurve(u, q, degree).evaluate_indices(batch)
        np.testing.assert_array_equal(fit.n_control_points, k + degree + 1)
        interiors = [u[np.sort(r)] for r in batch]
        fits.append(assert_matches_scipy(u, q, degree, interiors, fit, f"indices K={k}"))
        assert set(fit.reason) <= {Infeasibility.FEASIBLE, Infeasibility.SINGULAR}
        # the same knots as masks give the same numbers
        masks = np.zeros((batch.shape[0], n - 2), dtype=bool)
        masks[np.arange(batch.shape[0])[:, None], batch - 1] = True
        as_masks = OpenCurve(u, q, degree).evaluate_masks(masks)
        np.testing.assert_array_equal(as_masks.sse, fit.sse)
        np.testing.assert_array_equal(as_masks.max_deviation, fit.max_deviation)
    assert sum(fits) >= 0.75 * len(rows)


@pytest.mark.parametrize("degree", DEGREES)
@pytest.mark.parametrize("name", CURVES)
def test_evaluate_positions_matches_scipy(curves, name, degree):
    u, q = curves[name]
    n = u.size
    rng = np.random.default_rng(3000 + 10 * CURVES.index(name) + degree)
    compared = 0
    feasible = 0
    for k in (2, n // 12, n // 5):
        # uniformly random positions, and data parameters jittered within their gaps
        uniform = rng.uniform(u[0], u[-1], size=(4, k))
        idx = np.array([rng.choice(np.arange(1, n - 1), size=k, replace=False) for _ in range(4)])
        jitter = u[idx] + rng.uniform(-0.4, 0.4, size=idx.shape) * np.diff(u).min()
        batch = np.vstack((uniform, jitter))  # rows deliberately unsorted
        fit = OpenCurve(u, q, degree).evaluate_positions(batch)
        np.testing.assert_array_equal(fit.n_control_points, k + degree + 1)
        compared += assert_matches_scipy(u, q, degree, list(batch), fit, f"positions K={k}")
        feasible += int(fit.feasible.sum())
        for b in np.flatnonzero(~fit.feasible):
            # only Schoenberg-Whitney (or singular) failures are possible for these knots; an
            # exactly rank-deficient collocation matrix confirms a Schoenberg-Whitney report
            assert fit.reason[b] in (Infeasibility.SCHOENBERG_WHITNEY, Infeasibility.SINGULAR)
            if fit.reason[b] == Infeasibility.SCHOENBERG_WHITNEY:
                a = collocation(u, batch[b], degree)
                assert np.linalg.matrix_rank(a) < a.shape[1]
    assert feasible >= 12
    assert compared >= 0.75 * feasible


def test_results_do_not_depend_on_threads(curves):
    """One thread and all threads give bit-identical results (no races between chunks)."""
    u, q = curves["epitrochoid"]
    rng = np.random.default_rng(98)
    masks = rng.random((200, u.size - 2)) < rng.uniform(0.02, 0.9, (200, 1))
    pos = rng.uniform(-0.05, 1.05, (200, 25))
    old = numba.get_num_threads()
    try:
        results = []
        for threads in sorted({1, numba.config.NUMBA_NUM_THREADS}):
            numba.set_num_threads(threads)
            results.append([OpenCurve(u, q, 3).evaluate_masks(masks),
                            OpenCurve(u, q, 4).evaluate_positions(pos)])
    finally:
        numba.set_num_threads(old)
    for a, b in zip(results[0], results[-1], strict=True):
        np.testing.assert_array_equal(a.sse, b.sse)
        np.testing.assert_array_equal(a.max_deviation, b.max_deviation)
        np.testing.assert_array_equal(a.reason, b.reason)


def test_max_deviation_pass_is_optional(curves):
    """Skipping the maximum-deviation pass leaves every other number unchanged."""
    u, q = curves["vivaldi"]
    rng = np.random.default_rng(99)
    masks = rng.random((10, u.size - 2)) < 0.3
    idx = np.sort(rng.choice(np.arange(1, u.size - 1), size=(1, 12), replace=False), axis=1)
    pos = np.vstack((rng.uniform(0.0, 1.0, (4, 12)), [[np.nan] * 12]))
    curve = OpenCurve(u, q, 3)
    for evaluate, x in ((curve.evaluate_masks, masks), (curve.evaluate_indices, idx),
                        (curve.evaluate_positions, pos)):
        full = evaluate(x)
        lean = evaluate(x, max_deviation=False)
        assert lean.max_deviation is None
        assert full.max_deviation is not None and full.max_deviation.shape == (x.shape[0],)
        np.testing.assert_array_equal(lean.sse, full.sse)
        np.testing.assert_array_equal(lean.reason, full.reason)
        np.testing.assert_array_equal(lean.n_control_points, full.n_control_points)


# --------------------------------------------------------------------------------------------
# reference-free bounds for every feasible fit (dense masks: ill-conditioned systems)


def rank_and_cond(a: np.ndarray) -> tuple[int, float]:
    """Numerical rank (numpy's default tolerance ``s_max * max(shape) * eps``) and condition."""
    s = np.linalg.svd(a, compute_uv=False)
    rank = int(np.sum(s > s[0] * max(a.shape) * EPS))
    return rank, (s[0] / s[-1] if s[-1] > 0 else np.inf)


def least_squares_bound_violations(u, q, p, interiors, fit, bounds) -> list[str]:
    """Checks of every feasible candidate of ``fit`` that need no reference fit.

    * the collocation matrix has full numerical rank (else the system is numerically singular
      and must be reported as ``SINGULAR``);
    * ``sse <= bounds[b]``: the SSE of a least-squares fit is at most that of any fit in a
      smaller spline space (``bounds`` holds such SSEs);
    * ``max_deviation <= sqrt(sse)`` and :func:`fit_spline` with the same knots (the spline a
      knot problem's ``decode`` returns) has the SSE the batch reported -- up to the error of
      fitted points computed from control points, ``16 * eps * cond * max|q|`` per point.
    """
    problems = []
    n_pts = q.shape[0]
    for b in np.flatnonzero(fit.feasible):
        sse, dev, bound = fit.sse[b], fit.max_deviation[b], bounds[b]
        n_ctrl = int(fit.n_control_points[b])
        rank, cond = rank_and_cond(collocation(u, interiors[b], p))
        point_err = 16.0 * EPS * cond * np.abs(q).max()
        single = fit_spline(u, q, interiors[b], p)
        found = []
        if rank < n_ctrl:
            found.append(f"numerically singular (rank {rank} < {n_ctrl})")
        if not sse <= bound * (1 + REL) + sse_floor(bound, q):
            found.append(f"sse {sse:.3e} > sse {bound:.3e} of a smaller spline space")
        if not dev <= np.sqrt(sse) * (1 + REL) + point_err + maxdev_floor(q):
            found.append(f"max_deviation {dev:.3e} > sqrt(sse) {np.sqrt(sse):.3e}")
        gap = abs(np.sqrt(single.sse) - np.sqrt(sse))
        if not gap <= REL * np.sqrt(sse) + np.sqrt(n_pts) * point_err + np.sqrt(sse_floor(0, q)):
            found.append(f"fit_spline gives sse {single.sse:.3e}, the batch {sse:.3e}")
        if found:
            problems.append(
                f"candidate {b} ({n_ctrl} control points, cond(collocation) = {cond:.1e}) "
                "reported feasible: " + "; ".join(found)
            )
    return problems


@pytest.mark.parametrize("degree", DEGREES)
@pytest.mark.parametrize("name", CURVES)
def test_feasible_dense_masks_obey_least_squares_bounds(name, degree):
    """Every fit reported feasible is a least-squares fit (see
    :func:`least_squares_bound_violations`; the smaller spaces are constants and every second
    knot dropped).

    Dense masks (80-95 % of the points are knots) make the collocation matrix badly conditioned;
    the evaluator must either fit such a candidate correctly or report it as infeasible
    (``SINGULAR``), never return meaningless numbers as feasible. The curves are sampled at
    about 100 points here, which keeps the SVDs cheap.
    """
    q = np.asarray(get_curve(name, n_points=DENSE_POINTS[name]).points, dtype=np.float64)
    u = parameterize(q, "centripetal")
    rng = np.random.default_rng(4000 + 10 * CURVES.index(name) + degree)
    densities = np.repeat([0.5, 0.8, 0.9, 0.95], 8)
    masks = rng.random((densities.size, u.size - 2)) < densities[:, None]
    coarse = masks.copy()
    for b in range(masks.shape[0]):
        coarse[b, np.flatnonzero(masks[b])[1::2]] = False  # drop every second knot
    fit = OpenCurve(u, q, degree).evaluate_masks(masks)
    coarse_fit = OpenCurve(u, q, degree).evaluate_masks(coarse)
    sse_const = float(np.sum((q - q.mean(axis=0)) ** 2))
    bounds = np.where(coarse_fit.feasible, np.minimum(coarse_fit.sse, sse_const), sse_const)
    interiors = [u[1:-1][m] for m in masks]
    problems = least_squares_bound_violations(u, q, degree, interiors, fit, bounds)
    assert not problems, "\n".join(problems)


# --------------------------------------------------------------------------------------------
# feasibility and reason codes against the collocation matrix's rank (small data)


def _applicable_reasons(u: np.ndarray, row: np.ndarray, p: int) -> set[Infeasibility]:
    """Structural reasons (not rank) that make a knot row infeasible, from first principles."""
    reasons = set()
    if row.size + p + 1 > u.size:
        reasons.add(Infeasibility.TOO_MANY_CONTROL_POINTS)
    if not np.all((row > u[0]) & (row < u[-1])):  # NaN compares False
        reasons.add(Infeasibility.KNOT_OUT_OF_RANGE)
    if np.any(np.diff(np.sort(row)) == 0):
        reasons.add(Infeasibility.COINCIDENT_KNOTS)
    return reasons


def _check_feasibility(u, p, rows, fit, label):
    """``fit.feasible`` equals full column rank of the collocation matrix.

    Numerical rank is numpy's (singular values above ``s_max * max(shape) * eps``). Between a
    condition number of ``1e10`` and numerical rank deficiency the evaluator may also report the
    system as numerically singular (its documented ``SINGULAR`` code).
    """
    counts = {"feasible": 0, "deficient": 0, "structural": 0}
    problems = []
    for b, row in enumerate(rows):
        reason = Infeasibility(int(fit.reason[b]))
        assert not np.isnan(fit.sse[b]) and not np.isnan(fit.max_deviation[b])
        if fit.feasible[b]:
            assert np.isfinite(fit.sse[b]) and np.isfinite(fit.max_deviation[b])
        else:
            assert fit.sse[b] == np.inf and fit.max_deviation[b] == np.inf
        structural = _applicable_reasons(u, row, p)
        if structural:
            counts["structural"] += 1
            if reason not in structural:
                problems.append(f"{label}[{b}] {row}: reason {reason!r}, expected {structural}")
            continue
        a = collocation(u, row, p)
        rank, cond = rank_and_cond(a)
        full = rank == a.shape[1]
        if not full:
            counts["deficient"] += 1
            ok = reason in (Infeasibility.SCHOENBERG_WHITNEY, Infeasibility.SINGULAR)
        elif cond <= COND_MAX:
            counts["feasible"] += 1
            ok = reason == Infeasibility.FEASIBLE
        else:
            ok = reason in (Infeasibility.FEASIBLE, Infeasibility.SINGULAR)
        if reason == Infeasibility.SCHOENBERG_WHITNEY and full:
            ok = False
        if not ok:
            problems.append(
                f"{label}[{b}] p={p} knots={row!r}: reason {reason!r} but collocation matrix "
                f"{'has full rank' if full else 'is rank deficient'} (cond {cond:.2e})"
            )
    assert not problems, "\n".join(problems)
    return counts


def _small_data(rng: np.random.Generator):
    n = int(rng.integers(8, 16))
    p = int(rng.integers(1, 6))
    gaps = rng.uniform(0.2, 1.0, n - 1)
    lo, hi = sorted(rng.uniform(-5.0, 5.0, 2))
    u = np.concatenate(([0.0], np.cumsum(gaps)))
    u = lo + (hi - lo + 0.5) * u / u[-1]
    q = rng.normal(size=(n, int(rng.integers(1, 4))))
    return u, q, p


@pytest.mark.parametrize("seed", range(4))
def test_feasibility_matches_collocation_rank(seed):
    rng = np.random.default_rng(5000 + seed)
    totals = {"feasible": 0, "deficient": 0, "structural": 0}
    for _ in range(30):
        u, q, p = _small_data(rng)
        n = u.size
        b = 40
        # masks
        masks = rng.random((b, n - 2)) < rng.random((b, 1))
        fit = OpenCurve(u, q, p).evaluate_masks(masks)
        np.testing.assert_array_equal(fit.n_control_points, masks.sum(axis=1) + p + 1)
        counts = _check_feasibility(u, p, [u[1:-1][m] for m in masks], fit, "mask")
        # data indices, repetitions allowed (coincident knots)
        k = int(rng.integers(1, n - 1))
        idx = rng.integers(1, n - 1, size=(b, k))
        fit = OpenCurve(u, q, p).evaluate_indices(idx)
        c2 = _check_feasibility(u, p, list(u[idx]), fit, "indices")
        # continuous positions: random, snapped to data parameters (including the ends),
        # slightly out of range, exact duplicates and NaN
        k = int(rng.integers(1, n - p))
        span = u[-1] - u[0]
        pos = rng.uniform(u[0] - 0.05 * span, u[-1] + 0.05 * span, size=(b, k))
        snap = rng.random((b, k)) < 0.3
        pos[snap] = u[rng.integers(0, n, size=int(snap.sum()))]
        if k > 1:
            pos[: b // 8, 1] = pos[: b // 8, 0]
        pos[b // 8 : b // 6, 0] = np.nan
        fit = OpenCurve(u, q, p).evaluate_positions(pos)
        c3 = _check_feasibility(u, p, list(pos), fit, "positions")
        for c in (counts, c2, c3):
            for key, v in c.items():
                totals[key] += v
    # every class was exercised
    assert min(totals.values()) >= 20, totals


def test_reason_codes_for_constructed_cases():
    n, p = 12, 3
    u = np.linspace(0.0, 1.0, n)
    q = np.column_stack((np.cos(3 * u), np.sin(3 * u)))
    r = Infeasibility

    # too many control points: all N - 2 interior points as knots give N + p - 1 > N
    fit = OpenCurve(u, q, p).evaluate_masks(np.ones((1, n - 2), dtype=bool))
    assert fit.reason[0] == r.TOO_MANY_CONTROL_POINTS
    fit = OpenCurve(u, q, p).evaluate_indices(np.arange(1, n - p + 1)[None, :])  # N - p knots
    assert fit.reason[0] == r.TOO_MANY_CONTROL_POINTS
    assert fit.n_control_points[0] == n + 1

    # coincident knots: a repeated index, equal positions
    fit = OpenCurve(u, q, p).evaluate_indices([[3, 5, 3], [4, 4, 4]])
    assert list(fit.reason) == [r.COINCIDENT_KNOTS] * 2
    fit = OpenCurve(u, q, p).evaluate_positions([[0.5, 0.5, 0.7], [0.2, 0.7, 0.2]])
    assert list(fit.reason) == [r.COINCIDENT_KNOTS] * 2

    # out of range: on the ends, outside, NaN, infinite
    bad = [[0.0, 0.5], [0.5, 1.0], [-0.1, 0.5], [0.5, 1.5], [np.nan, 0.5], [0.5, np.inf],
           [-np.inf, 0.5]]
    fit = OpenCurve(u, q, p).evaluate_positions(bad)
    assert list(fit.reason) == [r.KNOT_OUT_OF_RANGE] * len(bad)

    # Schoenberg-Whitney: five knots inside one data gap leave a basis function without data
    sw = np.array([[0.46, 0.47, 0.48, 0.49, 0.5]])
    assert np.linalg.matrix_rank(collocation(u, sw[0], p)) < sw.shape[1] + p + 1
    fit = OpenCurve(u, q, p).evaluate_positions(sw)
    assert fit.reason[0] == r.SCHOENBERG_WHITNEY

    # the batch as a whole: infeasible -> inf (never NaN), feasible -> finite
    good = [[0.3, 0.6, np.nan], [0.25, 0.5, 0.75]]
    fit = OpenCurve(u, q, p).evaluate_positions(good)
    assert list(fit.reason) == [r.KNOT_OUT_OF_RANGE, r.FEASIBLE]
    assert fit.sse[0] == np.inf and fit.max_deviation[0] == np.inf
    assert np.isfinite(fit.sse[1]) and np.isfinite(fit.max_deviation[1])
    assert list(fit.feasible) == [False, True]
    for code in r:
        assert isinstance(code.message, str) and code.message


def test_infeasible_batches_never_nan():
    """A large batch of malformed knot rows: every row gets inf (not NaN) and no crash."""
    rng = np.random.default_rng(6)
    n = 30
    u = np.sort(rng.uniform(0.0, 1.0, n))
    q = rng.normal(size=(n, 2))
    pool = np.concatenate((u, u, [np.nan, np.inf, -np.inf, -1.0, 2.0, u[0], u[-1]]))
    for p in DEGREES:
        for k in (1, 5, n - p - 1, n, 2 * n):
            pos = rng.choice(pool, size=(64, k))
            fit = OpenCurve(u, q, p).evaluate_positions(pos)
            assert not np.isnan(fit.sse).any() and not np.isnan(fit.max_deviation).any()
            assert np.array_equal(np.isinf(fit.sse), ~fit.feasible)
            assert np.array_equal(np.isinf(fit.max_deviation), ~fit.feasible)
            assert (fit.sse[fit.feasible] >= 0).all()


# --------------------------------------------------------------------------------------------
# fit_spline


@pytest.mark.parametrize("degree", DEGREES)
@pytest.mark.parametrize("name", CURVES)
def test_fit_spline_matches_scipy_and_numpy(curves, name, degree):
    u, q = curves[name]
    n = u.size
    interior = averaging_knots(u, n // 6, degree)
    fit = fit_spline(u, q, interior, degree)
    t = knot_vector(u, interior, degree)
    ref_sse, ref_dev, ref = scipy_fit(u, q, interior, degree)

    assert isinstance(fit.spline, BSpline)
    assert fit.degree == degree
    np.testing.assert_array_equal(fit.knots, t)
    np.testing.assert_array_equal(fit.interior_knots, interior)
    assert fit.n_control_points == interior.size + degree + 1
    assert fit.control_points.shape == (interior.size + degree + 1, q.shape[1])
    scale = np.abs(ref.c).max()
    np.testing.assert_allclose(fit.control_points, ref.c, rtol=0, atol=1e-9 * scale)

    # metrics by direct numpy computation from the returned control points
    a = BSpline.design_matrix(u, t, degree).toarray()
    dist = np.linalg.norm(q - a @ fit.control_points, axis=1)
    sse = float(dist @ dist)
    expected = {
        "n_control_points": interior.size + degree + 1,
        "sse": sse,
        "rmse": np.sqrt(sse / n),
        "euclidean_distance": np.sqrt(sse),
        "max_deviation": dist.max(),
    }
    metrics = fit.metrics
    assert set(metrics) == set(expected)
    assert metrics["n_control_points"] == expected["n_control_points"]
    for key in ("sse", "rmse", "euclidean_distance", "max_deviation"):
        assert getattr(fit, key) == metrics[key]
    assert abs(fit.sse - sse) <= REL * sse + sse_floor(sse, q)
    assert fit.rmse == pytest.approx(np.sqrt(sse / n), rel=REL, abs=np.sqrt(sse_floor(0, q) / n))
    assert fit.euclidean_distance == pytest.approx(np.sqrt(sse), rel=REL,
                                                   abs=np.sqrt(sse_floor(0, q)))
    assert fit.max_deviation == pytest.approx(dist.max(), rel=REL, abs=maxdev_floor(q))
    np.testing.assert_allclose(fit.residuals, dist, rtol=REL, atol=maxdev_floor(q))
    # ...and against scipy's own fit
    assert abs(fit.sse - ref_sse) <= REL * ref_sse + sse_floor(ref_sse, q)
    assert abs(fit.max_deviation - ref_dev) <= REL * ref_dev + maxdev_floor(q)
    # ...and against the batched evaluator for the same knots
    batch = OpenCurve(u, q, degree).evaluate_positions(interior[None, :])
    assert batch.feasible[0]
    assert abs(batch.sse[0] - fit.sse) <= REL * fit.sse + sse_floor(fit.sse, q)


@pytest.mark.parametrize(
    ("interior", "message"),
    [
        ([0.46, 0.47, 0.48, 0.49, 0.5], "Schoenberg-Whitney"),
        ([0.5, 0.5], "coincident"),
        ([0.6, 0.3], "coincident"),
        ([0.0, 0.5], "outside the open parameter range"),
        ([0.5, 1.0], "outside the open parameter range"),
        ([0.5, 1.5], "outside the open parameter range"),
        ([np.nan], "not finite"),
        ([0.5, np.inf], "not finite"),
        (np.linspace(0.05, 0.95, 9), "more control points than data points"),
    ],
)
def test_fit_spline_rejects_infeasible_knots(interior, message):
    n, p = 12, 3
    u = np.linspace(0.0, 1.0, n)
    q = np.column_stack((u, u**2))
    with pytest.raises(ValueError, match=message):
        fit_spline(u, q, interior, p)


# --------------------------------------------------------------------------------------------
# parameterization, knot vectors, averaging knots


def test_parameterize_closed_forms():
    pts = np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 5.0]])  # chord lengths 5 and 1
    np.testing.assert_allclose(parameterize(pts, "uniform", degree=1), [0.0, 0.5, 1.0])
    np.testing.assert_allclose(parameterize(pts, "chord", degree=1), [0.0, 5 / 6, 1.0],
                               rtol=1e-15)
    s5 = np.sqrt(5.0)
    np.testing.assert_allclose(parameterize(pts, "centripetal", degree=1),
                               [0.0, s5 / (s5 + 1.0), 1.0], rtol=1e-15)

    pts3 = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 2.0], [1.0, 2.0, 6.0], [1.0, 2.0, 7.0]])
    # chord lengths 3, 4, 1
    np.testing.assert_allclose(parameterize(pts3, "chord", degree=2), [0, 3 / 8, 7 / 8, 1],
                               rtol=1e-15)
    total = np.sqrt(3.0) + 2.0 + 1.0
    np.testing.assert_allclose(parameterize(pts3, "centripetal", degree=2),
                               [0, np.sqrt(3.0) / total, (np.sqrt(3.0) + 2) / total, 1],
                               rtol=1e-15)
    np.testing.assert_allclose(parameterize(pts3, "uniform", degree=2), [0, 1 / 3, 2 / 3, 1],
                               rtol=1e-15)
    # default method is centripetal; end values are exactly 0 and 1
    u = parameterize(pts3, degree=2)
    assert u[0] == 0.0 and u[-1] == 1.0
    np.testing.assert_allclose(u, parameterize(pts3, "centripetal", degree=2), rtol=0, atol=0)


def test_parameterize_passes_explicit_values_through():
    pts = np.array([[0.0, 1.0], [0.0, 1.0], [2.0, 0.0], [5.0, 5.0]])  # duplicates are fine here
    x = [-2.0, 0.5, 0.75, 7.0]
    u = parameterize(pts, x, degree=2)
    assert u.dtype == np.float64 and u.shape == (4,)
    np.testing.assert_array_equal(u, x)
    np.testing.assert_array_equal(parameterize(pts, np.array(x), degree=2), x)


@pytest.mark.parametrize("name", CURVES)
def test_parameterize_seed_curves(name):
    q = np.asarray(get_curve(name).points)
    for method in ("uniform", "chord", "centripetal"):
        u = parameterize(q, method)
        assert u.shape == (q.shape[0],)
        assert u[0] == 0.0 and u[-1] == 1.0
        assert (np.diff(u) > 0).all()
    # chord parameter increments are proportional to the chord lengths
    chords = np.sqrt(((q[1:] - q[:-1]) ** 2).sum(axis=1))
    np.testing.assert_allclose(np.diff(parameterize(q, "chord")), chords / chords.sum(),
                               rtol=1e-12)


def test_clamped_knot_vector():
    u = np.array([0.0, 0.2, 0.5, 0.9, 1.0])
    for p in DEGREES:
        np.testing.assert_array_equal(
            clamped_knot_vector(u, [0.3, 0.6], p), [0.0] * (p + 1) + [0.3, 0.6] + [1.0] * (p + 1)
        )
    np.testing.assert_array_equal(clamped_knot_vector(u, [], 2), [0, 0, 0, 1, 1, 1])
    for bad, msg in [([0.0], "inside"), ([1.0], "inside"), ([0.6, 0.3], "increasing"),
                     ([0.3, 0.3], "increasing"), ([np.nan], "NaN")]:
        with pytest.raises(ValueError, match=msg):
            clamped_knot_vector(u, bad, 3)


def test_averaging_knots_by_hand():
    """NURBS Book eqs. 9.68-9.69: d = (m+1)/(n-p+1), u_{p+j} = (1-a) ub_{i-1} + a ub_i."""
    ub = np.array([0.0, 0.1, 0.3, 0.4, 0.6, 0.8, 1.0])  # m + 1 = 7 data parameters
    # p = 2, two interior knots: n = 4, d = 7/3
    #   j = 1: jd = 7/3  -> i = 2, a = 1/3 -> 2/3 * 0.1 + 1/3 * 0.3 = 1/6
    #   j = 2: jd = 14/3 -> i = 4, a = 2/3 -> 1/3 * 0.4 + 2/3 * 0.6 = 8/15
    np.testing.assert_allclose(averaging_knots(ub, 2, 2), [1 / 6, 8 / 15], rtol=1e-14)
    # p = 2, four interior knots: n = 6 = m, d = 7/5
    #   jd = 1.4, 2.8, 4.2, 5.6 -> i = 1, 2, 4, 5; a = 0.4, 0.8, 0.2, 0.6
    expected = [0.4 * 0.1, 0.2 * 0.1 + 0.8 * 0.3, 0.8 * 0.4 + 0.2 * 0.6, 0.4 * 0.6 + 0.6 * 0.8]
    np.testing.assert_allclose(averaging_knots(ub, 4, 2), expected, rtol=1e-13)
    # p = 3, one interior knot: d = 7/2, i = 3, a = 1/2 -> (0.3 + 0.4) / 2
    np.testing.assert_allclose(averaging_knots(ub, 1, 3), [0.35], rtol=1e-14)
    assert averaging_knots(ub, 0, 3).shape == (0,)
    with pytest.raises(ValueError, match="n_interior"):
        averaging_knots(ub, 5, 2)  # n = 7 > m = 6
    with pytest.raises(ValueError, match="n_interior"):
        averaging_knots(ub, -1, 2)


@pytest.mark.parametrize("seed", range(3))
def test_averaging_knots_leave_data_in_every_span(seed):
    """The book's guarantee: every knot span holds a data parameter, so the fit is feasible."""
    rng = np.random.default_rng(7000 + seed)
    for _ in range(20):
        n = int(rng.integers(7, 60))
        p = int(rng.integers(1, 6))
        u = np.concatenate(([0.0], np.cumsum(rng.uniform(0.3, 1.0, n - 1))))
        q = rng.normal(size=(n, 2))
        for k in range(0, n - p):
            interior = averaging_knots(u, k, p)
            assert interior.shape == (k,)
            t = np.concatenate(([u[0]], interior, [u[-1]]))
            assert (np.diff(t) > 0).all()
            # a data parameter in every knot span [t_j, t_{j+1}) (the last one closed)
            for lo, hi in itertools.pairwise(t):
                inside = (u >= lo) & ((u < hi) | (hi == u[-1]))
                assert inside.any(), (n, p, k, lo, hi)
            fit = OpenCurve(u, q, p).evaluate_positions(interior[None, :])
            assert fit.reason[0] in (Infeasibility.FEASIBLE, Infeasibility.SINGULAR)


# --------------------------------------------------------------------------------------------
# function data y = f(x)


@pytest.mark.parametrize("degree", DEGREES)
def test_function_data_matches_scipy(degree):
    rng = np.random.default_rng(8000 + degree)
    x = np.sort(rng.uniform(2.0, 12.0, 80))
    assert (np.diff(x) > 0).all()
    y = np.sin(x) + 0.1 * x + 0.01 * rng.normal(size=x.size)
    u = parameterize(y, x, degree=degree)
    np.testing.assert_array_equal(u, x)
    np.testing.assert_array_equal(parameterize(y[:, None], x, degree=degree), x)

    masks = rng.random((12, x.size - 2)) < np.repeat([0.05, 0.15, 0.3], 4)[:, None]
    fit2d = OpenCurve(x, y[:, None], degree).evaluate_masks(masks)
    fit1d = OpenCurve(x, y, degree).evaluate_masks(masks)
    np.testing.assert_array_equal(fit1d.sse, fit2d.sse)
    assert fit2d.feasible.all()
    q = y[:, None]
    for b, m in enumerate(masks):
        interior = x[1:-1][m]
        spl = make_lsq_spline(x, y, knot_vector(x, interior, degree), k=degree)
        dist = np.abs(spl(x) - y)
        ref = float(dist @ dist)
        assert abs(fit2d.sse[b] - ref) <= REL * ref + sse_floor(ref, q)
        assert abs(fit2d.max_deviation[b] - dist.max()) <= REL * dist.max() + maxdev_floor(q)

    interior = x[1:-1][masks[5]]
    fit = fit_spline(x, y, interior, degree)
    spl = make_lsq_spline(x, y, knot_vector(x, interior, degree), k=degree)
    assert fit.control_points.shape == (interior.size + degree + 1, 1)
    np.testing.assert_allclose(fit.spline(x)[:, 0], spl(x), rtol=0, atol=1e-9 * np.abs(y).max())

    # positions are in x units: knots outside [x0, xm] are out of range
    pos = np.array([[x[0] + 1.0, x[-1] - 1.0], [0.5, 5.0], [5.0, 13.0]])
    fit = OpenCurve(x, y, degree).evaluate_positions(pos)
    assert list(fit.reason) == [Infeasibility.FEASIBLE] + [Infeasibility.KNOT_OUT_OF_RANGE] * 2
