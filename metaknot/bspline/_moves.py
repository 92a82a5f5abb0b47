"""Compiled delta evaluation of local knot moves on open and closed curves (numba); see
:mod:`metaknot.bspline.moves`. Closed curves: the notes above :func:`bind_closed`.

Notation: ``t`` is the incumbent's clamped knot vector with ``n`` basis functions (columns);
data row ``j`` lies in knot span ``spans[j]`` (``t[k] <= u[j] < t[k + 1]``, the last point in
span ``n - 1``) and touches columns ``spans[j] - p .. spans[j]``.

*Forward state* ``c`` (``p <= c <= n``): the data rows of spans ``< c`` rotated, in order, into
a banded triangular factor by Givens rotations. Columns below ``c - p`` are final (no row of a
later span touches them), so the state that matters to later rows is the ``p`` rows of the
factor for columns ``c - p .. c - 1`` (their entries lie in those columns too), their right-hand
sides and the squared residual so far. *Backward state* ``c``: the same for the rows of spans
``>= c``, rotated from the right end with the columns counted from the right; its active rows
are again columns ``c - p .. c - 1``.

States are kept in the flat layout of the generated row loop (:mod:`._codegen`):
``W = 1 + p + d`` entries per column (reciprocal weight, the unit triangular row's ``p``
off-diagonal entries, the right-hand sides), ``dinv = EMPTY`` for a column no row has reached.
The backward sweep runs the same loop on the mirrored problem (parameters and knots negated and
reversed, points reversed: column ``c`` is the mirror's ``n - 1 - c``), with the rows taken by
index, so a point on a knot belongs to the same side in both sweeps.

A move changes the knots between two unchanged ends. The rows of spans ``< cL`` keep their
basis values and columns (counted from the left), those of spans ``>= cR`` keep theirs (counted
from the right). The candidate's SSE is then exactly::

    forward residual at cL + backward residual at cR
    + residual of [forward active rows; window rows (new basis); backward active rows]

the last a small banded least-squares problem over columns ``cL - p .. cR' - 1`` (``cR'`` is
``cR`` counted in the candidate's columns). The final rows of either factor are satisfied
exactly (their pivot column appears in no other row), so they add nothing.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._kernel import (
    COINCIDENT_KNOTS,
    COND_LIMIT,
    FEASIBLE,
    KNOT_OUT_OF_RANGE,
    PIVOT_RATIO,
    SCHOENBERG_WHITNEY,
    SINGULAR,
    TOO_MANY_CONTROL_POINTS,
    _fit_ws,
    _score,
    _score_workspaces,
    basis_at,
    empty_state,
    fit_workspaces,
    givens,
    periodic_distance2,
    reciprocals,
    repeated_beyond,
    rotate_entries,
)
from ._moves_rows import EMPTY, absorb, frame, sweep, window
from ._rows import deviation

# How each candidate was decided (``path`` output).
PATH_DELTA = 0  # merged from the cached states
PATH_CHECKS = 1  # infeasible by the knot checks alone (no fit needed on either path)
PATH_FULL = 2  # fitted in full (too wide a change, or a verdict the delta path cannot certify)


# The delta path reports a candidate feasible only if an upper bound of the condition number
# the full kernel tests is below this fraction of its limit (room for rounding in the bound);
# other candidates are fitted in full, so the kernel's own tests decide them.
CERTIFY = 0.5


# A column whose reciprocal weight is still above this was reached by no row (see EMPTY).
UNREACHED = EMPTY * 1e-10

# An open factor has no wrap triangle, nor states of one.
NO_TRIANGLE = np.zeros(0)
NO_TRIANGLES = np.zeros((0, 0))


@njit(cache=True, inline='always')
def check_offsets(offsets, size):
    """Raise unless ``offsets`` runs from 0 to ``size`` without decreasing."""
    n_cand = offsets.size - 1
    bad = offsets[0] != 0 or offsets[n_cand] != size
    for b in range(n_cand):
        bad |= offsets[b + 1] < offsets[b]
    if bad:
        raise ValueError("offsets must run from 0 to len(knots) without decreasing")


@njit(cache=True, inline='always', error_model='numpy')
def candidate_reciprocals(t2, t, iv_t, p, iv, lo_start, lo_stop, e, tail, shift):
    """:func:`reciprocals` of the candidate's knots ``t2`` for ``lo_start <= lo < lo_stop``,
    copied from the incumbent's table ``iv_t`` where both knots are the incumbent's: below
    ``e`` (the first changed knot) and from ``tail`` on (``t2[i] = t[i - shift]``); only the
    differences that involve a changed knot are divided."""
    size2 = t2.size
    size = t.size
    for j in range(1, p + 1):
        for lo in range(max(lo_start, 0), min(lo_stop, size2 - j)):
            if lo + j < e:
                iv[(j - 1) * size2 + lo] = iv_t[(j - 1) * size + lo]
            elif lo >= tail:
                iv[(j - 1) * size2 + lo] = iv_t[(j - 1) * size + lo - shift]
            else:
                gap = t2[lo + j] - t2[lo]
                iv[(j - 1) * size2 + lo] = 1.0 / gap if gap > 0.0 else 0.0


@njit(cache=True, inline='always', error_model='numpy')
def inverse_norm_bound(st, width, p, size, v, wv, tri):
    """Upper bound of the 2-norm of ``R^-1`` for the flat factor's first ``size`` columns
    (``R = diag(1 / sqrt(dinv)) rb``; ``inf`` if a column was reached by no row), ``width``
    entries per column. With ``tri`` not empty, a closed factor in the layout of the frames
    (:func:`_rotate_wide`): each column's ``p`` wrap-around entries after its band entries, and
    the wrap triangle ``tri`` (``p`` more columns of ``width - p`` entries) after the band;
    without it, the band alone.

    ``|rb^-1| <= M^-1`` elementwise for the comparison matrix ``M`` of the unit triangular
    ``rb``, so its infinity and 1-norms are at most the largest entries of ``M^-1 e`` and
    ``M^-T e``; ``||A||_2 <= sqrt(||A||_1 ||A||_inf)``, and the diagonal scaling adds at most
    ``max sqrt(dinv)``. ``v`` and ``wv`` are workspaces of at least ``size + p`` entries.
    """
    wrap = p if tri.size > 0 else 0
    tw = width - p  # a triangle column's entries
    v_max = 0.0
    w_max = 0.0
    d_max = 0.0
    for k in range(wrap - 1, -1, -1):  # v = M^-1 e: the triangle's rows, then the band's
        di = tri[k * tw]
        if di >= UNREACHED:
            return np.inf
        d_max = max(d_max, di)
        acc = 1.0
        for a in range(p - 1 - k, 0, -1):
            acc += abs(tri[k * tw + a]) * v[size + k + a]
        v[size + k] = acc
        v_max = max(v_max, acc)
    for i in range(size - 1, -1, -1):
        di = st[i * width]
        if di >= UNREACHED:
            return np.inf
        d_max = max(d_max, di)
        acc = 1.0
        for a in range(min(p, size - 1 - i), 0, -1):
            acc += abs(st[i * width + a]) * v[i + a]
        for k in range(wrap):
            acc += abs(st[i * width + 1 + p + k]) * v[size + k]
        v[i] = acc
        v_max = max(v_max, acc)
    for j in range(size):  # w = M^-T e
        acc = 1.0
        for a in range(min(p, j), 0, -1):
            acc += abs(st[(j - a) * width + a]) * wv[j - a]
        wv[j] = acc
        w_max = max(w_max, acc)
    for k in range(wrap):
        acc = 1.0
        for i in range(size):
            acc += abs(st[i * width + 1 + p + k]) * wv[i]
        for a in range(1, k + 1):
            acc += abs(tri[(k - a) * tw + a]) * wv[size + k - a]
        wv[size + k] = acc
        w_max = max(w_max, acc)
    return math.sqrt(v_max * w_max * d_max)


@njit(cache=True, inline='always')
def _substitute(st, o, p, d, wrap, reach, step, x, at):
    """Back substitution of one row of a merged factor (``st[o:]``: the unit triangular row's
    ``p`` band entries, its ``wrap`` wrap-around entries, its right-hand side): ``x[at]``
    from its ``reach`` band entries (entry ``a`` the unknown ``x[at + a * step]``) and its
    wrap-around entries (the unknowns ``x[:wrap]``)."""
    for c in range(d):
        acc = st[o + 1 + p + wrap + c]
        for a in range(reach, 0, -1):
            acc -= st[o + a] * x[at + a * step, c]
        for k in range(wrap):
            acc -= st[o + 1 + p + k] * x[k, c]
        x[at, c] = acc


@njit(cache=True)
def _merged_coefficients(stm, tri, nbm, final_f, final_m, nb, p, d, wrap, KL, KR, delta, x):
    """Control points ``x`` of a merged candidate: the ``wrap`` wrap-around unknowns of a
    closed curve first (none on an open one), then the band columns (the incumbent has
    ``nb``), counted in the candidate. Solved from the merged factor (the wrap triangle
    ``tri``, then ``stm``: band columns ``KL - p ..``, ``nbm`` of them) outwards: the
    incumbent's final forward rows (``final_f``) leftwards and its final mirrored rows
    (``final_m``, band column ``P`` their ``nb - 1 - P``) rightwards, ``+ delta`` right of
    the change. Unit triangular, square-root-free rows of ``1 + p + wrap + d`` entries."""
    width = 1 + p + d
    wide = width + wrap
    for k in range(wrap - 1, -1, -1):  # the wrap triangle
        for c in range(d):
            acc = tri[k * width + p + 1 + c]
            for a in range(1, p - k):
                acc -= tri[k * width + a] * x[k + a, c]
            x[k, c] = acc
    base = KL - p
    for i in range(nbm - 1, -1, -1):
        _substitute(stm, i * wide, p, d, wrap, min(p, nbm - 1 - i), 1, x, wrap + base + i)
    for pos in range(base - 1, -1, -1):
        _substitute(final_f, pos * wide, p, d, wrap, min(p, nb - 1 - pos), 1, x, wrap + pos)
    for P in range(KR, nb):
        _substitute(final_m, (nb - 1 - P) * wide, p, d, wrap, min(p, P), -1, x,
                    wrap + P + delta)


@njit(cache=True, inline='always', error_model='numpy')
def sw_local(u, t2, p, n2, match, first, tail, shift, keep):
    """The Schoenberg-Whitney check of ``t2`` (the check the full kernel makes) by a greedy
    matching: each basis function gets the first free data row inside its support; False where
    one finds none. With ``keep`` (an incumbent's: ``first = shift = 0``, ``tail = n2``), the
    row of function ``i`` is kept in ``match[i]``.

    Given the incumbent's matching ``match``: functions below ``first`` have the incumbent's
    supports, so the greedy matching agrees there; it is resumed at ``first``. Functions from
    ``tail`` on have the supports of the incumbent's functions ``i - shift``: once the resumed
    matching gives one of them a row no later than the incumbent's, every later function is
    matched too (the greedy choice is monotone in the row it starts from), and the check stops
    early.
    """
    m = u.size
    j = match[first - 1] + 1 if first > 0 else 0
    for i in range(first, n2):
        lo = t2[i]
        hi = t2[i + p + 1]
        while j < m and not (u[j] > lo or (i == 0 and u[j] >= lo)):
            j += 1
        if j == m:
            return False
        if not (u[j] < hi or (i == n2 - 1 and u[j] <= hi)):
            return False
        if i >= tail and j <= match[i - shift]:
            return True
        if keep:
            match[i] = j
        j += 1
    return True


# _replaced's verdict on knots out of order, feasible so far: an open candidate is refused
# (COINCIDENT_KNOTS, as the batch evaluator refuses it), a closed one sorted, as the batch
# evaluator sorts it (no longer a local change: the full fit decides).
UNSORTED = -1


@njit(cache=True, inline='always', error_model='numpy')
def _changed_block(interior, knots, lo, hi):
    """The incumbent's interior knots ``start:stop`` that candidate ``knots[lo:hi]`` replaces
    (by its knots ``lo + start : hi - (k - stop)``): the common head and tail removed."""
    k = interior.size
    limit = min(k, hi - lo)
    # compared eight knots at a time (the compiler vectorises a block without an early
    # exit), then one at a time
    e = 0
    while e + 8 <= limit:
        differs = False
        for i in range(8):
            differs |= interior[e + i] != knots[lo + e + i]
        if differs:
            break
        e += 8
    while e < limit and interior[e] == knots[lo + e]:
        e += 1
    f = 0
    while f + 8 <= limit - e:
        differs = False
        for i in range(8):
            differs |= interior[k - 1 - f - i] != knots[hi - 1 - f - i]
        if differs:
            break
        f += 8
    while f < limit - e and interior[k - 1 - f] == knots[hi - 1 - f]:
        f += 1
    return e, k - f, lo + e, hi - f


@njit(cache=True, inline='always', error_model='numpy')
def _replaced(own, head, trail, start, stop, inserted, out, lo, hi, max_mult):
    """Fill ``out`` with the incumbent's knots ``own`` (``head`` entries before its interior
    knots, ``trail`` after them: an open curve's clamped knot vector, a closed curve's interior
    breakpoints alone) whose interior knots ``start:stop`` are replaced by ``inserted``; return the
    batch evaluator's verdict, only the inserted knots checked (the others are the
    incumbent's): KNOT_OUT_OF_RANGE for a replacement outside the interior knots or an
    inserted knot outside ``(lo, hi)`` (NaN included), then ``UNSORTED`` for knots out of
    order, COINCIDENT_KNOTS for a run of more than ``max_mult`` equal interior knots, else
    FEASIBLE. The one check of the moves' knots, open and closed."""
    if start > stop or stop > own.size - head - trail:
        return KNOT_OUT_OF_RANGE
    e = head + start
    tail = e + inserted.size
    shift = out.size - own.size
    for i in range(e):  # the head, the inserted knots, the tail
        out[i] = own[i]
    for i in range(inserted.size):
        out[e + i] = inserted[i]
    for i in range(tail, out.size):
        out[i] = own[i - shift]
    for i in range(inserted.size):
        x = inserted[i]
        if not (x > lo and x < hi):  # also catches NaN
            return KNOT_OUT_OF_RANGE
    first, end = head + 1, out.size - trail  # the knots with an interior one before them
    for i in range(max(e, first), min(tail + 1, end)):
        if out[i] <= out[i - 1]:
            if out[i] < out[i - 1]:
                return UNSORTED
            if max_mult == 1:
                return COINCIDENT_KNOTS
    if max_mult == 1:
        return FEASIBLE
    return _runs_verdict(out, max(e - max_mult - 1, first), min(tail + max_mult + 2, end),
                         max_mult, FEASIBLE)


