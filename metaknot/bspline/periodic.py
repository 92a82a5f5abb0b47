"""The two closed-curve helpers :mod:`metaknot.bspline.moves` reaches through this module
(closed curves are fitted by :class:`~metaknot.bspline.curve.ClosedCurve`): the data check of
:mod:`.fit`, closed, and the periodic knot vector of a degree the move evaluator's constructor
has checked."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from . import fit
from .knots import _periodic_knots as periodic_knot_vector
from .parameterize import check_degree

__all__ = ["periodic_knot_vector"]


def _prepare(u: ArrayLike, points: ArrayLike, degree: int
             ) -> tuple[int, np.ndarray, np.ndarray]:
    """Degree, parameters and points of a closed outline, checked as
    :class:`~metaknot.bspline.curve.ClosedCurve` checks them."""
    u, q = fit._prepare(u, points, degree, closed=True)
    return check_degree(degree), u, q
