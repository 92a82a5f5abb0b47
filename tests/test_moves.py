"""Delta evaluation of local knot moves against the full batched evaluator.

Every candidate scored by a :class:`MoveEvaluator` must come back exactly as
:meth:`OpenCurve.evaluate_knots` scores it: the same reason code, the same control-point count
and the same SSE to 1e-10 relative. The tests also check that the delta path did the work (a
test in which every move fell back to the full fit would prove nothing).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from metaknot.bspline import Infeasibility, parameterize
from metaknot.bspline.curve import OpenCurve
from metaknot.bspline.knots import stack_masks
from metaknot.bspline.moves import PATH_CHECKS, PATH_DELTA, PATH_FULL, MoveEvaluator
from metaknot.problems import get_curve


def curve(n_points: int, dim: int, seed: int = 0) -> np.ndarray:
    """A smooth curve with a little noise, in ``dim`` dimensions."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, n_points)
    columns = [np.sin(2 * np.pi * (k + 1) * s + k) + 0.3 * s ** (k + 1) for k in range(dim)]
    return np.column_stack(columns) + 1e-3 * rng.standard_normal((n_points, dim))


def params_for(points: np.ndarray, how: str, degree: int, seed: int = 0) -> np.ndarray:
    if how == "explicit":
        rng = np.random.default_rng(seed)
        return np.sort(np.concatenate(([0.0, 1.0], rng.random(len(points) - 2))))
    return parameterize(points, how, degree=degree)


