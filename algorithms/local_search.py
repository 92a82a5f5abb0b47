"""Greedy knot insertion, removal and shifts from the averaging knots (``local_search``).

The simple local method any population method must beat at equal budget:

1. **Start** from the averaging knots (NURBS Book eqs. 9.68-9.69): on a mask, scanned over
   the knot count K as the ``averaging`` baseline does (the best K under the problem's
   objective); on ordered indices, at the problem's K.
2. **Improve** step by step. The neighbours of the incumbent: every knot removed, a knot
   inserted at the middle data point of every knot span (masks only; indices keep K), and every
   knot shifted by ``±1..max_step`` data points (onto free points); on a mask of
   multiplicities (``KnotSelection(max_multiplicity=m)``) a removal lowers a knot's
   multiplicity by one, a shift moves all its copies and a knot below ``m`` may be raised by
   one (a kink, or a corner at the degree). With ``pivot="first"`` (the
   default) they are tried in a random order, ``batch_size`` at a time, and the first one
   better than the incumbent replaces it (the evaluator counts the rows up to it:
   :meth:`~metaknot.Optimizer.acceptance`); with ``pivot="best"`` the whole neighbourhood is
   evaluated and the best neighbour replaces the incumbent if it is better. When no neighbour
   is better, the search is at a local optimum. A best-improvement step costs the whole
   neighbourhood, about ``(2 max_step + 2) K`` evaluations: from a start with many knots (a
   tolerance task on an outline with corners, where the averaging knots need 188 on digit_1)
   3,000 evaluations give a dozen steps of one knot each, where first improvement takes one
   knot in a few evaluations. From a start beyond the tolerance, first improvement takes any
   lower error (one knot shifted far from the worst point, say) and can end in a local optimum
   beyond it, where best improvement takes the largest step towards it.
3. **Iterate** (``iterated=True``, the default): from the best solution found so far, make
   ``kick`` random moves of the same kinds (drawn from the run's generator) and improve again
   from there; repeat until the budget is spent. Each kick after which the best did not improve
   makes the next one a move longer, up to one move per candidate position (a longer random
   walk reaches nothing new, and on a handful of points it would only cost time). This is an
   iterated local search (Lourenço, Martin & Stützle 2003) that always restarts from the
   best, the simplest acceptance rule.
   With ``iterated=False`` the search stops at its first local optimum (``finished``), leaving
   the rest of the budget unused, as the plain variant always did.
"""

from __future__ import annotations

import numpy as np

from metaknot.optimizer import Optimizer, check_param
from metaknot.problems import KnotSpace, is_mask
from metaknot.registry import register
from metaknot.task import ProblemView

from .baselines import AveragingKnots

__all__ = ["LocalSearch", "index_neighbours", "mask_neighbours"]