@njit(cache=True, inline='always')
def _runs_verdict(knots, lo, hi, max_mult, verdict):
    """``COINCIDENT_KNOTS`` if sorted knots ``knots[lo - 1:hi]`` repeat one more than
    ``max_mult`` times, else ``verdict`` (a caller keeps the range to interior knots)."""
    return COINCIDENT_KNOTS if repeated_beyond(knots[lo - 1 : hi], max_mult) else verdict


@njit(cache=True, error_model='numpy')
def evaluate_moves(u, q, p, t, iv_t, n, spans, basis, row_start, match, F, Fsse, Fcol, G, Gsse,
                   Gcol, st_f, st_m, col_before, col_from, base_sse, inverse_left, inverse_right,
                   gram_norm, max_mult, knots, offsets, starts, stops, max_window_rows,
                   want_max_dev, sse_out, max_dev_out, n_ctrl_out, reason_out, path_out):
    """Score candidates (interior knots ``knots[offsets[b]:offsets[b + 1]]``, each repeated at
    most ``max_mult`` times) by merging the incumbent's cached states; fall back to the full
    fit where the cheap path cannot decide.
    With ``starts`` not empty, candidate ``b`` is instead the incumbent with its interior knots
    ``starts[b]:stops[b]`` replaced by ``knots[offsets[b]:offsets[b + 1]]`` (a move: no
    comparison of whole knot vectors is then needed).

    Outputs per candidate: SSE, maximum deviation (when ``want_max_dev``), control points,
    reason code and the path that decided it. The maximum deviation of a merged candidate
    comes from its control points, solved from the merged block outwards through the final
    rows of the incumbent's forward factor (``st_f``: columns left of the block) and of the
    mirror's (``st_m``: columns right of it), and the incumbent's basis values for the rows
    outside the window.
    """
    m, d = q.shape
    w = 1 + p + d
    n_cand = offsets.size - 1
    check_offsets(offsets, knots.size)
    n_max = m + p + 1  # a candidate with more columns than points is rejected before a fit
    t2 = np.empty(n_max + p + 1)
    iv = np.zeros(p * (n_max + p + 1))
    coef = np.empty((n_max, d))
    basis_ws = np.empty((m if want_max_dev else 0, p + 1))  # the full fits' rows
    spans_ws = np.empty(m if want_max_dev else 0, dtype=np.int64)
    rows_max = n_max + p
    stl = np.empty(rows_max * w)
    colsum = np.empty(rows_max)
    bound_v = np.empty(rows_max)
    bound_w = np.empty(rows_max)
    window_basis = np.empty((m if want_max_dev else 0, p + 1))
    window_span = np.empty(m if want_max_dev else 0, dtype=np.int64)
    own = t[p + 1 : n]  # the incumbent's interior knots
    replacing = starts.size > 0
    for b in range(n_cand):
        lo, hi = offsets[b], offsets[b + 1]
        if replacing:
            n2 = n - (stops[b] - starts[b]) + hi - lo
        else:
            n2 = hi - lo + p + 1
        n_ctrl_out[b] = n2
        sse_out[b] = np.inf
        if want_max_dev:
            max_dev_out[b] = np.inf
        path_out[b] = PATH_CHECKS
        if n2 > m:
            reason_out[b] = TOO_MANY_CONTROL_POINTS
            continue
        tb = t2[: n2 + p + 1]
        if replacing:
            start, stop = starts[b], stops[b]
        else:  # the incumbent's knots that the candidate replaces
            start, stop, lo, hi = _changed_block(own, knots, lo, hi)
        inserted = knots[lo:hi]
        code = _replaced(t, p + 1, p + 1, start, stop, inserted, tb, u[0], u[m - 1], max_mult)
        interior = tb[p + 1 : n2]
        if code != FEASIBLE:
            reason_out[b] = COINCIDENT_KNOTS if code == UNSORTED else code
            continue
        e = p + 1 + start  # the first changed knot, and the length of the common tail
        f = tb.size - e - inserted.size
        delta = n2 - n
        # functions below e - p - 1 keep their supports, those from t.size - f + delta on
        # (counted in t2) keep the supports of the incumbent's functions shifted by delta
        if not sw_local(u, tb, p, n2, match, max(e - p - 1, 0), t.size - f + delta, delta,
                        False):
            reason_out[b] = SCHOENBERG_WHITNEY
            continue
        c_left = max(e - p, p)
        c_right = min(t.size - f + p - 1, n)
        if not replacing and start == stop and inserted.size == 0:  # the incumbent itself
            if not want_max_dev:
                reason_out[b] = FEASIBLE
                sse_out[b] = base_sse
                path_out[b] = PATH_DELTA
                continue
            c_left = max(n - p, p)  # merge the last spans again (their rows are unchanged)
            c_right = n
        c_right2 = c_right + delta
        if row_start[c_right] - row_start[c_left] <= max_window_rows:
            size = c_right2 - c_left + p
            for i in range(p * w):  # the forward state's columns, then empty ones
                stl[i] = F[c_left, i]
            empty_state(stl[p * w :], size - p, w)
            for i in range(size):
                colsum[i] = 0.0
            for a in range(p):
                colsum[a] += Fcol[c_left, a]
                colsum[size - p + a] += Gcol[c_right, a]
            # the basis of the window's spans c_left .. c_right2 - 1 reads these reciprocals
            candidate_reciprocals(tb, t, iv_t, p, iv, c_left - p + 1, c_right2, e, tb.size - f,
                                  delta)
            res, _ = window(p, d, u, q, tb, iv, row_start[c_left], row_start[c_right], c_left,
                            n2 - 1, c_left - p, stl, colsum, window_basis, window_span)
            # the backward state's rows, as weighted rows
            res += absorb(p, d, stl, size - p, G, c_right, UNREACHED)
            # certify the full kernel's verdict (feasible) by bounding the condition number:
            # [left final rows; merged rows; right final rows] is a square factor S of the
            # candidate's normal matrix, block triangular around the merged block, with the
            # left and right blocks parts of the incumbent's factors (see the module notes)
            inv_m = inverse_norm_bound(stl, w, p, size, bound_v, bound_w, NO_TRIANGLE)
            inv_s = inv_m + inverse_left * (1.0 + gram_norm * inv_m) \
                + inverse_right * (1.0 + gram_norm * inv_m)
            # ||B'||_2^2 <= largest column sum (entries >= 0, rows summing to 1); the columns
            # outside the merged block keep the incumbent's sums
            largest_sum = max(col_before[c_left - p], col_from[c_right])
            for i in range(size):
                largest_sum = max(largest_sum, colsum[i])
            # the kernel's condition number is in the infinity norm, of the upper triangular R':
            # ||R'||_inf <= sqrt(p + 1) ||R'||_2 and ||R'^-1||_inf <= sqrt(n) ||R'^-1||_2
            kappa = math.sqrt((p + 1) * n2) * math.sqrt(largest_sum) * inv_s
            if kappa <= CERTIFY * COND_LIMIT:
                reason_out[b] = FEASIBLE
                sse_out[b] = Fsse[c_left] + Gsse[c_right] + res
                path_out[b] = PATH_DELTA
                if want_max_dev:
                    c = coef[:n2]
                    _merged_coefficients(stl, NO_TRIANGLE, size, st_f, st_m, n, p, d, 0,
                                         c_left, c_right, delta, c)
                    worst = 0.0
                    for j in range(m):
                        if j < row_start[c_left] or j >= row_start[c_right]:
                            first = spans[j] - p + (0 if j < row_start[c_left] else delta)
                            hj = basis[j]
                        else:
                            first = window_span[j] - p
                            hj = window_basis[j]
                        worst = max(worst, periodic_distance2(q, j, hj, first, c, n2, p))
                    max_dev_out[b] = math.sqrt(worst)
                continue
        # the full fit decides, as the batched evaluator fits it (its workspaces allocated
        # here: most calls need none, and a call's allocations weigh on a move of 1-2 us)
        path_out[b] = PATH_FULL
        iv_full, st_full = fit_workspaces(n2, p, d)
        code, value = _fit_ws(u, q, interior, p, tb, coef[:n2], basis_ws, spans_ws, iv_full,
                              st_full, max_mult)
        reason_out[b] = code
        sse_out[b] = value
        if want_max_dev and code == FEASIBLE:
            max_dev_out[b] = deviation(q, p, coef[:n2], basis_ws, spans_ws)


