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
* ``floor`` (default 1e-3) of the mean is added to the density, keeping it positive where
  ``D^k f`` vanishes, so every span gets some length. ``floor=0`` is NEWNOT's own rule: no
  floor; a new knot that falls on a span of zero density goes to that span's middle, and if
  the density is zero everywhere the new knots are uniform. With the floor the knots move
  towards uniform by about the floor's share (the density's integral over a span is at least
  ``floor^(1/k)`` times the mean's).
"""

from __future__ import annotations

import numpy as np

from metaknot.optimizer import check_param
from metaknot.registry import register

from .literature import Target, ToleranceMethod, equidistribute, tolerance_method

__all__ = ["NewKnt", "newknt", "newnot"]


def newnot(target: Target, knots: np.ndarray, floor: float = 1e-3,
           count: int | None = None) -> np.ndarray | None:
    """One NEWNOT step: ``count`` knots (default as many as ``knots``; PPPACK's ``lnew - 1``)
    equidistributing the density of the fit with ``knots`` (None if those cannot be fitted);
    ``floor``: see the module docstring."""
    count = knots.size if count is None else int(check_param("count", count, low=1, integer=True))
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
    if floor == 0.0:
        return _inverse(breaks, size ** (1.0 / (p + 1)), count)
    rho = (size + floor * max(size.mean(), np.finfo(float).tiny)) ** (1.0 / (p + 1))
    total = np.concatenate(([0.0], np.cumsum(rho * width)))  # exact for a piecewise constant
    return equidistribute((breaks, total / total[-1]), count)


def _inverse(breaks: np.ndarray, slope: np.ndarray, count: int) -> np.ndarray | None:
    """NEWNOT's new knots: ``g^-1(i step)`` for the piecewise linear ``g`` of the given slope
    on each span (from 0 at the first break), ``step = g(end) / (count + 1)``; a knot on a span
    of zero slope at its middle; uniform knots if ``g`` is zero (None if two coincide)."""
    g = np.concatenate(([0.0], np.cumsum(slope * np.diff(breaks))))
    if not g[-1] > 0.0:
        return np.linspace(breaks[0], breaks[-1], count + 2)[1:-1]
    levels = np.arange(1, count + 1) * (g[-1] / (count + 1))
    span = np.minimum(np.searchsorted(g[1:], levels, side="left"), slope.size - 1)
    flat = slope[span] == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        knots = np.where(flat, 0.5 * (breaks[span] + breaks[span + 1]),
                         breaks[span] + (levels - g[span]) / slope[span])
    return knots if np.all(np.diff(knots) > 0) else None


@tolerance_method("newknt")
def newknt(target: Target, iterations: int = 3, floor: float = 1e-3) -> np.ndarray:
    """de Boor's NEWNOT (``newknt``) at the fewest knots within the tolerance (see the module
    docstring; ``floor=0``: NEWNOT's own rules)."""

    def knots_at(k: int) -> np.ndarray | None:
        knots = target.curve.spread_knots(k)
        best, best_error = knots, target.error(knots)
        for _ in range(iterations):
            refined = newnot(target, knots, floor)
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
    floor
        Share of the mean density added everywhere (>= 0; 0: de Boor's NEWNOT exactly).
    tolerance, metric, max_knots, batch_size
        As :class:`~metaknot.algorithms.literature.ToleranceMethod`.
    """

    method = staticmethod(newknt)
    options = ("iterations", "floor")

    def __init__(self, iterations: int = 3, floor: float = 1e-3,
                 tolerance: float | None = None, metric: str = "max_deviation",
                 max_knots: int | None = None, batch_size: int = 1) -> None:
        super().__init__(tolerance, metric, max_knots, batch_size)
        self.iterations = check_param("iterations", iterations, low=0, integer=True)
        self.floor = check_param("floor", floor, low=0)
