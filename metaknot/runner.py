"""``minimize``: run an optimizer on a problem under a budget with one seeded generator."""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from .budget import BudgetExhausted, Callback, Evaluator, Progress
from .optimizer import Optimizer
from .problem import Problem
from .registry import get_optimizer, get_problem
from .result import RunResult

__all__ = ["ProgressBar", "make_rng", "minimize"]


def make_rng(seed: int | np.random.SeedSequence | None) -> np.random.Generator:
    """The run's single random generator, built from a ``SeedSequence``."""
    if isinstance(seed, np.random.SeedSequence):
        return np.random.default_rng(seed)
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int | np.integer)
                             or seed < 0):
        raise ValueError(f"seed must be a non-negative integer or None; got {seed!r}")
    return np.random.default_rng(np.random.SeedSequence(seed))


class ProgressBar:
    """Callback showing a tqdm progress bar over the evaluation budget."""

    def __init__(self, description: str = "") -> None:
        self.description = description
        self._bar: Any = None

    def __call__(self, progress: Progress) -> None:
        if self._bar is None:
            self._bar = tqdm(total=progress.budget, desc=self.description, unit="eval",
                             leave=False)
        self._bar.update(progress.n_evaluations - self._bar.n)
        self._bar.set_postfix(best=f"{progress.best_f:.6g}", refresh=False)
        if progress.n_evaluations >= progress.budget:
            self.close()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def minimize(
    problem: Problem | str,
    optimizer: Optimizer | str,
    *,
    budget: int,
    seed: int | np.random.SeedSequence | None = None,
    callbacks: Sequence[Callback] = (),
    progress: bool = False,
    problem_kwargs: dict[str, Any] | None = None,
    optimizer_kwargs: dict[str, Any] | None = None,
) -> RunResult:
    """Minimise ``problem`` with ``optimizer`` using at most ``budget`` evaluations.

    Parameters
    ----------
    problem, optimizer
        Instances, or registry names (built with ``problem_kwargs`` / ``optimizer_kwargs``).
    budget
        Hard cap on objective evaluations, enforced by the framework.
    seed
        Seed of the run's single ``numpy.random.Generator`` (``SeedSequence``); the same seed
        gives the same result.
    callbacks
        Called after every evaluated batch with a :class:`~metaknot.budget.Progress`; returning
        ``True`` stops the run.
    progress
        Show a progress bar.

    Returns
    -------
    RunResult
        Best solution, its decoded spline, and the best-so-far trace.
    """
    if isinstance(problem, str):
        problem = get_problem(problem, **(problem_kwargs or {}))
    if isinstance(optimizer, str):
        optimizer = get_optimizer(optimizer, **(optimizer_kwargs or {}))
    bar = ProgressBar(f"{optimizer.name} on {problem.name}") if progress else None
    evaluator = Evaluator(problem, budget, [*callbacks, *([bar] if bar else [])])
    start = time.perf_counter()
    optimizer.setup(problem, make_rng(seed))
    try:
        optimizer.run(evaluator)
    except BudgetExhausted:
        pass
    except Exception as exc:
        # keep what was computed: the best so far rides on the exception
        if evaluator.n_evaluations:
            exc.partial_result = _record(problem, optimizer, seed, evaluator, start)
            exc.add_note(f"metaknot: the run stopped after {evaluator.n_evaluations} "
                         "evaluations; the exception's `partial_result` holds the best so far")
        raise
    finally:
        if bar is not None:
            bar.close()
    return _record(problem, optimizer, seed, evaluator, start)


def _record(problem: Problem, optimizer: Optimizer, seed: Any, evaluator: Evaluator,
            start: float) -> RunResult:
    evals, best = evaluator.trace()
    best_x = evaluator.best_x
    solution = problem.decode(best_x) if best_x is not None else None
    return RunResult(
        problem=problem.name,
        optimizer=optimizer.name,
        seed=None if seed is None or isinstance(seed, np.random.SeedSequence) else int(seed),
        budget=evaluator.budget,
        n_evaluations=evaluator.n_evaluations,
        best_x=best_x,
        best_f=evaluator.best_f,
        trace_evaluations=evals,
        trace_best=best,
        elapsed=time.perf_counter() - start,
        problem_info=problem.describe(),
        optimizer_params=optimizer.params(),
        solution=solution,
    )
