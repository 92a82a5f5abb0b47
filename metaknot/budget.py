"""The evaluation budget: the only path from an optimizer to the problem's objective, and the
fit tally that audits it.

An optimizer never calls ``problem.evaluate`` itself (it is set up on a :class:`~metaknot.Task`,
which cannot evaluate); it calls an :class:`Evaluator`, which truncates a batch to what is left of
the budget, keeps the best candidate, reports a :class:`Progress` to the callbacks and raises
:class:`BudgetExhausted` once nothing is left. So an optimizer that plays by the interface cannot
use more evaluations than it was given. The evaluator's budget and counters are read-only
properties.

The evaluator counts the candidates it scores; the fit tally counts, independently, the fits
the model layer computes. metaknot's B-spline layer (the batched kernels, the move evaluator,
the periodic kernel and the single fits of :mod:`metaknot.bspline`) adds every fit it makes
with :func:`add_fits`, whoever calls it. :func:`metaknot.minimize` compares the fits tallied
during a run with those the run accounts for (its evaluations, further fits made during its
evaluator's calls, and the fits the optimizer declared with :meth:`metaknot.Task.count_fits`);
more fits than that mark the run ``status="budget_violation"``. The tally is per thread, so
runs in different threads of one process audit only their own fits. A problem whose model is
not metaknot's spline layer takes part by calling :func:`add_fits` from its own evaluation
code.
"""

from __future__ import annotations

import threading
import time
import warnings
import weakref
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from .front import ParetoArchive
from .problem import Problem
from .task import Task
from .validate import is_integer

__all__ = ["BudgetExhausted", "Evaluator", "Progress", "add_fits", "fits_tallied"]

_FLOAT64 = np.dtype(np.float64)


class _Tally(threading.local):
    count = 0


_tally = _Tally()


def add_fits(n: int) -> None:
    """Add ``n`` fits to this thread's fit tally (called by the model layer, once per call)."""
    _tally.count += n


def fits_tallied() -> int:
    """Fits tallied in this thread so far."""
    return _tally.count


class BudgetExhausted(Exception):
    """Raised when an optimizer asks for an evaluation after the budget is spent (or a callback
    asked to stop)."""


def check_budget(budget: object) -> int:
    """``budget`` as an int, or a ``ValueError`` unless it is a positive integer."""
    if not is_integer(budget) or budget < 1:
        raise ValueError(f"budget must be a positive integer number of evaluations; "
                         f"got {budget!r}")
    return int(budget)


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


class _TraceRows(Protocol):
    """What an evaluator feeds a run's trace (:class:`~metaknot.callbacks.TraceRecorder`)."""

    @property
    def next_checkpoint(self) -> float: ...

    def record(self, n: int, batch_f: np.ndarray, batch_metrics: Mapping[str, np.ndarray]
               ) -> None: ...


