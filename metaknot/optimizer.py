"""The :class:`Optimizer` interface: ask for candidates, be told their objective values.

A new optimizer implements :meth:`Optimizer.setup`, :meth:`Optimizer.ask` and
:meth:`Optimizer.tell` (or only :meth:`Optimizer.run`); :meth:`Optimizer.run` drives them through an
:class:`~metaknot.budget.Evaluator`, which enforces the evaluation budget. Optimizers that must
call the objective themselves (nlopt, for instance) override :meth:`run` and call the evaluator
directly: the budget still holds.

``setup`` receives a :class:`~metaknot.Task`: the problem's encoding, sampler and settings plus
the budget (``self.problem.budget``), but no way to evaluate. An external loop drives an
optimizer the same way::

    evaluator = Evaluator(problem, budget)
    optimizer.setup(evaluator.task, rng)
    while not evaluator.done and not optimizer.finished():
        X = optimizer.ask()
        optimizer.tell(X, evaluator(X))      # the last batch may come back shorter
"""

from __future__ import annotations

import inspect
from abc import ABC
from collections.abc import Callable
from typing import Any, ClassVar, TypeVar

import numpy as np

from .budget import BudgetExhausted, Evaluator
from .task import ProblemView
from .validate import is_real

_Hook = TypeVar("_Hook", bound=Callable[[], Any])

__all__ = ["Optimizer", "check_param"]


def check_param(name: str, value: Any, *, low: float | None = None, high: float | None = None,
                integer: bool = False, low_open: bool = False) -> Any:
    """Validate a numeric hyperparameter; raise ``ValueError`` naming it if out of range."""
    if not is_real(value):
        raise ValueError(f"{name} must be a number; got {value!r}")
    if not np.isfinite(value):
        raise ValueError(f"{name} must be finite; got {value!r}")
    if integer and int(value) != value:
        raise ValueError(f"{name} must be an integer; got {value!r}")
    if low is not None and (value <= low if low_open else value < low):
        raise ValueError(f"{name} must be {'>' if low_open else '>='} {low}; got {value!r}")
    if high is not None and value > high:
        raise ValueError(f"{name} must be <= {high}; got {value!r}")
    return int(value) if integer else float(value)


class Optimizer(ABC):
    """Base class of all optimizers.

    Class attributes
    ----------------
    name
        Registry name (set by :func:`metaknot.register`).
    encodings
        Encoding kinds the optimizer can handle.
    multi_objective
        True if the optimizer handles two-objective problems (its ``tell`` gets values of
        shape ``(B, 2)``; objective ``pareto``), or ignores the values altogether.
    """

    name: ClassVar[str] = "optimizer"
    encodings: ClassVar[tuple[str, ...]] = ("binary", "integer", "continuous")
    multi_objective: bool = False

    problem: ProblemView
    rng: np.random.Generator

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        """Bind to a problem (normally its :class:`~metaknot.Task`) and a random generator;
        subclasses extend to build their state."""
        if problem.encoding.kind not in self.encodings:
            raise ValueError(
                f"optimizer {self.name!r} handles {', '.join(self.encodings)} encodings; "
                f"problem {problem.name!r} is {problem.encoding.kind}"
            )
        if getattr(problem, "n_objectives", 1) > 1 and not self.multi_objective:
            raise ValueError(
                f"optimizer {self.name!r} minimises one objective; problem {problem.name!r} has "
                f"{problem.n_objectives} (a front): use a multi-objective optimizer such as "
                "pymoo:NSGA2, or a single objective (paper, bic, error_bounded)"
            )
        self.problem = problem
        self.rng = rng

    def ask(self) -> np.ndarray:
        """Next batch of candidates, shape ``(B, n_var)``."""
        raise NotImplementedError(f"{type(self).__name__} implements neither ask/tell nor run")

    def tell(self, X: np.ndarray, F: np.ndarray) -> None:
        """Objective values ``F`` of the candidates ``X`` returned by the last :meth:`ask`.

        ``X`` may hold fewer rows than were asked for: the last batch is truncated to the budget.
        """
        raise NotImplementedError(f"{type(self).__name__} implements neither ask/tell nor run")

    def finished(self) -> bool:
        """True when the optimizer has nothing more to try (default: never; the budget ends
        the run)."""
        return False

    def move_origin(self) -> np.ndarray | None:
        """The candidate the last batch from :meth:`ask` was made from by local moves (one
        knot flipped, shifted, inserted or removed), or ``None`` (the default).

        :meth:`run` passes it to the evaluator, which lets a knot problem score the batch by
        exact delta evaluation: same values, same budget, less work per candidate.
        """
        return None

    def acceptance(self) -> np.ndarray | None:
        """For a sequential optimizer that asks for its next steps ahead: per row of the last
        :meth:`ask`, the value at or below which it takes that row, or ``None`` (the default:
        every row counts).

        A (1+1) EA that knows its next mutations, but not whether the parent changes, asks for
        them all as children of the current parent and returns the parent's value for each.
        The evaluator scores the batch in one call and counts its rows up to the first one
        taken; :meth:`tell` gets just those. The rows after it are dropped unseen, so the run
        is the one of asking one row at a time (same candidates, values and trace), at the
        cost of one call per batch. A stop a callback asks for takes effect after the rows
        counted, as for any batch.
        """
        return None

    def count_fits(self, n: int = 1, *, charged: bool = False) -> None:
        """Report ``n`` fits made outside the evaluator (recorded as ``external_fits``, or with
        ``charged=True`` using the budget: :meth:`metaknot.Task.count_fits`)."""
        count = getattr(self.problem, "count_fits", None)
        if count is not None:
            count(n, charged=charged)

    def run(self, evaluator: Evaluator) -> None:
        """Ask, evaluate and tell until the budget is spent or :meth:`finished`.

        Raises
        ------
        RuntimeError
            If :meth:`ask` returns no candidates while :meth:`finished` is false (the run would
            never end).
        TypeError
            If :meth:`ask` returns None.
        """
        ask, tell = self.ask, self.tell
        # the default hooks answer the same every time: not called once per batch
        finished = _unless_default(self.finished, Optimizer.finished)
        move_origin = _unless_default(self.move_origin, Optimizer.move_origin)
        acceptance = _unless_default(self.acceptance, Optimizer.acceptance)
        while not evaluator.done and not (finished is not None and finished()):
            X = ask()
            if X is None:
                raise TypeError(f"{type(self).__name__}.ask() returned None; return an array "
                                "of candidates (one row each), or True from finished() when "
                                "there is nothing left to try")
            if len(X) == 0:
                if self.finished():
                    return
                raise RuntimeError(
                    f"{type(self).__name__}.ask() returned no candidates but finished() is "
                    "False; return candidates, or True from finished() when there is nothing "
                    "left to try"
                )
            try:
                F = evaluator(X, None if move_origin is None else move_origin(),
                              None if acceptance is None else acceptance())
            except BudgetExhausted:
                return
            tell(X if F.size == len(X) else X[: F.size], F)

    def hyperparameters(self) -> dict[str, Any]:
        """Hyperparameters, for run records: the ``__init__`` arguments, read back from the
        attributes of the same name."""
        names = inspect.signature(type(self).__init__).parameters
        return {k: getattr(self, k) for k in names if k != "self" and hasattr(self, k)}


def _unless_default(hook: _Hook, default: Callable[..., Any]) -> _Hook | None:
    """``hook`` (a bound method of an optimizer), or None if it is ``default``, the base
    class's method, whose answer never changes."""
    return None if getattr(hook, "__func__", None) is default else hook
