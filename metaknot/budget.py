"""The evaluation budget: the only path from an optimizer to the problem's objective.

An optimizer never calls ``problem.evaluate`` itself (it is set up on a :class:`~metaknot.Task`,
which cannot evaluate); it calls an :class:`Evaluator`, which truncates a batch to what is left of
the budget, keeps the best candidate, runs the callbacks and raises :class:`BudgetExhausted` once
nothing is left. So an optimizer cannot use more evaluations than it was given, whatever it does.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Sequence

import numpy as np

from .callbacks import Callback, Progress, as_callback
from .front import ParetoArchive
from .problem import Problem
from .task import Task

__all__ = ["BudgetExhausted", "Evaluator", "Progress"]


class BudgetExhausted(Exception):
    """Raised when an optimizer asks for an evaluation after the budget is spent (or a callback
    asked to stop)."""


def check_budget(budget: object) -> int:
    """``budget`` as an int, or a ``ValueError`` unless it is a positive integer."""
    if isinstance(budget, bool) or not isinstance(budget, int | np.integer) or budget < 1:
        raise ValueError(f"budget must be a positive integer number of evaluations; "
                         f"got {budget!r}")
    return int(budget)


class Evaluator:
    """Evaluate batches of candidates under a hard cap on the number of evaluations.

    Parameters
    ----------
    problem
        The problem whose objective is called.
    budget
        Maximum number of candidate evaluations (>= 1).
    callbacks
        :class:`~metaknot.callbacks.Callback` objects or plain callables; their ``on_batch`` is
        called with a :class:`Progress` after every batch, and returning ``True`` stops the run
        (the next request raises :class:`BudgetExhausted`).

    Attributes
    ----------
    task
        The optimizer's view of the problem (no evaluation), bound to this budget.
    best_x, best_f
        Best candidate so far and its value (``None`` and ``inf`` at first). With two
        objectives, ``best_f`` is the hypervolume gap of the front and ``best_x`` the front's
        knee (its member closest to the ideal point).
    front
        With two objectives, the :class:`~metaknot.front.ParetoArchive` of the non-dominated
        candidates; else ``None``.
    external_fits
        Fits the optimizer reported making on its own (:meth:`Task.count_fits`).
    delta_evaluations
        Evaluations the problem decided by exact delta evaluation (batches passed with
        ``near``; see :meth:`__call__`).
    """

    def __init__(self, problem: Problem, budget: int,
                 callbacks: Sequence[Callback | Callable[[Progress], bool | None]] = ()):
        self.problem = problem
        self.budget = check_budget(budget)
        self.callbacks = [as_callback(c) for c in callbacks]
        self.n_evaluations = 0
        self.best_x: np.ndarray | None = None
        self.best_f = np.inf
        self.external_fits = 0
        self.delta_evaluations = 0
        self.stop_requested = False
        n_objectives = getattr(problem, "n_objectives", 1)
        if n_objectives not in (1, 2):
            raise ValueError(f"problem {problem.name!r} has {n_objectives} objectives; metaknot "
                             "handles one, or two (a Pareto front)")
        self.front = ParetoArchive(*reversed(problem.hypervolume_box)) \
            if n_objectives == 2 else None
        self.task = Task(problem, self)
        self._start = time.perf_counter()

    @property
    def remaining(self) -> int:
        return self.budget - self.n_evaluations

    @property
    def done(self) -> bool:
        """True once the budget is spent or a callback asked to stop."""
        return self.remaining <= 0 or self.stop_requested

    def __call__(self, X: np.ndarray, near: np.ndarray | None = None) -> np.ndarray:
        """Evaluate ``X`` (shape ``(B, n_var)``) or the leading part that fits the budget.

        Returns the objective values of the evaluated rows: possibly fewer than ``B``. Only the
        first ``len(result)`` rows of ``X`` were evaluated. With two objectives the values have
        shape ``(len, 2)``, and callbacks see the hypervolume gap after each candidate.

        ``near`` is a candidate the rows of ``X`` were made from by local moves (the parent of
        a (1+1) EA, the incumbent of a local search). A problem with ``evaluate_near`` (the
        knot problems) then scores them by exact delta evaluation where it can: the values are
        the same, each row still counts as one evaluation.

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
        evaluate_near = getattr(self.problem, "evaluate_near", None)
        if near is not None and evaluate_near is not None:
            F, metrics, n_delta = evaluate_near(X, np.asarray(near))
            self.delta_evaluations += int(n_delta)
        else:
            F, metrics = self.problem.evaluate_with_metrics(X)
        F = np.asarray(F, dtype=np.float64)
        expected = (X.shape[0],) if self.front is None else (X.shape[0], 2)
        if F.shape != expected:
            raise ValueError(
                f"{type(self.problem).__name__}.evaluate returned shape {F.shape}; "
                f"expected {expected}"
            )
        if np.isnan(F).any():
            warnings.warn(
                f"{type(self.problem).__name__}.evaluate returned NaN; counted as +inf",
                RuntimeWarning, stacklevel=2,
            )
            F = np.where(np.isnan(F), np.inf, F)
        self.n_evaluations += len(F)
        scalar = F if self.front is None else self.front.add(X, F, metrics)
        if self.front is not None and not len(self.front):
            scalar = np.full(len(F), np.inf)  # nothing feasible yet: no front, no incumbent
        best = int(np.argmin(scalar))
        if scalar[best] < self.best_f:
            self.best_f = float(scalar[best])
            self.best_x = X[best].copy() if self.front is None else \
                self.front.X[self.front.knee()].copy()
        progress = Progress(self.n_evaluations, self.budget, self.best_f, scalar,
                            time.perf_counter() - self._start, metrics)
        for callback in self.callbacks:
            if callback.on_batch(progress):
                self.stop_requested = True
        return F