@njit(cache=True)
def bind(u, q, u_mirror, q_mirror, t, p):
    """Everything delta evaluation caches for the incumbent with knot vector ``t`` (a feasible
    fit): spans and basis values of the rows, ``row_start``, the Schoenberg-Whitney matching,
    the reciprocal table, the forward states (``F``, ``Fsse``, ``Fcol``) and final factor,
    the backward states (``G``, ``Gsse``, ``Gcol``) and the mirror's final factor, the bounds
    of both factors' inverses and the column sums. One forward and one backward sweep."""
    m, d = q.shape
    w = 1 + p + d
    n = t.size - p - 1
    spans = np.empty(m, dtype=np.int64)
    basis = np.empty((m, p + 1))
    row_start = np.zeros(n + 1, dtype=np.int64)  # the first row of a span >= c
    j = 0
    for c in range(p + 1, n):
        while j < m and u[j] < t[c]:
            j += 1
        row_start[c] = j
    row_start[n] = m
    match = np.empty(n, dtype=np.int64)
    sw_local(u, t, p, n, match, 0, n, 0, True)
    iv = np.zeros(p * t.size)
    reciprocals(t, p, iv, 0, t.size)
    steps = n - p + 1
    blocks = np.arange(steps)
    F = np.empty((n + 1, p * w))
    Fsse = np.empty(n + 1)
    Fcol = np.empty((n + 1, p))
    st_f = np.empty(n * w)
    empty_state(st_f, n, w)
    column_sums = np.zeros(n)
    sweep(p, d, u, q, t, iv, p, n - 1, row_start[p:], blocks, st_f, NO_TRIANGLE, F[p:],
          NO_TRIANGLES, Fsse[p:], Fcol[p:], column_sums, basis, spans, 0.0)
    # the backward sweep: the same loop on the mirrored problem (column c is the mirror's
    # n - 1 - c); state c, after the rows j >= row_start[c], is saved at step n - c, its
    # columns c - 1 .. c - p being the mirror's n - c .. n - c + p - 1
    t_mirror = np.empty(t.size)
    for i in range(t.size):
        t_mirror[i] = -t[t.size - 1 - i]
    iv_mirror = np.zeros(p * t.size)
    reciprocals(t_mirror, p, iv_mirror, 0, t.size)
    bounds = np.empty(steps, dtype=np.int64)
    for s in range(steps):
        bounds[s] = m - row_start[n - s]
    states = np.empty((steps, p * w))
    sse = np.empty(steps)
    mirror_col = np.empty((steps, p))
    st_m = np.empty(n * w)
    empty_state(st_m, n, w)
    sweep(p, d, u_mirror, q_mirror, t_mirror, iv_mirror, p, n - 1, bounds, blocks, st_m,
          NO_TRIANGLE, states, NO_TRIANGLES, sse, mirror_col, np.zeros(n), basis[:0], spans[:0],
          0.0)
    G = np.empty((n + 1, p * w))
    Gsse = np.empty(n + 1)
    Gcol = np.empty((n + 1, p))
    for s in range(steps):
        c = n - s
        G[c, :] = states[s]
        Gsse[c] = sse[s]
        for a in range(p):
            Gcol[c, a] = mirror_col[s, p - 1 - a]
    work_v = np.empty(n)
    work_w = np.empty(n)
    inverse_left = inverse_norm_bound(st_f, w, p, n, work_v, work_w, NO_TRIANGLE)
    inverse_right = inverse_norm_bound(st_m, w, p, n, work_v, work_w, NO_TRIANGLE)
    return (spans, basis, row_start, match, iv, F, Fsse, Fcol, st_f, G, Gsse, Gcol, st_m,
            inverse_left, inverse_right, column_sums)


