"""The unit box ``[0, 1]^K`` as ordered knot vectors: how box-constrained continuous optimizers
(nlopt, CMA-ES, nevergrad) search free knot positions.

On the parameter range ``[a, b]`` (the problem's knot range: an open curve's first and last
data parameters; a closed outline's 0 and 1, the interval that closes it included) every one
of the K + 1 spans is ``gap`` plus a share of the free length ``(b - a) - (K + 1) gap``;
``gap`` is ``data_gap`` times the widest spacing of the data parameters, or ``min_gap`` of the
range if larger, at most half the room K knots leave.

* ``kind="spans"``: the shares are a softmax of log-weights centred on the averaging knots (NURBS
  Book eqs. 9.68-9.69): span ``j < K`` has log-weight ``log p_j + beta (y_j - 1/2)``, the last
  span ``log p_K``, with ``p`` the averaging knots' shares and ``beta = ln(span_range)``. The box
  centre is the averaging knots; a corner stretches or shrinks a span by ``sqrt(span_range)``
  against the others. Every box point is a sensible knot vector, which is what methods that
  sample the whole box need.
* ``kind="sorted"``: the shares are the sorted coordinates (knot ``i`` at
  ``a + (i + 1) gap + free sort(y)_i``), uniform over ordered knot vectors; natural for local
  methods that move each knot from a start.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from metaknot.bspline import averaging_knots
from metaknot.problems import KnotSpace

__all__ = ["KnotMap"]


class KnotMap:
    """Maps between the unit box and ordered knot vectors (see the module notes).

    Parameters
    ----------
    params
        The data parameters (strictly increasing).
    degree
        Spline degree (for the averaging knots of the ``"spans"`` map).
    kind
        ``"spans"`` or ``"sorted"``.
    min_gap, data_gap
        Smallest span as a fraction of the range, and as a multiple of the widest data spacing.
    span_range
        ``"spans"``: the factor (> 1) between a span's weights at the two faces of the box.
    start
        ``start(K)``: the K knots the ``"spans"`` box is centred on (default: the averaging
        knots of ``params``; :meth:`of` passes the knot problem's ``start_knots``, which on a
        closed outline go on beyond the averaging knots' range).
    end
        Where the range of knots ends (default: the last data parameter; :meth:`of` passes the
        problem's ``knot_bounds``: a closed outline's range runs on to 1, past its last data
        parameter, through the interval that closes it).
    """

    def __init__(self, params: np.ndarray, degree: int, *, kind: str = "spans",
                 min_gap: float = 1e-4, data_gap: float = 0.5,
                 span_range: float = 4.0,
                 start: Callable[[int], np.ndarray] | None = None,
                 end: float | None = None) -> None:
        if kind not in ("spans", "sorted"):
            raise ValueError(f"kind must be 'spans' or 'sorted'; got {kind!r}")
        self.params = np.asarray(params, dtype=np.float64)
        self.end = float(self.params[-1]) if end is None else float(end)
        self.degree = int(degree)
        self.kind = kind
        self.min_gap, self.data_gap, self.span_range = float(min_gap), float(data_gap), \
            float(span_range)
        self.start = start if start is not None else \
            (lambda n_knots: averaging_knots(self.params, n_knots, self.degree))
        self._priors: dict[int, np.ndarray] = {}
        self._frames: dict[int, tuple[float, float, float]] = {}

    @classmethod
    def of(cls, problem: KnotSpace, **options: Any) -> KnotMap:
        """The map of a knot problem's data parameters and degree over its knot range (its
        ``knot_bounds``), centred on its ``start_knots``."""
        return cls(problem.params, problem.degree, start=problem.start_knots,
                   end=problem.knot_bounds[1], **options)

    def gap(self, n_knots: int) -> float:
        """The smallest span for ``n_knots`` knots."""
        u = np.append(self.params, self.end)
        length = float(u[-1] - u[0])
        gap = max(self.min_gap * length, self.data_gap * float(np.diff(u).max()))
        return min(gap, 0.5 * length / (n_knots + 1))

    def _frame(self, n_knots: int) -> tuple[float, float, float]:
        """The range's start, the gap and the free length for ``n_knots`` knots (computed once
        per count: an optimizer maps one candidate after another)."""
        frame = self._frames.get(n_knots)
        if frame is None:
            a, b = float(self.params[0]), self.end
            gap = self.gap(n_knots)
            frame = self._frames[n_knots] = (a, gap, (b - a) - (n_knots + 1) * gap)
        return frame

    def _prior(self, n_knots: int) -> np.ndarray:
        """Log-shares of the free length of the averaging knots' spans."""
        if n_knots not in self._priors:
            a, gap, free = self._frame(n_knots)
            ext = np.concatenate(([a], self.start(n_knots), [self.end]))
            share = np.maximum(np.diff(ext) - gap, 1e-3 * free / (n_knots + 1))
            self._priors[n_knots] = np.log(share / share.sum())
        return self._priors[n_knots]

    def knots(self, y: np.ndarray) -> np.ndarray:
        """Knot positions of the unit-box vector ``y`` (sorted, spans >= the gap)."""
        y = np.asarray(y, dtype=np.float64)
        a, gap, free = self._frame(y.size)
        if self.kind == "sorted":
            return a + gap * np.arange(1, y.size + 1) + free * np.sort(y)
        logw = self._prior(y.size).copy()
        logw[:-1] += np.log(self.span_range) * (y - 0.5)
        share = np.exp(logw - logw.max())
        spans = gap + free * share / share.sum()
        return a + np.cumsum(spans)[:-1]

    def pull_back(self, y: np.ndarray, gradient: np.ndarray) -> np.ndarray:
        """The gradient with respect to the unit-box point ``y`` of a function of the knots
        whose gradient with respect to the knots :meth:`knots` gives is ``gradient`` (the
        ``"sorted"`` map: knot ``i`` moves with the ``i``-th smallest coordinate)."""
        if self.kind != "sorted":
            raise ValueError("gradients are pulled back through the 'sorted' map only")
        y = np.asarray(y, dtype=np.float64)
        out = np.empty(y.size)
        out[np.argsort(y, kind="stable")] = self._frame(y.size)[2] * np.asarray(gradient)
        return out

    def unit(self, knots: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`knots` for sorted knots (clipped to the unit box)."""
        knots = np.asarray(knots, dtype=np.float64)
        a, gap, free = self._frame(knots.size)
        if self.kind == "sorted":
            offsets = gap * np.arange(1, knots.size + 1)
            return np.clip((knots - a - offsets) / free, 0.0, 1.0)
        ext = np.concatenate(([a], knots, [self.end]))
        share = np.log(np.maximum(np.diff(ext) - gap, 1e-12 * free))
        prior = self._prior(knots.size)
        relative = (share[:-1] - share[-1]) - (prior[:-1] - prior[-1])
        return np.clip(0.5 + relative / np.log(self.span_range), 0.0, 1.0)
