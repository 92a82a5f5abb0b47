"""Periodic B-splines for closed outlines, against FITPACK's periodic least-squares spline."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline, splprep

from metaknot.bspline import closed_parameterize, periodic_knot_vector
from metaknot.bspline.curve import ClosedCurve


def dense_reference(u: np.ndarray, points: np.ndarray, interior: np.ndarray, degree: int
                    ) -> tuple[float, float] | None:
    """SSE and maximum deviation of the periodic least-squares fit by dense linear algebra on
    the wrapped design matrix (scipy's ``BSpline.design_matrix`` and numpy's ``lstsq``), or
    None if the system is rank-deficient."""
    t = periodic_knot_vector(interior, degree)
    m = t.size - 2 * degree - 1
    if m > len(u):
        return None
    full = BSpline.design_matrix(u, t, degree).toarray()  # (N, m + p)
    wrapped = full[:, :m].copy()
    wrapped[:, :degree] += full[:, m:]
    q = points[:, None] if points.ndim == 1 else points
    coef, _, rank, singular = np.linalg.lstsq(wrapped, q, rcond=None)
    if rank < m or singular[-1] < 1e-11 * singular[0]:
        return None
    distances = np.linalg.norm(q - wrapped @ coef, axis=1)
    return float((distances**2).sum()), float(distances.max())


def outline(n: int = 150, dim: int = 2, seed: int = 0) -> np.ndarray:
    angle = np.linspace(0, 2 * np.pi, n, endpoint=False)
    radius = 1 + 0.25 * np.cos(5 * angle) ** 3
    columns = [radius * np.cos(angle), radius * np.sin(angle), 0.3 * np.sin(3 * angle)]
    noise = np.random.default_rng(seed).normal(0, 1e-3, (n, 3))
    return (np.column_stack(columns) + noise)[:, :dim]


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("method", ["uniform", "chord", "centripetal"])
def test_least_squares_matches_fitpack(degree: int, dim: int, method: str) -> None:
    points = outline(dim=dim)
    u = closed_parameterize(points, method)
    rng = np.random.default_rng(degree * 10 + dim)
    for count in (degree, 12, 45):
        interior = np.sort(rng.choice(u[1:], count, replace=False))
        fitted = ClosedCurve(u, points, degree).fit(interior)
        t = periodic_knot_vector(interior, degree)
        (t_ref, c_ref, _), _ = splprep(np.vstack((points, points[:1])).T,
                                       u=np.append(u, 1.0), k=degree, task=-1, t=t, per=1,
                                       quiet=1)
        np.testing.assert_array_equal(t_ref, t)
        np.testing.assert_allclose(fitted.spline.c, np.array(c_ref).T, rtol=0, atol=1e-9)
        assert fitted.n_control_points == count + 1


@pytest.mark.parametrize("degree", [2, 3, 5])
def test_the_seam_is_smooth(degree: int) -> None:
    points = outline()
    u = closed_parameterize(points)
    fitted = ClosedCurve(u, points, degree).fit(np.linspace(0, 1, 22)[1:-1])
    for order in range(degree):  # value and derivatives up to p - 1 agree across the seam
        derivative = fitted.spline.derivative(order) if order else fitted.spline
        np.testing.assert_allclose(derivative(0.0), derivative(1.0), atol=1e-8)
    np.testing.assert_array_equal(fitted.spline.c[-degree:], fitted.spline.c[:degree])


def test_closed_parameterization_counts_the_closing_chord() -> None:
    square = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
    np.testing.assert_allclose(closed_parameterize(square, "chord"), [0, 0.25, 0.5, 0.75])
    kite = np.array([[0.0, 0], [4, 0], [4, 1]])  # chords 4, 1, sqrt(17)
    total = 5 + np.sqrt(17)
    np.testing.assert_allclose(closed_parameterize(kite, "chord"), [0, 4 / total, 5 / total])
    np.testing.assert_allclose(closed_parameterize(kite, "uniform"), [0, 1 / 3, 2 / 3])
    roots = np.sqrt([4, 1, np.sqrt(17)])
    np.testing.assert_allclose(closed_parameterize(kite, "centripetal"),
                               [0, roots[0] / roots.sum(), roots[:2].sum() / roots.sum()])


@pytest.mark.parametrize(("points", "message"), [
    (np.array([[0.0, 0], [1, 0]]), "at least 3 points"),
    (np.array([[0.0, 0], [1, 0], [1, 0], [0, 1]]), "repeats point 1"),
    (np.array([[0.0, 0], [1, 0], [0, 1], [0, 0]]), "do not repeat the first at the end"),
])
def test_bad_outlines_are_named(points, message) -> None:
    with pytest.raises(ValueError, match=message):
        closed_parameterize(points)


def test_impossible_knots_are_refused_or_infinite() -> None:
    points = outline(40)
    u = closed_parameterize(points)
    with pytest.raises(ValueError, match="distinct and lie in"):
        periodic_knot_vector([0.5, 0.5])
    with pytest.raises(ValueError, match="at least 2 interior knots"):
        periodic_knot_vector([0.5], 3)
    # eight knots between two neighbouring data points: basis functions without data
    empty_span = np.concatenate((u[20] + (u[21] - u[20]) * np.linspace(0.1, 0.9, 8), [0.7]))
    with pytest.raises(ValueError, match="singular"):
        ClosedCurve(u, points, 3).fit(np.sort(empty_span))
    errors = ClosedCurve(u, points, 3).errors([np.linspace(0, 1, 12)[1:-1], np.sort(empty_span)],
                                              "max_deviation")
    assert np.isfinite(errors[0]) and errors[1] == np.inf


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
def test_knots_at_the_ends_or_a_denormal_apart_are_refused_not_raised_nor_nan(closed) -> None:
    """Rows a free-knot search reaches when spans underflow: knots at 0 and 1 (passed on as
    0.5, so that the row holds coincident knots) and a span of 1e-320. The closed batch raised
    ZeroDivisionError on the first and gave NaN on the second."""
    from metaknot.bspline import Infeasibility
    from metaknot.bspline.curve import OpenCurve

    points = outline(60)
    u = closed_parameterize(points) if closed else np.linspace(0.0, 1.0, 60)
    rows = np.array([[0.0, 1e-320, 1.0, 1.0, 1.0, 1.0, 1.0],
                     [0.1, 0.1, 0.3, 0.4, 0.5, 0.6, 0.7],
                     [1e-320, 0.1, 0.3, 0.4, 0.5, 0.6, 0.7],
                     [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]])
    curve = (ClosedCurve if closed else OpenCurve)(u, points, 3)
    batch = curve.evaluate_positions(rows)
    assert list(batch.reason) == [Infeasibility.KNOT_OUT_OF_RANGE,
                                  Infeasibility.COINCIDENT_KNOTS, Infeasibility.SINGULAR,
                                  Infeasibility.FEASIBLE]
    assert np.isinf(batch.sse[:3]).all() and np.isinf(batch.max_deviation[:3]).all()
    assert np.isfinite(batch.sse[3])


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("method", ["uniform", "chord", "centripetal"])
def test_compiled_batch_matches_the_reference(degree: int, dim: int, method: str) -> None:

    points = outline(120, dim=dim, seed=degree)
    u = closed_parameterize(points, method)
    rng = np.random.default_rng(100 * degree + dim)
    rows = np.full((12, 40), np.nan)
    for i in range(12):
        count = int(rng.integers(max(degree - 1, 1), 40))
        rows[i, :count] = rng.choice(u[1:], count, replace=False)
    batch = ClosedCurve(u, points, degree).evaluate_positions(rows, nan_is_absent=True)
    for i, row in enumerate(rows):
        interior = np.sort(row[~np.isnan(row)])
        reference = dense_reference(u, points, interior, degree)
        if reference is None:
            assert not batch.feasible[i]
            with pytest.raises(ValueError):
                ClosedCurve(u, points, degree).fit(interior)
            continue
        assert batch.feasible[i]
        sse, max_deviation = reference
        assert batch.sse[i] == pytest.approx(sse, rel=1e-10)
        assert batch.max_deviation[i] == pytest.approx(max_deviation, rel=1e-10)
        fitted = ClosedCurve(u, points, degree).fit(interior)
        assert fitted.sse == pytest.approx(sse, rel=1e-10)
        assert batch.n_control_points[i] == fitted.n_control_points == interior.size + 1


def test_compiled_batch_names_what_cannot_be_fitted() -> None:
    from metaknot.bspline import Infeasibility

    points = outline(40)
    u = closed_parameterize(points)
    crowded = u[20] + (u[21] - u[20]) * np.linspace(0.1, 0.9, 8)
    rows = np.full((5, 9), np.nan)
    rows[0, :3] = [0.2, 0.5, 0.8]                   # fine
    rows[1, :3] = [0.2, 0.5, 1.2]                   # outside (0, 1)
    rows[2, :3] = [0.2, 0.5, 0.5]                   # coincident
    rows[3, :9] = np.sort(np.append(crowded, 0.7))  # spans without data
    rows[4, :1] = [0.5]                             # too few breakpoints for degree 3
    batch = ClosedCurve(u, points, 3).evaluate_positions(rows, nan_is_absent=True)
    assert list(batch.reason) == [Infeasibility.FEASIBLE, Infeasibility.KNOT_OUT_OF_RANGE,
                                  Infeasibility.COINCIDENT_KNOTS, Infeasibility.SINGULAR,
                                  Infeasibility.SINGULAR]
    assert np.isfinite(batch.sse[0]) and np.isinf(batch.sse[1:]).all()
    too_many = np.sort(np.concatenate((u[1:], (u[1:3] + u[2:4]) / 2)))[None, :]
    assert ClosedCurve(u, points, 3).evaluate_positions(too_many, nan_is_absent=True).reason[0] \
        == Infeasibility.TOO_MANY_CONTROL_POINTS



@pytest.mark.parametrize("serial", [True, False], ids=["calling thread", "thread pool"])
def test_closed_candidates_are_sorted_then_refused_in_order(serial) -> None:
    """A closed candidate's knots are taken in any order (sorted before the fit), and refused
    by the first check it fails: a knot outside (0, 1), then coincident knots, then too few
    breakpoints for the degree; on the calling thread (small batches) as on the threads."""
    from metaknot.bspline import Infeasibility
    from metaknot.bspline import curve as curve_module
    from metaknot.bspline.curve import make_curve

    curve = make_curve(outline(60), degree=5, closed=True)
    rows = [np.array([0.6, 0.2, 0.4, 0.8, 0.9, 0.1]), np.array([0.1, 0.2, 0.4, 0.6, 0.8, 0.9]),
            np.array([0.5, 0.5, 0.5]), np.array([1.5, 0.5, 0.5, 0.5]), np.array([0.5]),
            np.array([0.2, 0.2, 0.2, 0.7, 0.9, 0.95])]
    knots, offsets = np.concatenate(rows), np.cumsum([0] + [len(r) for r in rows])
    serial_batch = curve_module.SERIAL_BATCH
    curve_module.SERIAL_BATCH = serial_batch if serial else 0
    try:
        batch = curve.evaluate_knots(knots, offsets, max_multiplicity=2)
    finally:
        curve_module.SERIAL_BATCH = serial_batch
    assert list(batch.reason) == [Infeasibility.FEASIBLE, Infeasibility.FEASIBLE,
                                  Infeasibility.COINCIDENT_KNOTS, Infeasibility.KNOT_OUT_OF_RANGE,
                                  Infeasibility.SINGULAR, Infeasibility.COINCIDENT_KNOTS]
    assert batch.sse[0] == batch.sse[1] and batch.max_deviation[0] == batch.max_deviation[1]
    assert list(batch.n_control_points) == [7, 7, 4, 5, 2, 7]
    assert np.isinf(batch.sse[2:]).all() and np.isinf(batch.max_deviation[2:]).all()


@pytest.mark.parametrize("shape", [(1, 2, 3), (2, 1, 4)])
def test_compiled_batch_refuses_positions_that_are_not_rows(shape) -> None:
    """Positions of more than two dimensions are refused by name before the compiled loop
    (which trusts its offsets: a 3-D batch wrote past its outputs)."""

    points = outline(40)
    with pytest.raises(ValueError, match=r"positions must have shape \(B, K\); got"):
        ClosedCurve(closed_parameterize(points), points, 3).evaluate_positions(
            np.full(shape, 0.5), nan_is_absent=True)


@pytest.mark.parametrize("density", [0.0, 0.03, 0.3, 0.9, 1.0])
def test_closed_masks_fit_as_their_knots_do(density) -> None:
    """A closed curve's masks go to the compiled fit as the data's own parameters (no sorting,
    no checks of range or coincidence): the same bits as the same knots as positions."""
    from metaknot.bspline.curve import make_curve

    curve = make_curve(outline(80), closed=True)
    masks = (np.random.default_rng(4).random((7, 79)) < density).astype(np.int64)
    for max_deviation in (True, False):
        fast = curve.evaluate_masks(masks, max_deviation=max_deviation)
        rows = np.where(masks.astype(bool), curve.params[1:][None, :], np.nan)
        reference = curve.evaluate_positions(rows, max_deviation=max_deviation,
                                             nan_is_absent=True)
        for field in ("sse", "max_deviation", "n_control_points", "reason"):
            np.testing.assert_array_equal(getattr(fast, field), getattr(reference, field))


@pytest.mark.parametrize("nan_is_absent", [True, False])
def test_rows_of_positions_are_refused_as_numpy_finds_them(nan_is_absent) -> None:
    """Position rows (NaN dropped or out of range; knots outside (0, 1) refused before
    coincident knots, neither fitted) give the values of the same steps in numpy over random
    rows of every kind: the refused rows marked, the others fitted by the batch kernel."""
    from metaknot.bspline import _kernel
    from metaknot.bspline.curve import _outputs

    points = outline(50)
    u = closed_parameterize(points)
    rng = np.random.default_rng(11)
    rows = np.sort(rng.random((300, 7)), axis=1)
    kinds = rng.integers(0, 7, size=300)
    rows[kinds == 1, 2] = np.nan
    rows[kinds == 2, rng.integers(0, 7)] = rng.choice([-0.2, 1.0, 1.5, np.inf, -np.inf])
    rows[kinds == 3, 3] = rows[kinds == 3, 4]
    rows[kinds == 4, :] = np.nan
    rows[kinds == 5, 1] = 0.0
    rows[kinds == 6, 3] = rows[kinds == 6, 4]  # coincident and out of range: out of range
    rows[kinds == 6, 0] = 1.5
    for max_deviation in (True, False):
        batch = ClosedCurve(u, points, 3).evaluate_positions(rows, max_deviation=max_deviation,
                                                             nan_is_absent=nan_is_absent)
        # numpy's steps
        pos = np.sort(rows, axis=1)
        present = ~np.isnan(pos) if nan_is_absent else np.ones(pos.shape, dtype=bool)
        counts = present.sum(axis=1)
        knots = pos[present]
        offsets = np.concatenate(([0], np.cumsum(counts))).astype(np.int64)
        safe = knots.copy()
        bad_range = ~((safe > 0.0) & (safe < 1.0))
        safe[bad_range] = 0.5
        sse, max_dev, n_ctrl, reason = out = _outputs(len(rows), max_deviation)
        _kernel.evaluate_batch(u, points, 3, True, 1, safe, offsets, *out, 4)
        row_of = np.repeat(np.arange(len(rows)), counts)
        same_row = row_of[1:] == row_of[:-1]
        coincident = np.zeros(len(rows), dtype=bool)
        coincident[row_of[1:][same_row & (np.diff(knots) <= 0)]] = True
        out_of_range = np.zeros(len(rows), dtype=bool)
        out_of_range[row_of[bad_range]] = True
        reason[coincident] = 3
        reason[out_of_range] = 2
        sse[coincident | out_of_range] = np.inf
        if max_deviation:
            max_dev[coincident | out_of_range] = np.inf
        np.testing.assert_array_equal(batch.reason, reason)
        np.testing.assert_array_equal(batch.sse, sse)
        np.testing.assert_array_equal(batch.n_control_points, n_ctrl)
        if max_deviation:
            np.testing.assert_array_equal(batch.max_deviation, max_dev)
        assert {2, 3} <= set(reason.tolist()) and (reason == 0).any()

# --- the knot problems on closed outlines ----------------------------------------------------

def closed_problems(objective: str = "paper"):
    from metaknot.problems import FreeKnots, KnotIndices, KnotSelection

    points = outline(60)
    return [KnotSelection(points, closed=True, objective=objective),
            KnotIndices(points, n_knots=9, closed=True, objective=objective),
            FreeKnots(points, n_knots=9, closed=True, objective=objective)]


def interior_of(problem, x: np.ndarray) -> np.ndarray:
    kind = problem.encoding.kind
    if kind == "binary":
        return problem.params[1:][x.astype(bool)]
    if kind == "integer":
        return problem.params[np.sort(x)]
    return np.sort(x)


@pytest.mark.parametrize("index", [0, 1, 2], ids=["mask", "indices", "free"])
def test_closed_problems_score_the_periodic_fit(index: int) -> None:
    problem = closed_problems("error_bounded")[index]
    assert problem.describe()["closed"] is True and problem.n_objectives == 1
    n = problem.data.n_points
    if problem.encoding.kind == "binary":
        assert problem.encoding.n_var == n - 1  # every point but the first (always a knot)
    elif problem.encoding.kind == "integer":
        assert int(problem.encoding.upper.max()) == n - 1
    X = problem.sample(np.random.default_rng(index), 15)
    values, metrics = problem.evaluate_with_metrics(X)
    tol = problem.objective.bound(problem.info)
    for x, value, cp in zip(X, values, metrics["n_control_points"], strict=True):
        interior = interior_of(problem, x)
        try:
            reference = ClosedCurve(problem.params, problem.points, 3).fit(interior)
        except ValueError:
            assert value == np.inf
            continue
        ratio = reference.max_deviation / tol
        expected = reference.n_control_points + ratio if ratio <= 1 else n + 2 + ratio
        assert value == pytest.approx(expected, rel=1e-9)
        assert cp == reference.n_control_points == len(interior) + 1
    best = X[np.argmin(values)]
    solution = problem.decode(best)
    reference = ClosedCurve(problem.params, problem.points, 3).fit(interior_of(problem, best))
    assert solution.metrics["max_deviation"] == pytest.approx(reference.max_deviation, rel=1e-12)


def test_bic_counts_a_closed_curve_s_parameters() -> None:
    from metaknot.problems import KnotSelection

    points = outline(60)
    problem = KnotSelection(points, closed=True, objective="bic")
    mask = np.zeros(59, dtype=np.int64)
    mask[[9, 19, 29, 39, 49]] = 1
    value = problem.evaluate(mask[None, :])[0]
    fitted = ClosedCurve(problem.params, points, 3).fit(problem.params[1:][mask.astype(bool)])
    n, cp = 60 * 2, 6
    k = 2 * cp + (cp - 1)  # d x control points + interior knots (cp - 1 on a closed curve)
    assert value == pytest.approx(n * np.log(fitted.sse / n) + np.log(n) * k, rel=1e-9)


@pytest.mark.parametrize("index", [0, 1, 2], ids=["mask", "indices", "free"])
def test_every_optimizer_runs_on_closed_problems(index: int) -> None:
    import metaknot as mk

    problem = closed_problems()[index]
    for name in mk.available_optimizers():
        optimizer = mk.get_optimizer(name)
        if problem.encoding.kind not in optimizer.encodings:
            continue
        result = mk.minimize(problem, name, budget=60, seed=1)
        assert result.n_evaluations <= 60
        if result.best_x is not None:
            assert result.best_f == pytest.approx(
                float(problem.evaluate(result.best_x[None, :])[0]))
            assert result.metrics["n_control_points"] == \
                len(interior_of(problem, result.best_x)) + 1


def test_a_closed_problem_refuses_explicit_parameters() -> None:
    from metaknot.problems import KnotSelection, PointSet

    points = outline(30)
    with pytest.raises(ValueError, match="explicit parameters do not apply"):
        KnotSelection(PointSet(points, params=np.linspace(0, 1, 30)), closed=True)


def test_a_closed_study_from_the_command_line(tmp_path) -> None:
    import subprocess
    import sys

    from metaknot.experiments.store import load_study

    done = subprocess.run(
        [sys.executable, "-m", "metaknot.cli", "run", "-m", "problem=epitrochoid",
         "problem.closed=true,false", "optimizer=averaging", "budget=400", "seed=0",
         f"results_dir={tmp_path}", "study=closed"],
        capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    runs = load_study(tmp_path / "closed").runs.set_index("closed")
    # the seed's epitrochoid repeats its first point: a closed problem drops it
    assert runs.loc[True, "n_points"] == runs.loc[False, "n_points"] - 1 == 360
    assert runs.loc[True, "best_f"] < runs.loc[False, "best_f"]  # no seam to pay for
    # the report draws the closed fit over the whole period
    from metaknot.experiments.report import figures as f
    from metaknot.experiments.report.data import prepare

    comparison = prepare(tmp_path / "closed")
    figure = f.fitted_curves_figure(comparison, comparison.instances[0])
    lines = [line for ax in figure.axes for line in ax.get_lines() if line.get_label() == "fit"]
    closed_curves = [line.get_xydata() for line in lines]
    assert any(np.allclose(xy[0], xy[-1], atol=1e-9) for xy in closed_curves)


def test_a_closed_index_set_may_use_the_last_point() -> None:
    from metaknot.problems import KnotIndices

    points = outline(50)
    problem = KnotIndices(points, n_knots=6, closed=True)
    x = np.array([8, 16, 24, 32, 40, 49])  # 49 = N - 1: next to point 0 across the seam
    solution = problem.decode(x)
    reference = ClosedCurve(problem.params, points, 3).fit(problem.params[x])
    assert solution.metrics["sse"] == pytest.approx(reference.sse, rel=1e-12)


def test_a_single_fit_of_many_points_needs_no_dense_matrix() -> None:
    """200,000 points and 100,000 control points: the dense design matrix would take 160 GB;
    the compiled fit needs memory in proportion to the points."""
    angle = np.linspace(0, 2 * np.pi, 200_000, endpoint=False)
    points = np.column_stack((np.cos(angle), np.sin(2 * angle)))
    u = closed_parameterize(points, "uniform")
    fitted = ClosedCurve(u, points, 3).fit(u[2::2])
    assert fitted.n_control_points == 100_000
    assert fitted.max_deviation < 1e-9


@pytest.mark.parametrize("name", ["epitrochoid", "vivaldi"])
def test_a_breakpoint_at_every_point_of_a_seed_outline_is_fitted(name) -> None:
    """Interpolation (what ``metaknot fit`` measures first): rotations meet entries so small
    that their squares underflow, and must stay orthogonal."""
    from metaknot.bspline.curve import make_curve
    from metaknot.problems import get_curve

    curve = make_curve(get_curve(name).points, closed=True)
    residuals = curve.interpolation_residuals()
    assert residuals.max() < 1e-9 * curve.points.std()


def test_every_degree_and_dimension_fits_as_dense_least_squares() -> None:
    """The closed fit (the open kernel's generated rows for the spans from breakpoint p on,
    the rows across the seam after them) against dense least squares on the wrapped design
    matrix, for every degree and dimension, on random data and breakpoints: few breakpoints
    (m = p: basis functions that wrap onto one coefficient; m = p + 1: no span without seam
    rows but one), data at a breakpoint, spans without data (singular), many points."""
    from metaknot.bspline._kernel import evaluate_batch

    rng = np.random.default_rng(3)
    checked = singular = 0
    for p in range(1, 6):
        for d in range(1, 4):
            for trial in range(30):
                u = np.unique(np.concatenate(([0.0], rng.random(int(rng.integers(p + 2, 150))))))
                q = rng.normal(size=(u.size, d))
                m = [p, p + 1, int(rng.integers(p, max(p + 1, u.size // 2 + 1)))][trial % 3]
                m = min(m, u.size)
                chosen = rng.choice(u[1:], m - 1, replace=False) if trial % 2 else \
                    rng.uniform(0, 1, m - 1)
                interior = np.sort(chosen)
                outputs = (np.empty(1), np.empty(1), np.empty(1, dtype=np.int64),
                           np.empty(1, dtype=np.int8))
                evaluate_batch(u, q, p, True, 1, interior, np.array([0, m - 1]), *outputs, 1)
                sse, max_dev, n_ctrl, reason = (value[0] for value in outputs)
                reference = dense_reference(u, q, interior, p)
                assert n_ctrl == m
                if reference is None:
                    assert reason != 0, (p, d, m, trial)
                    singular += 1
                    continue
                if reason != 0:  # only where dense least squares is near singular too
                    assert dense_reference(u, q, interior, p) is None or \
                        np.linalg.cond(_wrapped(u, interior, p)) > 1e9, (p, d, m, trial)
                    continue
                checked += 1
                scale = float((q**2).sum())
                np.testing.assert_allclose(sse, reference[0], rtol=1e-9, atol=1e-12 * scale)
                np.testing.assert_allclose(max_dev, reference[1], rtol=1e-7, atol=1e-9)
    assert checked > 300 and singular > 10


def _wrapped(u: np.ndarray, interior: np.ndarray, degree: int) -> np.ndarray:
    t = periodic_knot_vector(interior, degree)
    m = t.size - 2 * degree - 1
    full = BSpline.design_matrix(u, t, degree).toarray()
    wrapped = full[:, :m].copy()
    wrapped[:, :degree] += full[:, m:]
    return wrapped


def _closed_calls():
    from metaknot.bspline.curve import ClosedCurve
    from metaknot.bspline.moves import PeriodicMoveEvaluator

    knots = np.array([0.2, 0.4, 0.6, 0.8])
    return {
        "PeriodicMoveEvaluator": lambda u, q: PeriodicMoveEvaluator(u, q, knots),
        "ClosedCurve": lambda u, q: ClosedCurve(u, q, 3).evaluate_positions(knots[None, :]),
    }


@pytest.mark.parametrize("call", list(_closed_calls()))
@pytest.mark.parametrize(("change", "message"), [
    (lambda q: np.where(np.arange(len(q))[:, None] == 4, np.nan, q),
     r"points contains NaN or infinite values \(first at row 4\)"),
    (lambda q: np.where(np.arange(len(q))[:, None] == 2, np.inf, q),
     r"points contains NaN or infinite values \(first at row 2\)"),
    (lambda q: q[:, :, None], r"points must have shape \(N, d\)"),
    (lambda q: q[:, :0], "at least one coordinate"),
])
def test_closed_fits_refuse_bad_points_by_name(call, change, message) -> None:
    """NaN or infinite coordinates (fitted to NaN, reported feasible), points of three
    dimensions (a numba typing error) or without coordinates (an SSE of 0) are refused."""
    points = outline(40)
    u = closed_parameterize(points)
    with pytest.raises(ValueError, match=message):
        _closed_calls()[call](u, change(points))


@pytest.mark.parametrize("call", list(_closed_calls()))
def test_closed_fits_refuse_too_few_points_by_name(call) -> None:
    with pytest.raises(ValueError, match="a closed curve needs at least 3 points; got 0"):
        _closed_calls()[call](np.empty(0), np.empty((0, 2)))


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_periodic_knots_are_refused_by_name(bad) -> None:
    """A NaN knot passed the range checks (every comparison with NaN is false) and reached the
    compiled fit; now refused like a knot outside (0, 1)."""
    from metaknot.bspline.curve import make_curve
    from metaknot.bspline.moves import PeriodicMoveEvaluator

    points = outline(40)
    u = closed_parameterize(points)
    knots = np.array([0.2, 0.4, bad, 0.8])
    with pytest.raises(ValueError, match="must be finite, distinct and lie in"):
        periodic_knot_vector(knots)
    with pytest.raises(ValueError, match="must be finite, distinct and lie in"):
        ClosedCurve(u, points, 3).fit(knots)
    with pytest.raises(ValueError, match="must be finite, distinct and lie in"):
        PeriodicMoveEvaluator(u, points, knots)
    assert make_curve(points, closed=True).move_evaluator(knots) is None


def test_closed_fit_refuses_interior_knots_of_two_dimensions() -> None:
    points = outline(40)
    u = closed_parameterize(points)
    with pytest.raises(ValueError, match="interior_knots must be 1-D"):
        ClosedCurve(u, points, 3).fit(np.array([[0.2, 0.4, 0.6, 0.8]]))


def test_points_of_more_than_three_coordinates_are_refused_as_on_open_curves() -> None:
    from metaknot.bspline.curve import make_curve

    points = outline(60, dim=3)
    points = np.column_stack((points, points[:, 0]))
    for closed in (False, True):
        with pytest.raises(ValueError, match="1 to 3 coordinates"):
            make_curve(points, closed=closed)
    with pytest.raises(ValueError, match="1 to 3 coordinates"):
        ClosedCurve(closed_parameterize(points), points, 3).fit([0.3, 0.6])


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
def test_either_side_of_the_seam_rows_own_factor_fits_as_dense_least_squares(degree) -> None:
    """m = 2p - 1, 2p, 2p + 1 control points (the seam rows get a factor of their own from
    m = 2p on) against dense least squares on the wrapped design matrix, dimensions 1-3,
    breakpoints at data points and between them."""
    from metaknot.bspline._kernel import evaluate_batch

    rng = np.random.default_rng(11)
    checked = 0
    for d in range(1, 4):
        for m in (2 * degree - 1, 2 * degree, 2 * degree + 1):
            for trial in range(6):
                u = np.unique(np.concatenate(([0.0], rng.random(int(rng.integers(40, 120))))))
                q = rng.normal(size=(u.size, d))
                chosen = rng.choice(u[1:], m - 1, replace=False) if trial % 2 else \
                    rng.uniform(0.02, 0.98, m - 1)
                interior = np.sort(chosen)
                outputs = (np.empty(1), np.empty(1), np.empty(1, dtype=np.int64),
                           np.empty(1, dtype=np.int8))
                evaluate_batch(u, q, degree, True, 1, interior, np.array([0, m - 1]), *outputs,
                               1)
                sse, max_dev, _, reason = (value[0] for value in outputs)
                reference = dense_reference(u, q, interior, degree)
                if reference is None or reason != 0:
                    assert reference is None or np.linalg.cond(
                        _wrapped(u, interior, degree)) > 1e9, (degree, d, m, trial)
                    continue
                checked += 1
                scale = float((q**2).sum())
                np.testing.assert_allclose(sse, reference[0], rtol=1e-9, atol=1e-12 * scale)
                np.testing.assert_allclose(max_dev, reference[1], rtol=1e-7, atol=1e-9)
    assert checked >= 40


def _rotated(rows: np.ndarray, rhs: np.ndarray, p: int) -> tuple[np.ndarray, float]:
    """The rows (each nonzero in its first ``p + 1`` columns from its first nonzero, and in the
    last ``p``), rotated one by one by ``_kernel.rotate_dense`` into an empty factor, in the
    order of their first nonzero; the back-substituted solution and the SSE left."""
    from metaknot.bspline import _kernel

    ncol = rows.shape[1]
    d = rhs.shape[1]
    width = 1 + p + d
    st = np.zeros(ncol * width)
    st[::width] = _kernel.EMPTY
    far = np.zeros((ncol, p))
    sse = 0.0
    for i in np.argsort([np.flatnonzero(r)[0] for r in rows], kind="stable"):
        first = int(np.flatnonzero(rows[i])[0])
        sse += _kernel.rotate_dense(st, far, width, p, d, ncol, rows[i].copy(), rhs[i].copy(),
                                    first, min(first + p + 1, ncol), 1.0)
    assert np.isfinite(st).all() and np.isfinite(far).all()
    x = np.zeros((ncol, d))
    _kernel.back_substitute(st, far, width, p, d, ncol, x)
    return x, sse


@pytest.mark.parametrize("p", [1, 2, 3])
def test_dense_rotation_with_wrap_around_columns_solves_least_squares(p: int) -> None:
    """The rotation of closed fits' seam rows and of the closed move evaluator's merge, on a
    random banded system with ``p`` wrap-around columns, against numpy's least squares."""
    rng = np.random.default_rng(p)
    ncol, n_rows, d = 9, 40, 2
    rows = np.zeros((n_rows, ncol))
    for i in range(n_rows):
        first = rng.integers(0, ncol - p)
        rows[i, first : first + p + 1] = rng.normal(size=p + 1)
        if rng.random() < 0.3:  # a seam row: it touches the wrap-around columns
            rows[i, ncol - p :] += rng.normal(size=p)
    rhs = rng.normal(size=(n_rows, d))
    x, sse = _rotated(rows, rhs, p)
    expected, residual, rank, _ = np.linalg.lstsq(rows, rhs, rcond=None)
    assert rank == ncol
    np.testing.assert_allclose(x, expected, rtol=1e-10, atol=1e-12)
    assert sse == pytest.approx(residual.sum(), rel=1e-10)


