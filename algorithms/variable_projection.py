"""Free knots by variable projection: the control points by the linear least-squares solve, the
knot positions as the nonlinear variables (Golub & Pereyra 1973), with the exact Jacobian.

For interior knots ``tau`` the least-squares fit ``C(tau) = B(tau)^+ Q`` leaves the residual
``r(tau) = Q - B(tau) C(tau) = P(tau) Q`` (``P`` the projector onto the complement of the
basis matrix's columns). Its Jacobian with respect to knot ``tau_k`` is (Golub & Pereyra)::

    dr/dtau_k = -(P D_k C + (B^+)^T D_k^T r),       D_k = dB/dtau_k.

The derivative of a B-spline with respect to one of its knots has a closed form. With de
Boor's definition ``B_i(x) = (t_{i+p+1} - t_i) [t_i, ..., t_{i+p+1}] (. - x)_+^p`` and the rule
that the derivative of a divided difference with respect to a node repeats that node,
``dB_i/dt_j`` for ``t_i <= t_j <= t_{i+p+1}`` is::

    s_ij B_i / (t_{i+p+1} - t_i) + Bh_{i+1} / (th_{i+p+2} - th_{i+1}) - Bh_i / (th_{i+p+1} - th_i)

where ``th`` is the knot vector with ``t_j`` doubled, ``Bh`` its B-splines of degree ``p``, and
``s_ij`` is ``-1`` for ``j = i``, ``+1`` for ``j = i + p + 1``, else 0 (a term with a zero
denominator is zero). :func:`residual_jacobian` builds both for an open curve (compiled, in
:mod:`~metaknot.algorithms._knot_jacobian`); the tests check it against finite differences.

The knots are kept ordered by searching their spacings' logarithms (Jupp 1978): ``K + 1``
spans of the parameter range are the softmax of ``(0, z_1, ..., z_K)``, so every ``z`` gives
ordered interior knots, and a span shrinking towards zero sends its ``z`` to minus infinity
instead of crossing its neighbour.

On a problem that allows multiple knots (``FreeKnots(merge_spacing=...)``) a span driven below
the problem's ``merge_spacing`` becomes a multiple knot: the knots are merged as the problem
merges them, and the search goes on over the distinct knots, each group moving as one (its
derivative is the sum of its copies').
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from contextlib import AbstractContextManager

import numpy as np
from scipy.linalg import solve_triangular
from scipy.optimize import OptimizeResult, least_squares, minimize
from scipy.special import softmax

from metaknot.bspline.curve import curve_model
from metaknot.budget import BudgetExhausted, Evaluator
from metaknot.optimizer import Optimizer, check_param
from metaknot.problems import FreeKnotSpace
from metaknot.problems.knot_problems import merge_close_knots
from metaknot.registry import register
from metaknot.task import ProblemView
from metaknot.validate import check_flag

from ._adapters import free_knots, refuse_variable_count
from .lyche_morken import removal_weights

# A start stops when its sum of squares fell by less than ``stall`` (relative) over this many
# iterations.
STALL_ITERATIONS = 5
# Solves on from a start's end whose knots ran together, each with one of them moved.
REPAIRS = 3
# A knot moved away from its spans goes to the middle of one of this many spans whose data
# have the largest squared residual; the knots left are widened apart to at least this
# fraction of the mean span (on humps+noise0.01s0 at K = 7, knots 1e-7 apart stayed together,
# 1e-6 apart or more parted).
RELOCATION_SPANS = 3
PARTED_SPAN = 1e-3
# Under the objective ``max_deviation`` a solve minimises the sum of the points' deviations to
# each of these powers in turn, each stage from where the one before ended (a continuation from
# least squares towards the largest deviation): least squares may take half of the start's
# share, the later stages split what is left evenly.
MAX_DEVIATION_POWERS = (2, 4, 8, 16, 32)
# When a start's share would be below this many iterations and moving a knot of the best point
# has been tried, what is left goes to quasi-Newton from the best point (``finish``), not to
# starts too short to converge.
FINISH_ITERATIONS = 20
# The finish's metric is Gauss-Newton's damped by this fraction of the Jacobian's largest
# singular value (:func:`gauss_newton_metric`). Over the suite's 270 fixed-K free tasks (seed 0)
# 3e-2 was better than the finish without the metric on 182 and worse on 15 (1e-3: 177 and 20, the
# worst by 0.3 %; 1e-1: 178 and 20); 1e-4 left epitrochoid at K = 9 behind its index set.
METRIC_DAMPING = 3e-2

__all__ = ["Projection", "VariableProjection", "deviation_power", "gauss_newton_metric",
           "jump_knots", "knots_from_log_spans", "log_spans_from_knots", "one_blas_thread",
           "removal_knots", "residual_jacobian", "start_evaluations"]


def one_blas_thread() -> AbstractContextManager[object]:
    """A context in which BLAS and LAPACK run on one thread. Their matrices here are small
    (N x K): a second thread gains nothing, and on a busy machine a call that waits for a
    descheduled thread took 100 times as long (a QR of 400 x 47: 0.33 s instead of 1 ms; a
    polish by ``metaknot fit`` 28 s instead of 5 s)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def start_evaluations(n_knots: int) -> int:
    """The most of the budget one start of :class:`VariableProjection` may use (and at most
    half of what is left): 100 iterations, each an evaluation and a Jacobian charged as
    ``K + 1`` fits; enough for Gauss-Newton to converge from a good start (50 stopped it short
    on galvez_f1 at K = 8: RMSE 0.026-0.062 against 0.014-0.015), few enough that a start in a
    poor basin gives way to the next."""
    return 100 * (n_knots + 2)


