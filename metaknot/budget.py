"""The evaluation budget: the only path from an optimizer to the problem's objective.

An optimizer never calls ``problem.evaluate`` itself; it calls an :class:`Evaluator`, which
truncates a batch to what is left of the budget, records the best-so-far trace, runs the
callbacks and raises :class:`BudgetExhausted` once nothing is left. So an optimizer cannot use
more evaluations than it was given, whatever it does.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .problem import Problem

__all__ = ["BudgetExhausted", "Evaluator", "Progress"]


class BudgetExhausted(Exception):
    """Raised when an optimizer asks for an evaluation after the budget is spent (or a callback
    asked to stop)."""


@dataclass(frozen=True)
class Progress:
    """What callbacks see after every evaluated batch."""

    n_evaluations: int
    budget: int
    best_f: float
    batch_f: np.ndarray
    elapsed: float


Callback = Callable[[Progress], bool | None]


class Evaluator:
    """Evaluate batches of candidates under a hard cap on the number of evaluations.

    Parameters
    ----------
    problem
        The problem whose ``evaluate`` is called.
    budget
        Maximum number of candidate evaluations (>= 1).
    callbacks
        Called with a :class:`Progress` after every batch; a callback returning ``True`` stops the
        run (the next request raises :class:`BudgetExhausted`).
    """

    def __init__(self, problem: Problem, budget: int, callbacks: Sequence[Callback] = ()):
        if isinstance(budget, bool) or not isinstance(budget, int | np.integer) or budget < 1:
            raise ValueError(f"budget must be a positive integer number of evaluations; "
                             f"got {budget!r}")
        self.problem = problem
        self.budget = int(budget)
        self.callbacks = list(callbacks)
        self.n_evaluations = 0
        self.best_x: np.ndarray | None = None
        self.best_f = np.inf
        self.stop_requested = False
        self._trace_evals: list[int] = []
        self._trace_best: list[float] = []
        self._start = time.perf_counter()

    @property
    def remaining(self) -> int:
        return self.budget - self.n_evaluations

    @property
    def done(self) -> bool:
        """True once the budget is spent or a callback asked to stop."""
        return self.remaining <= 0 or self.stop_requested

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """Evaluate ``X`` (shape ``(B, n_var)``) or the leading part that fits the budget.

        Returns the objective values of the evaluated rows: possibly fewer than ``B``. Only the
        first ``len(result)`` rows of ``X`` were evaluated.

        Raises
        ------
        BudgetExhausted
            If the budget is already spent or a stop was requested.
        """
        if self.done:
            raise BudgetExhausted(f"evaluation budget of {self.budget} spent")
        X = self.problem.encoding.check(X)
        X = X[: self.remaining]
        if X.shape[0] == 0:
            return np.empty(0)
        F = np.asarray(self.problem.evaluate(X), dtype=np.float64)
        if F.shape != (X.shape[0],):
            raise ValueError(
                f"{type(self.problem).__name__}.evaluate returned shape {F.shape}; "
                f"expected ({X.shape[0]},)"
            )
        if np.isnan(F).any():
            warnings.warn(
                f"{type(self.problem).__name__}.evaluate returned NaN; counted as +inf",
                RuntimeWarning, stacklevel=2,
            )
            F = np.where(np.isnan(F), np.inf, F)
        self._record(X, F)
        progress = Progress(self.n_evaluations, self.budget, self.best_f, F,
                            time.perf_counter() - self._start)
        for callback in self.callbacks:
            if callback(progress):
                self.stop_requested = True
        return F

    def _record(self, X: np.ndarray, F: np.ndarray) -> None:
        first = self.n_evaluations
        self.n_evaluations += F.size
        running = np.minimum.accumulate(np.concatenate(([self.best_f], F)))[1:]
        improved = np.flatnonzero(running < np.concatenate(([self.best_f], running[:-1])))
        for i in improved:
            self._trace_evals.append(first + int(i) + 1)
            self._trace_best.append(float(running[i]))
        if improved.size:
            i = int(improved[-1])
            self.best_f = float(F[i])
            self.best_x = X[i].copy()

    def trace(self) -> tuple[np.ndarray, np.ndarray]:
        """Best-so-far objective against evaluations: one entry per improvement, plus the end.

        ``evals[k]`` is the evaluation count (1-based) at which ``best[k]`` was first reached;
        the last entry repeats the final best at the total number of evaluations.
        """
        evals = list(self._trace_evals)
        best = list(self._trace_best)
        if self.n_evaluations and (not evals or evals[-1] != self.n_evaluations):
            evals.append(self.n_evaluations)
            best.append(best[-1] if best else np.inf)
        return np.asarray(evals, dtype=np.int64), np.asarray(best, dtype=np.float64)
