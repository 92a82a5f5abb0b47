"""One curve model for open and closed curves: how data points, a degree and interior knots
become a least-squares fit.

An open curve is fitted by a clamped B-spline over ``[u_0, u_{N-1}]``: its interior knots lie
strictly inside that range, knots at data points sit at ``u_1 .. u_{N-2}``, and it has
``degree + 1`` control points beyond its interior knots. A closed outline is fitted by a
periodic spline over one period ``[0, 1)`` (the closing chord counts in the parameterization):
0 is always a breakpoint, knots at data points sit at ``u_1 .. u_{N-1}``, and it has one control
point per breakpoint. :class:`OpenCurve` and :class:`ClosedCurve` answer the same questions
(:class:`Curve`), so the problems, ``metaknot fit``, studies and reports never ask which one
they hold.

:func:`closure` decides whether a point sequence is a closed outline, in one place: by its
closing chord (last point to first) against its typical point spacing.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar

import numba
import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import BSpline

from ..budget import add_fits
from ..validate import check_flag
from . import _kernel
from .fit import (
    BatchFit,
    CurveFit,
    Infeasibility,
    Metric,
    PeriodicFit,
    SplineFit,
    _fit_clamped,
    _prepare,
    batch_errors,
    check_metric,
    kernel_points,
)
from .knots import (
    _periodic_knots,
    as_positions,
    averaging_knots,
    check_masks,
    check_multiplicity,
    check_offsets,
    clamped_knot_vector,
    extra_control_points,
    periodic_knot_vector,
    stack_indices,
    stack_positions,
    stack_rows,
)
from .moves import MoveEvaluator, bound_to
from .parameterize import _parameters, check_degree, closed_parameterize

__all__ = ["CLOSING_CHORD_SPACINGS", "REPEAT_SPACINGS", "ClosedCurve", "Closure", "Curve",
           "OpenCurve", "closure", "curve_model", "make_curve"]

#: A closing chord of at most this many typical point spacings makes a sequence an outline.
CLOSING_CHORD_SPACINGS = 2.5
#: A last point this close to the first (in typical spacings) is the first point again.
REPEAT_SPACINGS = 0.25

#: Batches of at most this many candidates (a sequential optimizer's, a CMA-ES generation, a
#: nevergrad batch) are fitted on the calling thread: waking the kernel's thread pool costs
#: more than it saves (on a busy machine far more). 0 sends every batch to the thread pool.
SERIAL_BATCH = 16


def _outputs(b: int, max_deviation: bool
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The kernel's output arrays for ``b`` candidates (SSE, maximum deviation, control
    points, reason); the audit's tally counts the ``b`` fits they are for."""
    add_fits(b)
    return (np.empty(b), np.empty(b if max_deviation else 0), np.empty(b, dtype=np.int64),
            np.empty(b, dtype=np.int8))


@dataclass(frozen=True)
class Closure:
    """Whether a point sequence is a closed outline, and why.

    Attributes
    ----------
    closed
        The closing chord is at most :data:`CLOSING_CHORD_SPACINGS` typical spacings.
    repeats_first
        The last point is the first one again (at most :data:`REPEAT_SPACINGS` spacings
        away): a closed fit drops it.
    chord_spacings
        The closing chord in typical spacings (the median distance of consecutive points).
    """

    closed: bool
    repeats_first: bool
    chord_spacings: float

    def describe(self) -> str:
        """Why, in words (for ``metaknot fit``'s output)."""
        if self.repeats_first:
            return "its last point repeats the first"
        if not np.isfinite(self.chord_spacings):
            return "one coordinate or fewer than 4 points: no outline to close"
        return f"the closing chord is {self.chord_spacings:.3g} point spacings"


