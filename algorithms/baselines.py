"""Classical baselines: uniform, averaging (NURBS Book) and FITPACK knots.

Each baseline maps a number of interior knots K to interior knots, and those to a candidate of
the problem's encoding: ``FreeKnots`` takes the positions (NaN-padded with ``variable_count``),
``KnotIndices`` the nearest data indices (made distinct with ``Encoding.repair``),
``KnotSelection`` the mask of those data points (1 at each, on a mask of multiplicities too).
If the problem fixes K (``KnotIndices``, ``FreeKnots``), one candidate is evaluated; if it
leaves K free (``KnotSelection``, ``FreeKnots(variable_count=True)``), K = 1..K_max is scanned
in batches, in increasing order, and the evaluator keeps the best under the problem's objective
(paper, bic, error_bounded alike). A budget smaller than the scan ends it early. No randomness
is used: every seed gives the same run.
"""

from __future__ import annotations

import itertools
from abc import abstractmethod
from collections.abc import Iterator
from typing import Any, cast

import numpy as np

from metaknot.bspline import fit_spline, fitpack
from metaknot.optimizer import Optimizer, check_param
from metaknot.problem import Encoding
from metaknot.problems import FreeKnotSpace, KnotSpace, is_mask
from metaknot.registry import register
from metaknot.task import ProblemView

__all__ = ["AveragingKnots", "FitpackKnots", "UniformKnots", "knots_to_candidate", "with_count"]


def with_count(knots: np.ndarray, k: int, lower: float, upper: float) -> np.ndarray:
    """``knots`` brought to ``k`` knots, one at a time: drop the knot whose neighbours are
    closest, or split the widest knot span (ends ``lower``, ``upper``) at its midpoint."""
    t = np.sort(np.asarray(knots, dtype=np.float64))
    while t.size != k:
        ext = np.concatenate(([lower], t, [upper]))
        if t.size > k:
            t = np.delete(t, np.argmin(ext[2:] - ext[:-2]))
        else:
            i = int(np.argmax(np.diff(ext)))
            t = np.insert(t, i, 0.5 * (ext[i] + ext[i + 1]))
    return t


def knots_to_candidate(problem: KnotSpace, knots: np.ndarray) -> np.ndarray:
    """The candidate of a knot problem (or its task) for these interior knots: the positions
    (NaN-padded with ``variable_count``), or the nearest data indices (made distinct), or the
    mask of those data points (1 at each: simple knots, on a mask of multiplicities too)."""
    encoding = problem.encoding
    if encoding.kind == "continuous":
        if isinstance(problem, FreeKnotSpace) and problem.variable_count:
            return problem.pad(knots)
        return np.sort(knots)
    u = problem.params
    last = problem.last_candidate_point
    j = np.clip(np.searchsorted(u, knots), 1, u.size - 1)
    idx = np.clip(j - (knots - u[j - 1] <= u[j] - knots), 1, last)
    if not is_mask(problem):
        return encoding.repair(idx[None, :])[0]
    mask = np.zeros(encoding.n_var, dtype=np.int64)  # (of multiplicities: simple knots)
    if idx.size:
        sets = Encoding.integer(idx.size, 1, last, distinct_sorted=True)
        mask[sets.repair(idx[None, :])[0] - 1] = 1
    return mask


