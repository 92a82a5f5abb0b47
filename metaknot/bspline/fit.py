"""What least-squares fits give: the scores of a batch (:class:`BatchFit`, with the reasons a
candidate cannot be fitted) and one fitted spline with its metrics (:class:`CurveFit`); and
:func:`fit_spline`, one open fit. A :class:`~metaknot.bspline.curve.Curve` fits batches."""

from __future__ import annotations

import enum
from dataclasses import dataclass
from functools import cached_property
from typing import Literal, get_args

import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import BSpline

from ..budget import add_fits
from . import _kernel
from ._codegen import MAX_DIMENSION
from .knots import check_multiplicity, extra_control_points
from .parameterize import MAX_COORDINATE, as_points, check_degree

__all__ = [
    "BatchFit",
    "CurveFit",
    "Infeasibility",
    "PeriodicFit",
    "SplineFit",
    "fit_spline",
]


class Infeasibility(enum.IntEnum):
    """Why a knot vector cannot be fitted (the batched evaluator's reason codes)."""

    FEASIBLE = _kernel.FEASIBLE
    TOO_MANY_CONTROL_POINTS = _kernel.TOO_MANY_CONTROL_POINTS
    KNOT_OUT_OF_RANGE = _kernel.KNOT_OUT_OF_RANGE
    COINCIDENT_KNOTS = _kernel.COINCIDENT_KNOTS
    SCHOENBERG_WHITNEY = _kernel.SCHOENBERG_WHITNEY
    SINGULAR = _kernel.SINGULAR

    @property
    def message(self) -> str:
        """A sentence describing the reason."""
        return _MESSAGES[self]


_MESSAGES = {
    Infeasibility.FEASIBLE: "feasible",
    Infeasibility.TOO_MANY_CONTROL_POINTS: "more control points than data points",
    Infeasibility.KNOT_OUT_OF_RANGE: (
        "an interior knot is not finite or lies outside the open parameter range"
    ),
    Infeasibility.COINCIDENT_KNOTS: (
        "coincident (or unsorted) interior knots: a knot repeated more often than its "
        "multiplicity may be"
    ),
    Infeasibility.SCHOENBERG_WHITNEY: (
        "Schoenberg-Whitney conditions violated: some basis functions have no data point of "
        "their own (knot spans without data)"
    ),
    Infeasibility.SINGULAR: "the least-squares system is numerically singular",
}


@dataclass(slots=True)
class BatchFit:
    """Scores of a population of knot vectors, one entry per candidate.

    Attributes
    ----------
    sse
        Sum over data points of the squared distance to the fitted curve (``inf`` if infeasible).
    max_deviation
        Largest distance of a data point to its fitted point (``inf`` if infeasible), or
        ``None`` if it was not asked for (it costs a second pass over the data).
    n_control_points
        Interior knots + degree + 1.
    reason
        :class:`Infeasibility` code per candidate (0 = feasible).
    """

    sse: np.ndarray
    max_deviation: np.ndarray | None
    n_control_points: np.ndarray
    reason: np.ndarray

    @property
    def feasible(self) -> np.ndarray:
        """Boolean array: True where the candidate could be fitted."""
        return self.reason == 0  # Infeasibility.FEASIBLE (a plain int compares faster)

    def __len__(self) -> int:
        return self.sse.size


Metric = Literal["max_deviation", "rmse"]
#: The error measures a tolerance or an objective can be stated in.
METRICS: tuple[Metric, ...] = get_args(Metric)


def check_metric(metric: object) -> Metric:
    """``metric``, or a ``ValueError`` unless it is one of :data:`METRICS`."""
    if metric not in METRICS:
        raise ValueError(f"metric must be {' or '.join(map(repr, METRICS))}; got {metric!r}")
    return metric  # one of METRICS


def batch_errors(batch: BatchFit, metric: Metric, n_points: int
                 ) -> np.ndarray:
    """The error ``metric`` of every candidate of a batch; ``inf`` where infeasible."""
    check_metric(metric)
    if metric == "rmse":
        err = np.sqrt(batch.sse / n_points)
    elif batch.max_deviation is None:
        raise ValueError("the batch was fitted without its maximum deviations")
    else:
        err = batch.max_deviation
    return np.where(batch.feasible, err, np.inf)


def kernel_points(points: ArrayLike, degree: int, *, closed: bool = False) -> np.ndarray:
    """Points checked by :func:`~metaknot.bspline.parameterize.as_points`, of at most
    ``MAX_DIMENSION`` coordinates (the compiled kernels' loops are generated for those)."""
    q = as_points(points, degree=degree, closed=closed)
    if q.shape[1] > MAX_DIMENSION:
        raise ValueError(f"points must have 1 to {MAX_DIMENSION} coordinates (the compiled "
                         f"kernel's loops are generated for those); got {q.shape[1]}")
    return q


def _prepare(u: ArrayLike, points: ArrayLike, degree: int, *, closed: bool = False
             ) -> tuple[np.ndarray, np.ndarray]:
    """Parameters and points as the compiled kernels take them (float64, contiguous), checked:
    the points by :func:`kernel_points`, the parameters finite, strictly increasing and one per
    point, a ``closed`` outline's from 0 and below 1 (the kernels trust all of it)."""
    q = kernel_points(points, check_degree(degree), closed=closed)
    u = np.ascontiguousarray(u, dtype=np.float64)
    if u.shape != (q.shape[0],):
        raise ValueError(
            f"parameter values must have shape ({q.shape[0]},) to match the points; got {u.shape}"
        )
    if not np.isfinite(u).all() or (np.diff(u) <= 0).any():
        raise ValueError("parameter values must be finite and strictly increasing")
    if closed and (u[0] != 0.0 or u[-1] >= 1.0):
        raise ValueError("a closed outline's params must start at 0 and stay below 1 (one "
                         "period, [0, 1): metaknot.bspline.closed_parameterize)")
    if np.abs(u).max() > MAX_COORDINATE:
        raise ValueError(f"parameter values above {MAX_COORDINATE:g} in magnitude; rescale them")
    return u, q