def closure(points: ArrayLike) -> Closure:
    """Is ``points`` a closed outline? Yes if the chord from the last point back to the first
    is at most :data:`CLOSING_CHORD_SPACINGS` typical point spacings; the last point repeats
    the first if it is within :data:`REPEAT_SPACINGS` of them. The typical spacing is the
    largest of the median distance between consecutive points and the first and last steps
    (an outline sampled unevenly may have its widest steps at the seam). Sequences of fewer than
    4 points are open, and so are values of one coordinate (a 1-D sequence traces a line back
    and forth; it has no outline to close)."""
    q = np.asarray(points, dtype=np.float64)
    q = q[:, None] if q.ndim == 1 else q
    if len(q) < 4 or q.shape[1] < 2:
        return Closure(False, False, np.inf)
    steps = np.linalg.norm(np.diff(q, axis=0), axis=1)
    spacing = float(max(np.median(steps), steps[0], steps[-1]))
    chord = float(np.linalg.norm(q[-1] - q[0]))
    if spacing <= 0:
        spacing = float(steps.max()) if steps.max() > 0 else 1.0
    ratio = chord / spacing
    repeats = chord == 0 or ratio <= REPEAT_SPACINGS
    return Closure(repeats or ratio <= CLOSING_CHORD_SPACINGS, repeats, ratio)


