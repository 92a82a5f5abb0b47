"""Compiled delta evaluation of local knot moves (numba); see :mod:`metaknot.bspline.moves`.

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
    SCHOENBERG_WHITNEY,
    TOO_MANY_CONTROL_POINTS,
    _fit_into,
    _max_deviation,
)
from ._moves_rows import EMPTY, FASTMATH, absorb, sweep, window

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


@njit(cache=True, inline='always')
def check_offsets(offsets, size):
    """Raise unless ``offsets`` runs from 0 to ``size`` without decreasing."""
    n_cand = offsets.size - 1
    bad = offsets[0] != 0 or offsets[n_cand] != size
    for b in range(n_cand):
        bad |= offsets[b + 1] < offsets[b]
    if bad:
        raise ValueError("offsets must run from 0 to len(knots) without decreasing")


@njit(cache=True)
def reciprocals(t, p, iv, lo_start, lo_stop):
    """``iv[(j - 1) * t.size + lo] = 1 / (t[lo + j] - t[lo])`` (0 where not positive) for
    ``lo_start <= lo < lo_stop`` and ``j = 1..p``: the table of the generated basis loop."""
    size = t.size
    for j in range(1, p + 1):
        for lo in range(max(lo_start, 0), min(lo_stop, size - j)):
            gap = t[lo + j] - t[lo]
            iv[(j - 1) * size + lo] = 1.0 / gap if gap > 0.0 else 0.0


@njit(cache=True, inline='always', error_model='numpy', fastmath=FASTMATH)
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


@njit(cache=True, inline='always', error_model='numpy', fastmath=FASTMATH)
def empty_state(st, columns, width):
    """Mark ``columns`` columns of the flat factor ``st`` as reached by no row."""
    for c in range(columns):
        st[c * width] = EMPTY
        for k in range(1, width):
            st[c * width + k] = 0.0


@njit(cache=True, inline='always', error_model='numpy', fastmath=FASTMATH)
def inverse_norm_bound(st, p, d, size, v, wv):
    """Upper bound of the 2-norm of ``R^-1`` for the flat factor's first ``size`` columns
    (``R = diag(1 / sqrt(dinv)) rb``; ``inf`` if a column was reached by no row).

    ``|rb^-1| <= M^-1`` elementwise for the comparison matrix ``M`` of the unit triangular
    ``rb``, so its infinity and 1-norms are at most the largest entries of ``M^-1 e`` and
    ``M^-T e``; ``||A||_2 <= sqrt(||A||_1 ||A||_inf)``, and the diagonal scaling adds at most
    ``max sqrt(dinv)``. ``v`` and ``wv`` are workspaces of at least ``size`` entries.
    """
    w = 1 + p + d
    v_max = 0.0
    w_max = 0.0
    d_max = 0.0
    for i in range(size - 1, -1, -1):  # v = M^-1 e
        di = st[i * w]
        if di >= UNREACHED:
            return np.inf
        d_max = max(d_max, di)
        acc = 1.0
        for a in range(min(p, size - 1 - i), 0, -1):
            acc += abs(st[i * w + a]) * v[i + a]
        v[i] = acc
        v_max = max(v_max, acc)
    for j in range(size):  # w = M^-T e
        acc = 1.0
        for a in range(min(p, j), 0, -1):
            acc += abs(st[(j - a) * w + a]) * wv[j - a]
        wv[j] = acc
        w_max = max(w_max, acc)
    return math.sqrt(v_max * w_max * d_max)


@njit(cache=True)
def _merged_coefficients(stl, size, st_f, st_m, n, p, d, c_left, c_right, delta, coef):
    """Control points of a merged candidate (columns counted in the candidate): the merged
    block ``stl`` (columns ``c_left - p ..``) first, then the incumbent's final forward rows
    leftwards and its final mirrored rows rightwards (unit triangular, square-root-free)."""
    w = 1 + p + d
    base = c_left - p
    for i in range(size - 1, -1, -1):
        o = i * w
        for k in range(d):
            acc = stl[o + p + 1 + k]
            for a in range(min(p, size - 1 - i), 0, -1):
                acc -= stl[o + a] * coef[base + i + a, k]
            coef[base + i, k] = acc
    for col in range(base - 1, -1, -1):
        o = col * w
        for k in range(d):
            acc = st_f[o + p + 1 + k]
            for a in range(p, 0, -1):
                acc -= st_f[o + a] * coef[col + a, k]
            coef[col, k] = acc
    for oc in range(c_right, n):  # incumbent's column oc: the mirror's n - 1 - oc
        o = (n - 1 - oc) * w
        for k in range(d):
            acc = st_m[o + p + 1 + k]
            for a in range(min(p, oc), 0, -1):
                acc -= st_m[o + a] * coef[oc - a + delta, k]
            coef[oc + delta, k] = acc


@njit(cache=True)
def sw_matching(u, t, p, n, match):
    """A greedy Schoenberg-Whitney matching (the check the full kernel makes): ``match[i]`` is
    the data row given to basis function ``i`` (the first free row inside its support).
    Returns False (and stops) where a function finds none."""
    m = u.size
    j = 0
    for i in range(n):
        lo = t[i]
        hi = t[i + p + 1]
        while j < m and not (u[j] > lo or (i == 0 and u[j] >= lo)):
            j += 1
        if j == m:
            return False
        if not (u[j] < hi or (i == n - 1 and u[j] <= hi)):
            return False
        match[i] = j
        j += 1
    return True


@njit(cache=True, inline='always', error_model='numpy', fastmath=FASTMATH)
def sw_local(u, t2, p, n2, match, first, tail, shift):
    """The Schoenberg-Whitney check of ``t2`` given the incumbent's matching ``match``.

    Functions below ``first`` have the incumbent's supports, so the greedy matching agrees
    there; it is resumed at ``first``. Functions from ``tail`` on have the supports of the
    incumbent's functions ``i - shift``: once the resumed matching gives one of them a row no
    later than the incumbent's, every later function is matched too (the greedy choice is
    monotone in the row it starts from), and the check stops early.
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
        j += 1
    return True