class _KnotCountBaseline(Optimizer):
    """K interior knots -> candidate; one K if the problem fixes it, else a scan over K.

    Parameters
    ----------
    max_knots
        Largest K scanned when the problem leaves K free (default: the most it allows).
    batch_size
        Candidates per evaluated batch.
    """

    multi_objective = True  # a scan over K builds a front under the objective pareto
    problem: KnotSpace  # setup refuses any other

    def __init__(self, max_knots: int | None = None, batch_size: int = 64) -> None:
        self.max_knots = None if max_knots is None else \
            check_param("max_knots", max_knots, low=1, integer=True)
        self.batch_size = check_param("batch_size", batch_size, low=1, integer=True)

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        super().setup(problem, rng)
        if not isinstance(problem, KnotSpace):
            raise ValueError(f"optimizer {self.name!r} needs a knot problem; got {problem.name!r}")
        # the problems of fixed K (KnotIndices, FreeKnots) and FreeKnots have n_knots
        counted = cast(Any, problem)
        kind = problem.encoding.kind
        self.free_count = is_mask(problem) or (isinstance(problem, FreeKnotSpace)
                                               and problem.variable_count)
        if self.free_count:
            # a mask's most knots: N - p - 1 on an open curve, N - 1 (interpolation) closed
            cap = counted.n_knots if kind == "continuous" else \
                problem.data.n_points - 1 if problem.closed else \
                problem.data.n_points - problem.degree - 1
            self.counts = list(range(1, min(cap, self.max_knots or cap) + 1))
        else:
            self.counts = [counted.n_knots]
        self._pending = (self.candidate(t) for t in self.knot_sets())
        self._scanned = False

    @abstractmethod
    def knot_sets(self) -> Iterator[np.ndarray]:
        """Interior knots of every candidate, in evaluation order (K from ``self.counts``)."""

    def candidate(self, knots: np.ndarray) -> np.ndarray:
        """The problem's candidate for these interior knots (see the module docstring)."""
        return knots_to_candidate(self.problem, knots)

    def ask(self) -> np.ndarray:
        """The next batch of up to ``batch_size`` candidates (no rows once the scan is done)."""
        batch = list(itertools.islice(self._pending, self.batch_size))
        self._scanned = not batch
        return np.array(batch) if batch else np.empty((0, self.problem.encoding.n_var))

    def tell(self, X: np.ndarray, F: np.ndarray) -> None:
        pass  # the evaluator keeps the best

    def finished(self) -> bool:
        return self._scanned


@register("uniform")
class UniformKnots(_KnotCountBaseline):
    """K interior knots equally spaced over the knot range: ``linspace(a, b, K + 2)[1:-1]``
    with ``(a, b)`` the problem's ``knot_bounds`` (the first and last data parameters of an
    open curve; 0 and 1 on a closed outline: K + 1 equal spans round it)."""

    def knot_sets(self) -> Iterator[np.ndarray]:
        a, b = self.problem.knot_bounds
        return (np.linspace(a, b, k + 2)[1:-1] for k in self.counts)


@register("averaging")
class AveragingKnots(_KnotCountBaseline):
    """K interior knots by averaging the data parameters (NURBS Book eqs. 9.68-9.69; beyond
    the ``N - p - 1`` knots that formula places, which only a closed outline allows, the
    curve's evenly spread breakpoints: :meth:`~metaknot.bspline.curve.Curve.start_knots`)."""

    def knot_sets(self) -> Iterator[np.ndarray]:
        return (self.problem.start_knots(k) for k in self.counts)


