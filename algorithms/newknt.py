"""de Boor's ``newknt``: knots that equidistribute ``|D^(p+1) f|^(1/(p+1))`` of a pilot spline.

C. de Boor, *A Practical Guide to Splines* (Springer 1978, rev. 2001), chapter XII (subroutine
NEWNOT; MATLAB's ``newknt``). The best L2 or L-infinity approximation by splines of order
``k = p + 1`` with free knots has, asymptotically, knots that split ``|D^k f|^(1/k)`` into equal
integrals. ``D^k f`` is estimated from the current spline ``s``: ``D^p s`` is constant on each
knot span (``a_i``); its divided differences across the breaks,
``d_i = (a_i - a_{i-1}) / ((xi_{i+1} - xi_{i-1}) / 2)``, estimate ``D^k f`` there, and the
density on span ``i`` is ``(|d_i| + |d_{i+1}|)^(1/k)`` (a missing end difference counts the
other twice), piecewise constant. The new knots split its integral into equal parts; the
iteration fit -> new knots is repeated.

Choices the guide leaves to the caller:

* The start at each count ``K`` is the averaging knots (NURBS Book eqs. 9.68-9.69; a closed
  outline's evenly spread breakpoints), then ``iterations`` rounds of NEWNOT (default 3); the
  round with the lowest error is kept (NEWNOT need not improve each time).
* The count: the fewest ``K`` within the tolerance, found by doubling then bisection
  (:meth:`~metaknot.algorithms.literature.Target.fewest`).
* A closed outline: the breaks are cyclic (the span before 0 is the last one).
* A small floor (1e-3 of the mean) keeps the density positive where ``D^k f`` vanishes, so
  every span gets some length.
"""

from __future__ import annotations

import numpy as np

from metaknot.optimizer import check_param
from metaknot.registry import register

from .literature import Target, ToleranceMethod, equidistribute, tolerance_method

__all__ = ["NewKnt", "newknt", "newnot"]


def newnot(target: Target, knots: np.ndarray) -> np.ndarray | None:
    """One NEWNOT step: the same number of knots, equidistributing the density of the fit
    with ``knots`` (None if those cannot be fitted)."""
    found = target.fit(knots)
    if found is None:
        return None
    lo, hi = target.bounds
    p = target.degree
    breaks = np.concatenate(([lo], knots, [hi]))
    mid = 0.5 * (breaks[1:] + breaks[:-1])
    a = found.spline.derivative(p)(mid).reshape(mid.size, -1)  # D^p s on each span
    width = np.diff(breaks)
    # the jump at every break 0..m of the m spans: cyclic on a closed outline; at an open
    # curve's ends the spans are mirrored, so a missing end difference is its neighbour's
    a, width2 = target.curve.extend(a, 1, "reflect"), target.curve.extend(width, 1, "reflect")
    d = np.linalg.norm(np.diff(a, axis=0), axis=1) / (0.5 * (width2[1:] + width2[:-1]))
    size = d[:-1] + d[1:]
    rho = (size + 1e-3 * max(size.mean(), np.finfo(float).tiny)) ** (1.0 / (p + 1))
    total = np.concatenate(([0.0], np.cumsum(rho * width)))  # exact for a piecewise constant
    return equidistribute((breaks, total / total[-1]), knots.size)


@tolerance_method("newknt")
def newknt(target: Target, iterations: int = 3) -> np.ndarray:
    """de Boor's NEWNOT (``newknt``) at the fewest knots within the tolerance (see the module
    docstring)."""

    def knots_at(k: int) -> np.ndarray | None:
        knots = target.curve.spread_knots(k)
        best, best_error = knots, target.error(knots)
        for _ in range(iterations):
            refined = newnot(target, knots)
            if refined is None:
                break
            knots = refined
            error = target.error(knots)
            if error < best_error:
                best, best_error = knots, error
        return best

    return target.fewest(knots_at)


@register("newknt")
class NewKnt(ToleranceMethod):
    """de Boor's ``newknt`` (:func:`newknt`) as an optimizer
    (:class:`~metaknot.algorithms.literature.ToleranceMethod`).

    Parameters
    ----------
    iterations
        NEWNOT rounds at each count (>= 0).
    tolerance, metric, max_knots, batch_size
        As :class:`~metaknot.algorithms.literature.ToleranceMethod`.
    """

    method = staticmethod(newknt)
    options = ("iterations",)

    def __init__(self, iterations: int = 3, tolerance: float | None = None,
                 metric: str = "max_deviation", max_knots: int | None = None,
                 batch_size: int = 1) -> None:
        super().__init__(tolerance, metric, max_knots, batch_size)
        self.iterations = check_param("iterations", iterations, low=0, integer=True)