def mask_neighbours(mask: np.ndarray, max_step: int = 1, *, ordered: bool = True,
                    max_multiplicity: int = 1) -> np.ndarray:
    """Distinct masks one move from ``mask``: a knot removed, a knot inserted at the middle of a
    span (between consecutive selected points, or an end), a knot shifted to a free point.

    On a mask of multiplicities (``max_multiplicity`` above 1; an entry is the multiplicity of
    the knot at that point) a removal lowers a knot's multiplicity by one, a shift moves all its
    copies, and a knot below ``max_multiplicity`` may also be raised by one.

    No two moves give the same mask (a removal, an insertion, a raise and a shift change the
    mask differently; shifts differ in the knot moved or its target). ``ordered``: sorted as
    rows (the order best improvement breaks ties in); else removals, insertions, shifts,
    raises."""
    mask = np.asarray(mask, dtype=np.int64)
    n = mask.size
    on = np.flatnonzero(mask)
    bounds = np.concatenate(([-1], on, [n]))
    left, right = bounds[:-1], bounds[1:]
    inserted = ((left + right) // 2)[right - left >= 2]
    steps = np.arange(1, max_step + 1)
    source = np.repeat(on, 2 * max_step)
    target = (on[:, None] + np.concatenate((-steps, steps))[None, :]).ravel()
    free = (target >= 0) & (target < n)
    free[free] = mask[target[free]] == 0
    source, target = source[free], target[free]
    raised = on[mask[on] < max_multiplicity]
    count = on.size + inserted.size + source.size + raised.size
    if count == 0:
        return np.empty((0, n), dtype=np.int64)
    moves = np.repeat(mask[None, :], count, axis=0)
    rows = np.arange(count)
    moves[rows[: on.size], on] -= 1  # removals
    moves[rows[on.size: on.size + inserted.size], inserted] = 1  # insertions
    shifts = rows[on.size + inserted.size: count - raised.size]
    moves[shifts, target] = mask[source]
    moves[shifts, source] = 0
    moves[rows[count - raised.size:], raised] += 1  # raises
    return np.unique(moves, axis=0) if ordered else moves


def index_neighbours(x: np.ndarray, lower: int, upper: int, max_step: int = 1,
                     max_multiplicity: int = 1) -> np.ndarray:
    """Sorted index sets one shift from ``x``: a knot moved by ``±1..max_step`` to an index
    within ``lower..upper`` that holds fewer than ``max_multiplicity`` knots (a free one for
    distinct knots; else onto a knot, raising its multiplicity)."""
    x = np.asarray(x, dtype=np.int64)
    steps = np.arange(1, max_step + 1)
    source = np.repeat(np.arange(x.size), 2 * max_step)
    target = (x[:, None] + np.concatenate((-steps, steps))[None, :]).ravel()
    inside = (target >= lower) & (target <= upper)
    source, target = source[inside], target[inside]
    held = np.bincount(x - lower, minlength=upper - lower + 1)  # knots at each index
    free = held[target - lower] < max_multiplicity
    if not free.any():
        return np.empty((0, x.size), dtype=np.int64)
    moves = np.repeat(x[None, :], int(free.sum()), axis=0)
    moves[np.arange(len(moves)), source[free]] = target[free]
    moves.sort(axis=1)
    moves = moves[np.lexsort(moves.T[::-1])]  # as rows, the order np.unique gives them
    repeated = np.zeros(len(moves), dtype=bool)  # a copy of a multiple knot moved like another
    repeated[1:] = (moves[1:] == moves[:-1]).all(axis=1)
    return moves[~repeated]


@register("local_search")
class LocalSearch(Optimizer):
    """Best-improvement local search from the averaging knots, iterated from the best solution
    by random kicks until the budget is spent (see the module notes).

    Parameters
    ----------
    max_step
        Largest shift of a knot, in data points (>= 1).
    batch_size
        Candidates per batch of the start's scan over K (masks).
    iterated
        Kick the best solution and search again at every local optimum (default); False
        stops at the first local optimum.
    kick
        Random moves of a kick (>= 1).
    pivot
        ``"first"``: neighbours in a random order, ``batch_size`` at a time, the first better
        one taken; ``"best"``: the whole neighbourhood, the best one taken.
    """

    encodings = ("binary", "integer")

    def __init__(self, max_step: int = 2, batch_size: int = 64, iterated: bool = True,
                 kick: int = 3, pivot: str = "first") -> None:
        self.max_step = check_param("max_step", max_step, low=1, integer=True)
        self.batch_size = check_param("batch_size", batch_size, low=1, integer=True)
        if not isinstance(iterated, bool | np.bool_):
            raise ValueError(f"iterated must be true or false; got {iterated!r}")
        self.iterated = bool(iterated)
        self.kick = check_param("kick", kick, low=1, integer=True)
        if pivot not in ("first", "best"):
            raise ValueError(f"pivot must be 'first' or 'best'; got {pivot!r}")
        self.pivot = pivot

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        super().setup(problem, rng)
        if not isinstance(problem, KnotSpace):
            raise ValueError(f"optimizer {self.name!r} needs a knot problem; got {problem.name!r}")
        self._mask = is_mask(problem)
        self._start = AveragingKnots(batch_size=self.batch_size)
        self._start.setup(problem, rng)
        self.incumbent: np.ndarray | None = None
        self.incumbent_f = np.inf
        self.best_x: np.ndarray | None = None
        self.best_f = np.inf
        self._scanning = True
        self._kicked = False  # the last batch was a kick: its candidate becomes the incumbent
        self._stuck = False
        self.steps = 0
        self.kicks = 0
        self._failed_kicks = 0  # kicks since the best last improved: each makes the next longer
        self._best_at_kick = np.inf
        self._cannot_kick = False
        self._untried: np.ndarray | None = None  # first improvement: neighbours left to try
        self._asked_neighbours = 0  # rows of the last ask that are first-improvement tries

    def _neighbours(self, x: np.ndarray) -> np.ndarray:
        encoding = self.problem.encoding
        if self._mask:  # first improvement shuffles them: no order needed
            return mask_neighbours(x, self.max_step, ordered=self.pivot == "best",
                                   max_multiplicity=int(encoding.upper.max()))
        return index_neighbours(x, int(encoding.lower.min()), int(encoding.upper.max()),
                                self.max_step, int(getattr(self.problem, "max_multiplicity", 1)))

    def _kicked_best(self) -> np.ndarray | None:
        """The best solution after ``kick`` random moves (None if it has no neighbour)."""
        x = self.best_x
        assert x is not None  # asked for after a best was found
        encoding = self.problem.encoding
        positions = encoding.n_var if self._mask else \
            int(encoding.upper.max() - encoding.lower.min()) + 1
        for _ in range(min(self.kick + self._failed_kicks, max(self.kick, positions))):
            moves = self._neighbours(x)
            if len(moves) == 0:
                return None
            x = moves[self.rng.integers(len(moves))]
        return x[None, :]

    def ask(self) -> np.ndarray:
        """The start's scan, then the incumbent's neighbours; at a local optimum, a kick of the
        best solution (iterated) or nothing (plain)."""
        self._asked_neighbours = 0
        if self._scanning:
            batch = self._start.ask()
            if len(batch):
                return batch
            self._scanning = False
        empty = np.empty((0, self.problem.encoding.n_var), dtype=np.int64)
        if self.incumbent is None or not np.isfinite(self.incumbent_f):
            if self._stuck is False and self.kicks:  # a kick landed on an infeasible candidate
                self._failed_kicks += 1
            self._stuck = True  # nothing to improve here: kick the best again, if there is one
            if not (self.iterated and self.best_x is not None and np.isfinite(self.best_f)):
                return empty
        if self._stuck and self.iterated:
            kicked = self._kicked_best()
            if kicked is None:
                self._cannot_kick = True  # the best has no neighbour: nothing left to try
            else:
                self._stuck, self._kicked = False, True
                self.kicks += 1
                self._best_at_kick = self.best_f
                return kicked
        if self._stuck:
            return empty
        assert self.incumbent is not None  # not stuck: a feasible incumbent (checks above)
        if self.pivot == "first" and self._untried is not None and len(self._untried):
            moves, self._untried = self._untried[: self.batch_size], \
                self._untried[self.batch_size:]
            self._asked_neighbours = len(moves)
            return moves
        moves = self._neighbours(self.incumbent)
        if len(moves) == 0:
            self._stuck = True
            return self.ask() if self.iterated and self.best_x is not None else empty
        if self.pivot == "first":
            self._untried = moves[self.rng.permutation(len(moves))]
            return self.ask()
        return moves

    def acceptance(self) -> np.ndarray | None:
        """First improvement: a neighbour better than the incumbent is taken (the rows after
        it are not counted)."""
        if not self._asked_neighbours:
            return None
        return np.full(self._asked_neighbours, np.nextafter(self.incumbent_f, -np.inf))

    def move_origin(self) -> np.ndarray | None:
        """The incumbent, once the start's scan is over: every neighbour is one move from it
        (delta evaluation)."""
        return None if self._scanning else self.incumbent

    def tell(self, X: np.ndarray, F: np.ndarray) -> None:
        best = int(np.argmin(F))
        if self._kicked:  # search on from the kicked solution, whatever its value
            self._kicked = False
            self._untried = None
            self.incumbent, self.incumbent_f = np.array(X[best], copy=True), float(F[best])
        elif F[best] < self.incumbent_f:
            self._untried = None
            self.incumbent, self.incumbent_f = np.array(X[best], copy=True), float(F[best])
            if not self._scanning:
                self.steps += 1
        elif self._untried is not None and len(self._untried):
            pass  # first improvement: more neighbours to try
        elif not self._scanning:
            self._untried = None
            self._stuck = True  # no neighbour is better: a local optimum
            if self.kicks:
                improved = self.incumbent_f < self._best_at_kick
                self._failed_kicks = 0 if improved else self._failed_kicks + 1
        if self.incumbent is not None and self.incumbent_f < self.best_f:
            self.best_x, self.best_f = self.incumbent.copy(), self.incumbent_f

    def finished(self) -> bool:
        return self._stuck and not (self.iterated and self.best_x is not None
                                    and np.isfinite(self.best_f) and not self._cannot_kick)
