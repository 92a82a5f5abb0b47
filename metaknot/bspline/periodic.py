"""Closed curves: periodic B-splines fitted by least squares.

A closed outline Q_0..Q_{N-1} (the last point is *not* a repeat of the first) is parameterized
over one period [0, 1), the closing chord Q_{N-1} -> Q_0 included. A periodic spline of degree p
with breakpoints 0 = t_0 < t_1 < ... < t_{m-1} < 1 has m control points; its knot vector is the
breakpoints extended by p periodic copies on each side (``m + 2p + 1`` knots, FITPACK's
periodic layout) and its ``m + p`` coefficients repeat the first p at the end, so the curve and
its first p - 1 derivatives are continuous across the seam.

:func:`fit_periodic` fits one knot vector and :func:`evaluate_periodic` a whole batch, both in
compiled code (the open kernel's factorisation with wrap-around columns,
:func:`metaknot.bspline._kernel.solve_closed_into`); the tests check them against FITPACK's periodic
least-squares spline (its fixed-knot mode) and against dense least squares on the wrapped design
matrix.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numba
import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import BSpline

from .. import audit
from . import _kernel
from ._codegen import MAX_DIMENSION
from .fit import BatchFit, CurveFit, Infeasibility, _outputs, batch_errors, check_metric
from .knots import as_positions, padded_rows, stack_rows
from .parameterize import PARAMETERIZATIONS, check_coordinates, check_degree

__all__ = ["PeriodicFit", "closed_parameterize", "evaluate_periodic", "fit_periodic",
           "periodic_errors", "periodic_knot_vector"]

#: The step between neighbours is the chord length to this power, per parameterization.
EXPONENTS = dict(zip(PARAMETERIZATIONS, (0.0, 1.0, 0.5), strict=True))


def closed_parameterize(points: ArrayLike, method: str = "centripetal") -> np.ndarray:
    """Parameter values in [0, 1) of a closed outline (the closing chord included).

    Raises
    ------
    ValueError
        For an unknown method, fewer than 3 points, or consecutive repeated points (the
        closing pair included).
    """
    if method not in EXPONENTS:
        raise ValueError(f"parameterization must be one of {', '.join(EXPONENTS)}; "
                         f"got {method!r}")
    q = np.asarray(points, dtype=np.float64)
    q = q[:, None] if q.ndim == 1 else q
    if q.shape[0] < 3:
        raise ValueError(f"a closed curve needs at least 3 points; got {q.shape[0]}")
    chords = np.linalg.norm(np.diff(np.vstack((q, q[:1])), axis=0), axis=1)
    if (chords == 0).any():
        i = int(np.argmax(chords == 0))
        raise ValueError(f"point {(i + 1) % len(q)} repeats point {i}; a closed outline "
                         "lists each point once (do not repeat the first at the end)")
    steps = chords ** EXPONENTS[method]
    return np.concatenate(([0.0], np.cumsum(steps[:-1]))) / steps.sum()


def periodic_knot_vector(interior: ArrayLike, degree: int = 3) -> np.ndarray:
    """The extended knot vector of a periodic spline on [0, 1) whose breakpoints are 0 and
    the sorted ``interior`` knots (all in (0, 1))."""
    p = check_degree(degree)
    inner = np.sort(np.asarray(interior, dtype=np.float64).ravel())
    # NaN sorts last and fails no comparison: checked by name
    if inner.size and (inner[0] <= 0.0 or not inner[-1] < 1.0 or (np.diff(inner) <= 0).any()):
        raise ValueError("interior knots of a periodic spline must be finite, distinct and lie "
                         "in (0, 1)")
    breaks = np.concatenate(([0.0], inner))
    m = breaks.size
    if m < p:
        raise ValueError(f"a periodic spline of degree {p} needs at least {p - 1} interior "
                         f"knots; got {inner.size}")
    before = breaks[m - p :] - 1.0
    after = np.concatenate((breaks, [1.0]))[: p + 1] + 1.0
    return np.concatenate((before, breaks, [1.0], after[1:]))


@dataclass(frozen=True, eq=False)
class PeriodicFit(CurveFit):
    """A least-squares periodic spline with its metrics (``spline`` is a scipy ``BSpline`` with
    the extended knots, whose last ``degree`` coefficients repeat the first; evaluate it on
    [0, 1)). Its interior knots are the breakpoints in (0, 1); 0 is always one too."""

    @property
    def n_control_points(self) -> int:
        return int(self.spline.c.shape[0] - self.spline.k)

    @property
    def extra_control_points(self) -> int:
        """1: a periodic spline has one control point per breakpoint, 0 included."""
        return 1


def _prepare(u: ArrayLike, points: ArrayLike, degree: int
             ) -> tuple[int, np.ndarray, np.ndarray]:
    """Degree, parameters and points of a closed outline, checked, as the compiled kernel
    takes them."""
    p = check_degree(degree)
    u = np.ascontiguousarray(u, dtype=np.float64)
    try:
        q = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"points must be a numeric array: {exc}") from None
    q = q[:, None] if q.ndim == 1 else q
    # the compiled kernel trusts the layout it is given: anything else is refused here
    if q.ndim != 2:
        raise ValueError(f"points must have shape (N, d); got an array with shape {q.shape}")
    if q.shape[1] < 1:
        raise ValueError(f"points must have at least one coordinate; got shape {q.shape}")
    if q.shape[1] > MAX_DIMENSION:
        raise ValueError(f"points must have 1 to {MAX_DIMENSION} coordinates (the compiled "
                         f"kernel's loops are generated for those); got shape {q.shape}")
    if q.shape[0] < 3:
        raise ValueError(f"a closed curve needs at least 3 points; got {q.shape[0]}")
    check_coordinates(q, "points")
    q = np.ascontiguousarray(q)
    if u.shape != (q.shape[0],) or not np.isfinite(u).all() or (np.diff(u) <= 0).any() \
            or u[0] < 0 or u[-1] >= 1:
        raise ValueError("parameter values must be finite, strictly increasing and in [0, 1)")
    return p, u, q


def fit_periodic(u: ArrayLike, points: ArrayLike, interior: ArrayLike,
                 degree: int = 3) -> PeriodicFit:
    """Least-squares periodic spline through a closed outline (the compiled kernel's fit:
    O(N p^2) time and O(m p) memory, for any number of points).

    Raises
    ------
    ValueError
        If the knots give more control points than data points or a rank-deficient system
        (knot spans without data).
    """
    p, u, q = _prepare(u, points, degree)
    interior = np.asarray(interior, dtype=np.float64)
    if interior.ndim != 1:
        raise ValueError(f"interior_knots must be 1-D; got shape {interior.shape}")
    t = periodic_knot_vector(interior, p)
    m = t.size - 2 * p - 1
    audit.add_fits(1)
    if m > len(u):
        raise ValueError(f"{m} control points for {len(u)} data points")
    coef = np.zeros((m, q.shape[1]))
    _, code = _kernel.fit_closed(u, q, t, p, coef, np.empty((0, p + 1)),
                                 np.empty(0, dtype=np.int64))
    if code != Infeasibility.FEASIBLE:
        raise ValueError("the least-squares system is singular: some knot spans have no data")
    return PeriodicFit(BSpline(t, np.vstack((coef, coef[:p])), p), u, q)


def evaluate_periodic(u: ArrayLike, points: ArrayLike, positions: ArrayLike,
                      degree: int = 3, *, max_deviation: bool = True,
                      nan_is_absent: bool = True) -> BatchFit:
    """Fit a ``(B, K)`` batch of interior knot positions in (0, 1) as periodic splines.

    Like :func:`~metaknot.bspline.evaluate_positions` for open curves: positions are sorted per
    row; NaN means "no knot" (``nan_is_absent``); knots outside (0, 1), coincident knots and
    rank-deficient systems come back infeasible with their reason, never raised.
    """
    p, u, q = _prepare(u, points, degree)
    return _evaluate_periodic(p, u, q, positions, max_deviation, nan_is_absent)


def _evaluate_periodic(p: int, u: np.ndarray, q: np.ndarray, positions: ArrayLike,
                       max_deviation: bool, nan_is_absent: bool) -> BatchFit:
    """:func:`evaluate_periodic` of data already checked (``p``, ``u``, ``q`` as
    :func:`_prepare` returns them)."""
    pos = as_positions(positions)
    if pos.ndim != 2:  # the compiled loop trusts the offsets it is given: refused before
        raise ValueError(f"positions must have shape (B, K); got {pos.shape}")
    knots, offsets, refusal = _kernel.rows_to_knots(np.sort(pos, axis=1), nan_is_absent)
    sse, max_dev, n_ctrl, reason = _fit_flat(p, u, q, knots, offsets, max_deviation)
    refused = refusal != 0  # the reasons the fit does not check itself
    if refused.any():
        reason[refused] = refusal[refused]
        sse[refused] = np.inf
        if max_deviation:
            max_dev[refused] = np.inf
    return BatchFit(sse, max_dev if max_deviation else None, n_ctrl, reason)


def _fit_flat(p: int, u: np.ndarray, q: np.ndarray, knots: np.ndarray, offsets: np.ndarray,
              max_deviation: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The compiled fits of a flattened batch whose knots lie inside (0, 1), each row sorted
    (nothing is checked; a row of coincident knots fits as singular): SSE, maximum deviation,
    control points, reason."""
    out = _outputs(offsets.size - 1, max_deviation)
    _kernel.evaluate_batch(u, q, p, True, knots, offsets, *out, 8 * numba.get_num_threads())
    return out


