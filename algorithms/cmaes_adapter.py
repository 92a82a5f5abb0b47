"""CMA-ES on free knots (``cmaes``), through the ``cmaes`` package (an optional dependency:
``pip install metaknot[adapters]``).

CMA-ES searches the unit box of a :class:`~metaknot.algorithms.knot_map.KnotMap` (span weights
centred on the averaging knots, every span at least half the widest data spacing), starting at
its centre, the averaging knots. A generation is one evaluated batch. Infeasible fits reach
CMA-ES as a finite penalty (worse than every finite value seen). When CMA-ES stops (its step size
has collapsed) it restarts from the best point with a new seed drawn from the run's generator,
until the budget is spent. The last generation, cut short by the budget, is not told.
"""

from __future__ import annotations

import numpy as np

from metaknot.optimizer import Optimizer, check_param
from metaknot.problems import FreeKnotSpace
from metaknot.registry import register
from metaknot.task import ProblemView

from ._adapters import FinitePenalty, optional_import, refuse_variable_count
from .knot_map import KnotMap

__all__ = ["CMAESKnots"]


@register("cmaes")
class CMAESKnots(Optimizer):
    """CMA-ES (the ``cmaes`` package) on the K knot positions of a ``FreeKnots`` problem.

    Parameters
    ----------
    sigma
        Initial step size in the unit box (> 0).
    population
        Candidates per generation; ``None``: CMA-ES's default ``4 + 3 ln K``.
    span_range, data_gap
        The box map's settings (:class:`~metaknot.algorithms.knot_map.KnotMap`).
    """

    encodings = ("continuous",)

    def __init__(self, sigma: float = 0.15, population: int | None = None,
                 span_range: float = 4.0, data_gap: float = 0.5) -> None:
        self.sigma = check_param("sigma", sigma, low=0, low_open=True)
        self.population = None if population is None else \
            check_param("population", population, low=2, integer=True)
        self.span_range = check_param("span_range", span_range, low=1, low_open=True)
        self.data_gap = check_param("data_gap", data_gap, low=0)

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        if not isinstance(problem, FreeKnotSpace):
            raise ValueError(f"optimizer 'cmaes' needs a FreeKnots problem; got {problem.name!r}")
        refuse_variable_count(problem, "cmaes")
        optional_import("cmaes", "cmaes")
        super().setup(problem, rng)
        self.box = KnotMap.of(problem, data_gap=self.data_gap, span_range=self.span_range)
        self.best_y = np.full(problem.n_knots, 0.5)
        self.best_f = np.inf
        self.penalty = FinitePenalty()
        self._start(self.best_y)

    def _start(self, mean: np.ndarray) -> None:
        cmaes = optional_import("cmaes", "cmaes")
        n = mean.size
        self.es = cmaes.CMA(mean=np.clip(mean, 0.0, 1.0), sigma=self.sigma,
                            bounds=np.tile([0.0, 1.0], (n, 1)),
                            seed=int(self.rng.integers(2**31)),
                            population_size=self.population)
        self._asked: np.ndarray | None = None

    def ask(self) -> np.ndarray:
        """One generation, as knot vectors."""
        if self.es.should_stop():
            self._start(self.best_y)
        self._asked = np.array([self.es.ask() for _ in range(self.es.population_size)])
        return np.array([self.box.knots(y) for y in self._asked])

    def tell(self, X: np.ndarray, F: np.ndarray) -> None:
        F = np.asarray(F, dtype=np.float64)
        if self._asked is None or len(F) < len(self._asked):
            return  # the budget cut the generation short: the run ends here
        values = self.penalty(F)
        best = int(np.argmin(F))
        if F[best] < self.best_f:
            self.best_f, self.best_y = float(F[best]), self._asked[best].copy()
        self.es.tell(list(zip(self._asked, values, strict=True)))
        self._asked = None
