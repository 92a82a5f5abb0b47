"""Run callbacks with a lifecycle: start, after each evaluated batch, end.

A callback is a :class:`Callback` (override any of :meth:`~Callback.on_start`,
:meth:`~Callback.on_batch`, :meth:`~Callback.on_end`) or a plain callable, which is called after
every batch like :meth:`Callback.on_batch`. Returning ``True`` from ``on_batch`` stops the run.
The progress bar (:class:`ProgressBar`) and the anytime trace (:class:`TraceRecorder`) are
callbacks like any other.
"""

from __future__ import annotations

from bisect import bisect_left
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from tqdm.auto import tqdm

from .budget import Progress
from .result import RunResult, Trace
from .validate import is_integer

if TYPE_CHECKING:
    from .optimizer import Optimizer
    from .problem import Problem

__all__ = [
    "Callback",
    "ProgressBar",
    "RunStart",
    "StopWhenStalled",
    "TraceRecorder",
    "as_callback",
    "checkpoint_grid",
]


@dataclass(frozen=True)
class RunStart:
    """What :meth:`Callback.on_start` sees: the run's problem, optimizer and budget."""

    problem: Problem
    optimizer: Optimizer
    budget: int


class Callback:
    """Base class of run callbacks; every hook is optional."""

    def on_start(self, run: RunStart) -> None:
        """Before the optimizer is set up."""

    def on_batch(self, progress: Progress) -> bool | None:
        """After every evaluated batch; return ``True`` to stop the run."""
        return None

    def on_end(self, result: RunResult | None) -> None:
        """After the run, also when it failed (``result`` is then the best so far, or ``None``
        if nothing was evaluated)."""


class _PlainCallable(Callback):
    def __init__(self, function: Callable[[Progress], bool | None]) -> None:
        self.function = function

    def on_batch(self, progress: Progress) -> bool | None:
        return self.function(progress)


def as_callback(obj: Callback | Callable[[Progress], bool | None]) -> Callback:
    """``obj`` itself if it is a :class:`Callback`, else a callback calling it after every
    batch."""
    if isinstance(obj, Callback):
        return obj
    if not callable(obj):
        raise TypeError(f"a callback must be a Callback or a callable; got {obj!r}")
    return _PlainCallable(obj)


class ProgressBar(Callback):
    """A tqdm progress bar over the evaluation budget, showing the best value so far.

    Parameters
    ----------
    description
        Label of the bar; defaults to ``"<optimizer> on <problem>"``.
    disable
        ``None`` (default) hides the bar when the output is not a terminal.
    """

    def __init__(self, description: str = "", disable: bool | None = None) -> None:
        self.description = description
        self.disable = disable
        self._bar: Any = None

    def on_start(self, run: RunStart) -> None:
        self.close()
        label = self.description or f"{run.optimizer.name} on {run.problem.name}"
        self._bar = tqdm(total=run.budget, desc=label, unit="eval", leave=False,
                         disable=self.disable)

    def on_batch(self, progress: Progress) -> None:
        if self._bar is None:  # used without on_start (directly on an Evaluator)
            self._bar = tqdm(total=progress.budget, desc=self.description, unit="eval",
                             leave=False, disable=self.disable)
        self._bar.update(progress.n_evaluations - self._bar.n)
        self._bar.set_postfix(best=f"{progress.best_f:.6g}", refresh=False)

    def on_end(self, result: RunResult | None) -> None:
        self.close()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def checkpoint_grid(budget: int, per_decade: int = 10) -> np.ndarray:
    """Log-spaced evaluation counts ``round(10 ** (i / per_decade))`` up to ``budget``, plus
    ``budget``.

    The grid does not depend on the budget below it, so runs of different budgets share their
    checkpoints and fixed-budget or fixed-target views need no interpolation.
    """
    if budget < 1:
        return np.empty(0, dtype=np.int64)
    top = int(np.ceil(np.log10(budget) * per_decade)) + 1
    grid = np.unique(np.round(10.0 ** (np.arange(top) / per_decade)).astype(np.int64))
    return np.union1d(grid[grid <= budget], [budget])


