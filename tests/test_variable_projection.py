"""Variable projection on free knots: the exact Jacobian against finite differences and scipy,
the log-span map, and the optimizer (a known spline recovered, no worse than its start,
reproducible, clear refusals, every hyperparameter pinned)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline, make_lsq_spline

import metaknot as mk
from metaknot.algorithms.variable_projection import (
    deviation_power,
    knots_from_log_spans,
    log_spans_from_knots,
    removal_knots,
    residual_jacobian,
)
from metaknot.problems import FreeKnots, KnotSelection, PointSet, get_curve

TRUE_KNOTS = np.array([0.13, 0.31, 0.37, 0.58, 0.81])
ANGLES = np.linspace(0.0, 2 * np.pi, 40, endpoint=False)
CIRCLE = np.column_stack((np.cos(ANGLES), np.sin(ANGLES)))


def _assert_slope(function, knots: np.ndarray, moved: list[int], slope: np.ndarray,
                  rtol: float = 1e-6) -> None:
    """``slope`` is the derivative of ``function`` (of the knots) when the knots ``moved`` all
    move together, by central differences (step 1e-6), to ``rtol`` of its largest entry."""
    step = 1e-6
    up, down = knots.copy(), knots.copy()
    up[moved] += step
    down[moved] -= step
    central = (function(up) - function(down)) / (2 * step)
    assert np.abs(slope - central).max() <= rtol * max(1.0, np.abs(central).max())


def _data(rng: np.random.Generator, n: int, d: int) -> tuple[np.ndarray, np.ndarray]:
    u = np.sort(rng.uniform(0.0, 1.0, n))
    u[0], u[-1] = 0.0, 1.0
    q = np.column_stack([np.sin((c + 2) * u) + 0.05 * rng.normal(size=n) for c in range(d)])
    return u, q


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("dimension", [1, 2, 3])
def test_the_jacobian_is_the_residuals_derivative_by_finite_differences(degree, dimension,
                                                                         closed):
    rng = np.random.default_rng(10 * degree + dimension)
    u, q = _data(rng, 60, dimension)
    if closed:
        u = u[:-1]  # a closed outline's parameters lie in [0, 1)
        q = q[:-1]
    knots = np.sort(rng.uniform(0.1, 0.9, 5))

    def residual(at: np.ndarray) -> np.ndarray:
        return residual_jacobian(u, q, degree, at, (0.0, 1.0), closed=closed,
                                 jacobian=False)[0]

    _, jacobian, _ = residual_jacobian(u, q, degree, knots, (0.0, 1.0), closed=closed)
    for k in range(knots.size):
        _assert_slope(residual, knots, [k], jacobian[:, k])


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
@pytest.mark.parametrize("power", [4, 8, 32])
@pytest.mark.parametrize("dimension", [1, 2])
def test_the_weighted_residual_and_its_jacobian(power, dimension, closed):
    """:func:`deviation_power`: its sum of squares is the sum of the deviations to the power
    (scaled), and its Jacobian the weighted residual's derivative by finite differences."""
    rng = np.random.default_rng(power + dimension)
    u, q = _data(rng, 60, dimension)
    if closed:
        u, q = u[:-1], q[:-1]
    knots = np.sort(rng.uniform(0.1, 0.9, 5))
    raw, derivative, _ = residual_jacobian(u, q, 3, knots, (0.0, 1.0), closed=closed)
    deviations = np.linalg.norm(raw.reshape(u.size, -1), axis=1)
    scale = deviations.max()
    weighted, jacobian = deviation_power(raw, u.size, power, scale, derivative)
    assert np.sum(weighted**2) == pytest.approx(scale**2 * np.sum((deviations / scale)**power),
                                                rel=1e-12)

    def at(where: np.ndarray) -> np.ndarray:
        r = residual_jacobian(u, q, 3, where, (0.0, 1.0), closed=closed, jacobian=False)[0]
        return deviation_power(r, u.size, power, scale)[0]

    assert jacobian is not None
    for k in range(knots.size):
        _assert_slope(at, knots, [k], jacobian[:, k], rtol=1e-5)


def test_the_weighted_residual_at_power_two_and_at_a_point_on_the_curve():
    raw = np.array([3.0, 4.0, 0.0, 0.0, 1.0, 0.0])
    jacobian = np.arange(12.0).reshape(6, 2)
    same, same_jacobian = deviation_power(raw, 3, 2, 5.0, jacobian)
    assert same is raw and same_jacobian is jacobian
    weighted, weighted_jacobian = deviation_power(raw, 3, 4, 5.0, jacobian)
    np.testing.assert_allclose(weighted, [3.0, 4.0, 0.0, 0.0, 0.2, 0.0])  # |r| / 5 times r
    assert np.isfinite(weighted_jacobian).all()
    np.testing.assert_array_equal(weighted_jacobian[2:4], 0.0)  # the point on the curve


