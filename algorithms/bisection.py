"""Bisection and refinement (Dung & Tjahjowidodo 2017): split the data where one polynomial piece
is beyond the tolerance, then refine the knots by nonlinear least squares.

V. T. Dung & T. Tjahjowidodo, "A direct method to solve optimal knots of B-spline curves: An
application for non-uniform B-spline curves fitting", PLoS ONE 12(3): e0173857 (2017). The data
are bisected recursively: a segment whose least-squares polynomial of the spline's degree stays
within the tolerance is kept, any other is split in two at its middle data point; the segment
ends are the initial knots. The knot positions are then refined by nonlinear least squares
(``scipy.optimize.least_squares``, the residuals of the spline's least-squares fit to the data
— metaknot's kernel — as the residual function), and knots that are no longer needed are
removed.

Choices the paper leaves open (or that differ):

* The segment test uses the tolerance on the segment's own points, with ``metric``: the largest
  point distance, or the segment's RMSE.
* A spline joins its pieces with ``C^(p-1)`` continuity, so knots at the segment ends need not
  bring the spline within the tolerance: after the refinement, while it is not, the knot span
  holding the largest error at a data point inside it (not at a knot) is split at its middle
  data point (no second refinement:
  each one costs ``(K + 1) max_nfev`` fits); a split after which the fit is singular (a data
  point next to a refined knot can leave a span without data) is undone, and the splitting
  ends there.
* The refinement: ``least_squares`` (trust region reflective with LSMR, finite differences, at most
  ``max_nfev`` residual evaluations), each knot bounded to the middle 90 % between its
  neighbours, so the order holds; the refined knots are kept only if their fit is no worse.
  A single knot is refined with the exact trust-region solver: scipy's LSMR variant solves
  its subproblem in a two-dimensional subspace and fails on one variable.
* Redundant knots: removed one at a time, the removal that leaves the lowest error first,
  while the fit stays within the tolerance.
* A closed outline is bisected as the sequence of its points from point 0 round to point 0
  again (at parameter 1); 0 is always a breakpoint.
"""

from __future__ import annotations

import numpy as np

from metaknot.optimizer import check_param
from metaknot.registry import register

from .literature import Target, ToleranceMethod, tolerance_method

__all__ = ["Bisection", "bisect_segments", "bisection", "refine_knots", "remove_redundant"]


def bisect_segments(target: Target) -> np.ndarray:
    """The interior segment ends of the recursive bisection (data parameters)."""
    curve, p = target.curve, target.degree
    u, q = curve.domain_params, curve.around(curve.points)  # a closed outline: round to 0 again
    ends, stack = [], [(0, u.size - 1)]
    while stack:
        a, b = stack.pop()
        if b - a <= p + 1:  # as many points as coefficients: the polynomial interpolates
            continue
        x = (u[a : b + 1] - u[a]) / (u[b] - u[a]) * 2.0 - 1.0
        basis = np.polynomial.legendre.legvander(x, p)
        target.count(1)
        coef, *_ = np.linalg.lstsq(basis, q[a : b + 1], rcond=None)
        d = np.linalg.norm(basis @ coef - q[a : b + 1], axis=1)
        error = d.max() if target.metric == "max_deviation" else np.sqrt(np.mean(d**2))
        if error > target.tolerance:
            mid = (a + b) // 2
            ends.append(mid)
            stack += [(mid, b), (a, mid)]
    return np.sort(u[np.array(ends, dtype=np.int64)])


def refine_knots(target: Target, knots: np.ndarray, max_nfev: int) -> np.ndarray:
    """Knot positions refined by ``scipy.optimize.least_squares`` on the fit's residuals (the
    refined knots if their fit is no worse)."""
    from scipy.optimize import least_squares

    if knots.size == 0 or max_nfev < 1:
        return knots
    lo, hi = target.bounds
    ext = np.concatenate(([lo], knots, [hi]))
    lower = knots - 0.45 * (knots - ext[:-2])
    upper = knots + 0.45 * (ext[2:] - knots)
    start = target.fit(knots)
    if start is None:
        return knots
    shape = start.points.size

    def residuals(x: np.ndarray) -> np.ndarray:
        found = target.fit(np.sort(x))
        if found is None:
            return np.full(shape, 1e3 * max(start.max_deviation, 1e-300))
        return (found.points - found.spline(found.params)).ravel()

    solution = least_squares(residuals, knots, bounds=(lower, upper), method="trf",
                             x_scale=np.minimum(knots - lower, upper - knots) + 1e-300,
                             max_nfev=max_nfev,
                             tr_solver="lsmr" if knots.size > 1 else "exact")
    refined = np.sort(solution.x)
    return refined if target.error(refined) <= target.error(knots) else knots


def remove_redundant(target: Target, knots: np.ndarray) -> np.ndarray:
    """Remove knots one at a time, the removal of lowest error first, while within."""
    while knots.size > target.min_count:
        rows = [np.delete(knots, j) for j in range(knots.size)]
        errors = target.errors(rows)
        best = int(np.argmin(errors))
        if errors[best] > target.tolerance:
            break
        knots = rows[best]
    return knots


@tolerance_method("bisection")
def bisection(target: Target, max_nfev: int = 20) -> np.ndarray:
    """Dung & Tjahjowidodo's bisection and refinement (see the module docstring)."""
    knots = bisect_segments(target)
    knots = target.with_min_count(knots)  # a closed spline needs p - 1 breakpoints beside 0
    knots = refine_knots(target, knots, max_nfev)
    lo, hi = target.bounds
    fitted = knots  # the last knots that could be fitted
    while True:
        found = target.fit(knots)
        if found is None:  # the last split left a span no basis function can be fitted on
            knots = fitted
            break
        fitted = knots
        d = found.residuals
        error = d.max() if target.metric == "max_deviation" else np.sqrt(np.mean(d**2))
        if error <= target.tolerance or knots.size >= target.max_count:
            break
        ext = np.concatenate(([lo], knots, [hi]))
        span = np.searchsorted(ext, target.params, side="right") - 1
        splittable = (target.params > ext[span]) & (target.params < ext[np.minimum(span + 1,
                                                                             ext.size - 1)])
        if not splittable.any():
            break
        worst = span[np.flatnonzero(splittable)[np.argmax(d[splittable])]]
        inside = target.params[splittable & (span == worst)]
        knots = np.sort(np.append(knots, inside[inside.size // 2]))
    return remove_redundant(target, knots)


@register("bisection")
class Bisection(ToleranceMethod):
    """Bisection and refinement (:func:`bisection`) as an optimizer
    (:class:`~metaknot.algorithms.literature.ToleranceMethod`).

    Parameters
    ----------
    max_nfev
        Residual evaluations of each ``least_squares`` refinement (>= 0; 0: no refinement).
    tolerance, metric, max_knots, batch_size
        As :class:`~metaknot.algorithms.literature.ToleranceMethod`.
    """

    method = staticmethod(bisection)
    options = ("max_nfev",)

    def __init__(self, max_nfev: int = 20, tolerance: float | None = None,
                 metric: str = "max_deviation", max_knots: int | None = None,
                 batch_size: int = 1) -> None:
        super().__init__(tolerance, metric, max_knots, batch_size)
        self.max_nfev = check_param("max_nfev", max_nfev, low=0, integer=True)