class TraceRecorder(Callback):
    """Record the best-so-far trace with the incumbent's metrics (see :class:`Trace`).

    Parameters
    ----------
    per_decade
        Checkpoints per decade of evaluations (default 10).
    """

    def __init__(self, per_decade: int = 10) -> None:
        if not is_integer(per_decade) or per_decade < 1:
            raise ValueError(f"per_decade must be a positive integer; got {per_decade!r}")
        self.per_decade = per_decade
        self._grid: np.ndarray | None = None
        self._next_checkpoint: float = 0  # every batch is recorded, until on_start says when
        self._reset()

    def _reset(self) -> None:
        self._evals: list[np.ndarray] = []
        self._best: list[np.ndarray] = []
        self._improved: list[np.ndarray] = []
        self._metrics: dict[str, list[np.ndarray]] = {}
        self._best_f = np.inf
        self._incumbent: dict[str, float] = {}
        self._n = 0

    def on_start(self, run: RunStart) -> None:
        self._reset()
        self._set_grid(run.budget)

    def _set_grid(self, budget: int) -> None:
        self._grid = checkpoint_grid(budget, self.per_decade)
        self._grid_list = self._grid.tolist()
        self._next_checkpoint = self._grid_list[0] if self._grid_list else np.inf

    @property
    def next_checkpoint(self) -> float:
        """The first checkpoint after the batches recorded so far (``inf`` after the last)."""
        return self._next_checkpoint

    def on_batch(self, progress: Progress) -> None:
        if self._grid is None:  # used without on_start (directly on an Evaluator)
            self._set_grid(progress.budget)
        self.record(progress.n_evaluations, progress.batch_f, progress.batch_metrics)

    def record(self, n: int, batch_f: np.ndarray, batch_metrics: Mapping[str, np.ndarray]
               ) -> None:
        """Record the rows of a batch ending at evaluation ``n``: its values ``batch_f`` and
        metrics. A batch that neither improves the best value nor reaches
        :attr:`next_checkpoint` adds no row, so a caller may leave it out at the cost of two
        comparisons (an :class:`~metaknot.Evaluator` given the recorder as its ``trace``
        does: the only quick test, most batches; called back after every batch, the
        recorder finds it here)."""
        grid = self._grid
        if grid is None:
            raise RuntimeError("a TraceRecorder records after its on_start (which sets its "
                               "checkpoints from the budget)")
        F = np.asarray(batch_f, dtype=np.float64)
        first = n - F.size  # evaluations before this batch
        if F.size == 0:
            return
        checkpoint = bisect_left(self._grid_list, n + 1)  # the next one after this batch
        self._next_checkpoint = self._grid_list[checkpoint] \
            if checkpoint < len(self._grid_list) else np.inf
        if F[F.argmin()] >= self._best_f:  # no improvement: rows only if a checkpoint is in it
            checkpoint = bisect_left(self._grid_list, first + 1)  # the next one
            if checkpoint == len(self._grid_list) or self._grid_list[checkpoint] > n:
                self._n = n
                return
        running = np.minimum.accumulate(np.concatenate(([self._best_f], F)))
        improved = running[1:] < running[:-1]
        on_grid = np.zeros(F.size, dtype=bool)
        lo, hi = bisect_left(self._grid_list, first + 1), bisect_left(self._grid_list, n + 1)
        on_grid[grid[lo:hi] - first - 1] = True
        rows = np.flatnonzero(improved | on_grid)
        # index in the batch of the incumbent at each row (-1: one of an earlier batch)
        incumbent = np.maximum.accumulate(np.where(improved, np.arange(F.size), -1))[rows]
        earlier, at = incumbent < 0, np.maximum(incumbent, 0)
        for name in batch_metrics:  # first seen now: earlier rows get NaN
            if name not in self._metrics:
                self._metrics[name] = [np.full(len(r), np.nan) for r in self._evals]
        # the names recorded so far, then the new ones: a dict's fixed order (a set's would
        # change with the interpreter's string hashing, and the stored columns with it)
        for name, columns in self._metrics.items():
            values = batch_metrics.get(name)
            column = np.full(rows.size, np.nan) if values is None else \
                np.asarray(values, dtype=np.float64)[at]
            column[earlier] = self._incumbent.get(name, np.nan)
            columns.append(column)
            if incumbent[-1] >= 0:
                self._incumbent[name] = float(column[-1])
        self._evals.append(first + 1 + rows)
        self._best.append(running[1:][rows])
        self._improved.append(improved[rows])
        self._best_f = float(running[-1])
        self._n = n

    def trace(self, n_evaluations: int | None = None) -> Trace:
        """The trace so far; the last evaluation is always a checkpoint row.

        ``n_evaluations``: the run's evaluations, when more than the batches this recorder
        saw (an evaluator feeds it only the batches that add rows)."""
        if n_evaluations is not None and n_evaluations > self._n:
            self._n = n_evaluations
        evals = np.concatenate([*self._evals, np.empty(0, dtype=np.int64)]).astype(np.int64)
        best = np.concatenate([*self._best, np.empty(0)])
        improved = np.concatenate([*self._improved, np.empty(0, dtype=bool)])
        metrics = {k: np.concatenate([*v, np.empty(0)]) for k, v in self._metrics.items()}
        checkpoint = np.isin(evals, self._grid if self._grid is not None else [])
        if self._n and (evals.size == 0 or evals[-1] != self._n):
            evals = np.append(evals, self._n)
            best = np.append(best, self._best_f)
            improved = np.append(improved, False)
            metrics = {k: np.append(v, self._incumbent.get(k, np.nan))
                       for k, v in metrics.items()}
            checkpoint = np.append(checkpoint, True)
        elif self._n:
            checkpoint[-1] = True
        return Trace(evals, best, metrics, improved, checkpoint)


class StopWhenStalled(Callback):
    """Stop a run whose best value has not improved over the last ``evaluations``
    evaluations.

    Parameters
    ----------
    evaluations
        Evaluations without an improvement of the best value that end the run (>= 1).
    """

    def __init__(self, evaluations: int) -> None:
        if not is_integer(evaluations) or evaluations < 1:
            raise ValueError(f"evaluations must be a whole number >= 1; got {evaluations!r}")
        self.evaluations = int(evaluations)
        self._best = float("inf")
        self._since = 0

    def on_start(self, run: RunStart) -> None:
        self._best, self._since = float("inf"), 0

    def on_batch(self, progress: Progress) -> bool:
        if progress.best_f < self._best:
            self._best, self._since = progress.best_f, progress.n_evaluations
        return progress.n_evaluations - self._since >= self.evaluations