def test_under_max_deviation_varpro_moves_the_knots_to_where_the_worst_point_is_nearest():
    """The continuation over :data:`MAX_DEVIATION_POWERS` ends with a smaller largest deviation
    than least squares from the same start at the same budget (the control points are the
    least-squares ones either way): 0.000281 against 0.000318."""
    data = get_curve("archimedean", n_points=80)
    start = np.linspace(0.0, 1.0, 9)[1:-1]
    largest = {}
    for objective in ("rmse", "max_deviation"):
        problem = FreeKnots(data, n_knots=7, objective=objective)
        result = mk.minimize(problem, "varpro", budget=900, seed=0,
                             optimizer_kwargs={"initial": list(start), "restarts": 0,
                                               "removal_start": False})
        checked = FreeKnots(data, n_knots=7, objective="max_deviation")
        largest[objective] = float(checked.evaluate(np.asarray(result.best_x)[None])[0])
    assert largest["max_deviation"] < 0.95 * largest["rmse"]


def test_the_residual_and_control_points_are_scipys_least_squares_fit():
    rng = np.random.default_rng(3)
    u, q = _data(rng, 80, 2)
    knots = np.array([0.2, 0.45, 0.5, 0.77])
    residual, jacobian, coefficients = residual_jacobian(u, q, 3, knots, (0.0, 1.0),
                                                         jacobian=False)
    reference = make_lsq_spline(u, q, np.r_[[0.0] * 4, knots, [1.0] * 4], 3)
    assert jacobian is None
    np.testing.assert_allclose(coefficients, reference.c, atol=1e-10)
    np.testing.assert_allclose(residual, (q - reference(u)).ravel(), atol=1e-10)


def test_a_closed_fit_is_least_squares_on_the_periodic_basis_and_the_problems_value():
    """Independent reference: scipy's B-splines of the periodically extended knot vector,
    the ``p`` beyond the seam added to the first ``p``, solved by numpy's lstsq."""
    problem = FreeKnots(PointSet(CIRCLE * [1.0, 0.6], "ellipse"), n_knots=5, closed=True,
                        objective="rmse")
    knots = np.array([0.1, 0.3, 0.45, 0.7, 0.85])
    u, q = problem.params, problem.points
    residual, _, coefficients = residual_jacobian(u, q, 3, knots, (0.0, 1.0), closed=True,
                                                  jacobian=False)
    breaks = np.r_[0.0, knots]
    t = np.r_[breaks[-3:] - 1.0, breaks, breaks[:4] + 1.0]
    extended = BSpline.design_matrix(u, t, 3).toarray()
    basis = extended[:, :6].copy()
    basis[:, :3] += extended[:, 6:]
    reference = np.linalg.lstsq(basis, q, rcond=None)[0]
    np.testing.assert_allclose(coefficients, reference, atol=1e-12)
    np.testing.assert_allclose(np.sqrt(np.sum(residual**2) / len(u)),
                               problem.evaluate(knots[None, :])[0], rtol=1e-12)


def test_a_knot_span_without_data_is_refused():
    u = np.r_[np.linspace(0.0, 0.3, 20), np.linspace(0.7, 1.0, 20)]
    with pytest.raises(np.linalg.LinAlgError, match="rank deficient"):
        residual_jacobian(u, np.sin(u)[:, None], 3, np.array([0.35, 0.4, 0.5, 0.6, 0.65]),
                          (0.0, 1.0))


def test_log_spans_map_to_ordered_knots_with_their_derivative():
    rng = np.random.default_rng(5)
    z = rng.normal(size=6)
    knots, derivative = knots_from_log_spans(z, (-1.0, 2.0))
    assert np.all(np.diff(np.r_[-1.0, knots, 2.0]) > 0)
    step = 1e-7
    for column in range(z.size):
        e = np.eye(z.size)[column] * step
        central = (knots_from_log_spans(z + e, (-1.0, 2.0))[0]
                   - knots_from_log_spans(z - e, (-1.0, 2.0))[0]) / (2 * step)
        np.testing.assert_allclose(derivative[:, column], central, atol=1e-7)
    np.testing.assert_allclose(log_spans_from_knots(knots, (-1.0, 2.0)), z, atol=1e-12)
    with pytest.raises(ValueError, match="increasing and strictly inside"):
        log_spans_from_knots(np.array([0.5, 0.5]), (0.0, 1.0))


def _spline_problem(n_knots: int = TRUE_KNOTS.size, **options) -> FreeKnots:
    """Points of a cubic spline with knots TRUE_KNOTS (none at a data parameter)."""
    x = np.linspace(0.0, 1.0, 201)
    coefficients = np.array([0.0, 1.0, -1.0, 2.0, 0.5, -0.5, 1.5, 0.2, 1.0])
    y = BSpline(np.r_[[0.0] * 4, TRUE_KNOTS, [1.0] * 4], coefficients, 3)(x)
    data = PointSet(y[:, None], "spline", params=x)
    return FreeKnots(data, n_knots=n_knots, objective="rmse", **options)


