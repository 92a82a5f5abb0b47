"""Objectives over fitted knot vectors, chosen by name. All are minimised.

Each objective maps a :class:`~metaknot.bspline.BatchFit` (SSE, maximum deviation and number of
control points per candidate) to one value per candidate; infeasible candidates get ``+inf``.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from metaknot.bspline import BatchFit
from metaknot.bspline.fit import check_metric

__all__ = ["BIC", "OBJECTIVES", "RMSE", "DataInfo", "ErrorBounded", "MaxDeviation", "Objective",
           "Paper", "Pareto", "get_objective"]


@dataclass(frozen=True)
class DataInfo:
    """What an objective needs to know of the data: count, dimension, scale, degree, and the
    control points a fit has beyond its interior knots (``degree + 1`` for an open curve, 1 for
    a closed one: :attr:`metaknot.bspline.curve.Curve.extra_control_points`)."""

    n_points: int
    dim: int
    scale: float
    degree: int
    extra_control_points: int


# The formulas, compiled: one pass over a batch of fits, so a batch of one candidate costs one
# call and a sequential optimizer takes the same code as a population. The caller allocates
# the outputs (an array numpy made is returned faster than one made in compiled code). An
# infeasible fit (reason not 0) scores +inf and has NaN metrics.


@njit(cache=True)
def _paper_kernel(sse, n_control_points, reason, floor, values):
    """Control points x ``max(sqrt(SSE), floor)`` (:class:`~.objectives.Paper`)."""
    for b in range(sse.size):
        values[b] = n_control_points[b] * max(math.sqrt(sse[b]), floor) \
            if reason[b] == 0 else math.inf


@njit(cache=True)
def _rmse_kernel(sse, reason, n_points, values):
    """Root-mean-square point distance (:class:`~.objectives.RMSE`)."""
    for b in range(sse.size):
        values[b] = math.sqrt(sse[b] / n_points) if reason[b] == 0 else math.inf


@njit(cache=True)
def _max_deviation_kernel(max_deviation, reason, values):
    """Largest point distance (:class:`~.objectives.MaxDeviation`)."""
    for b in range(max_deviation.size):
        values[b] = max_deviation[b] if reason[b] == 0 else math.inf


@njit(cache=True)
def _error_bounded_kernel(sse, max_deviation, n_control_points, reason, n_points, tolerance,
                          by_max_deviation, values):
    """Control points plus error / tolerance within the tolerance, ``N + 2`` plus it beyond
    (:class:`~.objectives.ErrorBounded`); the error is the maximum deviation or, unless
    ``by_max_deviation``, the RMSE."""
    beyond = n_points + 2
    for b in range(sse.size):
        error = max_deviation[b] if by_max_deviation else math.sqrt(sse[b] / n_points)
        ratio = error / tolerance
        value = n_control_points[b] + ratio if ratio <= 1.0 else beyond + ratio
        values[b] = value if reason[b] == 0 else math.inf


@njit(cache=True)
def _metrics_kernel(sse, max_deviation, n_control_points, reason, n_points, rmse_values,
                    control_points, deviations):
    """RMSE, control points and maximum deviation (unless ``deviations`` is empty) per fit
    into the last three arrays, NaN for an infeasible fit."""
    with_max_deviation = deviations.size > 0
    for b in range(sse.size):
        feasible = reason[b] == 0
        rmse_values[b] = math.sqrt(sse[b] / n_points) if feasible else math.nan
        control_points[b] = n_control_points[b] if feasible else math.nan
        if with_max_deviation:
            deviations[b] = max_deviation[b] if feasible else math.nan


def _max_deviation(fit: BatchFit, objective: str) -> np.ndarray:
    """The maximum deviation of every candidate of a batch, for the objective named
    ``objective`` (which says it needs it: a problem has it computed)."""
    if fit.max_deviation is None:
        raise ValueError(f"{objective} by max_deviation needs fits with max_deviation")
    return fit.max_deviation


def _error(fit: BatchFit, metric: str, n_points: int, objective: str) -> np.ndarray:
    """The error ``metric`` (``max_deviation`` or ``rmse``) of every candidate of a batch."""
    if metric != "max_deviation":
        return np.sqrt(fit.sse / n_points)
    return _max_deviation(fit, objective)


class Objective(ABC):
    """Maps batch fit statistics to objective values (lower is better)."""

    name: ClassVar[str]
    #: True if the objective reads ``BatchFit.max_deviation`` (an extra pass over the data).
    needs_max_deviation: bool = False
    #: True if values are positive quantities with a natural zero, so their ratios mean
    #: something (``paper``: control points x distance). Optimizers that turn values into
    #: fitness by inversion (Dolphin Echolocation's ``fitness="auto"``) need this; for the
    #: others (``bic`` is defined up to a constant) only ranks are meaningful.
    ratio_scale: ClassVar[bool] = False
    #: Number of objectives: 1, or 2 for a front (values of shape ``(B, 2)``).
    n_objectives: ClassVar[int] = 1

    @abstractmethod
    def __call__(self, fit: BatchFit, data: DataInfo) -> np.ndarray: ...

    def options(self) -> dict[str, Any]:
        """The objective's options (its constructor arguments)."""
        return {k: v for k, v in vars(self).items()
                if not k.startswith("_") and k != "needs_max_deviation"}

    def describe(self) -> dict[str, Any]:
        """``{"objective": name, "objective.<option>": value, ...}``."""
        return {"objective": self.name,
                **{f"objective.{k}": v for k, v in self.options().items()}}


