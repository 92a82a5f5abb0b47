"""B-spline machinery: parameterization, clamped knot vectors, least-squares fits.

The batched evaluators (:func:`evaluate_masks`, :func:`evaluate_indices`,
:func:`evaluate_positions`) fit a whole population of knot vectors in compiled code;
:func:`fit_spline` returns one fit as a :class:`scipy.interpolate.BSpline` with its metrics.
"""

from .fit import (
    BatchFit,
    CurveFit,
    Infeasibility,
    SplineFit,
    evaluate_indices,
    evaluate_knots,
    evaluate_masks,
    evaluate_positions,
    fit_spline,
)
from .knots import (
    averaging_knots,
    clamped_knot_vector,
    interior_from_indices,
    interior_from_mask,
    n_control_points,
)
from .parameterize import PARAMETERIZATIONS, as_points, check_degree, parameterize

__all__ = [
    "PARAMETERIZATIONS",
    "BatchFit",
    "CurveFit",
    "Infeasibility",
    "SplineFit",
    "as_points",
    "averaging_knots",
    "check_degree",
    "clamped_knot_vector",
    "evaluate_indices",
    "evaluate_knots",
    "evaluate_masks",
    "evaluate_positions",
    "fit_spline",
    "interior_from_indices",
    "interior_from_mask",
    "n_control_points",
    "parameterize",
]
