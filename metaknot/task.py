"""The optimizer's view of a problem: everything but evaluation.

An optimizer set up by :func:`metaknot.minimize` (or on :attr:`Evaluator.task`) receives a
:class:`Task`, not the problem. The task forwards what an optimizer needs — the encoding,
``sample``, ``repair`` through the encoding, and the problem's read-only settings (``params``,
``points``, ``degree``, ``n_knots``, ``pad``, ...) — and adds the budget, but it has no way to
evaluate or decode candidates: every evaluation goes through the :class:`~metaknot.Evaluator`,
which counts it. Fits an optimizer makes on its own (a baseline's FITPACK scan) are reported with
:meth:`Task.count_fits` and end up in the run record.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .problem import Problem

if TYPE_CHECKING:
    from .budget import Evaluator

__all__ = ["Task", "problem_type"]

#: Problem members an optimizer may not reach through a task.
HIDDEN = frozenset({"evaluate", "evaluate_details", "evaluate_with_metrics", "evaluate_near",
                    "decode"})


class Task:
    """What an optimizer sees: the problem without its objective, plus the budget.

    Parameters
    ----------
    problem
        The problem being optimised.
    evaluator
        The evaluator that owns the budget.
    """

    def __init__(self, problem: Problem, evaluator: Evaluator) -> None:
        object.__setattr__(self, "_problem", problem)
        object.__setattr__(self, "_evaluator", evaluator)

    def __getattr__(self, name: str) -> Any:
        if name in HIDDEN:
            raise AttributeError(
                f"an optimizer cannot call problem.{name}(): candidates are evaluated only "
                "through the evaluator, which enforces the budget"
            )
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(self._problem, name)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"a task is read-only; cannot set {name!r}")

    def __repr__(self) -> str:
        return f"Task({self._problem.name!r}, budget={self.budget})"

    @property
    def problem_type(self) -> type:
        """The class of the problem behind the task (for ``issubclass`` checks)."""
        return type(self._problem)

    @property
    def budget(self) -> int:
        """Evaluations allowed in this run."""
        return self._evaluator.budget

    @property
    def n_evaluations(self) -> int:
        """Evaluations used so far."""
        return self._evaluator.n_evaluations

    @property
    def remaining(self) -> int:
        """Evaluations left."""
        return self._evaluator.remaining

    def count_fits(self, n: int = 1) -> None:
        """Report ``n`` fits the optimizer made outside the evaluator (recorded in the run's
        ``external_fits``; they are not objective evaluations and do not use the budget)."""
        self._evaluator.external_fits += int(n)


def problem_type(problem: Problem | Task) -> type:
    """The class of a problem, seen directly or through a :class:`Task`."""
    return problem.problem_type if isinstance(problem, Task) else type(problem)