class Curve(ABC):
    """Data points with their parameters and a degree: what a knot vector is fitted to.

    Built by :func:`make_curve`, which checks its input once; the constructors
    (``OpenCurve(params, points, degree)``, ``ClosedCurve(...)``) check theirs. Every fit and
    batch of fits goes to the compiled kernels with the data as they are.

    Attributes
    ----------
    params, points, degree
        Parameter values ``(N,)``, points ``(N, d)`` (float64, contiguous) and the spline
        degree.

    Raises
    ------
    ValueError
        For bad points, parameters or degree (:func:`~metaknot.bspline.fit._prepare`).
    """

    closed: ClassVar[bool]
    #: In words, for messages: "open (clamped)" or "closed (periodic)".
    kind: ClassVar[str]
    #: :attr:`max_interior_knots` as a formula, for messages.
    max_interior_knots_rule: ClassVar[str]

    def __init__(self, params: ArrayLike, points: ArrayLike, degree: int) -> None:
        self.params, self.points = _prepare(params, points, degree, closed=self.closed)
        self.degree = int(degree)

    @classmethod
    def _checked(cls, params: np.ndarray, points: np.ndarray, degree: int) -> Curve:
        """The curve of data :func:`make_curve` has checked, taken as they are."""
        curve = cls.__new__(cls)
        curve.params, curve.points, curve.degree = params, points, degree
        return curve

    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])

    @property
    @abstractmethod
    def extra_control_points(self) -> int:
        """Control points beyond the interior knots."""

    @property
    @abstractmethod
    def knot_bounds(self) -> tuple[float, float]:
        """The open interval interior knots lie in."""

    @property
    @abstractmethod
    def candidate_params(self) -> np.ndarray:
        """The data parameters a knot at a data point may sit at (the bits of a mask)."""

    @property
    @abstractmethod
    def max_interior_knots(self) -> int:
        """The most interior knots a fit can have (one control point per data point)."""

    @property
    def max_index(self) -> int:
        """The highest data index a knot at a data point may sit at."""
        return int(self.candidate_params.size)

    def evaluate_knots(self, knots: np.ndarray, offsets: np.ndarray, *,
                       max_deviation: bool = True, max_multiplicity: int = 1) -> BatchFit:
        """Fit every candidate ``knots[offsets[b]:offsets[b + 1]]`` (sorted interior knots,
        each repeated at most ``max_multiplicity`` times)."""
        return self._evaluate_flat(*check_offsets(knots, offsets), max_deviation,
                                   check_multiplicity(max_multiplicity, self.degree))

    def _evaluate_flat(self, knots: np.ndarray, offsets: np.ndarray, max_deviation: bool,
                       max_multiplicity: int = 1) -> BatchFit:
        """:meth:`evaluate_knots` of offsets that match the knots (not checked again), by the
        compiled fits: on the calling thread up to :data:`SERIAL_BATCH` candidates, else on the
        kernel's threads."""
        sse, max_dev, n_ctrl, reason = out = _outputs(offsets.size - 1, max_deviation)
        knots = np.ascontiguousarray(knots, dtype=np.float64)
        if sse.size <= SERIAL_BATCH:
            _kernel.evaluate_batch_serial(self.params, self.points, self.degree, self.closed,
                                          max_multiplicity, knots, offsets, *out)
        else:
            _kernel.evaluate_batch(self.params, self.points, self.degree, self.closed,
                                   max_multiplicity, knots, offsets, *out,
                                   8 * numba.get_num_threads())
        return BatchFit(sse, max_dev if max_deviation else None, n_ctrl, reason)

    def evaluate_masks(self, masks: np.ndarray, *, max_deviation: bool = True) -> BatchFit:
        """Fit a ``(B, len(candidate_params))`` batch of 0/1 masks over the candidate knots
        (nonzero: a knot; the values of integer masks are not checked, those of others must be
        0 or 1)."""
        return self._evaluate_masks(
            check_masks(masks, self.n_points, closed=self.closed, trust_integers=True),
            max_deviation)

    def _evaluate_masks(self, masks: np.ndarray, max_deviation: bool) -> BatchFit:
        """:meth:`evaluate_masks` of masks already checked (2-D, one column per candidate
        knot, booleans or integers 0 and 1: a problem's encoding has checked them)."""
        if len(masks) > SERIAL_BATCH:
            knots, offsets = _kernel.masks_to_knots(self.params,
                                                    np.ascontiguousarray(masks, dtype=bool))
            return self._evaluate_flat(knots, offsets, max_deviation)
        sse, max_dev, n_ctrl, reason = out = _outputs(len(masks), max_deviation)
        _kernel.evaluate_masks_serial(self.params, self.points, self.degree, self.closed, masks,
                                      *out)
        return BatchFit(sse, max_dev if max_deviation else None, n_ctrl, reason)

    def evaluate_indices(self, indices: np.ndarray, *, max_deviation: bool = True) -> BatchFit:
        """Fit a ``(B, K)`` batch of data indices (1..``max_index``): knots at those
        parameters; a repeated index makes its candidate infeasible."""
        return self._evaluate_flat(*stack_indices(self.params, indices, closed=self.closed),
                                   max_deviation)

    def evaluate_positions(self, positions: np.ndarray, *, max_deviation: bool = True,
                           nan_is_absent: bool = False, max_multiplicity: int = 1) -> BatchFit:
        """Fit a ``(B, K)`` batch of knot positions (NaN: no knot, with ``nan_is_absent``); a
        row repeating a knot more than ``max_multiplicity`` times (1 to the degree) is
        infeasible (:attr:`~metaknot.bspline.Infeasibility.COINCIDENT_KNOTS`)."""
        return self._evaluate_positions(positions, max_deviation, nan_is_absent,
                                        check_multiplicity(max_multiplicity, self.degree))

    def _evaluate_positions(self, positions: np.ndarray, max_deviation: bool,
                            nan_is_absent: bool, max_multiplicity: int) -> BatchFit:
        """:meth:`evaluate_positions` with its multiplicity checked: each row sorted; knots
        outside the range, coincident knots and rank-deficient systems come back infeasible
        with their reason, never raised."""
        positions = as_positions(positions)
        if positions.ndim != 2 or len(positions) > SERIAL_BATCH:
            return self._evaluate_flat(*stack_positions(positions, nan_is_absent=nan_is_absent),
                                       max_deviation, max_multiplicity)
        sse, max_dev, n_ctrl, reason = out = _outputs(len(positions), max_deviation)
        _kernel.evaluate_positions_serial(self.params, self.points, self.degree, self.closed,
                                          max_multiplicity, positions, nan_is_absent, *out)
        return BatchFit(sse, max_dev if max_deviation else None, n_ctrl, reason)

    def fit(self, interior_knots: ArrayLike, *, max_multiplicity: int = 1) -> CurveFit:
        """The least-squares fit with these interior knots, each repeated at most
        ``max_multiplicity`` times (1 to the degree: a knot of multiplicity m leaves the
        spline C^(degree - m) there); ``ValueError`` naming why not."""
        return self._fit(_interior(interior_knots),
                         check_multiplicity(max_multiplicity, self.degree))

    @abstractmethod
    def _fit(self, interior: np.ndarray, max_multiplicity: int) -> CurveFit:
        """:meth:`fit` of 1-D interior knots and a multiplicity checked."""

    def move_evaluator(self, interior_knots: np.ndarray,
                       previous: MoveEvaluator | None = None, *, max_multiplicity: int = 1
                       ) -> MoveEvaluator | None:
        """A :class:`~metaknot.bspline.moves.MoveEvaluator` bound to these knots (``previous``
        moved to them if given; a :class:`~metaknot.bspline.moves.PeriodicMoveEvaluator` on
        closed curves; knots repeated at most ``max_multiplicity`` times), or None if the
        knots cannot be fitted (moves are then fitted in full)."""
        return bound_to(previous, self.params, self.points,
                        np.ascontiguousarray(interior_knots, dtype=np.float64), self.degree,
                        closed=self.closed, max_multiplicity=max_multiplicity)

    @abstractmethod
    def spread_knots(self, count: int) -> np.ndarray:
        """``count`` interior knots spread over the data (a start for searches)."""

    def start_knots(self, count: int) -> np.ndarray:
        """``count`` interior knots for an optimizer to start from (or centre its box on): the
        averaging knots of the data parameters (NURBS Book eqs. 9.68-9.69) while that formula
        applies, up to ``N - p - 1`` knots, else :meth:`spread_knots` (a closed outline takes
        up to ``N - 1`` knots)."""
        if count <= self.n_points - self.degree - 1:
            return averaging_knots(self.params, count, self.degree)
        return self.spread_knots(count)

    @property
    @abstractmethod
    def min_interior_knots(self) -> int:
        """The fewest interior knots a fit can have."""

    @abstractmethod
    def interpolation_residuals(self) -> np.ndarray:
        """Distance of every point to the spline through all of them: what no fit of this
        curve can beat."""

    # -- the data polygon's topology: what methods that walk the data need --------------------

    @property
    @abstractmethod
    def domain_params(self) -> np.ndarray:
        """The data parameters with the end of the domain: every knot span lies between two
        consecutive ones (a closed outline's ``1.0``, where the first point comes round
        again, is appended)."""

    @property
    @abstractmethod
    def end_indices(self) -> np.ndarray:
        """The data indices of the curve's ends (an open curve's first and last point; a
        closed outline has none)."""

    @abstractmethod
    def around(self, values: np.ndarray) -> np.ndarray:
        """Per-point ``values`` in the order the data polygon visits them: a closed outline
        comes back to its first point (its first value is appended), an open curve does
        not."""

    @abstractmethod
    def extend(self, values: np.ndarray, width: int, open_mode: str = "edge") -> np.ndarray:
        """``values`` along the curve (per point or per span, first axis) with ``width`` more
        on each side: cyclic on a closed outline, by :func:`numpy.pad`'s ``open_mode`` beyond
        an open curve's ends."""

    @abstractmethod
    def knots_for_breaks(self, break_params: np.ndarray) -> np.ndarray:
        """Interior knots whose spline breaks at (about) these sorted data parameters, the
        curve's start included: a closed outline's breakpoints are those parameters (0 aside);
        an open curve's knots are the averages of ``degree`` consecutive ones (its ends
        aside), as for interpolation at them (The NURBS Book, eq. 9.8)."""

    @abstractmethod
    def coefficient_map(self, interior_knots: np.ndarray) -> tuple[np.ndarray, Any]:
        """The full knot vector of the spline with these interior knots, and the sparse
        ``(coefficients, distinct coefficients)`` matrix that spreads its distinct
        coefficients over its coefficients (the identity on an open curve; a closed one's
        first ``degree`` coefficients come again at the end)."""

    def errors(self, knot_sets: list[np.ndarray] | np.ndarray, metric: Metric, *,
               max_multiplicity: int = 1) -> np.ndarray:
        """Error (``metric``) of the fit of each set of sorted interior knots (each knot
        repeated at most ``max_multiplicity`` times); ``inf`` where it cannot be fitted."""
        check_metric(metric)
        batch = self._evaluate_flat(*stack_rows(knot_sets), metric == "max_deviation",
                                    check_multiplicity(max_multiplicity, self.degree))
        return batch_errors(batch, metric, self.n_points)