class Evaluator:
    """Evaluate batches of candidates under a hard cap on the number of evaluations.

    Parameters
    ----------
    problem
        The problem whose objective is called.
    budget
        Maximum number of candidate evaluations (>= 1).
    callbacks
        Plain callables, or objects with an ``on_batch`` method (a
        :class:`~metaknot.callbacks.Callback`): called with a :class:`~metaknot.Progress` after
        every batch; returning ``True`` stops the run (the next request raises
        :class:`BudgetExhausted`).
    trace
        A :class:`~metaknot.callbacks.TraceRecorder` (after its ``on_start``) given the
        batches that add rows to the run's trace, before the callbacks see them: the trace
        :func:`metaknot.minimize` records, at no cost for the other batches.

    Attributes
    ----------
    task
        The optimizer's view of the problem (no evaluation), bound to this budget.
    budget, n_evaluations, remaining
        Evaluations allowed, used and left (used: the candidates evaluated and the
        ``charged_fits``).
    best_x, best_f
        Best candidate so far and its value (``None`` and ``inf`` at first). With two
        objectives, ``best_f`` is the hypervolume gap of the front and ``best_x`` the front's
        knee (its member closest to the ideal point).
    front
        With two objectives, the :class:`~metaknot.front.ParetoArchive` of the non-dominated
        candidates; else ``None``.
    external_fits
        Fits the optimizer declared making on its own, uncharged (:meth:`Task.count_fits`).
    charged_fits
        Fits the optimizer declared as charged to the budget (:meth:`Task.count_fits`), each
        counted as an evaluation in ``n_evaluations``. A charge is made at the next evaluation,
        leaving room for it (so every count a callback sees follows an evaluation); what the
        budget cannot take, or is declared after the last evaluation or a stop, is an external
        fit.
    delta_evaluations
        Evaluations the problem decided by exact delta evaluation (batches passed with
        ``near``; see :meth:`__call__`).
    accounted_fits
        The model fits this evaluator accounts for (see :func:`add_fits`): one per
        evaluation, the fits made during its calls beyond those (rows scored and dropped
        after an accepted one, a move evaluator moved to a new incumbent, the callbacks'),
        and the declared external fits. Evaluations made beyond the budget by tampering
        with the count are fits it does not account for.

    Every attribute is read-only: the budget is fixed when the evaluator is made, and the
    counters change only by evaluating.
    """

    def __init__(self, problem: Problem, budget: int,
                 callbacks: Sequence[Callable[[Progress], bool | None] | Any] = (),
                 trace: _TraceRows | None = None):
        self._problem = problem
        self._budget = check_budget(budget)
        self._callbacks = tuple(callbacks)
        self._on_batch = tuple(_batch_hook(c) for c in self._callbacks)
        self._trace = trace
        self._n_evaluations = 0
        self._best_x: np.ndarray | None = None
        self._best_f = np.inf
        self._external_fits = 0
        self._charged_fits = 0
        self._pending_charge = 0  # declared charged fits not yet taken from the budget
        self._delta_evaluations = 0
        self._extra_fits = 0  # fits made during its calls beyond one per evaluation counted
        self._stop_requested = False
        n_objectives = getattr(problem, "n_objectives", 1)
        if n_objectives not in (1, 2):
            raise ValueError(f"problem {problem.name!r} has {n_objectives} objectives; metaknot "
                             "handles one, or two (a Pareto front)")
        self._front = ParetoArchive(*reversed(problem.hypervolume_box)) \
            if n_objectives == 2 else None
        self._task: weakref.ref[Task] | None = None
        self._start = time.perf_counter()

    problem = property(lambda self: self._problem, doc="The problem evaluated.")
    budget = property(lambda self: self._budget, doc="Evaluations allowed.")
    n_evaluations = property(lambda self: self._n_evaluations, doc="Evaluations used.")
    callbacks = property(lambda self: self._callbacks, doc="The run's callbacks.")
    best_x = property(lambda self: self._best_x, doc="Best candidate so far (or None).")
    best_f = property(lambda self: self._best_f, doc="Its objective value (inf at first).")
    front = property(lambda self: self._front, doc="The Pareto archive (two objectives).")
    external_fits = property(lambda self: self._external_fits + self._pending_charge,
                             doc="Fits declared with :meth:`Task.count_fits`, uncharged.")
    charged_fits = property(lambda self: self._charged_fits,
                            doc="Declared fits charged to the budget (in n_evaluations).")
    delta_evaluations = property(lambda self: self._delta_evaluations,
                                 doc="Evaluations decided by delta evaluation.")
    stop_requested = property(lambda self: self._stop_requested,
                              doc="True once a callback asked to stop.")

    @property
    def task(self) -> Task:
        """The optimizer's view of the problem, bound to this budget.

        The task keeps its evaluator alive, not the other way round (the evaluator holds it
        weakly, making a new one when the last was dropped), so neither outlives its use.
        """
        task = None if self._task is None else self._task()
        if task is None:
            task = Task(self._problem, self)
            self._task = weakref.ref(task)
        return task

    @property
    def accounted_fits(self) -> int:
        """Model fits this evaluator accounts for: one per evaluation, those made during its
        calls beyond that, and the declared external fits."""
        return self._n_evaluations + self._extra_fits + self.external_fits

    @property
    def remaining(self) -> int:
        """Evaluations left."""
        return self._budget - self._n_evaluations

    @property
    def done(self) -> bool:
        """True once the budget is spent or a callback asked to stop."""
        return self._n_evaluations >= self._budget or self._stop_requested

    def _declare_external_fits(self, n: int, charged: bool = False) -> None:
        """Record ``n`` fits an optimizer made outside the evaluator (:meth:`Task.count_fits`):
        as external fits, or ``charged`` to the budget (what is left, at most; the rest as
        external fits)."""
        if not is_integer(n) or n < 0:
            raise ValueError(f"count_fits takes a whole number of fits >= 0; got {n!r}")
        if charged:
            self._pending_charge += int(n)
        else:
            self._external_fits += int(n)

    def _charge(self) -> None:
        """Take the pending charged fits from the budget, leaving the evaluation about to be
        made (none after a stop; the rest are external fits)."""
        charge = 0 if self._stop_requested else max(0, min(self._pending_charge,
                                                           self.remaining - 1))
        self._n_evaluations += charge
        self._charged_fits += charge
        self._external_fits += self._pending_charge - charge
        self._pending_charge = 0

    def __call__(self, X: np.ndarray, near: np.ndarray | None = None,
                 accept: np.ndarray | None = None) -> np.ndarray:
        """Evaluate ``X`` (shape ``(B, n_var)``) or the leading part that fits the budget.

        Returns the objective values of the evaluated rows: possibly fewer than ``B``. Only the
        first ``len(result)`` rows of ``X`` were evaluated. With two objectives the values have
        shape ``(len, 2)``, and callbacks see the hypervolume gap after each candidate.

        ``near`` is a candidate the rows of ``X`` were made from by local moves (the parent of
        a (1+1) EA, the incumbent of a local search). They are then scored by
        :meth:`Problem.evaluate_near` (the knot problems use exact delta evaluation where they
        can): the values are the same, each row still counts as one evaluation.

        ``accept`` (one value per row) makes ``X`` a sequential optimizer's next steps asked
        ahead (:meth:`~metaknot.Optimizer.acceptance`): the rows count up to the first whose
        value is at most its ``accept`` entry, that one included; the rest were scored in the
        same call but are dropped unseen (their fits are accounted as fits made inside
        evaluations), as if the rows had been asked for one at a time.

        Raises
        ------
        BudgetExhausted
            If the budget is already spent or a stop was requested.
        ValueError
            If ``accept`` does not have one value per row, or the problem has two objectives.
        """
        if self._pending_charge:
            self._charge()
        remaining = self._budget - self._n_evaluations
        if remaining <= 0 or self._stop_requested:
            raise BudgetExhausted(f"evaluation budget of {self._budget} spent")
        X = self._problem.encoding.check(X)
        if accept is not None:
            accept = np.asarray(accept, dtype=np.float64)
            if accept.shape != (X.shape[0],):
                raise ValueError(f"accept must have one value per candidate, shape "
                                 f"({X.shape[0]},); got {accept.shape}")
            if self._front is not None:
                raise ValueError("accept applies to one objective; this problem has two")
        size = len(X)
        if size > remaining:
            X = X[:remaining]
        elif size == 0:
            return np.empty(0)
        fits_before, evaluations_before = _tally.count, self._n_evaluations
        try:
            return self._score(X, near, accept)
        finally:  # the call's fits (the problem's and the callbacks') beyond its evaluations
            extra = _tally.count - fits_before - (self._n_evaluations - evaluations_before)
            if extra > 0:
                self._extra_fits += extra

    def _score(self, X: np.ndarray, near: np.ndarray | None, accept: np.ndarray | None
               ) -> np.ndarray:
        """:meth:`__call__` on a checked, non-empty batch within the budget."""
        problem = self._problem
        if near is not None:
            F, metrics, delta = problem.evaluate_near(X, np.asarray(near))
        else:
            (F, metrics), delta = problem.evaluate_with_metrics(X), 0
        if type(F) is not np.ndarray or F.dtype is not _FLOAT64:  # (float64 is one object)
            F = self._as_values(np.asarray(F))
        size = len(X)
        if F.shape != ((size,) if self._front is None else (size, 2)):
            raise ValueError(
                f"{type(problem).__name__}.evaluate returned shape {F.shape}; expected "
                f"{(size,) if self._front is None else (size, 2)}"
            )
        if accept is not None and size > 1:
            taken = np.flatnonzero(F <= accept[:size])  # NaN is never taken
            if taken.size and taken[0] + 1 < size:
                size = int(taken[0]) + 1
                X, F = X[:size], F[:size]
                metrics = _Head(metrics, size)
        if near is not None:  # which rows the delta path decided (an array), or how many
            self._delta_evaluations += int(np.count_nonzero(delta[:size])) \
                if isinstance(delta, np.ndarray) else min(int(delta), size)
        front = self._front
        if front is None:
            best = int(F.argmin()) if size > 1 else 0  # the first NaN, if there is one
            value = F.item(best)
            if value != value:
                F = self._warn_nan(F)
                best = int(F.argmin())
                value = F.item(best)
            scalar = F
        else:
            if np.isnan(F).any():
                F = self._warn_nan(F)
            scalar = front.add(X, F, metrics)
            if not len(front):
                scalar = np.full(len(F), np.inf)  # nothing feasible yet: no front, no incumbent
            best = int(scalar.argmin())
            value = scalar.item(best)
        self._n_evaluations += size
        improved = value < self._best_f
        if improved:
            self._best_f = value
            if front is None:
                self._best_x = X[best].copy()
            else:
                assert front.X is not None  # a front with members (above)
                self._best_x = front.X[front.knee()].copy()
        trace = self._trace
        if trace is not None and (improved or self._n_evaluations >= trace.next_checkpoint):
            trace.record(self._n_evaluations, scalar, metrics)
        if self._on_batch:
            self._after_batch(scalar, metrics)
        return F

    def _as_values(self, F: np.ndarray) -> np.ndarray:
        """Values of another dtype than float64 as float64, or a ``ValueError`` naming the
        problem: complex values (a cast would drop their imaginary parts with only a warning)
        and values that are not numbers."""
        name = type(self._problem).__name__
        if F.shape == () and F.dtype == object and F.item() is None:
            raise ValueError(f"{name}.evaluate returned None; return one value per candidate")
        if F.dtype.kind == "c":
            raise ValueError(f"{name}.evaluate returned complex values; objective values must "
                             "be real numbers")
        if F.dtype.kind not in "biuf":
            raise ValueError(f"{name}.evaluate returned values of dtype {F.dtype}; objective "
                             "values must be real numbers")
        return F.astype(np.float64)

    def _warn_nan(self, F: np.ndarray) -> np.ndarray:
        """``F`` with NaN counted as +inf, and a warning that the problem returned NaN."""
        warnings.warn(f"{type(self._problem).__name__}.evaluate returned NaN; counted as +inf",
                      RuntimeWarning, stacklevel=4)
        return np.where(np.isnan(F), np.inf, F)

    def _after_batch(self, scalar: np.ndarray, metrics: Mapping[str, np.ndarray]) -> None:
        """Report the batch's values (``scalar``) to the callbacks; a stop they ask for ends
        the run."""
        progress = Progress(self._n_evaluations, self._budget, self._best_f, scalar,
                            time.perf_counter() - self._start, metrics)
        for on_batch in self._on_batch:
            if on_batch(progress):
                self._stop_requested = True


class _Head(Mapping[str, np.ndarray]):
    """The first ``size`` rows of every metric of a batch (the rows an evaluator kept of a
    batch asked ahead), each sliced when it is read: a problem that computes its metrics on
    first use (the knot problems) computes them only if a callback reads them."""

    __slots__ = ("_metrics", "_size")

    def __init__(self, metrics: Mapping[str, np.ndarray], size: int) -> None:
        self._metrics = metrics
        self._size = size

    def __getitem__(self, name: str) -> np.ndarray:
        return self._metrics[name][: self._size]

    def __iter__(self) -> Iterator[str]:
        return iter(self._metrics)

    def __len__(self) -> int:
        return len(self._metrics)


def _batch_hook(callback: Any) -> Callable[[Progress], bool | None]:
    """What the evaluator calls after every batch: ``callback.on_batch`` if it has one, else the
    callable itself."""
    hook = getattr(callback, "on_batch", callback)
    if not callable(hook):
        raise TypeError(f"a callback must be a Callback or a callable; got {callback!r}")
    return hook