@njit(cache=True)
def mask_replacements(u, near, masks):
    """Each row of ``masks`` (over the interior points ``u[1:-1]``: 0/1, or the multiplicity of
    a knot at each point) as a replacement of the knots of the mask ``near``: the incumbent's
    knots between its first and last differing entry by the row's knots there. Returns
    ``(starts, stops, inserted, offsets)``."""
    n_cand, n_var = masks.shape
    rank = np.zeros(n_var + 1, dtype=np.int64)  # knots of near before each bit
    for i in range(n_var):
        rank[i + 1] = rank[i] + near[i]
    starts = np.zeros(n_cand, dtype=np.int64)
    stops = np.zeros(n_cand, dtype=np.int64)
    lo = np.zeros(n_cand, dtype=np.int64)
    hi = np.zeros(n_cand, dtype=np.int64)
    offsets = np.zeros(n_cand + 1, dtype=np.int64)
    for b in range(n_cand):
        first = 0
        while first < n_var and masks[b, first] == near[first]:
            first += 1
        last = n_var - 1
        while last > first and masks[b, last] == near[last]:
            last -= 1
        if first == n_var:  # the incumbent itself: an empty replacement
            lo[b] = hi[b] = 0
        else:
            lo[b] = first
            hi[b] = last + 1
        starts[b] = rank[lo[b]]
        stops[b] = rank[hi[b]]
        count = 0
        for i in range(lo[b], hi[b]):
            count += masks[b, i]
        offsets[b + 1] = offsets[b] + count
    inserted = np.empty(offsets[n_cand])
    for b in range(n_cand):
        pos = offsets[b]
        for i in range(lo[b], hi[b]):
            for _ in range(masks[b, i]):
                inserted[pos] = u[i + 1]
                pos += 1
    return starts, stops, inserted, offsets