def _evaluate_masks(p: int, u: np.ndarray, q: np.ndarray, masks: np.ndarray,
                    max_deviation: bool) -> BatchFit:
    """Fit a ``(B, N - 1)`` batch of masks over the data parameters after the first
    (nonzero: a knot; the shape is not checked): the data's own parameters, sorted, distinct
    and inside (0, 1), go to the compiled fit as they are."""
    knots, offsets = _kernel.masks_to_knots(u, np.ascontiguousarray(masks, dtype=bool))
    sse, max_dev, n_ctrl, reason = _fit_flat(p, u, q, knots, offsets, max_deviation)
    return BatchFit(sse, max_dev if max_deviation else None, n_ctrl, reason)


def periodic_errors(u: ArrayLike, points: ArrayLike, knot_sets: list[np.ndarray],
                    degree: int = 3, metric: Literal["max_deviation", "rmse"] = "max_deviation"
                    ) -> np.ndarray:
    """Error (max deviation or RMSE) of the periodic fit for each interior-knot set;
    ``inf`` where it cannot be fitted (the compiled batch evaluator)."""
    check_metric(metric)
    fit = evaluate_periodic(u, points, padded_rows(*stack_rows(knot_sets)), degree,
                            max_deviation=metric == "max_deviation")
    return batch_errors(fit, metric, len(np.asarray(u)))