@register("fitpack")
class FitpackKnots(_KnotCountBaseline):
    """The knots of FITPACK's smoothing spline (``metaknot.bspline.fitpack``, ``u``: the problem's
    parameters, ``k`` = its degree), least-squares refitted by the problem.

    ``target="count"``: for each K, the smoothing factor s is searched by bisection on log s
    over ``[1e-14 fp0, fp0]`` (fp0: SSE of the polynomial fit): FITPACK's knot count falls as s
    grows, so an interval is split while the counts at its ends enclose a wanted count not yet
    met, down to a width of 1e-4 in log s. FITPACK adds knots in groups, so some counts are never
    chosen, and for small s the count is not monotone in s, so a count met only inside such a
    wiggle can be missed. A K-free scan skips the counts not found; for a fixed K not found, the
    closest counts met above and below are brought to K by :func:`with_count`, and both are
    evaluated.
    ``target="tolerance"``: one run with s = N * tolerance**2, i.e. FITPACK adds knots until its
    RMSE (sqrt(SSE / N)) is within ``tolerance``; the refit's RMSE is then no larger. Needs a
    problem that leaves K free (a count above its maximum is cut by :func:`with_count`).
    """

    def __init__(self, target: str = "count", tolerance: float | None = None,
                 max_knots: int | None = None, batch_size: int = 64) -> None:
        super().__init__(max_knots, batch_size)
        if target not in ("count", "tolerance"):
            raise ValueError(f"target must be 'count' or 'tolerance'; got {target!r}")
        if (tolerance is None) == (target == "tolerance"):
            raise ValueError("tolerance must be given exactly when target='tolerance'; "
                             f"got target={target!r}, tolerance={tolerance!r}")
        self.target = target
        self.tolerance = None if tolerance is None else \
            check_param("tolerance", tolerance, low=0, low_open=True)

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        super().setup(problem, rng)
        problem = self.problem  # a knot problem (the base's setup checks)
        if self.target == "tolerance" and not self.free_count:
            raise ValueError("target='tolerance' lets FITPACK choose the knot count, but this "
                             "problem fixes it; use target='count'")
        fp0 = fit_spline(problem.params, problem.points, [], problem.degree).sse
        self.count_fits(1)
        self._top = float(np.log(max(fp0, np.finfo(float).tiny)))
        self._counts_at = {self._top: 0}  # log s -> FITPACK's knot count (the probes so far)
        self._found: dict[int, tuple[float, np.ndarray]] = {0: (fp0, np.empty(0))}

    def _knots(self, s: float) -> np.ndarray:
        """FITPACK's interior knots at smoothing ``s`` (one FITPACK call, counted as an
        external fit: it is not an evaluation of the problem's objective)."""
        self.count_fits(1)
        return fitpack.interior_knots(self.problem.params, self.problem.points,
                                      self.problem.degree, s)

    def _probe(self, log_s: float) -> int:
        if log_s not in self._counts_at:
            knots = self._knots(float(np.exp(log_s)))
            self._found.setdefault(knots.size, (float(np.exp(log_s)), knots))
            self._counts_at[log_s] = knots.size
        return self._counts_at[log_s]

    def search(self, wanted: set[int]) -> dict[int, tuple[float, np.ndarray]]:
        """``{count: (s, interior knots)}`` for every FITPACK knot count met so far while
        searching the smoothing factor s for the counts in ``wanted`` (the first s met for each
        count; probes are kept, so searching count after count repeats no FITPACK run)."""
        stack = [(self._top + np.log(1e-14), self._top)]
        while stack:
            a, b = stack.pop()
            lo, hi = sorted((self._probe(a), self._probe(b)))
            if b - a < 1e-4 or not any(lo < w < hi and w not in self._found for w in wanted):
                continue
            stack += [(0.5 * (a + b), b), (a, 0.5 * (a + b))]
        return dict(self._found)

    def knot_sets(self) -> Iterator[np.ndarray]:
        u = self.problem.params
        if self.target == "tolerance":
            assert self.tolerance is not None  # given with target="tolerance" (__init__)
            knots = self._knots(u.size * self.tolerance**2)
            yield with_count(knots, min(knots.size, self.counts[-1]), u[0], u[-1])
            return
        if self.free_count:  # search batch by batch: a small budget needs only the first counts
            for first in range(0, len(self.counts), self.batch_size):
                chunk = self.counts[first : first + self.batch_size]
                found = self.search(set(chunk))
                yield from (found[k][1] for k in chunk if k in found)
            return
        knots_at = {c: knots for c, (_, knots) in self.search(set(self.counts)).items()}
        (k,) = self.counts
        if k in knots_at:
            yield knots_at[k]
            return
        for near in (min((c for c in knots_at if c > k), default=None),
                     max((c for c in knots_at if c < k), default=None)):
            if near is not None:
                yield with_count(knots_at[near], k, u[0], u[-1])
