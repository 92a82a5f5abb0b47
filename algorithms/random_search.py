"""Random search: independent random candidates drawn from the problem's sampler."""

from __future__ import annotations

import numpy as np

from metaknot.optimizer import Optimizer, check_param
from metaknot.registry import register


@register("random_search")
class RandomSearch(Optimizer):
    """Draw ``batch_size`` random candidates per step (``problem.sample``); keep the best.

    The simplest baseline, and the reference any metaheuristic has to beat at equal budget.
    It ignores the values, so it also builds a front on two-objective problems.
    """

    multi_objective = True

    def __init__(self, batch_size: int = 100) -> None:
        self.batch_size = check_param("batch_size", batch_size, low=1, integer=True)

    def ask(self) -> np.ndarray:
        return self.problem.sample(self.rng, self.batch_size)

    def tell(self, X: np.ndarray, F: np.ndarray) -> None:
        pass  # the evaluator keeps the best-so-far