# --- closed curves --------------------------------------------------------------------------
#
# A periodic incumbent has ``m`` breakpoints ``b_0 = 0 < b_1 < ... < b_{m-1} < 1`` and the
# extended knot vector ``t`` of :func:`._kernel.extended_knots`; data row ``r`` lies in natural
# span ``spans[r]`` and touches the natural columns ``spans[r] .. spans[r] + p`` (mod ``m``).
#
# *Frames.* A frame cuts the circle at a breakpoint ``s`` and orders the columns as the closed
# fit (:func:`._kernel.solve_closed_into`) does for ``s = 0``: frame column ``c`` is natural
# column ``(s + p + c) mod m``, so the ``nb = m - p`` *band columns* come first and the ``p``
# *wrap columns* (natural ``s .. s + p - 1``) last; a row of frame span ``k`` (natural span
# ``(s + k) mod m``) touches the frame columns ``(k - p .. k) mod m``. The factor is the one of
# the fits: square-root-free rotations, a band plus the entries of each row in the wrap columns
# beyond it. A sweep carries those entries as ``p`` more right-hand sides and what the band
# leaves of a row goes into the wrap triangle (the generated ``frame`` loop; the rows of the
# first and last ``p`` spans, which touch the wrap columns themselves, by :func:`_rotate_wide`).
# The merge continues a forward state's sweep over the window and takes in the backward
# state's rows in the same layout, as the open merge does. The mirrored sweep
# runs the frame spans backwards with the band columns mirrored (``nb - 1 - c``), the wrap
# columns in place.
#
# *States* ``K`` of a frame: the forward state holds the rows of frame spans ``< K`` rotated,
# the mirrored one those of spans ``>= K``; each keeps its ``p`` active band rows (band columns
# ``K - p .. K - 1``, mirrored for the backward state), the wrap triangle, the residual and the
# active columns' sums. A move changes the breakpoints between two unchanged ones; if
# ``p <= KL`` and ``KR <= nb`` (the change lies at least about ``2p`` spans from the cut) the
# candidate's SSE is exactly the two states' residuals plus that of [forward rows; window rows
# under the candidate's knots; backward rows], a small least-squares problem over the band
# columns ``KL - p .. KR' - 1`` and the wrap columns. Every incumbent is swept from two cuts or
# more (:func:`metaknot.bspline.moves._cuts`), so every change of one or two neighbouring knots
# lies inside one frame.
#
# *Certificate* (``docs/internals/kernel.md``): the open rule against the closed fit's pivot
# test. A merged candidate is reported feasible only when a bound of ``1 / sigma_min`` keeps
# every pivot above ``PIVOT_RATIO / CERTIFY`` times the largest; the full fit decides the rest.