def test_a_spline_with_knots_between_the_data_is_recovered():
    problem = _spline_problem()
    result = mk.minimize(problem, "varpro", budget=400, seed=0)
    assert result.best_f <= 1e-9
    np.testing.assert_allclose(np.sort(result.best_x), TRUE_KNOTS, atol=1e-6)


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
def test_better_than_its_start(closed):
    points = np.c_[np.cos(ANGLES) * (1 + 0.3 * np.cos(3 * ANGLES)), np.sin(ANGLES)] if closed \
        else get_curve("archimedean", n_points=60).points
    problem = FreeKnots(PointSet(points), n_knots=6, objective="rmse", closed=closed)
    start = problem.evaluate(np.sort(problem.start_knots(6))[None, :])[0]
    result = mk.minimize(problem, "varpro", budget=200, seed=0)
    assert result.best_f < 0.9 * start


def test_the_same_seed_gives_the_same_run():
    problem = FreeKnots(get_curve("archimedean", n_points=60), n_knots=6, objective="rmse")
    first, second = (mk.minimize(problem, "varpro", budget=300, seed=4) for _ in range(2))
    assert first.best_f == second.best_f
    np.testing.assert_array_equal(first.best_x, second.best_x)
    assert first.n_evaluations == second.n_evaluations == 300


@pytest.mark.parametrize(("problem", "message"), [
    (KnotSelection(get_curve("archimedean", n_points=40)), "needs a FreeKnots problem"),
    (FreeKnots(get_curve("archimedean", n_points=40), n_knots=4, variable_count=True),
     "searches a fixed number of knots"),
])
def test_problems_it_cannot_search_are_refused_by_name(problem, message):
    with pytest.raises(ValueError, match=message):
        mk.minimize(problem, "varpro", budget=10, seed=0)


@pytest.mark.parametrize(("option", "value", "message"), [
    ("restarts", -1, "restarts must be >= 0"),
    ("perturbation", 0.0, "perturbation must be > 0"),
    ("tolerance", float("nan"), "tolerance must be finite"),
    ("stall", 1.5, "stall must be <= 1"),
    ("stall", -0.1, "stall must be >= 0"),
    ("removal_start", "no", "removal_start must be True or False"),
    ("only_initial", 1, "only_initial must be True or False"),
])
def test_bad_options_are_named(option, value, message):
    with pytest.raises(ValueError, match=message):
        mk.get_optimizer("varpro", **{option: value})


def test_only_initial_needs_the_initial_knots():
    with pytest.raises(ValueError, match="only_initial needs the initial knots"):
        mk.get_optimizer("varpro", only_initial=True)


def test_only_initial_solves_from_the_given_knots_alone_with_the_whole_budget(monkeypatch):
    """``only_initial``: one start, from ``initial``, which may use the whole budget (up to
    :func:`start_evaluations`) and then the run stops; without it the same start takes half
    and the averaging, equally spaced and jump knots follow."""
    import metaknot.algorithms.variable_projection as module

    starts: list[np.ndarray] = []
    solve = module.least_squares

    def recorded(fun, x0, *args, **kwargs):
        starts.append(np.array(x0))
        return solve(fun, x0, *args, **kwargs)

    monkeypatch.setattr(module, "least_squares", recorded)
    problem = FreeKnots(get_curve("archimedean", n_points=60), n_knots=6, objective="rmse")
    initial = np.linspace(0.0, 1.0, 8)[1:-1] + 0.01
    alone = mk.minimize(problem, "varpro", budget=400, seed=0,
                        optimizer_kwargs={"initial": list(initial), "only_initial": True,
                                          "stall": 0.0, "tolerance": 1e-15})
    z_initial = log_spans_from_knots(initial, problem.knot_bounds)
    assert len(starts) == 1 and np.array_equal(starts[0], z_initial)
    assert alone.n_evaluations > 200  # beyond the half a start gets among others
    starts.clear()
    converged = mk.minimize(problem, "varpro", budget=400, seed=0,  # and no start after it
                            optimizer_kwargs={"initial": list(initial), "only_initial": True})
    assert len(starts) == 1 and converged.n_evaluations < 400
    starts.clear()
    mk.minimize(problem, "varpro", budget=400, seed=0,
                optimizer_kwargs={"initial": list(initial), "restarts": 0, "stall": 0.0,
                                  "tolerance": 1e-15, "removal_start": False})
    assert len(starts) > 1 and np.array_equal(starts[0], z_initial)


def test_by_default_starts_follow_each_other_until_the_budget_is_spent():
    result = mk.minimize(_spline_problem(n_knots=7), "varpro", budget=1500, seed=0)
    assert result.n_evaluations == 1500


def test_one_start_takes_at_most_its_share_of_the_evaluations(monkeypatch):
    import metaknot.algorithms.variable_projection as module

    shares = []
    original = module.least_squares

    def recorded(*args, max_nfev, **kwargs):
        shares.append(max_nfev)
        return original(*args, max_nfev=max_nfev, **kwargs)

    monkeypatch.setattr(module, "least_squares", recorded)
    mk.minimize(FreeKnots(get_curve("archimedean", n_points=60), n_knots=6, objective="rmse"),
                "varpro", budget=2000, seed=0)
    # 100 iterations: an evaluation and a Jacobian charged as 7 fits each
    assert module.start_evaluations(6) == 800
    assert shares[0] == 800 // (6 + 2) == 100
    assert max(shares) <= 100