@njit(cache=True, inline='always', error_model='numpy', fastmath=FASTMATH)
def _candidate_knots(u, t, interior, p, t2):
    """Fill ``t2`` with the candidate's clamped knot vector; return (reason, e, f): ``e`` the
    first index where it differs from the incumbent's ``t``, ``f`` the length of their common
    tail. Only the changed knots are checked (the others are the incumbent's): the reason is
    the full kernel's ``_build_knots`` verdict."""
    k = interior.size
    n1 = t.size
    n2 = k + 2 * p + 2
    u0 = u[0]
    um = u[u.size - 1]
    for i in range(p + 1):
        t2[i] = u0
        t2[n2 - 1 - i] = um
    for i in range(k):
        t2[p + 1 + i] = interior[i]
    # the common head and tail, compared eight entries at a time (the compiler vectorises a
    # block without an early exit), then one at a time
    limit = min(n1, n2)
    e = 0
    while e + 8 <= limit:
        differs = False
        for i in range(8):
            differs |= t[e + i] != t2[e + i]
        if differs:
            break
        e += 8
    while e < limit and t[e] == t2[e]:
        e += 1
    f = 0
    while f + 8 <= limit - e:
        differs = False
        for i in range(8):
            differs |= t[n1 - 1 - f - i] != t2[n2 - 1 - f - i]
        if differs:
            break
        f += 8
    while f < limit - e and t[n1 - 1 - f] == t2[n2 - 1 - f]:
        f += 1
    stop = n2 - f  # t2[e:stop] are the changed knots, all interior
    for i in range(e, stop):
        x = t2[i]
        if not (x > u0 and x < um):  # also catches NaN
            return KNOT_OUT_OF_RANGE, e, f
    for i in range(max(e, p + 2), min(stop + 1, n2 - p - 1)):
        if t2[i] <= t2[i - 1]:
            return COINCIDENT_KNOTS, e, f
    return FEASIBLE, e, f


@njit(cache=True, inline='always', error_model='numpy', fastmath=FASTMATH)
def _replacement_knots(u, t, n, start, stop, inserted, p, t2):
    """Fill ``t2`` with the knots of the incumbent ``t`` whose interior knots ``start:stop``
    are replaced by ``inserted``; return (reason, e, f) as :func:`_candidate_knots` does, with
    only the inserted knots checked."""
    k = n - p - 1
    size = t2.size
    for i in range(p + 1 + start):  # the head, the inserted knots, the tail
        t2[i] = t[i]
    for i in range(inserted.size):
        t2[p + 1 + start + i] = inserted[i]
    tail = p + 1 + start + inserted.size
    shift = size - t.size
    for i in range(tail, size):
        t2[i] = t[i - shift]
    e = p + 1 + start
    f = size - tail
    u0 = u[0]
    um = u[u.size - 1]
    for i in range(inserted.size):
        x = inserted[i]
        if not (x > u0 and x < um):  # also catches NaN
            return KNOT_OUT_OF_RANGE, e, f
    if stop > k or start > stop:
        return KNOT_OUT_OF_RANGE, e, f
    for i in range(max(e, p + 2), min(tail + 1, size - p - 1)):
        if t2[i] <= t2[i - 1]:
            return COINCIDENT_KNOTS, e, f
    return FEASIBLE, e, f


