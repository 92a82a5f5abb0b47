"""Classical baselines: uniform, averaging (NURBS Book 9.68-9.69) and FITPACK knots."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import splev, splprep

import metaknot as mk
import metaknot.algorithms.baselines as bl
from metaknot.bspline.curve import OpenCurve
from metaknot.problems import FreeKnots, KnotIndices, KnotSelection

NAMES = ("uniform", "averaging", "fitpack")


def scipy_fitpack(problem, s):
    """FITPACK's smoothing spline for ``problem``'s data, parameters and degree (the reference)."""
    (tck, _), fp, _, _ = splprep(problem.points.T, u=problem.params, k=problem.degree, s=s,
                                 full_output=1, quiet=1)
    p = problem.degree
    return tck, fp, tck[0][p + 1 : -(p + 1)]


def set_up(name, problem, **kwargs):
    opt = mk.get_optimizer(name, **kwargs)
    opt.setup(problem, mk.make_rng(0))
    return opt


def all_candidates(opt):
    rows = []
    while (X := opt.ask()).shape[0]:
        rows.extend(X)
    return np.array(rows)


# --- knots of each baseline ------------------------------------------------------------------


def test_uniform_knots_are_equally_spaced():
    fixed = FreeKnots("archimedean", n_knots=7)
    result = mk.minimize(fixed, "uniform", budget=5, seed=0)
    assert result.n_evaluations == 1
    np.testing.assert_allclose(result.best_x, [1 / 8, 2 / 8, 3 / 8, 4 / 8, 5 / 8, 6 / 8, 7 / 8])

    variable = FreeKnots("archimedean", n_knots=12, variable_count=True)
    rows = all_candidates(set_up("uniform", variable, batch_size=5))
    assert rows.shape == (12, 12)
    for k, row in enumerate(rows, start=1):
        np.testing.assert_allclose(row[~np.isnan(row)], np.linspace(0.0, 1.0, k + 2)[1:-1])


def test_uniform_breakpoints_go_round_a_closed_outline():
    """On a closed outline the K knots and 0 split the whole period into K + 1 equal spans
    (the closing interval included; they were spread over the data parameters only, which
    end one spacing short of 1)."""
    angle = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    problem = FreeKnots(np.column_stack((np.cos(angle), np.sin(angle))), n_knots=5,
                        closed=True)
    assert problem.params[-1] < 1.0
    result = mk.minimize(problem, "uniform", budget=5, seed=0)
    np.testing.assert_allclose(result.best_x, np.arange(1, 6) / 6)


@pytest.mark.parametrize(("n_points", "degree", "n_knots"), [(8, 2, 2), (10, 3, 3)])
def test_averaging_knots_match_the_nurbs_book_by_hand(n_points, degree, n_knots):
    t = np.linspace(0.0, 2.5, n_points)
    problem = FreeKnots(np.column_stack((t, np.sin(t) + t**2)), degree=degree, n_knots=n_knots,
                        parameterization="chord")
    u = problem.params
    if n_points == 8:  # m = 7, n = 4, d = 8/3: j d = 8/3, 16/3
        expected = [u[1] / 3 + 2 * u[2] / 3, 2 * u[4] / 3 + u[5] / 3]
    else:  # m = 9, n = 6, d = 5/2: j d = 2.5, 5, 7.5
        expected = [(u[1] + u[2]) / 2, u[4], (u[6] + u[7]) / 2]
    result = mk.minimize(problem, "averaging", budget=3, seed=0)
    assert result.n_evaluations == 1
    np.testing.assert_allclose(result.best_x, expected, rtol=0, atol=1e-15)


@pytest.mark.parametrize("curve", ["epitrochoid", "vivaldi"])
@pytest.mark.parametrize("tolerance", [1e-2, 1e-3])
def test_fitpack_tolerance_uses_splprep_knots_for_s(curve, tolerance):
    variable = FreeKnots(curve, n_knots=100, variable_count=True)
    s = variable.data.n_points * tolerance**2
    _, fp, knots = scipy_fitpack(variable, s)
    assert 0 < knots.size <= 100
    kwargs = {"target": "tolerance", "tolerance": tolerance}
    result = mk.minimize(variable, "fitpack", budget=10, seed=0, optimizer_kwargs=kwargs)
    assert result.n_evaluations == 1
    np.testing.assert_array_equal(result.best_x[: knots.size], knots)
    assert np.isnan(result.best_x[knots.size :]).all()

    selection = KnotSelection(curve)
    result = mk.minimize(selection, "fitpack", budget=10, seed=0, optimizer_kwargs=kwargs)
    np.testing.assert_array_equal(result.best_x, np.isin(selection.params[1:-1], knots))
    # FITPACK stops at fp = s within 0.1 %; the least-squares refit can only be closer
    assert fp <= 1.001 * s
    assert result.solution.fit.rmse <= tolerance * np.sqrt(1.001)


@pytest.mark.parametrize("curve", ["epitrochoid", "vivaldi"])
def test_fitpack_count_search_hits_fitpack_counts(curve):
    probe = KnotSelection(curve)
    n = probe.data.n_points
    for exponent in (3, 4, 5, 6):
        k = scipy_fitpack(probe, n * 10.0**-exponent)[2].size  # a count FITPACK does choose
        problem = KnotIndices(curve, n_knots=k)
        s, knots = set_up("fitpack", problem).search({k})[k]
        np.testing.assert_array_equal(knots, scipy_fitpack(problem, s)[2])
        assert knots.size == k
        result = mk.minimize(problem, "fitpack", budget=10, seed=0)
        assert result.n_evaluations == 1
        np.testing.assert_array_equal(problem.params[result.best_x], knots)


@pytest.mark.parametrize("curve", ["epitrochoid", "vivaldi"])
@pytest.mark.parametrize("relative_s", [1e-2, 1e-4, 1e-6])
def test_least_squares_refit_beats_fitpack_smoothing_spline(curve, relative_s):
    problem = FreeKnots(curve, n_knots=150, variable_count=True)
    tck, fp, knots = scipy_fitpack(problem, relative_s * problem.data.n_points)
    fitpack_sse = np.sum((np.column_stack(splev(problem.params, tck)) - problem.points) ** 2)
    np.testing.assert_allclose(fitpack_sse, fp, rtol=1e-6)
    _, fit = problem.evaluate_details(problem.pad(knots)[None, :])
    assert fit.feasible[0]
    assert fit.sse[0] <= fitpack_sse * (1 + 1e-9)


def test_with_count_drops_and_inserts_by_hand():
    knots = np.array([0.3, 0.5, 0.6, 0.95])
    # spans around each knot: 0.5, 0.3, 0.45, 0.4 -> drop 0.5; then 0.6, 0.65, 0.4 -> drop 0.95
    np.testing.assert_allclose(bl.with_count(knots, 3, 0.0, 1.0), [0.3, 0.6, 0.95])
    np.testing.assert_allclose(bl.with_count(knots, 2, 0.0, 1.0), [0.3, 0.6])
    # spans 0.3, 0.2, 0.1, 0.35, 0.05 -> split 0.6..0.95; then 0.3, 0.2, 0.1, 0.175, 0.175, 0.05
    np.testing.assert_allclose(bl.with_count(knots, 5, 0.0, 1.0), [0.3, 0.5, 0.6, 0.775, 0.95])
    np.testing.assert_allclose(bl.with_count(knots, 6, 0.0, 1.0),
                               [0.15, 0.3, 0.5, 0.6, 0.775, 0.95])


def test_fitpack_unreachable_count_is_brought_to_k():
    found = set_up("fitpack", KnotSelection("archimedean")).search(set(range(1, 60)))
    k = min(set(range(1, 60)) - set(found))  # a count FITPACK never chose
    above, below = min(c for c in found if c > k), max(c for c in found if c < k)
    problem = FreeKnots("archimedean", n_knots=k)
    rows = all_candidates(set_up("fitpack", problem))
    assert rows.shape == (2, k)
    np.testing.assert_allclose(rows[0], bl.with_count(found[above][1], k, 0.0, 1.0))
    np.testing.assert_allclose(rows[1], bl.with_count(found[below][1], k, 0.0, 1.0))
    assert mk.minimize(problem, "fitpack", budget=1).n_evaluations == 1


# --- candidates of each encoding ----------------------------------------------------------


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("n_knots", [5, 40, 90])
def test_knot_indices_candidates_are_sorted_distinct_indices(name, n_knots):
    problem = KnotIndices("archimedean", n_knots=n_knots)
    rows = all_candidates(set_up(name, problem))
    assert 1 <= rows.shape[0] <= 2 and rows.shape[1] == n_knots
    assert (np.diff(rows, axis=1) > 0).all() and rows.min() >= 1 and rows.max() <= 98


def test_knot_indices_are_the_nearest_data_points():
    problem = KnotIndices("archimedean", n_knots=6)
    positions = np.linspace(0.0, 1.0, 8)[1:-1]
    nearest = np.abs(problem.params[:, None] - positions).argmin(axis=0)
    np.testing.assert_array_equal(all_candidates(set_up("uniform", problem))[0], nearest)


@pytest.mark.parametrize("name", NAMES)
def test_knot_selection_candidates_are_masks_with_k_ones(name):
    problem = KnotSelection("archimedean")  # N = 100: K up to 96 of 98 interior points
    rows = all_candidates(set_up(name, problem, batch_size=17))
    assert np.isin(rows, (0, 1)).all()
    counts = rows.sum(axis=1)
    if name == "fitpack":  # the counts FITPACK chooses, in increasing order
        assert (np.diff(counts) > 0).all() and 1 <= counts[0] and counts[-1] <= 96
        # every count FITPACK chooses where its count still falls monotonically with s (here
        # s >= 3e-9 fp0, up to about 25 knots; below, it wiggles and a bisection may miss counts)
        fp0 = scipy_fitpack(problem, 1e30)[1]
        grid = {scipy_fitpack(problem, s)[2].size for s in np.geomspace(3e-9 * fp0, fp0, 200)}
        assert len(grid) > 20 and grid - {0} <= set(counts)
    else:
        np.testing.assert_array_equal(counts, np.arange(1, 97))


def test_error_bounded_scan_finds_fewest_uniform_knots():
    problem = KnotSelection("vivaldi", objective="error_bounded")
    u, points = problem.params, problem.points
    tol = 1e-3 * problem.data.scale
    reference = None
    for k in range(1, 238):  # independent enumeration of the uniform knots
        nearest = np.abs(u[:, None] - np.linspace(0.0, 1.0, k + 2)[1:-1]).argmin(axis=0)
        assert np.unique(nearest).size == k  # no collisions up to the answer
        mask = np.zeros(u.size - 2, dtype=bool)
        mask[nearest - 1] = True
        fit = OpenCurve(u, points, 3).evaluate_masks(mask[None, :], max_deviation=True)
        if fit.feasible[0] and fit.max_deviation[0] <= tol:
            reference = mask
            break
    assert reference is not None and 5 < reference.sum() < 200
    result = mk.minimize(problem, "uniform", budget=10_000, seed=0)
    assert result.n_evaluations == 237
    np.testing.assert_array_equal(result.best_x, reference)
    assert result.solution.fit.max_deviation <= tol


# --- budget, determinism, callbacks, parameters ---------------------------------------------


@pytest.mark.parametrize("name", NAMES)
def test_budget_smaller_than_scan_stops_early(name):
    batches = []
    result = mk.minimize(KnotSelection("archimedean"), name, budget=25, seed=0,
                         optimizer_kwargs={"batch_size": 10},
                         callbacks=[lambda p: batches.append(p.n_evaluations)])
    assert result.n_evaluations == 25
    assert batches == [10, 20, 25]


@pytest.mark.parametrize("name", ["uniform", "averaging"])
def test_budget_larger_than_scan_uses_the_scan(name):
    problem = FreeKnots("archimedean", n_knots=30, variable_count=True)
    result = mk.minimize(problem, name, budget=1000, seed=0, optimizer_kwargs={"max_knots": 20})
    assert result.n_evaluations == 20
    assert np.sum(~np.isnan(result.best_x)) <= 20


@pytest.mark.parametrize("name", NAMES)
def test_deterministic_whatever_the_seed(name):
    runs = [mk.minimize("mask", name, budget=40, seed=seed,
                        problem_kwargs={"points": "archimedean", "objective": "bic"})
            for seed in (1, 1, 2)]
    for other in runs[1:]:
        np.testing.assert_array_equal(other.best_x, runs[0].best_x)
        assert other.best_f == runs[0].best_f
        np.testing.assert_array_equal(other.trace_evaluations, runs[0].trace_evaluations)
        np.testing.assert_array_equal(other.trace_best, runs[0].trace_best)


def test_callbacks_report_progress_and_can_stop():
    seen = []
    result = mk.minimize(KnotSelection("archimedean"), "averaging", budget=1000, seed=0,
                         optimizer_kwargs={"batch_size": 30},
                         callbacks=[lambda p: seen.append((p.n_evaluations, p.best_f))])
    assert [n for n, _ in seen] == [30, 60, 90, 96]
    bests = [f for _, f in seen]
    assert bests == sorted(bests, reverse=True) and bests[-1] == result.best_f
    stopped = mk.minimize(KnotSelection("archimedean"), "averaging", budget=1000, seed=0,
                          optimizer_kwargs={"batch_size": 30}, callbacks=[lambda p: True])
    assert stopped.n_evaluations == 30


def test_registered_and_recorded():
    result = mk.minimize("indices", "fitpack", budget=5, seed=0,
                         problem_kwargs={"points": "archimedean", "n_knots": 10})
    assert isinstance(mk.get_optimizer("fitpack"), bl.FitpackKnots)
    assert result.optimizer == "fitpack"
    assert result.optimizer_params == {"target": "count", "tolerance": None, "max_knots": None,
                                       "batch_size": 64}


@pytest.mark.parametrize(("name", "kwargs", "message"), [
    ("uniform", {"max_knots": 0}, "max_knots"),
    ("averaging", {"max_knots": 2.5}, "max_knots"),
    ("uniform", {"batch_size": 0}, "batch_size"),
    ("fitpack", {"target": "rmse"}, "target"),
    ("fitpack", {"target": "tolerance"}, "tolerance"),
    ("fitpack", {"tolerance": 1e-3}, "tolerance"),
    ("fitpack", {"target": "tolerance", "tolerance": 0.0}, "tolerance"),
    ("fitpack", {"target": "tolerance", "tolerance": float("nan")}, "tolerance"),
])
def test_bad_parameters_are_rejected(name, kwargs, message):
    with pytest.raises(ValueError, match=message):
        mk.get_optimizer(name, **kwargs)


def test_unsuitable_problems_are_rejected():
    with pytest.raises(ValueError, match="target='tolerance'"):
        mk.minimize("indices", "fitpack", budget=5,
                    optimizer_kwargs={"target": "tolerance", "tolerance": 1e-3})

    class Sphere(mk.Problem):
        encoding = mk.Encoding.continuous(3, -1.0, 1.0)

        def evaluate(self, X):
            return np.sum(X**2, axis=1)

        def decode(self, x):
            return x

    with pytest.raises(ValueError, match="knot problem"):
        mk.minimize(Sphere(), "uniform", budget=5)


@pytest.mark.parametrize("name", ["uniform", "averaging"])
def test_a_scan_on_a_closed_outline_goes_up_to_interpolation(name):
    """A closed outline of N points takes up to N - 1 interior knots (N control points, the
    interpolating spline), more than an open curve's N - p - 1: a tolerance only
    interpolation meets is met by the scan."""
    from metaknot.bspline import closed_parameterize

    angle = np.linspace(0.0, 2 * np.pi, 30, endpoint=False)
    square = np.column_stack((np.clip(1.5 * np.cos(angle), -1, 1),
                              np.clip(1.5 * np.sin(angle), -1, 1)))
    problem = KnotSelection(square, closed=True, objective="error_bounded",
                            objective_options={"tolerance": 1e-9})
    opt = set_up(name, problem)
    assert opt.counts == list(range(1, 30))  # N - 1 = 29
    result = mk.minimize(problem, name, budget=100, seed=0)
    assert result.n_evaluations == 29 and result.best_f < 31  # within the tolerance: N + err
    assert closed_parameterize(square).size == 30