@njit(cache=True, inline='always')
def _periodic_rows(u, q, first, u_out, q_out):
    """The data rows ``first, first + 1, ...`` (``u_out.size`` of them) counted on past the
    last: a row past it is row ``r - n``, one period later (its parameter plus 1)."""
    n = u.size
    for i in range(u_out.size):
        r = first + i
        u_out[i] = u[r] if r < n else u[r - n] + 1.0
        q_out[i] = q[r if r < n else r - n]


@njit(cache=True, inline='always')
def _periodic_breaks(breaks, first, base, out):
    """The breakpoints ``first, first + 1, ...`` (``out.size`` of them) of a closed curve with
    the ``breaks``, counted on past the last one period later each time round, from the period
    of breakpoint ``base``."""
    m = breaks.size
    for i in range(out.size):
        period, index = divmod(first + i, m)
        out[i] = breaks[index] + (period - base // m)


@njit(cache=True)
def _rotate_wide(ext, tri, p, d, nb, row, values, first, big_w):
    """Rotate one row of a frame (``row[:nb]`` its band entries from ``first``, ``row[nb:nb +
    p]`` its wrap-around entries, ``values[:d]`` its right-hand side, reciprocal weight
    ``big_w``) into the frame's factor as :func:`._moves_rows.frame` keeps it: the band's
    columns in ``ext`` (``1 + 2p + d`` entries per column: the wrap-around entries as ``p``
    right-hand sides), then what is left of the row into the wrap triangle ``tri``. The rows
    that touch the wrap-around columns themselves (the frame's first and last ``p`` spans);
    returns what is left of the row."""
    wide = 1 + 2 * p + d
    width = 1 + p + d
    for col in range(first, min(first + p + 1, nb)):
        hc = row[col]
        o = col * wide
        cb, sb, big_w = givens(ext, o, hc, big_w)
        rotate_entries(ext, o + 1, row, col + 1, min(p, nb - 1 - col), hc, cb, sb)
        rotate_entries(ext, o + 1 + p, row, nb, p, hc, cb, sb)
        rotate_entries(ext, o + 1 + 2 * p, values, 0, d, hc, cb, sb)
        row[col] = 0.0
    for i in range(p):
        hc = row[nb + i]
        if hc == 0.0:  # a rotation by a zero entry changes nothing
            continue
        o = i * width
        cb, sb, big_w = givens(tri, o, hc, big_w)
        rotate_entries(tri, o + 1, row, nb + i + 1, p - 1 - i, hc, cb, sb)
        rotate_entries(tri, o + p + 1, values, 0, d, hc, cb, sb)
        row[nb + i] = 0.0
    left_over = 0.0
    for c in range(d):
        left_over += values[c] * values[c]
    return left_over / big_w


@njit(cache=True)
def _frame_sweep(u, q, t, basis, p, m, s, mirror, row_start, ext, tri, S, T, Ssse, Scol):
    """One sweep of the frame cut at breakpoint ``s`` of the incumbent with extended knots
    ``t``: forward (frame spans ``0 .. m - 1``, state ``K`` saved before span ``K``) or mirrored
    (spans ``m - 1 .. 0``, state ``K`` saved after span ``K``), for ``p <= K <= nb`` (the states
    a merge reads), as step ``i = K - p`` (mirrored ``i = nb - K``). ``S[i]`` holds the active
    band rows (forward band columns ``K - p ..``, mirrored ``nb - K ..``) in the layout of
    :func:`_rotate_wide`, ``T[i]`` the wrap triangle, ``Ssse[i]`` the residual so far and
    ``Scol[i]`` the active columns' sums. The rows of the spans that touch the wrap-around
    columns by :func:`_rotate_wide`, the others by the generated :func:`._moves_rows.frame` on
    the frame's own knots (mirrored for the mirrored sweep: the band columns mirrored, ``nb - 1
    - c``, the wrap columns in place). Leaves the final factor in ``ext`` (band columns) and
    ``tri`` (the wrap triangle)."""
    n, d = q.shape
    width = 1 + p + d
    wide = 1 + 2 * p + d
    nb = m - p
    empty_state(ext, nb, wide)
    empty_state(tri, p, width)
    colsum = np.zeros(nb)  # by (mirrored) band column
    row = np.zeros(m)
    values = np.empty(d)
    # the frame's rows and knots, one period later past the data's end; local row i is data
    # row (r0 + i) mod n, local knot k breakpoint s + k
    r0 = row_start[s]
    first_row = np.empty(m + 1, dtype=np.int64)
    for k in range(m):
        first_row[k] = row_start[s + k] - r0 if s + k < m else row_start[s + k - m] + n - r0
    first_row[m] = n
    u_f = np.empty(n)
    q_f = np.empty((n, d))
    _periodic_rows(u, q, r0, u_f, q_f)
    t_f = np.empty(m + 1)
    _periodic_breaks(t[p : p + m], s, s, t_f)
    if mirror:
        u_f = -u_f[::-1]
        q_f = q_f[::-1].copy()
        t_f = -t_f[::-1]
    iv = np.zeros(p * (m + 1))
    reciprocals(t_f, p, iv, 0, m + 1)
    steps = nb - p
    bounds = np.empty(steps + 1, dtype=np.int64)
    for i in range(steps + 1):  # the first local row of (mirrored) frame span p + i
        bounds[i] = first_row[p + i] if not mirror else n - first_row[m - p - i]
    blocks = np.arange(steps + 1)
    sse = 0.0
    for part in range(2):  # the spans before the band's, then those after it
        for step in range(p):
            k = step if part == 0 else nb + step
            if mirror:
                k = m - 1 - k
            r_lo, r_hi = first_row[k], first_row[k + 1]
            for i in range(r_hi - r_lo):
                r = r0 + (r_lo + i if not mirror else r_hi - 1 - i)
                if r >= n:
                    r -= n
                first = m
                for e in range(p + 1):
                    c = k - p + e
                    if c < 0:
                        c += m
                    if c < nb:
                        if mirror:
                            c = nb - 1 - c
                        colsum[c] += basis[r, e]
                        first = min(first, c)
                    row[c] += basis[r, e]
                for c in range(d):
                    values[c] = q[r, c]
                sse += _rotate_wide(ext, tri, p, d, nb, row, values, first, 1.0)
        if part == 0:
            sse = frame(p, d, u_f, q_f, t_f, iv, p, nb - 1, bounds, blocks, ext, tri, S, T,
                        Ssse, Scol, colsum, basis[:0], row_start[:0], sse)


@njit(cache=True)
def bind_closed(u, q, t, p, cuts):
    """Everything delta evaluation caches for the periodic incumbent with extended knot vector
    ``t`` (a feasible fit): spans and basis values of the rows, ``row_start`` (first row of each
    natural span), the column sums, and per frame (cut at breakpoint ``cuts[f]``) and side
    (forward, mirrored) the states, the final factors and the bounds of their band blocks'
    inverses."""
    n, d = q.shape
    width = 1 + p + d
    m = t.size - 2 * p - 1
    nb = m - p
    spans = np.empty(n, dtype=np.int64)
    basis = np.empty((n, p + 1))
    row_start = np.empty(m + 1, dtype=np.int64)
    column_sums = np.zeros(m)
    left = np.empty(p + 1)
    right = np.empty(p + 1)
    j = 0
    row_start[0] = 0
    for r in range(n):
        x = u[r]
        while j < m - 1 and x >= t[p + j + 1]:
            j += 1
            row_start[j] = r
        spans[r] = j
        basis_at(t, p + j, x, p, basis[r], left, right)
        for i in range(p + 1):
            column_sums[(j + i) % m] += basis[r, i]
    while j < m - 1:  # spans without rows (not in a feasible fit, but kept consistent)
        j += 1
        row_start[j] = n
    row_start[m] = n
    frames = cuts.size
    wide = 1 + 2 * p + d
    steps = max(nb - p + 1, 0)  # the states K = p .. nb of each sweep
    S = np.zeros((frames, 2, steps, p * wide))
    T = np.zeros((frames, 2, steps, p * width))
    Ssse = np.zeros((frames, 2, steps))
    Scol = np.zeros((frames, 2, steps, p))
    final_ext = np.zeros((frames, 2, nb * wide))
    tri = np.empty(p * width)  # a sweep's final wrap triangle: no merge reads it
    inverse = np.zeros((frames, 2))
    v = np.empty(m)
    w = np.empty(m)
    for f in range(frames):
        for side in range(2):
            _frame_sweep(u, q, t, basis, p, m, cuts[f], side == 1, row_start, final_ext[f, side],
                         tri, S[f, side], T[f, side], Ssse[f, side], Scol[f, side])
            inverse[f, side] = inverse_norm_bound(final_ext[f, side], wide, p, nb, v, w,
                                                  NO_TRIANGLE)
    return (spans, basis, row_start, column_sums, S, T, Ssse, Scol, final_ext, inverse)


@njit(cache=True)
def evaluate_closed_moves(u, q, p, interior, spans, basis, row_start, cuts, S, T, Ssse, Scol,
                          final_ext, inverse, gram_norm, base_sse,
                          base_max_dev, max_mult, knots, offsets, starts, stops,
                          max_window_rows, want_max_dev, sse_out, max_dev_out, n_ctrl_out,
                          reason_out, path_out):
    """:func:`evaluate_moves` of a periodic incumbent: candidates merged from a frame's cached
    states; the full fit decides where no frame holds the change, the change spans more than
    ``max_window_rows`` rows, or the certificate fails."""
    n, d = q.shape
    width = 1 + p + d
    m = interior.size + 1
    nb = m - p
    n_cand = offsets.size - 1
    check_offsets(offsets, knots.size)
    m_max = n + 1
    # a candidate's breakpoints are gathered before its count is checked against the data:
    # room for the largest (the incumbent's and all its inserted knots at most)
    widest = 0
    for b in range(n_cand):
        widest = max(widest, offsets[b + 1] - offsets[b])
    breaks = np.empty(max(m_max, m + widest))
    coef = np.zeros((m_max, d))
    wide = 1 + 2 * p + d
    cols_max = m_max + 2 * p
    stm = np.empty(cols_max * wide)  # the merged factor: its band, then its wrap triangle
    trim = np.empty(p * width)
    mcol = np.zeros(cols_max)
    row = np.zeros(cols_max)
    values = np.empty(d)
    v = np.empty(cols_max)
    w = np.empty(cols_max)
    # the window's rows go in as one step of the frame loop (its saved states unused)
    bounds_w = np.zeros(2, dtype=np.int64)
    blocks_w = np.zeros(2, dtype=np.int64)
    S_w, T_w, Ssse_w, Scol_w = (np.empty((2, p * wide)), np.empty((2, p * width)),
                                np.empty(2), np.empty((2, p)))
    full = _score_workspaces(n, d, p, m_max, want_max_dev)  # the full fits'
    window_basis = np.empty((n if want_max_dev else 0, p + 1))  # the window's rows
    window_span = np.empty(n if want_max_dev else 0, dtype=np.int64)
    u_window = np.empty(n)
    q_window = np.empty((n, d))
    t_window = np.empty(m_max + 2 * p + 1)
    iv_window = np.empty(p * (m_max + 2 * p + 1))
    replacing = starts.size > 0
    for b in range(n_cand):
        lo, hi = offsets[b], offsets[b + 1]
        if replacing:
            start, stop, ins_lo, ins_hi = starts[b], stops[b], lo, hi
        else:
            start, stop, ins_lo, ins_hi = _changed_block(interior, knots, lo, hi)
        inserted = knots[ins_lo:ins_hi]
        m2 = m - (stop - start) + inserted.size
        delta = m2 - m
        n_ctrl_out[b] = m2
        sse_out[b] = np.inf
        if want_max_dev:
            max_dev_out[b] = np.inf
        path_out[b] = PATH_CHECKS
        br = breaks[:m2]  # breakpoint 0, then the candidate's interior knots
        br[0] = 0.0
        code = _replaced(interior, 0, 0, start, stop, inserted, br[1:], 0.0, 1.0, max_mult)
        local = code == FEASIBLE
        if code == UNSORTED:  # sorted, as the batch evaluator sorts them: fitted in full
            br[1:] = np.sort(br[1:])
            code = _runs_verdict(br, 2, br.size, max_mult, FEASIBLE)
        if code == FEASIBLE and m2 < p:
            code = SINGULAR
        if code == FEASIBLE and m2 > n:
            code = TOO_MANY_CONTROL_POINTS
        if code != FEASIBLE:
            reason_out[b] = code
            continue
        if local and start == stop and inserted.size == 0:  # the incumbent itself
            reason_out[b] = FEASIBLE
            sse_out[b] = base_sse
            path_out[b] = PATH_DELTA
            if want_max_dev:
                max_dev_out[b] = base_max_dev
            continue
        # the frame that holds the change: breakpoints start (natural) and stop + 1 are the
        # last and first unchanged ones; rows of frame spans < KL and >= KR keep their basis
        held = -1
        KL = KR = s2 = 0
        for f in range(cuts.size if local else 0):
            s = cuts[f]
            A = start - s
            if A < 0:
                A += m
            B = A + (stop - start) + 1
            KL = A - p + 1
            KR = B + p - 1
            if KL >= p and KR <= nb:
                held = f
                s2 = s if s <= start else s + delta
                break
        rows_lo = row_start[(cuts[held] + KL) % m] if held >= 0 else 0
        rows_hi = row_start[(cuts[held] + KR) % m] if held >= 0 else 0
        window_rows = rows_hi - rows_lo
        if window_rows < 0:
            window_rows += n
        if held >= 0 and window_rows <= max_window_rows:
            KR2 = KR + delta
            nbm = KR2 - KL + p  # merged band columns: band columns KL - p .. KR2 - 1
            iL, iR = KL - p, nb - KR  # the states' steps (forward, mirrored)
            # the forward state's active rows are the merged band's first p columns and its
            # wrap triangle the merged one: the sweep goes on from there, over the rows between
            # the unchanged spans under the candidate's knots, by the generated row loop on the
            # window's own knots (local span p is frame span KL; the rows past the data's end
            # are taken one period later)
            stm[: p * wide] = S[held, 0, iL]
            empty_state(stm[p * wide :], nbm - p, wide)
            trim[:] = T[held, 0, iL]
            mcol[:p] = Scol[held, 0, iL]
            mcol[p:nbm] = 0.0
            spans_w = KR2 - KL
            tw = t_window[: spans_w + 2 * p + 1]
            _periodic_breaks(br, s2 + KL - p, s2 + KL, tw)
            iv_w = iv_window[: p * tw.size]
            reciprocals(tw, p, iv_w, 0, tw.size)
            _periodic_rows(u, q, rows_lo, u_window[:window_rows], q_window[:window_rows])
            bounds_w[1] = window_rows
            res = frame(p, d, u_window, q_window, tw, iv_w, p, p + spans_w - 1, bounds_w,
                        blocks_w, stm, trim, S_w, T_w, Ssse_w, Scol_w, mcol, window_basis,
                        window_span, 0.0)
            # the backward state's active rows: mirrored band column nb - KR + a is band
            # column KR - 1 - a, merged column P; its entries lie leftwards, within the last
            # p columns (the active ones)
            for a in range(p):
                o = a * wide
                big_w = S[held, 1, iR, o]
                mcol[nbm - 1 - a] += Scol[held, 1, iR, a]
                if big_w >= UNREACHED:
                    continue
                P = nbm - 1 - a
                row[P] = 1.0
                for k in range(1, p - a):
                    row[P - k] = S[held, 1, iR, o + k]
                for k in range(p):
                    row[nbm + k] = S[held, 1, iR, o + 1 + p + k]
                for c in range(d):
                    values[c] = S[held, 1, iR, o + 1 + 2 * p + c]
                res += _rotate_wide(stm, trim, p, d, nbm, row, values, nbm - p, big_w)
            # and its wrap triangle's rows
            for a in range(p):
                o = a * width
                big_w = T[held, 1, iR, o]
                if big_w >= UNREACHED:
                    continue
                row[nbm + a] = 1.0
                for k in range(1, p - a):
                    row[nbm + a + k] = T[held, 1, iR, o + k]
                for c in range(d):
                    values[c] = T[held, 1, iR, o + p + 1 + c]
                res += _rotate_wide(stm, trim, p, d, nbm, row, values, nbm, big_w)
            # the certificate (see the notes above)
            inv_m = inverse_norm_bound(stm, wide, p, nbm, v, w, trim)
            inv_s = inv_m + (inverse[held, 0] + inverse[held, 1]) * (1.0 + gram_norm * inv_m)
            largest_sum = gram_norm * gram_norm
            for i in range(nbm):
                largest_sum = max(largest_sum, mcol[i])
            if inv_s * math.sqrt(largest_sum) * PIVOT_RATIO <= CERTIFY:
                reason_out[b] = FEASIBLE
                sse_out[b] = Ssse[held, 0, iL] + Ssse[held, 1, iR] + res
                path_out[b] = PATH_DELTA
                if want_max_dev:
                    _merged_coefficients(stm, trim, nbm, final_ext[held, 0],
                                         final_ext[held, 1], nb, p, d, p, KL, KR, delta,
                                         coef[:m2])
                    max_dev_out[b] = _closed_max_deviation(
                        q, p, spans, basis, window_basis, window_span, cuts[held], m, m2, KL,
                        KR, rows_lo, window_rows, coef)
                continue
        # the full fit decides, as the batched evaluator scores it
        path_out[b] = PATH_FULL
        _score(u, q, p, True, br[1:], b, full, sse_out, max_dev_out, n_ctrl_out, reason_out,
               max_mult)


@njit(cache=True)
def _closed_max_deviation(q, p, spans, basis, window_basis, window_span, s, m, m2, KL, KR,
                          rows_lo, window_rows, coef):
    """Largest distance of a data point to a merged periodic candidate with the coefficients
    ``coef`` (counted from the candidate's cut): every row's value from its basis (the window's
    for rows in the window, by their place in it, the incumbent's elsewhere)."""
    n = q.shape[0]
    delta = m2 - m
    worst = 0.0
    for r in range(n):
        in_window = r - rows_lo
        if in_window < 0:
            in_window += n
        if in_window < window_rows:
            k = KL + window_span[in_window] - p  # the window's local span p is frame span KL
            h = window_basis[in_window]
        else:
            k = spans[r] - s
            if k < 0:
                k += m
            if k >= KR:
                k += delta
            h = basis[r]
        worst = max(worst, periodic_distance2(q, r, h, k, coef, m2, p))
    return math.sqrt(worst)
