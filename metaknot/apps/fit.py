"""A user's points to a compact B-spline within a tolerance: :func:`fit` (``metaknot fit``).

Open curves and function data get a clamped spline of degree p; closed outlines a periodic one
(:class:`metaknot.bspline.curve.ClosedCurve`, FITPACK's periodic spline as the reference). The
search:

1. **FITPACK's answer** — the reference everyone knows: FITPACK's smoothing spline
   (:mod:`metaknot.bspline.fitpack`) over a scan of its smoothing factor s, refined by bisection
   on log s, keeping the fewest control points whose error is within the tolerance.
2. **Starts** — FITPACK's knots, the averaging knots (NURBS Book) at the fewest knots whose
   least-squares fit is within the tolerance, and the knots of the literature methods in
   :data:`LITERATURE_STARTS` (:mod:`metaknot.algorithms.literature`), all refitted by least
   squares: a portfolio, so the result is no worse than any of them.
3. **Knot removal** — from each start, every "remove one knot" candidate is scored in one batch
   (by exact delta evaluation from the current knots, :mod:`metaknot.bspline.moves`); the best
   is taken while it stays within the tolerance. When none
   does, the knots next to the most promising removals are nudged, a knot at a time, over a
   grid between their neighbours, and the removal is tried again.
4. **Fewer still** — one knot fewer at a time, knots at data points are searched under the
   ``error_bounded`` objective at the same tolerance by the ``local_search`` optimizer
   (removal, insertion and shifts from the averaging knots) and, failing that, the GA, while
   a count within the tolerance is found; then knot removal once more.
   **Polish** (``polish``, the default) — knot removal once more, and where it would stop,
   the most promising removal's knots moved freely by variable projection; on from there
   while that is within the tolerance. Where it stops at few knots (``K <= 9``), one knot
   fewer is searched by variable projection from its own starts, and the polish goes on from
   there if that is within the tolerance.
5. The result never has more control points than FITPACK's answer: if the search does not beat
   it, FITPACK's own spline is returned, and ``method`` says which one it is.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import BSpline

from ..bspline import check_degree, fitpack
from ..bspline.curve import Curve, Metric, batch_errors, closure, make_curve
from ..bspline.fit import check_metric
from ..bspline.knots import stack_rows
from ..bspline.moves import PATH_DELTA, MoveEvaluator
from ..bspline.parameterize import as_points, check_coordinates
from ..validate import check_flag, check_tolerance, is_integer

__all__ = ["ToleranceFit", "corner_params", "fit"]


@dataclass(frozen=True, eq=False)
class ToleranceFit:
    """The spline :func:`fit` returns, with what it took to find it.

    Attributes
    ----------
    spline
        A :class:`scipy.interpolate.BSpline`, coefficients of shape ``(n_control_points, d)``
        (closed curves: a periodic spline on [0, 1), ``n_control_points + p`` coefficients).
    params
        The parameter value of every data point (``x`` for function data).
    tolerance, metric
        The absolute tolerance and the error it bounds.
    method
        ``"knot removal"`` or ``"knot removal + fixed-count search"`` (metaknot's search),
        ``"fitpack"`` (FITPACK's answer was not beaten), or the literature method asked for.
    metrics
        ``n_control_points``, ``max_deviation``, ``rmse``, ``seconds``.
    fitpack
        FITPACK's answer at the same tolerance: ``n_control_points``, ``max_deviation``,
        ``rmse``, ``s`` and ``seconds``.
    closed, points
        Whether the curve was fitted as a closed outline, and the points fitted (a closed
        outline's repeated last point dropped).
    """

    spline: BSpline
    params: np.ndarray
    tolerance: float
    metric: str
    method: str
    metrics: dict[str, float]
    fitpack: dict[str, float]
    stages: list[str] = field(default_factory=list)
    closed: bool = False
    points: np.ndarray | None = None

    @property
    def knots(self) -> np.ndarray:
        """The full clamped knot vector."""
        return np.asarray(self.spline.t)

    @property
    def interior_knots(self) -> tuple[np.ndarray, np.ndarray]:
        """The distinct interior knots (an open curve's; a closed outline's breakpoints in
        (0, 1)) and the multiplicity of each (above 1 only with ``corners``)."""
        p = self.degree
        lo, hi = self.parameter_range
        t = self.knots[p + 1 : self.knots.size - p - 1]
        values, counts = np.unique(t[(t > lo) & (t < hi)], return_counts=True)
        return values, counts

    @property
    def control_points(self) -> np.ndarray:
        """The distinct control points (a closed curve's spline repeats its first p at the
        end of ``spline.c``)."""
        return np.asarray(self.spline.c)[: self.metrics["n_control_points"]]

    @property
    def parameter_range(self) -> tuple[float, float]:
        """The interval the spline is defined on: ``[u_0, u_{N-1}]``, or ``[0, 1)`` for a
        closed outline (``spline.t[p]`` and ``spline.t[-p-1]`` either way)."""
        p = self.degree
        return float(self.spline.t[p]), float(self.spline.t[-p - 1])

    @property
    def degree(self) -> int:
        return int(self.spline.k)

    @property
    def n_control_points(self) -> int:
        return int(self.control_points.shape[0])


class _Search:
    """Knot removal with nudging, on the compiled batched evaluator of the curve."""

    def __init__(self, curve: Curve, tol: float, metric: Metric, nudge_grid: int = 9,
                 nudge_window: int = 3, nudge_tries: int = 3, max_multiplicity: int = 1,
                 parameterization: str = "centripetal") -> None:
        self.curve, self.tol, self.metric = curve, tol, metric
        self.parameterization = parameterization  # the curve's (a polish's problem needs it)
        self.grid, self.window, self.tries = nudge_grid, nudge_window, nudge_tries
        self.max_multiplicity = max_multiplicity
        self.evaluations = 0
        self.delta_evaluations = 0
        self._moves: MoveEvaluator | None = None

    def errors(self, rows: list[np.ndarray] | np.ndarray, near: np.ndarray | None = None
               ) -> np.ndarray:
        """Error of each row of sorted interior knots (``inf`` if it cannot be fitted); rows
        one move from the knots ``near`` are scored by delta evaluation (open and closed
        curves)."""
        self.evaluations += len(rows)
        moves = None if near is None else self._move_evaluator(near)
        if moves is None:
            return self.curve.errors(rows, self.metric, max_multiplicity=self.max_multiplicity)
        batch, path = moves.evaluate(*stack_rows(rows),
                                     max_deviation=self.metric == "max_deviation")
        self.delta_evaluations += int(np.count_nonzero(path == PATH_DELTA))
        return batch_errors(batch, self.metric, self.curve.n_points)

    def _move_evaluator(self, near: np.ndarray) -> MoveEvaluator | None:
        """The move evaluator bound to the knots ``near`` (None if the curve has none, or the
        knots cannot be fitted)."""
        if self._moves is None or not np.array_equal(self._moves.interior, near):
            self._moves = self.curve.move_evaluator(near, self._moves,
                                                    max_multiplicity=self.max_multiplicity)
        return self._moves

    def nudge(self, knots: np.ndarray, around: int, sweeps: int = 2) -> tuple[np.ndarray, float]:
        """Move the knots near index ``around`` one at a time to the grid position (between
        their neighbours) that lowers the error most."""
        knots = knots.copy()
        (err,) = self.errors([knots])
        lo_u, hi_u = self.curve.knot_bounds
        for _ in range(sweeps):
            moved = False
            for j in range(max(0, around - self.window), min(len(knots), around + self.window)):
                left = knots[j - 1] if j > 0 else lo_u
                right = knots[j + 1] if j + 1 < len(knots) else hi_u
                grid = np.linspace(left, right, self.grid + 2)[1:-1]
                rows = np.repeat(knots[None], grid.size, axis=0)  # knot j at each grid point
                rows[:, j] = grid
                errs = self.errors(rows, near=knots)
                best = int(np.argmin(errs))
                if errs[best] < err:
                    knots, err, moved = rows[best], float(errs[best]), True
            if not moved:
                break
        return knots, err

    def polish(self, knots: np.ndarray, err: float) -> tuple[np.ndarray, float]:
        """``knots`` moved by variable projection (``varpro`` on the curve's points as free
        knots, least squares, from these knots alone: :data:`POLISH_ITERATIONS` Gauss-Newton
        steps at most); knots closer than 1e-6 of the parameter range become one multiple
        knot where multiplicities are allowed. Under the metric ``max_deviation``, knots still
        beyond the tolerance are moved once more, by ``varpro`` under the objective
        ``max_deviation``, from where least squares left them (as many steps). Returns the
        polished knots and their error, or the given ones (their error ``err``) if polishing
        did not lower it."""
        if knots.size == 0:
            return knots, float(err)
        best, best_err = knots, float(err)
        objectives = ("rmse", "max_deviation") if self.metric == "max_deviation" else ("rmse",)
        for objective in objectives:
            found = self._varpro(best, objective)
            if found is None:
                break
            (found_err,) = self.errors([found])
            if found_err < best_err:
                best, best_err = found, float(found_err)
            if best_err <= self.tol:
                break
        return best, best_err

    def _varpro(self, knots: np.ndarray, objective: str) -> np.ndarray | None:
        """The best knots of a short ``varpro`` run from ``knots`` alone under ``objective``
        (:data:`POLISH_ITERATIONS` steps; None if the curve's free-knot problem would see
        other parameters)."""
        # from these knots alone (the averaging and equally spaced starts searched far from
        # them, at twice the time on bench_fit's star outline)
        steps = POLISH_ITERATIONS * (knots.size + 2)  # a step: an evaluation, a Jacobian
        return self._run_varpro(knots.size, objective, steps,
                                {"initial": knots, "only_initial": True})

    def fewer_free(self, knots: np.ndarray) -> np.ndarray | None:
        """Where it is cheap (:data:`FREE_SEARCH_ITERATIONS` times ``K + 1`` evaluations, at
        most :data:`FREE_SEARCH_MOST`): one knot fewer than ``knots`` (``K``) searched by
        ``varpro`` from its own starts, under the metric's objective; its knots if they are
        within the tolerance, else None."""
        count = knots.size - 1
        steps = FREE_SEARCH_ITERATIONS * (count + 2)
        if count < max(1, self.curve.min_interior_knots) or steps > FREE_SEARCH_MOST:
            return None
        found = self._run_varpro(count, self.metric, steps, {"restarts": 0})
        if found is None or self.errors([found])[0] > self.tol:
            return None
        return found

    def _run_varpro(self, n_knots: int, objective: str, budget: int,
                    options: dict[str, Any]) -> np.ndarray | None:
        """The best knots of a ``varpro`` run (``options``, seed 0) on the curve's points as
        ``n_knots`` free knots under ``objective`` (knots closer than 1e-6 of the parameter
        range merged where multiplicities are allowed); None if the curve's free-knot problem
        would see other parameters."""
        import metaknot as mk
        from metaknot.problems import FreeKnots, PointSet
        from metaknot.problems.knot_problems import merge_close_knots

        curve = self.curve
        lo, hi = curve.knot_bounds
        merge = 1e-6 * (hi - lo) if self.max_multiplicity > 1 else None
        # a closed outline's problem computes its parameters as the curve did (a thinned
        # copy's are those of all points: not polished)
        data = PointSet(curve.points, params=None if curve.closed else curve.params)
        problem = FreeKnots(data, n_knots=n_knots, degree=curve.degree, objective=objective,
                            merge_spacing=merge, closed=curve.closed,
                            parameterization=self.parameterization)
        if not np.array_equal(problem.params, curve.params):
            return None
        result = mk.minimize(problem, "varpro", budget=budget, seed=0,
                             optimizer_kwargs=options)
        self.evaluations += result.n_evaluations
        found = np.sort(np.asarray(result.best_x, dtype=np.float64))
        if merge is not None:
            found = merge_close_knots(found[None, :], merge)[0]
        return found

    def remove(self, knots: np.ndarray, polish: bool = False) -> np.ndarray:
        """Remove knots while the fit stays within the tolerance (see the module notes); with
        ``polish``, where neither a removal nor a nudge holds, the most promising removals are
        polished (:meth:`polish`) before the search gives up."""
        knots = np.sort(np.asarray(knots, dtype=np.float64))
        while len(knots):
            # one copy of each knot (a multiple knot loses one copy: the same row from each)
            first = np.flatnonzero(np.diff(knots, prepend=-np.inf) != 0)
            rows = [np.delete(knots, j) for j in first]
            errs = self.errors(rows, near=knots)
            order = np.argsort(errs)
            if errs[order[0]] <= self.tol:
                knots = rows[order[0]]
                continue
            unstuck = self._unstick(rows, errs, order, first, polish)
            if unstuck is None:
                return knots
            knots = unstuck
        return knots

    def _unstick(self, rows: list[np.ndarray], errs: np.ndarray, order: np.ndarray,
                 removed: np.ndarray, polish: bool) -> np.ndarray | None:
        """Where no removal stays within the tolerance: the most promising removals (``order``
        of ``errs``; ``rows[j]`` is the knots without knot ``removed[j]``) nudged, then, with
        ``polish``, the most promising polished (:meth:`polish`) and, under the maximum
        deviation, the next :data:`MAX_DEVIATION_TRIES` moved by ``varpro`` under
        ``max_deviation`` alone; the first within the tolerance, or None."""
        for j in order[: self.tries]:
            if not np.isfinite(errs[j]):
                return None  # no removal left can be fitted: nothing to nudge
            nudged, err = self.nudge(rows[j], int(removed[j]))
            if err <= self.tol:
                return nudged
        for j in order[:POLISH_TRIES] if polish else []:
            found, err = self.polish(rows[j], float(errs[j]))
            if err <= self.tol:
                return found
        further = MAX_DEVIATION_TRIES if polish and self.metric == "max_deviation" else 0
        for j in order[POLISH_TRIES : POLISH_TRIES + further]:
            if not np.isfinite(errs[j]) or rows[j].size == 0:
                break
            moved = self._varpro(rows[j], "max_deviation")
            if moved is not None and self.errors([moved])[0] <= self.tol:
                return moved
        return None

    def fewest_averaging(self, upper: int) -> np.ndarray | None:
        """The curve's spread knots (averaging knots on open curves) at the fewest count, up
        to ``upper``, whose fit is within the tolerance."""
        curve = self.curve
        counts = range(curve.min_interior_knots, min(upper, curve.max_interior_knots) + 1)
        rows = [curve.spread_knots(k) for k in counts]
        errs = self.errors(rows)
        ok = np.flatnonzero(errs <= self.tol)
        return rows[ok[0]] if ok.size else None


#: A data point is a corner where the polygon through its neighbours ``CORNER_REACH`` points
#: away on either side turns by more than this (radians) and by more than at the points near it.
CORNER_ANGLE = 0.5
CORNER_REACH = 2


def corner_params(curve: Curve, angle: float = CORNER_ANGLE, reach: int = CORNER_REACH
                  ) -> np.ndarray:
    """Parameters of the data points where the curve appears to have a corner: the chords to
    the points ``reach`` away turn by more than ``angle`` there, the most within ``reach``
    points (function data as the graph, each axis scaled to [0, 1]); only points strictly
    inside the knot range (not a closed outline's point 0, an open curve's first or last
    ``reach``)."""
    from metaknot.algorithms.equidistribution import turning_angles

    turn = turning_angles(curve, reach)
    window = np.stack([np.roll(turn, k) for k in range(-reach, reach + 1)])
    peaks = np.flatnonzero((turn >= window.max(axis=0)) & (turn > angle))
    # of equal maxima within reach of each other, the first
    peaks = peaks[np.diff(peaks, prepend=-reach - 1) > reach]
    lo, hi = curve.knot_bounds
    at = curve.params[peaks]
    return at[(at > lo) & (at < hi)]


def _with_corners(knots: np.ndarray, corners: np.ndarray, multiplicity: int) -> np.ndarray:
    """``knots`` with a knot of ``multiplicity`` at each corner (knots already there
    replaced)."""
    kept = knots[~np.isin(knots, corners)]
    return np.sort(np.concatenate((kept, np.repeat(corners, multiplicity))))


def _largest_multiplicity(knots: np.ndarray) -> int:
    """The most copies of one value among sorted ``knots`` (1 for none)."""
    if knots.size == 0:
        return 1
    return int(np.unique(knots, return_counts=True)[1].max())


#: Gauss-Newton steps of a polish by variable projection (``polish``) from the knots it is
#: given: its ``varpro`` run has this many times ``K + 2`` evaluations (a step is an
#: evaluation and a Jacobian, charged as ``K + 1`` fits).
POLISH_ITERATIONS = 40
#: The removals polished where knot removal would stop, the most promising first.
POLISH_TRIES = 1
#: Under the maximum deviation, the next removals then moved by ``varpro`` under
#: ``max_deviation`` alone (humps: the second removal within the tolerance at 15 control
#: points, where the first polished stayed beyond it).
MAX_DEVIATION_TRIES = 2
#: Where the polish stops at ``K`` knots, ``K - 1`` searched by ``varpro`` from its own starts
#: (the averaging, equally spaced, jump and removal knots; no restarts), with this many times
#: ``K + 1`` evaluations, if that is at most ``FREE_SEARCH_MOST`` (K <= 9). galvez_f3's
#: tolerance task: 11 control points instead of 12 (removal and polish left its knots at 1.9
#: times the tolerance; 300 times K + 1 stopped the starts short), in 1.4 s instead of 0.8 s.
FREE_SEARCH_ITERATIONS = 600
FREE_SEARCH_MOST = 6000


#: ``fit``'s default ``budget`` (the GA's at each count; the local search gets a quarter): on the
#: suite's 135 tolerance tasks 20,000 gave the same control points on 131 (1 fewer on one, 1,
#: 4 and 6 more on three), in 247 s against 168 s in all; on ``bench_literature``'s 21 cases
#: 2,000 to 20,000 gave the same control points; ``bench_fit``'s slowest case (the star
#: outline) 1.3-1.5 s instead of 2.2-2.8 s.
FIXED_COUNT_BUDGET = 5000
#: A search at a fixed count stops after this many evaluations without improving its best.
STALL_EVALUATIONS = 5000


def fixed_count_searches(budget: int) -> tuple[tuple[str, dict[str, Any], int], ...]:
    """The searches tried at each knot count (name, options, budget): the local search with a
    quarter of ``budget``, then a GA with all of it."""
    return ("local_search", {}, max(1, budget // 4)), ("ga", {"population": 100}, budget)


def _fewer_at_fixed_counts(curve: Curve, tol: float, metric: Metric, parameterization: str,
                           count: int, searches: tuple[tuple[str, dict[str, Any], int], ...],
                           seed: int = 0,
                           progress: bool = False, max_multiplicity: int = 1
                           ) -> tuple[np.ndarray | None, int]:
    """Knots at data points, one fewer at a time than ``count``: each count is searched under
    ``error_bounded`` at the same tolerance by the local search (best-improvement removal,
    insertion and shifts from the averaging knots), then, if that stays beyond the tolerance,
    by the GA (``searches``: :func:`fixed_count_searches`); an index may repeat
    ``max_multiplicity`` times (a multiple knot). Returns the knots of the last count found
    within the tolerance (or None) and the fits used."""
    from metaknot.callbacks import StopWhenStalled
    from metaknot.problems import KnotIndices, PointSet
    from metaknot.runner import minimize

    # an open curve's own parameters (a thinned copy's are those of all points); a closed
    # problem computes its own, and the knots found are mapped back to the curve's below
    data = PointSet(curve.points, params=None if curve.closed else curve.params)
    found, fits = None, 0
    for k in range(count - 1, 0, -1):
        problem = KnotIndices(data, n_knots=k, degree=curve.degree, closed=curve.closed,
                              parameterization=parameterization, objective="error_bounded",
                              objective_options={"tolerance": tol, "metric": metric},
                              max_multiplicity=max_multiplicity)
        within = None
        for name, options, budget in searches:
            try:
                result = minimize(problem, name, budget=budget, seed=seed,
                                  optimizer_kwargs=options, progress=progress,
                                  callbacks=[StopWhenStalled(STALL_EVALUATIONS)])
            except ValueError:  # a search that cannot start here (no averaging knots for k)
                continue
            fits += result.n_evaluations
            if result.best_x is not None and \
                    result.best_f <= k + curve.extra_control_points + 1:
                within = result.best_x
                break
        if within is None:
            break
        found = np.sort(curve.params[np.asarray(within, dtype=np.int64)])
    return found, fits


def _check_points(points: ArrayLike, params: ArrayLike | None, degree: int,
                  function: bool) -> tuple[np.ndarray, np.ndarray | None]:
    if function:
        columns = np.asarray(points, dtype=np.float64)
        if columns.ndim != 2 or columns.shape[1] < 2:
            raise ValueError("function data needs at least two columns: x, then f(x)")
        params, points = columns[:, 0].copy(), columns[:, 1:].copy()
    q = as_points(points, degree=degree)
    if params is not None:
        params = np.asarray(params, dtype=np.float64)
        if params.shape != (q.shape[0],):
            raise ValueError("the parameter values (x) must be one per point")
        check_coordinates(params, "the parameter values (x)")
        steps = np.flatnonzero(np.diff(params) <= 0)
        if steps.size:
            raise ValueError(f"x must increase strictly: row {steps[0] + 2} has x "
                             f"{params[steps[0] + 1]:g} after {params[steps[0]]:g}")
    else:
        same = np.flatnonzero((np.diff(q, axis=0) == 0).all(axis=1))
        if same.size:
            raise ValueError(f"point {same[0] + 1} (row {same[0] + 2}) repeats the point "
                             "before it; remove repeated consecutive points")
    return q, params


def fit(points: ArrayLike, tolerance: float, *, relative: bool = False,
        metric: Metric = "max_deviation", function: bool = False,
        params: ArrayLike | None = None, degree: int = 3,
        parameterization: str = "centripetal", closed: bool | None = None,
        method: str = "auto", budget: int = FIXED_COUNT_BUDGET, seed: int = 0,
        corners: bool = False,
        polish: bool = True, progress: bool = False,
        on_stage: Callable[[str], None] | None = None) -> ToleranceFit:
    """The fewest control points whose clamped B-spline stays within ``tolerance`` of the points.

    Parameters
    ----------
    points
        ``(N, d)`` data points; with ``function=True`` the first column is ``x`` and the others
        are ``f(x)`` (as FITPACK's curves of one coordinate), and ``x`` is the parameter.
    tolerance
        The tolerance on ``metric``; with ``relative=True`` a fraction of the bounding-box
        diagonal of the points.
    metric
        ``"max_deviation"`` (largest point distance, the default) or ``"rmse"``.
    params
        Explicit parameter values (instead of ``parameterization``).
    degree
        Spline degree, 1..5.
    parameterization
        ``"uniform"``, ``"chord"`` or ``"centripetal"`` (ignored with explicit parameters).
    closed
        ``True``: a closed outline, fitted by a periodic spline (no seam); ``False``: an open
        curve, clamped at its ends; ``None`` (default): closed if the chord from the last
        point back to the first is at most 2.5 typical point spacings
        (:func:`metaknot.bspline.curve.closure`). A closed outline's last point is dropped if
        it repeats the first. The first stage line says which was chosen and why.
    method
        ``"auto"`` (knot removal, then the fixed-count search: the best in
        ``benchmarks/bench_fit.py``), ``"removal"`` (knot removal only, fastest),
        ``"fitpack"`` (FITPACK's answer), or the name of a literature method
        (:data:`metaknot.algorithms.literature.METHODS`: ``newknt``, ``equidistribution``,
        ``dominant_points``, ``lyche_morken``, ``bisection``, ``sparse_l1``): its knots as
        they are (a ``ValueError`` says why if they are not within the tolerance).
    budget, seed
        Evaluations of the GA at each count of the fixed-count search (the local search gets
        a quarter; :data:`FIXED_COUNT_BUDGET`, 5,000 by default, says why) and the seed of
        both.
    corners
        Allow knots of multiplicity up to the degree, where the curve is then only continuous
        (C^0; a double knot of a cubic leaves it C^1): the search also starts from each start
        with a knot of multiplicity ``degree`` at every corner :func:`corner_params` finds,
        knot removal lowers multiplicities one copy at a time, and the fixed-count search may
        repeat a knot. Off by default: the spline is then C^(degree - 1) everywhere.
    polish
        After the search (``method`` ``"auto"`` or ``"removal"``), remove knots once more,
        and where neither a removal nor a nudge stays within the tolerance, polish the most
        promising removal by variable projection (free knot positions, least squares:
        ``varpro`` from those knots) and go on if it is within the tolerance; where that
        stops at 9 knots or fewer, search one knot fewer by ``varpro`` from its own starts
        (:data:`FREE_SEARCH_MOST`) and go on from there if it is within. Knots may then
        lie between data points; with ``corners`` too, knots that meet become a multiple
        knot. On by default (it added at most 0.9 s to a case of ``bench_fit``); False
        ends the search with knots at or between data points as knot removal left them.
    progress
        Show a progress bar over each search's evaluations.
    on_stage
        Called with each stage's line as the stage ends (``metaknot fit`` prints them: one
        line per stage, on a terminal or not); the lines are also in the result's ``stages``.

    Notes
    -----
    On more than :data:`THIN_ABOVE` points the search (FITPACK's answer, the starts, knot
    removal and the fixed-count search) runs on :data:`THIN_TO` of them, evenly spaced in
    index (the ends kept), and each answer's knots are fitted by least squares on all points
    and checked there; an answer beyond the tolerance on all points makes the search run
    again at a tighter tolerance (at most :data:`THIN_ATTEMPTS` times, then on all points).

    Returns
    -------
    ToleranceFit
        The spline, its metrics, FITPACK's answer at the same tolerance, and the method that
        produced it (never more control points than FITPACK's answer).

    Raises
    ------
    ValueError
        For bad points (NaN, magnitudes above 1e100, too few, repeated consecutive points, x
        not increasing), a tolerance <= 0, below what interpolation reaches or not below the
        extent of the points (their bounding-box diagonal), or a bad option.
    """
    start = time.perf_counter()
    p = check_degree(degree)
    from metaknot.algorithms.literature import METHODS as LITERATURE

    if method not in ("auto", "removal", "fitpack", *LITERATURE):
        raise ValueError(f"method must be 'auto', 'removal', 'fitpack' or a literature method "
                         f"({', '.join(sorted(LITERATURE))}); got {method!r}")
    if not is_integer(budget) or budget < 1:
        raise ValueError(f"budget must be a positive integer; got {budget!r}")
    check_metric(metric)
    relative, function, progress, corners, polish = (
        check_flag(name, value) for name, value in (
            ("relative", relative), ("function", function), ("progress", progress),
            ("corners", corners), ("polish", polish)))
    if closed is not None:
        closed = check_flag("closed", closed)
    q, params = _check_points(points, params, p, function)
    tolerance = check_tolerance(tolerance)
    diagonal = float(np.linalg.norm(q.max(axis=0) - q.min(axis=0)))
    if relative and diagonal == 0:
        raise ValueError("a relative tolerance needs points that are not all equal (their "
                         "bounding box has zero size); give an absolute tolerance")
    tol_abs = float(tolerance) * (diagonal if relative else 1.0)
    if 0 < diagonal <= tol_abs:  # every curve in the bounding box would do, and the ends "meet"
        raise ValueError(f"the tolerance {tol_abs:.3g} is not below the extent of the points "
                         f"(their bounding-box diagonal, {diagonal:.3g}); give a smaller one")
    found = closure(q)
    if closed is None:
        closed = found.closed and not function and params is None and len(q) > p + 2
        why = f" (auto: {found.describe()}; --{'open' if closed else 'closed'} to change it)"
    else:
        why = f" (--{'closed' if closed else 'open'})"
    if closed and (function or params is not None):
        raise ValueError("closed curves take their own parameters: --closed does not apply "
                         "to function data or explicit parameters")
    curve = make_curve(q, degree=p, parameterization=parameterization, closed=closed,
                       params=params)
    distance = curve.interpolation_residuals()
    floor = float(distance.max() if metric == "max_deviation" else
                  np.sqrt(np.mean(distance**2)))
    if tol_abs < floor:
        raise ValueError(f"the tolerance {tol_abs:.3g} is below what interpolation reaches "
                         f"({floor:.3g}); raise it")
    stages: list[str] = []

    def note(line: str) -> None:
        stages.append(line)
        if on_stage is not None:
            on_stage(line)

    note(f"{curve.kind} curve of {curve.n_points} points{why}")
    if method in LITERATURE:
        reference = fitpack.fewest_within(curve.params, curve.points, p, tol_abs, metric,
                                          closed=curve.closed)
        note(_fitpack_line(reference))
        return _literature_fit(curve, method, tol_abs, metric, reference, note, stages, start)
    options = _SearchOptions(method, budget, seed, progress, parameterization,
                             p if corners else 1, polish)
    if curve.n_points <= THIN_ABOVE:
        best, method_name, reference = _search(curve, params, tol_abs, metric, options, note)
        return _checked_answer(curve, best, method_name, tol_abs, metric, reference, note,
                               stages, start)
    return _thinned_search(curve, params, tol_abs, metric, options, note, stages, start)


#: ``fit`` searches on a thinned copy of more points than this (see :func:`fit`'s notes).
THIN_ABOVE = 4000
#: The points the thinned copy keeps.
THIN_TO = 2000
#: Searches on the thinned copy, each at a tighter tolerance, before one on all points.
THIN_ATTEMPTS = 4


@dataclass(frozen=True)
class _SearchOptions:
    """The settings of :func:`fit` that :func:`_search` passes on."""

    method: str
    budget: int
    seed: int
    progress: bool
    parameterization: str
    max_multiplicity: int = 1
    polish: bool = False


def _fitpack_line(reference: dict, of: str = "") -> str:
    return (f"FITPACK{of}: {reference['n_control_points']} control points (s = "
            f"{reference['s']:.3g}) in {reference['seconds']:.2f} s")


def _search(curve: Curve, params: np.ndarray | None, tol_abs: float, metric: Metric,
            options: _SearchOptions, note: Callable[[str], None], of: str = ""
            ) -> tuple[np.ndarray | None, str, dict]:
    """FITPACK's answer, then metaknot's search from it and the other starts (and, with
    corners, again from the starts with multiple knots at the corners): returns the knots
    found (None: none beat FITPACK's answer within the tolerance), the method that found them
    and FITPACK's answer (``of`` names the points in the stage lines)."""
    p, method, multiplicity = curve.degree, options.method, options.max_multiplicity
    search = _Search(curve, tol_abs, metric, parameterization=options.parameterization)
    reference = fitpack.fewest_within(curve.params, curve.points, p, tol_abs, metric,
                                      closed=curve.closed)
    note(_fitpack_line(reference, of))
    t_fp = reference["spline"].t
    starts = [np.asarray(t_fp[p + 1 : len(t_fp) - p - 1])]
    averaging = search.fewest_averaging(len(starts[0]) + 1)
    if averaging is not None:
        starts.append(averaging)
    best, method_name = None, "knot removal"
    if method != "fitpack":
        starts += _literature_starts(curve, tol_abs, metric, note)
        best, method_name = _reduce(search, starts, options, note, of)
    if multiplicity > 1 and method != "fitpack":
        corners = corner_params(curve)
        note(f"corners{of}: {corners.size} found" + (
            f"; the search again from each start with a knot of multiplicity {multiplicity} "
            "at each" if corners.size else ""))
        if corners.size:
            found, how = _reduce(_Search(curve, tol_abs, metric, max_multiplicity=multiplicity,
                                         parameterization=options.parameterization),
                                 [_with_corners(knots, corners, multiplicity)
                                  for knots in starts], options, note, of + " with corners")
            if found is not None and (best is None or len(found) < len(best)):
                best, method_name = found, how + " with corners"
    if best is not None and \
            len(best) + curve.extra_control_points >= reference["n_control_points"]:
        best = None
    return best, method_name, reference


def _reduce(search: _Search, starts: list[np.ndarray], options: _SearchOptions,
            note: Callable[[str], None], of: str) -> tuple[np.ndarray | None, str]:
    """Knot removal from each start within the tolerance, then (``method="auto"``) the
    fixed-count search below the fewest found and removal once more: the fewest knots found
    (None if no start is within the tolerance) and the method that found them."""
    curve, tol_abs = search.curve, search.tol
    best = None
    for knots in starts:
        (err,) = search.errors([knots])
        if err > tol_abs:
            continue
        reduced = search.remove(knots)
        if best is None or len(reduced) < len(best):
            best = reduced
    note(f"knot removal{of}: {search.evaluations:,} fits")
    method_name = "knot removal"
    if best is not None and options.method == "auto":
        fewer, fits = _fewer_at_fixed_counts(curve, tol_abs, search.metric,
                                             options.parameterization, len(best),
                                             fixed_count_searches(options.budget),
                                             options.seed, options.progress,
                                             search.max_multiplicity)
        note(f"search at fixed counts{of}: {fits:,} fits, "
             f"{len(best) - (len(fewer) if fewer is not None else len(best))} knots fewer")
        if fewer is not None:  # and knot removal once more from there
            best, method_name = search.remove(fewer), "knot removal + fixed-count search"
    if best is not None and options.polish:
        before, evaluations = len(best), search.evaluations
        best = search.remove(best, polish=True)
        while (fewer := search.fewer_free(best)) is not None:  # few knots: one fewer, freely
            best = search.remove(fewer, polish=True)
        note(f"polish{of}: {search.evaluations - evaluations:,} fits, "
             f"{before - len(best)} knots fewer")
        if len(best) < before:
            method_name += " + polish"
    return best, method_name


def _checked_answer(curve: Curve, best: np.ndarray | None, method_name: str, tol_abs: float,
                    metric: Metric, reference: dict, note: Callable[[str], None],
                    stages: list[str], start: float) -> ToleranceFit:
    """The search's answer checked by a full fit, or FITPACK's answer."""
    if best is not None:
        (err,) = curve.errors([best], metric,  # the answer checked by a full fit
                              max_multiplicity=_largest_multiplicity(best))
        if err <= tol_abs:
            return _result(curve, best, method_name, tol_abs, metric, reference, stages,
                           start)
        note(f"{method_name}: its answer fails the check by a full fit ({err:.3g} > "
             f"{tol_abs:.3g}); FITPACK's answer kept")
    return _result(curve, None, "fitpack", tol_abs, metric, reference, stages, start)


def _thinned(curve: Curve, size: int) -> Curve:
    """``size`` of the curve's points, evenly spaced in index (the ends kept), with their
    parameters."""
    index = np.unique(np.linspace(0, curve.n_points - 1, size).round().astype(np.int64))
    return type(curve)._checked(curve.params[index], curve.points[index], curve.degree)


def _thinned_search(curve: Curve, params: np.ndarray | None, tol_abs: float, metric: Metric,
                    options: _SearchOptions, note: Callable[[str], None], stages: list[str],
                    start: float) -> ToleranceFit:
    """:func:`_search` on a thinned copy of ``curve``, its answers (the search's and
    FITPACK's) fitted on all points and checked there; tighter each time neither holds."""
    thin = _thinned(curve, THIN_TO)
    of = f" on {thin.n_points:,} of the {curve.n_points:,} points"
    note(f"{curve.n_points:,} points: the search runs on {thin.n_points:,} of them, evenly "
         "spaced; each answer is fitted on all points and checked there")
    sub_params = None if params is None else thin.params
    target = tol_abs
    for _ in range(THIN_ATTEMPTS):
        best, method_name, found = _search(thin, sub_params, target, metric, options, note, of)
        t_fp = found["spline"].t
        p = curve.degree
        candidates = ([best] if best is not None else []) + [t_fp[p + 1 : len(t_fp) - p - 1]]
        errors = curve.errors([np.asarray(c, dtype=np.float64) for c in candidates], metric,
                              max_multiplicity=max(map(_largest_multiplicity, candidates)))
        fp_knots, fp_error = candidates[-1], float(errors[-1])
        if fp_error <= tol_abs:  # FITPACK's knots, least squares on all points: the reference
            reference = _on_all_points(curve, fp_knots, found)
            if best is not None and errors[0] <= tol_abs:
                return _result(curve, best, method_name, tol_abs, metric, reference, stages,
                               start)
            return _result(curve, None, "fitpack", tol_abs, metric, reference, stages, start)
        worst = float(np.max(errors[np.isfinite(errors)], initial=fp_error))
        target *= min(0.9, tol_abs / worst) if np.isfinite(worst) else 0.5
        note(f"beyond the tolerance on all points ({metric} {worst:.4g} > {tol_abs:.4g}): "
             f"searching again at {target:.4g}")
    note("the thinned search found no answer within the tolerance on all points: searching "
         "on all points")
    best, method_name, reference = _search(curve, params, tol_abs, metric, options, note)
    return _checked_answer(curve, best, method_name, tol_abs, metric, reference, note, stages,
                           start)


def _on_all_points(curve: Curve, knots: np.ndarray, found: dict) -> dict:
    """FITPACK's answer on a thinned copy as the reference on all points: its knots fitted
    by least squares on all of them."""
    solution = curve.fit(knots)
    return {**found, "spline": solution.spline,
            **{k: solution.metrics[k] for k in ("n_control_points", "max_deviation", "rmse")}}


def _result(curve: Curve, knots: np.ndarray | None, method: str, tol: float, metric: Metric,
            reference: dict, stages: list[str], start: float) -> ToleranceFit:
    """The fit with these knots (FITPACK's answer if None), as :func:`fit` returns it."""
    if knots is None:
        spline, found = reference["spline"], reference
    else:
        solution = curve.fit(knots, max_multiplicity=_largest_multiplicity(knots))
        spline, found = solution.spline, solution.metrics
    metrics = {k: found[k] for k in ("n_control_points", "max_deviation", "rmse")}
    metrics["seconds"] = time.perf_counter() - start
    return ToleranceFit(spline=spline, params=curve.params, tolerance=tol, metric=metric,
                        method=method, metrics=metrics,
                        fitpack={k: v for k, v in reference.items() if k != "spline"},
                        stages=stages, closed=curve.closed, points=curve.points)


#: Literature methods whose knots also start the knot removal of ``method="auto"`` and
#: ``"removal"`` (a portfolio: the search starts from the best of them too, so it ends no worse
#: than they do; ``benchmarks/bench_literature.py``).
LITERATURE_STARTS = ("bisection", "lyche_morken")


def _literature_starts(curve: Curve, tol: float, metric: Metric,
                       note: Callable[[str], None]) -> list[np.ndarray]:
    """The knots of the :data:`LITERATURE_STARTS` methods that are within the tolerance."""
    from metaknot.algorithms.literature import METHODS

    found = [METHODS[name](curve.params, curve.points, tol, degree=curve.degree,
                           closed=curve.closed, metric=metric) for name in LITERATURE_STARTS]
    note("literature starts: " + ", ".join(
        f"{name} {r.knots.size + curve.extra_control_points if r.within else '-'}"
        for name, r in zip(LITERATURE_STARTS, found, strict=True)) + " control points")
    return [r.knots for r in found if r.within]


def _literature_fit(curve: Curve, method: str, tol: float, metric: Metric, reference: dict,
                    note: Callable[[str], None], stages: list[str], start: float
                    ) -> ToleranceFit:
    """``fit(method=<a literature method>)``: that method's knots, least-squares fitted."""
    from metaknot.algorithms.literature import METHODS

    found = METHODS[method](curve.params, curve.points, tol, degree=curve.degree,
                            closed=curve.closed, metric=metric)
    if not found.within:
        raise ValueError(f"method {method!r} does not reach the tolerance: {found.reason}")
    note(f"{method}: {found.knots.size} knots, {found.fits:,} fits")
    return _result(curve, found.knots, method, tol, metric, reference, stages, start)
