"""Curvature / feature equidistribution: knots that split a feature function into equal parts.

Three papers place knots by equal integrals of a feature of the data, growing the count until the
fit is within the tolerance:

* A. Razdan, "Knot placement for B-spline curve approximation", Tech. report, Arizona State
  University (1999): equal shares of a combination of arc length and curvature;
* W. Li, S. Xu, G. Zhao & L. P. Goh, "Adaptive knot placement in B-spline curve
  approximation", Computer-Aided Design 37 (2005): equal integrals of the smoothed discrete
  curvature (Li, Xu & Wang in the issue's words);
* Y.-C. Yeh, M. Nashed, T. Peterka & X. Tricoche, "Fast automatic knot placement method for
  accurate B-spline curve fitting", Computer-Aided Design 128 (2020): the feature
  ``|f^(p+1)|^(1/(p+1))``, estimated from the data, equidistributed.

``feature="derivative"`` (default) is Yeh et al.'s feature: ``|x^(p+1)(u)|^(1/(p+1))`` of a
pilot least-squares spline (:func:`~metaknot.algorithms.literature.knot_density`, the density
``free_front`` starts from with its own exponent). ``feature="curvature"`` is Razdan's and Li et
al.'s: the turning angle of the data polygon at each point, smoothed by a Gaussian of
``smoothing`` points (Li et al.'s smoothing), plus an equal share of arc length (Razdan's
combination), both normalised to a total of 1: a data interval gets
``(turning_i / total turning + length_i / total length) / 2`` of the density.

Choices the papers leave open:

* Function data ``y = f(x)`` have no curve to measure curvature on: the graph ``(x, y)`` is
  used, each axis scaled to [0, 1].
* Li et al. then refine by inserting knots where the error is largest; here the whole
  equidistributed set is recomputed at each count (the count search of
  :meth:`~metaknot.algorithms.literature.Target.fewest`: doubling, then bisection), which keeps
  the method a pure equidistribution.
* A closed outline's turning is measured cyclically (the closing chord included); its pilot
  spline (``feature="derivative"``) is an open one over its parameters.
"""

from __future__ import annotations

import numpy as np

from metaknot.bspline.curve import Curve
from metaknot.optimizer import check_param
from metaknot.registry import register

from .literature import (
    Target,
    ToleranceMethod,
    cumulative,
    equidistribute,
    knot_density,
    tolerance_method,
)

__all__ = ["FEATURES", "Equidistribution", "check_feature", "curvature_density",
           "equidistribution", "smoothed_turning", "turning_angles"]

#: the feature functions a knot density can equidistribute
FEATURES = ("derivative", "curvature")


def check_feature(feature: str) -> str:
    """``feature`` if it names one of :data:`FEATURES`, else a ``ValueError`` naming them."""
    if feature not in FEATURES:
        raise ValueError(f"feature must be 'derivative' or 'curvature'; got {feature!r}")
    return feature


def turning_angles(curve: Curve, reach: int = 1) -> np.ndarray:
    """The turning angle of the data polygon at every point, between the chords to the points
    ``reach`` away on either side (0 at an open curve's first and last ``reach``); function
    data (one coordinate) as the graph ``(x, y)``, both scaled to [0, 1]."""
    q, params = curve.points, curve.params
    if q.shape[1] == 1:
        span = np.ptp(q[:, 0]) or 1.0
        q = np.column_stack(((params - params[0]) / (params[-1] - params[0]), q[:, 0] / span))
    nxt = np.roll(q, -reach, axis=0) - q
    prv = q - np.roll(q, reach, axis=0)
    cos = np.einsum("ij,ij->i", nxt, prv) / np.maximum(
        np.linalg.norm(nxt, axis=1) * np.linalg.norm(prv, axis=1), np.finfo(float).tiny)
    angle = np.arccos(np.clip(cos, -1.0, 1.0))
    if not curve.closed:
        angle[:reach] = angle[-reach:] = 0.0
    return angle


def smoothed_turning(target: Target, smoothing: float) -> np.ndarray:
    """:func:`turning_angles` smoothed by a Gaussian of ``smoothing`` points (Li et al.'s
    smoothed discrete curvature; cyclic on a closed outline)."""
    angle = turning_angles(target.curve)
    if smoothing > 0:
        half = int(np.ceil(3 * smoothing))
        w = np.exp(-0.5 * (np.arange(-half, half + 1) / smoothing) ** 2)
        padded = target.curve.extend(angle, half, open_mode="edge")
        angle = np.convolve(padded, w / w.sum(), mode="valid")
    return angle


def curvature_density(target: Target, smoothing: float) -> tuple[np.ndarray, np.ndarray]:
    """The cumulative density of Razdan's combination (see the module docstring), over the
    data parameters (a closed outline's extended to 1)."""
    curve = target.curve
    grid = curve.domain_params
    steps = np.linalg.norm(np.diff(curve.around(curve.points), axis=0), axis=1)
    angle = curve.around(smoothed_turning(target, smoothing))
    turn = 0.5 * (angle[1:] + angle[:-1])
    share = steps / steps.sum() + (turn / turn.sum() if turn.sum() > 0 else 0.0)
    total = np.concatenate(([0.0], np.cumsum(share)))  # constant rate on each data interval
    return grid, total / total[-1]


@tolerance_method("equidistribution")
def equidistribution(target: Target, feature: str = "derivative",
                     smoothing: float = 2.0) -> np.ndarray:
    """Knots equidistributing a feature function, at the fewest count within the tolerance
    (see the module docstring)."""
    if check_feature(feature) == "derivative":
        target.count(1)
        density = knot_density(target.params, target.points, target.degree,
                               1.0 / (target.degree + 1))
        if density is None:  # too few points for the pilot: arc length alone
            density = cumulative(np.ones(target.params.size), target.params)
    else:
        density = curvature_density(target, smoothing)

    def knots_at(k: int) -> np.ndarray | None:
        knots = equidistribute(density, k)
        lo, hi = target.bounds
        return None if knots is None else knots[(knots > lo) & (knots < hi)]

    return target.fewest(knots_at)


@register("equidistribution")
class Equidistribution(ToleranceMethod):
    """Feature equidistribution (:func:`equidistribution`) as an optimizer
    (:class:`~metaknot.algorithms.literature.ToleranceMethod`).

    Parameters
    ----------
    feature
        ``"derivative"`` (Yeh et al. 2020) or ``"curvature"`` (Razdan 1999; Li et al. 2005).
    smoothing
        Standard deviation, in points, of the Gaussian that smooths the curvature (>= 0).
    tolerance, metric, max_knots, batch_size
        As :class:`~metaknot.algorithms.literature.ToleranceMethod`.
    """

    method = staticmethod(equidistribution)
    options = ("feature", "smoothing")

    def __init__(self, feature: str = "derivative", smoothing: float = 2.0,
                 tolerance: float | None = None, metric: str = "max_deviation",
                 max_knots: int | None = None, batch_size: int = 1) -> None:
        super().__init__(tolerance, metric, max_knots, batch_size)
        self.feature = check_feature(feature)
        self.smoothing = check_param("smoothing", smoothing, low=0)
