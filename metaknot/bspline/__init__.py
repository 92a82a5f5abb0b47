"""B-spline machinery: parameterization, clamped and periodic knot vectors, least-squares fits.

A :class:`~metaknot.bspline.curve.Curve` (:func:`~metaknot.bspline.curve.make_curve`) fits
whole populations of knot vectors in compiled code, open and closed curves alike;
:func:`fit_spline` returns one fit as a :class:`scipy.interpolate.BSpline` with its metrics.
"""

from .fit import (
    BatchFit,
    CurveFit,
    Infeasibility,
    PeriodicFit,
    SplineFit,
    fit_spline,
)
from .knots import (
    averaging_knots,
    clamped_knot_vector,
    n_control_points,
    periodic_knot_vector,
)
from .parameterize import (
    PARAMETERIZATIONS,
    as_points,
    check_degree,
    closed_parameterize,
    parameterize,
)

__all__ = [
    "PARAMETERIZATIONS",
    "BatchFit",
    "CurveFit",
    "Infeasibility",
    "PeriodicFit",
    "SplineFit",
    "as_points",
    "averaging_knots",
    "check_degree",
    "clamped_knot_vector",
    "closed_parameterize",
    "fit_spline",
    "n_control_points",
    "parameterize",
    "periodic_knot_vector",
]
