"""A front of free knots: two starts at every count (the averaging knots and the knots of a
knot density), then each count refined locally.

For the objective ``pareto`` (control points against error) on ``FreeKnots(variable_count=
True)`` a knot count K fixes the control points (K + degree + 1), so the front is the lowest
error at each K. The run

1. scans the averaging knots (NURBS Book eqs. 9.68-9.69) at K = 1..n_knots in batches: the
   classical front, which every later point can only improve on; and, with a
   ``density_exponent`` e > 0, at each K the knots that split the parameter range into K + 1
   equal parts of the knot density ``|x^(p+1)(u)|^e`` (x: a pilot least-squares spline of
   degree p + 2 on about N / 2 averaging knots, one fit outside the budget, reported as an
   external fit; p: the degree). Asymptotically the best least-squares knots follow this
   density with e = 2 / (2p + 3) (de Boor, "Good approximation by splines with variable
   knots"); on the seed curves a slightly larger e, 0.3, starts better at most counts (on a
   closed outline the pilot is an open spline over its parameters, without the closing chord);
2. refines the counts in increasing order with a local nlopt algorithm (BOBYQA by default) on
   the K knot positions, started from that count's better scanned knots, in the ``"sorted"``
   unit box of a :class:`~metaknot.algorithms.knot_map.KnotMap` (every span at least
   ``min_gap`` of the range) with an initial step of ``initial_step`` average spans. Each count
   gets an equal share of the budget left (what a count leaves unused goes to the later ones).
   Under ``pareto`` the counts from the first one whose error is at the objective's error floor
   on are left out: more knots cannot lower an error counted as exact, so those points cannot
   reach the front;
3. spends what is left in rounds over the refined counts: a run of the local algorithm from a
   perturbed copy of each count's best knots (Gaussian, ``perturbation`` average spans).

Only the error at each K is minimised (the second objective under ``pareto``, the objective
itself on a one-objective problem); the evaluator's Pareto archive keeps the front. On a
problem that fixes K (``variable_count=False``) the run is the refinement of that one count,
with perturbed restarts, so the method also minimises ``paper``, ``bic`` or ``error_bounded``.
Every candidate goes through the evaluator: the budget holds.
"""

from __future__ import annotations

import itertools

import nlopt
import numpy as np

from metaknot.budget import BudgetExhausted, Evaluator
from metaknot.optimizer import Optimizer, check_param
from metaknot.problems import FreeKnotSpace
from metaknot.registry import register
from metaknot.task import ProblemView

from ._adapters import FinitePenalty, check_choice
from .knot_map import KnotMap
from .literature import equidistribute, knot_density
from .nlopt_knots import LOCAL_ALGORITHMS, NloptObjective, check_free_knots

__all__ = ["FreeKnotFront"]


