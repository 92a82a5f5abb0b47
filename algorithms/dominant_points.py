"""Dominant points (Park & Lee 2007): knots by averaging the parameters of dominant points,
which are added where the fit is worst until it is within the tolerance.

H. Park & J.-H. Lee, "B-spline curve fitting based on adaptive curve refinement using dominant
points", Computer-Aided Design 39 (2007) 439-451. Dominant points are data points of high
discrete curvature; a spline with ``n`` control points gets ``n`` dominant points and its knots
by averaging their parameters, ``knot_j = (u_d[j] + ... + u_d[j + p - 1]) / p`` (the NURBS
Book's averaging over the dominant points, eq. 9.8). Adaptive refinement: fit, find the segment
between consecutive dominant points with the largest error, add a dominant point in it, repeat
until the fit is within the tolerance.

Choices the paper leaves open (or that differ):

* Curvature is the turning angle of the data polygon
  (:func:`~metaknot.algorithms.equidistribution.turning_angles`; function data as the graph,
  each axis scaled to [0, 1]), smoothed by a Gaussian of ``smoothing`` points; the candidates
  are its local maxima.
* The start: the end points and the ``p - 1`` strongest maxima (no interior knot; evenly
  spread points if there are fewer maxima).
* The new dominant point in the worst segment: its unused candidate of highest curvature, or,
  without one, the data point of largest error inside the segment.
* The worst segment: by the largest point error (``max_deviation``) or the largest sum of
  squared errors (``rmse``).
* A closed outline: the dominant points are its breakpoints themselves (point 0 always one, as
  the periodic spline has a breakpoint at 0); segments are cyclic.
"""

from __future__ import annotations

import numpy as np

from metaknot.optimizer import check_param
from metaknot.registry import register

from .equidistribution import smoothed_turning
from .literature import Target, ToleranceMethod, tolerance_method

__all__ = ["DominantPoints", "dominant_knots", "dominant_points"]


def dominant_knots(target: Target, dominant: np.ndarray) -> np.ndarray:
    """Interior knots of the dominant point indices (sorted): averages of ``p`` consecutive
    dominant parameters (open), the dominant parameters but 0 (closed)."""
    return target.curve.knots_for_breaks(target.params[dominant])


def _candidates(target: Target, smoothing: float) -> tuple[np.ndarray, np.ndarray]:
    """Curvature of every point and the local maxima (indices), strongest first."""
    angle = smoothed_turning(target, smoothing)
    left, right = np.roll(angle, 1), np.roll(angle, -1)
    peak = (angle > left) & (angle >= right)
    peak[target.curve.end_indices] = False
    maxima = np.flatnonzero(peak)
    return angle, maxima[np.argsort(-angle[maxima], kind="stable")]


@tolerance_method("dominant_points")
def dominant_points(target: Target, smoothing: float = 1.0) -> np.ndarray:
    """Park & Lee's adaptive refinement by dominant points (see the module docstring)."""
    n, p = target.params.size, target.degree
    curvature, maxima = _candidates(target, smoothing)
    ends = sorted({0, *target.curve.end_indices.tolist()})
    chosen = set(ends) | set(maxima[: p - 1].tolist())  # no interior knot (closed: p breaks)
    for i in np.linspace(0, n - 1, p + 1).astype(int):  # too few maxima: spread the rest
        if len(chosen) >= len(ends) + p - 1:
            break
        chosen.add(int(i))
    best = None
    while True:
        dominant = np.array(sorted(chosen))
        knots = dominant_knots(target, dominant)
        found = target.fit(knots)
        if found is None:
            return knots if best is None else best
        error = found.max_deviation if target.metric == "max_deviation" else found.rmse
        best = knots
        if error <= target.tolerance or knots.size >= target.max_count:
            return knots
        residual = found.residuals
        # segment s holds the points strictly between dominant[s] and the next dominant point
        # (an open curve's last point is dominant: its last segment is empty)
        bounds = np.append(dominant, n)
        order = []
        for s in range(bounds.size - 1):
            inside = np.arange(bounds[s] + 1, bounds[s + 1]) % n
            if inside.size:
                r = residual[inside]
                order.append((r.max() if target.metric == "max_deviation" else (r**2).sum(),
                              s, inside))
        if not order:
            return knots
        _, s, inside = max(order, key=lambda e: e[0])
        unused = [i for i in maxima if i in set(inside.tolist())]
        pick = max(unused, key=lambda i: curvature[i]) if unused else \
            int(inside[np.argmax(residual[inside])])
        chosen.add(int(pick))


@register("dominant_points")
class DominantPoints(ToleranceMethod):
    """Dominant points (:func:`dominant_points`) as an optimizer
    (:class:`~metaknot.algorithms.literature.ToleranceMethod`).

    Parameters
    ----------
    smoothing
        Standard deviation, in points, of the Gaussian that smooths the curvature (>= 0).
    tolerance, metric, max_knots, batch_size
        As :class:`~metaknot.algorithms.literature.ToleranceMethod`.
    """

    method = staticmethod(dominant_points)
    options = ("smoothing",)

    def __init__(self, smoothing: float = 1.0, tolerance: float | None = None,
                 metric: str = "max_deviation", max_knots: int | None = None,
                 batch_size: int = 1) -> None:
        super().__init__(tolerance, metric, max_knots, batch_size)
        self.smoothing = check_param("smoothing", smoothing, low=0)