@njit(cache=True, error_model='numpy', fastmath=FASTMATH)
def evaluate_moves(u, q, p, t, iv_t, n, spans, basis, row_start, match, F, Fsse, Fcol, G, Gsse,
                   Gcol, st_f, st_m, col_before, col_from, base_sse, inverse_left, inverse_right,
                   gram_norm, knots, offsets, starts, stops, max_window_rows, want_max_dev,
                   sse_out, max_dev_out, n_ctrl_out, reason_out, path_out):
    """Score candidates (interior knots ``knots[offsets[b]:offsets[b + 1]]``) by merging the
    incumbent's cached states; fall back to the full fit where the cheap path cannot decide.
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
    basis_ws = np.empty((m if want_max_dev else 0, p + 1))
    spans_ws = np.empty(m if want_max_dev else 0, dtype=np.int64)
    rows_max = n_max + p
    stl = np.empty(rows_max * w)
    colsum = np.empty(rows_max)
    bound_v = np.empty(rows_max)
    bound_w = np.empty(rows_max)
    window_basis = np.empty((m if want_max_dev else 0, p + 1))
    window_span = np.empty(m if want_max_dev else 0, dtype=np.int64)
    replacing = starts.size > 0
    for b in range(n_cand):
        inserted = knots[offsets[b]:offsets[b + 1]]
        if replacing:
            n2 = n - (stops[b] - starts[b]) + inserted.size
        else:
            n2 = inserted.size + p + 1
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
            code, e, f = _replacement_knots(u, t, n, starts[b], stops[b], inserted, p, tb)
        else:
            code, e, f = _candidate_knots(u, t, inserted, p, tb)
        interior = tb[p + 1 : n2]
        if code != FEASIBLE:
            reason_out[b] = code
            continue
        delta = n2 - n
        # functions below e - p - 1 keep their supports, those from t.size - f + delta on
        # (counted in t2) keep the supports of the incumbent's functions shifted by delta
        if not sw_local(u, tb, p, n2, match, max(e - p - 1, 0), t.size - f + delta, delta):
            reason_out[b] = SCHOENBERG_WHITNEY
            continue
        c_left = max(e - p, p)
        c_right = min(t.size - f + p - 1, n)
        if e == t.size and n2 == n:  # the incumbent itself
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
            inv_m = inverse_norm_bound(stl, p, d, size, bound_v, bound_w)
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
                    _merged_coefficients(stl, size, st_f, st_m, n, p, d, c_left, c_right,
                                         delta, c)
                    worst = 0.0
                    for j in range(m):
                        if j < row_start[c_left] or j >= row_start[c_right]:
                            first = spans[j] - p + (0 if j < row_start[c_left] else delta)
                            hj = basis[j]
                        else:
                            first = window_span[j] - p
                            hj = window_basis[j]
                        dist2 = 0.0
                        for k in range(d):
                            acc = 0.0
                            for i in range(p + 1):
                                acc += hj[i] * c[first + i, k]
                            diff = q[j, k] - acc
                            dist2 += diff * diff
                        worst = max(worst, dist2)
                    max_dev_out[b] = math.sqrt(worst)
                continue
        # the full fit decides
        path_out[b] = PATH_FULL
        code, value = _fit_into(u, q, interior, p, tb, coef[:n2], basis_ws, spans_ws, 1)
        reason_out[b] = code
        sse_out[b] = value
        if want_max_dev and code == FEASIBLE:
            max_dev_out[b] = _max_deviation(q, p, coef[:n2], basis_ws, spans_ws)


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
    sw_matching(u, t, p, n, match)
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
    sweep(p, d, u, q, t, iv, n - 1, row_start[p:], blocks, st_f, F[p:], Fsse[p:], Fcol[p:],
          column_sums, basis, spans)
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
    sweep(p, d, u_mirror, q_mirror, t_mirror, iv_mirror, n - 1, bounds, blocks, st_m, states,
          sse, mirror_col, np.zeros(n), np.empty((m, p + 1)), np.empty(m, dtype=np.int64))
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
    inverse_left = inverse_norm_bound(st_f, p, d, n, work_v, work_w)
    inverse_right = inverse_norm_bound(st_m, p, d, n, work_v, work_w)
    return (spans, basis, row_start, match, iv, F, Fsse, Fcol, st_f, G, Gsse, Gcol, st_m,
            inverse_left, inverse_right, column_sums)


@njit(cache=True)
def mask_replacements(u, near, masks):
    """Each row of ``masks`` (0/1 over the interior points ``u[1:-1]``) as a replacement of the
    knots of the mask ``near``: the incumbent's knots between its first and last differing bit
    by the row's knots there. Returns ``(starts, stops, inserted, offsets)``."""
    n_cand, n_var = masks.shape
    rank = np.zeros(n_var + 1, dtype=np.int64)  # knots of near before each bit
    for i in range(n_var):
        rank[i + 1] = rank[i] + (near[i] != 0)
    starts = np.zeros(n_cand, dtype=np.int64)
    stops = np.zeros(n_cand, dtype=np.int64)
    lo = np.zeros(n_cand, dtype=np.int64)
    hi = np.zeros(n_cand, dtype=np.int64)
    offsets = np.zeros(n_cand + 1, dtype=np.int64)
    for b in range(n_cand):
        first = 0
        while first < n_var and (masks[b, first] != 0) == (near[first] != 0):
            first += 1
        last = n_var - 1
        while last > first and (masks[b, last] != 0) == (near[last] != 0):
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
            count += masks[b, i] != 0
        offsets[b + 1] = offsets[b] + count
    inserted = np.empty(offsets[n_cand])
    for b in range(n_cand):
        pos = offsets[b]
        for i in range(lo[b], hi[b]):
            if masks[b, i] != 0:
                inserted[pos] = u[i + 1]
                pos += 1
    return starts, stops, inserted, offsets
