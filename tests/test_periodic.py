"""Periodic B-splines for closed outlines, against FITPACK's periodic least-squares spline."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import splprep

from metaknot.bspline.periodic import (
    closed_parameterize,
    fit_periodic,
    periodic_errors,
    periodic_knot_vector,
)


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
        fitted = fit_periodic(u, points, interior, degree)
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
    fitted = fit_periodic(u, points, np.linspace(0, 1, 22)[1:-1], degree)
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
        fit_periodic(u, points, np.sort(empty_span), 3)
    errors = periodic_errors(u, points, [np.linspace(0, 1, 12)[1:-1], np.sort(empty_span)])
    assert np.isfinite(errors[0]) and errors[1] == np.inf


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("method", ["uniform", "chord", "centripetal"])
def test_compiled_batch_matches_the_reference(degree: int, dim: int, method: str) -> None:
    from metaknot.bspline.periodic import evaluate_periodic

    points = outline(120, dim=dim, seed=degree)
    u = closed_parameterize(points, method)
    rng = np.random.default_rng(100 * degree + dim)
    rows = np.full((12, 40), np.nan)
    for i in range(12):
        count = int(rng.integers(max(degree - 1, 1), 40))
        rows[i, :count] = rng.choice(u[1:], count, replace=False)
    batch = evaluate_periodic(u, points, rows, degree)
    for i, row in enumerate(rows):
        interior = np.sort(row[~np.isnan(row)])
        try:
            reference = fit_periodic(u, points, interior, degree)
        except ValueError:
            assert not batch.feasible[i]
            continue
        assert batch.feasible[i]
        sse = float((reference.distances() ** 2).sum())
        assert batch.sse[i] == pytest.approx(sse, rel=1e-10)
        assert batch.max_deviation[i] == pytest.approx(reference.max_deviation, rel=1e-10)
        assert batch.n_control_points[i] == reference.n_control_points


def test_compiled_batch_names_what_cannot_be_fitted() -> None:
    from metaknot.bspline import Infeasibility
    from metaknot.bspline.periodic import evaluate_periodic

    points = outline(40)
    u = closed_parameterize(points)
    crowded = u[20] + (u[21] - u[20]) * np.linspace(0.1, 0.9, 8)
    rows = np.full((5, 9), np.nan)
    rows[0, :3] = [0.2, 0.5, 0.8]                   # fine
    rows[1, :3] = [0.2, 0.5, 1.2]                   # outside (0, 1)
    rows[2, :3] = [0.2, 0.5, 0.5]                   # coincident
    rows[3, :9] = np.sort(np.append(crowded, 0.7))  # spans without data
    rows[4, :1] = [0.5]                             # too few breakpoints for degree 3
    batch = evaluate_periodic(u, points, rows, 3)
    assert list(batch.reason) == [Infeasibility.FEASIBLE, Infeasibility.KNOT_OUT_OF_RANGE,
                                  Infeasibility.COINCIDENT_KNOTS, Infeasibility.SINGULAR,
                                  Infeasibility.SINGULAR]
    assert np.isfinite(batch.sse[0]) and np.isinf(batch.sse[1:]).all()
    too_many = np.sort(np.concatenate((u[1:], (u[1:3] + u[2:4]) / 2)))[None, :]
    assert evaluate_periodic(u, points, too_many, 3).reason[0] == \
        Infeasibility.TOO_MANY_CONTROL_POINTS