def test_restarts_spend_the_budget_that_converged_starts_leave():
    problem = _spline_problem(n_knots=7)
    without, with_restarts = (mk.minimize(problem, "varpro", budget=3000, seed=0,
                                          optimizer_kwargs={"restarts": restarts})
                              for restarts in (0, 5))
    assert without.n_evaluations < with_restarts.n_evaluations


def test_the_perturbation_and_tolerance_change_the_search(monkeypatch):
    import metaknot.algorithms.variable_projection as module

    problem = FreeKnots(get_curve("archimedean", n_points=60), n_knots=6, objective="rmse")
    # a budget that reaches the perturbed starts (after the moved knots), none of it given to
    # the quasi-Newton finish (which would take what the perturbed start gets)
    monkeypatch.setattr(module, "FINISH_ITERATIONS", 0)
    base = mk.minimize(problem, "varpro", budget=600, seed=1, optimizer_kwargs={"restarts": 4})
    wider = mk.minimize(problem, "varpro", budget=600, seed=1,
                         optimizer_kwargs={"restarts": 4, "perturbation": 2.0})
    assert (base.n_evaluations, base.external_fits) != (wider.n_evaluations, wider.external_fits)
    loose = mk.minimize(problem, "varpro", budget=400, seed=1,
                        optimizer_kwargs={"restarts": 0, "tolerance": 1e-2})
    tight = mk.minimize(problem, "varpro", budget=400, seed=1,
                        optimizer_kwargs={"restarts": 0})
    assert loose.n_evaluations < tight.n_evaluations


def test_a_start_given_is_tried_first_and_checked():
    problem = FreeKnots(get_curve("archimedean", n_points=60), n_knots=6, objective="rmse")
    given = np.linspace(0.05, 0.6, 6) * problem.knot_bounds[1]
    result = mk.minimize(problem, "varpro", budget=50, seed=0,
                         optimizer_kwargs={"initial": list(given)})
    assert result.trace.best_f[0] == pytest.approx(problem.evaluate(given[None, :])[0], rel=1e-12)
    for bad, message in (([0.1, 0.2], "the problem's 6 knots"),
                         (given[::-1], "increasing and inside")):
        with pytest.raises(ValueError, match=message):
            mk.minimize(problem, "varpro", budget=5, seed=0,
                        optimizer_kwargs={"initial": list(bad)})


def test_the_methods_own_fits_are_declared(monkeypatch):
    import sys

    import metaknot.algorithms.variable_projection as module

    calls = {True: 0, False: 0}  # Jacobians; fits of a point's residual (after its evaluation)
    refits = []  # fits made for a Jacobian (its point's fit not kept)

    class Counted(module.Projection):
        def __init__(self, *args, **kwargs):
            caller = sys._getframe(1).f_code.co_name
            calls[False] += caller == "_fit"
            refits.append(caller == "jacobian")
            super().__init__(*args, **kwargs)

        def jacobian(self):
            calls[True] += 1
            return super().jacobian()

    evaluations = []
    evaluate = module.Evaluator.__call__

    def recorded(self, X, *args, **kwargs):  # a batch the budget refuses is not counted
        values = evaluate(self, X, *args, **kwargs)
        evaluations.append(len(X))
        return values

    removal_fits = []
    removal = module.removal_knots

    def removed(*args, **kwargs):
        knots, fits = removal(*args, **kwargs)
        removal_fits.append(fits)
        return knots, fits

    monkeypatch.setattr(module.Evaluator, "__call__", recorded)
    monkeypatch.setattr(module, "Projection", Counted)
    monkeypatch.setattr(module, "removal_knots", removed)
    problem = FreeKnots(get_curve("archimedean", n_points=60), n_knots=6, objective="rmse")
    result = mk.minimize(problem, "varpro", budget=300, seed=0)
    assert calls[True] > 0 and removal_fits == [6]  # 12 averaging knots down to 6
    assert sum(refits) <= calls[True] // 4, (sum(refits), calls)  # a Jacobian reuses its fit
    # the residual's fit (a repeat of the evaluation's) declared; each Jacobian charged as
    # 6 + 1 fits and the removal start's fits as fits, but for what the budget could not take
    # at the end (external): at most two Jacobians, one pending when a single evaluation is
    # left (the charge leaves it to the evaluation) and one made after that evaluation
    assert result.n_evaluations - result.charged_fits == sum(evaluations)
    assert result.charged_fits + result.external_fits == \
        calls[False] + (6 + 1) * calls[True] + 6
    assert (6 + 1) * calls[True] - result.charged_fits <= 2 * (6 + 1)
    assert result.status == "ok" and result.record()["charged_fits"] == result.charged_fits


MULTIPLE_KNOTS = np.array([0.13, 0.37, 0.37, 0.58, 0.58, 0.58, 0.81])  # a double, a triple