def stack(rows: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    offsets = np.concatenate(([0], np.cumsum([len(r) for r in rows]))).astype(np.int64)
    knots = np.concatenate(rows) if rows else np.empty(0)
    return knots.astype(np.float64), offsets


def assert_same(me: MoveEvaluator, knots: np.ndarray, offsets: np.ndarray,
                max_deviation: bool = False) -> np.ndarray:
    """Scores of the move evaluator equal the full evaluator's; returns the paths."""
    fit, path = me.evaluate(knots, offsets, max_deviation=max_deviation)
    ref = OpenCurve(me.u, me.q, me.degree).evaluate_knots(knots, offsets,
                                                          max_deviation=max_deviation)
    assert_same_scores(fit, ref, me.q, max_deviation)
    if not max_deviation:
        assert fit.max_deviation is None
    assert set(np.unique(path)) <= {PATH_DELTA, PATH_CHECKS, PATH_FULL}
    return path


def assert_same_scores(fit, ref, q: np.ndarray, max_deviation: bool) -> None:
    """A move evaluator's fits equal the reference kernel's: reasons and control points
    exactly, SSE (and the maximum deviation) of the feasible ones to rounding, +inf else."""
    np.testing.assert_array_equal(fit.reason, ref.reason)
    np.testing.assert_array_equal(fit.n_control_points, ref.n_control_points)
    ok = ref.feasible
    scale = float(np.sum(q ** 2))
    np.testing.assert_allclose(fit.sse[ok], ref.sse[ok], rtol=1e-10, atol=1e-22 * scale)
    assert np.all(np.isinf(fit.sse[~ok]))
    if max_deviation:
        # near interpolation both deviations are rounding (1e-10 of the curve's size)
        np.testing.assert_allclose(fit.max_deviation[ok], ref.max_deviation[ok], rtol=1e-9,
                                   atol=1e-9 * np.sqrt(scale))


def random_mask(rng: np.random.Generator, n_var: int, density: float) -> np.ndarray:
    return rng.random(n_var) < density


def feasible_mask(u, q, degree, rng, density) -> np.ndarray:
    """A random mask whose fit is feasible (re-drawn until it is)."""
    for _ in range(200):
        mask = random_mask(rng, u.size - 2, density)
        knots, offsets = stack_masks(u, mask[None, :])
        if OpenCurve(u, q, degree).evaluate_knots(knots, offsets, max_deviation=False).feasible[0]:
            return mask
    raise AssertionError("no feasible mask found")


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("how", ["uniform", "chord", "centripetal", "explicit"])
def test_every_bit_flip_matches_the_full_fit(degree, dim, how):
    q = curve(70, dim, seed=degree + 10 * dim)
    u = params_for(q, how, degree, seed=dim)
    rng = np.random.default_rng(degree * 100 + dim)
    for density in (0.15, 0.5):
        mask = feasible_mask(u, q, degree, rng, density)
        me = MoveEvaluator(u, q, u[1:-1][mask], degree)
        flips = np.repeat(mask[None], u.size - 2, axis=0) ^ np.eye(u.size - 2, dtype=bool)
        path = assert_same(me, *stack_masks(u, flips))
        np.testing.assert_array_equal(
            path, assert_same(me, *stack_masks(u, flips), max_deviation=True))
        if degree <= 3 or density < 0.3:
            # dense knots of degree 4-5 are too badly conditioned to certify: full fits
            assert np.mean(path == PATH_DELTA) > 0.5, np.bincount(path)


@pytest.mark.parametrize("degree", [1, 3, 5])
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_index_moves_and_shifts_match(degree, dim):
    q = curve(80, dim, seed=dim)
    u = params_for(q, "centripetal", degree)
    rng = np.random.default_rng(7 + degree)
    k = 12
    while True:
        idx = np.sort(rng.choice(np.arange(1, u.size - 1), size=k, replace=False))
        try:
            me = MoveEvaluator(u, q, u[idx], degree)
            break
        except ValueError:
            continue
    rows = []
    for _ in range(300):
        moved = idx.copy()
        moved[rng.integers(k)] = rng.integers(1, u.size - 1)  # knot k to index k'
        rows.append(u[np.sort(moved)])
    for i in range(k):  # every knot to its neighbouring data points
        for step in (-2, -1, 1, 2):
            moved = idx.copy()
            moved[i] += step
            if 1 <= moved[i] <= u.size - 2:
                rows.append(u[np.sort(moved)])
    path = assert_same(me, *stack(rows))
    assert np.mean(path == PATH_DELTA) > 0.3, np.bincount(path)
    assert (path == PATH_CHECKS).any()  # some moves made coincident knots


@pytest.mark.parametrize("degree", [2, 3, 4])
@pytest.mark.parametrize("dim", [1, 2])
def test_free_knot_shift_insert_remove_match(degree, dim):
    q = curve(90, dim, seed=3 * dim)
    u = params_for(q, "chord", degree)
    rng = np.random.default_rng(degree)
    interior = np.sort(rng.uniform(0.05, 0.95, 10))
    me = MoveEvaluator(u, q, interior, degree)
    rows = []
    for _ in range(200):
        kind = rng.integers(3)
        x = rng.uniform(u[0], u[-1])
        if kind == 0:  # shift one knot to x
            moved = interior.copy()
            moved[rng.integers(interior.size)] = x
            rows.append(np.sort(moved))
        elif kind == 1:  # insert x
            rows.append(np.sort(np.append(interior, x)))
        else:  # remove one
            rows.append(np.delete(interior, rng.integers(interior.size)))
    for i in range(interior.size):  # small shifts, staying between the neighbours
        moved = interior.copy()
        moved[i] += 1e-3
        rows.append(moved)
    path = assert_same(me, *stack(rows))
    assert np.mean(path == PATH_DELTA) > 0.8, np.bincount(path)


def test_infeasible_moves_get_the_full_kernels_reason():
    q = curve(60, 2)
    u = parameterize(q, "centripetal")
    interior = u[5:-5:6].copy()
    me = MoveEvaluator(u, q, interior, 3)
    gap = (u[20] + u[21]) / 2
    rows = [
        np.sort(np.append(interior, interior[2])),  # coincident with a knot
        np.sort(np.append(interior, u[-1])),  # on the range end
        np.sort(np.append(interior, -0.5)),  # outside
        np.append(interior[:-1], np.nan),  # not a number
        np.sort(np.concatenate((interior, gap + 1e-9 * np.arange(6)))),  # no data inside
        np.concatenate((interior, u[1:-1])),  # more control points than points (unsorted)
        u[1:-1].copy(),  # interpolation plus: too many
    ]
    fit, path = me.evaluate(*stack(rows))
    ref = OpenCurve(u, q, 3).evaluate_knots(*stack(rows), max_deviation=False)
    np.testing.assert_array_equal(fit.reason, ref.reason)
    expected = {Infeasibility.COINCIDENT_KNOTS, Infeasibility.KNOT_OUT_OF_RANGE,
                Infeasibility.SCHOENBERG_WHITNEY, Infeasibility.TOO_MANY_CONTROL_POINTS}
    assert expected <= {Infeasibility(r) for r in fit.reason}
    assert np.all(path[~ref.feasible] != PATH_DELTA)


@pytest.mark.parametrize("degree", [3, 4, 5])
def test_near_singular_moves_get_the_full_kernels_verdict(degree):
    # dense knots (80-90 % of the points) make some moves numerically singular: those must
    # come back SINGULAR, as from the full kernel, and never as a delta-path fit
    q = np.asarray(get_curve("epitrochoid", n_points=100).points)
    u = parameterize(q, "centripetal")
    rng = np.random.default_rng(degree)
    singular = 0
    paths = []
    for density in (0.8, 0.9) * 3:
        mask = random_mask(rng, u.size - 2, density)
        try:
            me = MoveEvaluator(u, q, u[1:-1][mask], degree)
        except ValueError:
            continue
        n_var = u.size - 2
        ones = np.repeat(mask[None], n_var, axis=0) ^ np.eye(n_var, dtype=bool)
        twos = np.repeat(mask[None], n_var - 1, axis=0)
        twos[np.arange(n_var - 1), np.arange(n_var - 1)] ^= True
        twos[np.arange(n_var - 1), np.arange(1, n_var)] ^= True  # neighbouring bits
        children = np.vstack((ones, twos))
        path = assert_same(me, *stack_masks(u, children))
        ref = OpenCurve(u, q, degree).evaluate_knots(*stack_masks(u, children), max_deviation=False)
        singular += int(np.sum(ref.reason == Infeasibility.SINGULAR))
        assert np.all(path[ref.reason == Infeasibility.SINGULAR] == PATH_FULL)
        paths.append(path)
    paths = np.concatenate(paths)
    assert singular > 0
    assert (paths == PATH_FULL).any()
    if degree == 3:  # dense knots of degree 4-5 are beyond what the delta path certifies
        assert (paths == PATH_DELTA).sum() > 50


def test_dense_incumbent_near_interpolation():
    q = curve(50, 2)
    u = parameterize(q, "chord")
    mask = np.ones(u.size - 2, dtype=bool)
    mask[::7] = False
    me = MoveEvaluator(u, q, u[1:-1][mask], 3)
    flips = np.repeat(mask[None], u.size - 2, axis=0) ^ np.eye(u.size - 2, dtype=bool)
    assert_same(me, *stack_masks(u, flips))


def test_max_deviation_matches_on_the_delta_path():
    q = curve(70, 2)
    u = parameterize(q, "centripetal")
    rng = np.random.default_rng(3)
    mask = feasible_mask(u, q, 3, rng, 0.4)
    me = MoveEvaluator(u, q, u[1:-1][mask], 3)
    flips = np.repeat(mask[None], u.size - 2, axis=0) ^ np.eye(u.size - 2, dtype=bool)
    path = assert_same(me, *stack_masks(u, flips), max_deviation=True)
    assert np.mean(path == PATH_DELTA) > 0.9
    # the incumbent itself, and free-knot moves of every kind, degrees 1-5
    for degree in (1, 2, 3, 4, 5):
        interior = np.sort(rng.uniform(0.1, 0.9, 8))
        me = MoveEvaluator(u, q, interior, degree)
        rows = [interior, np.sort(np.append(interior, 0.5)), interior[1:], interior[:-1],
                np.sort(np.append(interior[1:], 0.05)), interior + 1e-3]
        path = assert_same(me, *stack(rows), max_deviation=True)
        assert (path == PATH_DELTA).all()


def test_rebind_moves_the_incumbent_and_the_incumbent_scores_itself():
    q = curve(60, 3)
    u = parameterize(q, "centripetal")
    rng = np.random.default_rng(5)
    mask = feasible_mask(u, q, 3, rng, 0.3)
    me = MoveEvaluator(u, q, u[1:-1][mask], 3)
    for _ in range(20):  # a random walk of accepted flips
        flips = np.repeat(mask[None], u.size - 2, axis=0) ^ np.eye(u.size - 2, dtype=bool)
        fit, _ = me.evaluate(*stack_masks(u, flips))
        ok = np.flatnonzero(fit.feasible)
        mask = flips[rng.choice(ok)]
        me.rebind(u[1:-1][mask])
        fit, path = me.evaluate(*stack_masks(u, mask[None]))
        ref = OpenCurve(u, q, 3).evaluate_knots(*stack_masks(u, mask[None]), max_deviation=False)
        assert path[0] == PATH_DELTA
        np.testing.assert_allclose(fit.sse, ref.sse, rtol=1e-10)
        np.testing.assert_allclose(me.sse, ref.sse[0], rtol=1e-10)
    assert_same(me, *stack_masks(u, flips))


def test_an_infeasible_incumbent_is_refused():
    q = curve(30, 2)
    u = parameterize(q, "uniform")
    with pytest.raises(ValueError, match="incumbent cannot be fitted"):
        MoveEvaluator(u, q, np.array([0.5, 0.5]), 3)
    with pytest.raises(ValueError, match="1-D"):
        MoveEvaluator(u, q, np.ones((2, 2)) * 0.5, 3)
    with pytest.raises(ValueError, match="max_window_rows"):
        MoveEvaluator(u, q, u[5:-5:5], 3, max_window_rows=-1)
    me = MoveEvaluator(u, q, u[5:-5:5], 3)
    with pytest.raises(ValueError, match="offsets"):
        me.evaluate(u[5:-5:5], np.array([0, 2]))
    with pytest.raises(ValueError, match="1-D"):
        me.evaluate(u[5:-5:5][None, :], np.array([0, 1]))


def test_wide_changes_fall_back_to_the_full_fit():
    q = curve(80, 2)
    u = parameterize(q, "uniform")
    interior = u[4:-4:5].copy()
    me = MoveEvaluator(u, q, interior, 3, max_window_rows=40)
    far = interior.copy()
    far[0] += 1e-3
    far[-1] -= 1e-3  # two changes at the ends: the window spans almost every row
    near = interior.copy()
    near[5] += 1e-3
    path = assert_same(me, *stack([far, near]))
    assert list(path) == [PATH_FULL, PATH_DELTA]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(degree=st.integers(1, 5), dim=st.integers(1, 3), n_points=st.integers(12, 60),
       density=st.floats(0.05, 0.95), seed=st.integers(0, 2**32 - 1),
       how=st.sampled_from(["uniform", "chord", "centripetal", "explicit"]))
@example(degree=3, dim=2, n_points=17, density=0.75, seed=17, how="centripetal")  # interpolating
def test_random_moves_match_the_full_fit(degree, dim, n_points, density, seed, how):
    q = curve(n_points, dim, seed=seed % 1000)
    u = params_for(q, how, degree, seed=seed)
    rng = np.random.default_rng(seed)
    try:
        mask = feasible_mask(u, q, degree, rng, density)
    except AssertionError:
        return  # too few points for this degree and density
    me = MoveEvaluator(u, q, u[1:-1][mask], degree)
    n_var = u.size - 2
    children = np.repeat(mask[None], 40, axis=0)
    for child in children:
        flips = rng.integers(1, 4)
        if rng.random() < 0.5:  # neighbouring bits
            start = rng.integers(n_var)
            child[start:start + flips] ^= True
        else:
            child[rng.choice(n_var, size=min(flips, n_var), replace=False)] ^= True
    assert_same(me, *stack_masks(u, children), max_deviation=bool(seed % 2))
    free = [np.sort(np.append(u[1:-1][mask], rng.uniform(u[0], u[-1]))) for _ in range(10)]
    assert_same(me, *stack(free))


def test_generated_move_loops_are_current():
    """``_moves_rows.py`` must be what ``python -m metaknot.bspline._codegen`` writes."""
    from metaknot.bspline import _codegen

    assert _codegen.MOVES_TARGET.read_text() == _codegen.render_moves(), (
        "metaknot/bspline/_moves_rows.py is stale: run `python -m metaknot.bspline._codegen`"
    )


def test_more_than_three_coordinates_are_refused_with_a_clear_error():
    q = np.random.default_rng(0).random((30, 4)).cumsum(axis=0)
    u = parameterize(q, "chord")
    with pytest.raises(ValueError, match="1 to 3 coordinates"):
        MoveEvaluator(u, q, u[5:-5:5], 3)
    with pytest.raises(ValueError, match="1 to 3 coordinates"):
        OpenCurve(u, q, 3).evaluate_knots(u[5:-5:5], np.array([0, u[5:-5:5].size]))
    from metaknot.problems import KnotSelection

    with pytest.raises(ValueError, match="1 to 3 coordinates"):
        KnotSelection(q)


@pytest.mark.parametrize("degree", [1, 3, 5])
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_replacements_score_as_the_candidates_they_make(degree, dim):
    from metaknot.bspline.moves import bit_flips

    q = curve(70, dim, seed=dim)
    u = params_for(q, "centripetal", degree)
    rng = np.random.default_rng(degree + dim)
    mask = feasible_mask(u, q, degree, rng, 0.3)
    me = MoveEvaluator(u, q, u[1:-1][mask], degree)
    bits = np.arange(u.size - 2)
    fit, path = me.evaluate_replacements(*bit_flips(u, mask, bits))
    flips = np.repeat(mask[None], u.size - 2, axis=0) ^ np.eye(u.size - 2, dtype=bool)
    ref, ref_path = me.evaluate(*stack_masks(u, flips))
    np.testing.assert_array_equal(fit.reason, ref.reason)
    np.testing.assert_array_equal(fit.n_control_points, ref.n_control_points)
    np.testing.assert_array_equal(path, ref_path)
    ok = ref.feasible
    np.testing.assert_allclose(fit.sse[ok], ref.sse[ok], rtol=1e-12)
    # general replacements: shifts, two knots for one, one for two, nothing for several
    interior = me.interior
    k = interior.size
    starts, stops, inserted, counts = [], [], [], []
    for _ in range(200):
        a = int(rng.integers(0, k))
        b = min(k, a + int(rng.integers(0, 3)))
        lo = interior[a - 1] if a > 0 else u[0]
        hi = interior[b] if b < k else u[-1]
        new = np.sort(rng.uniform(lo, hi, int(rng.integers(0, 3))))
        if rng.random() < 0.1:
            new = new[::-1].copy()  # out of order: coincident knots, as the full kernel says
        starts.append(a)
        stops.append(b)
        inserted.append(new)
        counts.append(new.size)
    offsets = np.concatenate(([0], np.cumsum(counts)))
    fit, path = me.evaluate_replacements(np.array(starts), np.array(stops),
                                         np.concatenate(inserted), offsets,
                                         max_deviation=True)
    rows = [np.concatenate((interior[:a], new, interior[b:]))
            for a, b, new in zip(starts, stops, inserted, strict=True)]
    ref = OpenCurve(u, q, degree).evaluate_knots(*stack(rows), max_deviation=True)
    np.testing.assert_array_equal(fit.reason, ref.reason)
    ok = ref.feasible
    np.testing.assert_allclose(fit.sse[ok], ref.sse[ok], rtol=1e-10, atol=1e-22 * np.sum(q**2))
    np.testing.assert_allclose(fit.max_deviation[ok], ref.max_deviation[ok], rtol=1e-9,
                               atol=1e-11 * np.sqrt(np.sum(q**2)))
    assert (path == PATH_DELTA).sum() > 50


def test_replacements_refuse_bad_arrays():
    from metaknot.bspline.moves import bit_flips

    q = curve(30, 2)
    u = parameterize(q, "uniform")
    me = MoveEvaluator(u, q, u[4:-4:4], 3)
    k = me.interior.size
    with pytest.raises(ValueError, match="start:stop"):
        me.evaluate_replacements([2], [k + 1], [], [0, 0])
    with pytest.raises(ValueError, match="start:stop"):
        me.evaluate_replacements([3], [2], [], [0, 0])
    with pytest.raises(ValueError, match="same length"):
        me.evaluate_replacements([1, 2], [2], [], [0, 0])
    with pytest.raises(ValueError, match="one entry more"):
        me.evaluate_replacements([1], [2], [0.5], [0, 1, 1])
    with pytest.raises(ValueError, match="bits"):
        bit_flips(u, np.zeros(u.size - 2), [u.size])


@pytest.mark.parametrize("closed", [False, True])
def test_fractional_offsets_starts_stops_and_bits_are_refused(closed):
    """Offsets, starts, stops and bits of 2.5 were truncated to 2 (another candidate, scored
    silently); whole numbers given as floats are taken."""
    from metaknot.bspline.curve import make_curve
    from metaknot.bspline.moves import bit_flips

    points = curve(40, 2)
    model = make_curve(points, closed=closed)
    u = model.params
    incumbent = model.candidate_params[[5, 10, 15, 20, 25, 30]]
    me = model.move_evaluator(incumbent)
    assert me is not None
    with pytest.raises(ValueError, match="offsets must be integers"):
        me.evaluate(incumbent, [0, 2.5, 6])
    whole, _ = me.evaluate(incumbent, [0.0, 6.0])
    assert whole.reason.tolist() == [0]
    with pytest.raises(ValueError, match="starts must be integers"):
        me.evaluate_replacements([1.5], [2], [incumbent[1]], [0, 1])
    with pytest.raises(ValueError, match="stops must be integers"):
        me.evaluate_replacements([1], [2.5], [incumbent[1]], [0, 1])
    with pytest.raises(ValueError, match="offsets must be integers"):
        me.evaluate_replacements([1], [2], [incumbent[1]], [0, 0.5])
    same, _ = me.evaluate_replacements([1.0], [2.0], [incumbent[1]], [0.0, 1.0])
    assert same.sse[0] == pytest.approx(whole.sse[0], rel=1e-10)
    mask = np.isin(model.candidate_params, incumbent)
    with pytest.raises(ValueError, match="bits must be integers"):
        bit_flips(u, mask, [1.5], closed=closed)
    assert np.array_equal(bit_flips(u, mask, [1.0, 4.0], closed=closed)[0],
                          bit_flips(u, mask, [1, 4], closed=closed)[0])


@pytest.mark.parametrize("degree", [2, 3, 4, 5])
def test_an_incumbent_of_few_control_points_scores_itself_with_its_max_deviation(degree):
    """With at most 2p control points the incumbent's own max-deviation check merges from
    column p (the first forward state written), never from below it: the score equals the full
    fit's on every try (reading below p gave fresh, often wrong, scores)."""
    q = curve(9 + degree, 2)
    u = parameterize(q, "chord")
    for k in range(degree):  # n = p + 1 + k control points, up to 2p
        interior = np.linspace(u[0], u[-1], k + 2)[1:-1]
        for _ in range(20):
            me = MoveEvaluator(u, q, interior, degree)
            assert_same(me, *stack([interior]), max_deviation=True)


@pytest.mark.parametrize("closed", [False, True])
@pytest.mark.parametrize("max_multiplicity", [1, 2, 3])
def test_one_check_decides_moves_and_whole_candidates_as_the_batch_evaluator(
        closed, max_multiplicity):
    """Open and closed moves share one check of their knots: a move scored as a replacement,
    the candidate it makes scored whole, and the batch evaluator give the same reason (knots
    out of range, out of order, repeated too often, too many), the same control points and,
    for a feasible candidate, the same SSE to rounding. Out of order, an open candidate is
    refused and a closed one sorted (as the batch evaluators do)."""
    from metaknot.bspline.curve import make_curve

    rng = np.random.default_rng(max_multiplicity + 3 * closed)
    s = np.linspace(0, 2 * np.pi, 90, endpoint=False)
    points = np.column_stack((np.cos(s) + 0.3 * np.sin(3 * s), np.sin(2 * s)))
    model = make_curve(points, degree=3, closed=closed)
    sites = model.candidate_params
    interior = sites[4:-4:6]  # five free sites between neighbours, four or more at the ends
    interior = np.sort(np.concatenate((interior, np.repeat(interior[7], max_multiplicity - 1))))
    moves = model.move_evaluator(interior, max_multiplicity=max_multiplicity)
    assert moves is not None
    k = interior.size
    lo, hi = model.knot_bounds
    free = np.setdiff1d(sites, interior)

    def between(start: int, stop: int, count: int = 1) -> list[float]:
        """``count`` free sites between the knots a replacement of ``start:stop`` keeps."""
        left = interior[start - 1] if start > 0 else lo
        right = interior[stop] if stop < k else hi
        inside = free[(free > left) & (free < right)]
        return sorted(rng.choice(inside, count, replace=False))

    replacements = [(2, 3, []), (2, 3, between(2, 3)), (4, 4, between(4, 4)), (0, 0, []),
                    (5, 5, [interior[5]]), (5, 5, [interior[5]] * 3), (3, 4, [0.9, 0.1]),
                    (6, 8, [interior[6]] * 4), (2, 3, [np.nan]), (2, 3, [lo]),
                    (2, 3, [hi]), (k, k, between(k, k)), (1, 4, between(1, 4, 3)),
                    (7, 7, [interior[7]]),  # a knot of multiplicity max_multiplicity raised
                    (0, k, list(np.linspace(lo, hi, sites.size + 8)[1:-1]))]  # too many
    starts, stops, inserted, offsets = [], [], [], [0]
    whole, counts = [], [0]
    for start, stop, new in replacements:
        starts.append(start)
        stops.append(stop)
        inserted.extend(new)
        offsets.append(len(inserted))
        whole.extend(np.concatenate((interior[:start], new, interior[stop:])))
        counts.append(len(whole))
    fit, path = moves.evaluate_replacements(starts, stops, inserted, offsets)
    again, again_path = moves.evaluate(np.array(whole), np.array(counts))
    ref = model.evaluate_knots(np.array(whole), np.array(counts),
                               max_multiplicity=max_multiplicity)
    for scored in (fit, again):
        np.testing.assert_array_equal(scored.reason, ref.reason)
        np.testing.assert_array_equal(scored.n_control_points, ref.n_control_points)
        ok = ref.feasible
        np.testing.assert_allclose(scored.sse[ok], ref.sse[ok], rtol=1e-10)
    np.testing.assert_array_equal(path == PATH_CHECKS, again_path == PATH_CHECKS)
    reasons = {Infeasibility(r) for r in ref.reason}
    assert {Infeasibility.KNOT_OUT_OF_RANGE, Infeasibility.COINCIDENT_KNOTS,
            Infeasibility.TOO_MANY_CONTROL_POINTS} <= reasons
    assert ref.feasible.sum() >= 6
    shuffled = replacements.index((3, 4, [0.9, 0.1]))
    assert ref.feasible[shuffled] == closed  # sorted on a closed curve, refused on an open one