def _check_nonneg(name: str, value: float) -> float:
    value = float(value)
    if not np.isfinite(value) or value < 0:
        raise ValueError(f"{name} must be a finite value >= 0; got {value}")
    return value


class Paper(Objective):
    """The seed paper's objective: control points x Euclidean distance (eq. 3), minimised.

    This is the reciprocal of the seed's fitness ``1 / (CP x error)``. Unguarded, it is
    degenerate: the error falls to 0 as the fit approaches interpolation, so the product does
    too, and for smooth data it keeps falling as control points are added.

    Guard (the one used here): an **error floor**. The Euclidean distance is taken as
    ``max(sqrt(SSE), error_floor * scale * sqrt(N))``, i.e. a root-mean-square point error below
    ``error_floor`` times the bounding-box diagonal counts as that floor. Below the floor extra
    control points only cost, so the optimum is the fewest control points that reach it. The
    default ``1e-5`` lies below every error reported in the seed's tables; ``error_floor=0``
    gives the seed's unguarded objective.
    """

    name = "paper"
    ratio_scale = True

    def __init__(self, error_floor: float = 1e-5) -> None:
        self.error_floor = _check_nonneg("error_floor", error_floor)

    def __call__(self, fit: BatchFit, data: DataInfo) -> np.ndarray:
        floor = self.error_floor * data.scale * math.sqrt(data.n_points)
        values = np.empty(fit.sse.size)
        _paper_kernel(fit.sse, fit.n_control_points, fit.reason, floor, values)
        return values



class BIC(Objective):
    """Bayesian information criterion of the fit, assuming i.i.d. Gaussian errors.

    ``n ln(SSE / n) + ln(n) k`` with ``n = N d`` observed coordinates and
    ``k = d * control points + interior knots`` free parameters (knot positions count: they are
    chosen from the data). The SSE is floored at ``(error_floor * scale)^2 * n`` so exact fits
    stay finite; BIC is meant for noisy data, on noise-free data it still favours many knots.
    """

    name = "bic"

    def __init__(self, error_floor: float = 1e-9) -> None:
        self.error_floor = _check_nonneg("error_floor", error_floor)

    def __call__(self, fit: BatchFit, data: DataInfo) -> np.ndarray:
        floor = (self.error_floor * data.scale) ** 2 * (data.n_points * data.dim)
        sse = np.maximum(fit.sse, max(floor, np.finfo(float).tiny))
        with np.errstate(invalid="ignore", over="ignore"):
            value = bic_value(sse, data.n_points, data.dim, fit.n_control_points,
                              data.extra_control_points)
        return np.where(fit.feasible, value, np.inf)


