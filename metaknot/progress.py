"""What a run reports as it goes: :class:`Progress` after every evaluated batch, and the
:class:`Trace` of best-so-far values a run ends with.

Plain data, depending on nothing else in metaknot: the evaluator makes the first, the trace
recorder (:mod:`metaknot.callbacks`) the second, the run record (:mod:`metaknot.result`) keeps it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Progress", "Trace"]


@dataclass(frozen=True)
class Progress:
    """What callbacks see after every evaluated batch.

    Attributes
    ----------
    n_evaluations
        Evaluations used so far (this batch included).
    budget
        Evaluations allowed.
    best_f
        Best objective value so far.
    batch_f
        Objective values of this batch (evaluations ``n_evaluations - len(batch_f) + 1`` to
        ``n_evaluations``); for a two-objective problem, the front's hypervolume gap after
        each candidate.
    elapsed
        Seconds since the evaluator was created.
    batch_metrics
        Per-candidate metrics of this batch that the problem provides (knot problems:
        ``rmse``, ``n_control_points`` and, when computed, ``max_deviation``).
    """

    n_evaluations: int
    budget: int
    best_f: float
    batch_f: np.ndarray
    elapsed: float
    batch_metrics: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __init__(self, n_evaluations: int, budget: int, best_f: float, batch_f: np.ndarray,
                 elapsed: float, batch_metrics: Mapping[str, np.ndarray] | None = None) -> None:
        # made after every evaluated batch: the fields are set at once (the generated
        # __init__ of a frozen dataclass sets them one by one, at twice the cost)
        self.__dict__.update(n_evaluations=n_evaluations, budget=budget, best_f=best_f,
                             batch_f=batch_f, elapsed=elapsed,
                             batch_metrics={} if batch_metrics is None else batch_metrics)


@dataclass(frozen=True, eq=False)
class Trace:
    """Best-so-far history of a run, one row per recorded evaluation count.

    A row is recorded at every improvement of the best value and at every checkpoint of
    :func:`~metaknot.callbacks.checkpoint_grid` (and at the run's last evaluation, marked as a
    checkpoint).

    Attributes
    ----------
    evaluations
        Evaluation count (1-based) of the row, increasing.
    best_f
        Best objective value after that many evaluations.
    metrics
        The incumbent's metrics after that many evaluations (``rmse``, ``n_control_points``,
        ... as the problem provides them; NaN while nothing feasible was found).
    improvement, checkpoint
        Whether the row is an improvement, a checkpoint, or both.
    """

    evaluations: np.ndarray
    best_f: np.ndarray
    metrics: dict[str, np.ndarray]
    improvement: np.ndarray
    checkpoint: np.ndarray

    def columns(self) -> dict[str, np.ndarray]:
        """The trace as named columns (for a table)."""
        return {"evaluations": self.evaluations, "best_f": self.best_f, **self.metrics,
                "improvement": self.improvement, "checkpoint": self.checkpoint}

    def __len__(self) -> int:
        return int(self.evaluations.size)


def ordered_names(recorded: Mapping[str, object], new: Mapping[str, object]) -> list[str]:
    """The metric names recorded so far, then those ``new`` adds, in a fixed order (a set's
    order would change with the interpreter's string hashing, and with it the order of stored
    columns from one process to the next)."""
    return [*recorded, *(name for name in new if name not in recorded)]
