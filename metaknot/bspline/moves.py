"""Exact delta evaluation of local knot moves.

A local search, a (1+1) EA or knot insertion/removal evaluates candidates that differ from one
incumbent by a single knot: a bit of a mask flipped, a knot shifted to another data point or
position, one knot inserted or removed. Such a move changes the basis functions on only about
``2p + 2`` knot spans, yet a full fit costs O(N p^2). A :class:`MoveEvaluator` caches, for its
incumbent, the Givens factorization of the data rows swept from the left up to every knot and
from the right down to every knot (one sweep each way, O(N p^2) once). A candidate is then
scored by rotating only the rows of the changed spans between the cached left and right
states: the SSE is exact (it is the same least-squares problem, orthogonally transformed), not
an approximation.

Moves are given either as what they replace (:meth:`MoveEvaluator.evaluate_replacements`:
the incumbent's knots ``i:j`` by new ones; :func:`bit_flips` builds them for masks) or as the
whole candidates they make (:meth:`MoveEvaluator.evaluate`: the changed block is found by
comparing knot vectors, O(K) per candidate). Changes of several neighbouring knots work too.

Infeasible knots (out of range, coincident, too many, Schoenberg-Whitney) are rejected by the
same checks as the full kernel, the Schoenberg-Whitney matching resumed from the incumbent's.
A merged candidate is reported feasible only with a certificate: ``[left final rows; merged
rows; right final rows]`` is a square factor of the candidate's normal matrix, block
triangular around the merged block, its outer blocks parts of the incumbent's factors;
bounding the inverse of each block bounds the candidate's condition number, and the full
kernel's numerical-singularity tests (condition number above ``COND_LIMIT``) cannot fail below
half that bound. The full fit decides:

* a candidate whose bound is not below half the limit (dense knots of degree 4-5 often are not;
  the kernel's own tests then decide whether it is numerically singular);
* a change spanning more than ``max_window_rows`` data rows.

The maximum deviation needs the control points everywhere: they are solved from the merged
block outwards through the incumbent's final forward rows (left) and backward rows (right),
O(n p) without any rotation, and every point's deviation follows from its cached basis values
(recomputed only in the window).

The result is a :class:`BatchFit` identical to the batched evaluator's (SSE to rounding) plus,
per candidate, the path that decided it.

Closed curves have :class:`PeriodicMoveEvaluator`, behind the same interface: the circle is cut
at a few breakpoints and the same forward and backward states are cached from each cut, the
factor being the closed fit's (a band plus wrap-around columns, :mod:`._moves`); the same
certificate rule holds against the closed fit's singularity test.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..budget import add_fits
from ..validate import is_integer
from . import _kernel, _moves
from .fit import BatchFit, Infeasibility, _prepare
from .knots import _offsets, _periodic_knots, check_multiplicity

__all__ = ["PATH_CHECKS", "PATH_DELTA", "PATH_FULL", "MoveEvaluator", "PeriodicMoveEvaluator",
           "bit_flips", "bound_to"]

PATH_DELTA = _moves.PATH_DELTA
PATH_CHECKS = _moves.PATH_CHECKS
PATH_FULL = _moves.PATH_FULL
_NO_MOVES = (np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64))


def _as_int64(values: ArrayLike, name: str) -> np.ndarray:
    """``values`` as a contiguous int64 array, or a ``ValueError`` naming ``name`` unless they
    are whole numbers (a cast would truncate 2.5 to 2: another candidate, silently)."""
    arr = np.asarray(values)
    if arr.dtype != np.int64:
        if arr.dtype.kind not in "iu" and arr.size and (
                arr.dtype.kind != "f" or not np.array_equal(arr, np.round(arr))):
            raise ValueError(f"{name} must be integers; got {arr.dtype} {arr.tolist()!r:.80}")
        arr = arr.astype(np.int64)
    return np.ascontiguousarray(arr)


def bound_to(evaluator: MoveEvaluator | None, u: ArrayLike, points: ArrayLike,
             interior_knots: np.ndarray, degree: int, *, closed: bool = False,
             max_multiplicity: int = 1) -> MoveEvaluator | None:
    """``evaluator`` moved to ``interior_knots`` (a new one if it is None: a
    :class:`PeriodicMoveEvaluator` if ``closed``), or None if those knots cannot be fitted
    (their candidates must then be fitted in full)."""
    try:
        if evaluator is None:
            kind = PeriodicMoveEvaluator if closed else MoveEvaluator
            return kind(u, points, interior_knots, degree, max_multiplicity=max_multiplicity)
        evaluator.rebind(interior_knots)
        return evaluator
    except ValueError:
        return None


def bit_flips(u: ArrayLike, mask: ArrayLike, bits: ArrayLike, *, closed: bool = False
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Replacements (for :meth:`MoveEvaluator.evaluate_replacements`) that flip the given
    bits of a 0/1 mask over the candidate data points (``u[1:-1]``, or ``u[1:]`` on a
    ``closed`` curve): a set bit removes its knot, a clear bit inserts ``u[bit + 1]``. Returns
    ``(starts, stops, inserted, offsets)``."""
    u = np.asarray(u, dtype=np.float64)
    mask = np.asarray(mask)
    if mask.dtype != bool and not np.isin(mask, (0, 1)).all():
        raise ValueError("mask must contain only 0 and 1")
    mask = mask.astype(bool)
    bits = _as_int64(bits, "bits")
    n_var = u.size - (1 if closed else 2)
    if mask.shape != (n_var,):
        raise ValueError(f"mask must have shape ({n_var},); got {mask.shape}")
    if bits.ndim != 1 or (bits < 0).any() or (bits >= mask.size).any():
        raise ValueError(f"bits must be indices into the mask, 0..{mask.size - 1}")
    rank = np.concatenate(([0], np.cumsum(mask)))[bits]  # knots before each bit
    on = mask[bits]
    return rank, rank + on, u[bits[~on] + 1], _offsets(~on)


