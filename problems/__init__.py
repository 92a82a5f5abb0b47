"""Knot-placement problems, objectives and point sets (installed as ``metaknot.problems``)."""

from .curves import (
    CURVES,
    PointSet,
    add_noise,
    archimedean_spiral,
    check_points_file,
    epitrochoid,
    get_curve,
    load_points,
    vivaldi,
)
from .knot_problems import (
    FreeKnots,
    FreeKnotSpace,
    KnotIndices,
    KnotProblem,
    KnotSelection,
    KnotSolution,
    KnotSpace,
)
from .objectives import (
    BIC,
    OBJECTIVES,
    RMSE,
    DataInfo,
    ErrorBounded,
    Objective,
    Paper,
    get_objective,
)

__all__ = [
    "BIC",
    "CURVES",
    "OBJECTIVES",
    "RMSE",
    "DataInfo",
    "ErrorBounded",
    "FreeKnotSpace",
    "FreeKnots",
    "KnotIndices",
    "KnotProblem",
    "KnotSelection",
    "KnotSolution",
    "KnotSpace",
    "Objective",
    "Paper",
    "PointSet",
    "add_noise",
    "archimedean_spiral",
    "check_points_file",
    "epitrochoid",
    "get_curve",
    "get_objective",
    "load_points",
    "vivaldi",
]