@register("free_front")
class FreeKnotFront(Optimizer):
    """Averaging knots at every count, each count refined by a local nlopt search.

    Parameters
    ----------
    local_variant
        One of :data:`~metaknot.algorithms.nlopt_knots.LOCAL_ALGORITHMS`.
    initial_step
        Initial step of the local runs, in average knot spans (``1 / (K + 1)`` of the unit box).
    perturbation
        Standard deviation of the restart perturbation, in average knot spans (> 0).
    min_gap
        Smallest knot span as a fraction of the parameter range, in ``(0, 0.5]``; :meth:`setup`
        needs ``(n_knots + 1) * min_gap < 1``.
    density_exponent
        Exponent e of the knot density ``|x^(p+1)|^e`` of the second start at each count
        (>= 0; 0: the averaging knots only).
    batch_size
        Knot counts per batch of the scan.
    """

    encodings = ("continuous",)
    problem: FreeKnotSpace  # setup refuses any other (check_free_knots)
    multi_objective = True  # each count's error is minimised; the archive keeps the front

    def __init__(self, local_variant: str = "LN_BOBYQA", initial_step: float = 0.5,
                 perturbation: float = 0.1, min_gap: float = 1e-4,
                 density_exponent: float = 0.3, batch_size: int = 64) -> None:
        self.local_variant = check_choice("local_variant", local_variant, LOCAL_ALGORITHMS)
        self.initial_step = check_param("initial_step", initial_step, low=0, low_open=True)
        self.perturbation = check_param("perturbation", perturbation, low=0, low_open=True)
        self.min_gap = check_param("min_gap", min_gap, low=0, high=0.5, low_open=True)
        self.density_exponent = check_param("density_exponent", density_exponent, low=0)
        self.batch_size = check_param("batch_size", batch_size, low=1, integer=True)

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        check_free_knots(self.name, problem, self.min_gap)
        super().setup(problem, rng)
        problem = self.problem  # a FreeKnotSpace (check_free_knots)
        self.box = KnotMap.of(problem, kind="sorted", min_gap=self.min_gap, data_gap=0.0)
        self.pareto = getattr(problem, "n_objectives", 1) == 2
        self.variable = bool(problem.variable_count)  # check_free_knots: a FreeKnotSpace
        self.counts = list(range(1, problem.n_knots + 1)) if self.variable else \
            [problem.n_knots]
        #: per count: (lowest error or objective value seen, its knots)
        self.best: dict[int, tuple[float, np.ndarray]] = {}
        self.penalty = FinitePenalty()
        #: ``(u, F(u))``: the normalised cumulative knot density on a fine grid
        #: (:func:`~metaknot.algorithms.literature.knot_density`, one external fit)
        self._density: tuple[np.ndarray, np.ndarray] | None = None
        if self.density_exponent > 0:
            self.count_fits(1)
            self._density = knot_density(problem.params, problem.points, problem.degree,
                                         self.density_exponent)

    def density_knots(self, k: int) -> np.ndarray | None:
        """The ``k`` knots that split the knot density into equal parts (None without one)."""
        return equidistribute(self._density, k)

    # -- candidates and their scores ---------------------------------------------------------

    def candidate(self, knots: np.ndarray) -> np.ndarray:
        return self.problem.pad(knots) if self.variable else np.sort(knots)

    def score(self, F: np.ndarray) -> np.ndarray:
        """What a count minimises: the error (``pareto``'s second objective) or the value."""
        F = np.asarray(F, dtype=np.float64)
        return F[:, 1] if F.ndim == 2 else F

    def _offer(self, k: int, value: float, knots: np.ndarray) -> None:
        if k not in self.best or value < self.best[k][0]:
            self.best[k] = (float(value), np.array(knots, dtype=np.float64))

    def at_floor(self, k: int) -> bool:
        """True when count ``k`` has reached ``pareto``'s error floor (scaled error 0)."""
        return self.pareto and k in self.best and self.best[k][0] <= 0.0

    # -- the run -----------------------------------------------------------------------------

    def run(self, evaluator: Evaluator) -> None:
        try:
            self._scan(evaluator)
            # the counts to refine: all scanned, up to the first at the error floor (excluded)
            active = list(itertools.takewhile(lambda k: not self.at_floor(k), sorted(self.best)))
            for i, k in enumerate(active):
                if any(self.at_floor(j) for j in active[:i]):
                    active = active[:i]
                    break
                share = max(1, evaluator.remaining // (len(active) - i))
                self._local(evaluator, k, share, self.box.unit(self.best[k][1]))
            active = active or sorted(self.best)[:1]
            while True:  # the rest: perturbed restarts, count after count (ends by budget)
                for k in active:
                    n_left = max(1, evaluator.remaining // max(len(active), 1))
                    start = self.box.unit(self.best[k][1]) + self.rng.normal(
                        0.0, self.perturbation / (k + 1), k)
                    self._local(evaluator, k, max(2 * k + 2, n_left // 4),
                                np.clip(start, 0.0, 1.0))
        except BudgetExhausted:
            pass

    def _scan(self, evaluator: Evaluator) -> None:
        p = self.problem
        for first in range(0, len(self.counts), self.batch_size):
            chunk = self.counts[first : first + self.batch_size]
            starts = [(k, p.start_knots(k)) for k in chunk]
            starts += [(k, t) for k in chunk if (t := self.density_knots(k)) is not None]
            F = evaluator(np.array([self.candidate(t) for _, t in starts]))
            for (k, t), v in zip(starts, self.score(F), strict=False):
                self._offer(k, v, t)
            if len(F) < len(starts):
                raise BudgetExhausted

    def _local(self, evaluator: Evaluator, k: int, budget: int, y0: np.ndarray) -> None:
        """One local run on ``k`` knots from the unit-box point ``y0``, at most ``budget``
        evaluations; exceptions of the objective (the budget's) are raised after nlopt
        returns (:class:`~metaknot.algorithms.nlopt_knots.NloptObjective`)."""

        def evaluate(y: np.ndarray) -> float:
            knots = self.box.knots(y)
            value = float(self.score(evaluator(self.candidate(knots)[None, :]))[0])
            self._offer(k, value, knots)
            return value

        opt = nlopt.opt(getattr(nlopt, self.local_variant), k)
        objective = NloptObjective(evaluate, self.penalty)
        nlopt.srand(int(self.rng.integers(2**31)))
        opt.set_min_objective(objective)
        opt.set_lower_bounds(np.zeros(k))
        opt.set_upper_bounds(np.ones(k))
        opt.set_initial_step(min(self.initial_step / (k + 1), 0.5))
        opt.set_xtol_abs(1e-9)
        opt.set_maxeval(int(max(1, budget)))
        objective.optimize(opt, np.clip(np.asarray(y0, dtype=np.float64), 0.0, 1.0))
