"""Knot placement methods from the literature, in one shape: fewest knots within a tolerance.

Each method is a pure function, decorated by :func:`tolerance_method`::

    result = newknt(params, points, tolerance, degree=3, closed=False, metric="max_deviation")

taking the data parameters ``(N,)`` (in [0, 1) for a closed outline, as
:func:`metaknot.bspline.closed_parameterize` gives them) and points ``(N, d)``, and
returning a :class:`LiteratureKnots`: the interior knots, their fit's error (checked by the curve
model's evaluator, the one ``metaknot fit`` uses), whether it is within the tolerance (and if not,
why) and the fits the method made. Open curves and function data get a clamped spline, closed
outlines a periodic one (:mod:`metaknot.bspline.curve`). The method itself sees a
:class:`Target`: the curve model, the tolerance, a fit counter and the shared steps (the count
search :meth:`Target.fewest`, the knot density :func:`knot_density` and its equidistribution
:func:`equidistribute`).

Each method is registered as an optimizer by a :class:`ToleranceMethod` subclass, so studies
and the suite run it beside the metaheuristics: every tolerance of its ladder gives one
candidate, made of the problem's encoding by
:func:`~metaknot.algorithms.baselines.knots_to_candidate` (see :class:`ToleranceMethod`), and its
fits are declared with ``count_fits``. ``metaknot fit --method NAME`` calls the function
(:data:`METHODS`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike

from metaknot.bspline import averaging_knots, check_degree
from metaknot.bspline.curve import Curve, CurveFit, Metric, curve_model
from metaknot.bspline.fit import check_metric
from metaknot.bspline.parameterize import MAX_DEGREE, as_points
from metaknot.task import ProblemView
from metaknot.validate import check_tolerance

from .baselines import _KnotCountBaseline, with_count

__all__ = ["METHODS", "RELATIVE_LADDER", "LiteratureKnots", "Target", "ToleranceMethod",
           "equidistribute", "knot_density", "tolerance_method"]

#: name -> the method's function (filled by :func:`tolerance_method`), for ``metaknot fit``.
METHODS: dict[str, Callable[..., LiteratureKnots]] = {}

#: Tolerances (of the data's scale, on the maximum deviation) a :class:`ToleranceMethod` scans on
#: a problem whose objective sets none: one candidate each, coarse to fine.
RELATIVE_LADDER = tuple(10.0 ** -np.arange(1.0, 4.01, 0.5))


@dataclass(frozen=True, eq=False)
class LiteratureKnots:
    """What a literature method found.

    Attributes
    ----------
    knots
        Sorted interior knots (a closed outline's breakpoints in (0, 1); 0 is always one).
    error
        The error (``metric``) of their least-squares fit, by the curve model's evaluator.
    tolerance, metric
        The tolerance asked for and the error it bounds.
    fits
        Least-squares fits the method made (metaknot's kernels and scipy's alike).
    reason
        Empty when ``error <= tolerance``; else why the method could not reach it.
    """

    knots: np.ndarray
    error: float
    tolerance: float
    metric: str
    fits: int
    reason: str = ""

    @property
    def within(self) -> bool:
        return self.error <= self.tolerance


class Target:
    """What a method works on: the curve model, the tolerance, and the fits made so far.

    Raises
    ------
    ValueError
        One line naming the bad input (points, parameters, degree, tolerance or metric).
    """

    def __init__(self, params: ArrayLike, points: ArrayLike, tolerance: float, *,
                 degree: int = 3, closed: bool = False,
                 metric: Metric = "max_deviation") -> None:
        p = check_degree(degree)
        q = as_points(points, degree=p)  # the problems' checks and messages
        u = np.asarray(params, dtype=np.float64)
        if u.shape != (q.shape[0],):
            raise ValueError(f"params must be one value per point ({q.shape[0]}); got shape "
                             f"{u.shape}")
        if not np.isfinite(u).all() or (np.diff(u) <= 0).any():
            raise ValueError("params must be finite and strictly increasing")
        check_metric(metric)
        self.tolerance = check_tolerance(tolerance)
        self.curve: Curve = curve_model(closed)(u, q, p)
        self.metric: Metric = metric
        self.fits = 0

    # -- the data ----------------------------------------------------------------------------

    @property
    def params(self) -> np.ndarray:
        return self.curve.params

    @property
    def points(self) -> np.ndarray:
        return self.curve.points

    @property
    def degree(self) -> int:
        return self.curve.degree

    @property
    def bounds(self) -> tuple[float, float]:
        """The open interval interior knots lie in."""
        return self.curve.knot_bounds

    # -- fits, counted -----------------------------------------------------------------------

    def count(self, n: int = 1) -> None:
        """Count ``n`` fits made outside the curve model (scipy's)."""
        self.fits += int(n)

    def errors(self, knot_sets: list[np.ndarray]) -> np.ndarray:
        """The error of each set of sorted interior knots (``inf`` if it cannot be fitted)."""
        self.fits += len(knot_sets)
        return self.curve.errors(knot_sets, self.metric)

    def error(self, knots: np.ndarray) -> float:
        return float(self.errors([np.asarray(knots, dtype=np.float64)])[0])

    def within(self, knots: np.ndarray) -> bool:
        return self.error(knots) <= self.tolerance

    def fit(self, knots: np.ndarray) -> CurveFit | None:
        """The least-squares fit with these interior knots (None if they cannot be fitted)."""
        self.fits += 1
        try:
            return self.curve.fit(np.asarray(knots, dtype=np.float64))
        except ValueError:
            return None

    # -- shared steps ------------------------------------------------------------------------

    @property
    def max_count(self) -> int:
        """The most interior knots a fit can have."""
        return self.curve.max_interior_knots

    @property
    def min_count(self) -> int:
        """The fewest interior knots a fit can have (a closed spline needs ``degree - 1``)."""
        return self.curve.min_interior_knots

    def with_min_count(self, knots: np.ndarray) -> np.ndarray:
        """``knots``, joined by the curve's spread breakpoints for :attr:`min_count` if they
        are fewer than that (a closed spline needs ``degree - 1``; an open one none)."""
        if knots.size >= self.min_count:
            return knots
        return np.union1d(knots, self.curve.spread_knots(self.min_count))

    def with_data_between(self, knots: np.ndarray) -> np.ndarray:
        """``knots`` less those that would leave a knot span without a data parameter (which
        no least-squares fit allows), kept from the left."""
        lo, hi = self.bounds
        u = self.curve.domain_params
        knots = np.sort(np.asarray(knots, dtype=np.float64))
        below = np.searchsorted(u, knots, side="left")  # data parameters < knot
        up_to = np.searchsorted(u, knots, side="right")  # data parameters <= knot
        before_hi = np.searchsorted(u, hi, side="left")
        kept, last = [], np.searchsorted(u, lo, side="right")
        for i in range(knots.size):
            if below[i] > last and before_hi > up_to[i]:
                kept.append(i)
                last = up_to[i]
        return knots[kept]

    def fewest(self, knots_at: Callable[[int], np.ndarray | None],
               lowest: int | None = None) -> np.ndarray:
        """The knots at the fewest count whose fit is within the tolerance: the count doubled
        from ``lowest`` (default: the fewest a fit can have) until within, then bisected
        between the last count beyond and the first within. ``knots_at(k)`` gives the knots of
        count ``k`` (None if it has none); knots that cannot be fitted lose those that leave a
        span without data (:meth:`with_data_between`). If no count is within, the knots of the
        lowest error."""
        lo = self.min_count if lowest is None else max(lowest, self.min_count)
        found: dict[int, tuple[float, np.ndarray | None]] = {}

        def probe(k: int) -> bool:
            if k not in found:
                knots = knots_at(k)
                error = np.inf if knots is None else self.error(knots)
                if knots is not None and error == np.inf:  # a span without data, perhaps
                    knots = self.with_data_between(knots)
                    error = self.error(knots)
                found[k] = (error, knots)
            return found[k][0] <= self.tolerance

        beyond, k = lo - 1, lo
        while not probe(k):
            if k >= self.max_count:
                ok = [c for c, (_, t) in found.items() if t is not None]
                best = min(ok, key=lambda c: found[c][0]) if ok else None
                knots = None if best is None else found[best][1]  # not None: one of ok
                return knots if knots is not None else self.curve.spread_knots(self.max_count)
            beyond, k = k, min(max(2 * k, k + 1), self.max_count)
        within = k
        while within - beyond > 1:
            mid = (beyond + within) // 2
            if probe(mid):
                within = mid
            else:
                beyond = mid
        knots = found[within][1]
        assert knots is not None  # within the tolerance: knots were found
        return knots

    def result(self, knots: np.ndarray, reason: str = "") -> LiteratureKnots:
        """The method's answer, checked by the curve model's evaluator."""
        knots = np.sort(np.asarray(knots, dtype=np.float64))
        error = self.error(knots)
        if error > self.tolerance and not reason:
            reason = (f"its fit with {knots.size} knots has {self.metric} {error:.3g} > "
                      f"the tolerance {self.tolerance:.3g}")
            floor = self.interpolation_error()
            if floor > self.tolerance:
                reason = (f"the tolerance {self.tolerance:.3g} is below what interpolation "
                          f"reaches ({floor:.3g})")
        return LiteratureKnots(knots, error, self.tolerance, self.metric, self.fits, reason)

    def interpolation_error(self) -> float:
        """The error of the spline through every point (no fit does better)."""
        self.fits += 1
        d = self.curve.interpolation_residuals()
        return float(d.max() if self.metric == "max_deviation" else np.sqrt(np.mean(d**2)))


def tolerance_method(name: str) -> Callable[[Callable[..., np.ndarray]],
                                             Callable[..., LiteratureKnots]]:
    """Make ``core(target, **options) -> interior knots`` the method ``name``:
    ``method(params, points, tolerance, *, degree=3, closed=False, metric="max_deviation",
    **options) -> LiteratureKnots``, listed in :data:`METHODS`."""

    def decorator(core: Callable[..., np.ndarray]) -> Callable[..., LiteratureKnots]:
        @functools.wraps(core)
        def method(params: ArrayLike, points: ArrayLike, tolerance: float, *, degree: int = 3,
                   closed: bool = False, metric: Metric = "max_deviation",
                   **options: Any) -> LiteratureKnots:
            target = Target(params, points, tolerance, degree=degree, closed=closed,
                            metric=metric)
            return target.result(core(target, **options))

        METHODS[name] = method
        return method

    return decorator


# -- the knot density shared by the equidistribution methods (and free_front's start) ----------


def knot_density(params: np.ndarray, points: np.ndarray, degree: int, exponent: float,
                 order: int | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """``(grid, F)``: the normalised cumulative knot density ``|x^(order)(u)|^exponent`` on a
    fine grid (20 N points), ``x`` a pilot least-squares spline of degree ``p + 2`` on about
    N / 2 averaging knots (one scipy fit: callers count it), ``order`` ``p + 1`` by default
    (p: the degree). On a closed outline the pilot is an open spline over its parameters.
    None if the data are too few for the pilot or the derivative vanishes."""
    from scipy.interpolate import make_lsq_spline

    u, q = np.asarray(params), np.asarray(points)
    order = degree + 1 if order is None else order
    degree += 2
    n_interior = (u.size - degree - 1) // 2
    if n_interior < 1:
        return None
    try:  # the averaging formula of degree 5 at most (the kernel's limit; scipy fits any)
        interior = averaging_knots(u, n_interior, min(degree, MAX_DEGREE))
        t = np.concatenate((np.full(degree + 1, u[0]), interior, np.full(degree + 1, u[-1])))
        pilot = make_lsq_spline(u, q, t, k=degree)
    except (ValueError, np.linalg.LinAlgError):
        return None
    grid = np.linspace(u[0], u[-1], 20 * u.size)
    size = np.linalg.norm(pilot.derivative(order)(grid).reshape(grid.size, -1), axis=1)
    if not np.isfinite(size).all() or size.max() <= 0:
        return None
    return cumulative((size + 1e-3 * size.mean()) ** exponent, grid)


def cumulative(density: np.ndarray, grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(grid, F)``: the trapezoidal integral of ``density`` over ``grid``, normalised to 1."""
    total = np.concatenate(([0.0], np.cumsum(0.5 * (density[1:] + density[:-1])
                                             * np.diff(grid))))
    return grid, total / total[-1]


def equidistribute(density: tuple[np.ndarray, np.ndarray] | None, k: int
                   ) -> np.ndarray | None:
    """The ``k`` knots that split a cumulative density ``(grid, F)`` into equal parts (None
    without a density, or if two knots coincide)."""
    if density is None:
        return None
    grid, total = density
    knots = np.interp(np.arange(1, k + 1) / (k + 1), total, grid)
    return knots if np.all(np.diff(knots) > 0) else None


# -- the registered optimizer ------------------------------------------------------------------


class ToleranceMethod(_KnotCountBaseline):
    """A literature method as an optimizer: each tolerance gives one candidate.

    The tolerances: ``tolerance`` if given (on ``metric``); else the bound of the problem's
    ``error_bounded`` objective (and its metric); else the ladder :data:`RELATIVE_LADDER` times
    the data's scale on the maximum deviation, coarse to fine, the evaluator keeping the best
    under the problem's objective (``paper``, ``bic``, ``pareto``). The ladder ends early when a
    tolerance is out of the method's reach. Knots become candidates as the classical baselines'
    do (:func:`~metaknot.algorithms.baselines.knots_to_candidate`): knots at data points are the
    nearest ones, and a problem that fixes the count gets the knots brought to it by
    :func:`~metaknot.algorithms.baselines.with_count`. The method's fits are declared with
    ``count_fits``. No randomness is used.

    Parameters
    ----------
    tolerance
        Absolute tolerance (default: the problem's, or the ladder).
    metric
        The error the tolerance bounds: ``"max_deviation"`` or ``"rmse"`` (with ``tolerance``).
    max_knots, batch_size
        As the classical baselines (a batch is one tolerance by default).
    """

    #: the method's function (a :func:`tolerance_method`)
    method: ClassVar[Callable[..., LiteratureKnots]]
    #: the subclass's own hyperparameters, passed to the method by name
    options: ClassVar[tuple[str, ...]] = ()

    def __init__(self, tolerance: float | None = None, metric: str = "max_deviation",
                 max_knots: int | None = None, batch_size: int = 1) -> None:
        super().__init__(max_knots, batch_size)
        self.tolerance = None if tolerance is None else check_tolerance(tolerance)
        check_metric(metric)
        self.metric = metric

    def method_options(self) -> dict[str, Any]:
        """Options passed to the method (a subclass's own hyperparameters, :attr:`options`)."""
        return {name: getattr(self, name) for name in self.options}

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        super().setup(problem, rng)
        #: the method's answer at each tolerance so far
        self.results: list[LiteratureKnots] = []

    def tolerances(self) -> list[tuple[float, str]]:
        """The (tolerance, metric) pairs, in the order they are tried."""
        if self.tolerance is not None:
            return [(self.tolerance, self.metric)]
        objective, info = self.problem.objective, self.problem.info
        if hasattr(objective, "bound") and hasattr(objective, "metric"):  # error_bounded
            return [(float(objective.bound(info)), objective.metric)]
        return [(r * info.scale, "max_deviation") for r in RELATIVE_LADDER]

    def knot_sets(self) -> Iterator[np.ndarray]:
        p = self.problem
        lower, upper = p.knot_bounds
        for tolerance, metric in self.tolerances():
            found = type(self).method(p.params, p.points, tolerance, degree=p.degree,
                                      closed=p.closed, metric=metric, **self.method_options())
            self.count_fits(found.fits)
            self.results.append(found)
            knots = found.knots
            if not self.free_count or knots.size > self.counts[-1]:
                knots = with_count(knots, self.counts[-1], lower, upper)
            yield knots
            if not found.within:
                return
