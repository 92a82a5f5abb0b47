"""Knot removal by weighted significance (Lyche & Mørken 1987): from a dense knot vector, drop
the least significant knots while the fit stays within the tolerance.

T. Lyche & K. Mørken, "Knot removal for parametric B-spline curves and surfaces", Computer
Aided Geometric Design 4 (1987) 217-230. Each interior knot gets a weight: how far the spline
moves when that knot alone is removed. The knots are ranked by weight, and the largest number
``m`` of the lowest-ranked knots whose removal keeps the error within the tolerance is found by
a search over ``m``; the spline is refitted on the remaining knots, the weights recomputed, and
the step repeated until not even the least significant knot can go.

This is the classic ranking, beside ``metaknot fit``'s own removal (which scores every single
removal by a full refit and nudges knots): the two can be compared.

Choices the paper leaves open (or that differ):

* The weight of a knot is the NURBS Book's knot-removal distance (Piegl & Tiller, algorithm
  A5.8: the control points rebuilt from both sides of the knot, and the distance where they
  meet), a bound on how far the spline moves, in place of Lyche & Mørken's locally scaled
  discrete l-infinity approximation; both rank knots by the local change a removal makes.
* The approximation after a removal is the least-squares fit to the data (the tolerance is on
  the data), not to the previous spline.
* The dense start: half the knots the data can carry (the averaging knots of an open curve,
  every other data point of a closed one), a spline close to the data that still smooths
  it, or 3/4, 7/8, 15/16 of them if that is not within the tolerance (none within: the one
  of lowest error); the full count would interpolate, and a least-squares fit there is
  ill-conditioned.
* The search over ``m``: doubling from 1, then bisection (the error need not grow
  monotonically with ``m``; the largest ``m`` found within is taken).
"""

from __future__ import annotations

import numpy as np

from metaknot.registry import register

from .literature import Target, ToleranceMethod, tolerance_method

__all__ = ["LycheMorken", "lyche_morken", "most_removable", "removal_weights"]


def removal_weights(t: np.ndarray, c: np.ndarray, degree: int, positions: np.ndarray
                    ) -> np.ndarray:
    """The removal distance (NURBS Book A5.8, one removal of a simple knot) of the knot at each
    index of ``positions`` in the full knot vector ``t`` of a spline with coefficients ``c``
    ``(n, d)``."""
    p = degree
    weights = np.empty(positions.size)
    for n, r in enumerate(positions):
        u = t[r]
        first, last = r - p, r - 1
        off = first - 1
        temp = np.zeros((last - off + 2, c.shape[1]))
        temp[0], temp[last + 1 - off] = c[off], c[last + 1]
        i, j, ii, jj = first, last, 1, last - off
        while j - i > 0:
            alfi = (u - t[i]) / (t[i + p + 1] - t[i])
            alfj = (u - t[j]) / (t[j + p + 1] - t[j])
            temp[ii] = (c[i] - (1.0 - alfi) * temp[ii - 1]) / alfi
            temp[jj] = (c[j] - alfj * temp[jj + 1]) / (1.0 - alfj)
            i, j, ii, jj = i + 1, j - 1, ii + 1, jj - 1
        if j - i < 0:
            weights[n] = np.linalg.norm(temp[ii - 1] - temp[jj + 1])
        else:
            alfi = (u - t[i]) / (t[i + p + 1] - t[i])
            weights[n] = np.linalg.norm(c[i] - (alfi * temp[ii + 1]
                                                + (1.0 - alfi) * temp[ii - 1]))
    return weights


def most_removable(target: Target, knots: np.ndarray, order: np.ndarray) -> int:
    """The largest ``m`` such that the fit without the knots ``order[:m]`` is within the
    tolerance (0 if not even ``m = 1`` is): doubling from 1, then bisection."""
    most = knots.size - target.min_count
    if most < 1 or not target.within(np.delete(knots, order[:1])):
        return 0
    within, beyond = 1, most + 1  # beyond: the fewest removals found not within, or most + 1
    while beyond - within > 1:  # doubling until one is not within, then bisection
        m = min(2 * within, most) if beyond > most else (within + beyond) // 2
        if target.within(np.delete(knots, order[:m])):
            within = m
        else:
            beyond = m
    return within


@tolerance_method("lyche_morken")
def lyche_morken(target: Target) -> np.ndarray:
    """Lyche & Mørken's knot removal by ranked weights (see the module docstring)."""
    starts = [target.curve.spread_knots(target.max_count - target.max_count // share)
              for share in (2, 4, 8, 16)]  # half the knots the data carry, or more
    for knots in starts:
        if target.within(knots):
            break
    else:  # none within: the start of lowest error
        knots = starts[int(np.argmin(target.errors(starts)))]
    p = target.degree
    while knots.size > target.min_count:
        found = target.fit(knots)
        if found is None:
            break
        t = np.asarray(found.spline.t)
        c = np.asarray(found.spline.c).reshape(len(t) - p - 1, -1)
        positions = np.searchsorted(t, knots)  # each knot is simple: its index in t
        order = np.argsort(removal_weights(t, c, p, positions), kind="stable")
        within = most_removable(target, knots, order)
        if within == 0:
            break
        knots = np.delete(knots, order[:within])
    return knots


@register("lyche_morken")
class LycheMorken(ToleranceMethod):
    """Lyche & Mørken's knot removal (:func:`lyche_morken`) as an optimizer
    (:class:`~metaknot.algorithms.literature.ToleranceMethod`)."""

    method = staticmethod(lyche_morken)