class OpenCurve(Curve):
    """An open curve: a clamped B-spline over ``[u_0, u_{N-1}]``."""

    closed = False
    kind = "open (clamped)"
    max_interior_knots_rule = "N - degree - 1"

    @property
    def extra_control_points(self) -> int:
        return extra_control_points(self.degree)

    @property
    def knot_bounds(self) -> tuple[float, float]:
        return float(self.params[0]), float(self.params[-1])

    @property
    def candidate_params(self) -> np.ndarray:
        return self.params[1:-1]

    @property
    def max_interior_knots(self) -> int:
        return self.n_points - self.degree - 1

    def _fit(self, interior, max_multiplicity) -> SplineFit:
        return _fit_clamped(self.params, self.points, interior, self.degree, max_multiplicity)

    def spread_knots(self, count):
        """The averaging knots (NURBS Book eqs. 9.68-9.69)."""
        return averaging_knots(self.params, count, self.degree)

    @property
    def min_interior_knots(self) -> int:
        return 0

    def interpolation_residuals(self):
        """Against scipy's interpolating spline (``make_interp_spline``, not-a-knot ends)."""
        from scipy.interpolate import make_interp_spline

        fitted = make_interp_spline(self.params, self.points, k=self.degree)(self.params)
        return np.linalg.norm(self.points - fitted, axis=1)

    @property
    def domain_params(self) -> np.ndarray:
        return self.params

    @property
    def end_indices(self) -> np.ndarray:
        return np.array([0, self.n_points - 1])

    def around(self, values):
        return np.asarray(values)

    def extend(self, values, width, open_mode="edge"):
        values = np.asarray(values)
        return np.pad(values, [(width, width)] + [(0, 0)] * (values.ndim - 1), mode=open_mode)

    def knots_for_breaks(self, break_params):
        p = self.degree
        count = break_params.size - p - 1
        if count <= 0:
            return np.empty(0)
        window = np.lib.stride_tricks.sliding_window_view(break_params[1:-1], p)
        return window.mean(axis=1)[:count]

    def coefficient_map(self, interior_knots):
        from scipy import sparse

        interior_knots = _interior(interior_knots)
        t = clamped_knot_vector(self.params, interior_knots, self.degree)
        return t, sparse.identity(t.size - self.degree - 1, format="csr")