def jump_knots(u: np.ndarray, points: np.ndarray, p: int, count: int,
               bounds: tuple[float, float], *, closed: bool = False,
               repeat_weight: float = 1e-3) -> np.ndarray:
    """``count`` interior knots where the data's ``p``-th derivative jumps (a start for the
    search): the data's ``p``-th divided differences (of a spline of degree ``p``, constant
    between its knots) differenced again, their largest local peaks (each with its ``p + 1``
    neighbours either side, a cluster) taken in turn, a knot at each cluster's weighted centre.
    Knots beyond one per cluster go by highest averages, a cluster's ``n``-th (``2 <= n <= p``)
    scored ``repeat_weight`` times its mass / ``n``: a knot the data show to be multiple (its
    mass far above the others') is repeated, split over the data spacing, before a cluster at
    the level of rounding gets one (knots beyond what the jumps place are spread evenly). On
    data sampled from a spline with knots between the data sites this finds them to within a
    data spacing. A closed outline is extended by a period; a cluster at its seam is the
    breakpoint 0, which is a knot already."""
    u = np.asarray(u, dtype=np.float64)
    q = np.asarray(points, dtype=np.float64).reshape(u.size, -1)
    if closed:  # the first p + 1 points again, a period on
        u = np.concatenate((u, u[: p + 1] + 1.0))
        q = np.concatenate((q, q[: p + 1]))
    differences = q
    with np.errstate(divide="ignore", invalid="ignore"):  # repeated parameters: no jump
        for order in range(1, p + 1):
            differences = ((differences[1:] - differences[:-1])
                           / (u[order:] - u[:-order])[:, None])
        mass = np.linalg.norm(differences[1:] - differences[:-1], axis=1)  # points i..i+p+1
    mass[~np.isfinite(mass)] = 0.0
    centre = 0.5 * (u[: mass.size] + u[p + 1: p + 1 + mass.size])
    lower, upper = bounds
    spacing = float(np.median(np.diff(u)))
    clusters: list[tuple[float, float]] = []  # (mass, weighted centre)
    left = mass.copy()
    while len(clusters) < count and left.max() > 0:
        peak = int(np.argmax(left))
        window = slice(max(0, peak - p - 1), peak + p + 2)
        weights = left[window].copy()
        at = float(weights @ centre[window] / weights.sum())
        left[window] = 0.0
        if closed:  # a cluster at the seam is the breakpoint 0, a knot already
            at = at % 1.0
            if min(at, 1.0 - at) < spacing:
                continue
        clusters.append((float(weights.sum()), at))
    if not clusters:
        return np.linspace(lower, upper, count + 2)[1:-1]
    seats = np.zeros(len(clusters), dtype=np.int64)
    masses = np.array([cluster[0] for cluster in clusters])
    for _ in range(count):
        scores = np.where(seats == 0, masses, repeat_weight * masses / (seats + 1))
        scores[seats >= p] = -1.0  # at most p copies: the curve stays continuous
        if scores.max() < 0:
            break
        seats[int(np.argmax(scores))] += 1
    knots = np.concatenate([clusters[c][1] + spacing * (np.arange(n) - (n - 1) / 2)
                            for c, n in enumerate(seats) if n])
    if knots.size < count:  # too few jumps: the rest evenly spread
        knots = np.concatenate((knots, np.linspace(lower, upper, count - knots.size + 2)[1:-1]))
    margin = 0.5 * spacing
    return np.sort(np.clip(knots, lower + margin, upper - margin))


def removal_knots(u: np.ndarray, points: np.ndarray, p: int, count: int, *,
                  closed: bool = False) -> tuple[np.ndarray, int]:
    """``count`` interior knots left of twice as many averaging knots (at most all but one of
    those the data can carry) when the least significant is removed, one at a time, the fit
    redone after each removal: significance as Lyche & Mørken rank it (the distance the spline
    moves when the knot alone is removed, :func:`~.lyche_morken.removal_weights`). A start for
    the search from the other end: knots a dense fit has placed where the data need them.
    Returns the knots and the fits made (empty knots if none could be removed, or a fit
    failed)."""
    curve = curve_model(closed)(u, points, p)
    dense = min(2 * count, curve.max_interior_knots - 1)
    knots = np.sort(curve.start_knots(dense))
    fits = 0
    while knots.size > count:
        fits += 1
        try:
            spline = curve.fit(knots).spline
        except ValueError:  # a dense fit singular on these data: no start
            return np.empty(0), fits
        weights = removal_weights(spline.t, spline.c.reshape(spline.c.shape[0], -1), p,
                                  np.arange(knots.size) + p + 1)
        knots = np.delete(knots, int(np.argmin(weights)))
    # none if nothing was removed (the data carry too few knots for a denser start)
    return (knots if fits else np.empty(0)), fits


