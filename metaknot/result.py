"""The record of one optimisation run, and the :class:`Trace` of best-so-far values it keeps
(made by the trace recorder, :mod:`metaknot.callbacks`)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["RunResult", "Trace"]


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


@dataclass(frozen=True, eq=False)
class RunResult:
    """Everything a run produced, in plain values (ready to store).

    Attributes
    ----------
    problem, optimizer
        Names; ``problem_info`` and ``optimizer_params`` hold their settings.
    seed
        The integer seed the run's generator was made from (for a ``SeedSequence``: its
        entropy), or ``None``; ``seed_spawn_key`` is the sequence's spawn key (``()`` for an
        int seed).
    budget, n_evaluations
        Evaluations allowed and used.
    best_x, best_f
        Best candidate and its objective value (``best_x`` is ``None`` if nothing feasible was
        found).
    trace
        Best-so-far history: improvements and log-spaced checkpoints, with the incumbent's
        metrics (:class:`~metaknot.Trace`).
    elapsed
        Wall-clock seconds of the whole run; ``timings`` splits them into ``setup_seconds``,
        ``optimize_seconds`` and ``decode_seconds``.
    external_fits
        Fits the optimizer made on its own, outside the evaluation budget (a FITPACK scan).
    charged_fits
        Fits the optimizer made on its own and charged to the budget (a Jacobian), counted in
        ``n_evaluations``: the candidates evaluated are ``n_evaluations - charged_fits``.
    delta_evaluations
        Evaluations decided by exact delta evaluation of local moves (the rest were full fits
        or knot checks); every one counts against the budget like a full fit.
    status, error
        ``"ok"``; ``"failed"`` with the error (a partial result of a crashed run); or
        ``"budget_violation"`` with the reason, when the run's audit found more model fits than
        the run accounts for, or a changed budget (see :func:`metaknot.minimize`).
    audited_fits, accounted_fits
        The audit's counts: model fits tallied while the optimizer was set up and ran
        (:func:`~metaknot.budget.add_fits`), and the fits the run accounts for (its
        evaluations, further fits made during the evaluator's calls, by the problem or the
        callbacks, and declared external fits).
    front
        Two-objective problems: the final Pareto front as columns (``objective_0``,
        ``objective_1`` and the members' metrics, e.g. ``n_control_points`` and ``rmse``),
        sorted by the first objective; ``best_f`` is then its hypervolume gap. ``None`` for
        single-objective runs.
    solution
        ``problem.decode(best_x)`` (for knot problems: the fitted spline and its metrics).
    metric_names
        The problem's ``metric_names``: the metrics every record of it has.
    """

    problem: str
    optimizer: str
    seed: int | None
    budget: int
    n_evaluations: int
    best_x: np.ndarray | None
    best_f: float
    trace: Trace
    elapsed: float
    problem_info: dict[str, Any] = field(default_factory=dict)
    optimizer_params: dict[str, Any] = field(default_factory=dict)
    solution: Any = None
    seed_spawn_key: tuple[int, ...] = ()
    timings: dict[str, float] = field(default_factory=dict)
    external_fits: int = 0
    charged_fits: int = 0
    delta_evaluations: int = 0
    status: str = "ok"
    error: str | None = None
    front: dict[str, list[float]] | None = None
    audited_fits: int = 0
    accounted_fits: int = 0
    metric_names: tuple[str, ...] = ()

    @property
    def trace_evaluations(self) -> np.ndarray:
        """Evaluation counts of the improvements, plus the last evaluation."""
        return self.trace.evaluations[self._trace_rows()]

    @property
    def trace_best(self) -> np.ndarray:
        """Best-so-far values at :attr:`trace_evaluations`."""
        return self.trace.best_f[self._trace_rows()]

    def _trace_rows(self) -> np.ndarray:
        rows = self.trace.improvement.copy()
        if rows.size:
            rows[-1] = True
        return rows

    @property
    def metrics(self) -> dict[str, float]:
        """The solution's metrics (its ``metrics``), with NaN for each of the problem's
        ``metric_names`` it lacks (all of them if there is no solution)."""
        found = getattr(self.solution, "metrics", None) or {}
        return {**dict.fromkeys(self.metric_names, np.nan), **found}

    def summary(self) -> dict[str, Any]:
        """Flat dictionary of the scalar outcome: names, seed, budget, ``best_f`` (the objective
        value), the fit metrics and the time."""
        return {
            "problem": self.problem, "optimizer": self.optimizer, "seed": self.seed,
            "budget": self.budget, "n_evaluations": self.n_evaluations,
            "best_f": self.best_f, "elapsed": self.elapsed, **self.metrics,
        }

    def record(self) -> dict[str, Any]:
        """The complete flat record of the run (one row of a results table).

        Problem settings under their own names (``data``, ``data_fingerprint``, ``noise``,
        ``degree``, ``parameterization``, ``encoding``, ``n_knots``, ...), ``objective`` (its
        name) with ``objective.<option>``, ``optimizer`` with ``optimizer.<hyperparameter>``,
        the seed (``seed``, ``seed_spawn_key``), budget and evaluations used, ``best_f`` and the
        fit metrics, the timings, ``external_fits``, ``delta_evaluations``, the audit's
        ``audited_fits`` and ``accounted_fits``, ``status`` / ``error``. A two-objective run
        adds ``hypervolume`` (``1 - best_f``), ``front_size`` and ``front``, the front's columns
        as JSON (``metaknot.experiments.Study.fronts`` makes a long table of them). The study
        layer adds the run id, study name, versions and time stamp.
        """
        params = {f"optimizer.{k}": _plain(v) for k, v in self.optimizer_params.items()}
        front = {} if self.front is None else {
            "hypervolume": 1.0 - float(self.best_f),
            "front_size": len(self.front["objective_0"]),
            "front": json.dumps(self.front),
        }
        return {
            **{k: _plain(v) for k, v in self.problem_info.items()},
            "problem": self.problem,
            "optimizer": self.optimizer,
            **params,
            "seed": self.seed,
            "seed_spawn_key": ",".join(str(k) for k in self.seed_spawn_key),
            "budget": self.budget,
            "n_evaluations": self.n_evaluations,
            "best_f": float(self.best_f),
            **self.metrics,
            "elapsed_seconds": float(self.elapsed),
            **{k: float(v) for k, v in self.timings.items()},
            "external_fits": int(self.external_fits),
            "charged_fits": int(self.charged_fits),
            "delta_evaluations": int(self.delta_evaluations),
            "audited_fits": int(self.audited_fits),
            "accounted_fits": int(self.accounted_fits),
            "status": self.status,
            "error": self.error,
            **front,
        }


def _plain(value: Any) -> Any:
    """numpy scalars as Python scalars (for tables and JSON)."""
    return value.item() if isinstance(value, np.generic) else value