class ClosedCurve(Curve):
    """A closed outline: a periodic spline over one period ``[0, 1)``."""

    closed = True
    kind = "closed (periodic)"
    max_interior_knots_rule = "N - 1, closed"

    @property
    def extra_control_points(self) -> int:
        return extra_control_points(self.degree, closed=True)

    @property
    def knot_bounds(self) -> tuple[float, float]:
        return 0.0, 1.0

    @property
    def candidate_params(self) -> np.ndarray:
        return self.params[1:]

    @property
    def max_interior_knots(self) -> int:
        return self.n_points - 1

    def _fit(self, interior, max_multiplicity) -> PeriodicFit:
        """The compiled kernel's fit: O(N p^2) time and O(m p) memory, for any number of
        points."""
        p, u, q = self.degree, self.params, self.points
        t = _periodic_knots(interior, p, max_multiplicity)
        m = t.size - 2 * p - 1
        add_fits(1)
        if m > u.size:
            raise ValueError(f"{m} control points for {u.size} data points")
        coef = np.zeros((m, q.shape[1]))
        code, _ = _kernel.fit_closed(u, q, t, p, coef, np.empty((0, p + 1)),
                                     np.empty(0, dtype=np.int64))
        if code != Infeasibility.FEASIBLE:
            raise ValueError("the least-squares system is singular: some knot spans have no "
                             "data")
        return PeriodicFit(BSpline(t, np.vstack((coef, coef[:p])), p), u, q)

    def spread_knots(self, count):
        """Breakpoints at evenly spaced data points (0 is always one)."""
        at = np.unique(np.linspace(0, self.n_points, count + 2)[1:-1].astype(int))
        knots = self.params[at]
        return knots[knots > 0]

    @property
    def min_interior_knots(self) -> int:
        """``degree - 1``: a periodic spline needs at least ``degree`` breakpoints."""
        return self.degree - 1

    def interpolation_residuals(self):
        """Against the periodic interpolating spline (one fit): breakpoints at every data
        point for an odd degree; for an even degree at 0 and the midpoints between consecutive
        data parameters, as even-degree interpolation at the data parameters is singular on
        evenly spaced ones whenever the number of points is even."""
        u = self.params
        return self.fit(self.candidate_params if self.degree % 2 else
                        0.5 * (u[:-1] + u[1:])).residuals

    @property
    def domain_params(self) -> np.ndarray:
        return np.append(self.params, 1.0)

    @property
    def end_indices(self) -> np.ndarray:
        return np.empty(0, dtype=np.int64)

    def around(self, values):
        values = np.asarray(values)
        return np.concatenate((values, values[:1]))

    def extend(self, values, width, open_mode="edge"):
        values = np.asarray(values)
        return np.pad(values, [(width, width)] + [(0, 0)] * (values.ndim - 1), mode="wrap")

    def knots_for_breaks(self, break_params):
        return break_params[break_params > 0]

    def coefficient_map(self, interior_knots):
        from scipy import sparse

        p = self.degree
        interior_knots = _interior(interior_knots)
        t = periodic_knot_vector(interior_knots, p)
        n = t.size - p - 1
        distinct = interior_knots.size + 1  # breakpoints, 0 included
        spread = sparse.csr_matrix((np.ones(n), (np.arange(n), np.arange(n) % distinct)),
                                   shape=(n, distinct))
        return t, spread