def test_dense_rotation_drops_an_entry_too_small_to_reach_an_empty_column() -> None:
    """A row whose entry in a column no row has reached yet is so small that the column's
    weight would overflow (fill-in that died out along a band) passes that column by: the
    entry is dropped (it moves the fit by nothing a float can hold), the row goes on to its
    next column, and the factor stays finite. The column then took an infinite weight."""
    p = 2
    rows = np.array([[1e-160, 1.0, 0.5, 0.0, 0.0, 0.0],
                     [1.0, 2.0, 0.0, 0.0, 0.0, 0.0],
                     [0.0, 1.0, 1.0, 1.0, 0.0, 0.0],
                     [0.0, 0.0, 1.0, 0.5, 0.0, 0.2],
                     [0.0, 0.0, 0.0, 1.0, 1.0, 0.3],
                     [0.0, 0.0, 0.0, 0.0, 1.0, 1.0],
                     [0.0, 0.0, 0.0, 0.0, 0.5, 2.0],
                     [0.3, 0.0, 0.0, 0.0, 1.0, 1.0]])
    rhs = np.arange(1.0, 9.0)[:, None]
    x, sse = _rotated(rows, rhs, p)
    expected, residual, _, _ = np.linalg.lstsq(rows, rhs, rcond=None)
    np.testing.assert_allclose(x, expected, rtol=1e-9)
    assert sse == pytest.approx(residual.sum(), rel=1e-9)
