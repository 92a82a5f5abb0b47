"""metaknot: B-spline curve approximation by automatic knot selection with metaheuristics.

The public API::

    import metaknot as mk
    result = mk.minimize("knot_selection", "random_search", budget=2000, seed=1,
                         problem_kwargs={"points": "epitrochoid"})
    result.solution.fit.spline       # a scipy.interpolate.BSpline
"""

from .budget import BudgetExhausted, Evaluator
from .callbacks import Callback, ProgressBar, RunStart, TraceRecorder
from .front import ParetoArchive, hypervolume_2d, nondominated_mask
from .optimizer import Optimizer, check_param
from .problem import Encoding, Problem
from .progress import Progress, Trace
from .registry import (
    available_optimizers,
    available_problems,
    get_optimizer,
    get_problem,
    register,
)
from .result import RunResult
from .runner import make_rng, minimize
from .task import Task
from .tolerance_fit import ToleranceFit, fit

__version__ = "0.1.0"

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