def _multiple_knot_problem(**options) -> FreeKnots:
    """Points of a cubic spline with a double knot (a kink) and a triple one (a corner), none
    at a data parameter."""
    x = np.linspace(0.0, 1.0, 301)
    coefficients = np.array([0.0, 1.0, -1.0, 2.0, 0.5, -0.5, 1.5, 0.2, 1.0, -0.3, 0.4])
    y = BSpline(np.r_[[0.0] * 4, MULTIPLE_KNOTS, [1.0] * 4], coefficients, 3)(x)
    return FreeKnots(PointSet(y[:, None], "kinks", params=x), n_knots=MULTIPLE_KNOTS.size,
                     objective="rmse", **options)


def test_the_jacobian_of_a_multiple_knot_moves_its_copies_together():
    rng = np.random.default_rng(5)
    u, q = _data(rng, 80, 2)
    knots = np.array([0.2, 0.45, 0.45, 0.6, 0.6, 0.6, 0.8])
    _, jacobian, _ = residual_jacobian(u, q, 3, knots, (0.0, 1.0))

    def residual(at: np.ndarray) -> np.ndarray:
        return residual_jacobian(u, q, 3, at, (0.0, 1.0), jacobian=False)[0]

    for group in ([1, 2], [3, 4, 5]):
        _assert_slope(residual, knots, group, jacobian[:, group].sum(axis=1))


def test_a_double_and_a_triple_knot_are_recovered_to_rounding_when_spans_may_merge():
    """From knots near the truth with every multiple knot split apart, the search drives the
    split spans below ``merge_spacing``, merges them and ends at the true multiple knots;
    the same start without merging cannot end there."""
    start = MULTIPLE_KNOTS + np.array([0.01, -0.004, 0.004, -0.006, 0.0, 0.006, -0.01])
    merging = mk.minimize(_multiple_knot_problem(merge_spacing=1e-4), "varpro", budget=6000,
                          seed=0, optimizer_kwargs={"initial": list(start)})
    assert merging.best_f <= 1e-12
    solution = _multiple_knot_problem(merge_spacing=1e-4).decode(merging.best_x)
    np.testing.assert_allclose(solution.fit.spline.t[4:-4], MULTIPLE_KNOTS, atol=1e-9)
    plain = mk.minimize(_multiple_knot_problem(), "varpro", budget=6000, seed=0,
                        optimizer_kwargs={"initial": list(start)})
    assert plain.best_f > 1e3 * merging.best_f


def test_a_start_with_a_multiple_knot_needs_a_problem_that_allows_it():
    given = list(MULTIPLE_KNOTS)
    result = mk.minimize(_multiple_knot_problem(merge_spacing=0.0), "varpro", budget=20,
                         seed=0, optimizer_kwargs={"initial": given})
    assert result.trace.best_f[0] <= 1e-12  # the true knots, tried first
    with pytest.raises(ValueError, match="increasing and inside"):
        mk.minimize(_multiple_knot_problem(), "varpro", budget=5, seed=0,
                    optimizer_kwargs={"initial": given})
    with pytest.raises(ValueError, match="each at most 3 times"):
        mk.minimize(_multiple_knot_problem(merge_spacing=0.0), "varpro", budget=5, seed=0,
                    optimizer_kwargs={"initial": [0.1, 0.2, 0.3, 0.3, 0.3, 0.3, 0.5]})


def test_kangs_spline_is_recovered_from_the_data_sites_nearest_its_knots():
    """kang_spline (1,001 points, knots between them, a double one at 0.5408): from the data
    parameters nearest its 11 knots, the double knot split into 0.540 and 0.542, the search
    with merge_spacing=1e-4 ends at the true knots."""
    from metaknot.suite import get_instance
    from metaknot.suite.functions import KANG_KNOTS

    start = np.round(np.array(KANG_KNOTS), 3)
    start[6:8] = 0.540, 0.542
    problem = FreeKnots(get_instance("kang_spline").point_set(), n_knots=11, objective="rmse",
                        merge_spacing=1e-4)
    result = mk.minimize(problem, "varpro", budget=5000, seed=0,
                         optimizer_kwargs={"initial": list(start)})
    assert result.best_f <= 1e-12
    np.testing.assert_allclose(np.sort(result.best_x), KANG_KNOTS, atol=1e-9)


