"""The optimizer's view of a problem: an allowlist of what it may read, and the budget.

An optimizer set up by :func:`metaknot.minimize` (or on :attr:`Evaluator.task`) receives a
:class:`Task`, not the problem. A task offers the encoding, :meth:`Task.sample`,
:meth:`Task.repair`, the budget (:attr:`Task.budget`, :attr:`Task.remaining`,
:attr:`Task.n_evaluations`, all read-only) and the settings the problem lists in its
``public_attributes`` (for the knot problems: ``params``, ``points``, ``degree``, ``n_knots``,
``pad``, ...), arrays among them as read-only views. Nothing else of the problem is reachable by
attribute access: no way to evaluate or decode candidates, no private attribute, and no method
whose ``__self__`` is the problem. Every evaluation goes through the
:class:`~metaknot.Evaluator`, which counts it. Fits an optimizer makes on its own (a baseline's
FITPACK scan) are declared with :meth:`Task.count_fits` and end up in the run record.

This is what an optimizer is *given*; it is not a sandbox (Python has none). What keeps a run
honest beyond it is the audit of :func:`metaknot.minimize` (see :mod:`metaknot.budget`).
"""

from __future__ import annotations

import weakref
from typing import Any, Protocol

import numpy as np

from .problem import Encoding, Problem

__all__ = ["ProblemView", "Task"]

#: Problem members whose absence from a task deserves its own explanation: ``evaluate*`` and
#: ``decode*`` (``evaluate``, ``evaluate_with_metrics``, ``evaluate_near``, ``decode``, ...).
EVALUATING = ("evaluate", "decode")


class ProblemView(Protocol):
    """What an optimizer reads of the problem it is set up on, whichever it is given: a
    :class:`Task` (what :func:`metaknot.minimize` and :class:`~metaknot.Evaluator` hand it), or
    the :class:`~metaknot.Problem` itself. Both satisfy this protocol; an optimizer typed
    against it works with either.

    A knot problem's settings (``params``, ``degree``, ...) are a further protocol,
    :class:`metaknot.problems.KnotSpace`, that an optimizer for knot problems narrows to.
    """

    @property
    def name(self) -> str: ...

    @property
    def encoding(self) -> Encoding: ...

    @property
    def n_objectives(self) -> int: ...

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray: ...


class BudgetOwner(Protocol):
    """What a task reads of the :class:`~metaknot.Evaluator` that owns it."""

    @property
    def budget(self) -> int: ...

    @property
    def n_evaluations(self) -> int: ...

    @property
    def remaining(self) -> int: ...

    def _declare_external_fits(self, n: int, charged: bool = False) -> None: ...


class _Binding:
    """What a task is bound to, kept out of the task's own attributes."""

    __slots__ = ("evaluator", "problem", "views")

    def __init__(self, problem: Problem, evaluator: BudgetOwner) -> None:
        self.problem = problem
        self.evaluator = evaluator
        self.views: dict[str, Any] = {}  # read-only arrays and wrapped methods, by name


# id(task) -> binding, dropped when the task is collected; a task has no instance attributes
# (its ``__slots__`` holds only a weak reference slot), so nothing behind it is reachable as
# ``task.<name>``. A plain dict: it is read on every call an optimizer makes to its task (a
# weak-key dictionary's lookup, in Python, cost more than drawing a candidate)
_BINDINGS: dict[int, _Binding] = {}


class Task:
    """What an optimizer sees: the problem's encoding and public settings, plus the budget.

    Parameters
    ----------
    problem
        The problem being optimised.
    evaluator
        The evaluator that owns the budget.
    """

    __slots__ = ("__weakref__",)

    def __init__(self, problem: Problem, evaluator: BudgetOwner) -> None:
        _BINDINGS[id(self)] = _Binding(problem, evaluator)
        weakref.finalize(self, _BINDINGS.pop, id(self), None)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        binding = _BINDINGS[id(self)]
        if name.startswith(EVALUATING):
            raise AttributeError(
                f"an optimizer cannot call problem.{name}(): candidates are evaluated only "
                "through the evaluator, which enforces the budget"
            )
        if name in binding.views:
            return binding.views[name]
        problem = binding.problem
        public = type(problem).public_attributes
        if name.startswith("_") or name not in public:
            raise AttributeError(
                f"an optimizer sees only the encoding, sample, repair, the budget and the "
                f"problem's public settings ({', '.join(sorted(public))}); "
                f"{name!r} is not one of them"
            )
        value = getattr(problem, name)
        view = _read_only(value)
        if view is not value:  # arrays and methods: one view each, made once
            binding.views[name] = view
        return view

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"a task is read-only; cannot set {name!r}")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"a task is read-only; cannot delete {name!r}")

    def __repr__(self) -> str:
        return f"Task({_BINDINGS[id(self)].problem.name!r}, budget={self.budget})"

    @property
    def encoding(self) -> Encoding:
        """How candidates are represented."""
        return _BINDINGS[id(self)].problem.encoding

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` random candidates, drawn as the problem draws them."""
        return _BINDINGS[id(self)].problem.sample(rng, n)

    def repair(self, X: np.ndarray) -> np.ndarray:
        """The nearest valid candidates (:meth:`Encoding.repair`)."""
        return _BINDINGS[id(self)].problem.encoding.repair(X)

    @property
    def problem_type(self) -> type:
        """The class of the problem behind the task (for ``issubclass`` checks)."""
        return type(_BINDINGS[id(self)].problem)

    @property
    def budget(self) -> int:
        """Evaluations allowed in this run."""
        return _BINDINGS[id(self)].evaluator.budget

    @property
    def n_evaluations(self) -> int:
        """Evaluations used so far."""
        return _BINDINGS[id(self)].evaluator.n_evaluations

    @property
    def remaining(self) -> int:
        """Evaluations left."""
        return _BINDINGS[id(self)].evaluator.remaining

    def count_fits(self, n: int = 1, *, charged: bool = False) -> None:
        """Declare ``n`` fits the optimizer made outside the evaluator.

        By default they are recorded in the run's ``external_fits``: not objective
        evaluations, not using the budget, but accepted by the run's audit. ``charged=True``
        makes them use the budget instead, ``n`` evaluations' worth, counted in
        ``n_evaluations`` and ``charged_fits`` from the next evaluation on (what the budget can
        take; the rest are external fits): work an optimizer does per step beyond its
        evaluations (a Jacobian), so that equal budgets mean comparable work."""
        _BINDINGS[id(self)].evaluator._declare_external_fits(n, charged)


def _read_only(value: Any) -> Any:
    """``value`` as an optimizer may hold it: arrays as read-only views, the problem's own
    methods as plain functions (whose ``__self__`` is not the problem)."""
    if isinstance(value, np.ndarray):
        view = value.view()
        view.flags.writeable = False
        return view
    if callable(value) and isinstance(getattr(value, "__self__", None), Problem):
        method = value

        def call(*args: Any, **kwargs: Any) -> Any:
            return method(*args, **kwargs)

        call.__doc__ = method.__doc__
        call.__name__ = getattr(method, "__name__", "method")
        return call
    return value