def _interior(interior_knots: ArrayLike) -> np.ndarray:
    """Interior knots as a 1-D float array, or a ``ValueError`` naming their shape."""
    interior = np.asarray(interior_knots, dtype=np.float64)
    if interior.ndim != 1:
        raise ValueError(f"interior_knots must be 1-D; got shape {interior.shape}")
    return interior


def curve_model(closed: bool) -> type[Curve]:
    """The curve model class: :class:`ClosedCurve` for a closed outline, else
    :class:`OpenCurve` (the one place the flag picks an implementation)."""
    return ClosedCurve if check_flag("closed", closed) else OpenCurve


def make_curve(points: ArrayLike, *, degree: int = 3, parameterization: str = "centripetal",
               closed: bool = False, params: ArrayLike | None = None) -> Curve:
    """The curve model of ``points``.

    Parameters
    ----------
    points
        ``(N, d)`` data points.
    degree
        Spline degree, 1..5.
    parameterization
        ``"uniform"``, ``"chord"`` or ``"centripetal"``.
    closed
        A closed outline (a periodic spline; its parameters count the closing chord). A last
        point that repeats the first (:func:`closure`) is dropped.
    params
        Explicit parameter values (open curves only: function data ``y = f(x)``).

    Raises
    ------
    ValueError
        For bad points or parameters, or explicit parameters on a closed curve.
    """
    p = check_degree(degree)
    closed = check_flag("closed", closed)
    q = kernel_points(points, p)  # the one check of the points
    if not closed:  # explicit parameters are checked here, the computed ones are valid
        u = _parameters(q, params if params is not None else parameterization)
        return OpenCurve._checked(u, q, p)
    if params is not None:
        raise ValueError("a closed curve takes its own parameters (closing chord included); "
                         "explicit parameters do not apply")
    if len(q) > 3 and closure(q).repeats_first:
        q = q[:-1]
    return ClosedCurve._checked(closed_parameterize(q, parameterization), q, p)
