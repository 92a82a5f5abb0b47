"""FITPACK, the baseline everyone has: every call metaknot makes to scipy's ``splprep``.

FITPACK's smoothing spline places knots greedily at data sites until its weighted sum of squared
residuals is at most the smoothing factor ``s`` (Dierckx 1993). metaknot asks it for:

* :func:`smoothing_spline`: the spline at one ``s``, on open data or on a closed outline
  (``per=1``, the first point repeated at ``u = 1``), as a :class:`SmoothingSpline`;
* :func:`interior_knots`: just its interior knots (the ``fitpack`` baseline, the
  ``encoding.n_knots=fitpack:<factor>`` rule of studies);
* :func:`front`: its own front of control points against error over many ``s``;
* :func:`fewest_within`: the fewest control points it needs to stay within a tolerance (the
  reference ``metaknot fit`` is held to).

FITPACK refuses some smoothing factors (and some data); :func:`smoothing_spline` raises
:class:`FitpackError` then, and the searches skip those ``s``. None of these calls is a fit of
metaknot's kernels: optimizers that make them declare them with ``count_fits``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Literal, cast

import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import BSpline, splev, splprep

from .fit import Metric

__all__ = ["FitpackError", "SmoothingSpline", "fewest_within", "front", "interior_knots",
           "smoothing_spline"]


class FitpackError(ValueError):
    """FITPACK refused the data or the smoothing factor."""


@dataclass(frozen=True, eq=False)
class SmoothingSpline:
    """FITPACK's smoothing spline at one smoothing factor.

    Attributes
    ----------
    tck
        The spline as FITPACK returns it: knots, coefficients per coordinate, degree (for a
        closed outline the knots are periodic and the last ``degree`` coefficients repeat the
        first).
    closed
        Whether it is FITPACK's periodic spline.
    s
        The smoothing factor.
    """

    tck: tuple[np.ndarray, list[np.ndarray], int]
    closed: bool
    s: float

    @property
    def degree(self) -> int:
        return int(self.tck[2])

    @property
    def knots(self) -> np.ndarray:
        return np.asarray(self.tck[0])

    @property
    def interior_knots(self) -> np.ndarray:
        p = self.degree
        return self.knots[p + 1 : -(p + 1)]

    @property
    def n_control_points(self) -> int:
        """Control points (a closed spline's repeated coefficients not counted)."""
        p = self.degree
        return self.knots.size - p - 1 - (p if self.closed else 0)

    def distances(self, u: ArrayLike, points: ArrayLike) -> np.ndarray:
        """Distance of every point to the spline at its parameter value."""
        q = np.asarray(points, dtype=np.float64)
        return np.linalg.norm(q - np.column_stack(splev(np.asarray(u), self.tck)), axis=1)

    def bspline(self) -> BSpline:
        """The spline as a :class:`scipy.interpolate.BSpline` (coefficients ``(n, d)``)."""
        t, c, k = self.tck
        return BSpline(np.asarray(t), np.asarray(c).T, int(k))


def smoothing_spline(u: ArrayLike, points: ArrayLike, degree: int, s: float, *,
                     closed: bool = False) -> SmoothingSpline:
    """FITPACK's smoothing spline (``splprep``) through ``points`` at parameters ``u``.

    Parameters
    ----------
    u, points
        Parameter values ``(N,)`` (in [0, 1) for a closed outline) and points ``(N, d)``.
    degree
        Spline degree, 1..5.
    s
        Smoothing factor: the largest sum of squared residuals FITPACK accepts (0:
        interpolation).
    closed
        Fit FITPACK's periodic spline (the first point repeated at ``u = 1``).

    Raises
    ------
    FitpackError
        If FITPACK refuses the data or ``s`` (the message gives its reason).
    """
    u = np.asarray(u, dtype=np.float64)
    q = np.asarray(points, dtype=np.float64)
    if closed:
        q, u = np.vstack((q, q[:1])), np.append(u, 1.0)
    try:
        tck, _ = splprep(q.T, u=u, k=degree, s=s, per=1 if closed else 0, full_output=1,
                            quiet=1)[0]
    except Exception as exc:  # FITPACK raises ValueError, TypeError or its own errors
        raise FitpackError(f"FITPACK refused s = {s:g}: {exc}") from None
    # scipy-stubs type tck as a list of a union; it is [knots, coefficient arrays, degree]
    t, c, k = tck[0], cast(list[np.ndarray], tck[1]), cast(int, tck[2])
    return SmoothingSpline((np.asarray(t), [np.asarray(ci) for ci in c], int(k)), closed,
                           float(s))


def interior_knots(u: ArrayLike, points: ArrayLike, degree: int, s: float) -> np.ndarray:
    """Interior knots of FITPACK's smoothing spline on open data at smoothing factor ``s``.

    Raises
    ------
    FitpackError
        If FITPACK refuses the data or ``s``.
    """
    return smoothing_spline(u, points, degree, s).interior_knots


def front(u: ArrayLike, points: ArrayLike, degree: int, n_smoothing: int = 200, *,
          closed: bool = False) -> dict[str, np.ndarray]:
    """FITPACK's own front: its smoothing splines over ``n_smoothing`` smoothing factors spaced
    geometrically from 1e-14 to 1/2 of the data's total sum of squares, reduced to the best fit
    per control-point count.

    Returns
    -------
    dict
        ``n_control_points``, ``rmse`` and ``max_deviation`` (arrays, by control points); for
        each count the fit with the lowest RMSE (the ``s`` FITPACK refuses are left out).
    """
    q = np.asarray(points, dtype=np.float64)
    total = float(((q - q.mean(axis=0)) ** 2).sum())
    best: dict[int, tuple[float, float]] = {}
    for s in np.geomspace(total * 1e-14, total * 0.5, n_smoothing):
        try:
            spline = smoothing_spline(u, q, degree, float(s), closed=closed)
        except FitpackError:
            continue
        distance = spline.distances(u, q)
        rmse, count = float(np.sqrt(np.mean(distance**2))), spline.n_control_points
        if count not in best or rmse < best[count][0]:
            best[count] = (rmse, float(distance.max()))
    counts = np.array(sorted(best), dtype=np.int64)
    return {"n_control_points": counts,
            "rmse": np.array([best[c][0] for c in counts]),
            "max_deviation": np.array([best[c][1] for c in counts])}


#: The scan of :func:`fewest_within` runs from the largest smoothing factor down and stops
#: once FITPACK's spline has more than this many times the control points of the fewest found
#: within the tolerance (and at least ``SCAN_STOP_MARGIN`` more): below there FITPACK only adds
#: knots, and its fits near interpolation cost the most (tens of milliseconds each, against
#: about one near the answer).
SCAN_STOP_FACTOR = 2.0
SCAN_STOP_MARGIN = 10


def fewest_within(u: ArrayLike, points: ArrayLike, degree: int, tolerance: float,
                  metric: Metric, *, closed: bool = False
                  ) -> dict[str, Any]:
    """The fewest control points FITPACK's smoothing spline needs to stay within ``tolerance``: a
    scan of 60 smoothing factors over log s (1e-14 to 1 times the data's total sum of squares),
    then bisection on log s between the fewest within and the nearest larger factor beyond.

    The scan runs from the largest factor down and stops where FITPACK's splines have far more
    control points than the fewest found within (``SCAN_STOP_FACTOR``): the near-interpolating
    splines it leaves out are the costly ones and have no chance of being the answer.

    Returns
    -------
    dict
        ``spline`` (a :class:`scipy.interpolate.BSpline`), ``n_control_points``,
        ``max_deviation``, ``rmse``, ``s`` and ``seconds``.

    Raises
    ------
    ValueError
        If no smoothing spline, interpolation included, is within ``tolerance``.
    """
    start = time.perf_counter()
    q = np.asarray(points, dtype=np.float64)
    total = float(((q - q.mean(axis=0)) ** 2).sum())

    def errors(s: float) -> tuple[SmoothingSpline, float, float] | None:
        try:
            spline = smoothing_spline(u, q, degree, s, closed=closed)
        except FitpackError:
            return None
        distance = spline.distances(u, q)
        return spline, float(distance.max()), float(np.sqrt(np.mean(distance**2)))

    index: Literal[1, 2] = 1 if metric == "max_deviation" else 2
    best = None
    within, beyond = None, None  # log s of the answer, of the nearest larger factor beyond
    last_beyond = None
    for x in np.linspace(np.log(total * 1e-14), np.log(total), 60)[::-1]:
        found = errors(float(np.exp(x)))
        if found is None:
            continue
        count = found[0].n_control_points
        if found[index] > tolerance:
            last_beyond = x
        elif best is None or count < best[0].n_control_points:
            best, within, beyond = found, x, last_beyond
        if best is not None and count > max(SCAN_STOP_FACTOR * best[0].n_control_points,
                                            best[0].n_control_points + SCAN_STOP_MARGIN):
            break
    if best is None:  # interpolation (s = 0)
        best, within = errors(0.0), None
        if best is None or best[index] > tolerance:
            raise ValueError("FITPACK finds no spline within the tolerance")
    elif beyond is not None:
        lo, hi = within, beyond
        for _ in range(25):
            mid = 0.5 * (lo + hi)
            found = errors(float(np.exp(mid)))
            if found is not None and found[index] <= tolerance:
                lo = mid
                if found[0].knots.size <= best[0].knots.size:
                    best, within = found, mid
            else:
                hi = mid
    spline, max_dev, rmse = best
    return {"spline": spline.bspline(), "n_control_points": spline.n_control_points,
            "max_deviation": max_dev, "rmse": rmse,
            "s": float(np.exp(within)) if within is not None else 0.0,
            "seconds": time.perf_counter() - start}