def bic_value(sse: Any, n_points: float, dim: float, n_control_points: Any,
              extra_control_points: float) -> Any:
    """:class:`BIC`'s ``n ln(SSE / n) + ln(n) k`` (``n = N d``, ``k = d * control points +
    interior knots``) of an SSE already floored, for arrays or numbers: the one formula, which
    the results store also checks a record's best value against."""
    n = n_points * dim
    n_interior = n_control_points - extra_control_points
    k = dim * n_control_points + n_interior
    return n * np.log(sse / n) + np.log(n) * k


class ErrorBounded(Objective):
    """Fewest control points whose fit keeps the error within a tolerance.

    Value for a candidate within tolerance: ``CP + err / tol`` (in ``[CP, CP + 1]``: fewer control
    points first, then lower error). Beyond tolerance: ``N + 2 + err / tol`` — always behind every
    candidate within tolerance and ranked by error, so a search is led towards the bound.
    Candidates that cannot be fitted: ``+inf``.

    Parameters
    ----------
    tolerance
        Absolute tolerance; if ``None``, ``relative_tolerance`` times the bounding-box diagonal.
    metric
        ``"max_deviation"`` (largest point distance) or ``"rmse"``.
    """

    name = "error_bounded"

    def __init__(self, tolerance: float | None = None, relative_tolerance: float = 1e-3,
                 metric: Literal["max_deviation", "rmse"] = "max_deviation") -> None:
        check_metric(metric)
        if tolerance is not None and not (np.isfinite(tolerance) and tolerance > 0):
            raise ValueError(f"tolerance must be a finite value > 0; got {tolerance}")
        if not (np.isfinite(relative_tolerance) and relative_tolerance > 0):
            raise ValueError(f"relative_tolerance must be > 0; got {relative_tolerance}")
        self.tolerance = None if tolerance is None else float(tolerance)
        self.relative_tolerance = float(relative_tolerance)
        self.metric = metric
        self.needs_max_deviation = metric == "max_deviation"

    def bound(self, data: DataInfo) -> float:
        """The absolute tolerance in effect for ``data``."""
        return self.tolerance if self.tolerance is not None else \
            self.relative_tolerance * data.scale

    def __call__(self, fit: BatchFit, data: DataInfo) -> np.ndarray:
        by_max_deviation = self.metric == "max_deviation"
        values = np.empty(fit.sse.size)
        _error_bounded_kernel(
            fit.sse, _max_deviation(fit, self.name) if by_max_deviation else fit.sse,
            fit.n_control_points,
            fit.reason, data.n_points, self.bound(data), by_max_deviation, values)
        return values



class RMSE(Objective):
    """Root-mean-square point distance of the fit, for a fixed number of knots.

    With the knot count fixed (``indices`` and ``free`` encodings without a variable count) the
    control points are fixed too, and the error is all that is left to minimise: the suite's
    ``fixed_k`` tasks. On an encoding that varies the count it rewards more knots (down to
    interpolation), so use ``error_bounded``, ``bic`` or ``pareto`` there.
    """

    name = "rmse"
    ratio_scale = True

    def __call__(self, fit: BatchFit, data: DataInfo) -> np.ndarray:
        values = np.empty(fit.sse.size)
        _rmse_kernel(fit.sse, fit.reason, data.n_points, values)
        return values



