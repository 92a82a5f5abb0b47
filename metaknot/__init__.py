"""metaknot: B-spline curve approximation by automatic knot selection with metaheuristics.

The public API::

    import metaknot as mk
    result = mk.minimize("mask", "random_search", budget=2000, seed=1,
                         problem_kwargs={"points": "epitrochoid"})
    result.solution.fit.spline       # a scipy.interpolate.BSpline
"""

from .budget import BudgetExhausted, Evaluator, Progress
from .callbacks import Callback, ProgressBar, RunStart, TraceRecorder
from .front import ParetoArchive, hypervolume_2d, nondominated_mask
from .optimizer import Optimizer, check_param
from .problem import Encoding, Problem
from .registry import (
    available_optimizers,
    available_problems,
    get_optimizer,
    get_problem,
    register,
)
from .result import RunResult, Trace
from .runner import make_rng, minimize
from .task import Task

__version__ = "0.1.0"

#: Names loaded on first use: the applications above the framework (``metaknot fit`` and its
#: result), which pull in the compiled kernels.
_LAZY = {"fit": "metaknot.apps.fit", "ToleranceFit": "metaknot.apps.fit"}


def __getattr__(name: str) -> object:
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'metaknot' has no attribute {name!r}")

__all__ = [
    "BudgetExhausted",
    "Callback",
    "Encoding",
    "Evaluator",
    "Optimizer",
    "ParetoArchive",
    "Problem",
    "Progress",
    "ProgressBar",
    "RunResult",
    "RunStart",
    "Task",
    "ToleranceFit",
    "Trace",
    "TraceRecorder",
    "available_optimizers",
    "available_problems",
    "check_param",
    "fit",
    "get_optimizer",
    "get_problem",
    "hypervolume_2d",
    "make_rng",
    "minimize",
    "nondominated_mask",
    "register",
]