def _knot_vector(interior: np.ndarray, bounds: tuple[float, float], p: int, closed: bool
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The knot vector of an open curve (clamped) or a closed one (breakpoint 0, the interior
    knots, periodic copies on each side, as the kernel extends it), with the positions in it
    that each interior knot sets and the index of that knot."""
    k = interior.size
    if not closed:
        lower, upper = bounds
        t = np.concatenate((np.full(p + 1, lower), interior, np.full(p + 1, upper)))
        return t, p + 1 + np.arange(k), np.arange(k)
    m = k + 1  # breakpoints: 0 and the interior knots
    breaks = np.concatenate(([0.0], interior))
    after = np.arange(p + 1)  # the copies above 1 (a second period when m <= p)
    index = np.concatenate((np.arange(m - p, m), np.arange(m), after % m))
    shift = np.concatenate((np.full(p, -1.0), np.zeros(m), 1.0 + (after >= m)))
    t = breaks[index] + shift
    moving = np.flatnonzero(index > 0)
    return t, moving, index[moving] - 1


def residual_jacobian(u: np.ndarray, points: np.ndarray, p: int, interior: np.ndarray,
                      bounds: tuple[float, float], *, closed: bool = False,
                      jacobian: bool = True
                      ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """The least-squares residual of a curve with the given interior knots, and its Jacobian
    with respect to those knots (Golub & Pereyra's, see the module docstring).

    Parameters
    ----------
    u
        ``(N,)`` parameters, increasing, inside ``bounds`` (a closed outline's in ``[0, 1)``).
    points
        ``(N, d)`` data points.
    p
        Degree.
    interior
        ``(K,)`` interior knots, increasing, strictly inside ``bounds``.
    bounds
        The parameter range ``(a, b)``: an open curve's end knots, of multiplicity ``p + 1``;
        ``(0, 1)`` for a closed outline, whose breakpoints are 0 and the interior knots.
    closed
        A closed outline: a periodic spline with ``K + 1`` control points (its basis is the
        extended knot vector's, the last ``p`` B-splines folded onto the first).
    jacobian
        Compute the Jacobian (else ``None`` is returned in its place).

    Returns
    -------
    residual
        ``points - B C``, flattened point by point (length ``N d``).
    jacobian
        ``(N d, K)``: the derivative of ``residual`` with respect to each interior knot.
    coefficients
        ``C``, the control points: ``(K + p + 1, d)``, or ``(K + 1, d)`` closed.

    Raises
    ------
    numpy.linalg.LinAlgError
        If the basis matrix is rank deficient (a knot span without data).
    """
    fit = Projection(u, points, p, interior, bounds, closed=closed)
    return fit.residual, fit.jacobian() if jacobian else None, fit.coefficients


class Projection:
    """The least-squares fit of a curve with given interior knots, kept factored so that the
    Jacobian of its residual (:meth:`jacobian`) reuses the fit's QR factorisation: what
    :func:`residual_jacobian` computes, in two steps (``varpro`` evaluates a point, then
    asks for its Jacobian). Its arguments are :func:`residual_jacobian`'s.

    Attributes
    ----------
    residual
        ``points - B C``, flattened point by point (length ``N d``).
    coefficients
        ``C``, the control points.

    Raises
    ------
    numpy.linalg.LinAlgError
        If the basis matrix is rank deficient (a knot span without data).
    """

    def __init__(self, u: np.ndarray, points: np.ndarray, p: int, interior: np.ndarray,
                 bounds: tuple[float, float], *, closed: bool = False) -> None:
        from ._knot_jacobian import design_open

        t, self._positions, self._variables = _knot_vector(interior, bounds, p, closed)
        n = t.size - p - 1  # B-splines of t
        columns = interior.size + 1 if closed else n  # control points
        extended, spans = np.empty((u.size, n)), np.empty(u.size, dtype=np.int64)
        design_open(u, t, p, n, extended, spans)
        basis = extended
        if closed:  # B-spline i + m is periodic B-spline i's part beyond the seam
            basis = extended[:, :columns].copy()
            basis[:, : n - columns] += extended[:, columns:]
        q_factor, r_factor = np.linalg.qr(basis)
        diagonal = np.abs(np.diag(r_factor))
        if diagonal.min() <= 1e-12 * diagonal.max():
            raise np.linalg.LinAlgError("the basis matrix is rank deficient")
        self.coefficients = np.linalg.solve(r_factor, q_factor.T @ points)
        self._residual = points - basis @ self.coefficients
        self.residual = self._residual.ravel()
        self._u, self._t, self._p, self._n, self._columns = u, t, p, n, columns
        self._knots, self._closed = interior.size, closed
        self._extended, self._spans = extended, spans
        self._q, self._r = q_factor, r_factor

    def jacobian(self) -> np.ndarray:
        """``(N d, K)``: the derivative of :attr:`residual` with respect to each interior
        knot."""
        from ._knot_jacobian import knot_derivatives

        u, n, columns = self._u, self._n, self._columns
        d, k = self._residual.shape[1], self._knots
        moved, pulled = np.empty((u.size, d, k)), np.empty((n, d, k))
        knot_derivatives(u, self._t, self._p, n, self._spans, self._extended,
                         self.coefficients[np.arange(n) % columns], self._residual,
                         self._positions, self._variables, moved, pulled)
        if self._closed:
            pulled[: n - columns] += pulled[columns:]
            pulled = pulled[:columns]
        flat = moved.reshape(u.size, d * k)
        q_factor = self._q
        projected = flat - q_factor @ (q_factor.T @ flat)  # P D_k C, every k at once
        back = q_factor @ np.linalg.solve(self._r.T, pulled.reshape(columns, d * k))
        return -(projected + back).reshape(u.size * d, k)  # back: (B^+)^T D_k^T r


def deviation_power(residual: np.ndarray, n_points: int, power: float, scale: float,
                    jacobian: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray | None]:
    """The residual weighted so that its sum of squares is the sum of the points' deviations to
    ``power`` (scaled): point ``i``'s part ``r_i`` becomes ``r_i (|r_i| / scale)^((power - 2) /
    2)``, so its squared norm is ``scale^2 (|r_i| / scale)^power``; and its Jacobian from that
    of the residual (the chain rule through ``|r_i|``). ``power`` 2 returns both unchanged.

    Parameters
    ----------
    residual
        ``(N d,)``, flattened point by point (as :func:`residual_jacobian` returns it).
    n_points
        ``N``.
    power
        ``>= 2``.
    scale
        A deviation (``> 0``) the weights are relative to, e.g. the largest: keeps the powers
        of the deviations near 1.
    jacobian
        ``(N d, K)``, the residual's Jacobian, or None.
    """
    if power == 2:
        return residual, jacobian
    parts = residual.reshape(n_points, -1)
    norms = np.linalg.norm(parts, axis=1)
    half = (power - 2) / 2
    weights = (norms / scale) ** half
    out = (parts * weights[:, None]).ravel()
    if jacobian is None:
        return out, None
    slopes = jacobian.reshape(n_points, parts.shape[1], -1)
    # d|r_i|^h = h |r_i|^(h - 2) (r_i . dr_i): a point at zero contributes no slope
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = np.where(norms > 0, half * norms ** (half - 2) / scale**half, 0.0)
    along = np.einsum("ic,ick->ik", parts, slopes) * factor[:, None]
    weighted = slopes * weights[:, None, None] + parts[:, :, None] * along[:, None, :]
    return out, weighted.reshape(residual.size, -1)


def knots_from_log_spans(z: np.ndarray, bounds: tuple[float, float]
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Interior knots from the log spans ``z`` (Jupp's transformation, softmax form).

    Returns the ``K`` knots and their Jacobian ``d knots / d z``, shape ``(K, K)``.
    """
    lower, upper = bounds
    logits = np.concatenate(([0.0], z))
    weights = np.exp(logits - logits.max())
    weights /= weights.sum()
    cumulative = np.cumsum(weights)[:-1]
    knots = lower + (upper - lower) * cumulative
    below = np.tril(np.ones((z.size, z.size + 1)))  # span l lies below knot k when l <= k
    derivative = (upper - lower) * (below - cumulative[:, None]) * weights[None, :]
    return knots, derivative[:, 1:]


def log_spans_from_knots(knots: np.ndarray, bounds: tuple[float, float]) -> np.ndarray:
    """The log spans ``z`` of ordered interior knots (inverse of :func:`knots_from_log_spans`)."""
    spans = np.diff(np.concatenate(([bounds[0]], knots, [bounds[1]])))
    if (spans <= 0).any():
        raise ValueError("interior knots must be increasing and strictly inside the range")
    logs = np.log(spans)
    return logs[1:] - logs[0]


def gauss_newton_metric(jacobian: np.ndarray) -> np.ndarray:
    """The upper triangular ``R`` with ``R^T R = 2 (J^T J + mu^2 I)``: the Gauss-Newton Hessian
    of the sum of squares ``r^T r`` with Jacobian ``J``, damped as Levenberg-Marquardt damps it
    (``mu`` = :data:`METRIC_DAMPING` times ``J``'s largest singular value), so that a knot the
    residual hardly depends on leaves ``R`` well conditioned (its condition number at most
    ``sqrt(1 + 1 / METRIC_DAMPING^2)``; the Cholesky factor of so damped a matrix is accurate).
    """
    gram = jacobian.T @ jacobian
    damping = METRIC_DAMPING**2 * float(np.linalg.eigvalsh(gram)[-1])
    return np.sqrt(2.0) * np.linalg.cholesky(gram + damping * np.eye(gram.shape[0])).T


@register("varpro")
class VariableProjection(Optimizer):
    """Free knots by variable projection: Gauss-Newton in a trust region (scipy's
    ``least_squares``, ``trf``) on the knots' log spans, with the exact Jacobian of the
    projected residual (module docstring), from several starts.

    Every point the solver tries is evaluated through the run's evaluator (one evaluation; a
    point whose fit the problem finds infeasible is an infinite residual, on which the solver
    shrinks its step). The method's own fit of the same point (for the residual vector) is
    declared with ``count_fits`` (a repeat of the evaluation's fit); each Jacobian is charged
    to the budget as ``K + 1`` fits (one refined basis per knot, and the fit), so that a run
    of ``varpro`` and one of a derivative-free method at the same budget do comparable work.

    Starts: ``initial`` if given, the problem's averaging knots, equally spaced knots, the
    knots where the data's derivative of the degree's order jumps (:func:`jump_knots`), the
    knots left of twice as many when the least significant are removed (:func:`removal_knots`,
    its ``K`` fits charged to the budget), then,
    whenever the best point so far is better than when this was last done, that point with one
    knot moved (a knot added in the middle of the span whose data have the largest squared
    residual, and of the knots then the one whose removal leaves the least error taken out,
    each removal tried as one evaluation: a knot spent where it does little, two knots run
    together, goes where the error is) and, if that gains nothing, the point with one knot
    moved away from its own two spans to the middle of one of the three spans of largest
    squared residual (the pair that leaves the least error; knots run together parted first),
    else, in turn, a perturbation of the best point so far
    (its log spans plus normal noise, of standard deviation ``perturbation`` times 1/2, 1, 2, 4
    in turn), the best point with one knot drawn anywhere in the range, and knots drawn
    anywhere (spans uniform on the simplex), until the budget is spent or ``restarts`` further
    starts have run. A start may take at most :func:`start_evaluations` evaluations and half of
    those left, and stops when its sum of squares fell by less than ``stall`` (relative) over
    five iterations: knots running together converge slowly (on humps+noise0.01s0 at K = 7,
    two starts crept for 1,650 evaluations from 2.7207 to 2.7206). Where a start ends with two
    knots between the same two data parameters, the solve goes on (up to three times) from
    its end with one knot moved as above, within what is left of the start's share. A start
    solved before is not solved again. The solver's scaling follows the Jacobian's columns
    (``x_scale="jac"``). Once a start's share would be under :data:`FINISH_ITERATIONS`
    iterations and the moves of the best point's knots have been tried, what is left of the
    budget goes, once, to L-BFGS-B on the sum of squares from the best point (least squares
    without multiple knots, not with ``only_initial``), not to starts too short to converge:
    quasi-Newton takes in the curvature Gauss-Newton drops, which makes large residuals creep.
    It runs in Gauss-Newton's metric at that point (:func:`gauss_newton_metric`), its first
    step Gauss-Newton's, so that its updates learn only what Gauss-Newton drops. On
    ``bench_free``'s 24 tasks (5 seeds) the finish made no median worse (epitrochoid at K = 9:
    2.93365 -> 2.93268, and 2.93242 in the metric, below the best-known index set's 2.93247);
    over the suite's 270 fixed-K free tasks (seed 0) the finish was better on 231 and worse
    on 4 (by 0.03 % at most), and its metric then better on 182, worse on 15 (by 0.6 % at
    most, cubic_bump at the larger K, RMSE 4e-7).

    Under the objective ``max_deviation`` (the largest point distance) each solve is a
    continuation: the sum of squares first (up to half of the start's share), then the sum of
    the points' deviations to the powers 4, 8, 16 and 32 (:data:`MAX_DEVIATION_POWERS`,
    :func:`deviation_power`), each stage from where the one before ended, with an equal part of
    what is left. The weighted stages step in the log spans' own units (scaled by the
    Jacobian's columns, as least squares is, they took no step from the least-squares knots of
    ``bench_fit``'s star outline at K = 48). The control points stay the least-squares ones;
    the knots move to where the worst point is nearest: on 80 points of the Archimedean spiral
    with 7 knots, from equally spaced knots at 900 evaluations, a largest deviation of 0.000281
    against 0.000318 under ``rmse``.

    Parameters
    ----------
    restarts
        Starts after the deterministic ones (>= 0; a moved knot's start counts as one),
        or ``None``: until the budget is spent.
    perturbation
        Middle standard deviation of a perturbed start's change of the log spans (> 0; 0.5
        changes a span by a factor of about 1.6).
    tolerance
        ``least_squares``' ``ftol``, ``xtol`` and ``gtol`` (> 0).
    initial
        Knots to start from first, before the averaging knots (``K`` increasing values inside
        the range), e.g. the best index set's: a search that starts there ends no worse. On a
        problem that allows multiple knots a value may repeat (up to the degree): a multiple
        knot, kept as one.
    stall
        The relative fall of the sum of squares over five iterations below which a start gives
        way to the next (0 to 1; 0: a start runs until it converges or spends its share). On
        ``bench_free``'s 24 tasks (5 seeds, 3,000 evaluations) 3e-3 brought the worst best
        seed against the best-known index set from 1.0042 (1e-3; epitrochoid at K = 9, whose
        last start crept, 0.03 % an iteration) to 1.0008, and the worst median from 1.0042 to
        1.0027; titanium at K = 7 lost 0.5 % (median); 2e-3 and 5e-3 were worse.
    removal_start
        Whether the knots :func:`removal_knots` leaves are a start (its ``K`` fits charged to
        the budget). On ``bench_free``'s 24 tasks it brought epitrochoid at K = 9 from 2.970
        to 2.945 (the reference 2.932) and humps at K = 14 from 0.01152 to 0.00973, and made
        none worse; over the suite's 270 fixed-K free tasks it was better by more than 1 % on
        28 and worse on 15 (aspline_spa_het at the smaller K by 47 %).
    only_initial
        Solve from ``initial`` alone (which must then be given), with the whole budget up to
        :func:`start_evaluations`, and stop: a polish of given knots (``metaknot fit``'s
        polishes are runs so).
    """

    encodings = ("continuous",)
    problem: FreeKnotSpace  # setup refuses any other

    def __init__(self, restarts: int | None = None, perturbation: float = 0.5,
                 tolerance: float = 1e-10, initial: Sequence[float] | None = None,
                 stall: float = 3e-3, removal_start: bool = True,
                 only_initial: bool = False) -> None:
        self.restarts = None if restarts is None else check_param("restarts", restarts, low=0,
                                                                  integer=True)
        self.perturbation = check_param("perturbation", perturbation, low=0, low_open=True)
        self.tolerance = check_param("tolerance", tolerance, low=0, low_open=True)
        self.initial = None if initial is None else np.array(initial, dtype=np.float64)
        self.stall = check_param("stall", stall, low=0, high=1)
        self.removal_start = check_flag("removal_start", removal_start)
        self.only_initial = check_flag("only_initial", only_initial)
        if self.only_initial and self.initial is None:
            raise ValueError("only_initial needs the initial knots to start from")

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        space = free_knots(problem, self.name)
        refuse_variable_count(problem, self.name)
        if self.initial is not None:
            lower, upper = space.knot_bounds
            if self.initial.shape != (space.n_knots,):
                raise ValueError(f"initial must hold the problem's {space.n_knots} knots; got "
                                 f"{self.initial.size}")
            allowed = getattr(space, "max_multiplicity", 1)
            _, counts = np.unique(self.initial, return_counts=True)
            if not (np.all(np.diff(self.initial) >= 0) and counts.max() <= allowed
                    and self.initial[0] > lower and self.initial[-1] < upper):
                raise ValueError(f"initial knots must be increasing and inside ({lower:g}, "
                                 f"{upper:g})" + (f", each at most {allowed} times"
                                                  if allowed > 1 else ""))
        super().setup(problem, rng)

    def _starts(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The deterministic starts: log spans of distinct knots and their multiplicities."""
        bounds = self.problem.knot_bounds
        k = self.problem.n_knots
        uniform = np.linspace(*bounds, k + 2)[1:-1]
        given = [] if self.initial is None else [_grouped(self.initial, bounds)]
        if self.only_initial:
            return given
        jumps = jump_knots(self.problem.params, self.problem.points, self.problem.degree, k,
                           bounds, closed=bool(self.problem.closed))
        starts = [*given, _grouped(np.sort(self.problem.start_knots(k)), bounds),
                  _grouped(uniform, bounds), _grouped(jumps, bounds)]
        if self.removal_start:
            removed, fits = removal_knots(self.problem.params, self.problem.points,
                                          self.problem.degree, k,
                                          closed=bool(self.problem.closed))
            self.count_fits(fits, charged=True)
            if removed.size:
                starts.append(_grouped(removed, bounds))
        return starts

    def run(self, evaluator: Evaluator) -> None:
        with one_blas_thread():
            self._run(evaluator)

    def _run(self, evaluator: Evaluator) -> None:
        problem = self.problem
        bounds = problem.knot_bounds
        u, points, degree = problem.params, problem.points, problem.degree
        closed = bool(problem.closed)
        merge = getattr(problem, "merge_spacing", None)  # multiple knots allowed if set
        powers = MAX_DEVIATION_POWERS if problem.objective.name == "max_deviation" else (2,)
        stage = [2.0, 1.0]  # the solve's power and the deviation it is scaled by
        best: list = [np.inf, None, None]  # value, log spans, multiplicities
        # the last point's fit (None: infeasible), kept for its Jacobian; a point tried again
        # (a start) is not re-evaluated
        seen: dict[bytes, Projection | None] = {}
        solved: dict[bytes, np.ndarray | None] = {}  # each start solved: where it ended
        # the multiplicity of each distinct knot the search moves (all 1 without merging)
        groups = np.ones(problem.n_knots, dtype=np.int64)

        def residual(z: np.ndarray) -> np.ndarray:
            """The least-squares fit's residual at the log spans ``z`` (evaluated once; inf
            where the fit is infeasible)."""
            key = z.tobytes() + groups.tobytes()
            if key not in seen:
                seen.clear()
                seen[key] = _fit(z)
            fit = seen[key]
            return np.full(points.size, np.inf) if fit is None else fit.residual

        def weighted(z: np.ndarray) -> np.ndarray:
            """The residual the solve minimises the squares of: each point's deviation
            weighted to the stage's power (:func:`deviation_power`)."""
            return deviation_power(residual(z), u.size, stage[0], stage[1])[0]

        def _fit(z: np.ndarray) -> Projection | None:
            knots = np.repeat(knots_from_log_spans(z, bounds)[0], groups)
            value = float(evaluator(knots[None, :])[0])
            if not np.isfinite(value):
                return None
            if value < best[0]:
                best[:] = value, z.copy(), groups.copy()
            self.count_fits(1)
            try:
                return Projection(u, points, degree, knots, bounds, closed=closed)
            except np.linalg.LinAlgError:
                return None

        def jacobian(z: np.ndarray) -> np.ndarray:
            distinct, chain = knots_from_log_spans(z, bounds)
            knots = np.repeat(distinct, groups)
            self.count_fits(knots.size + 1, charged=True)
            fit = seen.get(z.tobytes() + groups.tobytes()) or \
                Projection(u, points, degree, knots, bounds, closed=closed)
            derivative = deviation_power(fit.residual, u.size, stage[0], stage[1],
                                         fit.jacobian())[1]
            assert derivative is not None
            if groups.size < knots.size:  # a group moves as one: its copies' sum
                derivative = np.add.reduceat(derivative, np.cumsum(groups) - groups, axis=1)
            return derivative @ chain

        def solve(z0: np.ndarray, share: int) -> np.ndarray | None:
            """One solve from ``z0`` using at most ``share`` evaluations (None if its fit is
            infeasible): the log spans reached (a start solved before: where it ended)."""
            key = z0.tobytes() + groups.tobytes()
            if key in solved:
                return solved[key]
            solved[key] = None
            if not np.isfinite(residual(z0)).all():
                return None
            before = evaluator.remaining
            costs: list[float] = []  # the stage's, iteration by iteration

            def stall(intermediate_result: OptimizeResult) -> None:
                costs.append(float(intermediate_result.cost))
                if (len(costs) > STALL_ITERATIONS
                        and costs[-1] > (1.0 - self.stall) * costs[-1 - STALL_ITERATIONS]):
                    raise StopIteration  # creeping (knots running together): the next start

            z = z0
            for stage_index, power in enumerate(powers):
                largest = float(np.max(np.linalg.norm(residual(z).reshape(u.size, -1),
                                                      axis=1)))
                if power > 2 and not largest > 0.0:
                    break  # an exact fit: nothing to weigh
                stage[:] = power, largest
                # at most one Jacobian per residual: the share bounds the budget used; least
                # squares may take half of it, the other stages split what is left evenly
                left = share - (before - evaluator.remaining)
                parts = 2 if stage_index == 0 and len(powers) > 1 else len(powers) - stage_index
                calls = max(1, left // parts // (problem.n_knots + 2))
                costs.clear()

                # the weighted stages in the log spans' own units: scaled by the Jacobian's
                # columns, a knot far from the worst points (a column near zero) took steps so
                # long that every one was refused (on the star outline at K = 48 not one step
                # of the four stages was taken)
                z = least_squares(weighted, z, jac=jacobian, method="trf", max_nfev=calls,
                                  x_scale="jac" if power == 2 else 1.0, ftol=self.tolerance,
                                  xtol=self.tolerance, gtol=self.tolerance, callback=stall).x
            solved[key] = z
            return z

        def merge_and_solve(z0: np.ndarray, reached: np.ndarray) -> None:
            """After a solve from ``z0`` to ``reached``, with multiple knots allowed: the spans
            below ``merge_spacing`` merged into multiple knots (as the problem merges them),
            else the smallest span if the solve drove it below half the smallest span it
            started from, and a solve on from there over the distinct knots."""
            nonlocal groups
            knots = np.repeat(knots_from_log_spans(reached, bounds)[0], groups)
            distinct = np.unique(knots)
            if distinct.size < 2:
                return
            smallest = np.diff(distinct).min()
            shrinking = smallest < 0.5 * np.diff(knots_from_log_spans(z0, bounds)[0]).min()
            assert merge is not None  # called only when the problem merges
            for spacing in [merge, *([smallest * (1.0 + 1e-9)] if shrinking else [])]:
                merged = merge_close_knots(knots, spacing)
                values, counts = np.unique(merged, return_counts=True)
                if counts.size < distinct.size and counts.max() <= degree:
                    groups = counts
                    solve(log_spans_from_knots(values, bounds), start_share())
                    return

        def relocated(z: np.ndarray, counts: np.ndarray, away: bool = False
                      ) -> tuple[np.ndarray, np.ndarray]:
            """The knots ``z`` (multiplicities ``counts``) with one knot moved: a knot added
            in the middle of the span whose data have the largest squared residual and one
            taken out, the one whose removal leaves the least error (each removal tried: one
            evaluation). ``away``: a knot moved away from its own two spans (where the solve
            has placed it) to the middle of one of the ``RELOCATION_SPANS`` spans of largest
            squared residual, the pair that leaves the least error (if there is such a move):
            on humps+noise0.01s0 at K = 7 the best of the first kind, a knot shifted within its
            spans, solved back to where it was (0.9439), the best move elsewhere to 0.9417."""
            nonlocal groups
            groups = counts
            errors = residual(z).reshape(u.size, -1)
            distinct = knots_from_log_spans(z, bounds)[0]
            ends = np.concatenate(([bounds[0]], distinct, [bounds[1]]))
            squared = np.bincount(np.searchsorted(distinct, u, side="right"),
                                  weights=np.sum(errors**2, axis=1), minlength=ends.size - 1)
            # beside: (away) the moves that keep a knot within its own spans
            candidates: list[np.ndarray] = []
            beside: list[np.ndarray] = []
            for worst in np.argsort(-squared, kind="stable")[:RELOCATION_SPANS if away else 1]:
                added = 0.5 * (ends[worst] + ends[worst + 1])
                for drop in range(distinct.size):
                    fewer = counts.copy()
                    fewer[drop] -= 1
                    moved = np.sort(np.append(np.repeat(distinct, fewer), added))
                    near = away and fewer[drop] == 0 and drop in (worst - 1, worst)
                    (beside if near else candidates).append(moved)
            candidates = candidates or beside
            scores = evaluator(np.array(candidates))
            z_moved, counts_moved = _grouped(candidates[int(np.argmin(scores))], bounds)
            return (_widened(z_moved) if away else z_moved), counts_moved

        def start_share() -> int:
            """The evaluations a start may use: :func:`start_evaluations`, at most half of
            those left (all of them with ``only_initial``)."""
            left = evaluator.remaining if self.only_initial else evaluator.remaining // 2
            return max(1, min(left, start_evaluations(problem.n_knots)))

        def collapsed(z: np.ndarray) -> bool:
            """Whether two of the knots ``z`` have no data parameter between them."""
            cells = np.searchsorted(u, knots_from_log_spans(z, bounds)[0])
            return bool(np.any(np.diff(cells) == 0))

        def finish(z: np.ndarray) -> None:
            """L-BFGS-B on the sum of squares from ``z`` with what is left (an evaluation and
            a Jacobian per call), in variables in which Gauss-Newton's metric at ``z`` is the
            identity (:func:`gauss_newton_metric`) and the first step is Gauss-Newton's: the
            quasi-Newton updates then learn only the residual's second-order term, which
            Gauss-Newton drops and misses where the residual is large (epitrochoid at K = 9:
            from varpro's best start, 2.93365, 12 calls reach 2.932417; without the metric
            they reached 2.93268)."""
            calls = evaluator.remaining // (problem.n_knots + 2)
            if calls < 2:
                return
            at_z = residual(z)
            if not np.isfinite(at_z).all():
                return
            jacobian_z = jacobian(z)
            try:
                metric = gauss_newton_metric(jacobian_z)
            except np.linalg.LinAlgError:  # the residual ignores the knots
                return

            def pulled(r: np.ndarray, jacobian_x: np.ndarray) -> np.ndarray:
                """The gradient of ``r^T r`` in the metric's variables: ``R^-T 2 J^T r``."""
                return solve_triangular(metric, 2.0 * (jacobian_x.T @ r), trans="T")

            first = pulled(at_z, jacobian_z)
            scale = float(np.linalg.norm(first))
            if not scale > 0.0:
                return

            def value_and_gradient(v: np.ndarray) -> tuple[float, np.ndarray]:
                if not v.any():  # z itself: known
                    return float(at_z @ at_z), scale * first
                x = z + solve_triangular(metric, scale * v)
                r = residual(x)
                if not np.isfinite(r).all():
                    return np.inf, np.zeros_like(v)
                return float(r @ r), scale * pulled(r, jacobian(x))

            minimize(value_and_gradient, np.zeros_like(z), jac=True, method="L-BFGS-B",
                     options={"maxfun": calls - 1, "ftol": 1e-15, "gtol": 1e-12})

        finishing = powers == (2,) and not self.only_initial and merge is None
        last_moved = np.inf  # the best value when a relocation was last tried
        move_away = False  # whether to move a knot away from its spans next
        starts = self._starts()
        try:
            restart = 0  # the perturbed and drawn starts so far
            for run in itertools.count():
                if finishing and run >= len(starts) and best[1] is not None \
                        and best[0] >= last_moved and not move_away \
                        and start_share() < FINISH_ITERATIONS * (problem.n_knots + 2):
                    finishing = False  # once; the starts go on with anything left
                    groups = best[2]
                    finish(best[1].copy())
                if evaluator.remaining <= 0 or (self.only_initial and run >= 1) or (
                        self.restarts is not None and run >= len(starts) + self.restarts):
                    break
                if run < len(starts):
                    z0, groups = starts[run]
                elif best[1] is not None and best[0] < last_moved:
                    last_moved, move_away = best[0], True
                    z0, groups = relocated(best[1], best[2])
                elif best[1] is not None and move_away:  # that gained nothing: farther
                    move_away = False
                    z0, groups = relocated(best[1], best[2], away=True)
                elif best[1] is not None and restart % 3 == 0:
                    scale = self.perturbation * 2.0 ** (restart // 3 % 4 - 1)
                    z0 = best[1] + self.rng.normal(0.0, scale, best[1].size)
                    groups = best[2]
                    restart += 1
                elif best[1] is not None and restart % 3 == 1:  # one knot moved anywhere
                    knots = np.repeat(knots_from_log_spans(best[1], bounds)[0], best[2])
                    knots[self.rng.integers(knots.size)] = self.rng.uniform(*bounds)
                    z0, groups = _grouped(np.sort(knots), bounds)
                    restart += 1
                else:  # spans drawn uniformly (a flat Dirichlet): anywhere in the range
                    z0 = np.log(self.rng.exponential(size=problem.n_knots + 1))
                    z0 = z0[1:] - z0[0]
                    groups = np.ones(problem.n_knots, dtype=np.int64)
                    restart += 1
                share, before = start_share(), evaluator.remaining
                reached = solve(z0, share)
                for _ in range(REPAIRS if merge is None else 0):  # knots run together: one moved
                    left = share - (before - evaluator.remaining)  # within the start's share
                    if reached is None or not collapsed(reached) \
                            or left < 2 * (problem.n_knots + 2):
                        break
                    reached = solve(relocated(reached, groups)[0], left - problem.n_knots)
                if merge is not None and reached is not None:
                    merge_and_solve(z0, reached)
        except BudgetExhausted:
            pass


def _widened(z: np.ndarray) -> np.ndarray:
    """The log spans ``z`` with every span at least ``PARTED_SPAN`` times the mean span (the
    others scaled down to make room): two knots run together (a span near 0, its log near
    minus infinity) would stay together in the solve's steps."""
    spans = np.maximum(softmax(np.concatenate(([0.0], z))), PARTED_SPAN / (z.size + 1))
    return np.log(spans[1:]) - np.log(spans[0])


def _grouped(knots: np.ndarray, bounds: tuple[float, float]
             ) -> tuple[np.ndarray, np.ndarray]:
    """Sorted knots (a value repeated: a multiple knot) as the log spans of the distinct knots
    and their multiplicities."""
    distinct, counts = np.unique(knots, return_counts=True)
    return log_spans_from_knots(distinct, bounds), counts