class MoveEvaluator:
    """Scores of candidates near one incumbent, by exact delta evaluation.

    Parameters
    ----------
    u, points
        Parameter values ``(N,)`` and data points ``(N, d)`` (open curves).
    interior_knots
        The incumbent's interior knots (strictly increasing, inside the parameter range, a
        feasible fit).
    degree
        Spline degree, 1..5.
    max_multiplicity
        How often an interior knot may repeat, 1 (distinct knots, the default) to the degree:
        the incumbent and the candidates as the batched evaluator takes them with that
        ``max_multiplicity`` (a move may then raise or lower a knot's multiplicity).
    max_window_rows
        Largest number of data rows a change may span for the delta path; wider changes are
        fitted in full (default: N, so every change qualifies: a change spanning most rows
        costs about what a full fit does).

    Raises
    ------
    ValueError
        If the incumbent's knots cannot be fitted (the message names the reason).
    """

    def __init__(self, u: ArrayLike, points: ArrayLike, interior_knots: ArrayLike,
                 degree: int = 3, *, max_multiplicity: int = 1,
                 max_window_rows: int | None = None) -> None:
        self.u, self.q = self._prepare(u, points, degree)
        self.degree = int(degree)
        self.max_multiplicity = check_multiplicity(max_multiplicity, self.degree)
        m = self.u.size
        if max_window_rows is not None and (not is_integer(max_window_rows)
                                            or max_window_rows < 0):
            raise ValueError(f"max_window_rows must be a whole number >= 0; got "
                             f"{max_window_rows!r}")
        self.max_window_rows = m if max_window_rows is None else int(max_window_rows)
        self.rebind(interior_knots)

    def _prepare(self, u: ArrayLike, points: ArrayLike, degree: int
                 ) -> tuple[np.ndarray, np.ndarray]:
        """Parameters and points, checked, as the compiled code takes them."""
        u, q = _prepare(u, points, degree)
        # the mirrored problem of the backward sweep (parameters negated and reversed, points
        # reversed)
        self._u_mirror = np.ascontiguousarray(-u[::-1])
        self._q_mirror = np.ascontiguousarray(q[::-1])
        return u, q

    def rebind(self, interior_knots: ArrayLike) -> None:
        """Move the incumbent to ``interior_knots`` (one forward and one backward sweep)."""
        p, u, q = self.degree, self.u, self.q
        interior = np.ascontiguousarray(interior_knots, dtype=np.float64)
        if interior.ndim != 1:
            raise ValueError(f"interior_knots must be 1-D; got shape {interior.shape}")
        add_fits(1)
        code, t, _ = _kernel.fit_one(u, q, interior, p, self.max_multiplicity)
        if code != _kernel.FEASIBLE:
            raise ValueError(f"the incumbent cannot be fitted: {Infeasibility(code).message}")
        self.interior = interior.copy()
        self.t = t
        self.n = t.size - p - 1
        (self.spans, self.basis, self.row_start, self.match, self._iv, self._F, self._Fsse,
         self._Fcol, self._st_f, self._G, self._Gsse, self._Gcol, self._st_m,
         self._inverse_left, self._inverse_right, column_sums) = _moves.bind(
            u, q, self._u_mirror, self._q_mirror, t, p)
        self.sse = float(self._Fsse[self.n])
        # the certificate's bound of ||B||_2: sqrt(largest column sum) (entries >= 0, rows
        # summing to 1)
        self._gram_norm = float(np.sqrt(column_sums.max()))
        # largest column sum of the columns before c, and from c on (c = 0 .. n)
        self._col_before = np.concatenate(([0.0], np.maximum.accumulate(column_sums)))
        self._col_from = np.concatenate((np.maximum.accumulate(column_sums[::-1])[::-1], [0.0]))

    def evaluate(self, knots: np.ndarray, offsets: np.ndarray, *, max_deviation: bool = False
                 ) -> tuple[BatchFit, np.ndarray]:
        """Score candidates ``knots[offsets[b]:offsets[b + 1]]`` (sorted interior knots).

        Returns the :class:`BatchFit` the batched evaluator would give and, per candidate, the
        path that decided it (``PATH_DELTA``, ``PATH_CHECKS`` or ``PATH_FULL``).

        Raises
        ------
        ValueError
            If ``knots`` is not 1-D or ``offsets`` does not run from 0 to ``len(knots)``
            without decreasing.
        """
        knots, offsets = np.asarray(knots), np.asarray(offsets)
        if knots.ndim != 1:
            raise ValueError(f"knots must be a 1-D array; got shape {knots.shape}")
        if offsets.ndim != 1 or offsets.size < 1:  # the rest is checked in compiled code
            raise ValueError("offsets must run from 0 to len(knots) without decreasing")
        if knots.dtype != np.float64 or not knots.flags.c_contiguous:
            knots = np.ascontiguousarray(knots, dtype=np.float64)
        if offsets.dtype != np.int64 or not offsets.flags.c_contiguous:
            offsets = _as_int64(offsets, "offsets")
        return self._evaluate(knots, offsets, max_deviation, *_NO_MOVES)

    def _evaluate(self, knots: np.ndarray, offsets: np.ndarray, max_deviation: bool,
                  starts: np.ndarray, stops: np.ndarray) -> tuple[BatchFit, np.ndarray]:
        """:meth:`evaluate` (``starts`` empty) or :meth:`evaluate_replacements` of arrays
        already of the compiled code's types (float64 knots, int64 offsets, starts and stops,
        contiguous; their values are checked there)."""
        b = offsets.size - 1
        add_fits(b)
        sse = np.empty(b)
        max_dev = np.empty(b if max_deviation else 0)
        n_ctrl = np.empty(b, dtype=np.int64)
        reason = np.empty(b, dtype=np.int8)
        path = np.empty(b, dtype=np.int8)
        self._score(knots, offsets, starts, stops, max_deviation, sse, max_dev, n_ctrl, reason,
                    path)
        return BatchFit(sse, max_dev if max_deviation else None, n_ctrl, reason), path

    def _score(self, knots: np.ndarray, offsets: np.ndarray, starts: np.ndarray,
               stops: np.ndarray, max_deviation: bool, sse: np.ndarray, max_dev: np.ndarray,
               n_ctrl: np.ndarray, reason: np.ndarray, path: np.ndarray) -> None:
        """The compiled evaluation of :meth:`evaluate` into its output arrays."""
        _moves.evaluate_moves(
            self.u, self.q, self.degree, self.t, self._iv, self.n, self.spans, self.basis,
            self.row_start, self.match, self._F, self._Fsse, self._Fcol, self._G, self._Gsse,
            self._Gcol, self._st_f, self._st_m, self._col_before, self._col_from, self.sse,
            self._inverse_left, self._inverse_right, self._gram_norm, self.max_multiplicity,
            knots, offsets, starts, stops, self.max_window_rows, max_deviation, sse, max_dev,
            n_ctrl, reason, path)

    def evaluate_replacements(self, starts: ArrayLike, stops: ArrayLike, inserted: ArrayLike,
                              offsets: ArrayLike, *, max_deviation: bool = False
                              ) -> tuple[BatchFit, np.ndarray]:
        """Score moves given as replacements: move ``b`` replaces the incumbent's interior
        knots ``starts[b]:stops[b]`` (indices into :attr:`interior`) by the sorted knots
        ``inserted[offsets[b]:offsets[b + 1]]``.

        A flipped bit, an inserted, removed or shifted knot is one replacement
        (:func:`bit_flips` builds them for masks). The result is what :meth:`evaluate` gives
        for the candidates the moves make, without comparing whole knot vectors.

        Raises
        ------
        ValueError
            If the arrays do not match (one start and stop per move, offsets from 0 to
            ``len(inserted)``) or a start or stop lies outside ``0..len(interior)``.
        """
        starts = _as_int64(starts, "starts")
        stops = _as_int64(stops, "stops")
        k = self.interior.size
        if starts.ndim != 1 or starts.shape != stops.shape:
            raise ValueError("starts and stops must be 1-D arrays of the same length")
        if starts.size == 0:
            raise ValueError("no moves given")
        offsets = _as_int64(offsets, "offsets")
        if offsets.ndim != 1 or offsets.size != starts.size + 1:
            raise ValueError("offsets must have one entry more than there are moves")
        if (starts < 0).any() or (stops > k).any() or (starts > stops).any():
            raise ValueError(f"each move must replace knots start:stop with "
                             f"0 <= start <= stop <= {k}")
        inserted = np.asarray(inserted)
        if inserted.ndim != 1:
            raise ValueError(f"inserted must be a 1-D array; got shape {inserted.shape}")
        return self._evaluate(np.ascontiguousarray(inserted, dtype=np.float64), offsets,
                              max_deviation, starts, stops)


