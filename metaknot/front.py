"""Pareto fronts of two objectives and the hypervolume they dominate.

A problem with two objectives (``problem.n_objectives == 2``, for knot problems the objective
``pareto``: control points and error) returns a ``(B, 2)`` array per batch. The evaluator keeps
the non-dominated candidates in a :class:`ParetoArchive`; the run's scalar, the one studies and
reports compare, is the **hypervolume gap**: the part of the box between the ideal point and the
reference point that the front does not dominate (0 is a perfect front; lower is better).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["ParetoArchive", "hypervolume_2d", "nondominated_mask"]


def nondominated_mask(F: ArrayLike) -> np.ndarray:
    """True for the rows of ``F`` (shape ``(n, 2)``, minimised) that no other row dominates.

    Of rows with equal values only the first is kept; rows with a non-finite value are never
    kept.
    """
    F = np.asarray(F, dtype=np.float64)
    keep = np.isfinite(F).all(axis=1)
    order = np.lexsort((np.arange(len(F)), F[:, 1], F[:, 0]))  # by f0, then f1, then row
    best_f1 = np.inf
    for i in order:
        if keep[i]:
            if F[i, 1] < best_f1:
                best_f1 = F[i, 1]
            else:
                keep[i] = False
    return keep


def hypervolume_2d(F: ArrayLike, reference: ArrayLike) -> float:
    """Area dominated by the points ``F`` (shape ``(n, 2)``, minimised) and bounded by
    ``reference``; points not strictly better than the reference in both objectives add
    nothing. Exact (a sum of rectangles over the sorted staircase)."""
    points = np.asarray(F, dtype=np.float64).reshape(-1, 2)
    ref = np.asarray(reference, dtype=np.float64)
    points = points[(points < ref).all(axis=1)]
    if not len(points):
        return 0.0
    points = points[nondominated_mask(points)]
    points = points[np.argsort(points[:, 0])]
    widths = np.diff(np.append(points[:, 0], ref[0]))
    return float(np.sum(widths * (ref[1] - points[:, 1])))


class ParetoArchive:
    """The non-dominated candidates seen so far, with their metrics.

    Parameters
    ----------
    reference
        Reference point of the hypervolume (a point worse than every interesting one).
    ideal
        The ideal point; the hypervolume gap is measured in the box from it to ``reference``.

    Attributes
    ----------
    X, F
        Candidates of the front and their objective vectors, sorted by the first objective.
    metrics
        Per-member metrics (``rmse``, ``n_control_points``, ...), in the same order.
    hypervolume
        Area the front dominates within the reference box.
    """

    def __init__(self, reference: ArrayLike = (1.0, 1.0), ideal: ArrayLike = (0.0, 0.0)) -> None:
        self.reference = np.asarray(reference, dtype=np.float64)
        self.ideal = np.asarray(ideal, dtype=np.float64)
        if self.reference.shape != (2,) or not (self.ideal < self.reference).all():
            raise ValueError("reference and ideal must be 2-vectors with ideal < reference; got "
                             f"{self.reference.tolist()} and {self.ideal.tolist()}")
        self.box = float(np.prod(self.reference - self.ideal))
        self.X: np.ndarray | None = None
        self.F = np.empty((0, 2))
        self.metrics: dict[str, np.ndarray] = {}
        self.hypervolume = 0.0

    @property
    def gap(self) -> float:
        """The share of the reference box the front does not dominate, in ``[0, 1]``."""
        return 1.0 - self.hypervolume / self.box

    def __len__(self) -> int:
        return len(self.F)

    def add(self, X: np.ndarray, F: ArrayLike,
            metrics: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
        """Offer a batch to the front, in order.

        Returns
        -------
        numpy.ndarray
            The hypervolume gap after each candidate of the batch (non-increasing).
        """
        F = np.asarray(F, dtype=np.float64)
        metrics = metrics or {}
        gaps = np.full(len(F), self.gap)
        inside = (F < self.reference).all(axis=1)
        if len(self.F):  # candidates the front already weakly dominates change nothing
            covered = ((self.F[None, :, 0] <= F[:, None, 0])
                       & (self.F[None, :, 1] <= F[:, None, 1])).any(axis=1)
            inside &= ~covered
        for i in np.flatnonzero(inside):
            if self._insert(X[i], F[i], {k: v[i] for k, v in metrics.items()}):
                gaps[i:] = self.gap
        return gaps

    def _insert(self, x: np.ndarray, f: np.ndarray, row: Mapping[str, float]) -> bool:
        F = self.F
        if ((F[:, 0] <= f[0]) & (F[:, 1] <= f[1])).any():
            return False
        keep = ~((F[:, 0] >= f[0]) & (F[:, 1] >= f[1]))
        at = int(np.searchsorted(F[keep, 0], f[0]))
        self.F = np.insert(F[keep], at, f, axis=0)
        x = np.asarray(x)[None, :]
        self.X = x.copy() if self.X is None else np.insert(self.X[keep], at, x, axis=0)
        # the names so far, then the new ones: a dict's fixed order (a set's would change with
        # the interpreter's string hashing, and the stored columns with it)
        self.metrics = {
            name: np.insert(self.metrics.get(name, np.full(keep.size, np.nan))[keep], at,
                            row.get(name, np.nan))
            for name in {**self.metrics, **row}
        }
        self.hypervolume = hypervolume_2d(self.F, self.reference)
        return True

    def knee(self) -> int:
        """Index of the member closest to the ideal point (objectives scaled to the box)."""
        if not len(self.F):
            raise ValueError("the front is empty")
        scaled = (self.F - self.ideal) / (self.reference - self.ideal)
        return int(np.argmin(np.hypot(scaled[:, 0], scaled[:, 1])))

    def table(self) -> dict[str, list[float]]:
        """The front as columns: ``objective_0``, ``objective_1`` and every metric."""
        return {"objective_0": self.F[:, 0].tolist(), "objective_1": self.F[:, 1].tolist(),
                **{k: v.tolist() for k, v in sorted(self.metrics.items())}}