@dataclass(frozen=True, eq=False)
class CurveFit:
    """A least-squares spline through data points, with its metrics: what open
    (:class:`SplineFit`) and closed (:class:`PeriodicFit`) fits have
    in common.

    ``spline`` is a :class:`scipy.interpolate.BSpline` whose coefficients have shape
    ``(n, d)``; ``spline(params)`` gives the fitted points.
    """

    spline: BSpline
    params: np.ndarray
    points: np.ndarray

    @property
    def degree(self) -> int:
        return int(self.spline.k)

    @property
    def knots(self) -> np.ndarray:
        """The full knot vector."""
        return np.asarray(self.spline.t)

    @property
    def interior_knots(self) -> np.ndarray:
        """The chosen knots inside the parameter range."""
        p = self.degree
        return self.knots[p + 1 : p + 1 + self.n_control_points - self.extra_control_points]

    @property
    def control_points(self) -> np.ndarray:
        """The distinct control points, shape ``(n_control_points, d)``."""
        return np.asarray(self.spline.c[: self.n_control_points])

    @property
    def n_control_points(self) -> int:
        """Distinct control points."""
        raise NotImplementedError

    @property
    def extra_control_points(self) -> int:
        """Control points beyond the interior knots."""
        raise NotImplementedError

    @cached_property
    def residuals(self) -> np.ndarray:
        """Distance of every data point to its fitted point, shape ``(N,)``."""
        return np.linalg.norm(self.points - self.spline(self.params), axis=1)

    @property
    def sse(self) -> float:
        """Sum over data points of squared distances."""
        return float(np.sum(self.residuals**2))

    @property
    def rmse(self) -> float:
        """Root mean squared point distance: ``sqrt(sse / N)``."""
        return float(np.sqrt(self.sse / self.points.shape[0]))

    @property
    def euclidean_distance(self) -> float:
        """The seed paper's eq. 3: ``sqrt(sse)``."""
        return float(np.sqrt(self.sse))

    @property
    def max_deviation(self) -> float:
        """Largest distance of a data point to its fitted point."""
        return float(self.residuals.max())

    @property
    def metrics(self) -> dict[str, float]:
        """All metrics as a flat dictionary."""
        return {
            "n_control_points": self.n_control_points,
            "sse": self.sse,
            "rmse": self.rmse,
            "euclidean_distance": self.euclidean_distance,
            "max_deviation": self.max_deviation,
        }


@dataclass(frozen=True, eq=False)
class SplineFit(CurveFit):
    """A least-squares clamped B-spline fit (an open curve) with its metrics."""

    @property
    def n_control_points(self) -> int:
        return int(self.spline.c.shape[0])

    @property
    def extra_control_points(self) -> int:
        """``degree + 1``: a clamped spline's control points beyond its interior knots."""
        return extra_control_points(self.degree)


@dataclass(frozen=True, eq=False)
class PeriodicFit(CurveFit):
    """A least-squares periodic spline (a closed outline) with its metrics (``spline`` is a
    scipy ``BSpline`` with the extended knots, whose last ``degree`` coefficients repeat the
    first; evaluate it on [0, 1)). Its interior knots are the breakpoints in (0, 1); 0 is
    always one too."""

    @property
    def n_control_points(self) -> int:
        return int(self.spline.c.shape[0] - self.spline.k)

    @property
    def extra_control_points(self) -> int:
        """1: a periodic spline has one control point per breakpoint, 0 included."""
        return extra_control_points(self.degree, closed=True)


def fit_spline(
    u: ArrayLike, points: ArrayLike, interior_knots: ArrayLike, degree: int = 3, *,
    max_multiplicity: int = 1,
) -> SplineFit:
    """Least-squares clamped B-spline through ``points`` with the given interior knots.

    Parameters
    ----------
    u
        Strictly increasing parameter values, shape ``(N,)`` (see :func:`parameterize`).
    points
        Data points, shape ``(N, d)``.
    interior_knots
        Interior knots, sorted, strictly inside ``(u[0], u[-1])``; each at most
        ``max_multiplicity`` times.
    degree
        Spline degree, 1..5.
    max_multiplicity
        How often an interior knot may repeat: 1 (default, distinct knots) to ``degree``; a knot
        of multiplicity m leaves the spline C^(degree - m) there (a corner at m = degree).

    Raises
    ------
    ValueError
        If the knot vector cannot be fitted; the message names the reason (for example a
        Schoenberg-Whitney violation).
    """
    u, q = _prepare(u, points, degree)
    p = int(degree)
    return _fit_clamped(u, q, interior_knots, p, check_multiplicity(max_multiplicity, p))


def _fit_clamped(u: np.ndarray, q: np.ndarray, interior_knots: ArrayLike, p: int,
                 max_multiplicity: int = 1) -> SplineFit:
    """:func:`fit_spline` of data already checked (``u``, ``q`` as :func:`_prepare` returns
    them) and a multiplicity checked."""
    interior = np.asarray(interior_knots, dtype=np.float64)
    if interior.ndim != 1:
        raise ValueError(f"interior_knots must be 1-D; got shape {interior.shape}")
    add_fits(1)
    code, t, coef = _kernel.fit_one(u, q, np.ascontiguousarray(interior), p, max_multiplicity)
    if code != Infeasibility.FEASIBLE:
        raise ValueError(f"cannot fit these knots: {Infeasibility(code).message}")
    return SplineFit(spline=BSpline(t, coef, p), params=u, points=q)