class MaxDeviation(Objective):
    """Largest distance of a data point to its fitted point, for a fixed number of knots.

    The minimax counterpart of :class:`RMSE`: the knots whose least-squares fit keeps its worst
    point closest (the control points are still the least-squares ones). Like ``rmse`` it is
    meant for a fixed knot count; ``error_bounded`` with ``metric="max_deviation"`` is the
    tolerance task it serves (``metaknot fit`` polishes its knots under it).
    """

    name = "max_deviation"
    ratio_scale = True
    needs_max_deviation = True

    def __call__(self, fit: BatchFit, data: DataInfo) -> np.ndarray:
        values = np.empty(fit.sse.size)
        _max_deviation_kernel(_max_deviation(fit, self.name), fit.reason, values)
        return values


class Pareto(Objective):
    """Two objectives, both minimised: control points and error — the whole trade-off.

    Values have shape ``(B, 2)``, both scaled to ``[0, 1]`` so that the hypervolume is
    comparable across curves:

    * ``control points / N`` (``N`` data points; interpolation is 1);
    * ``1 + log10(max(err / diagonal, error_floor)) / -log10(error_floor)``: the error relative
      to the bounding-box diagonal on a log scale, 0 at ``error_floor`` (errors below it count
      as exact) and 1 at the diagonal.

    The hypervolume's reference point is ``(1, 1)`` and its ideal point ``(0, 0)``: a run's
    scalar outcome (``best_f``) is the hypervolume gap, the share of the unit box its front
    does not dominate (see :mod:`metaknot.front`). Infeasible candidates get ``(+inf, +inf)``.

    Parameters
    ----------
    metric
        ``"rmse"`` or ``"max_deviation"`` (largest point distance).
    error_floor
        Relative error counted as exact (default ``1e-6`` of the diagonal).
    """

    name = "pareto"
    n_objectives = 2
    reference = (1.0, 1.0)
    ideal = (0.0, 0.0)

    def __init__(self, metric: Literal["rmse", "max_deviation"] = "rmse",
                 error_floor: float = 1e-6) -> None:
        check_metric(metric)
        error_floor = float(error_floor)
        if not 0.0 < error_floor < 1.0:
            raise ValueError(f"error_floor must lie in (0, 1); got {error_floor}")
        self.metric = metric
        self.error_floor = error_floor
        self.needs_max_deviation = metric == "max_deviation"

    def scale(self, n_control_points: ArrayLike, error: ArrayLike,
              data: DataInfo) -> np.ndarray:
        """Control points and errors (absolute) as the objective's scaled ``(n, 2)`` values."""
        cp = np.asarray(n_control_points, dtype=np.float64)
        rel = np.maximum(np.asarray(error, dtype=np.float64) / data.scale, self.error_floor)
        with np.errstate(divide="ignore", invalid="ignore"):
            f1 = 1.0 + np.log10(rel) / -np.log10(self.error_floor)
        return np.column_stack((cp / data.n_points, f1))

    def __call__(self, fit: BatchFit, data: DataInfo) -> np.ndarray:
        err = _error(fit, self.metric, data.n_points, self.name)
        values = self.scale(fit.n_control_points, err, data)
        return np.where(fit.feasible[:, None], values, np.inf)


OBJECTIVES: dict[str, type[Objective]] = {o.name: o for o in (Paper, BIC, ErrorBounded, RMSE,
                                                               MaxDeviation, Pareto)}


def get_objective(objective: str | Objective, **options: Any) -> Objective:
    """An objective by name (``paper``, ``bic``, ``error_bounded``, ``rmse``,
    ``max_deviation``, ``pareto``) with its options."""
    if isinstance(objective, Objective):
        if options:
            raise ValueError("objective options only apply when the objective is given by name")
        return objective
    try:
        cls = OBJECTIVES[objective]
    except (KeyError, TypeError):
        raise ValueError(f"unknown objective {objective!r}; choose one of "
                         f"{', '.join(OBJECTIVES)}") from None
    try:
        return cls(**options)
    except TypeError as exc:
        raise ValueError(f"bad options for objective {objective!r}: {exc}") from None