#: The most cuts a periodic incumbent is swept from (few breakpoints of a high degree).
MAX_CUTS = 6


def _cuts(m: int, degree: int) -> np.ndarray:
    """Breakpoints to cut the circle at, evenly spaced: enough that every change of one or two
    neighbouring knots lies inside one cut's sweeps (a cut holds changes ``2 degree``
    breakpoints or more from it), two at least and ``MAX_CUTS`` at most; none if no cut can
    hold such a change (too few breakpoints for the degree: every move is fitted in full)."""
    reach = m - 4 * degree  # the positions of a two-knot change one cut holds
    if reach <= 0:
        return np.empty(0, dtype=np.int64)
    count = min(MAX_CUTS, max(2, -(-m // reach)))
    return np.unique(np.arange(count) * m // count).astype(np.int64)


class PeriodicMoveEvaluator(MoveEvaluator):
    """:class:`MoveEvaluator` for closed curves: candidates near one incumbent periodic spline,
    scored as a closed :meth:`~metaknot.bspline.curve.Curve.evaluate_knots` scores them.

    The circle is cut at evenly spaced breakpoints (0 and one half a period on; more when
    there are few breakpoints for the degree); for each cut, the Givens factorization of the
    rows swept forwards and backwards from it is cached at every breakpoint, the wrap-around
    block (the ``degree`` columns both ends of the cut touch) with it. A change that lies, with
    ``2 degree`` breakpoints on either side, between the ends of one cut's sweeps is merged
    from that cut's states; the rest (changes wider than about half the circle) is fitted in
    full, as is a candidate the conditioning certificate cannot declare feasible (see
    :mod:`metaknot.bspline._moves`).

    Parameters
    ----------
    u, points
        Parameter values ``(N,)`` in [0, 1) (:func:`~metaknot.bspline.closed_parameterize`)
        and data points ``(N, d)`` of a closed outline.
    interior_knots
        The incumbent's breakpoints in (0, 1) (0 is always one), a feasible fit.
    degree, max_window_rows
        As for :class:`MoveEvaluator`.

    Raises
    ------
    ValueError
        If the incumbent's knots cannot be fitted (the message names the reason).
    """

    def _prepare(self, u: ArrayLike, points: ArrayLike, degree: int
                 ) -> tuple[np.ndarray, np.ndarray]:
        return _prepare(u, points, degree, closed=True)

    def rebind(self, interior_knots: ArrayLike) -> None:
        """Move the incumbent to ``interior_knots`` (a fit, then a forward and a backward sweep
        from each cut)."""
        p, u, q = self.degree, self.u, self.q
        interior = np.ascontiguousarray(interior_knots, dtype=np.float64)
        if interior.ndim != 1:
            raise ValueError(f"interior_knots must be 1-D; got shape {interior.shape}")
        t = _periodic_knots(interior, p, self.max_multiplicity)  # named if refused
        if (np.diff(interior) < 0).any():  # indexed as given: sorted
            raise ValueError("the incumbent cannot be fitted: "
                             f"{Infeasibility(_kernel.COINCIDENT_KNOTS).message}")
        m = interior.size + 1
        add_fits(1)
        if m > u.size:
            raise ValueError("the incumbent cannot be fitted: "
                             f"{Infeasibility(_kernel.TOO_MANY_CONTROL_POINTS).message}")
        coef = np.zeros((m, q.shape[1]))
        basis = np.empty((u.size, p + 1))
        spans = np.empty(u.size, dtype=np.int64)
        code, sse = _kernel.fit_closed(u, q, t, p, coef, basis, spans)
        if code != _kernel.FEASIBLE:
            raise ValueError(f"the incumbent cannot be fitted: {Infeasibility(code).message}")
        self.interior = interior.copy()
        self.t = t
        self.n = m
        self.sse = float(sse)
        self._max_dev = float(_kernel.deviation_from_basis(q, p, m, coef, basis, spans))
        self._cuts = _cuts(m, p)
        (self.spans, self.basis, self.row_start, column_sums, *self._states,
         self._inverse) = _moves.bind_closed(u, q, t, p, self._cuts)
        self._gram_norm = float(np.sqrt(column_sums.max()))

    def _score(self, knots, offsets, starts, stops, max_deviation, sse, max_dev, n_ctrl, reason,
               path):
        _moves.evaluate_closed_moves(
            self.u, self.q, self.degree, self.interior, self.spans, self.basis,
            self.row_start, self._cuts, *self._states, self._inverse, self._gram_norm,
            self.sse, self._max_dev, self.max_multiplicity, knots, offsets, starts, stops,
            self.max_window_rows, max_deviation, sse, max_dev, n_ctrl, reason, path)
