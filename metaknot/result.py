"""The record of one optimisation run."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["RunResult"]


@dataclass(frozen=True, eq=False)
class RunResult:
    """Everything a run produced, in plain values (ready to store).

    Attributes
    ----------
    problem, optimizer
        Names; ``problem_info`` and ``optimizer_params`` hold their settings.
    seed
        The seed the run's random generator was made from.
    budget, n_evaluations
        Evaluations allowed and used.
    best_x, best_f
        Best candidate and its objective value (``best_x`` is ``None`` if nothing feasible was
        found).
    trace_evaluations, trace_best
        Best-so-far objective against evaluations (one entry per improvement, plus the end).
    elapsed
        Wall-clock seconds.
    solution
        ``problem.decode(best_x)`` (for knot problems: the fitted spline and its metrics).
    """

    problem: str
    optimizer: str
    seed: int | None
    budget: int
    n_evaluations: int
    best_x: np.ndarray | None
    best_f: float
    trace_evaluations: np.ndarray
    trace_best: np.ndarray
    elapsed: float
    problem_info: dict[str, Any] = field(default_factory=dict)
    optimizer_params: dict[str, Any] = field(default_factory=dict)
    solution: Any = None

    def summary(self) -> dict[str, Any]:
        """Flat dictionary of the scalar outcome (for tables and stores)."""
        out: dict[str, Any] = {
            "problem": self.problem, "optimizer": self.optimizer, "seed": self.seed,
            "budget": self.budget, "n_evaluations": self.n_evaluations,
            "best_f": self.best_f, "elapsed": self.elapsed,
        }
        metrics = getattr(self.solution, "metrics", None)
        if callable(metrics):
            out.update(metrics())
        return out
