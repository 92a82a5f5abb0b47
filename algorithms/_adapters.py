"""What the adapters to other optimizer libraries share: optional imports, named choices,
finite penalties."""

from __future__ import annotations

import importlib
import math
from types import ModuleType

import numpy as np

from metaknot.problems import FreeKnotSpace
from metaknot.task import ProblemView

__all__ = ["FinitePenalty", "check_choice", "free_knots", "optional_import",
           "refuse_variable_count"]


def optional_import(module: str, optimizer: str) -> ModuleType:
    """``module``, or an ImportError naming the optimizer that needs it and how to install it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise ImportError(f"optimizer {optimizer!r} needs the {module} package: pip install "
                          f"{module} (or metaknot[adapters])") from None


def check_choice(name: str, value: object, valid: tuple[str, ...]) -> str:
    """``value`` if it is one of ``valid``, else a ``ValueError`` naming the parameter."""
    if value not in valid:
        raise ValueError(f"{name} must be one of {', '.join(valid)}; got {value!r}")
    return str(value)


def refuse_variable_count(problem: object, optimizer: str) -> None:
    """A ``ValueError`` for a ``FreeKnots(variable_count=True)`` problem: the adapters search a
    fixed number of knots (nlopt also searches the count)."""
    if isinstance(problem, FreeKnotSpace) and problem.variable_count:
        raise ValueError(f"optimizer {optimizer!r} searches a fixed number of knots; use "
                         "variable_count=False (or nlopt, which also searches K)")


def free_knots(problem: ProblemView, optimizer: str) -> FreeKnotSpace:
    """``problem`` as the FreeKnots problem whose knots the adapters map their unit box to, or
    a ``ValueError`` naming it: another continuous problem has no knots to map to."""
    if not isinstance(problem, FreeKnotSpace):
        raise ValueError(f"optimizer {optimizer!r} needs a FreeKnots problem for continuous "
                         f"candidates; got {problem.name!r}")
    return problem


class FinitePenalty:
    """Finite stand-ins for infeasible (+inf) values, which the wrapped libraries cannot rank:
    the worst finite value seen so far plus its magnitude plus 1 (1e12 before any)."""

    def __init__(self) -> None:
        self.worst = -np.inf

    @property
    def value(self) -> float:
        return self.worst + abs(self.worst) + 1.0 if np.isfinite(self.worst) else 1e12

    def one(self, value: float) -> float:
        """:meth:`__call__` of a single value, on a float (an nlopt objective's every call)."""
        if not math.isfinite(value):
            return self.value
        self.worst = max(self.worst, value)
        return value

    def __call__(self, F: np.ndarray) -> np.ndarray:
        """``F`` with every non-finite value replaced by the penalty (after seeing ``F``)."""
        F = np.asarray(F, dtype=np.float64)
        finite = F[np.isfinite(F)]
        if finite.size:
            self.worst = max(self.worst, float(finite.max()))
        return np.where(np.isfinite(F), F, self.value)