@pytest.mark.parametrize("optimizer", ["varpro", "nlopt:LD_LBFGS"])
def test_the_gradient_methods_run_blas_on_one_thread(optimizer, monkeypatch):
    """Every residual and Jacobian of varpro and nlopt's gradient methods is computed with
    BLAS on one thread (small matrices; a second thread waiting on a busy machine made them
    100 times slower), and the limit ends with the run."""
    from threadpoolctl import threadpool_info

    import metaknot.algorithms.variable_projection as vp

    def blas_threads() -> set[int]:
        return {lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"}

    seen: list[set[int]] = []

    class Recording(vp.Projection):  # residual_jacobian (nlopt's gradient) makes one too
        def jacobian(self):
            seen.append(blas_threads())
            return super().jacobian()

    monkeypatch.setattr(vp, "Projection", Recording)
    before = blas_threads()
    problem = FreeKnots(PointSet(CIRCLE), n_knots=4, closed=True, objective="rmse")
    mk.minimize(problem, optimizer, budget=200, seed=0)
    assert seen and all(threads == {1} for threads in seen)
    assert blas_threads() == before


def _kang() -> tuple[np.ndarray, np.ndarray]:
    from metaknot.suite import get_instance

    data = get_instance("kang_spline").point_set()
    return np.asarray(data.params), np.asarray(data.points)


def test_jump_knots_find_kangs_knots_and_its_double_one_above_noise():
    """Each of kang_spline's 11 knots within a data spacing (the double one as two knots next
    to 0.5408), with noise of 1e-9 of the range added: a repeat weight ten times larger gives
    the double knot a third copy instead of the knot at 0.9407, ten times smaller gives a
    knot to a cluster of noise instead of the double knot's second."""
    from metaknot.algorithms.variable_projection import jump_knots
    from metaknot.suite.functions import KANG_KNOTS

    u, q = _kang()
    for seed in range(3):
        noisy = q + 1e-9 * np.ptp(q) * np.random.default_rng(seed).normal(size=q.shape)
        found = jump_knots(u, noisy, 3, 11, (0.0, 1.0))
        assert np.abs(found - np.array(KANG_KNOTS)).max() < 1.1e-3
        for weight in (1e-2, 1e-4):
            other = jump_knots(u, noisy, 3, 11, (0.0, 1.0), repeat_weight=weight)
            assert np.abs(other - np.array(KANG_KNOTS)).max() > 1e-2


def test_jump_knots_repeat_a_knot_at_most_degree_times():
    from metaknot.algorithms.variable_projection import jump_knots
    from metaknot.suite.functions import KANG_KNOTS

    u, q = _kang()
    found = jump_knots(u, q, 3, 31, (0.0, 1.0))
    assert found.size == 31 and np.all(np.diff(found) > 0)
    for knot in KANG_KNOTS:
        assert 1 <= np.sum(np.abs(found - knot) < 3e-3) <= 3


def test_jump_knots_of_a_closed_outline_skip_its_seam():
    """A periodic cubic with breakpoints 0 and six knots: the six found (a cluster at the
    seam, where the breakpoint 0 is a knot already, gives none), a seventh repeats one."""
    from metaknot.algorithms.variable_projection import jump_knots

    knots = np.array([0.11, 0.27, 0.43, 0.52, 0.68, 0.86])
    breaks = np.r_[0.0, knots]
    t = np.r_[breaks[-3:] - 1.0, breaks, 1.0, breaks[1:4] + 1.0]
    coefficients = np.random.default_rng(1).normal(size=(breaks.size, 2))
    u = np.arange(400) / 400
    q = BSpline(t, np.r_[coefficients, coefficients[:3]], 3)(u)
    np.testing.assert_allclose(jump_knots(u, q, 3, 6, (0.0, 1.0), closed=True), knots,
                               atol=1e-9)
    seventh = jump_knots(u, q, 3, 7, (0.0, 1.0), closed=True)
    assert seventh.size == 7 and np.abs(seventh[:, None] - knots).min(axis=1).max() < 3e-3


def test_kangs_spline_is_recovered_from_its_own_starts():
    """From its own starts (the jump knots among them), 3,000 evaluations: kang_spline with
    11 knots and merge_spacing=1e-4 to rounding, the double knot merged."""
    from metaknot.suite import get_instance
    from metaknot.suite.functions import KANG_KNOTS

    data = get_instance("kang_spline").point_set()
    problem = FreeKnots(data, n_knots=11, objective="rmse", merge_spacing=1e-4)
    result = mk.minimize(problem, "varpro", budget=3000, seed=0)
    assert result.best_f <= 1e-9 * np.ptp(data.points)
    np.testing.assert_allclose(np.sort(result.best_x), KANG_KNOTS, atol=1e-9)


def test_a_knot_spent_where_it_does_little_is_moved_where_the_error_is():
    """humps with 7 knots (suite task fixed_k_small.free), seed 0: the deterministic starts
    end at 2.46-2.64 and the perturbed and drawn ones at 1.94 at best; moving the knot whose
    removal costs least to the span with the largest error, again after each improvement,
    reaches the reference's 0.21271 (a long multi-start of scipy's L-BFGS-B/Nelder-Mead)."""
    from metaknot.suite import get_instance
    from metaknot.suite.tasks import get_task

    problem = get_task(get_instance("humps"), "fixed_k_small.free").problem()
    result = mk.minimize(problem, "varpro", budget=3000, seed=0)
    assert result.best_f <= 0.2128


def _noisy_humps():
    from metaknot.suite import get_instance
    from metaknot.suite.tasks import get_task

    return get_task(get_instance("humps+noise0.01s0"), "fixed_k_small.free").problem()


def test_a_creeping_start_gives_way_to_the_next(monkeypatch):
    """humps+noise0.01s0 at K = 7: the averaging knots' solve creeps (knots running together)
    through its whole share of 100 iterations without ``stall``; with the default it stops
    within a third of them, and the budget left reaches better knots (1.056 before, as
    measured)."""
    import metaknot.algorithms.variable_projection as module

    problem = _noisy_humps()
    original = module.least_squares
    solves: list = []

    def recorded(*args, **kwargs):
        solves.append(original(*args, **kwargs))
        return solves[-1]

    monkeypatch.setattr(module, "least_squares", recorded)
    for stall, most in ((0.0, 100), (1e-3, 33)):
        solves.clear()
        mk.minimize(problem, "varpro", budget=3000, seed=0,
                    optimizer_kwargs={"restarts": 0, "stall": stall})
        assert (solves[0].nfev == most) if stall == 0.0 else (solves[0].nfev <= most)
    monkeypatch.setattr(module, "least_squares", original)
    assert mk.minimize(problem, "varpro", budget=3000, seed=0).best_f < 0.95


def test_knots_run_together_are_pulled_apart(monkeypatch):
    """A solve that ends with two knots between the same two data parameters goes on with one
    of them moved: without that (REPAIRS = 0) the same run on noisy humps ends elsewhere."""
    import metaknot.algorithms.variable_projection as module

    problem = _noisy_humps()
    ends = {}
    for repairs in (0, module.REPAIRS):
        monkeypatch.setattr(module, "REPAIRS", repairs)
        result = mk.minimize(problem, "varpro", budget=600, seed=0,
                             optimizer_kwargs={"restarts": 0})
        ends[repairs] = (result.n_evaluations, result.best_f)
    assert ends[0] != ends[module.REPAIRS]


def test_a_knot_moved_away_from_its_spans_passes_the_best_index_set(monkeypatch):
    """humps+noise0.01s0 at K = 7: every start and every knot moved within its own spans ends
    with two knots run together near 0.984 and one in the flat tail (0.9439, behind the
    best-known index set, re-fitted here); moving a knot away from its spans, with the knots
    run together parted, finds the basin below it (0.9417). With the knots left together
    (``PARTED_SPAN = 0``), or the knot moved only to the span of largest residual
    (``RELOCATION_SPANS = 1``), the run stays behind the index set."""
    import metaknot.algorithms.variable_projection as module
    from metaknot.suite.best import load_best_known

    problem = _noisy_humps()
    index = load_best_known()[("humps+noise0.01s0", "fixed_k_small.indices")]
    index_value = problem.evaluate(np.asarray(index.knots, dtype=float)[None, :])[0]
    assert index_value == pytest.approx(index.value, rel=1e-9)
    assert mk.minimize(problem, "varpro", budget=3000, seed=0).best_f < index_value
    for name, value in (("RELOCATION_SPANS", 1), ("PARTED_SPAN", 0.0)):
        with monkeypatch.context() as patched:
            patched.setattr(module, name, value)
            assert mk.minimize(problem, "varpro", budget=3000, seed=0).best_f > index_value


def test_no_start_is_solved_twice(monkeypatch):
    """A start is solved once: a moved knot that lands where an earlier move did (the best
    point unchanged) is not solved again (it would end where it ended)."""
    import metaknot.algorithms.variable_projection as module

    original = module.least_squares
    starts: list[bytes] = []

    def recorded(fun, x0, **kwargs):
        starts.append(np.asarray(x0).tobytes())
        return original(fun, x0, **kwargs)

    monkeypatch.setattr(module, "least_squares", recorded)
    mk.minimize(_noisy_humps(), "varpro", budget=3000, seed=0)
    assert len(starts) > 20 and len(set(starts)) == len(starts)


def test_a_start_and_its_repairs_keep_to_the_start_s_share(monkeypatch):
    """The solves on from knots that ran together are part of their start: with a share of
    200 evaluations, the four deterministic starts on noisy humps (whose knots run together)
    use 800 at most, repairs included, and the removal start's 7 fits."""
    import metaknot.algorithms.variable_projection as module

    monkeypatch.setattr(module, "start_evaluations", lambda n_knots: 200)
    result = mk.minimize(_noisy_humps(), "varpro", budget=3000, seed=0,
                         optimizer_kwargs={"restarts": 0})
    assert 600 < result.n_evaluations <= 4 * 200 + 7


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
def test_removal_keeps_the_knots_the_data_s_spline_has(closed):
    """Data of a spline whose knots are half of twice as many averaging knots: removing the
    least significant one at a time leaves exactly its knots (the others move the fit by
    rounding only), one fit per knot removed."""
    from metaknot.bspline import periodic_knot_vector
    from metaknot.bspline.curve import curve_model

    rng = np.random.default_rng(3)
    n, p, count = 200, 3, 6
    u = np.linspace(0.0, 1.0, n, endpoint=not closed)
    dense = np.sort(curve_model(closed)(u, np.zeros((n, 2)), p).start_knots(2 * count))
    kept = np.sort(rng.choice(dense, count, replace=False))
    if closed:
        t = periodic_knot_vector(kept, p)
        c = rng.normal(size=(count + 1, 2))
        points = BSpline(t, np.vstack((c, c[:p])), p)(u)
    else:
        t = np.r_[[0.0] * (p + 1), kept, [1.0] * (p + 1)]
        points = BSpline(t, rng.normal(size=(count + p + 1, 2)), p)(u)
    knots, fits = removal_knots(u, points, p, count, closed=closed)
    np.testing.assert_array_equal(knots, kept)
    assert fits == count


def test_the_removal_start_is_the_last_deterministic_one(monkeypatch):
    """The knots :func:`removal_knots` leaves are a start, after the averaging, equally spaced
    and jump knots, unless ``removal_start`` is off; none where it removes nothing."""
    import metaknot.algorithms.variable_projection as module

    starts = []
    original = module.least_squares

    def recorded(fun, z0, *args, **kwargs):
        starts.append(z0.copy())
        return original(fun, z0, *args, **kwargs)

    monkeypatch.setattr(module, "least_squares", recorded)
    problem = FreeKnots(get_curve("archimedean", n_points=60), n_knots=6, objective="rmse")
    removed, _ = removal_knots(problem.params, problem.points, 3, 6)
    expected = log_spans_from_knots(removed, problem.knot_bounds)
    for removal_start in (True, False):
        starts.clear()
        mk.minimize(problem, "varpro", budget=3000, seed=0,
                    optimizer_kwargs={"restarts": 0, "removal_start": removal_start})
        assert any(np.allclose(z0, expected) for z0 in starts[3:]) == removal_start
    from metaknot.bspline import parameterize

    few = get_curve("archimedean", n_points=10).points  # 5 averaging knots at most: none
    assert removal_knots(parameterize(few), few, 3, 6)[0].size == 0
    from metaknot.bspline import closed_parameterize

    outline = get_curve("epitrochoid", n_points=30).points  # K knots, or none, never fewer
    u = closed_parameterize(outline)
    sizes = {k: removal_knots(u, outline, 3, k, closed=True)[0].size for k in range(2, 29)}
    assert all(size in (0, k) for k, size in sizes.items()) and sizes[20] == 20


def test_the_budget_left_to_short_starts_finishes_the_best_point_by_quasi_newton(monkeypatch):
    """epitrochoid at K = 9 (closed; the residual large): Gauss-Newton creeps, and the last
    starts get too few evaluations to converge. What is left once a start's share is under
    ``FINISH_ITERATIONS`` iterations goes to L-BFGS-B from the best point in Gauss-Newton's
    metric: below the best-known index set of the same K (2.93247), the budget kept; 2.93268
    without the metric (its damping 1e-4: 2.93251), 2.93365 without the finish."""
    import metaknot.algorithms.variable_projection as module
    from metaknot.suite import get_instance
    from metaknot.suite.best import load_best_known
    from metaknot.suite.tasks import get_task

    task = get_task(get_instance("epitrochoid"), "fixed_k_small.free")
    index_set = load_best_known()[("epitrochoid", "fixed_k_small.indices")].value
    finished = mk.minimize(task.problem(), "varpro", budget=3000, seed=0)
    assert finished.best_f < index_set and finished.n_evaluations <= 3000
    monkeypatch.setattr(module, "METRIC_DAMPING", 1e-4)
    assert mk.minimize(task.problem(), "varpro", budget=3000, seed=0).best_f > index_set
    monkeypatch.setattr(module, "FINISH_ITERATIONS", 0)
    assert mk.minimize(task.problem(), "varpro", budget=3000, seed=0).best_f > 2.9335


def test_the_gauss_newton_metric_is_the_damped_hessian_of_the_sum_of_squares():
    from metaknot.algorithms.variable_projection import METRIC_DAMPING, gauss_newton_metric

    jacobian = np.random.default_rng(3).normal(size=(40, 5)) * np.array([1, 1, 1, 1, 1e-9])
    metric = gauss_newton_metric(jacobian)
    damping = METRIC_DAMPING * np.linalg.svd(jacobian, compute_uv=False)[0]
    expected = 2.0 * (jacobian.T @ jacobian + damping**2 * np.eye(5))
    np.testing.assert_allclose(metric.T @ metric, expected, rtol=1e-12, atol=1e-12)
    assert np.allclose(metric, np.triu(metric)) and np.linalg.cond(metric) < 1e3


def test_the_finish_starts_with_a_gauss_newton_step(monkeypatch):
    """clothoid+noise0.01s0 at K = 17: L-BFGS-B's first step has unit length in its variables;
    scaled so that it is Gauss-Newton's step, the finish gains 0.5 % (0.013744 -> 0.013676);
    a unit step in the metric's variables is refused and it gains nothing."""
    import metaknot.algorithms.variable_projection as module
    from metaknot.suite import get_instance
    from metaknot.suite.tasks import get_task

    task = get_task(get_instance("clothoid+noise0.01s0"), "fixed_k_large.free")
    finished = mk.minimize(task.problem(), "varpro", budget=3000, seed=0).best_f
    monkeypatch.setattr(module, "FINISH_ITERATIONS", 0)
    unfinished = mk.minimize(task.problem(), "varpro", budget=3000, seed=0).best_f
    assert finished < 0.997 * unfinished
